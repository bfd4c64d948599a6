"""The identification log: a CSV file of time, actuated positions and torques (optional velocities).

Format (docs/identification.md)::

    # delta-pin identification log
    # robot: delta
    # sample_rate_hz: 1000
    t,q[active_1],q[active_2],q[active_3],tau[active_1],tau[active_2],tau[active_3]
    0.000,0.2492,0.2492,0.2492,0.71,0.71,0.71
    ...

* comment lines start with ``#``; ``key: value`` comments are the header. ``sample_rate_hz``
  [Hz] is optional; where given, the time column must match it (median step within 1 %);
* one column ``t`` [s], strictly increasing, uniformly sampled (each step within 1 % of the median);
* per actuated joint J (the robot's names, :attr:`ClosedChainRobot.actuated_joints`): ``q[J]``
  [rad or m] and ``tau[J]`` [N m or N], and optionally ``qd[J]`` [rad/s or m/s];
* every value finite; no column the reader uses named twice; no ``tau[X]`` column of a joint X the
  robot does not actuate (a motor the model would leave out); each ``tau[J]`` column not constant
  (all zeros, say: such a log carries no information on the dynamics).

Any other column is ignored. A bad log raises :class:`~delta_pin.errors.InvalidParameterError`
with one line naming the file, the column and the line number.

**Whose log** (:func:`check_log_robot`, called by ``identify`` and ``validate``): where the header
has a ``robot`` key (``identify simulate`` writes it, with ``kinematics_sha256``: the digest of the
robot's kinematic description, :func:`kinematics_digest`), it must name the robot being fitted, and
a ``kinematics_sha256`` must be that robot's; a log without a ``robot`` key (a drive's, written by
anyone) is accepted.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from delta_pin.errors import InvalidParameterError
from delta_pin.utils.atomic import atomic_open

__all__ = [
    "IdentificationLog",
    "check_log_robot",
    "check_torques",
    "count_samples",
    "kinematics_digest",
    "read_log",
    "write_log",
]

RATE_TOLERANCE = 0.01  # relative: a step or the header's rate may differ this much from the median step


@dataclass
class IdentificationLog:
    """Measured samples of one run.

    Attributes:
        t: times (N,) [s].
        alpha: actuated positions (N, dof) [rad or m].
        tau: actuated torques (N, dof) [N m or N].
        joints: the actuated joints' names (dof,).
        alpha_dot: measured velocities (N, dof), or ``None``.
        header: the ``key: value`` comments.
        path: the file it was read from (:func:`read_log`), or ``None``; named in errors.
    """

    t: np.ndarray
    alpha: np.ndarray
    tau: np.ndarray
    joints: tuple[str, ...]
    alpha_dot: np.ndarray | None = None
    header: dict = field(default_factory=dict)
    path: Path | None = None

    @property
    def where(self) -> str:
        """``log PATH`` (or ``the log``) for messages."""
        return "the log" if self.path is None else f"log {self.path}"

    @property
    def sample_rate(self) -> float:
        """1 / the median step [Hz]."""
        return 1.0 / float(np.median(np.diff(self.t)))

    def __len__(self) -> int:
        return len(self.t)


def write_log(path: str | Path, log: IdentificationLog) -> Path:
    """Write ``log`` as the module's CSV (atomically); returns the path."""
    columns = ["t", *(f"q[{j}]" for j in log.joints), *(f"tau[{j}]" for j in log.joints)]
    blocks = [log.t[:, None], log.alpha, log.tau]
    if log.alpha_dot is not None:
        columns += [f"qd[{j}]" for j in log.joints]
        blocks.append(log.alpha_dot)
    data = np.hstack(blocks)
    header = {"sample_rate_hz": f"{log.sample_rate:.12g}", **log.header}
    with atomic_open(path, "w", newline="") as handle:
        handle.write("# delta-pin identification log\n")
        for key, value in header.items():
            handle.write(f"# {key}: {value}\n")
        handle.write(",".join(columns) + "\n")
        np.savetxt(handle, data, delimiter=",", fmt="%.17g")
    return Path(path)


def count_samples(path: str | Path, stop: int | None = None) -> tuple[int, bool]:
    """(the number of sample lines of a log, whether counted to the end) without reading the file
    into memory: its lines less the ``#`` lines and the column line that open it (blank lines and
    later comments are counted too: an upper bound by a few). With ``stop``, the count ends past
    ``stop`` lines and the rest is estimated from the file's size (``False``), so that a huge file
    is not read through to be refused."""
    size = Path(path).stat().st_size
    header, lines, read, last = 0, 0, 0, b"\n"
    with open(path, "rb") as handle:
        for line in iter(lambda: handle.readline(1 << 16), b""):
            if not line.startswith(b"#"):
                break
            header += 1
        handle.seek(0)
        while chunk := handle.read(1 << 20):
            lines += chunk.count(b"\n")
            read += len(chunk)
            last = chunk[-1:]
            if stop is not None and lines - header - 1 > stop and read < size:
                return int((lines - header - 1) * size / read), False
    lines += last != b"\n"  # a last line without its newline
    return max(lines - header - 1, 0), True


def read_log(path: str | Path, joints: tuple[str, ...] | list[str]) -> IdentificationLog:
    """Read and check a log (module docstring) for a robot's actuated ``joints``.

    Raises:
        InvalidParameterError: a missing file or column, a non-number or non-finite value, time
            not strictly increasing or not uniform, a sample rate that differs from the header's,
            fewer than 10 samples; one line naming the column and the line.
    """
    path = Path(path)
    if not path.is_file():
        raise InvalidParameterError(f"log {path}: no such file")
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError:
        raise InvalidParameterError(
            f"log {path} is not a text file (a CSV log: docs/identification.md)"
        ) from None
    header: dict[str, str] = {}
    first = None
    for number, line in enumerate(lines, 1):
        text = line.strip()
        if not text:
            continue
        if text.startswith("#"):
            if ":" in text:
                key, value = text[1:].split(":", 1)
                header[key.strip()] = value.strip()
            continue
        first = number
        break
    if first is None:
        raise InvalidParameterError(f"log {path}: no column header line (t,q[...],tau[...])")
    names = [c.strip() for c in lines[first - 1].split(",")]
    index = {name: k for k, name in enumerate(names)}
    wanted = ["t", *(f"q[{j}]" for j in joints), *(f"tau[{j}]" for j in joints)]
    missing = [name for name in wanted if name not in index]
    if missing:
        raise InvalidParameterError(
            f"log {path}: column {missing[0]!r} is missing (line {first} has {', '.join(names)}; "
            f"expected t, q[J] and tau[J] for J in {', '.join(joints)})"
        )
    velocity_names = [f"qd[{j}]" for j in joints]
    for name in wanted + velocity_names:
        positions = [k + 1 for k, other in enumerate(names) if other == name]
        if len(positions) > 1:
            raise InvalidParameterError(
                f"log {path}: column {name!r} is named twice on line {first}, as columns {positions[0]} "
                f"and {positions[1]}: which one is the joint's is not known; remove or rename one"
            )
    others = [n for n in names if n.startswith("tau[") and n.endswith("]") and n[4:-1] not in joints]
    if others:
        raise InvalidParameterError(
            f"log {path}: column {others[0]!r} is the torque of joint {others[0][4:-1]!r}, which the robot "
            f"does not actuate (its actuated joints: {', '.join(joints)}): the log is another robot's, or "
            "that motor is missing from the robot's actuated joints (--actuated); drop the column if "
            "that joint is no part of this robot"
        )
    rows, numbers = [], []
    for number, line in enumerate(lines[first:], first + 1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        cells = text.split(",")
        if len(cells) != len(names):
            raise InvalidParameterError(
                f"log {path}: line {number} has {len(cells)} values, the header {len(names)}"
            )
        try:
            rows.append([float(c) for c in cells])
        except ValueError:
            bad = next(k for k, c in enumerate(cells) if not _is_float(c))
            raise InvalidParameterError(
                f"log {path}: line {number}, column {names[bad]!r}: {cells[bad].strip()!r} is not a number"
            ) from None
        numbers.append(number)
    data = np.array(rows, dtype=float).reshape(len(rows), len(names))
    numbers = np.array(numbers)
    if len(data) < 10:
        raise InvalidParameterError(f"log {path}: {len(data)} samples; an identification needs many more")
    used = wanted + [n for n in velocity_names if n in index]
    for name in used:
        column = data[:, index[name]]
        bad = np.flatnonzero(~np.isfinite(column))
        if bad.size:
            raise InvalidParameterError(
                f"log {path}: line {numbers[bad[0]]}, column {name!r} is {float(column[bad[0]])} (not finite)"
            )
    t = data[:, index["t"]]
    step = np.diff(t)
    bad = np.flatnonzero(step <= 0.0)
    if bad.size:
        k = bad[0]
        raise InvalidParameterError(
            f"log {path}: time is not increasing at line {numbers[k + 1]} "
            f"(t = {t[k + 1]!r} s after {t[k]!r} s on line {numbers[k]})"
        )
    median = float(np.median(step))
    bad = np.flatnonzero(np.abs(step - median) > RATE_TOLERANCE * median)
    if bad.size:
        k = bad[0]
        raise InvalidParameterError(
            f"log {path}: time step {step[k]:.6g} s at line {numbers[k + 1]} differs from the median "
            f"{median:.6g} s by more than {RATE_TOLERANCE:.0%} (a gap or jitter: the log must be "
            "uniformly sampled)"
        )
    if "sample_rate_hz" in header:
        try:
            declared = float(header["sample_rate_hz"])
        except ValueError:
            raise InvalidParameterError(
                f"log {path}: header sample_rate_hz {header['sample_rate_hz']!r} is not a number"
            ) from None
        measured = 1.0 / median
        if not (declared > 0.0 and abs(measured - declared) <= RATE_TOLERANCE * declared):
            raise InvalidParameterError(
                f"log {path}: the header says sample_rate_hz: {declared:g} but column 't' is sampled at "
                f"{measured:.6g} Hz"
            )
    has_velocity = all(n in index for n in velocity_names)
    log = IdentificationLog(
        t=t,
        alpha=data[:, [index[f"q[{j}]"] for j in joints]],
        tau=data[:, [index[f"tau[{j}]"] for j in joints]],
        joints=tuple(joints),
        alpha_dot=data[:, [index[n] for n in velocity_names]] if has_velocity else None,
        header=header,
        path=path,
    )
    check_torques(log)
    return log


def check_torques(log: IdentificationLog) -> None:
    """Refuse a log with a constant torque column (all zeros, say: a drive that logged nothing, or
    the wrong column): a fit to it would report a residual of 0/0 = NaN, or fit that joint's
    parameters to a constant. Constant: its spread max - min is at most 1e-12 of its largest
    magnitude (0 for a column read from a file)."""
    for j, joint in enumerate(log.joints):
        column = np.asarray(log.tau[:, j], float)
        spread = float(column.max() - column.min()) if column.size else 0.0
        if spread <= 1e-12 * float(np.abs(column).max(initial=0.0)):
            value = float(column[0]) if column.size else 0.0
            raise InvalidParameterError(
                f"{log.where}: column 'tau[{joint}]' is {value:g} on every line: the torques carry no "
                "information on the dynamics; log the drives' measured torque (or current times the "
                "torque constant) while the robot runs the excitation"
            )


def _rounded(values) -> list[float]:
    """Numbers for a digest: to 1e-9 (a nanometre, a nanoradian), -0 as 0."""
    return [float(x) + 0.0 for x in np.round(np.asarray(values, float).ravel(), 9)]


def kinematics_digest(robot) -> str:
    """The SHA-256 (hex, first 16 digits) of a closed-chain robot's kinematic description: its tree's
    joints (name, type, parent, placement), closures (kind, joints, placements), joint couplings
    and actuated joints, numbers to 1e-9. Inertias, friction and limits are left out: they are
    what a fit identifies, and a simulated log's true robot differs from the CAD file in them on
    purpose (``identify simulate --mass-spread``, ``--true-set m_a=...``). So is gravity: the
    site's, not the robot's (``load_delta`` takes the paper's 9.8, ``load_robot`` 9.81 m/s^2 for
    the same Delta's URDF)."""
    tree = robot.tree
    items: list = [["actuated", list(robot.actuated_joints)]]
    for j in range(1, tree.njoints):
        placement = tree.jointPlacements[j]
        items.append([tree.names[j], tree.joints[j].shortname(), int(tree.parents[j]),
                      _rounded(placement.translation), _rounded(placement.rotation)])  # fmt: skip
    for c in robot.closures:
        items.append([c.kind, tree.names[c.joint1], _rounded(c.placement1.homogeneous),
                      tree.names[c.joint2], _rounded(c.placement2.homogeneous)])  # fmt: skip
    for c in getattr(robot, "joint_couplings", ()):
        items.append([c.joint1, c.joint2, _rounded(c.coefficients), _rounded([c.reference1, c.reference2])])
    return hashlib.sha256(json.dumps(items).encode()).hexdigest()[:16]


def check_log_robot(log: IdentificationLog, robot) -> None:
    """Refuse another robot's log: the log's joints must be ``robot``'s actuated joints, and where
    its header has a ``robot`` key (``identify simulate`` writes it) it must be ``robot``'s name, and
    its ``kinematics_sha256`` (where present) ``robot``'s :func:`kinematics_digest`. A header
    without a ``robot`` key (a drive's log, written by anyone) is accepted."""
    where = log.where
    joints = tuple(robot.actuated_joints)
    if tuple(log.joints) != joints:
        raise InvalidParameterError(
            f"{where}: its joints {list(log.joints)} are not the actuated joints of robot {robot.name!r}, "
            f"{list(joints)}"
        )
    header = log.header or {}
    if "robot" not in header:
        return
    named = str(header["robot"])
    if named != robot.name:
        raise InvalidParameterError(
            f"{where} was written for robot {named!r} (its header's '# robot: {named}'), not for robot "
            f"{robot.name!r}, the one given: fit it with the robot that made it (--robot/--urdf/--set as "
            "for identify simulate), or remove that header line if the log is this robot's"
        )
    digest = header.get("kinematics_sha256")
    if digest is not None and str(digest) != kinematics_digest(robot):
        raise InvalidParameterError(
            f"{where} was written for a robot {named!r} of other kinematics (its header's kinematics_sha256: "
            f"{digest}, the robot given: {kinematics_digest(robot)}): another --urdf, --set (R, r, l_a, "
            "l_b) or --robot file than the one identify simulate had; give that one, or remove the "
            "header line if the log is this robot's"
        )


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True

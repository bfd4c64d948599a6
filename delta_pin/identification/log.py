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
* every value finite.

Any other column is ignored. A bad log raises :class:`~delta_pin.errors.InvalidParameterError`
with one line naming the file, the column and the line number.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from delta_pin.errors import InvalidParameterError
from delta_pin.utils.atomic import atomic_open

__all__ = ["IdentificationLog", "read_log", "write_log"]

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
    """

    t: np.ndarray
    alpha: np.ndarray
    tau: np.ndarray
    joints: tuple[str, ...]
    alpha_dot: np.ndarray | None = None
    header: dict = field(default_factory=dict)

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
    velocity_names = [f"qd[{j}]" for j in joints]
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
    return IdentificationLog(
        t=t,
        alpha=data[:, [index[f"q[{j}]"] for j in joints]],
        tau=data[:, [index[f"tau[{j}]"] for j in joints]],
        joints=tuple(joints),
        alpha_dot=data[:, [index[n] for n in velocity_names]] if has_velocity else None,
        header=header,
    )


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True

"""A planned trajectory as a CSV a drive can play and delta-pin reads back as a reference.

Columns ``t, q[J], qd[J], qdd[J], tau[J], x, y, z`` (SI units; J the actuated joints' names) at a
fixed rate, after a header of ``#`` lines: ``# delta-pin planned trajectory``, the robot's name,
the rate, the duration and the limits. :func:`read_plan` gives a trajectory ``simulate`` takes:
between rows the joints follow the quintic Hermite polynomial of the two rows' (q, qd, qdd), so the
reference keeps the file's accelerations exactly at its rows.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from delta_pin.errors import InvalidParameterError
from delta_pin.model.trajectory import JointReference
from delta_pin.utils.atomic import atomic_open

__all__ = ["FIRST_LINE", "PlannedReference", "read_plan", "write_plan"]

FIRST_LINE = "# delta-pin planned trajectory"


def write_plan(
    path: str | Path, trajectory, robot, torque, rate: float = 1000.0, header: dict | None = None
) -> Path:
    """Write ``trajectory`` (a plan or a planned sequence, :mod:`delta_pin.planning.time_optimal`)
    of ``robot`` at ``rate`` [Hz], with ``torque(alpha, alpha_dot, alpha_ddot)`` -> (N, dof) [N m] the
    torque it needs, atomically; ``header``: more ``# key: value`` lines (JSON values)."""
    t = np.append(np.arange(0.0, trajectory.duration, 1.0 / rate), trajectory.duration)
    reference = trajectory.joint_reference(robot, t)
    alpha, alpha_dot, alpha_ddot = (
        np.array(getattr(reference, n)) for n in ("alpha", "alpha_dot", "alpha_ddot")
    )
    tau = torque(alpha, alpha_dot, alpha_ddot)
    joints = robot.actuated_joints
    columns = ["t", *(f"{kind}[{j}]" for kind in ("q", "qd", "qdd", "tau") for j in joints), "x", "y", "z"]
    with atomic_open(path, "w", newline="") as handle:
        handle.write(f"{FIRST_LINE}\n# robot: {robot.name}\n# sample_rate_hz: {rate:g}\n")
        handle.write(f"# duration_s: {trajectory.duration!r}\n")
        for key, value in (header or {}).items():
            handle.write(f"# {key}: {json.dumps(value)}\n")
        handle.write(",".join(columns) + "\n")
        table = np.hstack([t[:, None], alpha, alpha_dot, alpha_ddot, tau, np.array(reference.xyz)])
        np.savetxt(handle, table, delimiter=",", fmt="%.17g")
    return Path(path)


class PlannedReference:
    """The joint trajectory of a plan file (:func:`read_plan`): ``joint_reference(robot, t)``
    for ``simulate``, the file's robot and joints, ``duration`` [s]; holds the last row after it."""

    def __init__(
        self, t: np.ndarray, alpha, alpha_dot, alpha_ddot, xyz, joints: list[str], robot: str, source: str
    ):
        self.t, self.alpha, self.alpha_dot, self.alpha_ddot, self.xyz = t, alpha, alpha_dot, alpha_ddot, xyz
        self.joints, self.robot, self.source = joints, robot, source
        self.duration = float(t[-1])
        self.name = f"planned trajectory {Path(source).name}"

    def joint_reference(self, robot, t) -> JointReference:
        if list(getattr(robot, "actuated_joints", self.joints)) != self.joints:
            raise InvalidParameterError(
                f"{self.source} moves joints {self.joints}, robot {robot.name!r} actuates "
                f"{list(robot.actuated_joints)}"
            )
        times = np.atleast_1d(np.asarray(t, dtype=float))
        u = np.clip(times, 0.0, self.duration)
        k = np.clip(np.searchsorted(self.t, u, side="right") - 1, 0, len(self.t) - 2)
        h = (self.t[k + 1] - self.t[k])[:, None]
        x = ((u - self.t[k])[:, None]) / h
        # the quintic Hermite basis (values, first and second derivatives at both rows)
        x2, x3, x4, x5 = x * x, x**3, x**4, x**5
        basis = (
            (1 - 10 * x3 + 15 * x4 - 6 * x5, x - 6 * x3 + 8 * x4 - 3 * x5, 0.5 * (x2 - 3 * x3 + 3 * x4 - x5),
             10 * x3 - 15 * x4 + 6 * x5, -4 * x3 + 7 * x4 - 3 * x5, 0.5 * (x3 - 2 * x4 + x5)),
            (-30 * x2 + 60 * x3 - 30 * x4, 1 - 18 * x2 + 32 * x3 - 15 * x4,
             0.5 * (2 * x - 9 * x2 + 12 * x3 - 5 * x4),
             30 * x2 - 60 * x3 + 30 * x4, -12 * x2 + 28 * x3 - 15 * x4, 0.5 * (3 * x2 - 8 * x3 + 5 * x4)),
            (-60 * x + 180 * x2 - 120 * x3, -36 * x + 96 * x2 - 60 * x3,
             0.5 * (2 - 18 * x + 36 * x2 - 20 * x3),
             60 * x - 180 * x2 + 120 * x3, -24 * x + 84 * x2 - 60 * x3, 0.5 * (6 * x - 24 * x2 + 20 * x3)),
        )  # fmt: skip
        ends = (self.alpha[k], h * self.alpha_dot[k], h * h * self.alpha_ddot[k],
                self.alpha[k + 1], h * self.alpha_dot[k + 1], h * h * self.alpha_ddot[k + 1])  # fmt: skip
        alpha, alpha_dot, alpha_ddot = (
            sum(b * e for b, e in zip(basis[order], ends, strict=True)) / h**order for order in range(3)
        )
        after = times >= self.duration
        alpha_dot[after], alpha_ddot[after] = 0.0, 0.0
        xyz = np.column_stack([np.interp(u, self.t, self.xyz[:, i]) for i in range(3)])
        zeros = np.zeros_like(xyz)
        return JointReference(times, xyz, zeros, zeros, alpha, alpha_dot, alpha_ddot)

    def metadata(self) -> dict[str, Any]:
        return {
            "type": "PlannedReference",
            "name": self.name,
            "source": self.source,
            "duration": self.duration,
        }


def read_plan(path: str | Path) -> PlannedReference:
    """The trajectory of a file :func:`write_plan` wrote (``delta-pin plan``).

    Raises:
        InvalidParameterError: no such file, not a planned trajectory (its first line), columns
            that are not ``t, q[..], qd[..], qdd[..], tau[..], x, y, z``, fewer than two rows, times
            that do not increase or a non-finite value; one line naming it.
    """
    path = Path(path)
    if not path.is_file():
        raise InvalidParameterError(f"plan {path}: no such file")
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError:
        raise InvalidParameterError(f"plan {path} is not a text file") from None
    if not lines or lines[0].strip() != FIRST_LINE:
        raise InvalidParameterError(
            f"{path} is not a planned trajectory: its first line is not {FIRST_LINE!r}"
        )
    header = {}
    body = next((i for i, line in enumerate(lines) if not line.startswith("#")), len(lines))
    if body >= len(lines):
        raise InvalidParameterError(f"{path}: a header without columns or rows")
    for line in lines[:body]:
        key, _, value = line[1:].partition(":")
        header[key.strip()] = value.strip()
    columns = lines[body].split(",")
    joints = [c[2:-1] for c in columns if c.startswith("q[") and c.endswith("]")]
    n = len(joints)
    expected = ["t", *(f"{kind}[{j}]" for kind in ("q", "qd", "qdd", "tau") for j in joints), "x", "y", "z"]
    if not n or columns != expected:
        raise InvalidParameterError(f"{path}: columns {columns} are not {expected if n else 't, q[..], ...'}")
    try:
        table = np.loadtxt(lines[body + 1 :], delimiter=",", ndmin=2)
    except ValueError as exc:
        raise InvalidParameterError(f"{path}: a row is not {len(columns)} numbers ({exc})") from None
    if table.shape[0] < 2 or table.shape[1] != len(columns):
        raise InvalidParameterError(
            f"{path}: {table.shape[0]} rows of {table.shape[1]} values; need >= 2 of {len(columns)}"
        )
    if not np.all(np.isfinite(table)):
        row = int(np.argwhere(~np.isfinite(table))[0, 0])
        raise InvalidParameterError(f"{path}: row {row + 1} holds a non-finite value")
    t = table[:, 0]
    if np.any(np.diff(t) <= 0.0) or t[0] != 0.0:
        raise InvalidParameterError(f"{path}: the times must start at 0 and increase")
    alpha, alpha_dot, alpha_ddot = (table[:, 1 + i * n : 1 + (i + 1) * n] for i in range(3))
    return PlannedReference(
        t, alpha, alpha_dot, alpha_ddot, table[:, -3:], joints, header.get("robot", ""), str(path)
    )

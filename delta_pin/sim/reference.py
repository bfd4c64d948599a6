"""The reference alpha^d(t) of a run, tabulated before it starts (a path that leaves the workspace
fails at once, with the time and the point) and read at any time by Hermite interpolation."""

from __future__ import annotations

import numpy as np

from delta_pin.control.base import Reference
from delta_pin.errors import InvalidParameterError
from delta_pin.model.robot import Delta
from delta_pin.sim.arguments import joint_vector

__all__ = ["ReferenceTable", "tabulate_reference"]


class ReferenceTable:
    """alpha^d, alpha_dot^d, alpha_ddot^d on a uniform grid, read at any time by cubic Hermite
    interpolation (exact at the grid points; O(h^4) between them, ~1e-15 rad for path I on a
    0.25 ms grid)."""

    def __init__(
        self,
        step: float,
        alpha: np.ndarray,
        alpha_dot: np.ndarray,
        alpha_ddot: np.ndarray,
        alpha_dddot: np.ndarray | None = None,
    ) -> None:
        self.step = step
        self.alpha, self.alpha_dot, self.alpha_ddot = alpha, alpha_dot, alpha_ddot
        # jerk for the Hermite interpolation of alpha_ddot, by central differences of the table
        self.alpha_dddot = np.gradient(alpha_ddot, step, axis=0) if alpha_dddot is None else alpha_dddot
        self.last = len(alpha) - 1

    def rows(self, per_sample: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(alpha^d, alpha_dot^d, alpha_ddot^d) at every ``per_sample``-th grid point (the samples)."""
        return self.alpha[::per_sample], self.alpha_dot[::per_sample], self.alpha_ddot[::per_sample]

    def __call__(self, t: float) -> Reference:
        u = t / self.step
        k = min(max(int(u), 0), self.last)
        tau = u - k
        if tau <= 1e-9 or k == self.last:
            return Reference(self.alpha[k], self.alpha_dot[k], self.alpha_ddot[k])
        if tau >= 1.0 - 1e-9:
            return Reference(self.alpha[k + 1], self.alpha_dot[k + 1], self.alpha_ddot[k + 1])
        tau2, tau3 = tau * tau, tau * tau * tau
        h00, h10, h01, h11 = 2 * tau3 - 3 * tau2 + 1, tau3 - 2 * tau2 + tau, -2 * tau3 + 3 * tau2, tau3 - tau2
        h = self.step

        def hermite(y, dy):
            return h00 * y[k] + h10 * h * dy[k] + h01 * y[k + 1] + h11 * h * dy[k + 1]

        return Reference(
            hermite(self.alpha, self.alpha_dot),
            hermite(self.alpha_dot, self.alpha_ddot),
            hermite(self.alpha_ddot, self.alpha_dddot),
        )


def tabulate_reference(robot: Delta, trajectory, alpha0, dof: int, steps: int, dt: float, per_sample: int):
    """(reference table on the grid dt / per_sample, desired xyz at the samples, alpha0): the
    trajectory's, or a hold of ``alpha0`` (default: the robot's ``home``) when there is none.

    A trajectory in joint space declares it (``joint_space = True``) and gives its joints by
    ``joint_values(t) -> (alpha, alpha_dot, alpha_ddot)`` (N, dof) at times t (N,) [s]: they are
    then read on the whole grid and its ``joint_reference`` -- the end effector's xyz, by forward
    kinematics -- at the samples only, a quarter of the assemblies of a continuous run's grid."""
    grid = np.arange(steps * per_sample + 1) * (dt / per_sample)
    if getattr(trajectory, "joint_space", False) and per_sample > 1:
        values = trajectory.joint_values(grid)
        table = ReferenceTable(dt / per_sample, *(np.asarray(a, dtype=float) for a in values))
        at_samples = trajectory.joint_reference(robot, grid[::per_sample])
        return table, at_samples.xyz, table.alpha[0] if alpha0 is None else alpha0
    if trajectory is not None:
        ref = trajectory.joint_reference(robot, grid)
        table = ReferenceTable(dt / per_sample, ref.alpha, ref.alpha_dot, ref.alpha_ddot)
        return table, ref.xyz[::per_sample], ref.alpha[0] if alpha0 is None else alpha0
    if alpha0 is None:
        alpha0 = getattr(robot, "home", None)  # a closed chain's assembled home
    if alpha0 is None:
        raise InvalidParameterError("alpha0 is required when no trajectory is given")
    hold = joint_vector(alpha0, "alpha0", dof)
    zeros = np.zeros((len(grid), dof))
    table = ReferenceTable(dt / per_sample, np.broadcast_to(hold, (len(grid), dof)), zeros, zeros, zeros)
    return table, np.broadcast_to(robot.forward_kinematics(hold), (steps + 1, 3)), alpha0


class SharedReference:
    """A trajectory whose joint references are computed once per robot and time grid and then
    shared: the runs of a batch (:func:`~delta_pin.sim.batch.simulate_batch`) follow one path on
    one grid, and tabulating it (inverse kinematics at every point) costs about a third of a
    compiled 15 s run. Everything else is the wrapped trajectory's."""

    def __init__(self, trajectory) -> None:
        self.trajectory = trajectory
        self._tables: list[tuple[object, np.ndarray, object]] = []  # (robot, times, reference)

    def joint_reference(self, robot, times):
        times = np.asarray(times, dtype=float)
        for known_robot, known_times, reference in self._tables:
            if known_robot is robot and np.array_equal(known_times, times):
                return reference
        reference = self.trajectory.joint_reference(robot, times)
        self._tables.append((robot, times.copy(), reference))
        return reference

    def __getattr__(self, name: str):
        return getattr(self.trajectory, name)

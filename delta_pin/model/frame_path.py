"""Task-space references for any closed-chain robot: a path of a named frame, mapped to the
actuated joints by numeric closed-loop inverse kinematics.

* :class:`Circle` -- a circle in a coordinate plane, at constant speed (a task-space
  :class:`~delta_pin.model.trajectory.Trajectory`, so a Delta can follow it too);
* :class:`FramePath` -- any task-space trajectory followed by a frame of a
  :class:`~delta_pin.model.closed_chain.ClosedChainRobot`:

      alpha = IK(x),  alpha_dot = J_x^+ x_dot,  alpha_ddot = J_x^+ (x_ddot - J_x_dot alpha_dot),

  with J_x the frame's closed-loop Jacobian (rows of the controlled ``axes``) and J_x_dot
  alpha_dot its classical acceleration at zero actuated acceleration
  (:meth:`~delta_pin.model.closed_chain.ClosedChainRobot.frame_acceleration_drift`); each
  sample's IK starts from the previous one's (docs/architecture.md section 10).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from delta_pin.errors import AssemblyError, InvalidParameterError, UnreachablePoseError
from delta_pin.model.trajectory import JointReference, Trajectory, _vectorised

__all__ = ["Circle", "FramePath"]

_PLANES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}


class Circle(Trajectory):
    """x(t) = center + radius (cos(2 pi t / period + phase) e_1 + sin(2 pi t / period + phase) e_2) [m].

    Args:
        center: the circle's center (3,) [m].
        radius: [m] (> 0).
        period: time of one turn [s] (> 0).
        plane: ``"xy"``, ``"xz"`` or ``"yz"`` (e_1, e_2 its axes).
        phase: the start's angle on the circle [rad] (0: center + radius e_1).
    """

    name = "circle"
    duration = None

    def __init__(self, center, radius: float, period: float, plane: str = "xy", phase: float = 0.0) -> None:
        self.center = np.asarray(center, dtype=float).reshape(3)
        if not np.isfinite(self.center).all():
            raise InvalidParameterError(f"center={np.asarray(center).tolist()} must be 3 finite numbers [m]")
        if not (math.isfinite(radius) and radius > 0.0):
            raise InvalidParameterError(f"radius={radius!r} must be > 0 [m]")
        if not (math.isfinite(period) and period > 0.0):
            raise InvalidParameterError(f"period={period!r} must be > 0 [s]")
        if plane not in _PLANES:
            raise InvalidParameterError(f"plane={plane!r} must be one of {', '.join(_PLANES)}")
        if not math.isfinite(phase):
            raise InvalidParameterError(f"phase={phase!r} must be finite [rad]")
        self.radius, self.period, self.plane, self.phase = float(radius), float(period), plane, float(phase)

    def _axes(self, t: np.ndarray, derivative: int) -> np.ndarray:
        omega = 2.0 * math.pi / self.period
        phase = omega * t + self.phase + derivative * math.pi / 2.0  # d/dt cos = cos(. + pi/2) omega
        values = np.zeros((len(t), 3))
        i, j = _PLANES[self.plane]
        values[:, i] = self.radius * omega**derivative * np.cos(phase)
        values[:, j] = self.radius * omega**derivative * np.sin(phase)
        return values

    @_vectorised
    def position(self, t):
        return self.center + self._axes(t, 0)

    @_vectorised
    def velocity(self, t):
        return self._axes(t, 1)

    @_vectorised
    def acceleration(self, t):
        return self._axes(t, 2)

    def metadata(self) -> dict[str, Any]:
        return {
            **super().metadata(),
            "center": self.center.tolist(),
            "radius": self.radius,
            "period": self.period,
            "plane": self.plane,
            "phase": self.phase,
        }


class FramePath:
    """A task-space trajectory followed by a frame of a closed-chain robot (module docstring).

    Args:
        trajectory: any task-space trajectory (``position``, ``velocity``, ``acceleration`` of t).
        frame: the frame that follows it (default: the robot's end effector).
        axes: the controlled world coordinates (default: ``"xyz"`` for 3 or more actuators, the
            circle's plane -- or ``"xy"`` -- for 2, ``"z"`` for 1).
    """

    def __init__(self, trajectory: Trajectory, frame: str | None = None, axes: str | None = None) -> None:
        self.trajectory = trajectory
        self.frame = frame
        self.axes = axes
        self.name = f"{trajectory.name} of {frame or 'the end effector'}"
        self.duration = getattr(trajectory, "duration", None)

    def _axes_for(self, robot) -> str:
        if self.axes is not None:
            axes = self.axes
        elif robot.dof >= 3:
            axes = "xyz"
        elif robot.dof == 2:
            axes = getattr(self.trajectory, "plane", "xy")
        else:
            axes = "z"
        if len(axes) != robot.dof:
            raise InvalidParameterError(
                f"axes={axes!r} controls {len(axes)} coordinate(s) of the frame but the robot has "
                f"{robot.dof} "
                "actuators: give as many task coordinates as actuators"
            )
        return axes

    def joint_reference(self, robot, t, start: np.ndarray | None = None) -> JointReference:
        """alpha, alpha_dot, alpha_ddot at times ``t`` (N,) [s] (module docstring), the inverse
        kinematics of the first sample from ``start`` (a closed configuration q; default the
        robot's last assembly, so a path continues from where the robot was).

        Raises:
            UnreachablePoseError: naming the time and point the frame cannot reach.
        """
        if start is not None:
            robot._last_q = robot._configuration_vector(start).copy()
        times = np.atleast_1d(np.asarray(t, dtype=float))
        axes = self._axes_for(robot)
        rows = ["xyz".index(a) for a in axes]
        fid = robot.end_effector if self.frame is None else robot.frame_id(self.frame)
        xyz = np.atleast_2d(self.trajectory.position(times))
        xyz_dot = np.atleast_2d(self.trajectory.velocity(times))
        xyz_ddot = np.atleast_2d(self.trajectory.acceleration(times))
        n = len(times)
        compiled = self._compiled_reference(robot, fid, rows, times, xyz, xyz_dot, xyz_ddot)
        if compiled is not None:
            return JointReference(times, compiled[3], xyz_dot, xyz_ddot, *compiled[:3])
        alpha, alpha_dot, alpha_ddot = (np.empty((n, robot.dof)) for _ in range(3))
        actual = np.empty((n, 3))
        guess = None
        for k in range(n):
            if k > 0:  # second-order prediction from the previous sample: IK then needs ~1 step
                step = times[k] - times[k - 1]
                guess = alpha[k - 1] + step * alpha_dot[k - 1] + 0.5 * step * step * alpha_ddot[k - 1]
            try:
                guess = robot.inverse_kinematics(xyz[k], fid, axes=axes, initial_guess=guess)
            except (UnreachablePoseError, AssemblyError) as exc:  # name the time
                raise type(exc)(f"t={times[k]:g} s: {exc}") from None
            q = robot.configuration(guess)
            J = robot.frame_jacobian(q, fid)[:3][rows]
            alpha[k] = guess
            alpha_dot[k] = np.linalg.solve(J, xyz_dot[k, rows])
            drift = robot.frame_acceleration_drift(q, alpha_dot[k], fid)
            alpha_ddot[k] = np.linalg.solve(J, (xyz_ddot[k] - drift)[rows])
            actual[k] = robot.frame_placement(q, fid).translation
        return JointReference(times, actual, xyz_dot, xyz_ddot, alpha, alpha_dot, alpha_ddot)

    @staticmethod
    def _compiled_reference(robot, fid, rows, times, xyz, xyz_dot, xyz_ddot):
        """(alpha, alpha_dot, alpha_ddot, reached xyz) from the compiled core's loop over the
        samples (the same Newton iterations as the loop below, which stays the reference and
        names a sample that cannot be reached), or ``None`` where the core does not take the
        robot or a sample fails."""
        model = robot.compiled_model
        if model is None:
            return None
        start = robot._last_q.copy()
        alpha0 = start[robot.actuated_q_indices]
        failed, q, *reference = model.joint_reference(
            int(fid), np.asarray(rows, dtype=np.int32), times, xyz, xyz_dot, xyz_ddot, alpha0, start
        )
        if failed >= 0:
            return None
        robot._last_q = q  # the assembly mode the path ends in, as the loop below leaves it
        return reference

    def metadata(self) -> dict[str, Any]:
        return {
            "type": "FramePath",
            "frame": self.frame,
            "axes": self.axes,
            "path": self.trajectory.metadata(),
        }

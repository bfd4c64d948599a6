"""The distance of a closed chain's configuration to its singularities (Gosselin & Angeles, IEEE
T-RA 1990), for any robot of delta-pin's one robot model.

With the closures' velocity constraint J_c v = 0 (J_c: ``robot.closure_jacobian``, nv columns)
and the frame's task rows J_x v = x_dot (``axes`` of the frame's translation, as many as
actuators):

- **Type II** (actuation, "parallel") singularity: the actuated joints held still no longer fix
  the loops -- J_p, J_c's columns of the dependent joints, loses rank: the platform gains a
  motion no motor resists and the torque a path needs diverges. Measure: sigma_min / sigma_max of
  J_p (over its rank less the idle motions, as ``ClosedChainRobot.actuation_conditioning``).
- **Type I** (inverse-kinematic, "serial") singularity (with J_x the frame's translation rows along
  ``axes``, and for more than three actuators its rotation rows too): the frame held still no longer fixes the
  chain -- [J_c; J_x] loses rank: a motor turns without moving the frame (a Delta's arm in line
  with its forearm, the workspace boundary). Measure: sigma_min / sigma_max of [J_c; J_x] over
  nv less the idle motions.

Both are 1 far from a singularity's kind and 0 on it; they are ratios of singular values of
matrices whose columns mix revolute and prismatic joints and whose rows mix metres and
radians, so they compare configurations of one robot, not robots. A planner refuses a path that
comes within ``margin`` of either (:func:`path_singularity`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from delta_pin.errors import InvalidParameterError

__all__ = ["SingularityMeasure", "path_singularity", "singularity_measure", "workspace_map"]


@dataclass(frozen=True)
class SingularityMeasure:
    """sigma_min / sigma_max of the Type I ([J_c; J_x]) and Type II (J_p) matrices (module
    docstring): 0 on a singularity of that kind, 1 at the best-conditioned configuration."""

    type_one: float
    type_two: float

    @property
    def worst(self) -> float:
        return min(self.type_one, self.type_two)


def _ratio(matrix: np.ndarray, rank: int) -> float:
    if rank <= 0:
        return 1.0
    singular = np.linalg.svd(matrix, compute_uv=False)
    return float(singular[rank - 1] / singular[0]) if singular[0] > 0.0 else 0.0


def _task_rows(robot, axes: str | None) -> list[int]:
    """The rows of the frame's 6-row Jacobian (x, y, z, then rx, ry, rz) that are its task: ``axes``
    of the translation for up to 3 actuators (default ``"xyz"``, ``"xz"`` for 2, ``"z"`` for 1);
    for more, the translation and then the first rotations (a Stewart platform: all six)."""
    if robot.dof > 3 and axes is None:
        return list(range(robot.dof))
    axes = axes or ("xyz" if robot.dof >= 3 else "xz" if robot.dof == 2 else "z")
    if len(axes) != robot.dof or any(a not in "xyz" for a in axes):
        raise InvalidParameterError(
            f"axes={axes!r} must name {robot.dof} of x, y, z (one task coordinate per actuator)"
        )
    return ["xyz".index(a) for a in axes]


def singularity_measure(
    robot, q: np.ndarray, frame: str | None = None, axes: str | None = None
) -> SingularityMeasure:
    """The Type I and Type II measures at the closed configuration q (module docstring) of
    ``frame`` (default the end effector) along ``axes`` (default ``"xyz"`` for 3 or more
    actuators, ``"xz"`` for 2)."""
    q = np.asarray(q, dtype=float)
    rows = _task_rows(robot, axes)
    fid = robot.end_effector if frame is None else robot.frame_id(frame)
    J_c = robot.closure_jacobian(q)
    J_x = pin.computeFrameJacobian(robot.model, robot.data, q, fid, pin.LOCAL_WORLD_ALIGNED)[rows]
    idle = robot.idle_dof or 0
    dependent = robot.dependent_indices
    type_two = _ratio(J_c[:, dependent], len(dependent) - idle)
    type_one = _ratio(np.vstack([J_c, J_x]), robot.model.nv - idle)
    return SingularityMeasure(type_one, type_two)


def path_singularity(
    robot,
    alpha: np.ndarray,
    frame: str | None = None,
    axes: str | None = None,
    start: np.ndarray | None = None,
) -> np.ndarray:
    """The measures (N, 2) [Type I, Type II] along actuated values alpha (N, dof), each assembled
    from the one before, the first from ``start`` (a configuration on the branch wanted; default
    the robot's last assembly)."""
    alpha = np.atleast_2d(np.asarray(alpha, dtype=float))
    out = np.empty((len(alpha), 2))
    q = start
    for i, a in enumerate(alpha):
        q = robot.configuration(a, initial_guess=q)
        measure = singularity_measure(robot, q, frame, axes)
        out[i] = measure.type_one, measure.type_two
    return out


def workspace_map(
    robot,
    xs: np.ndarray,
    ys: np.ndarray,
    height: float,
    plane: str = "xy",
    frame: str | None = None,
    axes: str | None = None,
) -> np.ndarray:
    """The smaller of the two measures over a grid of frame positions (len(ys), len(xs)) in the
    ``plane`` (``"xy"`` at z = ``height``, ``"xz"`` at y = ``height``) [m]; NaN where the frame
    cannot reach. Each point by the core's inverse kinematics from its neighbour."""
    from delta_pin.errors import AssemblyError, UnreachablePoseError

    if plane not in ("xy", "xz"):
        raise InvalidParameterError(f"plane={plane!r} must be 'xy' or 'xz'")
    if robot.dof > 3:
        raise InvalidParameterError(
            f"a workspace map places a frame's position: {robot.dof} actuators move more"
        )
    rows = _task_rows(robot, axes)
    axes = "".join("xyz"[r] for r in rows)
    fid = robot.end_effector if frame is None else robot.frame_id(frame)
    out = np.full((len(ys), len(xs)), np.nan)
    for i, y in enumerate(ys):
        guess = None
        for j, x in enumerate(xs):
            target = np.array([x, y, height]) if plane == "xy" else np.array([x, height, y])
            try:
                guess = robot.inverse_kinematics(target, fid, axes=axes, initial_guess=guess)
                q = robot.configuration(guess)
            except (UnreachablePoseError, AssemblyError):
                guess = None
                continue
            out[i, j] = singularity_measure(robot, q, frame, axes).worst
    return out

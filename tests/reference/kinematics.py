"""The readable inverse kinematics of a frame: the twin of the compiled core's
``ClosedChainModel::inverse_kinematics`` (core/model/closed_chain_model.cpp), which
``ClosedChainRobot.inverse_kinematics`` and ``FramePath`` call. Newton on alpha with the
closed-loop Jacobian's task rows (least squares), steps capped at 0.2 (rad or m), each iterate
assembled from the previous configuration (``tests/reference/assembly.py``)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from delta_pin.model.closed_chain import least_squares
from tests.reference.assembly import newton_configuration
from tests.reference.projection import frame_jacobian

__all__ = ["inverse_kinematics"]


def inverse_kinematics(
    robot, target, frame: int, rows, alpha, q, tol: float = 1e-12, max_iterations: int = 60
) -> np.ndarray | None:
    """alpha putting the frame's origin at ``target`` [m] along ``rows`` (0..2), or ``None``: within
    ``tol``, or within 1000 ``tol`` where Newton stops gaining (the error not halved by a step: the
    floating-point floor of the loops' closure, itself solved to ``tol``)."""
    alpha = np.array(alpha, dtype=float)
    target = np.asarray(target, dtype=float)
    previous = np.inf
    for _ in range(max_iterations):
        q, _, _ = newton_configuration(robot, alpha, q)
        if q is None:
            return None
        pin.framesForwardKinematics(robot.model, robot.data, q)
        error = (robot.data.oMf[frame].translation - target)[rows]
        gap = np.abs(error).max()
        if gap <= tol or (gap > 0.5 * previous and gap <= 1e3 * tol):
            return alpha
        previous = gap
        J = frame_jacobian(robot, q, frame)[:3][rows]
        step = least_squares(J, error)
        largest = np.abs(step).max(initial=0.0)
        if largest > 0.2:
            step *= 0.2 / largest
        alpha = alpha - step
    return None

"""The readable Newton that assembles a built robot: the twin of the compiled core's
``ClosedChainModel::configuration`` (core/model/closed_chain_model.cpp), which
``ClosedChainRobot.configuration`` calls. Least squares on the closure residual over the dependent
coordinates (the minimum-norm step where idle motions leave a null space), steps capped at 0.5
(rad or m), the actuated joints at alpha and the named passive joints held."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from delta_pin.model.closed_chain import least_squares

__all__ = ["newton_configuration"]


def newton_configuration(
    robot, alpha: np.ndarray, start: np.ndarray, tol: float = 1e-12, max_iterations: int = 60
) -> tuple[np.ndarray | None, np.ndarray | None, int]:
    """(q, residual, iterations) from ``start`` with the actuated joints at ``alpha``; q is
    ``None`` where the loops do not close to ``tol`` within ``max_iterations`` steps, and the
    residual is then the last iterate's (``None`` where it is not finite)."""
    q = np.array(start, dtype=float)
    q[robot.actuated_q_indices] = alpha
    residual = None
    for iteration in range(max_iterations):
        residual = robot.closure_residual(q)
        if np.abs(residual).max() <= tol:
            return q, residual, iteration
        J = robot.closure_jacobian(q)[:, robot.dependent_indices]
        if robot.idle_dof == 0:
            step = least_squares(J, residual)
        else:  # the pseudo-inverse at the rank the classification fixed (columns less idle motions)
            U, singular, Vt = np.linalg.svd(J, full_matrices=False)
            rank = J.shape[1] - robot.idle_dof
            step = Vt[:rank].T @ ((U[:, :rank].T @ residual) / singular[:rank])
        largest = np.abs(step).max(initial=0.0)
        if largest > 0.5:
            step *= 0.5 / largest
        dv = np.zeros(robot.model.nv)
        dv[robot.dependent_indices] = -step
        q = pin.integrate(robot.model, q, dv)
        if not np.isfinite(q).all():
            return None, None, iteration + 1
    return None, robot.closure_residual(q), max_iterations

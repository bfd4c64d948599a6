"""The readable projection of a closed chain onto its actuated joints: the twins of the compiled
core's ``ClosedChainModel`` (core/model/closed_chain_model.cpp) that ``ClosedChainRobot``'s
``velocity_map``, ``project_state``, ``reduced_terms``, ``frame_jacobian`` and
``frame_acceleration_drift`` call. Module docstring of delta_pin/model/closed_chain.py,
"Mobility", and docs/architecture.md section 10 give the mathematics: S = dq/dalpha of least
kinetic energy, S = P S0 with S0 the minimum-norm map, N the idle motions and
P = I - N (N^T M N)^-1 N^T M; M_red = S^T M S, C_red = S^T (C_tree S + M S_dot), G_red = S^T g
(the file's springs with gravity, its dampers in C), C alpha_dot = S^T (nle - g + M S_dot alpha_dot)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from delta_pin.model.closed_chain import least_squares

__all__ = [
    "frame_acceleration_drift",
    "frame_jacobian",
    "idle_projection",
    "project_state",
    "reduced_terms",
    "velocity_map",
]

_WORLD = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def _pseudo_inverse(robot, A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A^+, an orthonormal basis of A's null space (columns)) at the rank the classification
    fixed: A's columns less the idle motions."""
    U, singular, Vt = np.linalg.svd(A)
    rank = A.shape[1] - robot.idle_dof
    pinv = Vt[:rank].T @ np.diag(1.0 / singular[:rank]) @ U[:, :rank].T
    return pinv, Vt[rank:].T


def _minimum_norm(robot, J: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """(S0 (nv, independent coordinates), N (nv, idle_dof) or None) from J_c."""
    nv, dependent, independent = robot.model.nv, robot.dependent_indices, robot.independent_indices
    S0 = np.zeros((nv, len(independent)))
    S0[independent] = np.eye(len(independent))
    A, B = J[:, dependent], J[:, independent]
    if robot.idle_dof == 0:
        S0[dependent] = -least_squares(A, B)
        return S0, None
    A_pinv, N_dependent = _pseudo_inverse(robot, A)
    S0[dependent] = -A_pinv @ B
    N = np.zeros((nv, robot.idle_dof))
    N[dependent] = N_dependent
    return S0, N


def velocity_map(robot, q: np.ndarray) -> np.ndarray:
    """S = dq/dalpha (nv, dof) at a closed q: the named passive joints at rest, with idle motions
    the map of least kinetic energy."""
    S0, N = _minimum_norm(robot, robot.closure_jacobian(q))
    if N is not None:
        M = robot.mass_matrix(q)
        S0 = S0 - N @ np.linalg.solve(N.T @ M @ N, N.T @ M @ S0)
    return S0[:, : robot.dof]


def project_state(robot, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The nearest closure-consistent (q, v) keeping the actuated and passive joints and the idle
    motions: Newton from q (tests/reference/assembly.py), then v's dependent part corrected by the
    minimum-norm velocity that closes the loops."""
    from tests.reference.assembly import newton_configuration

    q, _, _ = newton_configuration(robot, np.asarray(q)[robot.actuated_q_indices], q)
    v = np.array(v, dtype=float)
    J = robot.closure_jacobian(q)
    A = J[:, robot.dependent_indices]
    correction = least_squares(A, J @ v) if robot.idle_dof == 0 else _pseudo_inverse(robot, A)[0] @ (J @ v)
    v[robot.dependent_indices] -= correction
    return q, v


def idle_projection(robot, q: np.ndarray, alpha_dot: np.ndarray) -> dict:
    """S, S_dot along v = S alpha_dot, M, C_tree(q, v) and v with idle motions, S = P S0
    differentiated in closed form (d(A^+) of the pseudo-inverse, N_dot = -A^+ A_dot N,
    M_dot = C_tree + C_tree^T)."""
    nv, dependent, independent = robot.model.nv, robot.dependent_indices, robot.independent_indices
    J = robot.closure_jacobian(q)
    A, B = J[:, dependent], J[:, independent]
    A_pinv, N_dependent = _pseudo_inverse(robot, A)
    M = robot.mass_matrix(q)
    S0 = np.zeros((nv, len(independent)))
    S0[independent] = np.eye(len(independent))
    S0[dependent] = -A_pinv @ B
    N = np.zeros((nv, robot.idle_dof))
    N[dependent] = N_dependent
    W = N.T @ M @ N
    K = np.linalg.solve(W, N.T @ M)
    P = np.eye(nv) - N @ K
    S = (P @ S0)[:, : robot.dof]
    v = S @ alpha_dot
    J_dot = robot.closure_jacobian_derivative(q, v)
    A_dot, B_dot = J_dot[:, dependent], J_dot[:, independent]
    rows, columns = A.shape
    pinv_dot = (
        -A_pinv @ A_dot @ A_pinv
        + A_pinv @ A_pinv.T @ A_dot.T @ (np.eye(rows) - A @ A_pinv)
        + (np.eye(columns) - A_pinv @ A) @ A_dot.T @ A_pinv.T @ A_pinv
    )
    S0_dot = np.zeros_like(S0)
    S0_dot[dependent] = -(pinv_dot @ B + A_pinv @ B_dot)
    N_dot = np.zeros_like(N)
    N_dot[dependent] = -A_pinv @ A_dot @ N_dependent
    C_tree = pin.computeCoriolisMatrix(robot.model, robot.data, q, v).copy()
    M_dot = C_tree + C_tree.T
    W_dot = N_dot.T @ M @ N + N.T @ M_dot @ N + N.T @ M @ N_dot
    K_dot = np.linalg.solve(W, N_dot.T @ M + N.T @ M_dot - W_dot @ K)
    P_dot = -(N_dot @ K + N @ K_dot)
    S_dot = (P_dot @ S0 + P @ S0_dot)[:, : robot.dof]
    return {"S": S, "S_dot": S_dot, "M": M, "C_tree": C_tree, "v": v}


def _drift_rate(robot, q: np.ndarray, J: np.ndarray, v: np.ndarray) -> np.ndarray:
    """S_dot alpha_dot without idle motions, from the closures' drift (exact classical accelerations)."""
    rate = np.zeros(robot.model.nv)
    rate[robot.dependent_indices] = -least_squares(J[:, robot.dependent_indices], robot.closure_drift(q, v))
    return rate


def reduced_terms(robot, q: np.ndarray, alpha_dot: np.ndarray):
    """(M, C, G, C alpha_dot) on the actuated joints at a closed q (module docstring)."""
    alpha_dot = np.asarray(alpha_dot, dtype=float)
    if robot.idle_dof:
        p = idle_projection(robot, q, alpha_dot)
        S, S_dot, M, C_tree, v = p["S"], p["S_dot"], p["M"], p["C_tree"], p["v"]
        rate = S_dot @ alpha_dot
    else:
        J = robot.closure_jacobian(q)
        S = velocity_map(robot, q)
        v = S @ alpha_dot
        passive = J[:, robot.dependent_indices]
        S_dot = np.zeros_like(S)
        S_dot[robot.dependent_indices] = -least_squares(passive, robot.closure_jacobian_derivative(q, v) @ S)
        M = robot.mass_matrix(q)
        C_tree = pin.computeCoriolisMatrix(robot.model, robot.data, q, v).copy()
        rate = _drift_rate(robot, q, J, v)
    gravity = pin.computeGeneralizedGravity(robot.model, robot.data, q).copy()
    nle = pin.nonLinearEffects(robot.model, robot.data, q, v)
    M_red = S.T @ M @ S
    C = S.T @ C_tree @ S + S.T @ M @ S_dot
    coriolis = S.T @ (nle - gravity) + S.T @ (M @ rate)
    if robot.joint_springs:  # the file's springs and dampers, as the plant applies them
        stiffness, damping = robot.joint_spring_forces(q)
        gravity = gravity + stiffness
        damped = S.T @ damping @ S
        C, coriolis = C + damped, coriolis + damped @ alpha_dot
    return 0.5 * (M_red + M_red.T), C, S.T @ gravity, coriolis


def frame_jacobian(robot, q: np.ndarray, frame: int) -> np.ndarray:
    """J_frame S (6, dof), LOCAL_WORLD_ALIGNED."""
    S = velocity_map(robot, q)
    pin.computeJointJacobians(robot.model, robot.data, q)
    pin.updateFramePlacements(robot.model, robot.data)
    return pin.getFrameJacobian(robot.model, robot.data, frame, _WORLD) @ S


def frame_acceleration_drift(robot, q: np.ndarray, alpha_dot: np.ndarray, frame: int) -> np.ndarray:
    """The frame's classical linear acceleration (3,) [m/s^2] at zero actuated acceleration."""
    alpha_dot = np.asarray(alpha_dot, dtype=float)
    if robot.idle_dof:
        p = idle_projection(robot, q, alpha_dot)
        v, rate = p["v"], p["S_dot"] @ alpha_dot
    else:
        J = robot.closure_jacobian(q)
        v = velocity_map(robot, q) @ alpha_dot
        rate = _drift_rate(robot, q, J, v)
    pin.forwardKinematics(robot.model, robot.data, q, v, rate)
    return pin.getFrameClassicalAcceleration(robot.model, robot.data, frame, _WORLD).linear.copy()

"""The paper's reduced analytic dynamics of the Delta (eqs. 7-9), with the sign of G corrected.

    M(alpha) = (1/3 m_a + 1/2 m_b) l_a^2 I + J^T m_eq J                      (eq. 7)
    C(alpha, alpha_dot) = J^T m_eq J_dot                                     (eq. 8)
    G(alpha) = -(1/2 m_a + 1/2 m_b) g l_a cos(alpha) + J^T m_eq [0, 0, g]^T  (eq. 9, erratum 1)

with m_eq = m_o + 3/2 m_b. With alpha > 0 swinging the arm down and z up, the arm term of G is
NEGATIVE: the paper prints a + sign, which is off by up to (m_a + m_b) g l_a (docs/architecture.md section 4).
The model is exact for uniform-rod upper arms and forearms lumped as two point masses.
M_dot - 2C = m_eq (J_dot^T J - J^T J_dot) is skew-symmetric.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from delta_pin.model.description import DeltaParameters
from delta_pin.model.kinematics import as_vector3, forward_kinematics, jacobian, jacobian_derivative

__all__ = ["ReducedDynamics", "analytic_dynamics"]


@dataclass(frozen=True)
class ReducedDynamics:
    """Joint-space dynamics M alpha_ddot + coriolis + G = tau at one state.

    Attributes:
        M: inertia matrix (3, 3) [kg m^2].
        G: gravity torque (3,) [N m].
        coriolis: Coriolis/centrifugal torque C alpha_dot (3,) [N m].
        C: Coriolis matrix (3, 3) [kg m^2/s], or ``None`` where only C alpha_dot is known.
    """

    M: np.ndarray
    G: np.ndarray
    coriolis: np.ndarray
    C: np.ndarray | None = None


def analytic_dynamics(
    params: DeltaParameters,
    alpha: np.ndarray,
    alpha_dot: np.ndarray,
    platform_mass: float | None = None,
) -> ReducedDynamics:
    """M, C, G of eqs. 7-9 at (alpha [rad], alpha_dot [rad/s]), one state (3,) or a batch (..., 3).

    Args:
        params: the robot.
        platform_mass: m_o [kg] (scalar or per batch element) instead of ``params.m_o``
            (time-varying payload).
    """
    alpha = as_vector3(alpha, "alpha")
    alpha_dot = as_vector3(alpha_dot, "alpha_dot")
    m_o = params.m_o if platform_mass is None else np.asarray(platform_mass, dtype=float)
    m_eq = np.asarray(m_o + 1.5 * params.m_b)[..., None, None]
    xyz = forward_kinematics(params, alpha)
    J = jacobian(params, alpha, xyz)
    J_T = np.swapaxes(J, -1, -2)
    M = params.arm_equivalent_inertia * np.eye(3) + m_eq * (J_T @ J)
    C = m_eq * (J_T @ jacobian_derivative(params, alpha, alpha_dot, xyz, J=J))
    G = -0.5 * (params.m_a + params.m_b) * params.g * params.l_a * np.cos(alpha) + (
        m_eq[..., 0] * params.g * J[..., 2, :]
    )
    return ReducedDynamics(M=M, G=G, coriolis=(C @ alpha_dot[..., None])[..., 0], C=C)

"""Stribeck friction torque of the active joints (eqs. 11-12).

    M_f,i = [F_c + (F_s - F_c) exp(-(alpha_dot_i r_a / v_s)^2)] sgn(alpha_dot_i) r_a
            + mu_v alpha_dot_i r_a,               F_c = mu_d F_n,i,  F_s = mu_s F_n,i   (eq. 12)

Reading of eq. 12 (erratum 6 of DESIGN.md): the exponent compares the sliding speed at the
friction arm, alpha_dot r_a [m/s], with the Stribeck velocity v_s taken in m/s (Table 1 prints
rad/s); the viscous term is mu_v alpha_dot r_a [N m] with mu_v in N s/m, as printed.

``sign_velocity_scale`` replaces sgn(v) by tanh(v / scale): 0 gives the exact (discontinuous)
sign of the paper; a plant uses a small positive scale so that the ODE stays Lipschitz.
"""

from __future__ import annotations

import numpy as np

from .description import StribeckParameters

__all__ = ["stribeck_torque"]


def stribeck_torque(
    friction: StribeckParameters,
    alpha_dot: np.ndarray,
    normal_force: np.ndarray | float,
    sign_velocity_scale: float = 0.0,
) -> np.ndarray:
    """Friction torque M_f [N m] of eq. 12 opposing the joints' motion (it appears on the left).

    Args:
        friction: the Stribeck parameters (from the URDF).
        alpha_dot: active joint velocities [rad/s], any shape.
        normal_force: normal force F_n per joint [N], broadcast against ``alpha_dot``.
        sign_velocity_scale: smoothing scale of sgn [rad/s]; 0 for the exact sign.
    """
    alpha_dot = np.asarray(alpha_dot, dtype=float)
    normal_force = np.asarray(normal_force, dtype=float)
    coulomb = friction.mu_d * normal_force
    static = friction.mu_s * normal_force
    sliding = alpha_dot * friction.r_a / friction.v_s
    sign = np.tanh(alpha_dot / sign_velocity_scale) if sign_velocity_scale > 0.0 else np.sign(alpha_dot)
    level = coulomb + (static - coulomb) * np.exp(-(sliding**2))
    return level * sign * friction.r_a + friction.mu_v * alpha_dot * friction.r_a

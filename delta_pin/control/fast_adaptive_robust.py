"""Compiled step of designs I and II on the Delta's analytic nominal model.

One numba kernel evaluates C1 + C2 + C3/C4 and the adaptive law (eqs. 23-26, 30-32, 55-57, 67)
for one state, from the parameters packed once per controller by :func:`pack_controller`. The
readable :meth:`AdaptiveRobustController.evaluate_reference
<delta_pin.control.adaptive_robust.AdaptiveRobustController.evaluate_reference>` is the
specification and the test oracle (agreement <= 1e-12 relative, tests/test_fast_control.py).
Without numba the same kernel runs as plain Python (slower, same numbers).
"""

from __future__ import annotations

import math

import numpy as np

from ..fast_model import delta_terms, njit, stribeck_kernel

__all__ = ["adaptive_robust_kernel", "adaptive_robust_law", "pack_controller"]

# layout of the packed parameter vector
_D, _T_P, _T_V = slice(0, 3), slice(3, 6), slice(6, 9)
_BETA, _XI, _EPSILON, _B1, _B2, _B3 = 9, 10, 11, 12, 13, 14
_DESIGN_TWO, _VECTOR_RHO, _PERIOD, _MARGIN = 15, 16, 17, 18
_F_BAR = slice(19, 22)
_FRICTION_ON, _R_A, _V_S, _MU_S, _MU_D, _MU_V = 22, 23, 24, 25, 26, 27
_NORMAL = slice(28, 31)
_SIGN_SCALE, _M_EQ = 31, 32
GEOMETRY = slice(33, 40)
SIZE = 40


def pack_controller(controller) -> np.ndarray:
    """The parameter vector of an :class:`AdaptiveRobustController` on a ``DeltaNominalModel``."""
    nominal, gains, ctc = controller.nominal, controller.gains, controller.computed_torque
    p = np.zeros(SIZE)
    p[_D], p[_T_P], p[_T_V] = ctc.D, ctc.T_p, ctc.T_v
    p[_BETA], p[_XI], p[_EPSILON] = gains.beta, gains.xi, gains.epsilon
    p[_B1], p[_B2], p[_B3] = gains.b1, gains.b2, gains.b3
    p[_DESIGN_TWO] = controller.design == "II"
    p[_VECTOR_RHO] = controller.vector_rho
    p[_PERIOD] = controller.sampling_period or 0.0
    p[_MARGIN] = controller.sampling_margin
    p[_F_BAR] = nominal.disturbance()
    if controller.friction_compensation and nominal._friction_arguments is not None:
        p[_FRICTION_ON] = 1.0
        p[_R_A], p[_V_S], p[_MU_S], p[_MU_D], p[_MU_V] = nominal._friction_arguments
        p[_NORMAL] = nominal._normal_force
        p[_SIGN_SCALE] = nominal.friction_model.sign_velocity_scale
    p[_M_EQ] = nominal._m_eq
    p[GEOMETRY] = nominal._geometry
    return p


@njit(cache=True)
def adaptive_robust_kernel(
    p, cos_phi, sin_phi, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, rho
):
    """(tau (3,), rho_dot, info) with info = [ok, Lambda, robust gain, ||omega||, adaptation active,
    C3 (3 values)]; ``ok`` is 0 when the nominal model has no FK at ``alpha``."""
    ok, _, _, _, M, C, G = delta_terms(p[33:40], cos_phi, sin_phi, p[32], alpha, alpha_dot)
    if not ok:
        return np.zeros(3), np.zeros(rho.shape[0]), np.zeros(8)
    return adaptive_robust_law(p, M, C, G, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, rho)


@njit(cache=True)
def adaptive_robust_law(p, M, C, G, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, rho):
    """:func:`adaptive_robust_kernel` given the nominal M̄, C̄, Ḡ at the state (the closed-loop
    kernel computes the kinematics once for the controller and the plant)."""
    D, T_p, T_v = p[0:3], p[3:6], p[6:9]
    info = np.zeros(8)
    r = alpha - ref_alpha
    r_dot = alpha_dot - ref_alpha_dot
    s = r_dot + D * r
    a_ref = ref_alpha_ddot - D * r_dot
    v_ref = ref_alpha_dot - D * r
    tau = M @ a_ref + C @ v_ref + G + p[19:22]
    if p[22] > 0.0:
        tau = tau + stribeck_kernel(p[23], p[24], p[25], p[26], p[27], alpha_dot, p[28:31], p[31])
    tau = tau - T_p * r - T_v * r_dot
    # Lambda of eq. 67 and its gradient
    kappa0 = math.sqrt(a_ref @ a_ref)
    kappa1 = math.sqrt(v_ref @ v_ref)
    gradient = np.array([kappa0, kappa1, 1.0]) if p[16] > 0.0 else np.array([kappa0 + kappa1 + 1.0])
    Lambda = gradient @ rho
    s_norm = math.sqrt(s @ s)
    omega_norm = s_norm * Lambda
    xi = p[10]
    if p[15] > 0.0:
        phi = omega_norm / (omega_norm * omega_norm + omega_norm * xi + xi * xi)
    elif omega_norm > xi:
        phi = 1.0 / omega_norm
    else:
        phi = 1.0 / xi
    gain = phi * Lambda * Lambda
    if p[17] > 0.0:  # sampling-aware cap per inertia direction
        inertia, directions = np.linalg.eigh(M)
        t_v_max = max(T_v[0], max(T_v[1], T_v[2]))
        gains = np.minimum(np.maximum(p[18] * inertia / p[17] - t_v_max, 0.0), gain)
        c3 = -(directions @ (gains * (directions.T @ s)))
        gain = gains.min()
    else:
        c3 = -gain * s
    # adaptive law, eq. 24 (dead-zone eq. 25)
    leak = (p[13] * math.exp(-s_norm) + p[14]) * rho
    active = s_norm * math.sqrt(gradient @ gradient) > p[11]
    rho_dot = p[9] * (p[12] * gradient * s_norm - leak) if active else -p[9] * leak
    info[0], info[1], info[2], info[3], info[4] = 1.0, Lambda, gain, omega_norm, 1.0 if active else 0.0
    info[5:8] = c3
    return tau + c3, rho_dot, info

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

__all__ = ["adaptive_robust_kernel", "adaptive_robust_law", "adaptive_robust_law_into", "pack_controller"]

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
    tau, rho_dot, info = np.empty(3), np.empty(rho.shape[0]), np.zeros(8)
    adaptive_robust_law_into(
        p, M, C, G, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, rho, tau, rho_dot, info
    )
    return tau, rho_dot, info


@njit(cache=True)
def adaptive_robust_law_into(
    p, M, C, G, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, rho, tau, rho_dot, info
):
    """:func:`adaptive_robust_law` into preallocated tau (3,), rho_dot and info (8,)."""
    D, T_p, T_v = p[0:3], p[3:6], p[6:9]
    r0, r1, r2 = alpha[0] - ref_alpha[0], alpha[1] - ref_alpha[1], alpha[2] - ref_alpha[2]
    rd0 = alpha_dot[0] - ref_alpha_dot[0]
    rd1 = alpha_dot[1] - ref_alpha_dot[1]
    rd2 = alpha_dot[2] - ref_alpha_dot[2]
    s0, s1, s2 = rd0 + D[0] * r0, rd1 + D[1] * r1, rd2 + D[2] * r2
    a0 = ref_alpha_ddot[0] - D[0] * rd0
    a1 = ref_alpha_ddot[1] - D[1] * rd1
    a2 = ref_alpha_ddot[2] - D[2] * rd2
    v0 = ref_alpha_dot[0] - D[0] * r0
    v1 = ref_alpha_dot[1] - D[1] * r1
    v2 = ref_alpha_dot[2] - D[2] * r2
    for i in range(3):
        tau[i] = (M[i, 0] * a0 + M[i, 1] * a1 + M[i, 2] * a2) + (C[i, 0] * v0 + C[i, 1] * v1 + C[i, 2] * v2)
        tau[i] += G[i] + p[19 + i]
    if p[22] > 0.0:
        friction = stribeck_kernel(p[23], p[24], p[25], p[26], p[27], alpha_dot, p[28:31], p[31])
        for i in range(3):
            tau[i] += friction[i]
    tau[0] -= T_p[0] * r0 + T_v[0] * rd0
    tau[1] -= T_p[1] * r1 + T_v[1] * rd1
    tau[2] -= T_p[2] * r2 + T_v[2] * rd2
    # Lambda of eq. 67 and its gradient
    kappa0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    kappa1 = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    vector = p[16] > 0.0
    if vector:
        Lambda = kappa0 * rho[0] + kappa1 * rho[1] + rho[2]
        gradient_norm = math.sqrt(kappa0 * kappa0 + kappa1 * kappa1 + 1.0)
    else:
        Lambda = (kappa0 + kappa1 + 1.0) * rho[0]
        gradient_norm = kappa0 + kappa1 + 1.0
    s_norm = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
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
        s = np.array([s0, s1, s2])
        inertia, directions = np.linalg.eigh(M)
        t_v_max = max(T_v[0], max(T_v[1], T_v[2]))
        gains = np.minimum(np.maximum(p[18] * inertia / p[17] - t_v_max, 0.0), gain)
        c3 = -(directions @ (gains * (directions.T @ s)))
        gain = gains.min()
        info[5], info[6], info[7] = c3[0], c3[1], c3[2]
    else:
        info[5], info[6], info[7] = -gain * s0, -gain * s1, -gain * s2
    # adaptive law, eq. 24 (dead-zone eq. 25)
    decay = p[13] * math.exp(-s_norm) + p[14]
    active = s_norm * gradient_norm > p[11]
    for i in range(rho.shape[0]):
        leak = decay * rho[i]
        if active:
            gradient = (kappa0 if i == 0 else kappa1 if i == 1 else 1.0) if vector else kappa0 + kappa1 + 1.0
            rho_dot[i] = p[9] * (p[12] * gradient * s_norm - leak)
        else:
            rho_dot[i] = -p[9] * leak
    info[0], info[1], info[2], info[3], info[4] = 1.0, Lambda, gain, omega_norm, 1.0 if active else 0.0
    for i in range(3):
        tau[i] += info[5 + i]

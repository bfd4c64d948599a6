"""Compiled step of designs I and II on the Delta's analytic nominal model.

One numba kernel evaluates C1 + C2 + C3/C4 and the adaptive law (eqs. 23-26, 30-32, 55-57, 67)
for one state, from a :data:`~delta_pin.compiled.layouts.CONTROLLER` record (built once per
controller by :attr:`AdaptiveRobustController.kernel_parameters
<delta_pin.control.adaptive_robust.AdaptiveRobustController.kernel_parameters>`). The readable
:meth:`AdaptiveRobustController.evaluate_reference
<delta_pin.control.adaptive_robust.AdaptiveRobustController.evaluate_reference>` is the
specification and the test oracle (agreement <= 1e-12 relative, tests/control/test_compiled_step.py).
Without numba the same kernel runs as plain Python (slower, same numbers).
"""

from __future__ import annotations

import math

import numpy as np

from delta_pin.compiled.delta_kernels import delta_terms, friction_torque
from delta_pin.compiled.jit import as_record, njit

__all__ = ["adaptive_robust_kernel", "adaptive_robust_law_into"]


@njit(cache=True)
def adaptive_robust_kernel(
    p, cos_phi, sin_phi, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, rho, tau, rho_dot, info
):
    """The step at one state into tau (3,), rho_dot (nr,) and an
    :data:`~delta_pin.compiled.layouts.INFO` record; returns ``info.ok`` (False when the nominal
    model has no FK at ``alpha``: then nothing else is written). ``p`` and ``info`` may come as
    one-record arrays (from Python)."""
    p, info = as_record(p), as_record(info)
    ok, _, _, _, M, C, G = delta_terms(p.geometry, cos_phi, sin_phi, p.m_eq, alpha, alpha_dot)
    info.ok = ok
    if not ok:
        return False
    adaptive_robust_law_into(
        p, M, C, G, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, rho, tau, rho_dot, info
    )
    return True


@njit(cache=True)
def adaptive_robust_law_into(
    p, M, C, G, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, rho, tau, rho_dot, info
):
    """The law given the nominal M̄, C̄, Ḡ at the state (the closed loops compute the kinematics
    once for the controller and the plant), into tau (3,), rho_dot (nr,) and ``info``."""
    D, T_p, T_v = p.D, p.T_p, p.T_v
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
        tau[i] += G[i] + p.disturbance[i]
    if p.friction.on:
        friction = friction_torque(p.friction, alpha_dot, p.normal_force)
        for i in range(3):
            tau[i] += friction[i]
    tau[0] -= T_p[0] * r0 + T_v[0] * rd0
    tau[1] -= T_p[1] * r1 + T_v[1] * rd1
    tau[2] -= T_p[2] * r2 + T_v[2] * rd2
    # Lambda of eq. 67 and its gradient
    kappa0 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    kappa1 = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    vector = p.vector_rho
    if vector:
        Lambda = kappa0 * rho[0] + kappa1 * rho[1] + rho[2]
        gradient_norm = math.sqrt(kappa0 * kappa0 + kappa1 * kappa1 + 1.0)
    else:
        Lambda = (kappa0 + kappa1 + 1.0) * rho[0]
        gradient_norm = kappa0 + kappa1 + 1.0
    s_norm = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    omega_norm = s_norm * Lambda
    xi = p.xi
    if p.design_two:
        phi = omega_norm / (omega_norm * omega_norm + omega_norm * xi + xi * xi)
    elif omega_norm > xi:
        phi = 1.0 / omega_norm
    else:
        phi = 1.0 / xi
    gain = phi * Lambda * Lambda
    if p.sampling_period > 0.0:  # sampling-aware cap per inertia direction
        s = np.array([s0, s1, s2])
        inertia, directions = np.linalg.eigh(M)
        t_v_max = max(T_v[0], max(T_v[1], T_v[2]))
        gains = np.minimum(np.maximum(p.sampling_margin * inertia / p.sampling_period - t_v_max, 0.0), gain)
        c3 = -(directions @ (gains * (directions.T @ s)))
        gain = gains.min()
        robust = info.robust_torque
        robust[0], robust[1], robust[2] = c3[0], c3[1], c3[2]
    else:
        robust = info.robust_torque
        robust[0], robust[1], robust[2] = -gain * s0, -gain * s1, -gain * s2
    # adaptive law, eq. 24 (dead-zone eq. 25)
    decay = p.b2 * math.exp(-s_norm) + p.b3
    active = s_norm * gradient_norm > p.epsilon
    for i in range(rho.shape[0]):
        leak = decay * rho[i]
        if active:
            gradient = (kappa0 if i == 0 else kappa1 if i == 1 else 1.0) if vector else kappa0 + kappa1 + 1.0
            rho_dot[i] = p.beta * (p.b1 * gradient * s_norm - leak)
        else:
            rho_dot[i] = -p.beta * leak
    info.ok = True
    info.Lambda = Lambda
    info.robust_gain = gain
    info.omega_norm = omega_norm
    info.adaptation_active = 1.0 if active else 0.0
    for i in range(3):
        tau[i] += robust[i]

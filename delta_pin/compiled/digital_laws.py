"""Compiled steps of the discrete-time laws: time-delay control and the sampled-data adaptive
robust law, one sample each, on the Delta's analytic nominal model.

The laws are stated (and kept readable, as the reference these kernels are tested against) in
:mod:`delta_pin.control.digital` and :mod:`delta_pin.control.digital_robust`; their parameters come
in a :data:`~delta_pin.compiled.layouts.DIGITAL_LAW` record, their state in the same float vector
the Python classes keep, so that ``Controller.step``, the Python loop and the compiled loop of
:mod:`delta_pin.compiled.digital_loop` run the same arithmetic.
"""

from __future__ import annotations

import math

import numpy as np

from delta_pin.compiled.delta_kernels import delta_terms, friction_torque, solve3
from delta_pin.compiled.jit import as_record, njit
from delta_pin.compiled.layouts import DIGITAL_ROBUST, TDC

__all__ = [
    "digital_law_step",
    "digital_robust_step",
    "law_state_size",
    "smallest_eigenvalue",
    "tdc_step",
]


@njit(cache=True)
def law_state_size(law) -> int:
    """Length of the state vector of a law (as its Python class's ``initial_state``)."""
    law = as_record(law)
    if law.kind == TDC:
        return 6 + 3 * (law.delay + 2) + 1
    return 3 * law.observer_size + 3 * (law.delay + 1) + 12 + 2


@njit(cache=True)
def _nominal(law, cos_phi, sin_phi, alpha, alpha_dot):
    """(ok, M-bar, C-bar, G-bar) at one state."""
    ok, _, _, _, M, C, G = delta_terms(law.geometry, cos_phi, sin_phi, law.m_eq, alpha, alpha_dot)
    return ok, M, C, G


@njit(cache=True)
def _compensation(law, alpha_dot):
    """F-bar + M-bar_f(alpha_dot) (F-bar alone without friction compensation) [N m]."""
    if law.compensation and law.friction.on:
        return law.disturbance + friction_torque(law.friction, alpha_dot, law.normal_force)
    return law.disturbance + np.zeros(3)


@njit(cache=True)
def tdc_step(law, cos_phi, sin_phi, state, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot,
             tau, next_state, info):  # fmt: skip
    """One sample of :class:`~delta_pin.control.digital.TimeDelayControl`: ``tau`` and
    ``next_state`` filled, ``info.lumped_estimate`` set; returns False without an FK solution of
    the nominal model at ``alpha``."""
    law, info = as_record(law), as_record(info)
    d = law.delay
    previous, before = state[0:3], state[3:6]
    commands = state[6 : 6 + 3 * (d + 2)].reshape((d + 2, 3))  # newest first
    seen = state[-1]
    ok, M, C, G = _nominal(law, cos_phi, sin_phi, alpha, alpha_dot)
    info.ok = ok
    if not ok:
        return False
    r, r_dot = alpha - ref_alpha, alpha_dot - ref_alpha_dot
    if seen >= 3:
        acceleration = (alpha - 2.0 * previous + before) / law.dt**2
        acted = 0.5 * (commands[d + 1] + commands[d]) if law.mean_pairing else commands[d].copy()
        lumped = acted - M @ acceleration
    else:
        lumped = C @ alpha_dot + G + law.disturbance
    tau[:] = M @ (ref_alpha_ddot - law.K_v * r_dot - law.K_p * r) + lumped
    next_state[0:3] = alpha
    next_state[3:6] = previous
    next_state[6:9] = tau
    next_state[9 : 6 + 3 * (d + 2)] = state[6 : 3 + 3 * (d + 2)]
    next_state[-1] = min(seen + 1.0, 3.0)
    info.lumped_estimate[:] = lumped
    return True


@njit(cache=True)
def _model(law, cos_phi, sin_phi, estimate):
    """(ok, M-bar, n-bar) at an estimate's angle and velocity (n-bar = C-bar alpha_dot + G-bar +
    F-bar + M-bar_f)."""
    alpha, alpha_dot = estimate[0].copy(), estimate[1].copy()
    ok, M, C, G = _nominal(law, cos_phi, sin_phi, alpha, alpha_dot)
    return ok, M, C @ alpha_dot + G + _compensation(law, alpha_dot)


@njit(cache=True)
def _predict(law, estimate, M, n_bar, torque):
    """The estimate one period later with ``torque`` [N m] acting over it, for the nominal model
    (M-bar, n-bar) at the estimate."""
    size = law.observer_size
    acceleration = solve3(M, torque - n_bar)
    out = np.empty((size, 3))
    for i in range(size):
        for j in range(3):
            value = 0.0
            for m in range(size):
                value += law.transition[i, m] * estimate[m, j]
            out[i, j] = value + law.input_gain[i] * acceleration[j]
    return out


@njit(cache=True)
def smallest_eigenvalue(A):
    """The smallest eigenvalue of a symmetric 3x3 matrix, in closed form (Smith, CACM 1961): the
    same number as ``np.linalg.eigvalsh(A)[0]`` to rounding, without a LAPACK call."""
    p1 = A[0, 1] ** 2 + A[0, 2] ** 2 + A[1, 2] ** 2
    if p1 == 0.0:
        return min(A[0, 0], min(A[1, 1], A[2, 2]))
    q = (A[0, 0] + A[1, 1] + A[2, 2]) / 3.0
    p2 = (A[0, 0] - q) ** 2 + (A[1, 1] - q) ** 2 + (A[2, 2] - q) ** 2 + 2.0 * p1
    p = math.sqrt(p2 / 6.0)
    b00, b11, b22 = (A[0, 0] - q) / p, (A[1, 1] - q) / p, (A[2, 2] - q) / p
    b01, b02, b12 = A[0, 1] / p, A[0, 2] / p, A[1, 2] / p
    r = 0.5 * (b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02))
    r = min(max(r, -1.0), 1.0)
    return q + 2.0 * p * math.cos(math.acos(r) / 3.0 + 2.0 * math.pi / 3.0)


@njit(cache=True)
def digital_robust_step(law, cos_phi, sin_phi, state, alpha, ref_alpha, ref_alpha_dot, ref_alpha_ddot,
                        tau, next_state, info):  # fmt: skip
    """One sample of :class:`~delta_pin.control.digital_robust.DigitalRobustController`: ``tau``
    (the command), ``next_state`` and ``info`` filled; returns False without an FK solution of the
    nominal model where the law evaluates it."""
    law, info = as_record(law), as_record(info)
    d, T, size = law.delay, law.dt, law.observer_size
    n_estimate = 3 * size
    model = n_estimate + 3 * (d + 1)
    estimate = state[0:n_estimate].reshape((size, 3)).copy()
    commands = state[n_estimate:model].reshape((d + 1, 3))  # newest first
    rho, started = state[-2], state[-1]
    info.ok = False
    if started != 0.0:  # the torque that acted over [t_{k-1}, t_k) was commanded at sample k-1-d
        M_last = state[model : model + 9].reshape((3, 3)).copy()
        estimate = _predict(law, estimate, M_last, state[model + 9 : model + 12], commands[d].copy())
        innovation = alpha - estimate[0]
        for i in range(size):
            for j in range(3):
                estimate[i, j] = estimate[i, j] + law.observer_gain[i] * innovation[j]
    else:
        estimate[:, :] = 0.0
        estimate[0] = alpha
    ok, M_estimate, n_estimate_bar = _model(law, cos_phi, sin_phi, estimate)  # kept for the next sample
    if not ok:
        return False
    M, n_bar = M_estimate, n_estimate_bar
    ahead = estimate
    for j in range(d):  # over [t_{k+j}, t_{k+j+1}) acts the command of sample k+j-d
        ahead = _predict(law, ahead, M, n_bar, commands[d - 1 - j].copy())
        ok, M, n_bar = _model(law, cos_phi, sin_phi, ahead)
        if not ok:
            return False
    lead = d * T
    alpha_d = ref_alpha + lead * ref_alpha_dot + 0.5 * lead**2 * ref_alpha_ddot
    alpha_dot_d = ref_alpha_dot + lead * ref_alpha_ddot
    r, r_dot = ahead[0] - alpha_d, ahead[1] - alpha_dot_d
    disturbance = ahead[2].copy()
    command = M @ (ref_alpha_ddot - law.K_v * r_dot - law.K_p * r - disturbance) + n_bar
    s = r_dot + law.D * r
    damper = smallest_eigenvalue(M) / law.layer_time * s
    size_damper = math.sqrt(damper[0] ** 2 + damper[1] ** 2 + damper[2] ** 2)
    robust = -damper if size_damper <= rho else -rho / size_damper * damper
    tau[:] = command + robust
    acting = tau.copy()
    if law.has_limit:
        for i in range(3):
            acting[i] = min(max(tau[i], -law.torque_limit[i]), law.torque_limit[i])
    s_norm = math.sqrt(s[0] ** 2 + s[1] ** 2 + s[2] ** 2)
    leakage = law.b2 * math.exp(-s_norm) + law.b3
    growth = law.b1 * s_norm if s_norm > law.epsilon else 0.0
    rho_next = max(rho + T * law.beta * (growth - leakage * rho), 0.0)
    next_state[0:n_estimate] = estimate.ravel()
    next_state[n_estimate : n_estimate + 3] = acting
    next_state[n_estimate + 3 : model] = state[n_estimate : n_estimate + 3 * d]
    next_state[model : model + 9] = M_estimate.ravel()
    next_state[model + 9 : model + 12] = n_estimate_bar
    next_state[-2] = rho_next
    next_state[-1] = 1.0
    info.ok = True
    info.rho_hat = rho
    info.robust_torque[:] = robust
    info.disturbance_estimate[:] = M @ disturbance
    info.velocity_estimate[:] = estimate[1]
    info.s[:] = s
    return True


@njit(cache=True)
def digital_law_step(law, cos_phi, sin_phi, state, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot,
                     tau, next_state, info):  # fmt: skip
    """The step of whichever law ``law.kind`` names (``alpha_dot``: the measured velocity, which
    the digital robust law does not use)."""
    law = as_record(law)
    if law.kind == DIGITAL_ROBUST:
        return digital_robust_step(
            law,
            cos_phi,
            sin_phi,
            state,
            alpha,
            ref_alpha,
            ref_alpha_dot,
            ref_alpha_ddot,
            tau,
            next_state,
            info,
        )
    return tdc_step(
        law, cos_phi, sin_phi, state, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, tau,
        next_state, info,
    )  # fmt: skip

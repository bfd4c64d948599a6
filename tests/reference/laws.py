"""The readable laws: every built-in controller's arithmetic written as the paper and the module
docstrings of ``delta_pin.control`` write it, in Python -- the oracles the compiled laws
(``delta_pin/core/run/controller.hpp``, ``core/laws/``) are tested against. They were the
package's run-time laws until the core took every law on every nominal model (issue 38); the
package's controllers now evaluate their compiled copy.

:func:`readable_evaluate` gives a controller's readable law; :func:`called_back` a copy of a
controller whose compiled law is hidden, so the core's loops call the readable one back.
"""

from __future__ import annotations

import copy
import math
import types
from dataclasses import dataclass

import numpy as np

from delta_pin.control.adaptive_robust import AdaptiveRobustController
from delta_pin.control.base import ControlOutput, Reference
from delta_pin.control.baselines import LQR, ComputedTorque, PDGravity
from delta_pin.control.digital import TimeDelayControl
from delta_pin.control.digital_robust import DigitalRobustController
from delta_pin.control.pid_gravity import PIDGravity

__all__ = [
    "ComputedTorqueTerms",
    "adaptation_rate",
    "bound",
    "called_back",
    "computed_torque_terms",
    "readable_evaluate",
    "robust_gain_factor",
]


# ------------------------------------------------------------------ C1 + C2 (eqs. 23 and 26)
@dataclass(frozen=True)
class ComputedTorqueTerms:
    """The pieces of C1 + C2 at one instant (SI units).

    Attributes:
        r, r_dot: joint error alpha - alpha^d [rad] and its rate [rad/s] (eq. 14).
        s: the error surface r_dot + D r [rad/s].
        a_ref, v_ref: alpha_ddot^d - D r_dot [rad/s^2] and alpha_dot^d - D r [rad/s].
        M: the nominal inertia M̄ [kg m^2] at the state.
        tau: C1 + C2 [N m].
    """

    r: np.ndarray
    r_dot: np.ndarray
    s: np.ndarray
    a_ref: np.ndarray
    v_ref: np.ndarray
    M: np.ndarray
    tau: np.ndarray


def computed_torque_terms(law: ComputedTorque, alpha, alpha_dot, reference: Reference) -> ComputedTorqueTerms:
    """C1 + C2 and the quantities the robust designs reuse."""
    r = alpha - reference.alpha
    r_dot = alpha_dot - reference.alpha_dot
    a_ref = reference.alpha_ddot - law.D * r_dot
    v_ref = reference.alpha_dot - law.D * r
    M, C, G = law.nominal.terms(alpha, alpha_dot)
    c1 = M @ a_ref + C @ v_ref + G + law.nominal.compensation(alpha_dot, law.friction_compensation)
    c2 = -law.T_p * r - law.T_v * r_dot
    return ComputedTorqueTerms(r, r_dot, r_dot + law.D * r, a_ref, v_ref, M, c1 + c2)


def _computed_torque(law: ComputedTorque, t, alpha, alpha_dot, reference, state) -> ControlOutput:
    return ControlOutput(computed_torque_terms(law, alpha, alpha_dot, reference).tau)


def _pd_gravity(law: PDGravity, t, alpha, alpha_dot, reference, state) -> ControlOutput:
    _, _, G = law.nominal.terms(alpha, alpha_dot)
    return ControlOutput(
        G
        + law.nominal.compensation(alpha_dot, law.friction_compensation)
        - law.K_p * (alpha - reference.alpha)
        - law.K_d * (alpha_dot - reference.alpha_dot)
    )


def _pid_gravity(law: PIDGravity, t, alpha, alpha_dot, reference, state) -> ControlOutput:
    _, _, G = law.nominal.terms(alpha, alpha_dot)
    r = alpha - reference.alpha
    tau = (
        G
        + law.nominal.compensation(alpha_dot, law.friction_compensation)
        - law.K_p * r
        - law.K_i * state
        - law.K_d * (alpha_dot - reference.alpha_dot)
    )
    return ControlOutput(tau, state_derivative=r)


def _lqr(law: LQR, t, alpha, alpha_dot, reference, state) -> ControlOutput:
    error = np.concatenate([alpha - reference.alpha, alpha_dot - reference.alpha_dot])
    return ControlOutput(
        law.G0
        + law.nominal.compensation(alpha_dot, law.friction_compensation)
        + law.dG @ (reference.alpha - law.alpha0)
        + law.M0 @ reference.alpha_ddot
        - law.K @ error
    )


# ------------------------------------------------------------------ designs I and II
def bound(law: AdaptiveRobustController, rho_hat, a_ref, v_ref) -> tuple[float, np.ndarray]:
    """Lambda(rho_hat, ...) of eq. 67 and dLambda/drho (constant: Lambda is linear in rho)."""
    kappa = np.array([math.sqrt(a_ref @ a_ref), math.sqrt(v_ref @ v_ref), 1.0])
    gradient = kappa if law.vector_rho else np.array([kappa.sum()])
    return float(gradient @ rho_hat), gradient


def robust_gain_factor(law: AdaptiveRobustController, omega_norm: float) -> float:
    """phi of eq. 31 (design I) or eq. 56 (design II) for ||omega||."""
    xi = law.gains.xi
    if law.design == "I":
        return 1.0 / omega_norm if omega_norm > xi else 1.0 / xi
    return omega_norm / (omega_norm * omega_norm + omega_norm * xi + xi * xi)


def adaptation_rate(
    law: AdaptiveRobustController, rho_hat, s_norm: float, gradient
) -> tuple[np.ndarray, bool]:
    """rho_hat_dot of eq. 24 and whether the estimate is outside the dead-zone (eq. 25)."""
    g = law.gains
    leak = (g.b2 * math.exp(-s_norm) + g.b3) * rho_hat
    active = s_norm * math.sqrt(gradient @ gradient) > g.epsilon
    if active:
        return g.beta * (g.b1 * gradient * s_norm - leak), True
    return -g.beta * leak, False


def _adaptive_robust(law: AdaptiveRobustController, t, alpha, alpha_dot, reference, state) -> ControlOutput:
    """The law as ``delta_pin.control.adaptive_robust``'s module docstring writes it."""
    nominal = computed_torque_terms(law.computed_torque, alpha, alpha_dot, reference)  # C1 + C2
    s, M = nominal.s, nominal.M
    a_ref, v_ref = nominal.a_ref, nominal.v_ref
    Lambda, gradient = bound(law, state, a_ref, v_ref)
    s_norm = math.sqrt(s @ s)
    omega_norm = s_norm * Lambda
    gain = robust_gain_factor(law, omega_norm) * Lambda * Lambda  # phi Lambda^2 [N m s/rad]
    if law.sampling_period is None:
        c3 = -gain * s
    else:  # per inertia direction: k_j = min(gain, margin mu_j / T - T_v)
        inertia, directions = np.linalg.eigh(M)
        caps = np.maximum(law.sampling_margin * inertia / law.sampling_period - float(law.T_v.max()), 0.0)
        gains = np.minimum(gain, caps)
        c3 = -(directions @ (gains * (directions.T @ s)))
        gain = float(gains.min())
    rate, active = adaptation_rate(law, state, s_norm, gradient)
    return ControlOutput(
        tau=nominal.tau + c3,
        state_derivative=rate,
        internals={
            "rho_hat": state.copy(),
            "Lambda": Lambda,
            "robust_gain": gain,
            "omega_norm": omega_norm,
            "robust_torque": c3,
            "adaptation_active": float(active),
        },
    )


# ------------------------------------------------------------------ the digital laws
def _time_delay_control(law: TimeDelayControl, t, alpha, alpha_dot, reference, state) -> ControlOutput:
    """The law as ``delta_pin.control.digital``'s module docstring writes it."""
    n = law.nominal.dof
    previous, before, commands, seen = state[:n], state[n : 2 * n], state[2 * n : -1], state[-1]
    commands = commands.reshape(law.delay + 2, n)  # newest first: tau_cmd[k-1], ..., [k-2-d]
    r, r_dot = alpha - reference.alpha, alpha_dot - reference.alpha_dot
    M, C, G = law.nominal.terms(alpha, alpha_dot)
    if seen >= 3:
        acceleration = (alpha - 2.0 * previous + before) / law.dt**2
        # the second difference is the mean acceleration over [t_{k-2}, t_k], where the
        # commands of samples k-2-d and k-1-d acted: pair it with their mean
        acted = commands[-2] if law.pairing == "last" else 0.5 * (commands[-1] + commands[-2])
        lumped = acted - M @ acceleration
    else:
        lumped = C @ alpha_dot + G + law.nominal.disturbance()
    tau = M @ (reference.alpha_ddot - law.K_v * r_dot - law.K_p * r) + lumped
    next_state = np.concatenate([alpha, previous, tau, commands[:-1].ravel(), [min(seen + 1.0, 3.0)]])
    return ControlOutput(tau=tau, next_state=next_state, internals={"lumped_estimate": lumped})


def _split(law: DigitalRobustController, state: np.ndarray):
    """Views of a state: (estimate, commands, M-bar and n-bar at the estimate, rho_hat, started)."""
    n, size = law.nominal.dof, law.observer.size
    first = size * n
    model = first + n * (law.delay + 1)
    estimate = state[:first].reshape(size, n)
    commands = state[first:model].reshape(law.delay + 1, n)
    return (
        estimate, commands, state[model : model + n * n].reshape(n, n), state[model + n * n : -2],
        state[-2], state[-1],
    )  # fmt: skip


def _model(law: DigitalRobustController, estimate: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(M̄, n̄) at an estimate's angle and velocity."""
    alpha, alpha_dot = estimate[0], estimate[1]
    M, C, G = law.nominal.terms(alpha, alpha_dot)
    return M, C @ alpha_dot + G + law.nominal.compensation(alpha_dot, law.friction_compensation)


def _digital_robust(law: DigitalRobustController, t, alpha, alpha_dot, reference, state) -> ControlOutput:
    """The law as ``delta_pin.control.digital_robust``'s module docstring writes it (``alpha_dot``
    is not used: the observer's velocity replaces it)."""
    d, T = law.delay, law.dt
    estimate, commands, M_last, n_last, rho, started = _split(law, state)
    if started:  # the torque that acted over [t_{k-1}, t_k) was commanded at sample k-1-d
        predicted = law.observer.predict(estimate, np.linalg.solve(M_last, commands[-1] - n_last))
        estimate = law.observer.correct(predicted, alpha)
    else:
        estimate = law.observer.start(alpha)
    M_estimate, n_estimate = M, n_bar = _model(law, estimate)  # kept for the next sample
    ahead = estimate
    for j in range(d):  # over [t_{k+j}, t_{k+j+1}) acts the command of sample k+j-d
        ahead = law.observer.predict(ahead, np.linalg.solve(M, commands[d - 1 - j] - n_bar))
        M, n_bar = _model(law, ahead)
    lead = d * T  # the reference at t_{k+d}, by its Taylor series
    alpha_d = reference.alpha + lead * reference.alpha_dot + 0.5 * lead**2 * reference.alpha_ddot
    alpha_dot_d = reference.alpha_dot + lead * reference.alpha_ddot
    r, r_dot = ahead[0] - alpha_d, ahead[1] - alpha_dot_d
    disturbance = ahead[2]  # f̂ [rad/s^2]
    tau = M @ (reference.alpha_ddot - law.K_v * r_dot - law.K_p * r - disturbance) + n_bar
    s = r_dot + law.D * r
    damper = np.linalg.eigvalsh(M)[0] / (law.layer_samples * T) * s
    size = float(np.linalg.norm(damper))
    robust = -damper if size <= rho else -rho / size * damper  # the projection on ||v|| <= rho
    tau = tau + robust
    acting = tau if law.torque_limit is None else np.clip(tau, -law.torque_limit, law.torque_limit)
    s_norm = float(np.linalg.norm(s))
    leakage = law.b2 * math.exp(-s_norm) + law.b3
    growth = law.b1 * s_norm if s_norm > law.epsilon else 0.0  # the dead zone, eq. 25
    rho_next = max(rho + T * law.beta * (growth - leakage * rho), 0.0)
    next_state = np.concatenate(
        [estimate.ravel(), acting, commands[:-1].ravel(), M_estimate.ravel(), n_estimate, [rho_next, 1.0]]
    )
    internals = {
        "rho_hat": np.array([rho]),
        "robust_torque": robust,
        "disturbance_estimate": M @ disturbance,
        "velocity_estimate": estimate[1].copy(),
        "s": s,
    }
    return ControlOutput(tau=tau, next_state=next_state, internals=internals)


# the readable law of each built-in controller (its class or a base of it)
READABLE = {
    AdaptiveRobustController: _adaptive_robust,
    ComputedTorque: _computed_torque,
    PDGravity: _pd_gravity,
    PIDGravity: _pid_gravity,
    LQR: _lqr,
    TimeDelayControl: _time_delay_control,
    DigitalRobustController: _digital_robust,
}


def readable_evaluate(controller):
    """``controller``'s readable law as a bound ``evaluate(t, alpha, alpha_dot, reference,
    state) -> ControlOutput`` (torque, state rate or next state, internals), or ``None`` for a
    controller that is not built in (its own ``evaluate`` is its readable law)."""
    for cls in type(controller).__mro__:
        if cls in READABLE:
            return types.MethodType(READABLE[cls], controller)
    return None


def called_back(controller):
    """A copy of ``controller`` without its compiled law (``sampled_core_law()`` is ``None``)
    whose ``evaluate`` is its readable law: the core's loop calls it back."""
    readable = copy.copy(controller)
    readable.sampled_core_law = lambda: None
    law = readable_evaluate(readable)
    if law is not None:
        readable.evaluate = law
    return readable

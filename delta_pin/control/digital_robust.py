"""The paper's adaptive robust design carried into discrete time for a digital drive (issue 13).

The continuous designs I/II (eqs. 23-33) rest on a robust term of gain up to Lambda^2/xi that a
1 kHz zero-order-hold loop cannot carry (docs/architecture.md section 6). This law keeps their
three parts -- a nominal-model computed torque, a robust term of bound rho_hat, the adaptive law
of eqs. 24-25 with leakage and a dead zone -- and adds what a drive needs: an observer in place of
the velocity the drive does not measure and of most of the uncertainty the robust term had to
dominate, a prediction over the computation delay, and an implicit discretisation of the
switching term. At sample k, with the readings alpha_k of the encoders:

1. **Observer** (:class:`~delta_pin.control.observer.ExtendedStateObserver`): per joint
   x = [alpha, alpha_dot, f, f_dot, f_ddot], with the robot written as
   alpha_ddot = M̄^-1 (tau - n̄) + f,   n̄ = C̄ alpha_dot + Ḡ + F̄ + M̄_f(alpha_dot),
   f the lumped acceleration the nominal model misses (time-varying mass, friction and
   disturbance, eqs. 16-20). The estimate is predicted with the torque that acted over the last
   period and corrected by alpha_k.
2. **Prediction over the delay**: with d samples of computation delay the torque computed now acts
   over [t_{k+d}, t_{k+d+1}); the estimate is carried d periods ahead with the d torques already
   commanded, and the reference to t_{k+d} by its Taylor series (a Smith predictor).
3. **Computed torque with disturbance rejection** at the predicted state x̂:
   r = x̂_alpha - alpha^d, r_dot = x̂_alpha_dot - alpha_dot^d,
   tau_0 = M̄ (alpha_ddot^d - K_v r_dot - K_p r - f̂) + n̄,   K_p = omega_c^2, K_v = 2 omega_c.
4. **Robust term, implicitly discretised**: s = r_dot + D r and
   v = -proj_{||v|| <= rho_hat}(K_s s),   K_s = lambda_min(M̄) / (n_s T).
   This is the backward-Euler discretisation of -rho_hat s/||s|| (Acary & Brogliato, Systems &
   Control Letters 2010; Huber et al., CDC 2014): the set-valued sign is replaced by the
   multiplier that would close s in n_s samples, projected on the ball of radius rho_hat. Far from
   s = 0 it is the paper's unit vector times rho_hat; near it, a damper whose discrete pole
   1 - 1/n_s lies in (0, 1), so it does not chatter (n_s = 1 is Acary-Brogliato's one-step law; a
   delayed, noisy loop needs n_s > 1).
5. **Adaptive bound** (eqs. 24-25, forward Euler, with Lambda = rho_hat so dLambda/drho = 1):
   rho_{k+1} = rho_k + T beta [b1 ||s|| - (b2 exp(-||s||) + b3) rho_k]   if ||s|| > epsilon,
   rho_{k+1} = rho_k - T beta (b2 exp(-||s||) + b3) rho_k               otherwise,
   with the dead zone epsilon [rad/s] sized for what the observer leaves at the sample rate: the
   quantisation floor of ||s|| (~ (omega_o + D) q; 0.01 rad/s for a 17-bit encoder) and the O(T)
   residual, so that rho_hat does not grow on noise.

tau = tau_0 + v is the command. Where the drive saturates at ``torque_limit``, the observer is told
the clipped torque that will act, so a saturating drive does not wind it up (the command itself
is left for the drive to clip, so that the drive's count of saturated samples stays true).

**Stability (and its limits).** The argument is the separation one of extended-state-observer
control (Castañeda et al. 2015), not the Lyapunov proof of Theorem 1:
(a) the observer's error obeys e_k = (I - L H) Phi e_{k-1} + w_k, all eigenvalues at
exp(-omega_o T) < 1, driven by f^(3) over a period and by the quantisation (|n| <= q/2): it is
bounded, by O(sup|f^(3)| / omega_o^3) + O(omega_o^N q); (b) with the state predicted over the
delay, the error r obeys the zero-order-hold discretisation of r_ddot + K_v r_dot + K_p r = f - f̂,
stable for omega_c T << 1 (0.06 at the defaults) and driven by the bounded estimation error, so
r is uniformly ultimately bounded; (c) the robust term is bounded by rho_hat and its damper pole
is inside the unit circle, and rho_hat is bounded by the leakage (rho <= b1 sup||s|| / b3).
Limits: f depends on the torque itself where M̄ is wrong, f = (M^-1 M̄ - I) M̄^-1 (tau - n̄) + ...,
an algebraic loop that stays well-posed while ||I - M^-1 M̄|| < 1 (M̄ within a factor of two of
the true inertia; the time-delay-control condition, Youcef-Toumi & Ito 1990); the prediction is
exact only for the nominal model; the argument is not a proof of Theorem 1's bound.

Measured (docs/architecture.md section 6): see :func:`digital_robust`.
"""

from __future__ import annotations

import math

import numpy as np

from delta_pin.control.base import (
    CompiledController,
    check_delay,
    check_period,
    check_torque_limit,
)
from delta_pin.control.nominal import NominalModel, core_law_of
from delta_pin.control.observer import ExtendedStateObserver
from delta_pin.errors import InvalidParameterError

__all__ = ["DigitalRobustController", "digital_robust"]


def _positive(name: str, value: float, unit: str, *, allow_zero: bool = False) -> float:
    number = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if not (number and (value >= 0.0 if allow_zero else value > 0.0)):
        bound = ">= 0" if allow_zero else "> 0"
        raise InvalidParameterError(f"{name}={value!r} must be a finite number {bound} [{unit}]")
    return float(value)


class DigitalRobustController(CompiledController):
    """The sampled-data adaptive robust law of the module docstring, with a discrete-time state.

    Args:
        nominal: the nominal model (M̄, C̄, Ḡ, F̄, M̄_f).
        dt: the sample period T [s] (the loop's ``dt`` must equal it).
        bandwidth: omega_c [rad/s] of the error dynamics (K_p = omega_c^2, K_v = 2 omega_c).
        observer_bandwidth: omega_o [rad/s], the observer's poles.
        observer_order: the disturbance states of the observer (3: f, f_dot, f_ddot).
        D: the error surface's gain [1/s] in s = r_dot + D r (``None``: omega_c).
        delay: samples of computation delay of the drive (predicted over).
        friction_compensation: include M̄_f in n̄.
        rho0: rho_hat(0) [N m].
        beta, b1, b2, b3: the adaptive law's rate, sensitivity and leakage (eq. 24; the paper's
            0.1, 10, 2, 0.3).
        epsilon: the dead zone on ||s|| [rad/s] (eq. 25).
        layer_samples: n_s, the samples over which the robust term's damper closes s (>= 1).
        torque_limit: the drive's saturation [N m] (one value or one per joint): the observer
            is told the clipped torque (``None``: none).
    """

    name = "digital-robust"

    def __init__(
        self,
        nominal: NominalModel,
        dt: float = 1e-3,
        *,
        bandwidth: float = 60.0,
        observer_bandwidth: float = 150.0,
        observer_order: int = 3,
        D: float | None = None,
        delay: int = 0,
        friction_compensation: bool = True,
        rho0: float = 0.0,
        beta: float = 0.1,
        b1: float = 10.0,
        b2: float = 2.0,
        b3: float = 0.3,
        epsilon: float = 0.01,
        layer_samples: float = 8.0,
        torque_limit=None,
    ) -> None:
        self.nominal = nominal
        self.dt = check_period(dt)
        self.delay = check_delay(delay)
        self.bandwidth = _positive("bandwidth", bandwidth, "rad/s")
        self.observer = ExtendedStateObserver(self.dt, observer_bandwidth, observer_order)
        self.D = self.bandwidth if D is None else _positive("D", D, "1/s")
        self.K_p, self.K_v = self.bandwidth**2, 2.0 * self.bandwidth
        self.friction_compensation = bool(friction_compensation)
        self.rho0 = _positive("rho0", rho0, "N m", allow_zero=True)
        self.beta = _positive("beta", beta, "-", allow_zero=True)
        self.b1 = _positive("b1", b1, "-", allow_zero=True)
        self.b2 = _positive("b2", b2, "-", allow_zero=True)
        self.b3 = _positive("b3", b3, "-", allow_zero=True)
        self.epsilon = _positive("epsilon", epsilon, "rad/s", allow_zero=True)
        self.layer_samples = _positive("layer_samples", layer_samples, "samples")
        if self.layer_samples < 1.0:
            raise InvalidParameterError(f"layer_samples={layer_samples!r} must be >= 1 (1: one-step law)")
        self.torque_limit = check_torque_limit(torque_limit, nominal.dof)
        self.reset()

    # state: [estimate (N x n), the last delay + 1 commands newest first, M-bar (n x n) and n-bar (n)
    # at the estimate (the next sample's prediction starts there), rho_hat, started]
    def initial_state(self) -> np.ndarray:
        n, size = self.nominal.dof, self.observer.size
        return np.concatenate([np.zeros(size * n + n * (self.delay + 1) + n * n + n), [self.rho0, 0.0]])

    def sampled_core_law(self):
        """The compiled core's law with its observer (``DigitalRobust`` of
        ``delta_pin/core/run/controller.hpp``, the module docstring's arithmetic) on the nominal
        model (:meth:`NominalModel.core_law <delta_pin.control.nominal.NominalModel.core_law>`; a
        model written in Python is called back)."""
        observer = self.observer
        limit = np.zeros(0) if self.torque_limit is None else self.torque_limit
        gains = {
            "period": self.dt, "delay": self.delay, "K_p": self.K_p, "K_v": self.K_v, "D": self.D,
            "beta": self.beta, "b1": self.b1, "b2": self.b2, "b3": self.b3, "epsilon": self.epsilon,
            "layer_samples": self.layer_samples, "torque_limit": limit, "transition": observer.transition,
            "input_gain": observer.input_gain, "observer_gain": observer.gain,
        }  # fmt: skip
        return core_law_of(
            self.nominal, "DigitalRobust", self.name, gains, friction_compensation=self.friction_compensation
        )

    def metadata(self) -> dict:
        return {
            "name": self.name,
            "dt": self.dt,
            "bandwidth": self.bandwidth,
            "observer_bandwidth": self.observer.bandwidth,
            "observer_order": self.observer.order,
            "D": self.D,
            "delay": self.delay,
            "friction_compensation": self.friction_compensation,
            "rho0": self.rho0,
            "beta": self.beta,
            "b1": self.b1,
            "b2": self.b2,
            "b3": self.b3,
            "epsilon": self.epsilon,
            "layer_samples": self.layer_samples,
            "torque_limit": None if self.torque_limit is None else self.torque_limit.tolist(),
            "nominal": self.nominal.metadata(),
        }


def digital_robust(nominal: NominalModel, dt: float = 1e-3, **options) -> DigitalRobustController:
    """The sampled-data adaptive robust controller (:class:`DigitalRobustController`) at sample
    period ``dt`` [s]; ``options`` are its keyword arguments."""
    return DigitalRobustController(nominal, dt, **options)

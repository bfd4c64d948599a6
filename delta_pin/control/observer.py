"""A discrete-time extended-state observer: joint angle, velocity and the lumped disturbance.

Each joint is modelled as a chain of integrators driven by the known acceleration u [rad/s^2]
and an unknown one f (everything the nominal model misses), with f's first ``order - 1``
derivatives as extra states (a generalised-proportional-integral, or extended-state, observer;
Castañeda, Luviano-Juárez & Chairez, IEEE TCST 2015 on a Delta):

    x = [alpha, alpha_dot, f, f_dot, ..., f^(order-1)],   x_{k+1} = Phi x_k + Gamma u_k,

Phi the exact discretisation of the chain over the sample period T (Phi_ij = T^(j-i)/(j-i)!,
j >= i) and Gamma = [T^2/2, T, 0, ...]: exact for u held over the period and f^(order) = 0.
Only the angle is measured (y = alpha). The current estimator (Franklin, Powell & Workman,
*Digital Control of Dynamic Systems*, section 8.2) corrects each prediction with the new reading,

    x_pred = Phi x_{k-1} + Gamma u_{k-1},    x_k = x_pred + L (y_k - x_pred[0]),

and L places every eigenvalue of the error dynamics e_k = (I - L H) Phi e_{k-1} at
z = exp(-omega_o T) (Ackermann's formula), i.e. a continuous-time pole of multiplicity
``order + 2`` at -omega_o [rad/s]. The error is then driven by f^(order) only: with f of the size
and rate of this robot's uncertainty, ``order = 3`` (f, f_dot, f_ddot) at omega_o = 150 rad/s
leaves a tenth of the tracking error ``order = 1`` leaves (docs/architecture.md section 6).
Measurement noise n reaches f̂ through omega_o^N s^2 / (s + omega_o)^N (N = order + 2): a
low-pass of order N - 2, so the quantised readings of an encoder do not make the torque rough.
"""

from __future__ import annotations

import math

import numpy as np

from delta_pin.errors import InvalidParameterError

__all__ = ["ExtendedStateObserver"]


class ExtendedStateObserver:
    """The observer's matrices for sample period ``dt`` [s], bandwidth ``bandwidth`` (omega_o
    [rad/s]) and ``order`` (how many disturbance states: f, f_dot, ...; 1 to 4).

    The observer keeps no state itself: its estimate is an array (N, n) -- N = order + 2 rows
    (alpha, alpha_dot, f, ...), one column per joint -- that the controller owns.

    Attributes:
        size: N = order + 2, the states per joint.
        transition: Phi (N, N).
        input_gain: Gamma (N,), the states' response to an acceleration held over a period.
        gain: L (N,), the current estimator's correction gain.
    """

    def __init__(self, dt: float, bandwidth: float, order: int = 3) -> None:
        if not (isinstance(order, int) and 1 <= order <= 4):
            raise InvalidParameterError(f"observer order={order!r} must be an integer from 1 to 4")
        if not (math.isfinite(bandwidth) and bandwidth > 0.0):
            raise InvalidParameterError(
                f"observer_bandwidth={bandwidth!r} must be a positive angular frequency [rad/s]"
            )
        self.dt, self.bandwidth, self.order = float(dt), float(bandwidth), order
        self.size = size = order + 2
        self.transition = np.zeros((size, size))
        for i in range(size):
            for j in range(i, size):
                self.transition[i, j] = dt ** (j - i) / math.factorial(j - i)
        self.input_gain = np.zeros(size)
        self.input_gain[:2] = (0.5 * dt * dt, dt)
        self.gain = self._ackermann(math.exp(-bandwidth * dt))

    def _ackermann(self, pole: float) -> np.ndarray:
        """L = a(Phi) [H Phi; H Phi^2; ...; H Phi^N]^-1 e_N with a(z) = (z - pole)^N."""
        phi, size = self.transition, self.size
        powers = [np.linalg.matrix_power(phi, i) for i in range(1, size + 1)]
        observability = np.vstack([power[0] for power in powers])  # H = [1, 0, ..., 0]
        characteristic = np.linalg.matrix_power(phi - pole * np.eye(size), size)
        last = np.zeros(size)
        last[-1] = 1.0
        return characteristic @ np.linalg.solve(observability, last)

    def start(self, alpha: np.ndarray) -> np.ndarray:
        """The estimate at the first reading: at ``alpha`` [rad], at rest, no disturbance."""
        estimate = np.zeros((self.size, len(alpha)))
        estimate[0] = alpha
        return estimate

    def predict(self, estimate: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        """The estimate one period later, for the known ``acceleration`` u [rad/s^2] held over it."""
        return self.transition @ estimate + np.outer(self.input_gain, acceleration)

    def correct(self, predicted: np.ndarray, alpha_measured: np.ndarray) -> np.ndarray:
        """The predicted estimate corrected by a reading of the angles [rad]."""
        return predicted + np.outer(self.gain, alpha_measured - predicted[0])

    def error_eigenvalues(self) -> np.ndarray:
        """Eigenvalues of the error dynamics (I - L H) Phi (all exp(-omega_o T) by design)."""
        correction = np.eye(self.size)
        correction[:, 0] -= self.gain
        return np.linalg.eigvals(correction @ self.transition)

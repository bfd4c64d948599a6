"""Baseline controllers to compare the adaptive robust designs with.

* :class:`ComputedTorque` -- C1 + C2 of the paper (eqs. 23, 26): the adaptive robust designs
  without their robust term;
* :class:`PDGravity` -- PD on the joint error plus gravity (and nominal disturbance) compensation;
* :class:`LQR` -- an infinite-horizon LQR on the nominal model linearised at one configuration
  (the path's start): x = [r, r_dot], A = [[0, I], [-M̄0^-1 dḠ/dalpha, 0]], B = [0; M̄0^-1];
  gain K = R^-1 B^T P from scipy's continuous Riccati solver; torque
  tau = Ḡ(alpha0) + F̄ + dḠ/dalpha (alpha^d - alpha0) + M̄0 alpha_ddot^d - K x (+ M̄_f).
  It knows only the linear model: no Coriolis term, M̄ and Ḡ frozen at alpha0 (their first-order
  change in Ḡ excepted). Default weights Q = diag(100 I, I), R = 0.01 I give K_p = 100 N m/rad and
  K_d ~ 10 N m s/rad, the stiffness and damping scale of design I's PD part (T_p + D T_v = 84,
  T_v + D M̄ ~ 9.3) so the comparison is about the model, not the gains.
  Its law runs compiled, in the core (:meth:`LQR.sampled_core_law`, on any nominal model); the
  readable law it is tested against lives in ``tests/reference/laws.py``.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_continuous_are

from delta_pin.control.base import CompiledController
from delta_pin.control.nominal import NominalModel, core_law_of
from delta_pin.errors import InvalidParameterError

__all__ = ["LQR", "ComputedTorque", "PDGravity"]


def _positive_diagonal(value, dof: int, name: str) -> np.ndarray:
    array = np.broadcast_to(np.asarray(value, dtype=float), (dof,)).copy()
    if not np.all(np.isfinite(array)) or np.any(array <= 0.0):
        raise InvalidParameterError(f"gain {name}={value!r} must be finite and > 0")
    return array


class ComputedTorque(CompiledController):
    """C1 + C2 (eqs. 23 and 26) on a nominal model: tau = M̄ (alpha_ddot^d - D r_dot) +
    C̄ (alpha_dot^d - D r) + Ḡ + F̄ [+ M̄_f] - T_p r - T_v r_dot. Designs I and II add their robust
    term to exactly this."""

    name = "ctc"

    def __init__(self, nominal: NominalModel, *, D=9.0, T_p=3.0, T_v=9.0, friction_compensation: bool = True):
        self.nominal = nominal
        n = nominal.dof
        self.D = _positive_diagonal(D, n, "D")
        self.T_p = _positive_diagonal(T_p, n, "T_p")
        self.T_v = _positive_diagonal(T_v, n, "T_v")
        self.friction_compensation = friction_compensation

    def sampled_core_law(self):
        """The compiled core's C1 + C2 on the nominal model."""
        gains = {"D": self.D, "T_p": self.T_p, "T_v": self.T_v}
        return core_law_of(
            self.nominal, "ComputedTorque", self.name, gains, friction_compensation=self.friction_compensation
        )

    def metadata(self):
        return {
            "name": self.name,
            "D": self.D.tolist(),
            "T_p": self.T_p.tolist(),
            "T_v": self.T_v.tolist(),
            "friction_compensation": self.friction_compensation,
            "nominal": self.nominal.metadata(),
        }


class PDGravity(CompiledController):
    """tau = Ḡ(alpha) + F̄ [+ M̄_f] - K_p r - K_d r_dot [N m]; K_p [N m/rad], K_d [N m s/rad]."""

    name = "pd"

    def __init__(self, nominal: NominalModel, *, K_p=100.0, K_d=10.0, friction_compensation: bool = True):
        self.nominal = nominal
        self.K_p = _positive_diagonal(K_p, nominal.dof, "K_p")
        self.K_d = _positive_diagonal(K_d, nominal.dof, "K_d")
        self.friction_compensation = friction_compensation

    def sampled_core_law(self):
        """The compiled core's PD + gravity on the nominal model."""
        gains = {"K_p": self.K_p, "K_d": self.K_d}
        return core_law_of(
            self.nominal, "PDGravity", self.name, gains, friction_compensation=self.friction_compensation
        )

    def metadata(self):
        return {
            "name": self.name,
            "K_p": self.K_p.tolist(),
            "K_d": self.K_d.tolist(),
            "friction_compensation": self.friction_compensation,
            "nominal": self.nominal.metadata(),
        }


class LQR(CompiledController):
    """LQR on the nominal model linearised at ``alpha_linearisation`` (see the module docstring).

    Args:
        nominal: the nominal model.
        alpha_linearisation: configuration of the linearisation [rad] (the path's start).
        Q: state weight (2n,) diagonal or (2n, 2n) on [r, r_dot]; R: input weight (n,) or (n, n).
        friction_compensation: add the nominal friction M̄_f(alpha_dot).
    """

    name = "lqr"

    def __init__(
        self,
        nominal: NominalModel,
        alpha_linearisation,
        *,
        Q=None,
        R=None,
        friction_compensation: bool = True,
    ) -> None:
        n = nominal.dof
        self.nominal = nominal
        self.alpha0 = np.asarray(alpha_linearisation, dtype=float).reshape(n)
        self.Q = self._weight(np.concatenate([np.full(n, 100.0), np.ones(n)]) if Q is None else Q, 2 * n, "Q")
        self.R = self._weight(np.full(n, 0.01) if R is None else R, n, "R")
        self.friction_compensation = friction_compensation
        zero = np.zeros(n)
        M0, _, self.G0 = nominal.terms(self.alpha0, zero)
        h = 1e-6  # [rad] central differences of the nominal gravity
        self.dG = np.column_stack(
            [
                (nominal.terms(self.alpha0 + h * e, zero)[2] - nominal.terms(self.alpha0 - h * e, zero)[2])
                / (2 * h)
                for e in np.eye(n)
            ]
        )
        self.M0 = M0
        M0_inv = np.linalg.inv(M0)
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-M0_inv @ self.dG, np.zeros((n, n))]])
        B = np.vstack([np.zeros((n, n)), M0_inv])
        P = solve_continuous_are(A, B, self.Q, self.R)
        self.K = np.linalg.solve(self.R, B.T @ P)
        self.closed_loop_poles = np.linalg.eigvals(A - B @ self.K)

    @staticmethod
    def _weight(value, size: int, name: str) -> np.ndarray:
        matrix = np.asarray(value, dtype=float)
        matrix = np.diag(matrix) if matrix.ndim == 1 else matrix
        if matrix.shape != (size, size) or not np.all(np.isfinite(matrix)):
            raise InvalidParameterError(f"LQR weight {name} must be ({size},) or ({size}, {size}) and finite")
        if np.linalg.eigvalsh(0.5 * (matrix + matrix.T)).min() <= 0.0:
            raise InvalidParameterError(f"LQR weight {name}={value!r} must be positive definite")
        return matrix

    def sampled_core_law(self):
        """The compiled core's LQR (``LQR`` of ``delta_pin/core/run/controller.hpp``, the module
        docstring's arithmetic with this linearisation and gain) on the nominal model."""
        gains = {
            "alpha0": self.alpha0,
            "gravity": self.G0,
            "gravity_slope": self.dG,
            "inertia": self.M0,
            "gain": self.K,
        }
        return core_law_of(
            self.nominal, "LQR", self.name, gains, friction_compensation=self.friction_compensation
        )

    def metadata(self):
        return {
            "name": self.name,
            "alpha_linearisation": self.alpha0.tolist(),
            "Q": self.Q.tolist(),
            "R": self.R.tolist(),
            "K": self.K.tolist(),
            "friction_compensation": self.friction_compensation,
            "nominal": self.nominal.metadata(),
        }

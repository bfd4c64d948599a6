"""The paper's adaptive robust controllers: design I (eq. 33) and design II (eq. 54).

With r = alpha - alpha^d (eq. 14), s = r_dot + D r and the nominal model (M̄, C̄, Ḡ, F̄, M̄_f):

    C1 = M̄ (alpha_ddot^d - D r_dot) + C̄ (alpha_dot^d - D r) + Ḡ + F̄ + M̄_f       (eq. 23)
    C2 = -T_p r - T_v r_dot                                                    (eq. 26)
    Lambda = rho_hat (||alpha_ddot^d - D r_dot|| + ||alpha_dot^d - D r|| + 1)   (eq. 67, scalar rho)
    omega = s Lambda                                                           (eqs. 32, 57)
    C3 = C4 = -phi omega Lambda                                                (eqs. 30, 55; erratum 2)
    design I:  phi = 1/||omega|| if ||omega|| > xi, else 1/xi                   (eq. 31)
    design II: phi = ||omega|| / (||omega||^2 + ||omega|| xi + xi^2)            (eq. 56; erratum 3)

and the bound estimate follows the adaptive law with exponential leakage and dead-zone (eq. 24):

    rho_hat_dot = beta [b1 dLambda/drho^T ||s|| - (b2 exp(-||s||) + b3) rho_hat]
                                                   if ||s|| ||dLambda/drho|| > epsilon,
    rho_hat_dot = -beta (b2 exp(-||s||) + b3) rho_hat     otherwise (the dead-zone, eq. 25).

Signs: the paper prints C3 = +phi omega Lambda; its own proof (eq. 39) needs the minus sign, and
the printed sign destabilises (docs/architecture.md section 4, erratum 2). With ``vector_rho=True`` Lambda is
rho_1 ||alpha_ddot^d - D r_dot|| + rho_2 ||alpha_dot^d - D r|| + rho_3 with a 3-vector rho_hat
(the first line of eq. 67; erratum 7).

Sampling-aware option. In the boundary layer the robust term is a linear damper on s with gain
k = phi Lambda^2 (up to Lambda^2 / xi = 2000 N m s/rad for xi = 1e-3 and Lambda ~ 1.4). A
zero-order-hold loop with period T acting on an inertia m is stable only while k T / m < 2
(s_{k+1} = (1 - k T / m) s_k), so with m ~ 0.03 kg m^2 and T = 1 ms the paper's gains put the
discrete pole near -65: the sampled loop loses stability. Given ``sampling_period=T`` the robust
gain is capped so that the total damping on s stays inside the stable, well-damped region:

    (T_v + k) T / lambda_min(M̄) <= sampling_margin  (0.5 by default: discrete pole at >= 0.5).

The cap is the same as widening the boundary layer to xi_eff = Lambda^2 / k_max >= xi; the proof
of Theorem 1 then holds with xi_eff in gamma_4 = xi_eff/4 + ..., i.e. uniform ultimate
boundedness with a larger ball, now actually reachable by a digital drive.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np

from delta_pin.control.base import CompiledController
from delta_pin.control.baselines import ComputedTorque
from delta_pin.control.nominal import NominalModel, core_law_of
from delta_pin.errors import InvalidParameterError

__all__ = ["AdaptiveRobustController", "AdaptiveRobustGains", "design1", "design2"]

DESIGNS = ("I", "II")


@dataclass(frozen=True)
class AdaptiveRobustGains:
    """Gains of designs I and II; defaults are the paper's Section V values.

    Attributes:
        T_v: derivative gain [N m s/rad] (scalar or per joint, T_v = diag(9, 9, 9)).
        T_p: proportional gain [N m/rad] (T_p = diag(3, 3, 3)).
        D: error-surface gain [1/s] (D = diag(9, 9, 9)).
        beta: adaptation rate beta [-] (0.1).
        xi: boundary layer of phi [N m] (0.001).
        epsilon: dead-zone of the adaptive law (0.05).
        b1, b2, b3: adaptation sensitivity and leakage gains (10, 2, 0.3).
        rho0: initial estimate rho_hat(0) (2; the paper's text also says 0.02, erratum 5).
    """

    T_v: float | tuple = 9.0
    T_p: float | tuple = 3.0
    D: float | tuple = 9.0
    beta: float = 0.1
    xi: float = 0.001
    epsilon: float = 0.05
    b1: float = 10.0
    b2: float = 2.0
    b3: float = 0.3
    rho0: float = 2.0

    def __post_init__(self) -> None:
        for field in fields(self):
            value = np.asarray(getattr(self, field.name), dtype=float)
            if not np.all(np.isfinite(value)) or np.any(value <= 0.0):
                raise InvalidParameterError(
                    f"gain {field.name}={getattr(self, field.name)!r} must be finite and > 0"
                )


class AdaptiveRobustController(CompiledController):
    """Design I or II on any nominal model (see the module docstring for the law; its compiled
    copy is what runs, :class:`~delta_pin.control.base.CompiledController`).

    Args:
        nominal: what the controller knows (:class:`~delta_pin.control.nominal.NominalModel`).
        design: ``"I"`` (eq. 33) or ``"II"`` (eq. 54).
        gains: :class:`AdaptiveRobustGains` (the paper's by default).
        friction_compensation: include M̄_f in C1 (eq. 23).
        vector_rho: Lambda with a 3-vector rho_hat instead of the scalar bound of eq. 67.
        sampling_period: control period T [s] of a digital drive: caps the robust gain (the
            sampling-aware option); ``None`` applies the paper's law unchanged.
        sampling_margin: bound on (T_v + k) T / lambda_min(M̄) for the cap (0 < margin < 2).
    """

    def __init__(
        self,
        nominal: NominalModel,
        design: str = "I",
        gains: AdaptiveRobustGains | None = None,
        *,
        friction_compensation: bool = True,
        vector_rho: bool = False,
        sampling_period: float | None = None,
        sampling_margin: float = 1.0,
    ) -> None:
        if design not in DESIGNS:
            raise InvalidParameterError(f"design={design!r} must be one of {', '.join(DESIGNS)}")
        if sampling_period is not None and not sampling_period > 0.0:
            raise InvalidParameterError(f"sampling_period={sampling_period!r} must be > 0")
        if not 0.0 < sampling_margin < 2.0:
            raise InvalidParameterError(f"sampling_margin={sampling_margin!r} must lie in (0, 2)")
        self.nominal = nominal
        self.design = design
        self.gains = gains or AdaptiveRobustGains()
        self.friction_compensation = friction_compensation
        self.vector_rho = vector_rho
        self.sampling_period = sampling_period
        self.sampling_margin = sampling_margin
        self.computed_torque = ComputedTorque(
            nominal,
            D=self.gains.D,
            T_p=self.gains.T_p,
            T_v=self.gains.T_v,
            friction_compensation=friction_compensation,
        )
        self.T_v = self.computed_torque.T_v
        self.name = f"design{design}"
        self.reset()

    def initial_state(self) -> np.ndarray:
        return np.full(3 if self.vector_rho else 1, self.gains.rho0)

    def sampled_core_law(self):
        """The compiled core's design I/II on the nominal model (``AdaptiveRobust`` of
        ``delta_pin/core/run/controller.hpp``, the module docstring's arithmetic) on the
        nominal model (:meth:`NominalModel.core_law
        <delta_pin.control.nominal.NominalModel.core_law>`; a model written in Python is called
        back)."""
        ctc, g = self.computed_torque, self.gains
        gains = {
            "D": ctc.D, "T_p": ctc.T_p, "T_v": ctc.T_v, "beta": g.beta, "xi": g.xi, "epsilon": g.epsilon,
            "b1": g.b1, "b2": g.b2, "b3": g.b3, "design_two": self.design == "II",
            "vector_rho": self.vector_rho, "sampling_period": self.sampling_period or 0.0,
            "sampling_margin": self.sampling_margin,
        }  # fmt: skip
        return core_law_of(
            self.nominal, "AdaptiveRobust", self.name, gains, friction_compensation=self.friction_compensation
        )

    def boundary_layer(self, alpha_dot_d: np.ndarray, alpha_ddot_d: np.ndarray) -> float:
        """Thinnest boundary layer [rad/s] in s along a reference (N, 3): xi / Lambda_max, with
        Lambda of eq. 67 at perfect tracking and rho_hat_0. A continuous-mode integrator has to
        resolve it (the LSODA reference of ``tests/reference`` tightens its rtol to do so): ~7e-5
        rad/s on path II, ~1.4e-5 on path I, ~4e-6 on the Adept cycle (87 rad/s^2: Lambda ~240)."""
        kappa = np.stack(
            [
                np.linalg.norm(alpha_ddot_d, axis=-1),
                np.linalg.norm(alpha_dot_d, axis=-1),
                np.ones(len(alpha_dot_d)),
            ],
            axis=-1,
        )
        rho0 = self.initial_state()
        largest = float((kappa @ rho0 if self.vector_rho else kappa.sum(axis=-1) * rho0[0]).max())
        return self.gains.xi / largest

    def metadata(self) -> dict:
        gains = {k: (np.asarray(v).tolist()) for k, v in asdict(self.gains).items()}
        return {
            "name": self.name,
            "design": self.design,
            "gains": gains,
            "friction_compensation": self.friction_compensation,
            "vector_rho": self.vector_rho,
            "sampling_period": self.sampling_period,
            "sampling_margin": self.sampling_margin,
            "nominal": self.nominal.metadata(),
        }


def design1(nominal: NominalModel, **options) -> AdaptiveRobustController:
    """Design I (C1 + C2 + C3, eq. 33); ``options`` as :class:`AdaptiveRobustController`, gains by name."""
    return _make("I", nominal, options)


def design2(nominal: NominalModel, **options) -> AdaptiveRobustController:
    """Design II (C1 + C2 + C4, eq. 54); ``options`` as :class:`AdaptiveRobustController`, gains by name."""
    return _make("II", nominal, options)


def _make(design: str, nominal: NominalModel, options: dict) -> AdaptiveRobustController:
    gain_names = {f.name for f in fields(AdaptiveRobustGains)}
    gains = {k: options.pop(k) for k in list(options) if k in gain_names}
    base = options.pop("gains", None) or AdaptiveRobustGains()
    return AdaptiveRobustController(
        nominal, design, AdaptiveRobustGains(**{**asdict(base), **gains}), **options
    )

"""PID + gravity in joint space: the example of a law added through the declarations (issue 38).

    tau = Ḡ(alpha) + F̄ [+ M̄_f(alpha_dot)] - K_p r - K_i z - K_d r_dot,   z_dot = r = alpha - alpha^d

with the integral z [rad s] the law's continuous-time state (z(0) = 0). The integral removes the
steady error a PD + gravity law keeps under a constant unmodelled torque. Its compiled twin is
``delta_pin/core/laws/pid_gravity.cpp``, the law that runs; its readable twin, the reference it is
tested against, is ``tests/reference/laws.py``'s. The module declares itself (``DECLARATION``),
which the registry collects.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from delta_pin.control.base import CompiledController
from delta_pin.control.declaration import FRICTION_COMPENSATION, ControllerDeclaration, LawOptions
from delta_pin.control.nominal import NominalModel, core_law_of
from delta_pin.errors import InvalidParameterError

__all__ = ["DECLARATION", "PIDGravity"]


def _gain(value, dof: int, name: str, *, zero: bool = False) -> np.ndarray:
    array = np.broadcast_to(np.asarray(value, dtype=float), (dof,)).copy()
    if not np.all(np.isfinite(array)) or np.any(array < 0.0 if zero else array <= 0.0):
        raise InvalidParameterError(f"gain {name}={value!r} must be finite and {'>=' if zero else '>'} 0")
    return array


class PIDGravity(CompiledController):
    """PID + gravity (module docstring); K_p [N m/rad], K_i [N m/(rad s)] (0: PD + gravity),
    K_d [N m s/rad]."""

    name = "pid"

    def __init__(
        self, nominal: NominalModel, *, K_p=100.0, K_i=50.0, K_d=10.0, friction_compensation: bool = True
    ) -> None:
        self.nominal = nominal
        self.K_p = _gain(K_p, nominal.dof, "K_p")
        self.K_i = _gain(K_i, nominal.dof, "K_i", zero=True)
        self.K_d = _gain(K_d, nominal.dof, "K_d")
        self.friction_compensation = friction_compensation

    def initial_state(self) -> np.ndarray:
        return np.zeros(self.nominal.dof)  # the integral of r [rad s]

    def sampled_core_law(self):
        """The compiled core's PID + gravity where the nominal model has one there."""
        gains = {"K_p": self.K_p, "K_i": self.K_i, "K_d": self.K_d}
        return core_law_of(
            self.nominal, "PIDGravity", self.name, gains, friction_compensation=self.friction_compensation
        )

    def metadata(self):
        return {
            "name": self.name,
            "K_p": self.K_p.tolist(),
            "K_i": self.K_i.tolist(),
            "K_d": self.K_d.tolist(),
            "friction_compensation": self.friction_compensation,
            "nominal": self.nominal.metadata(),
        }


def _build(nominal: NominalModel, options: LawOptions, gains: Mapping) -> CompiledController:
    return PIDGravity(nominal, friction_compensation=options.friction_compensation, **gains)


DECLARATION = ControllerDeclaration(
    "pid", "PID", PIDGravity, _build, options=frozenset({FRICTION_COMPENSATION}), compiled_continuous=True
)

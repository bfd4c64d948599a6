"""Controllers: one shared base (:mod:`.base`), one module per control law."""

from delta_pin.control.adaptive_robust import AdaptiveRobustController, AdaptiveRobustGains, design1, design2
from delta_pin.control.base import (
    CallableController,
    CompiledController,
    Controller,
    ControlOutput,
    Reference,
    as_controller,
)
from delta_pin.control.baselines import LQR, ComputedTorque, PDGravity
from delta_pin.control.digital import TimeDelayControl, tdc
from delta_pin.control.digital_robust import DigitalRobustController, digital_robust
from delta_pin.control.nominal import (
    ClosedChainNominalModel,
    DeltaNominalModel,
    NominalModel,
    PinocchioNominalModel,
)

__all__ = [
    "LQR",
    "AdaptiveRobustController",
    "AdaptiveRobustGains",
    "CallableController",
    "ClosedChainNominalModel",
    "CompiledController",
    "ComputedTorque",
    "ControlOutput",
    "Controller",
    "DeltaNominalModel",
    "DigitalRobustController",
    "NominalModel",
    "PDGravity",
    "PinocchioNominalModel",
    "Reference",
    "TimeDelayControl",
    "as_controller",
    "design1",
    "design2",
    "digital_robust",
    "tdc",
]

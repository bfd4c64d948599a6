"""delta-pin: model-based control of Delta parallel robots, built on Pinocchio.

The public names below are imported on first use (PEP 562), so that ``import delta_pin.X`` or a
command such as ``delta-pin validate`` loads only the modules it needs (no SciPy, numba or
controllers for a validation); ``delta_pin.Name`` and ``from delta_pin import Name`` work as usual.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING

from .errors import (
    AssemblyError,
    DeltaPinError,
    ForwardKinematicsError,
    InvalidParameterError,
    NonFiniteError,
    SimulationError,
    UnreachablePoseError,
    URDFConventionError,
    XacroArgumentError,
)

if TYPE_CHECKING:
    from .batch import simulate_batch
    from .control import (
        LQR,
        AdaptiveRobustController,
        AdaptiveRobustGains,
        ComputedTorque,
        Controller,
        DeltaNominalModel,
        PDGravity,
        PinocchioNominalModel,
        design1,
        design2,
    )
    from .description import DeltaParameters, StribeckParameters, compile_urdf
    from .dynamics import ReducedDynamics
    from .plant import AnalyticPlant, Friction, PinocchioPlant, Plant
    from .robot import Delta, load_delta
    from .simulate import Run, load_run, simulate
    from .trajectory import (
        AdeptCycle,
        JointReference,
        PathI,
        PathII,
        SplinePath,
        Trajectory,
        check_workspace,
    )
    from .uncertainty import (
        FunctionUncertainty,
        NoUncertainty,
        PaperUncertainty,
        RandomUncertainty,
        Uncertainty,
    )

__version__ = "0.1.0"


__all__ = [
    "LQR",
    "AdaptiveRobustController",
    "AdaptiveRobustGains",
    "AdeptCycle",
    "AnalyticPlant",
    "AssemblyError",
    "ComputedTorque",
    "Controller",
    "Delta",
    "DeltaNominalModel",
    "DeltaParameters",
    "DeltaPinError",
    "ForwardKinematicsError",
    "Friction",
    "FunctionUncertainty",
    "InvalidParameterError",
    "JointReference",
    "NoUncertainty",
    "NonFiniteError",
    "PDGravity",
    "PaperUncertainty",
    "PathI",
    "PathII",
    "PinocchioNominalModel",
    "PinocchioPlant",
    "Plant",
    "RandomUncertainty",
    "ReducedDynamics",
    "Run",
    "SimulationError",
    "SplinePath",
    "StribeckParameters",
    "Trajectory",
    "URDFConventionError",
    "Uncertainty",
    "UnreachablePoseError",
    "XacroArgumentError",
    "check_workspace",
    "compile_urdf",
    "design1",
    "design2",
    "load_delta",
    "load_run",
    "simulate",
    "simulate_batch",
]

# submodule -> the public names it defines (the errors above are imported eagerly: they are tiny)
_SUBMODULES = {
    "control": (
        "LQR",
        "AdaptiveRobustController",
        "AdaptiveRobustGains",
        "ComputedTorque",
        "Controller",
        "DeltaNominalModel",
        "PDGravity",
        "PinocchioNominalModel",
        "design1",
        "design2",
    ),
    "batch": ("simulate_batch",),
    "description": ("DeltaParameters", "StribeckParameters", "compile_urdf"),
    "dynamics": ("ReducedDynamics",),
    "plant": ("AnalyticPlant", "Friction", "PinocchioPlant", "Plant"),
    "robot": ("Delta", "load_delta"),
    "simulate": ("Run", "load_run", "simulate"),
    "trajectory": (
        "AdeptCycle",
        "JointReference",
        "PathI",
        "PathII",
        "SplinePath",
        "Trajectory",
        "check_workspace",
    ),
    "uncertainty": (
        "FunctionUncertainty",
        "NoUncertainty",
        "PaperUncertainty",
        "RandomUncertainty",
        "Uncertainty",
    ),
}
_LAZY = {name: module for module, names in _SUBMODULES.items() for name in names}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is not None:
        value = getattr(importlib.import_module(f".{module}", __name__), name)
    elif not name.startswith("_"):  # a submodule, e.g. delta_pin.kinematics
        try:
            value = importlib.import_module(f".{name}", __name__)
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


class _Package(types.ModuleType):
    """Keeps ``delta_pin.simulate`` the function when its submodule ``delta_pin.simulate`` is
    first imported (the import system binds a new submodule to the package attribute of the same
    name; the eager imports used to rebind the function right after)."""

    def __setattr__(self, name: str, value: object) -> None:
        if name in _LAZY and isinstance(value, types.ModuleType):
            return  # the public function of that name stays (loaded by __getattr__ when used)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package

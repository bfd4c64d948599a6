"""delta-pin: model-based control of Delta parallel robots, built on Pinocchio.

The public API is the table :data:`_PUBLIC` below: each name ``dp.X`` and the module that defines
it. The table makes ``__all__`` and loads each module on first use (PEP 562), so that a command
such as ``delta-pin validate`` imports only what it needs (no SciPy, compiled core or controllers for a
validation). The layers behind it (``model``, ``control``, ``sim``, ``studies``, ``viz``; private
``compiled``) are described in docs/architecture.md section 2.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from delta_pin import errors
from delta_pin.errors import (
    AssemblyError,
    DeltaPinError,
    ForwardKinematicsError,
    InvalidParameterError,
    MeshFileError,
    NativeUnavailableError,
    NonFiniteError,
    OptionalDependencyError,
    PlanningError,
    SchedulerUnreachableError,
    SimulationError,
    UnreachablePoseError,
    URDFConventionError,
    XacroArgumentError,
)

if TYPE_CHECKING:
    from delta_pin.control import (
        LQR,
        AdaptiveRobustController,
        AdaptiveRobustGains,
        ClosedChainNominalModel,
        ComputedTorque,
        Controller,
        DeltaNominalModel,
        DigitalRobustController,
        PDGravity,
        PinocchioNominalModel,
        Reference,
        TimeDelayControl,
        design1,
        design2,
        digital_robust,
        tdc,
    )
    from delta_pin.model.closed_chain import ClosedChainRobot
    from delta_pin.model.closures import Closure
    from delta_pin.model.delta_robot import load_delta
    from delta_pin.model.description import DeltaParameters, StribeckParameters, compile_urdf
    from delta_pin.model.dynamics import ReducedDynamics
    from delta_pin.model.frame_path import Circle, FramePath
    from delta_pin.model.friction import Friction
    from delta_pin.model.loaders import load_robot
    from delta_pin.model.robot import Delta
    from delta_pin.model.trajectory import (
        AdeptCycle,
        JointReference,
        PathI,
        PathII,
        SplinePath,
        Trajectory,
        check_workspace,
    )
    from delta_pin.sim.batch import simulate_batch
    from delta_pin.sim.closed_chain_plant import ClosedChainPlant, PinocchioPlant
    from delta_pin.sim.drive import Encoder
    from delta_pin.sim.plants import AnalyticPlant, DeltaPlant, Plant
    from delta_pin.sim.run import Run, load_run
    from delta_pin.sim.runner import simulate
    from delta_pin.sim.serial import JointSinusoid
    from delta_pin.sim.uncertainty import (
        FunctionUncertainty,
        NoUncertainty,
        PaperUncertainty,
        RandomUncertainty,
        Uncertainty,
    )

from delta_pin._version import __version__

# module -> the public names it defines, loaded on first use
_PUBLIC = {
    "delta_pin.model.closed_chain": ("ClosedChainRobot",),
    "delta_pin.model.closures": ("Closure",),
    "delta_pin.model.frame_path": ("Circle", "FramePath"),
    "delta_pin.model.loaders": ("load_robot",),
    "delta_pin.model.description": ("DeltaParameters", "StribeckParameters", "compile_urdf"),
    "delta_pin.model.dynamics": ("ReducedDynamics",),
    "delta_pin.model.friction": ("Friction",),
    "delta_pin.model.robot": ("Delta",),
    "delta_pin.model.delta_robot": ("load_delta",),
    "delta_pin.model.trajectory": (
        "AdeptCycle",
        "JointReference",
        "PathI",
        "PathII",
        "SplinePath",
        "Trajectory",
        "check_workspace",
    ),
    "delta_pin.control": (
        "LQR",
        "AdaptiveRobustController",
        "AdaptiveRobustGains",
        "ClosedChainNominalModel",
        "ComputedTorque",
        "Controller",
        "DeltaNominalModel",
        "DigitalRobustController",
        "PDGravity",
        "PinocchioNominalModel",
        "Reference",
        "TimeDelayControl",
        "design1",
        "design2",
        "digital_robust",
        "tdc",
    ),
    "delta_pin.sim.plants": ("AnalyticPlant", "DeltaPlant", "Plant"),
    "delta_pin.sim.uncertainty": (
        "FunctionUncertainty",
        "NoUncertainty",
        "PaperUncertainty",
        "RandomUncertainty",
        "Uncertainty",
    ),
    "delta_pin.sim.drive": ("Encoder",),
    "delta_pin.sim.run": ("Run", "load_run"),
    "delta_pin.sim.serial": ("JointSinusoid",),
    "delta_pin.sim.runner": ("simulate",),
    "delta_pin.sim.batch": ("simulate_batch",),
    "delta_pin.sim.closed_chain_plant": ("ClosedChainPlant", "PinocchioPlant"),
    "delta_pin.identification.workflow": ("identify",),
}
_LAZY = {name: module for module, names in _PUBLIC.items() for name in names}
# dp.model, dp.planning, ... on first use
_LAYERS = ("model", "control", "sim", "planning", "studies", "viz", "errors", "cli")
__all__ = sorted([*_LAZY, *errors.__all__])


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is not None:
        value = getattr(importlib.import_module(module), name)
    elif name in _LAYERS:
        value = importlib.import_module(f"{__name__}.{name}")
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

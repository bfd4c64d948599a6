"""delta-pin: model-based control of Delta parallel robots, built on Pinocchio."""

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
]

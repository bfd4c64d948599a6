"""delta-pin: model-based control of Delta parallel robots, built on Pinocchio."""

from .description import DeltaParameters, StribeckParameters, compile_urdf
from .dynamics import ReducedDynamics
from .errors import (
    AssemblyError,
    DeltaPinError,
    ForwardKinematicsError,
    InvalidParameterError,
    NonFiniteError,
    UnreachablePoseError,
    URDFConventionError,
    XacroArgumentError,
)
from .robot import Delta, load_delta
from .trajectory import (
    AdeptCycle,
    JointReference,
    PathI,
    PathII,
    SplinePath,
    Trajectory,
    check_workspace,
)

__version__ = "0.1.0"

__all__ = [
    "AdeptCycle",
    "AssemblyError",
    "Delta",
    "DeltaParameters",
    "DeltaPinError",
    "ForwardKinematicsError",
    "InvalidParameterError",
    "JointReference",
    "NonFiniteError",
    "PathI",
    "PathII",
    "ReducedDynamics",
    "SplinePath",
    "StribeckParameters",
    "Trajectory",
    "URDFConventionError",
    "UnreachablePoseError",
    "XacroArgumentError",
    "check_workspace",
    "compile_urdf",
    "load_delta",
]

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

__version__ = "0.1.0"

__all__ = [
    "AssemblyError",
    "Delta",
    "DeltaParameters",
    "DeltaPinError",
    "ForwardKinematicsError",
    "InvalidParameterError",
    "NonFiniteError",
    "ReducedDynamics",
    "StribeckParameters",
    "URDFConventionError",
    "UnreachablePoseError",
    "XacroArgumentError",
    "compile_urdf",
    "load_delta",
]

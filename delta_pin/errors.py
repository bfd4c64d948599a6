"""One exception hierarchy for delta-pin, rooted at :class:`DeltaPinError`.

Every error message names the offending value (the point, the argument, the time), so that a
failing script says what to change without a debugger.
"""

from __future__ import annotations

__all__ = [
    "AssemblyError",
    "DeltaPinError",
    "ForwardKinematicsError",
    "InvalidParameterError",
    "MeshFileError",
    "NativeUnavailableError",
    "NonFiniteError",
    "OptionalDependencyError",
    "PlanningError",
    "SchedulerUnreachableError",
    "SimulationError",
    "URDFConventionError",
    "UnreachablePoseError",
    "XacroArgumentError",
]


class DeltaPinError(Exception):
    """Base class of every error raised on purpose by delta-pin."""


class InvalidParameterError(DeltaPinError, ValueError):
    """A parameter (length, mass, gain, option) has a value outside its domain."""


class XacroArgumentError(InvalidParameterError):
    """An unknown xacro argument, or a value that is not valid for a known one."""


class NonFiniteError(DeltaPinError, ValueError):
    """A NaN or infinite number where a finite one is required."""


class URDFConventionError(DeltaPinError):
    """The URDF does not follow delta-pin's Delta convention (docs/architecture.md section 3)."""


class MeshFileError(URDFConventionError):
    """A mesh visual whose file cannot be found or read (the message names the file)."""


class AssemblyError(DeltaPinError):
    """The geometry cannot close its three loops (e.g. forearms too short to meet)."""


class UnreachablePoseError(DeltaPinError, ValueError):
    """A platform position outside the workspace (or outside the elbow-out IK branch)."""


class ForwardKinematicsError(DeltaPinError, ValueError):
    """Active joint angles for which no platform position closes the three loops."""


class SimulationError(DeltaPinError):
    """A simulation that cannot go on: the message gives the time [s] at which it stopped.

    Attributes:
        time: simulated time [s] of the failure.
        configuration: the last configuration q the run recorded before it stopped, where the
            loop knows it (a closed-chain run in the compiled core), else None.
    """

    def __init__(self, message: str, time: float, configuration=None) -> None:
        super().__init__(f"{message} (at t={time:.6g} s)")
        self.time = time
        self.configuration = configuration


class NativeUnavailableError(DeltaPinError, RuntimeError):
    """The compiled core (``delta_pin/core/``) cannot be imported here: not built (a source tree
    without an install) or built against another Pinocchio than the one installed. The message
    names the command that rebuilds it."""


class OptionalDependencyError(DeltaPinError, ImportError):
    """An optional extra (e.g. ``dask``, ``mujoco``) is needed for the requested feature; the
    message gives the pip command."""


class SchedulerUnreachableError(DeltaPinError, ConnectionError):
    """No Dask scheduler answers at the given address within the connect timeout."""


class PlanningError(DeltaPinError):
    """No time law runs the path within the limits (delta_pin.planning), said in one line."""

"""Checks of the arguments every simulation entry point shares: one place for each error text."""

from __future__ import annotations

import numpy as np

from delta_pin.choices import MODES
from delta_pin.errors import InvalidParameterError, NonFiniteError
from delta_pin.model.kinematics import as_vector3

__all__ = ["MODES", "check_mode", "check_substeps", "check_timing", "joint_vector"]


def check_timing(dt: float, t_end: float) -> int:
    """The number of periods in a run of ``t_end`` [s] sampled every ``dt`` [s] (both > 0)."""
    for name, value in (("dt", dt), ("t_end", t_end)):
        if not (isinstance(value, int | float) and value > 0.0 and np.isfinite(value)):
            raise InvalidParameterError(f"{name}={value!r} must be a positive number of seconds")
    steps = round(t_end / dt)
    if steps < 1:
        raise InvalidParameterError(f"t_end={t_end} s is shorter than one period dt={dt} s")
    return steps


def check_substeps(substeps: int) -> None:
    """Integrator steps per period: an integer >= 1."""
    if not (isinstance(substeps, int) and substeps >= 1):
        raise InvalidParameterError(f"substeps={substeps!r} must be an integer >= 1")


def check_mode(mode: str) -> None:
    """``"sampled"`` or ``"continuous"``."""
    if mode not in MODES:
        raise InvalidParameterError(f"mode={mode!r} must be one of {', '.join(MODES)}")


def joint_vector(value, name: str, dof: int) -> np.ndarray:
    """``value`` as a finite (dof,) float array, or an error naming ``name``."""
    if dof == 3:
        return as_vector3(value, name)
    array = np.asarray(value, dtype=float)
    if array.shape != (dof,):
        raise InvalidParameterError(f"{name} must have shape ({dof},), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise NonFiniteError(f"{name}={array.tolist()} holds a non-finite number")
    return array

"""The one divergence check of every loop, and the readable RK4 step.

:func:`check_state` is the divergence rule, the same predicate the compiled loops apply, with its
error message; :func:`rk4_step` is the readable RK4 of ``validate``'s free motion (the runs of
``simulate`` take the compiled core's RK4, :mod:`delta_pin.sim.loop`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from delta_pin.choices import INTEGRATORS
from delta_pin.errors import SimulationError

__all__ = [
    "INTEGRATORS",
    "MAX_JOINT_SPEED",
    "PROJECTION_CHUNK",
    "all_finite",
    "check_state",
    "rk4_step",
]

MAX_JOINT_SPEED = 1e3  # [rad/s] a state beyond this has diverged
PROJECTION_CHUNK = 1000  # samples between the whole-state continuous loop's projections onto the loops


def rk4_step(f: Callable[[float, np.ndarray], np.ndarray], t: float, y: np.ndarray, h: float) -> np.ndarray:
    """One classical Runge-Kutta step of y' = f(t, y) from t [s] over h [s]."""
    k1 = f(t, y)
    k2 = f(t + 0.5 * h, y + 0.5 * h * k1)
    k3 = f(t + 0.5 * h, y + 0.5 * h * k2)
    k4 = f(t + h, y + h * k3)
    return y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def all_finite(values: np.ndarray) -> bool:
    """Whether every entry of a small float array is finite: its sum is (a NaN or an infinity
    makes the sum non-finite; a sum that overflows falls back to numpy's test)."""
    return math.isfinite(sum(values.tolist())) or bool(np.isfinite(values).all())


def check_state(t: float, x: np.ndarray, z: np.ndarray, alpha: np.ndarray, alpha_dot: np.ndarray) -> None:
    """Raise :class:`SimulationError` where the plant state x or the controller state z is not
    finite or a joint turns faster than :data:`MAX_JOINT_SPEED`; (alpha, alpha_dot): x's joints."""
    # once per sample: Python's own sums and max of the few values are a few times faster than
    # numpy's reductions (a sum is finite only if every term is, or overflows: checked below)
    if all_finite(x) and all_finite(z) and max(map(abs, alpha_dot.tolist()), default=0.0) <= MAX_JOINT_SPEED:
        return  # a NaN speed is not within the limit (NaN <= limit is False)
    finite = np.isfinite(x).all() and np.isfinite(z).all()
    if finite and (np.abs(alpha_dot) <= MAX_JOINT_SPEED).all():
        return
    if not finite:
        raise SimulationError(f"the state became non-finite (alpha={alpha.tolist()})", t)
    speed = np.abs(alpha_dot).max()
    raise SimulationError(f"the run diverged: |alpha_dot| = {speed:.3g} rad/s > {MAX_JOINT_SPEED:g} rad/s", t)

"""The integrators of the Python loop and the one divergence check of every loop.

:func:`rk4_step` is the readable RK4 (the reference of the compiled core's RK4 steps);
:func:`integrate_lsoda` drives scipy's LSODA in chunks for continuous mode; :func:`check_state` is
the divergence rule, the same predicate the compiled loops apply, with its error message.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from delta_pin.choices import INTEGRATORS
from delta_pin.errors import SimulationError

__all__ = [
    "INTEGRATORS",
    "LSODA_CHUNK",
    "MAX_JOINT_SPEED",
    "all_finite",
    "check_state",
    "integrate_lsoda",
    "rk4_step",
]

MAX_JOINT_SPEED = 1e3  # [rad/s] a state beyond this has diverged
LSODA_CHUNK = 1000  # samples per LSODA call (each restart costs a start-up; finish_step runs between)


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


def integrate_lsoda(closed_loop, sample, check, finish_step, x, z, t, rtol, atol, bar):
    """Continuous mode with scipy's LSODA, in chunks of :data:`LSODA_CHUNK` samples.

    Args:
        closed_loop: f(t, [x, z]) -> d[x, z]/dt.
        sample: ``sample(k, x, z)`` records sample k.
        check: ``check(t, x, z)`` raises where the state diverged.
        finish_step: the plant's correction between chunks (``finish_step(x, t) -> x``).
        x, z: initial plant and controller states; ``t``: the sample times [s].
        rtol, atol: LSODA's tolerances; ``bar``: a progress display.

    Returns:
        (x, z) at t[-1] (not yet recorded).
    """
    from scipy.integrate import solve_ivp

    nx = len(x)
    dt = t[1] - t[0]
    k = 0
    while k < len(t) - 1:
        stop = min(k + LSODA_CHUNK, len(t) - 1)
        sample(k, x, z)
        solution = solve_ivp(
            closed_loop,
            (t[k], t[stop]),
            np.concatenate([x, z]),
            method="LSODA",
            t_eval=t[k : stop + 1],
            rtol=rtol,
            atol=atol,
            max_step=dt,
        )
        if solution.status != 0:  # the time of the last sample it reached, not the chunk's start
            reached = float(solution.t[-1]) if len(solution.t) else float(t[k])
            raise SimulationError(f"the integrator failed: {solution.message}", reached)
        for j in range(1, stop - k):
            xs, zs = solution.y[:nx, j], solution.y[nx:, j]
            check(t[k + j], xs, zs)
            sample(k + j, xs, zs)
        x, z = solution.y[:nx, -1], solution.y[nx:, -1]
        check(t[stop], x, z)
        x = finish_step(x, t[stop])
        bar.update(round(t[stop] - t[k], 9))
        k = stop
    return x, z

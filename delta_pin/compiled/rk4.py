"""The compiled RK4 step's arithmetic and the one divergence check of every loop.

:func:`delta_pin.sim.integrators.rk4_step` is the readable RK4 (the reference); the compiled
loops and the Pinocchio plant's fast sampled step build their stages with :func:`stage_point`
and :func:`combine`, in the same order of operations, so that they agree with it bit for bit:

    y2 = x + (h/2) k1,  y3 = x + (h/2) k2,  y4 = x + h k3,
    x_next = x + (h/6) (((k1 + 2 k2) + 2 k3) + k4).
"""

from __future__ import annotations

import math

from delta_pin.compiled.jit import njit

__all__ = ["all_finite", "combine", "stage_point", "within_limits"]


@njit(cache=True)
def stage_point(y, x, k, c):
    """y = x + c k (a stage point: c = h / 2 or h)."""
    for i in range(x.shape[0]):
        y[i] = x[i] + c * k[i]


@njit(cache=True)
def combine(x, k1, k2, k3, k4, c, out):
    """out = x + c (((k1 + 2 k2) + 2 k3) + k4) with c = h / 6 (``out`` may be ``x``)."""
    for i in range(x.shape[0]):
        out[i] = x[i] + c * (((k1[i] + 2.0 * k2[i]) + 2.0 * k3[i]) + k4[i])


@njit(cache=True)
def all_finite(values):
    """``np.isfinite(values).all()`` for a 1-d array, without the temporaries."""
    for value in values:  # noqa: SIM110 - a plain loop for numba
        if not math.isfinite(value):
            return False
    return True


@njit(cache=True)
def within_limits(x, z, alpha_dot, max_speed):
    """The divergence check of every loop: the plant state x and the controller state z are
    finite and every |alpha_dot| <= max_speed [rad/s]."""
    if not (all_finite(x) and all_finite(z)):
        return False
    for value in alpha_dot:  # noqa: SIM110 - a plain loop for numba
        if not abs(value) <= max_speed:
            return False
    return True

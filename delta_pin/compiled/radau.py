"""Compiled Radau IIA (order 5) with error control: designs I/II on either plant, continuous mode.

The closed loop [alpha, alpha_dot, rho_hat] of :mod:`delta_pin.compiled.closed_loop` (its
right-hand side ``_rhs_into``: the controller inside the derivative, the analytic plant or
Pinocchio's tree in active coordinates) integrated by the three-stage Radau IIA collocation method
(Hairer & Wanner, *Solving ODEs II*, IV.8; the scheme of SciPy's ``Radau``, which is its readable
reference in the tests): stiffly accurate, L-stable, order 5, with

* the stage increments Z solved by simplified Newton on the whole 3n system
  (I - h A (x) J) dZ = -(Z - h (A (x) I) F(Z)), J a forward-difference Jacobian re-used across
  steps while Newton contracts fast (the robust term's boundary layer makes the loop stiff, and
  its Jacobian changes little along the layer);
* the embedded error estimate err = (gamma/h I - J)^-1 (f(y0) + (e^T Z)/h), filtered once more
  through the system where a step was just rejected, in the norm
  rms(err / (atol + rtol max(|y0|, |y1|)));
* step-size control h <- h min(10, max(0.2, 0.9 (2 k_max + 1)/(2 k_max + k) err^(-1/4)));
* dense output: the collocation polynomial gives the state at every sample t_k = k dt that a step
  crosses, where the controller's torque and internals are recorded (one evaluation each).

The reference and the plant's truth are tabulated on a uniform grid (``control.grid_step``) and
read between grid points by cubic Hermite interpolation (the reference, from its derivatives, as
:class:`~delta_pin.sim.reference.ReferenceTable`) and linear interpolation (the truth).
"""

from __future__ import annotations

import math

import numpy as np

from delta_pin.compiled.closed_loop import (
    DIVERGED,
    NO_CONVERGENCE,
    NO_FK,
    OK,
    _lu_factor,
    _lu_solve,
    _rhs_into,
    control_into,
    record_sample,
)
from delta_pin.compiled.jit import njit
from delta_pin.compiled.rk4 import within_limits

__all__ = ["MU_REAL", "RADAU_A", "RADAU_C", "RADAU_E", "RADAU_P", "run_radau"]

_S6 = math.sqrt(6.0)
RADAU_C = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])  # the stage times c_i
RADAU_A = np.array(
    [
        [(88.0 - 7.0 * _S6) / 360.0, (296.0 - 169.0 * _S6) / 1800.0, (-2.0 + 3.0 * _S6) / 225.0],
        [(296.0 + 169.0 * _S6) / 1800.0, (88.0 + 7.0 * _S6) / 360.0, (-2.0 - 3.0 * _S6) / 225.0],
        [(16.0 - _S6) / 36.0, (16.0 + _S6) / 36.0, 1.0 / 9.0],
    ]
)
RADAU_E = np.array([-13.0 - 7.0 * _S6, -13.0 + 7.0 * _S6, -1.0]) / 3.0  # the error estimate's weights
MU_REAL = 3.0 + 3.0 ** (2.0 / 3.0) - 3.0 ** (1.0 / 3.0)  # the real eigenvalue of A^-1
# dense output: y(t0 + x h) = y0 + (Z^T P) [x, x^2, x^3]
RADAU_P = np.array(
    [
        [13.0 / 3.0 + 7.0 * _S6 / 3.0, -23.0 / 3.0 - 22.0 * _S6 / 3.0, 10.0 / 3.0 + 5.0 * _S6],
        [13.0 / 3.0 - 7.0 * _S6 / 3.0, -23.0 / 3.0 + 22.0 * _S6 / 3.0, 10.0 / 3.0 - 5.0 * _S6],
        [1.0 / 3.0, -8.0 / 3.0, 10.0 / 3.0],
    ]
)
MAX_NEWTON = 6  # simplified Newton iterations per attempt
MIN_FACTOR, MAX_FACTOR = 0.2, 10.0  # step-size change per step
MIN_STEP = 1e-12  # [s] below which the run is abandoned


@njit(cache=True)
def _inputs_at(truth, reference, jerk, grid_step, t, ws):
    """The truth (linear) and the reference (cubic Hermite from its derivatives) at time t [s]
    into ``ws.truth`` and ``ws.reference``."""
    last = truth.shape[0] - 1
    u = t / grid_step
    k = min(max(int(u), 0), last - 1)  # t >= 0
    w = min(max(u - k, 0.0), 1.0)
    t0, t1, out = truth[k], truth[k + 1], ws.truth
    out.platform_mass = (1.0 - w) * t0.platform_mass + w * t1.platform_mass
    w2, w3 = w * w, w * w * w
    h00, h10, h01, h11 = 2.0 * w3 - 3.0 * w2 + 1.0, w3 - 2.0 * w2 + w, -2.0 * w3 + 3.0 * w2, w3 - w2
    r0, r1, ref, g = reference[k], reference[k + 1], ws.reference, grid_step
    for i in range(3):
        out.normal_force[i] = (1.0 - w) * t0.normal_force[i] + w * t1.normal_force[i]
        out.disturbance[i] = (1.0 - w) * t0.disturbance[i] + w * t1.disturbance[i]
        ref.alpha[i] = (
            h00 * r0.alpha[i] + h10 * g * r0.alpha_dot[i] + h01 * r1.alpha[i] + h11 * g * r1.alpha_dot[i]
        )
        ref.alpha_dot[i] = (
            h00 * r0.alpha_dot[i]
            + h10 * g * r0.alpha_ddot[i]
            + h01 * r1.alpha_dot[i]
            + h11 * g * r1.alpha_ddot[i]
        )
        ref.alpha_ddot[i] = (
            h00 * r0.alpha_ddot[i] + h10 * g * jerk[k, i] + h01 * r1.alpha_ddot[i] + h11 * g * jerk[k + 1, i]
        )


@njit(cache=True)
def _rhs_at(pc, cos_phi, sin_phi, plant, truth, reference, jerk, grid_step, t, y, nr, y_dot, ws):
    """The closed-loop derivative at (t, y) into y_dot; returns ``ok``."""
    _inputs_at(truth, reference, jerk, grid_step, t, ws)
    return _rhs_into(pc, cos_phi, sin_phi, plant, ws.truth, ws.reference, y, nr, y_dot, ws)


@njit(cache=True)
def _record_at(pc, cos_phi, sin_phi, plant, truth, reference, jerk, grid_step, t, y, nr, y_dot, ws):
    """The controller's outputs at (t, y) in ``ws`` for a sample's record; returns ``ok``. On the
    tree with the controller's kinematics shared, the plant is not evaluated: the platform position
    is the analytic forward kinematics (Pinocchio's q(alpha) gives the same point to ~1e-12 m)
    and the closure gap the last completion's."""
    if plant.tree and plant.shared_kinematics:
        _inputs_at(truth, reference, jerk, grid_step, t, ws)
        return control_into(pc, cos_phi, sin_phi, plant, ws.reference, y, nr, ws)
    return _rhs_at(pc, cos_phi, sin_phi, plant, truth, reference, jerk, grid_step, t, y, nr, y_dot, ws)


@njit(cache=True)
def _jacobian_at(
    pc, cos_phi, sin_phi, plant, truth, reference, jerk, grid_step, t, y, f, nr, J, ws, counters
):
    """Forward-difference df/dy at (t, y) into J; ``f`` = f(t, y). Returns ``ok``; counts its
    evaluations and itself in ``counters`` [0] and [3]."""
    n = y.shape[0]
    counters[0] += n
    counters[3] += 1
    shifted = y.copy()
    shifted_dot = np.empty(n)
    for i in range(n):
        step = 1e-8 * max(1.0, abs(y[i]))
        shifted[i] = y[i] + step
        ok = _rhs_at(
            pc, cos_phi, sin_phi, plant, truth, reference, jerk, grid_step, t, shifted, nr, shifted_dot, ws
        )
        shifted[i] = y[i]
        if not ok:
            return False
        for k in range(n):
            J[k, i] = (shifted_dot[k] - f[k]) / step
    return True


@njit(cache=True)
def _factor(J, h):
    """LU factors of I - h (A (x) J) (3n x 3n, stage-major) and of MU_REAL/h I - J (n x n)."""
    n = J.shape[0]
    full = np.eye(3 * n)
    for i in range(3):
        for j in range(3):
            a = h * RADAU_A[i, j]
            for p in range(n):
                for q in range(n):
                    full[i * n + p, j * n + q] -= a * J[p, q]
    real = -J.copy()
    for p in range(n):
        real[p, p] += MU_REAL / h
    full_lu, full_pivots = _lu_factor(full)
    real_lu, real_pivots = _lu_factor(real)
    return full_lu, full_pivots, real_lu, real_pivots


@njit(cache=True)
def _rms(values, scale):
    total = 0.0
    for i in range(values.shape[0]):
        total += (values[i] / scale[i]) ** 2
    return math.sqrt(total / values.shape[0])


@njit(cache=True)
def _newton(pc, cos_phi, sin_phi, plant, truth, reference, jerk, grid_step, t, y, h, Z, nr, full_lu,
            full_pivots, scale, tolerance, ws, counters):  # fmt: skip
    """Simplified Newton on the collocation system from the guess Z (3, n), updated in place.
    Returns (status, converged, iterations, rate)."""
    n = y.shape[0]
    F = np.empty((3, n))
    stage = np.empty(n)
    residual = np.empty(3 * n)
    previous_norm = -1.0
    rate = -1.0
    for k in range(MAX_NEWTON):
        for i in range(3):
            for p in range(n):
                stage[p] = y[p] + Z[i, p]
            if not _rhs_at(
                pc,
                cos_phi,
                sin_phi,
                plant,
                truth,
                reference,
                jerk,
                grid_step,
                t + RADAU_C[i] * h,
                stage,
                nr,
                F[i],
                ws,
            ):
                return NO_FK, False, k, rate
        counters[0] += 3
        for i in range(3):
            for p in range(n):
                value = Z[i, p]
                for j in range(3):
                    value -= h * RADAU_A[i, j] * F[j, p]
                residual[i * n + p] = -value
        delta = _lu_solve(full_lu, full_pivots, residual)
        norm = 0.0
        for i in range(3):
            for p in range(n):
                norm += (delta[i * n + p] / scale[p]) ** 2
        norm = math.sqrt(norm / (3 * n))
        if not math.isfinite(norm):
            return OK, False, k + 1, rate
        if previous_norm > 0.0:
            rate = norm / previous_norm
            if rate >= 1.0 or rate ** (MAX_NEWTON - k) / (1.0 - rate) * norm > tolerance:
                return OK, False, k + 1, rate
        for i in range(3):
            for p in range(n):
                Z[i, p] += delta[i * n + p]
        if norm == 0.0 or (rate > 0.0 and rate / (1.0 - rate) * norm < tolerance):
            return OK, True, k + 1, rate
        previous_norm = norm
    return OK, False, MAX_NEWTON, rate


@njit(cache=True)
def run_radau(
    pc, cos_phi, sin_phi, plant, truth, reference, jerk, control, y0, timing, ws, out, info_out, counters
):
    """Integrate one run with error control, recording the samples t_k = k ``timing.step``.

    Args:
        pc, cos_phi, sin_phi, plant: as :func:`~delta_pin.compiled.closed_loop.run_closed_loop`.
        truth, reference: TRUTH and REFERENCE records on the grid ``control.grid_step``, and
            ``jerk`` (grid, 3) the reference's third derivative there [rad/s^3].
        control: a STEP_CONTROL record (rtol, atol, first step, largest step, grid step).
        y0: [alpha, alpha_dot, rho_hat] at t = 0.
        timing: a TIMING record (``step``: the sample period dt [s]; ``samples``).
        ws: a WORKSPACE record; ``out``, ``info_out``: SAMPLE and INFO records per sample.
        counters: int64 [evaluations, rejected steps, accepted steps, Jacobians].

    Returns:
        (status, failure time [s]): ``OK``, ``NO_FK``, ``NO_CONVERGENCE`` (the step fell below
        ``MIN_STEP``) or ``DIVERGED``.
    """
    n = y0.shape[0]
    nr = n - 6
    dt, samples = timing.step, timing.samples
    t_end = samples * dt
    rtol, atol = control.rtol, control.atol
    tolerance = max(10.0 * 2.220446049250313e-16 / rtol, min(0.03, math.sqrt(rtol)))
    y = y0.copy()
    t = 0.0
    f = np.empty(n)
    if not _rhs_at(pc, cos_phi, sin_phi, plant, truth, reference, jerk, control.grid_step, t, y, nr, f, ws):
        return NO_FK, 0.0
    counters[0] += 1
    record_sample(out[0], info_out[0], y, ws)
    next_sample = 1
    J = np.empty((n, n))
    if not _jacobian_at(
        pc, cos_phi, sin_phi, plant, truth, reference, jerk, control.grid_step, t, y, f, nr, J, ws, counters
    ):
        return NO_FK, 0.0
    current_jacobian = True
    h = min(control.first_step, control.max_step, t_end)
    full_lu, full_pivots, real_lu, real_pivots = _factor(J, h)
    factored_h = h
    Q = np.zeros((n, 3))  # the last accepted step's dense output, from y_last
    y_last = y0.copy()
    have_dense, h_last = False, 0.0
    Z = np.zeros((3, n))
    scale = np.empty(n)
    rejected = False
    first = True
    y_new = np.empty(n)
    sample = np.empty(n)
    f_new = np.empty(n)
    while next_sample <= samples:
        h = min(h, control.max_step, t_end - t)
        if h < MIN_STEP:
            return NO_CONVERGENCE, t
        if h != factored_h:
            full_lu, full_pivots, real_lu, real_pivots = _factor(J, h)
            factored_h = h
        if have_dense:  # the guess: the last step's collocation polynomial, extrapolated
            for i in range(3):
                x = 1.0 + RADAU_C[i] * h / h_last
                for p in range(n):
                    Z[i, p] = Q[p, 0] * x + Q[p, 1] * x * x + Q[p, 2] * x * x * x + y_last[p] - y[p]
        else:
            Z[:, :] = 0.0
        for p in range(n):
            scale[p] = atol + abs(y[p]) * rtol
        status, converged, iterations, rate = _newton(
            pc, cos_phi, sin_phi, plant, truth, reference, jerk, control.grid_step, t, y, h, Z, nr, full_lu,
            full_pivots, scale, tolerance, ws, counters,
        )  # fmt: skip
        if status != OK:
            return status, t
        if not converged:
            if not current_jacobian:
                if not _jacobian_at(
                    pc, cos_phi, sin_phi, plant, truth, reference, jerk, control.grid_step, t, y, f, nr, J,
                    ws, counters,
                ):  # fmt: skip
                    return NO_FK, t
                current_jacobian = True
            else:
                h *= 0.5
            factored_h = -1.0  # refactor
            counters[1] += 1
            rejected = True
            continue
        # the error estimate
        for p in range(n):
            y_new[p] = y[p] + Z[2, p]
            scale[p] = atol + max(abs(y[p]), abs(y_new[p])) * rtol
        ze = np.empty(n)
        for p in range(n):
            ze[p] = (RADAU_E[0] * Z[0, p] + RADAU_E[1] * Z[1, p] + RADAU_E[2] * Z[2, p]) / h
        error = _lu_solve(real_lu, real_pivots, f + ze)
        norm = _rms(error, scale)
        if norm > 1.0 and (first or rejected):
            for p in range(n):
                sample[p] = y[p] + error[p]
            if not _rhs_at(
                pc,
                cos_phi,
                sin_phi,
                plant,
                truth,
                reference,
                jerk,
                control.grid_step,
                t,
                sample,
                nr,
                f_new,
                ws,
            ):
                return NO_FK, t
            counters[0] += 1
            error = _lu_solve(real_lu, real_pivots, f_new + ze)
            norm = _rms(error, scale)
        safety = 0.9 * (2 * MAX_NEWTON + 1) / (2 * MAX_NEWTON + iterations)
        if norm > 1.0:
            h *= max(MIN_FACTOR, safety * norm**-0.25)
            counters[1] += 1
            rejected = True
            continue
        # accepted: the samples this step crosses, from the collocation polynomial
        for p in range(n):
            for m in range(3):
                Q[p, m] = Z[0, p] * RADAU_P[0, m] + Z[1, p] * RADAU_P[1, m] + Z[2, p] * RADAU_P[2, m]
        t_new = t + h
        while next_sample <= samples and next_sample * dt <= t_new * (1.0 + 1e-14):
            x = (next_sample * dt - t) / h
            for p in range(n):
                sample[p] = y[p] + Q[p, 0] * x + Q[p, 1] * x * x + Q[p, 2] * x * x * x
            if next_sample == samples:
                sample[:] = y_new  # the run ends on the last step's end
            at = next_sample * dt
            if not _record_at(
                pc,
                cos_phi,
                sin_phi,
                plant,
                truth,
                reference,
                jerk,
                control.grid_step,
                at,
                sample,
                nr,
                f_new,
                ws,
            ):
                return NO_FK, next_sample * dt
            counters[0] += 1
            record_sample(out[next_sample], info_out[next_sample], sample, ws)
            next_sample += 1
        if not within_limits(y_new[0:6], y_new[6:], y_new[3:6], timing.max_speed):
            return DIVERGED, t_new
        if not _rhs_at(
            pc,
            cos_phi,
            sin_phi,
            plant,
            truth,
            reference,
            jerk,
            control.grid_step,
            t_new,
            y_new,
            nr,
            f_new,
            ws,
        ):
            return NO_FK, t_new
        counters[0] += 1
        counters[2] += 1
        y_last = y.copy()
        have_dense, h_last = True, h
        t = t_new
        y[:] = y_new
        f[:] = f_new
        first, rejected = False, False
        factor = min(MAX_FACTOR, safety * norm**-0.25) if norm > 0.0 else MAX_FACTOR
        if iterations > 2 and rate > 1e-3:  # Newton contracted slowly: a fresh Jacobian
            if not _jacobian_at(
                pc, cos_phi, sin_phi, plant, truth, reference, jerk, control.grid_step, t, y, f, nr, J, ws,
                counters,
            ):  # fmt: skip
                return NO_FK, t
            current_jacobian = True
            factored_h = -1.0
        else:
            current_jacobian = False
        if factor >= 1.2 or factor < 1.0:
            h *= factor
    return OK, 0.0

"""Compiled closed loop: designs I/II integrated by BDF2 (or sampled RK4), one run or a batch.

The plant is the analytic one (eqs. 7-9, fast_model's kernels) or Pinocchio's constrained tree in
active coordinates through :mod:`delta_pin.native` (q(alpha) completed by Newton at every
evaluation, then ``constraintDynamics``): the packed plant vector says which.

Continuous mode of the paper's controllers is stiff in an unusual way. Inside the boundary layer
(||omega|| <= xi) the robust term is a damper of gain Lambda^2 / xi (~2000 N m s/rad); outside it
is a unit-vector (sliding-mode) term of constant size Lambda. The layer is thin (||s|| ~ xi /
Lambda ~ 1e-4 rad/s), so the solution slides along it. Explicit methods need ~1e-5 s steps; a
linearly implicit (Rosenbrock) step linearised outside the layer sees no stiffness along s and
chatters across it (first-order, 4e-2 rad off after 0.3 s at 0.25 ms steps). A fully implicit
step with Newton's method lands on the layer's equivalent control: BDF2 (second order, A-stable,
stage time on the step grid so the reference and truth tables are exact), with the first step
implicit Euler:

    y_1 - y_0 = h f(t_1, y_1);    y_{n+1} - 4/3 y_n + 1/3 y_{n-1} = 2/3 h f(t_{n+1}, y_{n+1}).

Each step is solved by Newton's method on y - anchor - c h f(y) = 0 from a quadratic
extrapolation of the last three points, with a forward-difference Jacobian and its LU factors
reused across steps while the iteration contracts (re-computed when it needs backtracking or more
than three iterations), a backtracking line search (the steep tanh of the friction sign and the
layer's kink defeat plain Newton), and the stopping test of Hairer & Wanner (IV.8): the last
correction, or theta / (1 - theta) times it with theta the observed contraction, below
``NEWTON_TOLERANCE``. Where Newton still fails (the first milliseconds of the reaching phase from
the paper's 0.083 rad initial error), the step is retried as 2, 4, ... 1024 implicit Euler
sub-steps with the reference and the truth interpolated linearly inside the step. The controller
and the plant share one evaluation of the kinematics (M, C, G are linear in the platform mass).

Accuracy (tests/test_batch.py, path I, paper scenario, against LSODA at rtol 1e-9): with 1 ms
steps the joint angles differ by ~5e-4 rad during the first 10 ms (the reaching phase) and by
~3e-7 rad after 1 s, rho_hat by 1e-3 (relative); with 0.25 ms steps by 1.9e-5, 2e-8 rad and
1.7e-4. A 15 s run costs ~62 000 evaluations and ~0.1 s (LSODA from Python: ~80 000, 8 s); on
the Pinocchio plant ~0.93 s (~15 us per evaluation, ~9 of them in Pinocchio; LSODA: 24 s), with
the same accuracy against LSODA on that plant (tests/test_fast_tree_loop.py).

The state of a run is y = [alpha (3), alpha_dot (3), rho_hat (1 or 3)]. Runs of a batch are
independent (each its own gains, truth table and initial state; the path is shared), so a batch
result equals the same runs made one at a time, exactly.
"""

from __future__ import annotations

import math

import numpy as np

from .control.fast_adaptive_robust import adaptive_robust_kernel, adaptive_robust_law_into
from .fast_model import delta_dynamics_into, delta_kinematics_into, njit, solve3_into, stribeck_kernel
from .native.calls import call_active_dynamics

__all__ = ["NEWTON_TOLERANCE", "closed_loop_batch"]

TREE = 16  # the packed plant's length; beyond it: the native tree (see _plant_acceleration_into)
NEWTON_TOLERANCE = 1e-10  # largest Newton correction accepted as converged (rad, rad/s, -)
MAX_NEWTON_ITERATIONS = 12
STALE_ITERATIONS = 3  # Newton iterations on a reused Jacobian before it is re-computed
MAX_SPLIT_DEPTH = 10  # a failing step is retried as 2, 4, ... 1024 implicit Euler steps
# status codes of a run
OK, NO_FK, NO_CONVERGENCE, DIVERGED = 0, 1, 2, 3


@njit(cache=True)
def _workspace(nr):
    """Scratch arrays of :func:`_rhs_into` for one run: (matrices (13, 3, 3), vectors (7, 8))."""
    return np.empty((13, 3, 3)), np.zeros((7, 8))


@njit(cache=True)
def _control_into(pc, cos_phi, sin_phi, plant, ref, y, nr, mats, vecs):
    """The kinematics at y (J, J_dot in ``mats[0:2]``, xyz in ``vecs[4]``) and the controller's
    output (tau in ``vecs[2]``, info in ``vecs[3]``, rho_dot in ``vecs[6]``); returns ``ok``.

    ``plant`` = [geometry (7), 1.5 m_b, friction on, r_a, v_s, mu_s, mu_d, mu_v, sign scale,
    same geometry as the controller's nominal model] (the Pinocchio plant in active coordinates
    appends [address of ``dpn_active_dynamics``, tree handle, nominal platform mass, nominal
    platform rotational inertia (9)]: addresses are exact in float64 below 2^53); ``ref`` =
    [alpha_d, alpha_dot_d, alpha_ddot_d]. When the nominal geometry is the plant's, the
    kinematics serve both: M, C, G are linear in the platform mass.
    """
    alpha, velocity, rho = y[0:3], y[3:6], y[6 : 6 + nr]
    J, J_dot, M_bar, C_bar = mats[0], mats[1], mats[8], mats[9]
    G_bar, tau, info, xyz, rho_dot = vecs[0], vecs[2], vecs[3], vecs[4], vecs[6]
    if not delta_kinematics_into(plant[0:7], cos_phi, sin_phi, alpha, velocity, xyz, J, J_dot, mats[2:8]):
        return False
    if plant[15] > 0.0:
        delta_dynamics_into(plant[0:7], pc[32], alpha, J, J_dot, M_bar, C_bar, G_bar)
        adaptive_robust_law_into(
            pc, M_bar, C_bar, G_bar, alpha, velocity, ref[0:3], ref[3:6], ref[6:9], rho, tau, rho_dot, info
        )
        return True
    tau_, rho_dot_, info_ = adaptive_robust_kernel(
        pc, cos_phi, sin_phi, alpha, velocity, ref[0:3], ref[3:6], ref[6:9], rho
    )
    tau[0:3], rho_dot[0:nr], info[0:8] = tau_, rho_dot_, info_
    return info_[0] != 0.0


@njit(cache=True)
def _plant_acceleration_into(plant, truth, alpha, velocity, tau, mats, vecs, acceleration):
    """alpha_ddot of eq. 13, M alpha_ddot = tau - C alpha_dot - G - (F + M_f), for the truth
    ``truth`` = [m_o, F_n (3), F (3)]; returns ``ok``.

    Analytic plant (``plant`` of 16 numbers): with the kinematics already in ``mats[0:2]`` (the
    order of operations of :meth:`AnalyticPlant.derivative
    <delta_pin.plant.AnalyticPlant.derivative>`). Pinocchio plant in active coordinates (``plant``
    extended by :data:`TREE`): the net torques tau - (F + M_f) go to Pinocchio's constrained
    dynamics (:mod:`delta_pin.native`), which completes q(alpha) and leaves the platform position
    in ``vecs[4, 0:3]`` and the closure gap [m] in ``vecs[4, 3]``."""
    rhs = vecs[5]
    tree = plant.shape[0] > TREE
    if tree:
        for i in range(3):
            rhs[i] = tau[i]
    else:
        J, J_dot, M, C, G = mats[0], mats[1], mats[10], mats[11], vecs[1]
        delta_dynamics_into(plant[0:7], truth[0] + plant[7], alpha, J, J_dot, M, C, G)
        for i in range(3):
            coriolis = C[i, 0] * velocity[0] + C[i, 1] * velocity[1] + C[i, 2] * velocity[2]
            rhs[i] = tau[i] - coriolis - G[i]
    if plant[8] > 0.0:
        friction = stribeck_kernel(
            plant[9], plant[10], plant[11], plant[12], plant[13], velocity, truth[1:4], plant[14]
        )
        for i in range(3):
            rhs[i] -= truth[4 + i] + friction[i]
    else:
        for i in range(3):
            rhs[i] -= truth[4 + i]
    if not tree:
        solve3_into(M, rhs, acceleration, mats[12])
        return True
    # the platform's rotational inertia scales with its mass (PinocchioPlant._rotational_inertia)
    rotational = mats[12]
    scale = truth[0] / plant[TREE + 2]
    for i in range(3):
        for j in range(3):
            rotational[i, j] = plant[TREE + 3 + 3 * i + j] * scale
    status = call_active_dynamics(
        np.int64(plant[TREE]), np.int64(plant[TREE + 1]), alpha, velocity, rhs[0:3], truth[0],
        rotational, acceleration, vecs[4, 0:3], vecs[4, 3:4],
    )  # fmt: skip
    return status == 0


@njit(cache=True)
def _rhs_into(pc, cos_phi, sin_phi, plant, truth, ref, y, nr, y_dot, mats, vecs):
    """Closed-loop derivative at one state into y_dot; returns ``ok``. tau, the controller's info
    and the platform position are left in ``vecs[2, :3]``, ``vecs[3]`` and ``vecs[4, :3]``
    (see :func:`_control_into`, :func:`_plant_acceleration_into`)."""
    if not _control_into(pc, cos_phi, sin_phi, plant, ref, y, nr, mats, vecs):
        return False
    if not _plant_acceleration_into(plant, truth, y[0:3], y[3:6], vecs[2], mats, vecs, y_dot[3:6]):
        return False
    for i in range(3):
        y_dot[i] = y[3 + i]
    for i in range(nr):
        y_dot[6 + i] = vecs[6, i]
    return True


@njit(cache=True)
def _held_derivative(cos_phi, sin_phi, plant, truth, x, tau, mats, vecs, x_dot):
    """[alpha_dot, alpha_ddot] of the plant alone under a held torque; returns ``ok``."""
    if not delta_kinematics_into(
        plant[0:7], cos_phi, sin_phi, x[0:3], x[3:6], vecs[4], mats[0], mats[1], mats[2:8]
    ):
        return False
    if not _plant_acceleration_into(plant, truth, x[0:3], x[3:6], tau, mats, vecs, x_dot[3:6]):
        return False
    for i in range(3):
        x_dot[i] = x[3 + i]
    return True


@njit(cache=True)
def _record(row, info_row, y, vecs):
    """One sample: [alpha, alpha_dot, tau, xyz, rho_hat(, closure gap)] into ``row`` and the
    controller's info into ``info_row``, from the state y and the outputs :func:`_rhs_into` left
    in ``vecs`` (the gap where ``row`` has room for it: the Pinocchio plant)."""
    nr = y.shape[0] - 6
    row[0:6] = y[0:6]
    row[6:9] = vecs[2, 0:3]
    row[9:12] = vecs[4, 0:3]
    row[12 : 12 + nr] = y[6 : 6 + nr]
    if row.shape[0] > 12 + nr:
        row[12 + nr] = vecs[4, 3]
    info_row[:] = vecs[3]


@njit(cache=True)
def _run_one_sampled(
    pc, cos_phi, sin_phi, plant, truth, ref, y0, dt, substeps, steps, max_speed, out, info_out, counters
):
    """Sampled mode (zero-order hold, as :func:`delta_pin.simulate.simulate`): at each sample the
    controller, then ``substeps`` RK4 steps of the plant under the held torque (truth rows on the
    h / 2 grid), then rho_hat += dt rho_hat_dot. ``out``/``info_out``/``counters`` as
    :func:`_run_one` (controller evaluations and plant stages both count). Returns (status,
    failure time)."""
    nr = y0.shape[0] - 6
    mats, vecs = _workspace(nr)
    y = y0.copy()
    h = dt / substeps
    tau = np.empty(3)
    rho_dot = np.empty(nr)
    k1, k2, k3, k4, stage = np.empty(6), np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    for k in range(steps + 1):
        if not _control_into(pc, cos_phi, sin_phi, plant, ref[k], y, nr, mats, vecs):
            return NO_FK, k * dt
        _record(out[k], info_out[k], y, vecs)
        counters[0] += 1
        if k == steps:
            break
        tau[:] = vecs[2, 0:3]
        rho_dot[:] = vecs[6, 0:nr]
        x = y[0:6].copy()
        for j in range(substeps):
            row = 2 * (k * substeps + j)  # the stages of simulate._rk4: rows row, row+1, row+1, row+2
            ok = _held_derivative(cos_phi, sin_phi, plant, truth[row], x, tau, mats, vecs, k1)
            for i in range(6):
                stage[i] = x[i] + 0.5 * h * k1[i]
            ok = ok and _held_derivative(cos_phi, sin_phi, plant, truth[row + 1], stage, tau, mats, vecs, k2)
            for i in range(6):
                stage[i] = x[i] + 0.5 * h * k2[i]
            ok = ok and _held_derivative(cos_phi, sin_phi, plant, truth[row + 1], stage, tau, mats, vecs, k3)
            for i in range(6):
                stage[i] = x[i] + h * k3[i]
            ok = ok and _held_derivative(cos_phi, sin_phi, plant, truth[row + 2], stage, tau, mats, vecs, k4)
            counters[0] += 4
            if not ok:
                return NO_FK, (k * substeps + j) * h
            for i in range(6):
                x[i] = x[i] + (h / 6.0) * (((k1[i] + 2.0 * k2[i]) + 2.0 * k3[i]) + k4[i])
        for i in range(6):
            y[i] = x[i]
        for i in range(nr):
            y[6 + i] = y[6 + i] + dt * rho_dot[i]
        for i in range(6 + nr):
            if not math.isfinite(y[i]):
                return DIVERGED, (k + 1) * dt
        for i in range(3):
            if abs(y[3 + i]) > max_speed:
                return DIVERGED, (k + 1) * dt
    return OK, 0.0


@njit(cache=True)
def _residual(pc, cos_phi, sin_phi, plant, truth, ref, anchor, ch, y, nr, mats, vecs):
    """(ok, y - anchor - ch f(y), f(y))."""
    y_dot = np.empty(y.shape[0])
    ok = _rhs_into(pc, cos_phi, sin_phi, plant, truth, ref, y, nr, y_dot, mats, vecs)
    return ok, y - anchor - ch * y_dot, y_dot


@njit(cache=True)
def _jacobian(pc, cos_phi, sin_phi, plant, truth, ref, y, y_dot, nr, J, mats, vecs):
    """Forward-difference df/dy at y into J (n, n); one evaluation per column."""
    shifted = y.copy()
    shifted_dot = np.empty(y.shape[0])
    for i in range(y.shape[0]):
        step = 1e-8 * max(1.0, abs(y[i]))
        shifted[i] = y[i] + step
        _rhs_into(pc, cos_phi, sin_phi, plant, truth, ref, shifted, nr, shifted_dot, mats, vecs)
        shifted[i] = y[i]
        for k in range(y.shape[0]):
            J[k, i] = (shifted_dot[k] - y_dot[k]) / step


@njit(cache=True)
def _lu_factor(A):
    """In-place LU with partial pivoting of a small dense matrix: (LU, pivots)."""
    n = A.shape[0]
    pivots = np.arange(n)
    for k in range(n):
        best = k
        for i in range(k + 1, n):
            if abs(A[i, k]) > abs(A[best, k]):
                best = i
        if best != k:
            for j in range(n):
                A[k, j], A[best, j] = A[best, j], A[k, j]
            pivots[k], pivots[best] = pivots[best], pivots[k]
        for i in range(k + 1, n):
            A[i, k] /= A[k, k]
            for j in range(k + 1, n):
                A[i, j] -= A[i, k] * A[k, j]
    return A, pivots


@njit(cache=True)
def _lu_solve(LU, pivots, b):
    """Solve with the factors of :func:`_lu_factor`."""
    n = LU.shape[0]
    x = np.empty(n)
    for i in range(n):
        x[i] = b[pivots[i]]
    for i in range(n):
        for j in range(i):
            x[i] -= LU[i, j] * x[j]
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            x[i] -= LU[i, j] * x[j]
        x[i] /= LU[i, i]
    return x


@njit(cache=True)
def _implicit_step(
    pc, cos_phi, sin_phi, plant, truth, ref, anchor, c, h, guess, nr, J, jacobian_valid, mats, vecs
):
    """Solve y = anchor + c h f(t, y) from ``guess`` by Newton with backtracking: (status, y,
    evaluations, J valid). J (updated in place) is reused across steps while the iteration
    contracts fast; it is re-computed at the current iterate when it does not."""
    ch = c * h
    n = 6 + nr
    y = guess.copy()
    ok, residual, y_dot = _residual(pc, cos_phi, sin_phi, plant, truth, ref, anchor, ch, y, nr, mats, vecs)
    evaluations = 1
    if not ok:
        return NO_FK, y, evaluations, jacobian_valid
    norm = math.sqrt(residual @ residual)
    since_refresh = 0
    previous = np.inf
    factored = False
    LU, pivots = np.eye(n), np.arange(n)
    for _ in range(MAX_NEWTON_ITERATIONS):
        if not jacobian_valid or since_refresh >= STALE_ITERATIONS:
            _jacobian(pc, cos_phi, sin_phi, plant, truth, ref, y, y_dot, nr, J, mats, vecs)
            evaluations += n
            jacobian_valid, since_refresh, previous, factored = True, 0, np.inf, False
        if not factored:  # one factorisation of I - ch J per Jacobian (and step)
            LU, pivots = _lu_factor(np.eye(n) - ch * J)
            factored = True
        since_refresh += 1
        delta = _lu_solve(LU, pivots, -residual)
        largest = np.abs(delta).max()
        if not math.isfinite(largest):
            return DIVERGED, y, evaluations, False
        # converged: this correction is small, or the contraction rate theta says the error left
        # after it is (theta / (1 - theta) ||delta||, Hairer & Wanner IV.8)
        theta = largest / previous
        if largest <= NEWTON_TOLERANCE or (
            0.0 < theta < 0.5 and theta / (1.0 - theta) * largest <= NEWTON_TOLERANCE
        ):
            return OK, y + delta, evaluations, jacobian_valid
        previous = largest
        fraction = 1.0
        while True:  # backtracking: the steep friction sign and the layer's kink defeat plain Newton
            trial = y + fraction * delta
            ok, trial_residual, trial_dot = _residual(
                pc, cos_phi, sin_phi, plant, truth, ref, anchor, ch, trial, nr, mats, vecs
            )
            evaluations += 1
            trial_norm = math.sqrt(trial_residual @ trial_residual) if ok else np.inf
            if trial_norm <= (1.0 - 1e-4 * fraction) * norm or fraction < 1e-3:
                break
            fraction *= 0.5
        if not ok:
            return NO_FK, trial, evaluations, False
        if fraction < 1.0:
            previous = np.inf  # theta is only an estimate of the contraction of full steps
            if since_refresh > 1:
                jacobian_valid = False  # a stale Jacobian that needs backtracking: refresh it
        y, residual, y_dot, norm = trial, trial_residual, trial_dot, trial_norm
    return NO_CONVERGENCE, y, evaluations, False


@njit(cache=True)
def _split_step(pc, cos_phi, sin_phi, plant, truth0, truth1, ref0, ref1, y, h, nr, depth, mats, vecs):
    """Cross one grid step by 2^depth implicit Euler steps (the reference and truth interpolated
    linearly inside the step): the fallback where Newton fails on the whole step (the reaching
    phase of the sliding mode). (status, y, evaluations)."""
    parts = 1 << depth
    evaluations = 0
    J = np.zeros((y.shape[0], y.shape[0]))
    valid = False
    for m in range(parts):
        w = (m + 1.0) / parts
        truth = (1.0 - w) * truth0 + w * truth1
        ref = (1.0 - w) * ref0 + w * ref1
        status, y_new, used, valid = _implicit_step(
            pc, cos_phi, sin_phi, plant, truth, ref, y, 1.0, h / parts, y, nr, J, valid, mats, vecs
        )
        evaluations += used
        if status != OK:
            return status, y, evaluations
        y = y_new
    return OK, y, evaluations


@njit(cache=True)
def _run_one(
    pc, cos_phi, sin_phi, plant, truth, ref, y0, h, substeps, steps, max_speed, out, info_out, counters
):
    """Integrate one run; ``out`` (steps + 1, 12 + nr) gets [alpha, alpha_dot, tau, xyz, rho] per
    sample, ``info_out`` (steps + 1, 8) the controller's info, ``counters`` [evaluations, split
    steps]. Returns (status, failure time)."""
    nr = y0.shape[0] - 6
    y = y0.copy()
    y_prev = y0.copy()
    y_prev2 = y0.copy()
    taken = 0  # BDF steps taken: the first is implicit Euler, the predictor's order grows to 2
    J = np.zeros((y.shape[0], y.shape[0]))
    valid = False
    mats, vecs = _workspace(nr)
    y_dot = np.empty(y.shape[0])
    for k in range(steps + 1):
        index = k * substeps
        if not _rhs_into(pc, cos_phi, sin_phi, plant, truth[index], ref[index], y, nr, y_dot, mats, vecs):
            return NO_FK, k * substeps * h
        _record(out[k], info_out[k], y, vecs)
        if k == steps:
            break
        for j in range(substeps):
            index = k * substeps + j + 1
            if taken == 0:
                anchor, c, guess = y.copy(), 1.0, y.copy()
            elif taken == 1:
                anchor, c, guess = (4.0 * y - y_prev) / 3.0, 2.0 / 3.0, 2.0 * y - y_prev
            else:  # quadratic extrapolation through the last three points
                anchor, c, guess = (4.0 * y - y_prev) / 3.0, 2.0 / 3.0, 3.0 * (y - y_prev) + y_prev2
            status, y_new, used, valid = _implicit_step(
                pc,
                cos_phi,
                sin_phi,
                plant,
                truth[index],
                ref[index],
                anchor,
                c,
                h,
                guess,
                nr,
                J,
                valid,
                mats,
                vecs,
            )
            counters[0] += used
            depth = 0
            while status == NO_CONVERGENCE and depth < MAX_SPLIT_DEPTH:
                depth += 1
                status, y_new, used = _split_step(
                    pc,
                    cos_phi,
                    sin_phi,
                    plant,
                    truth[index - 1],
                    truth[index],
                    ref[index - 1],
                    ref[index],
                    y,
                    h,
                    nr,
                    depth,
                    mats,
                    vecs,
                )
                counters[0] += used
            if depth > 0:
                counters[1] += 1
                valid = False
            if status != OK:
                return status, index * h
            for i in range(3):
                if not abs(y_new[3 + i]) <= max_speed:
                    return DIVERGED, index * h
            taken += 1
            y_prev2 = y_prev
            y_prev = y
            y = y_new
    return OK, 0.0


@njit(cache=True)
def closed_loop_batch(pcs, cos_phi, sin_phi, plant, truths, ref, y0s, h, substeps, steps, max_speed, sampled):
    """Integrate a batch of runs (one after another, compiled).

    Args:
        pcs: packed controllers (B, 40) (:func:`~delta_pin.control.fast_adaptive_robust.pack_controller`).
        plant: packed plant (16,) (see :func:`_control_into`).
        truths: (B, rows, 7) truth tables: on the step grid (continuous: steps substeps + 1 rows)
            or on the half-step grid (sampled: 2 steps substeps + 1 rows).
        ref: reference rows (9,) on the step grid (continuous) or at the samples (sampled).
        y0s: (B, 6 + nr) initial states.
        h: step [s] (continuous) or sample period dt [s] (sampled); substeps: steps per sample;
            steps: samples - 1.
        max_speed: |alpha_dot| [rad/s] beyond which a run has diverged.
        sampled: zero-order hold and RK4 (:func:`_run_one_sampled`) instead of BDF2.

    Returns:
        (samples (B, steps + 1, 12 + nr), info (B, steps + 1, 8), status (B,), failure time (B,)).
    """
    count = pcs.shape[0]
    nr = y0s.shape[1] - 6
    gap_column = 1 if plant.shape[0] > TREE else 0  # the Pinocchio plant records its closure gap
    samples = np.full((count, steps + 1, 12 + nr + gap_column), np.nan)
    info = np.full((count, steps + 1, 8), np.nan)
    status = np.zeros(count, dtype=np.int64)
    failure_time = np.zeros(count)
    counters = np.zeros((count, 2), dtype=np.int64)
    for b in range(count):
        arguments = (pcs[b], cos_phi, sin_phi, plant, truths[b], ref, y0s[b], h, substeps, steps, max_speed)
        if sampled:
            status[b], failure_time[b] = _run_one_sampled(*arguments, samples[b], info[b], counters[b])
        else:
            status[b], failure_time[b] = _run_one(*arguments, samples[b], info[b], counters[b])
    return samples, info, status, failure_time, counters

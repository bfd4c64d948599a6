"""Compiled closed loop: designs I/II integrated by BDF2 (or sampled RK4), one run per call.

The plant is the analytic one (eqs. 7-9, :mod:`delta_pin.compiled.delta_kernels`) or Pinocchio's
constrained tree in
active coordinates through :mod:`delta_pin.compiled.native` (q(alpha) completed by Newton at every
evaluation, then ``constraintDynamics``): the :data:`~delta_pin.compiled.layouts.PLANT` record says which.

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

Accuracy (tests/sim/test_compiled_loops.py, path I, paper scenario, against LSODA at rtol 1e-9): with 1 ms
steps the joint angles differ by ~5e-4 rad during the first 10 ms (the reaching phase) and by
~3e-7 rad after 1 s, rho_hat by 1e-3 (relative); with 0.25 ms steps by 1.9e-5, 2e-8 rad and
1.7e-4. A 15 s run costs ~62 000 evaluations and ~0.1 s (LSODA from Python: ~80 000, 8 s); on
the Pinocchio plant ~0.93 s (~15 us per evaluation, ~9 of them in Pinocchio; LSODA: 24 s), with
the same accuracy against LSODA on that plant (tests/sim/test_compiled_loops.py).

The state of a run is the ODE vector y = [alpha (3), alpha_dot (3), rho_hat (1 or 3)]; every
other number comes in a named record (:mod:`delta_pin.compiled.layouts`): the controller, the
plant, the truth and reference tables, the timing, the workspace and the recorded samples.
"""

from __future__ import annotations

import math

import numpy as np

from delta_pin.compiled.adaptive_robust import adaptive_robust_kernel, adaptive_robust_law_into
from delta_pin.compiled.delta_kernels import (
    delta_dynamics_into,
    delta_kinematics_into,
    friction_torque,
    solve3_into,
)
from delta_pin.compiled.jit import njit
from delta_pin.compiled.layouts import LAW_LQR
from delta_pin.compiled.lqr import lqr_law_into
from delta_pin.compiled.native.calls import call_active_dynamics
from delta_pin.compiled.rk4 import combine, stage_point, within_limits

__all__ = ["DIVERGED", "NEWTON_TOLERANCE", "NO_CONVERGENCE", "NO_FK", "OK", "run_closed_loop"]

NEWTON_TOLERANCE = 1e-10  # largest Newton correction accepted as converged (rad, rad/s, -)
MAX_NEWTON_ITERATIONS = 12
STALE_ITERATIONS = 3  # Newton iterations on a reused Jacobian before it is re-computed
MAX_SPLIT_DEPTH = 10  # a failing step is retried as 2, 4, ... 1024 implicit Euler steps
# status codes of a run
OK, NO_FK, NO_CONVERGENCE, DIVERGED = 0, 1, 2, 3


@njit(cache=True)
def copy_info(source, target):
    """target = source for two :data:`~delta_pin.compiled.layouts.INFO` records."""
    target.ok = source.ok
    target.Lambda = source.Lambda
    target.robust_gain = source.robust_gain
    target.omega_norm = source.omega_norm
    target.adaptation_active = source.adaptation_active
    for i in range(3):
        target.robust_torque[i] = source.robust_torque[i]


@njit(cache=True)
def control_into(pc, cos_phi, sin_phi, plant, ref, y, nr, ws):
    """The kinematics at y (``ws.J``, ``ws.J_dot``, ``ws.xyz``) and the controller's output
    (``ws.tau``, ``ws.rho_dot``, ``ws.info``); returns ``ok``. The controller is design I or II, or
    the LQR baseline (``pc.law``; it has no rho_hat: nr = 0).

    ``pc``: a CONTROLLER record; ``plant``: a PLANT record; ``ref``: a REFERENCE record. When the
    controller's nominal geometry is the plant's (``plant.shared_kinematics``), the kinematics
    serve both: M, C, G are linear in the platform mass.
    """
    alpha, velocity, rho = y[0:3], y[3:6], y[6 : 6 + nr]
    if not delta_kinematics_into(
        plant.geometry, cos_phi, sin_phi, alpha, velocity, ws.xyz, ws.J, ws.J_dot, ws.kinematics
    ):
        return False
    if pc.law == LAW_LQR:  # a linear model frozen at alpha0: no nominal terms at the state
        lqr_law_into(pc, alpha, velocity, ref.alpha, ref.alpha_dot, ref.alpha_ddot, ws.tau, ws.info)
        return True
    if plant.shared_kinematics:
        delta_dynamics_into(plant.geometry, pc.m_eq, alpha, ws.J, ws.J_dot, ws.M_bar, ws.C_bar, ws.G_bar)
        adaptive_robust_law_into(
            pc, ws.M_bar, ws.C_bar, ws.G_bar, alpha, velocity, ref.alpha, ref.alpha_dot, ref.alpha_ddot,
            rho, ws.tau, ws.rho_dot, ws.info,
        )  # fmt: skip
        return True
    return adaptive_robust_kernel(
        pc, cos_phi, sin_phi, alpha, velocity, ref.alpha, ref.alpha_dot, ref.alpha_ddot, rho,
        ws.tau, ws.rho_dot, ws.info,
    )  # fmt: skip


@njit(cache=True)
def _plant_acceleration_into(plant, truth, alpha, velocity, tau, ws, acceleration):
    """alpha_ddot of eq. 13, M alpha_ddot = tau - C alpha_dot - G - (F + M_f), for the TRUTH
    record ``truth``; returns ``ok``.

    Analytic plant: with the kinematics already in ``ws.J``, ``ws.J_dot`` (the order of operations
    of :meth:`AnalyticPlant.derivative <delta_pin.sim.plants.AnalyticPlant.derivative>`).
    Pinocchio plant in active coordinates (``plant.tree``): the net torques tau - (F + M_f) go to
    Pinocchio's constrained dynamics (:mod:`delta_pin.compiled.native`), which completes q(alpha)
    and leaves the platform position in ``ws.xyz`` and the closure gap [m] in ``ws.gap``."""
    rhs = ws.rhs
    if plant.tree:
        for i in range(3):
            rhs[i] = tau[i]
    else:
        M, C, G = ws.M, ws.C, ws.G
        delta_dynamics_into(
            plant.geometry, truth.platform_mass + plant.forearm_mass, alpha, ws.J, ws.J_dot, M, C, G
        )
        for i in range(3):
            coriolis = C[i, 0] * velocity[0] + C[i, 1] * velocity[1] + C[i, 2] * velocity[2]
            rhs[i] = tau[i] - coriolis - G[i]
    if plant.friction.on:
        friction = friction_torque(plant.friction, velocity, truth.normal_force)
        for i in range(3):
            rhs[i] -= truth.disturbance[i] + friction[i]
    else:
        for i in range(3):
            rhs[i] -= truth.disturbance[i]
    if not plant.tree:
        solve3_into(ws.M, rhs, acceleration, ws.matrix)
        return True
    # the platform's rotational inertia scales with its mass (PinocchioPlant.rotational_inertia)
    rotational = ws.matrix
    scale = truth.platform_mass / plant.nominal_platform_mass
    for i in range(3):
        for j in range(3):
            rotational[i, j] = plant.nominal_platform_rotational[i, j] * scale
    status = call_active_dynamics(
        plant.active_dynamics, plant.tree_handle, alpha, velocity, rhs, truth.platform_mass,
        rotational, acceleration, ws.xyz, ws.gap,
    )  # fmt: skip
    return status == 0


@njit(cache=True)
def _rhs_into(pc, cos_phi, sin_phi, plant, truth, ref, y, nr, y_dot, ws):
    """Closed-loop derivative at one state into y_dot; returns ``ok``. tau, the controller's info
    and the platform position are left in ``ws`` (see :func:`control_into`)."""
    if not control_into(pc, cos_phi, sin_phi, plant, ref, y, nr, ws):
        return False
    if not _plant_acceleration_into(plant, truth, y[0:3], y[3:6], ws.tau, ws, y_dot[3:6]):
        return False
    for i in range(3):
        y_dot[i] = y[3 + i]
    for i in range(nr):
        y_dot[6 + i] = ws.rho_dot[i]
    return True


@njit(cache=True)
def _held_derivative(cos_phi, sin_phi, plant, truth, x, tau, ws, x_dot):
    """[alpha_dot, alpha_ddot] of the plant alone under a held torque; returns ``ok``."""
    if not delta_kinematics_into(
        plant.geometry, cos_phi, sin_phi, x[0:3], x[3:6], ws.xyz, ws.J, ws.J_dot, ws.kinematics
    ):
        return False
    if not _plant_acceleration_into(plant, truth, x[0:3], x[3:6], tau, ws, x_dot[3:6]):
        return False
    for i in range(3):
        x_dot[i] = x[3 + i]
    return True


@njit(cache=True)
def held_rk4_step(cos_phi, sin_phi, plant, truth, row, x, tau, h, ws, stages):
    """One RK4 step of length h [s] of the analytic plant (or the tree in active coordinates) x
    under the held torque tau, in place, its stages on TRUTH rows row, row+1, row+1, row+2 (the
    half-step grid; the order of operations of rk4_step); ``stages`` (5, 6) scratch. Returns ``ok``
    (False: no forward kinematics at a stage; x is then unchanged)."""
    k1, k2, k3, k4, stage = stages[0], stages[1], stages[2], stages[3], stages[4]
    ok = _held_derivative(cos_phi, sin_phi, plant, truth[row], x, tau, ws, k1)
    stage_point(stage, x, k1, 0.5 * h)
    ok = ok and _held_derivative(cos_phi, sin_phi, plant, truth[row + 1], stage, tau, ws, k2)
    stage_point(stage, x, k2, 0.5 * h)
    ok = ok and _held_derivative(cos_phi, sin_phi, plant, truth[row + 1], stage, tau, ws, k3)
    stage_point(stage, x, k3, h)
    ok = ok and _held_derivative(cos_phi, sin_phi, plant, truth[row + 2], stage, tau, ws, k4)
    if ok:
        combine(x, k1, k2, k3, k4, h / 6.0, x)
    return ok


@njit(cache=True)
def record_sample(sample, info, y, ws):
    """One SAMPLE record from the state y and the outputs the last evaluation left in ``ws``
    (the closure gap is the tree's, 0 on the analytic plant), and the controller's INFO."""
    nr = y.shape[0] - 6
    for i in range(3):
        sample.alpha[i] = y[i]
        sample.alpha_dot[i] = y[3 + i]
        sample.tau[i] = ws.tau[i]
        sample.xyz[i] = ws.xyz[i]
    for i in range(nr):
        sample.rho_hat[i] = y[6 + i]
    sample.closure_gap = ws.gap[0]
    copy_info(ws.info, info)


@njit(cache=True)
def _run_sampled(pc, cos_phi, sin_phi, plant, truth, ref, y0, timing, ws, out, info_out, counters):
    """Sampled mode (zero-order hold, as :func:`delta_pin.sim.runner.simulate`): at each sample the
    controller, then ``timing.substeps`` RK4 steps of the plant under the held torque (truth rows
    on the h / 2 grid), then rho_hat += dt rho_hat_dot. Returns (status, failure time)."""
    nr = y0.shape[0] - 6
    dt, substeps, steps = timing.step, timing.substeps, timing.samples
    y = y0.copy()
    h = dt / substeps
    tau = np.empty(3)
    rho_dot = np.empty(nr)
    stages = np.empty((5, 6))  # k1..k4 and a stage point
    for k in range(steps + 1):
        if not control_into(pc, cos_phi, sin_phi, plant, ref[k], y, nr, ws):
            return NO_FK, k * dt
        record_sample(out[k], info_out[k], y, ws)
        counters[0] += 1
        if k == steps:
            break
        tau[:] = ws.tau
        rho_dot[:] = ws.rho_dot[0:nr]
        x = y[0:6].copy()
        for j in range(substeps):
            ok = held_rk4_step(cos_phi, sin_phi, plant, truth, 2 * (k * substeps + j), x, tau, h, ws, stages)
            counters[0] += 4
            if not ok:
                return NO_FK, (k * substeps + j) * h
        for i in range(6):
            y[i] = x[i]
        for i in range(nr):
            y[6 + i] = y[6 + i] + dt * rho_dot[i]
        if not within_limits(y[0:6], y[6:], y[3:6], timing.max_speed):
            return DIVERGED, (k + 1) * dt
    return OK, 0.0


@njit(cache=True)
def _residual(pc, cos_phi, sin_phi, plant, truth, ref, anchor, ch, y, nr, ws):
    """(ok, y - anchor - ch f(y), f(y))."""
    y_dot = np.empty(y.shape[0])
    ok = _rhs_into(pc, cos_phi, sin_phi, plant, truth, ref, y, nr, y_dot, ws)
    return ok, y - anchor - ch * y_dot, y_dot


@njit(cache=True)
def _jacobian(pc, cos_phi, sin_phi, plant, truth, ref, y, y_dot, nr, J, ws):
    """Forward-difference df/dy at y into J (n, n); one evaluation per column."""
    shifted = y.copy()
    shifted_dot = np.empty(y.shape[0])
    for i in range(y.shape[0]):
        step = 1e-8 * max(1.0, abs(y[i]))
        shifted[i] = y[i] + step
        _rhs_into(pc, cos_phi, sin_phi, plant, truth, ref, shifted, nr, shifted_dot, ws)
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
def _implicit_step(pc, cos_phi, sin_phi, plant, truth, ref, anchor, c, h, guess, nr, J, jacobian_valid, ws):
    """Solve y = anchor + c h f(t, y) from ``guess`` by Newton with backtracking: (status, y,
    evaluations, J valid). J (updated in place) is reused across steps while the iteration
    contracts fast; it is re-computed at the current iterate when it does not."""
    ch = c * h
    n = 6 + nr
    y = guess.copy()
    ok, residual, y_dot = _residual(pc, cos_phi, sin_phi, plant, truth, ref, anchor, ch, y, nr, ws)
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
            _jacobian(pc, cos_phi, sin_phi, plant, truth, ref, y, y_dot, nr, J, ws)
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
                pc, cos_phi, sin_phi, plant, truth, ref, anchor, ch, trial, nr, ws
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
def _interpolate(truth0, truth1, ref0, ref1, w, truth, ref):
    """truth = (1 - w) truth0 + w truth1 and the same for the reference (TRUTH and REFERENCE
    records), field by field."""
    truth.platform_mass = (1.0 - w) * truth0.platform_mass + w * truth1.platform_mass
    for i in range(3):
        truth.normal_force[i] = (1.0 - w) * truth0.normal_force[i] + w * truth1.normal_force[i]
        truth.disturbance[i] = (1.0 - w) * truth0.disturbance[i] + w * truth1.disturbance[i]
        ref.alpha[i] = (1.0 - w) * ref0.alpha[i] + w * ref1.alpha[i]
        ref.alpha_dot[i] = (1.0 - w) * ref0.alpha_dot[i] + w * ref1.alpha_dot[i]
        ref.alpha_ddot[i] = (1.0 - w) * ref0.alpha_ddot[i] + w * ref1.alpha_ddot[i]


@njit(cache=True)
def _split_step(pc, cos_phi, sin_phi, plant, truth0, truth1, ref0, ref1, y, h, nr, depth, ws):
    """Cross one grid step by 2^depth implicit Euler steps (the reference and truth interpolated
    linearly inside the step): the fallback where Newton fails on the whole step (the reaching
    phase of the sliding mode). (status, y, evaluations)."""
    parts = 1 << depth
    evaluations = 0
    J = np.zeros((y.shape[0], y.shape[0]))
    valid = False
    truth, ref = ws.truth, ws.reference
    for m in range(parts):
        _interpolate(truth0, truth1, ref0, ref1, (m + 1.0) / parts, truth, ref)
        status, y_new, used, valid = _implicit_step(
            pc, cos_phi, sin_phi, plant, truth, ref, y, 1.0, h / parts, y, nr, J, valid, ws
        )
        evaluations += used
        if status != OK:
            return status, y, evaluations
        y = y_new
    return OK, y, evaluations


@njit(cache=True)
def _run_bdf2(pc, cos_phi, sin_phi, plant, truth, ref, y0, timing, ws, out, info_out, counters):
    """Integrate one run by BDF2 with steps h = ``timing.step``; truth and reference rows on the
    step grid. Returns (status, failure time)."""
    nr = y0.shape[0] - 6
    h, substeps, steps = timing.step, timing.substeps, timing.samples
    y = y0.copy()
    y_prev = y0.copy()
    y_prev2 = y0.copy()
    taken = 0  # BDF steps taken: the first is implicit Euler, the predictor's order grows to 2
    J = np.zeros((y.shape[0], y.shape[0]))
    valid = False
    y_dot = np.empty(y.shape[0])
    for k in range(steps + 1):
        index = k * substeps
        if not _rhs_into(pc, cos_phi, sin_phi, plant, truth[index], ref[index], y, nr, y_dot, ws):
            return NO_FK, k * substeps * h
        record_sample(out[k], info_out[k], y, ws)
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
                pc, cos_phi, sin_phi, plant, truth[index], ref[index], anchor, c, h, guess, nr, J, valid, ws
            )
            counters[0] += used
            depth = 0
            while status == NO_CONVERGENCE and depth < MAX_SPLIT_DEPTH:
                depth += 1
                status, y_new, used = _split_step(
                    pc, cos_phi, sin_phi, plant, truth[index - 1], truth[index], ref[index - 1],
                    ref[index], y, h, nr, depth, ws,
                )  # fmt: skip
                counters[0] += used
            if depth > 0:
                counters[1] += 1
                valid = False
            if status != OK:
                return status, index * h
            if not within_limits(y_new[0:6], y_new[6:], y_new[3:6], timing.max_speed):
                return DIVERGED, index * h
            taken += 1
            y_prev2 = y_prev
            y_prev = y
            y = y_new
    return OK, 0.0


@njit(cache=True)
def run_closed_loop(
    controller, cos_phi, sin_phi, plant, truth, reference, y0, timing, workspace, out, info_out, counters
):
    """Integrate one run of design I or II on the plant: BDF2, or sampled RK4 (``timing.sampled``).

    Args:
        controller: a CONTROLLER record.
        cos_phi, sin_phi: the chain azimuths' cos and sin (3,).
        plant: a PLANT record.
        truth: TRUTH records on the step grid (BDF2: steps substeps + 1) or on the half-step grid
            (sampled: 2 steps substeps + 1).
        reference: REFERENCE records on the step grid (BDF2) or at the samples (sampled).
        y0: the initial state [alpha, alpha_dot, rho_hat] (6 + nr,).
        timing: a TIMING record; ``workspace``: a WORKSPACE record (scratch).
        out, info_out: SAMPLE and INFO records per sample (steps + 1,), written.
        counters: int64 [evaluations, split steps], incremented.

    Returns:
        (status, failure time [s]): ``OK``, ``NO_FK``, ``NO_CONVERGENCE`` or ``DIVERGED``.
    """
    if timing.sampled:
        return _run_sampled(
            controller,
            cos_phi,
            sin_phi,
            plant,
            truth,
            reference,
            y0,
            timing,
            workspace,
            out,
            info_out,
            counters,
        )
    return _run_bdf2(
        controller, cos_phi, sin_phi, plant, truth, reference, y0, timing, workspace, out, info_out, counters
    )

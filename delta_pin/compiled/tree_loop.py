"""Compiled sampled closed loop on the Pinocchio plant: designs I/II, zero-order hold, RK4.

The arithmetic of :func:`delta_pin.sim.runner.simulate` in sampled mode with
:meth:`PinocchioPlant.held_rk4 <delta_pin.sim.plants.PinocchioPlant.held_rk4>` (the same stage
kernels, truth rows and reference rows), with two differences of cost only:

* the constrained tree dynamics are evaluated in C++ through :mod:`delta_pin.compiled.native`, by
  the stage :data:`delta_pin.sim.batch.NATIVE_STAGE` names: delta-pin's own recursive algorithms
  (``axis_tree``, the default; equal to the Python loop's to ~1e-13 per evaluation) or the same
  compiled function ``pin.constraintDynamics`` calls (bit for bit); the closure gap after each step
  is computed there too;
* the controller step is the compiled law of :func:`delta_pin.compiled.closed_loop.control_into`.

The loop stops where the closure gap after a step exceeds the projection tolerance: the caller
(:func:`delta_pin.sim.batch.simulate_batch`) projects the state back onto the constraint manifold with
the plant's own Python routine and resumes the loop where it stopped, so that projection has one
implementation.

Per 1 ms sample: four tree evaluations (~1.9 us each with ``axis_tree``, ~5.2 us with
``constraintDynamics``, against ~8 us through the Python binding and ~25 us of Python around them
in :meth:`held_rk4`).
"""

from __future__ import annotations

import numpy as np

from delta_pin.compiled.closed_loop import control_into, record_sample
from delta_pin.compiled.jit import njit
from delta_pin.compiled.native.calls import call_closure_gap, call_tree_dynamics
from delta_pin.compiled.rk4 import within_limits
from delta_pin.compiled.tree_kernels import joint_torques_at, tree_combine, tree_stage

__all__ = ["DIVERGED", "EXPLODED", "NO_FK", "OK", "PINOCCHIO_FAILED", "PROJECT", "run_tree_sampled"]

OK, NO_FK, DIVERGED, PROJECT, EXPLODED, PINOCCHIO_FAILED = 0, 1, 3, 4, 5, 6


@njit(cache=True)
def _held_step(tree, x, tau, active, truth, rotational, friction, row, h, torques, stages, ddq):
    """One RK4 step of length h [s] of the tree x = [q, v] under the held torque tau, from row
    ``row`` of the half-step truth grid (stages at rows row, row+1, row+1, row+2, as
    :meth:`PinocchioPlant.held_rk4 <delta_pin.sim.plants.PinocchioPlant.held_rk4>`); returns
    (x after the step, number of failed dynamics calls)."""
    nq = x.shape[0] - ddq.shape[0]
    disturbances, normals, masses = truth.disturbance, truth.normal_force, truth.platform_mass
    k, points = stages[0:4], stages[4:7]  # k1..k4; the stage points y2, y3, y4
    joint_torques_at(torques, active, tau, x[nq:], disturbances, normals, row, friction)
    failed = call_tree_dynamics(
        tree.dynamics, tree.handle, x[:nq], x[nq:], torques, masses[row], rotational[row], ddq
    )
    q, v = x[:nq], x[nq:]
    for stage in range(3):
        c = h if stage == 2 else 0.5 * h
        at = row + (2 if stage == 2 else 1)  # the stage point's time: t + h/2, t + h/2, t + h
        y = points[stage]
        tree_stage(y, x, k[stage], v, ddq, c, torques, active, tau, disturbances, normals, at, friction)
        q, v = y[:nq], y[nq:]
        failed += call_tree_dynamics(
            tree.dynamics, tree.handle, q, v, torques, masses[at], rotational[at], ddq
        )
    return tree_combine(x, k[0], k[1], k[2], k[3], v, ddq, h / 6.0), failed


@njit(cache=True)
def _joints_of(y, x, nq, active, rho):
    """y = [alpha, alpha_dot, rho_hat]: the controller's view of the tree state x."""
    for i in range(3):
        y[i] = x[active[i]]
        y[3 + i] = x[nq + active[i]]
    y[6:] = rho


@njit(cache=True)
def run_tree_sampled(
    controller, cos_phi, sin_phi, plant, tree, active, platform, truth, rotational, friction, reference,
    timing, limits, state, workspace, out, info_out, counters,
):  # fmt: skip
    """Run (or resume) one sampled run on the tree.

    Args:
        controller: a CONTROLLER record; ``cos_phi``, ``sin_phi``, ``plant``: as
            :func:`~delta_pin.compiled.closed_loop.run_closed_loop` (the controller's kinematics).
        tree: a NATIVE_TREE record.
        active, platform: int64 indices of alpha in q (and v) and of the platform slides in q.
        truth: TRUTH records on the h / 2 grid, h = dt / substeps; ``rotational``: the platform's
            rotational inertia at each of them (R, 3, 3) [kg m^2]; ``friction``: the plant's
            FRICTION record.
        reference: REFERENCE records at the samples (steps + 1,).
        timing: a TIMING record (``step`` = dt); ``limits``: a TREE_LOOP_LIMITS record.
        state: the resumable :func:`~delta_pin.compiled.layouts.tree_loop_state` record (in/out):
            ``substep`` 0 starts sample ``sample`` with a control step; j > 0 resumes it after
            sub-step j - 1 with the held ``tau`` and ``rho_dot``.
        out, info_out: SAMPLE and INFO records per sample; ``counters``: [tree evaluations].

    Returns:
        (status, time [s]): ``OK``; ``PROJECT`` (the state after the sub-step ending at ``time``
        needs projection: ``state`` holds it with ``substep`` advanced); ``NO_FK`` (the
        controller's kinematics failed at the sample); ``DIVERGED`` (non-finite or too fast after
        the sample ending at ``time``); ``EXPLODED`` (gap above the failure tolerance);
        ``PINOCCHIO_FAILED``.
    """
    nr = state.rho_hat.shape[0] if controller.vector_rho else 1
    nx = state.x.shape[0]
    nv = nx // 2  # nq == nv: 1-DOF joints only
    nq = nx - nv
    dt, substeps, steps = timing.step, timing.substeps, timing.samples
    x = state.x.copy()
    rho = state.rho_hat[0:nr].copy()
    tau = state.tau.copy()
    rho_dot = state.rho_dot[0:nr].copy()
    k, j0, gap = state.sample, state.substep, state.gap
    h = dt / substeps
    y = np.empty(6 + nr)
    torques = np.zeros(nv)
    stages = np.empty((7, nx))
    ddq = np.empty(nv)
    alpha_dot = np.empty(3)
    status, when = OK, 0.0
    if k == 0 and j0 == 0:
        gap = call_closure_gap(tree.closure_gap, tree.handle, x[:nq])
    while True:
        if j0 == 0:  # a new sample: the control step, recorded with the tree's platform position
            _joints_of(y, x, nq, active, rho)
            if not control_into(controller, cos_phi, sin_phi, plant, reference[k], y, nr, workspace):
                status, when = NO_FK, k * dt
                break
            record_sample(out[k], info_out[k], y, workspace)
            for i in range(3):
                out[k].xyz[i] = x[platform[i]]
            out[k].closure_gap = gap
            if k == steps:
                break
            tau[:] = workspace.tau
            rho_dot[:] = workspace.rho_dot[0:nr]
        for j in range(j0, substeps):
            x, failed = _held_step(
                tree,
                x,
                tau,
                active,
                truth,
                rotational,
                friction,
                2 * (k * substeps + j),
                h,
                torques,
                stages,
                ddq,
            )
            counters[0] += 4
            when = (k * substeps + j + 1) * h
            if failed:
                status = PINOCCHIO_FAILED
                break
            gap = call_closure_gap(tree.closure_gap, tree.handle, x[:nq])
            if not gap <= limits.failure_tolerance:
                status = EXPLODED
                break
            if gap > limits.projection_tolerance:
                status, j0 = PROJECT, j + 1
                break
        if status != OK:
            break
        j0 = 0
        rho = rho + dt * rho_dot
        when = (k + 1) * dt
        for i in range(3):
            alpha_dot[i] = x[nq + active[i]]
        if not within_limits(x, rho, alpha_dot, timing.max_speed):
            status = DIVERGED
            break
        k += 1
    state.sample, state.substep, state.gap = k, j0, gap
    state.x[:] = x
    state.rho_hat[0:nr] = rho
    state.tau[:] = tau
    state.rho_dot[0:nr] = rho_dot
    return status, when

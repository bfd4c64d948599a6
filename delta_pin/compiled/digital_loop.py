"""Compiled digital loop: a law on a digital drive (the discrete-time laws, or designs I/II with
their state advanced once per sample), on either plant, sampled RK4.

The arithmetic of :func:`delta_pin.sim.loop.run_python_loop` in sampled mode with an encoder, a
computation delay and a torque limit (:mod:`delta_pin.sim.drive`), for the laws of
:mod:`delta_pin.compiled.digital_laws`, in the same order of operations, so that the two agree bit
for bit (tests/sim/test_compiled_loops.py). At sample k:

1. the joints are read: round((alpha + n_k) / q) q with the encoder's noise n_k (drawn in Python
   from its seeded generator, the same stream the Python encoder draws), and the velocity as
   the difference of the readings (zero at the first sample) or the true one;
2. the law's step gives the command and the law's next state;
3. the drive: the command of sample k - d acts (zero before), clipped at the torque limit;
4. ``substeps`` RK4 steps of the plant under that torque (the analytic plant, or the Pinocchio
   tree in full coordinates with the stop-and-resume protocol of
   :mod:`delta_pin.compiled.tree_loop` for projections); then the law's state advances.

The loop's whole state is one :func:`~delta_pin.compiled.layouts.digital_loop_state` record, so a
run can stop (a projection, a failure) and resume.
"""

from __future__ import annotations

import numpy as np

from delta_pin.compiled.adaptive_robust import adaptive_robust_kernel
from delta_pin.compiled.closed_loop import held_rk4_step
from delta_pin.compiled.delta_kernels import delta_kinematics_into
from delta_pin.compiled.digital_laws import digital_law_step
from delta_pin.compiled.jit import njit
from delta_pin.compiled.layouts import ADAPTIVE_ROBUST
from delta_pin.compiled.native.calls import call_closure_gap
from delta_pin.compiled.rk4 import all_finite, within_limits
from delta_pin.compiled.tree_loop import _held_step

__all__ = [
    "DIVERGED",
    "EXPLODED",
    "NONFINITE_TORQUE",
    "NO_FK",
    "OK",
    "PINOCCHIO_FAILED",
    "PROJECT",
    "run_digital_analytic",
    "run_digital_tree",
]

OK, NO_FK, DIVERGED, PROJECT, EXPLODED, PINOCCHIO_FAILED, NONFINITE_TORQUE = 0, 1, 3, 4, 5, 6, 7


@njit(cache=True)
def _read(drive, noise, k, alpha, alpha_dot, state, dt, measured, velocity):
    """What the law sees at sample k (``noise``: (samples, 3) rows, or none)."""
    if drive.resolution == 0.0:
        for i in range(3):
            measured[i] = alpha[i]
            velocity[i] = alpha_dot[i]
        return
    q = drive.resolution
    for i in range(3):
        angle = alpha[i] + noise[k, i] if noise.shape[0] > 0 else alpha[i]
        measured[i] = np.rint(angle / q) * q
        if drive.exact_velocity:
            velocity[i] = alpha_dot[i]
        elif k == 0:
            velocity[i] = 0.0
        else:
            velocity[i] = (measured[i] - state.previous_reading[i]) / dt
        state.previous_reading[i] = measured[i]


@njit(cache=True)
def _apply(drive, state, command):
    """The drive's torque from this sample on: the command of ``delay`` samples ago (zero before),
    clipped; counts a hit where the limit bound."""
    if drive.delay == 0:
        for i in range(3):
            state.tau[i] = command[i]
    else:
        head = state.head
        for i in range(3):
            state.tau[i] = state.pending[head, i]
            state.pending[head, i] = command[i]
        state.head = (head + 1) % drive.delay
    if drive.has_limit:
        hit = False
        for i in range(3):
            clipped = min(max(state.tau[i], -drive.torque_limit[i]), drive.torque_limit[i])
            if clipped != state.tau[i]:
                hit = True
            state.tau[i] = clipped
        if hit:
            state.hits += 1


@njit(cache=True)
def _law_step(
    law, design, cos_phi, sin_phi, z, measured, velocity, row, dt, command, z_next, info, design_info
):
    """The law's command and next state: a digital law's step, or designs I/II's compiled step with
    their continuous state advanced over the period, z + dt z_dot (Controller.advance)."""
    if law.kind != ADAPTIVE_ROBUST:
        return digital_law_step(
            law, cos_phi, sin_phi, z, measured, velocity, row.alpha, row.alpha_dot, row.alpha_ddot, command,
            z_next, info,
        )  # fmt: skip
    rate = np.empty(z.shape[0])
    if not adaptive_robust_kernel(
        design, cos_phi, sin_phi, measured, velocity, row.alpha, row.alpha_dot, row.alpha_ddot, z, command,
        rate, design_info,
    ):  # fmt: skip
        return False
    for i in range(z.shape[0]):
        z_next[i] = z[i] + dt * rate[i]
    return True


@njit(cache=True)
def _control(law, design, cos_phi, sin_phi, drive, noise, reference, k, alpha, alpha_dot, state, dt, sample,
             info, design_info):  # fmt: skip
    """Steps 1-3 at sample k; records the sample; returns a status (OK, NO_FK, NONFINITE_TORQUE)."""
    measured, velocity, command = np.empty(3), np.empty(3), np.empty(3)
    _read(drive, noise, k, alpha, alpha_dot, state, dt, measured, velocity)
    if law.kind == ADAPTIVE_ROBUST:
        for i in range(state.z.shape[0]):
            sample.rho_hat[i] = state.z[i]
    if not _law_step(
        law, design, cos_phi, sin_phi, state.z, measured, velocity, reference[k], dt, command, state.z_next,
        info, design_info,
    ):  # fmt: skip
        return NO_FK
    if not all_finite(command):
        return NONFINITE_TORQUE
    _apply(drive, state, command)
    for i in range(3):
        sample.alpha[i] = alpha[i]
        sample.alpha_dot[i] = alpha_dot[i]
        sample.tau_command[i] = command[i]
        sample.tau[i] = state.tau[i]
    return OK


@njit(cache=True)
def run_digital_analytic(
    law, design, cos_phi, sin_phi, drive, noise, plant, truth, reference, timing, state, workspace, out,
    info_out, design_info_out, counters,
):  # fmt: skip
    """One run on the analytic plant (x = [alpha, alpha_dot]).

    Args:
        law: a DIGITAL_LAW record; ``design``: designs I/II's CONTROLLER record where ``law.kind``
            is ADAPTIVE_ROBUST (any CONTROLLER record otherwise); ``cos_phi``, ``sin_phi``: the
            chain azimuths' cosines and sines.
        drive: a DRIVE record; ``noise``: the encoder's noise per sample (steps + 1, 3), or (0, 3).
        plant: a PLANT record; ``truth``: TRUTH records on the h / 2 grid, h = dt / substeps.
        reference: REFERENCE records at the samples (steps + 1,).
        timing: a TIMING record; ``state``: the digital_loop_state record (in/out); ``workspace``:
            a WORKSPACE record.
        out, info_out, design_info_out: DIGITAL_SAMPLE, DIGITAL_INFO and (designs I/II) INFO
            records per sample; ``counters``: [plant evaluations].

    Returns:
        (status, time [s]).
    """
    dt, substeps, steps = timing.step, timing.substeps, timing.samples
    h = dt / substeps
    x = state.x.copy()
    stages = np.empty((5, 6))  # k1..k4 and a stage point of held_rk4_step
    ws = workspace
    for k in range(steps + 1):
        status = _control(
            law, design, cos_phi, sin_phi, drive, noise, reference, k, x[0:3], x[3:6], state, dt, out[k],
            info_out[k], design_info_out[k],
        )  # fmt: skip
        if status != OK:
            state.x[:] = x
            return status, k * dt
        if not delta_kinematics_into(
            plant.geometry, cos_phi, sin_phi, x[0:3], x[3:6], ws.xyz, ws.J, ws.J_dot, ws.kinematics
        ):
            state.x[:] = x
            return NO_FK, k * dt
        for i in range(3):
            out[k].xyz[i] = ws.xyz[i]
        out[k].closure_gap = 0.0
        if k == steps:
            break
        tau = state.tau
        for j in range(substeps):
            ok = held_rk4_step(cos_phi, sin_phi, plant, truth, 2 * (k * substeps + j), x, tau, h, ws, stages)
            counters[0] += 4
            if not ok:
                state.x[:] = x
                return NO_FK, (k * substeps + j) * h
        state.z[:] = state.z_next
        if not within_limits(x, state.z, x[3:6], timing.max_speed):
            state.x[:] = x
            return DIVERGED, (k + 1) * dt
    state.x[:] = x
    return OK, 0.0


@njit(cache=True)
def run_digital_tree(
    law, design, cos_phi, sin_phi, drive, noise, tree, active, platform, truth, rotational, friction,
    reference, timing, limits, state, out, info_out, design_info_out, counters,
):  # fmt: skip
    """Run (or resume) one run on the Pinocchio tree in full coordinates: the arguments of
    :func:`run_digital_analytic` less the plant, plus those of
    :func:`~delta_pin.compiled.tree_loop.run_tree_sampled` (``tree``, ``active``, ``platform``,
    ``rotational``, ``friction``, ``limits``). ``state.substep`` j > 0 resumes sample
    ``state.sample`` after sub-step j - 1 with the held torque.

    Returns:
        (status, time [s]): ``OK``; ``PROJECT`` (the state after the sub-step ending at ``time``
        needs projection: ``state`` holds it); ``NO_FK``, ``NONFINITE_TORQUE``, ``DIVERGED``,
        ``EXPLODED`` (gap above the failure tolerance), ``PINOCCHIO_FAILED``.
    """
    nx = state.x.shape[0]
    nv = nx // 2  # nq == nv: 1-DOF joints only
    nq = nx - nv
    dt, substeps, steps = timing.step, timing.substeps, timing.samples
    h = dt / substeps
    x = state.x.copy()
    k, j0, gap = state.sample, state.substep, state.gap
    torques = np.zeros(nv)
    stages = np.empty((7, nx))
    ddq = np.empty(nv)
    alpha, alpha_dot = np.empty(3), np.empty(3)
    status, when = OK, 0.0
    if k == 0 and j0 == 0:
        gap = call_closure_gap(tree.closure_gap, tree.handle, x[:nq])
    while True:
        if j0 == 0:  # a new sample: the law's step, recorded with the tree's platform position
            for i in range(3):
                alpha[i] = x[active[i]]
                alpha_dot[i] = x[nq + active[i]]
            status = _control(
                law, design, cos_phi, sin_phi, drive, noise, reference, k, alpha, alpha_dot, state, dt,
                out[k], info_out[k], design_info_out[k],
            )  # fmt: skip
            if status != OK:
                when = k * dt
                break
            for i in range(3):
                out[k].xyz[i] = x[platform[i]]
            out[k].closure_gap = gap
            if k == steps:
                break
        for j in range(j0, substeps):
            x, failed = _held_step(
                tree, x, state.tau, active, truth, rotational, friction, 2 * (k * substeps + j), h, torques,
                stages, ddq,
            )  # fmt: skip
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
        state.z[:] = state.z_next
        when = (k + 1) * dt
        for i in range(3):
            alpha_dot[i] = x[nq + active[i]]
        if not within_limits(x, state.z, alpha_dot, timing.max_speed):
            status = DIVERGED
            break
        k += 1
    state.sample, state.substep, state.gap = k, j0, gap
    state.x[:] = x
    return status, when

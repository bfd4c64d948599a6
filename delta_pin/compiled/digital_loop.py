"""Compiled digital loop: a law on a digital drive (the discrete-time laws, or designs I/II with
their state advanced once per sample), on the Delta's analytic plant, sampled RK4 (on the
Pinocchio plant the compiled core runs these laws with its drive).

The arithmetic of :func:`delta_pin.sim.loop.run_python_loop` in sampled mode with an encoder, a
computation delay and a torque limit (:mod:`delta_pin.sim.drive`), for the laws of
:mod:`delta_pin.compiled.digital_laws`, in the same order of operations, so that the two agree bit
for bit (tests/sim/test_compiled_loops.py). At sample k:

1. the joints are read: round((alpha + n_k) / q) q with the encoder's noise n_k (drawn in Python
   from its seeded generator, the same stream the Python encoder draws), and the velocity as
   the difference of the readings (zero at the first sample) or the true one;
2. the law's step gives the command and the law's next state;
3. the drive: the command of sample k - d acts (zero before), clipped at the torque limit;
4. ``substeps`` RK4 steps of the analytic plant under that torque; then the law's state advances.

The loop's whole state is one :func:`~delta_pin.compiled.layouts.digital_loop_state` record.
"""

from __future__ import annotations

import numpy as np

from delta_pin.compiled.adaptive_robust import adaptive_robust_kernel
from delta_pin.compiled.closed_loop import held_rk4_step
from delta_pin.compiled.delta_kernels import delta_kinematics_into
from delta_pin.compiled.digital_laws import digital_law_step
from delta_pin.compiled.jit import njit
from delta_pin.compiled.layouts import ADAPTIVE_ROBUST
from delta_pin.compiled.rk4 import all_finite, within_limits

__all__ = ["DIVERGED", "NONFINITE_TORQUE", "NO_FK", "OK", "run_digital_analytic"]

OK, NO_FK, DIVERGED, NONFINITE_TORQUE = 0, 1, 3, 7


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

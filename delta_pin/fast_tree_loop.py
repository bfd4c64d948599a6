"""Compiled sampled closed loop on the Pinocchio plant: designs I/II, zero-order hold, RK4.

The arithmetic of :func:`delta_pin.simulate.simulate` in sampled mode with
:meth:`PinocchioPlant.held_rk4 <delta_pin.plant.PinocchioPlant.held_rk4>` (the same stage
kernels, truth rows and reference rows), with two differences of cost only:

* the constrained tree dynamics are Pinocchio's C++ ``constraintDynamics`` called through
  :mod:`delta_pin.native` (the same compiled function ``pin.constraintDynamics`` calls), and the
  closure gap after each step is computed there too;
* the controller step is the compiled law of :func:`delta_pin.fast_closed_loop._control_into`.

The loop stops where the closure gap after a step exceeds the projection tolerance: the caller
(:func:`delta_pin.batch.simulate_batch`) projects the state back onto the constraint manifold with
the plant's own Python routine and resumes the loop where it stopped, so that projection has one
implementation.

Per 1 ms sample: four tree evaluations (~6.8 us each in C++, against ~8 us through the Python
binding and ~25 us of Python around them in :meth:`held_rk4`).
"""

from __future__ import annotations

import math

import numpy as np

from .fast_closed_loop import _control_into, _record, _workspace
from .fast_model import njit
from .native.calls import call_closure_gap, call_tree_dynamics
from .plant import _joint_torques_at, _rk4_combine, _rk4_stage

__all__ = ["DIVERGED", "EXPLODED", "NO_FK", "OK", "PINOCCHIO_FAILED", "PROJECT", "tree_sampled_loop"]

OK, NO_FK, DIVERGED, PROJECT, EXPLODED, PINOCCHIO_FAILED = 0, 1, 3, 4, 5, 6


@njit(cache=True)
def tree_sampled_loop(
    pc,
    cos_phi,
    sin_phi,
    packed_plant,
    tree,
    active,
    platform,
    truth,
    friction,
    ref,
    dt,
    substeps,
    steps,
    limits,
    state,
    out,
    info_out,
    gaps,
    counters,
):
    """Run (or resume) one sampled run on the tree.

    Args:
        pc: the packed controller; ``cos_phi``, ``sin_phi``, ``packed_plant``: as
            :func:`~delta_pin.fast_closed_loop.closed_loop_batch` (the controller's kinematics).
        tree: int64 [address of ``dpn_dynamics``, of ``dpn_closure_gap``, tree handle].
        active, platform: indices of alpha in q (and v) and of the platform slides in q.
        truth: (masses (R,), rotational inertias (R, 3, 3), normal forces (R, 3), disturbances
            (R, 3)) on the h / 2 grid, h = dt / substeps; ``friction``: the plant's friction vector.
        ref: reference rows [alpha_d, alpha_dot_d, alpha_ddot_d] at the samples (steps + 1, 9).
        limits: [max |alpha_dot| (rad/s), projection tolerance (m), failure tolerance (m)].
        state: the resumable state (in/out): [k, j, gap, x (nq + nv), rho_hat (nr), tau (3),
            rho_dot (nr)]; j = 0 starts sample k with a control step, j > 0 resumes it after
            sub-step j - 1 with the held tau and rho_dot.
        out, info_out: per sample [alpha, alpha_dot, tau, xyz, rho_hat] and the controller's info;
            ``gaps``: per sample closure gap [m]; ``counters``: [tree evaluations].

    Returns:
        (status, time [s]): ``OK``; ``PROJECT`` (the state after the sub-step ending at ``time``
        needs projection: ``state`` holds it with j advanced); ``NO_FK`` (the controller's
        kinematics failed at sample k); ``DIVERGED`` (non-finite or too fast after the sample
        ending at ``time``); ``EXPLODED`` (gap above the failure tolerance); ``PINOCCHIO_FAILED``.
    """
    masses, rotational, normals, disturbances = truth
    address_dynamics, address_gap, handle = tree[0], tree[1], tree[2]
    nr = out.shape[1] - 12
    nx = state.shape[0] - 6 - 2 * nr
    nv = nx // 2  # nq == nv: 1-DOF joints only
    nq = nx - nv
    x = state[3 : 3 + nx].copy()
    rho = state[3 + nx : 3 + nx + nr].copy()
    tau = state[3 + nx + nr : 6 + nx + nr].copy()
    rho_dot = state[6 + nx + nr : 6 + nx + 2 * nr].copy()
    k, j0, gap = int(state[0]), int(state[1]), state[2]
    h = dt / substeps
    half = 0.5 * h
    mats, vecs = _workspace(nr)
    y = np.empty(6 + nr)
    torques = np.zeros(nv)
    stages = np.empty((6, nx))
    k1, k2, k3, y2, y3, y4 = stages[0], stages[1], stages[2], stages[3], stages[4], stages[5]
    ddq = np.empty(nv)
    status, when = OK, 0.0
    if k == 0 and j0 == 0:
        gap = call_closure_gap(address_gap, handle, x[:nq])
    while True:
        if j0 == 0:
            for i in range(3):
                y[i] = x[active[i]]
                y[3 + i] = x[nq + active[i]]
            y[6 : 6 + nr] = rho
            if not _control_into(pc, cos_phi, sin_phi, packed_plant, ref[k], y, nr, mats, vecs):
                status, when = NO_FK, k * dt
                break
            _record(out[k], info_out[k], y, vecs)
            for i in range(3):
                out[k, 9 + i] = x[platform[i]]
            gaps[k] = gap
            if k == steps:
                break
            tau[:] = vecs[2, 0:3]
            rho_dot[:] = vecs[6, 0:nr]
        stop = False
        for j in range(j0, substeps):
            # PinocchioPlant.held_rk4: stages at rows i, i+1, i+1, i+2 of the half-step grid
            i = 2 * (k * substeps + j)
            q, v = x[:nq], x[nq:]
            _joint_torques_at(torques, active, tau, v, disturbances, normals, i, friction)
            failed = call_tree_dynamics(
                address_dynamics, handle, q, v, torques, masses[i], rotational[i], ddq
            )
            _rk4_stage(y2, x, k1, v, ddq, half, torques, active, tau, disturbances, normals, i + 1, friction)
            failed += call_tree_dynamics(
                address_dynamics, handle, y2[:nq], y2[nq:], torques, masses[i + 1], rotational[i + 1], ddq
            )
            _rk4_stage(
                y3, x, k2, y2[nq:], ddq, half, torques, active, tau, disturbances, normals, i + 1, friction
            )
            failed += call_tree_dynamics(
                address_dynamics, handle, y3[:nq], y3[nq:], torques, masses[i + 1], rotational[i + 1], ddq
            )
            _rk4_stage(
                y4, x, k3, y3[nq:], ddq, h, torques, active, tau, disturbances, normals, i + 2, friction
            )
            failed += call_tree_dynamics(
                address_dynamics, handle, y4[:nq], y4[nq:], torques, masses[i + 2], rotational[i + 2], ddq
            )
            counters[0] += 4
            when = (k * substeps + j + 1) * h
            if failed:
                status = PINOCCHIO_FAILED
                stop = True
                break
            x = _rk4_combine(x, k1, k2, k3, y4[nq:], ddq, h / 6.0)
            gap = call_closure_gap(address_gap, handle, x[:nq])
            if not gap <= limits[2]:
                status = EXPLODED
                stop = True
                break
            if gap > limits[1]:
                status, j0 = PROJECT, j + 1
                stop = True
                break
        if stop:
            break
        j0 = 0
        rho = rho + dt * rho_dot
        when = (k + 1) * dt
        finite = True
        for i in range(nx):
            finite = finite and math.isfinite(x[i])
        for i in range(nr):
            finite = finite and math.isfinite(rho[i])
        if not finite:
            status = DIVERGED
            break
        too_fast = False
        for i in range(3):
            too_fast = too_fast or abs(x[nq + active[i]]) > limits[0]
        if too_fast:
            status = DIVERGED
            break
        k += 1
    state[0], state[1], state[2] = k, j0, gap
    state[3 : 3 + nx] = x
    state[3 + nx : 3 + nx + nr] = rho
    state[3 + nx + nr : 6 + nx + nr] = tau
    state[6 + nx + nr : 6 + nx + 2 * nr] = rho_dot
    return status, when

"""Kernels of the Pinocchio plant in full coordinates x = [q, v]: the active-joint torques of
eq. 13 and the RK4 stages of a step under a held torque.

:class:`~delta_pin.sim.plants.PinocchioPlant` (its ``derivative`` and its fast sampled step)
builds its torques and stages here. ``friction`` is a
:data:`~delta_pin.compiled.layouts.FRICTION` record.
"""

from __future__ import annotations

import numpy as np

from delta_pin.compiled.delta_kernels import friction_torque
from delta_pin.compiled.jit import as_record, njit
from delta_pin.compiled.rk4 import combine, stage_point

__all__ = [
    "joint_torques",
    "joint_torques_at",
    "largest_gap",
    "tree_combine",
    "tree_derivative",
    "tree_stage",
]


@njit(cache=True)
def joint_torques(out, active, tau, v, disturbance, normal_force, friction):
    """out[active] = tau - (F + M_f(alpha_dot, F_n)) with alpha_dot = v[active]: the torques of
    eq. 13 on the tree's active joints [N m] (what :meth:`Plant.acceleration_terms
    <delta_pin.sim.plants.Plant.acceleration_terms>` gives, bit for bit). ``friction``: a FRICTION
    record or a one-record array."""
    friction = as_record(friction)
    if not friction.on:
        for i in range(len(active)):
            out[active[i]] = tau[i] - disturbance[i]
        return
    alpha_dot = np.empty(len(active))
    for i in range(len(active)):
        alpha_dot[i] = v[active[i]]
    torque = friction_torque(friction, alpha_dot, normal_force)
    for i in range(len(active)):
        out[active[i]] = tau[i] - (disturbance[i] + torque[i])


@njit(cache=True)
def joint_torques_at(out, active, tau, v, disturbances, normal_forces, row, friction):
    """:func:`joint_torques` for row ``row`` of the truth's columns F (R, 3) and F_n (R, 3)."""
    joint_torques(out, active, tau, v, disturbances[row], normal_forces[row], friction)


@njit(cache=True)
def tree_derivative(k, v, ddq):
    """k = [v, ddq]: the derivative of x = [q, v] (1-DOF joints: nq == nv)."""
    n = v.shape[0]
    for i in range(n):
        k[i] = v[i]
        k[n + i] = ddq[i]


@njit(cache=True)
def tree_combine(x, k1, k2, k3, k4, v, ddq, c):
    """x after the step: k4 = [v, ddq] (the last stage), then
    :func:`~delta_pin.compiled.rk4.combine` with c = h / 6 into a new array."""
    tree_derivative(k4, v, ddq)
    out = np.empty(x.shape[0])
    combine(x, k1, k2, k3, k4, c, out)
    return out


@njit(cache=True)
def tree_stage(y, x, k, v, ddq, c, torques, active, tau, disturbances, normal_forces, row, friction):
    """One RK4 stage point of a held-torque step: k = [v, ddq] (the stage derivative of x), y = x
    + c k (:func:`~delta_pin.compiled.rk4.stage_point`), then the joint torques at y for row
    ``row`` of the truth's columns F and F_n (y's time)."""
    tree_derivative(k, v, ddq)
    stage_point(y, x, k, c)
    n = x.shape[0] - v.shape[0]
    joint_torques_at(torques, active, tau, y[n:], disturbances, normal_forces, row, friction)


@njit(cache=True)
def largest_gap(gap, nan, parent, child):
    """(max(gap, max |parent - child|), nan or any NaN among them): one closure's share of
    ``DeltaPinocchioModel.closure_gap`` (:mod:`delta_pin.model.pinocchio_model`) [m]."""
    for i in range(len(parent)):
        d = abs(parent[i] - child[i])
        if d > gap:
            gap = d
        elif d != d:
            nan = True
    return gap, nan

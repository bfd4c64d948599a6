"""Compiled law of the LQR baseline (:class:`delta_pin.control.baselines.LQR`) for the closed loops.

The LQR knows a linear model frozen at one configuration alpha0, so its torque needs no kinematics:

    tau = G0 + F-bar [+ M-bar_f(alpha_dot)] + dG (alpha^d - alpha0) + M0 alpha_ddot^d - K [r, r_dot],

with G0, dG, M0, K and alpha0 computed once by the controller and read from the ``lqr_*`` fields of
a :data:`~delta_pin.compiled.layouts.CONTROLLER` record (``law == LAW_LQR``). The readable
:meth:`LQR.evaluate <delta_pin.control.baselines.LQR.evaluate>` is the specification and the test
oracle (tests/control/test_compiled_step.py: 1e-13 relative; the sums are in its order).
"""

from __future__ import annotations

from delta_pin.compiled.delta_kernels import friction_torque
from delta_pin.compiled.jit import njit

__all__ = ["lqr_law_into"]


@njit(cache=True)
def lqr_law_into(p, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, tau, info):
    """The LQR torque at one state into tau (3,); ``info`` (an INFO record) says ``ok`` and holds
    no robust term."""
    error = (
        alpha[0] - ref_alpha[0], alpha[1] - ref_alpha[1], alpha[2] - ref_alpha[2],
        alpha_dot[0] - ref_alpha_dot[0], alpha_dot[1] - ref_alpha_dot[1], alpha_dot[2] - ref_alpha_dot[2],
    )  # fmt: skip
    offset = (ref_alpha[0] - p.lqr_alpha0[0], ref_alpha[1] - p.lqr_alpha0[1], ref_alpha[2] - p.lqr_alpha0[2])
    for i in range(3):
        tau[i] = p.disturbance[i]
    if p.friction.on:
        friction = friction_torque(p.friction, alpha_dot, p.normal_force)
        for i in range(3):
            tau[i] += friction[i]
    G, dG, M, K = p.lqr_gravity, p.lqr_gravity_slope, p.lqr_inertia, p.lqr_gain
    for i in range(3):
        slope = dG[i, 0] * offset[0] + dG[i, 1] * offset[1] + dG[i, 2] * offset[2]
        inertia = M[i, 0] * ref_alpha_ddot[0] + M[i, 1] * ref_alpha_ddot[1] + M[i, 2] * ref_alpha_ddot[2]
        feedback = 0.0
        for j in range(6):
            feedback += K[i, j] * error[j]
        tau[i] = G[i] + tau[i] + slope + inertia - feedback
    info.ok = True
    info.Lambda = 0.0
    info.robust_gain = 0.0
    info.omega_norm = 0.0
    info.adaptation_active = 0.0
    for i in range(3):
        info.robust_torque[i] = 0.0

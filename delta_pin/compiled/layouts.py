"""Named data layouts of the numba BDF2 loop (:mod:`delta_pin.compiled.closed_loop`, entered through
:mod:`delta_pin.sim.compiled_batch`): numpy structured dtypes, read in its kernels by field. They go
with that loop; every other compiled run takes the compiled core, built from plain numbers.

Every number a kernel reads travels in one of these records (``p.xi``, ``plant.friction.mu_s``,
``ws.J``), never at a position of a float vector: a field that is renamed, added or moved changes
the dtype, and a kernel that reads a missing field fails to compile instead of reading a
neighbour. numba compiles each record type once and caches it (docs/architecture.md section 8).

Records are built with :func:`record`; arrays of records (a truth table, the samples of a run)
with :func:`records`. Both read their fields as attributes. Units are SI throughout. This module
imports only numpy: the model layer builds its records without loading numba.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "CONTROLLER",
    "FRICTION",
    "GEOMETRY",
    "INFO",
    "LAW_ADAPTIVE_ROBUST",
    "LAW_LQR",
    "PLANT",
    "REFERENCE",
    "SAMPLE",
    "STEP_CONTROL",
    "TIMING",
    "TRUTH",
    "WORKSPACE",
    "record",
    "records",
]

F8, B1, I8 = np.float64, np.bool_, np.int64

#: The Delta's constants for the single-state kernels (eqs. 3-10).
GEOMETRY = np.dtype(
    [
        ("R", F8),  # base radius [m]
        ("r", F8),  # platform radius [m]
        ("l_a", F8),  # upper-arm length [m]
        ("l_b", F8),  # forearm length [m]
        ("arm_inertia", F8),  # (m_a / 3 + m_b / 2) l_a^2 [kg m^2], the arm part of M (eq. 7)
        ("arm_gravity", F8),  # (m_a + m_b) g l_a / 2 [N m], the arm part of G (eq. 9, corrected)
        ("g", F8),  # gravity [m/s^2]
    ]
)

#: Stribeck friction of eq. 12 with sgn smoothed by tanh (``on`` False: no friction).
FRICTION = np.dtype(
    [
        ("on", B1),
        ("r_a", F8),  # friction arm [m]
        ("v_s", F8),  # Stribeck sliding speed [m/s]
        ("mu_s", F8),  # static coefficient [-]
        ("mu_d", F8),  # dynamic coefficient [-]
        ("mu_v", F8),  # viscous coefficient [N s/m]
        ("sign_velocity_scale", F8),  # tanh(alpha_dot / scale) for sgn [rad/s]
    ]
)

#: Designs I and II on the Delta's analytic nominal model (eqs. 23-26, 30-32, 55-57, 67), or the LQR
#: baseline (``law``), as the compiled closed loops read them.
CONTROLLER = np.dtype(
    [
        ("D", F8, (3,)),  # error-surface gain [1/s]
        ("T_p", F8, (3,)),  # proportional gain [N m/rad]
        ("T_v", F8, (3,)),  # derivative gain [N m s/rad]
        ("beta", F8),
        ("xi", F8),  # boundary layer [N m]
        ("epsilon", F8),  # dead zone of eq. 25
        ("b1", F8),
        ("b2", F8),
        ("b3", F8),
        ("design_two", B1),  # phi of eq. 56 instead of eq. 31
        ("vector_rho", B1),  # a 3-vector rho_hat in Lambda (else the scalar bound of eq. 67)
        ("sampling_period", F8),  # T [s] of the sampling-aware cap; 0: the paper's law
        ("sampling_margin", F8),
        ("disturbance", F8, (3,)),  # nominal F-bar [N m]
        ("friction", FRICTION),  # nominal friction (compensated when ``friction.on``)
        ("normal_force", F8, (3,)),  # nominal F_n [N]
        ("m_eq", F8),  # nominal m_o + 3/2 m_b [kg]
        ("geometry", GEOMETRY),  # the nominal model's geometry
        # the law: LAW_ADAPTIVE_ROBUST (the fields above) or LAW_LQR (delta_pin.control.baselines.LQR:
        # tau = G0 + F-bar [+ M-bar_f] + dG (alpha^d - alpha0) + M0 alpha_ddot^d - K [r, r_dot],
        # with disturbance, friction and normal_force above)
        ("law", I8),
        ("lqr_alpha0", F8, (3,)),  # the linearisation's configuration [rad]
        ("lqr_gravity", F8, (3,)),  # G0 = G-bar(alpha0) [N m]
        ("lqr_gravity_slope", F8, (3, 3)),  # dG-bar/dalpha at alpha0 [N m/rad]
        ("lqr_inertia", F8, (3, 3)),  # M0 = M-bar(alpha0) [kg m^2]
        ("lqr_gain", F8, (3, 6)),  # K on [r, r_dot] [N m/rad, N m s/rad]
    ]
)
LAW_ADAPTIVE_ROBUST, LAW_LQR = 0, 1  # CONTROLLER.law

#: A plant for the closed loops: the analytic model, or Pinocchio's tree in active coordinates.
PLANT = np.dtype(
    [
        ("geometry", GEOMETRY),
        ("forearm_mass", F8),  # 3/2 m_b [kg]: m_eq = m_o(t) + forearm_mass
        ("friction", FRICTION),
        ("shared_kinematics", B1),  # every controller's nominal geometry is this one
        ("tree", B1),  # the Pinocchio tree through the native library (else the analytic model)
        ("active_dynamics", I8),  # address of dpn_active_dynamics
        ("tree_handle", I8),  # the native tree
        ("nominal_platform_mass", F8),  # [kg]: the platform's rotational inertia scales with it
        ("nominal_platform_rotational", F8, (3, 3)),  # about the COM [kg m^2]
    ]
)

#: The plant's time-varying truth at one time (eq. 13).
TRUTH = np.dtype([("platform_mass", F8), ("normal_force", F8, (3,)), ("disturbance", F8, (3,))])

#: The reference at one time.
REFERENCE = np.dtype([("alpha", F8, (3,)), ("alpha_dot", F8, (3,)), ("alpha_ddot", F8, (3,))])

#: What the controller's step reports besides its torque.
INFO = np.dtype(
    [
        ("ok", B1),  # False: the nominal model has no FK at alpha
        ("Lambda", F8),  # eq. 67 [N m]
        ("robust_gain", F8),  # phi Lambda^2 [N m s/rad]
        ("omega_norm", F8),  # ||omega|| [N m]
        ("adaptation_active", F8),  # 1 outside the dead zone of eq. 25, else 0
        ("robust_torque", F8, (3,)),  # C3 or C4 [N m]
    ]
)

#: One recorded sample of a compiled run (``rho_hat``: the first 1 or 3 entries).
SAMPLE = np.dtype(
    [
        ("alpha", F8, (3,)),
        ("alpha_dot", F8, (3,)),
        ("tau", F8, (3,)),
        ("xyz", F8, (3,)),
        ("rho_hat", F8, (3,)),
        ("closure_gap", F8),  # [m]; 0 on the analytic plant
    ]
)

#: The time grid and the divergence limit of a compiled run.
TIMING = np.dtype(
    [
        ("step", F8),  # BDF2: the step h [s]; sampled: the sample period dt [s]
        ("substeps", I8),  # integrator steps per sample
        ("samples", I8),  # steps: the run records samples 0 .. steps
        ("max_speed", F8),  # |alpha_dot| [rad/s] beyond which the run has diverged
        ("sampled", B1),  # zero-order hold and RK4 (else BDF2)
    ]
)

#: Error control of the compiled Radau IIA integrator.
STEP_CONTROL = np.dtype(
    [
        ("rtol", F8),  # relative tolerance [-]
        ("atol", F8),  # absolute tolerance (SI units of the state)
        ("first_step", F8),  # [s]
        ("max_step", F8),  # [s]
        ("grid_step", F8),  # [s] of the truth and reference tables
    ]
)

#: Scratch space of one closed-loop evaluation (kinematics, controller, plant).
WORKSPACE = np.dtype(
    [
        ("J", F8, (3, 3)),
        ("J_dot", F8, (3, 3)),
        ("kinematics", F8, (6, 3, 3)),  # scratch of delta_kinematics_into
        ("M_bar", F8, (3, 3)),  # the controller's nominal M, C, G
        ("C_bar", F8, (3, 3)),
        ("G_bar", F8, (3,)),
        ("M", F8, (3, 3)),  # the plant's M, C, G
        ("C", F8, (3, 3)),
        ("G", F8, (3,)),
        ("matrix", F8, (3, 3)),  # scratch: a 3x3 inverse, or the platform's rotational inertia
        ("tau", F8, (3,)),  # the controller's torque [N m]
        ("rho_dot", F8, (3,)),
        ("info", INFO),
        ("xyz", F8, (3,)),  # the platform position [m]
        ("gap", F8, (1,)),  # the closure gap [m] the tree reports
        ("rhs", F8, (3,)),  # net active torques [N m]
        ("truth", TRUTH),  # the truth inside a split step (interpolated)
        ("reference", REFERENCE),  # the reference inside a split step (interpolated)
    ]
)


def record(dtype: np.dtype, **values) -> np.record:
    """One zeroed record of ``dtype`` with the given fields set: a writable ``np.record``, whose
    fields read as attributes (``rec.xi``) in Python as in compiled code."""
    out = np.zeros(1, dtype).view(np.recarray)[0]
    for name, value in values.items():
        out[name] = value
    return out


def records(dtype: np.dtype, count: int) -> np.recarray:
    """``count`` zeroed records of ``dtype`` (a ``np.recarray``: fields read as attributes)."""
    return np.zeros(count, dtype).view(np.recarray)

"""The plants in the compiled core, and the core's one run of a plant with any controller
(docs/architecture.md section 7).

A :class:`~delta_pin.sim.closed_chain_plant.ClosedChainPlant`'s copy
(``delta_pin/core/plant/closed_chain.cpp``) is built from the very numbers of the Python plant -- the
robot's Pinocchio model (its text archive, closure frames included), the closures with the
plant's Baumgarte gains and proximal settings, the springs, dampers, friction and the payload --
and integrates x = [q, v] with the same RK4 steps, renormalisation and projections. An
:class:`~delta_pin.sim.plants.AnalyticPlant`'s (``delta_pin/core/plant/analytic_plant.cpp``) takes the
Delta's constants and friction and integrates the paper's reduced ODE. Either reads its
time-varying truth (the uncertainty profile, the payload) from a table of the integrator's times
(:func:`set_core_truth`). The controller runs in the core (its compiled law) or stays in Python:
the loop then calls back once per sample for the torque (sensor, controller, drive), so a user's
own law gets the compiled plant.

:meth:`Plant.sampled_core <delta_pin.sim.plants.Plant.sampled_core>` says whether a plant has one.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from delta_pin.compiled.core import core
from delta_pin.errors import SimulationError
from delta_pin.model.core_model import core_chain, core_friction, core_springs
from delta_pin.model.kinematics import chain_trigonometry

__all__ = [
    "CoreRecords",
    "build_core_analytic_plant",
    "build_core_plant",
    "keep_core_projections",
    "python_core_plant",
    "run_core",
    "set_core_truth",
]


class CoreRecords:
    """What the core's run recorded at its samples (:func:`run_core`): the actuated joints
    ``alpha``, ``alpha_dot``, the torque that acted ``tau``, the law's integrated ``state``
    (continuous mode), the multibody ``q``, ``v`` (``None`` where the plant has no configuration),
    the end effector ``xyz`` [m], the closure ``gap``, with a drive the law's ``commands`` [N m] and
    the torque limit's ``hits``, and the integrators' counters
    (``radau_counters``, ``bdf2_counters``: see ``RunRecords``).

    For a plant written in Python (:func:`python_core_plant`) the core recorded its state x; the
    multibody configuration is the plant's own reading of each row (``configuration_state``)."""

    def __init__(self, records, compiled, plant=None) -> None:
        self.alpha, self.alpha_dot = np.array(records.alpha), np.array(records.alpha_dot)
        self.tau, self.state = np.array(records.tau), np.array(records.state)
        self.xyz, self.gap = np.array(records.xyz), np.array(records.gap)
        self.commands, self.hits = np.array(records.commands), int(records.hits)  # with a drive
        self.q = self.v = None
        self.radau_counters, self.bdf2_counters = records.radau_counters, records.bdf2_counters
        if isinstance(compiled, core().PythonPlant):
            full = [plant.configuration_state(x) for x in np.array(records.q)]
            if full and full[0] is not None:
                self.q, self.v = np.array([c[0] for c in full]), np.array([c[1] for c in full])
        elif compiled.has_configuration:  # the reduced Delta's q, v are alpha, alpha_dot
            self.q, self.v = np.array(records.q), np.array(records.v)


def _payload_masses(plant, step: float, count: int) -> np.ndarray:
    """The payload m(t) [kg] at t = i step, i < count (the RK4 stage times).

    Raises:
        SimulationError: m(t) is not a finite mass >= 0 (at the first such time).
    """
    masses = np.array([float(plant.payload_mass(i * step)) for i in range(count)])
    bad = np.flatnonzero(~(np.isfinite(masses) & (masses >= 0.0)))
    if bad.size:
        raise SimulationError(f"payload_mass(t) returned {masses[bad[0]]!r} kg", bad[0] * step)
    return masses


def build_core_plant(plant, step: float | None = None, count: int = 0):
    """The core's plant for a Python ``ClosedChainPlant`` (the caller checks that it applies),
    with the payload and the uncertainty profile's truth tabulated at t = i step, i < count [s]
    (:func:`set_core_truth`; ``count=0``: the caller sets it later).

    Every joint type is taken: one without a configuration rate (a universal joint, ZYX Euler
    angles, a composite beside a ball) is stepped in active coordinates only.

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """
    robot = plant.robot
    module = core()
    constraints = [
        (
            6 if cm.type == pin.ContactType.CONTACT_6D else 3,
            int(cm.joint1_id),
            cm.joint1_placement.homogeneous,
            int(cm.joint2_id),
            cm.joint2_placement.homogeneous,
            int(cm.reference_frame),
        )
        for cm in plant.constraint_models
    ]
    settings = plant.settings
    chain = core_chain(robot, core_springs(robot, damping=plant.joint_damping))
    compiled = module.ClosedChainPlant(
        chain, constraints, *plant.baumgarte_gains, settings.absolute_accuracy, settings.mu,
        settings.max_iter, plant.projection_tolerance,
    )  # fmt: skip
    if math.isfinite(plant.failure_tolerance):
        compiled.set_failure_tolerance(plant.failure_tolerance, plant._gap_unit)
    if plant.friction is not None:
        compiled.set_friction(
            core_friction(plant.stribeck, plant.friction.sign_velocity_scale, plant._normal_force)
        )
    if step is not None and count > 0:
        set_core_truth(compiled, plant, step, count)
    return compiled


def set_core_truth(compiled, plant, step: float, count: int) -> None:
    """The plant's time-varying truth at t = i step, i < count [s] into its core copy: the
    uncertainty profile's m_o(t), F_n(t), F(t) (:mod:`delta_pin.sim.truth`) and, for a closed
    chain, its payload m(t); nothing where the plant has neither (its nominal truth).

    Raises:
        SimulationError: the payload m(t) is not a finite mass >= 0.
    """
    payload = getattr(plant, "payload_mass", None)
    if payload is None and plant.uncertainty is None:
        return
    body, normal, disturbance = np.zeros(0), np.zeros((0, plant.dof)), np.zeros((0, plant.dof))
    if plant.uncertainty is not None:  # m_o(t), F_n(t), F(t) at the table's times (sim/truth.py)
        body, normal, disturbance = (
            np.ascontiguousarray(a, dtype=float) for a in plant.truth_table(step, count)
        )
    if compiled.has_configuration:  # a multibody: the truth's body, and a point payload
        points = _payload_masses(plant, step, count) if payload is not None else np.zeros(0)
        compiled.set_truth(
            int(plant._payload_joint), plant._payload_point, step, body, points, normal, disturbance
        )
    else:
        compiled.set_truth(step, body, normal, disturbance)


def build_core_analytic_plant(plant, step: float | None = None, count: int = 0):
    """The core's reduced Delta (``delta_pin/core/plant/analytic_plant.hpp``) for a Python
    :class:`~delta_pin.sim.plants.AnalyticPlant`, with its truth tabulated at t = i step,
    i < count [s] (:func:`set_core_truth`).

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """
    module = core()
    p = plant.robot.params
    compiled = module.AnalyticDeltaPlant(
        p.R, p.r, p.l_a, p.l_b, p.arm_equivalent_inertia, 0.5 * (p.m_a + p.m_b) * p.g * p.l_a, p.g,
        *chain_trigonometry(), 1.5 * p.m_b, p.m_o,
    )  # fmt: skip
    if plant.friction is not None:
        normal_force = np.full(3, float(plant.friction.normal_force))
        compiled.set_friction(core_friction(plant.stribeck, plant.friction.sign_velocity_scale, normal_force))
    if step is not None and count > 0:
        set_core_truth(compiled, plant, step, count)
    return compiled


def python_core_plant(plant, states: int):
    """A plant written in Python (``derivative``, ``finish_step_residual``, ``joint_state``,
    ``platform_position``, ``closure_residual`` of :class:`~delta_pin.sim.plants.Plant`) in the
    core's sampled run (``PythonPlant`` of ``delta_pin/core/python/python_plant.cpp``), its state of
    ``states`` entries: the core's RK4 calls its derivative back at every stage.

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """

    def derivative(t: float, x: np.ndarray, tau: np.ndarray) -> np.ndarray:
        dx = np.asarray(plant.derivative(t, x, tau), dtype=float)
        if dx.shape != (states,):
            raise SimulationError(
                f"plant {plant.name!r}'s derivative returned shape {dx.shape}, expected ({states},)", t
            )
        return dx

    def finish(x: np.ndarray, t: float) -> tuple[np.ndarray, float]:
        x, gap = plant.finish_step_residual(x, t)
        return np.asarray(x, dtype=float), float(gap)

    def joints(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        alpha, alpha_dot = plant.joint_state(x)
        return np.asarray(alpha, dtype=float), np.asarray(alpha_dot, dtype=float)

    def position(x: np.ndarray) -> np.ndarray:
        return np.asarray(plant.platform_position(x), dtype=float)

    def gap(x: np.ndarray) -> float:
        return float(plant.closure_residual(x))

    return core().PythonPlant(states, plant.dof, derivative, finish, joints, position, gap)


def run_core(compiled, law, settings, x: np.ndarray, plant=None, z0=None, reference=None) -> CoreRecords:
    """The core's one run (``delta_pin/core/run/run.hpp``) of ``compiled`` (any core plant) from its
    state x: ``settings`` (a ``RunSettings``) names the integrator -- ``"rk4"``: ``law`` (a compiled
    law or ``control(k, x) -> tau``) gives the torque held over each sample; ``"radau"``/``"bdf2"``:
    plant and law (compiled, or an object with ``evaluate`` and ``keep``) integrated as one ODE from
    the law's state ``z0`` along ``reference`` (a ``HermiteReference``). ``plant``: the Python
    plant of a ``PythonPlant``.

    Raises:
        SimulationError: the loops cannot be closed again, the state is no longer finite or the
            run diverged (at the time it happened, with the last configuration recorded);
            whatever a Python ``law`` raises passes through unchanged.
    """
    module = core()
    records = module.RunRecords()
    try:
        module.run(compiled, law, settings, np.asarray(x, dtype=float), records, z0, reference)
    except module.SimulationFailure as exc:
        time = records.failure_time
        last = None
        if compiled.has_configuration and records.samples > 0:
            last = np.array(records.q[records.samples - 1])
        raise SimulationError(str(exc), time if math.isfinite(time) else 0.0, last) from None
    return CoreRecords(records, compiled, plant)


def keep_core_projections(plant, compiled) -> None:
    """Add the projections the core's copy of ``plant`` made during a run to the Python plant's
    own counters, which the run's metadata reads: how many, and the largest gap brought back."""
    if compiled.projections:  # a closed chain's (the reduced Delta has no loops to project onto)
        plant.projections += compiled.projections
        plant.largest_projected_gap = max(plant.largest_projected_gap, compiled.largest_projected_gap)

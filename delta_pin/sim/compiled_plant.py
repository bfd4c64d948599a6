"""The plants in the compiled core, and the sampled loop that runs them with any controller
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
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from delta_pin.compiled.core import core
from delta_pin.errors import SimulationError
from delta_pin.model.core_model import core_chain, core_friction, core_springs
from delta_pin.model.kinematics import chain_trigonometry

__all__ = [
    "CompiledSampledRun",
    "build_core_analytic_plant",
    "build_core_plant",
    "keep_core_projections",
    "python_core_plant",
    "run_core_sampled",
    "set_core_truth",
]


class CompiledSampledRun:
    """What the compiled sampled loop records (steps + 1 rows): q, v, end-effector xyz, closure gap.

    For a plant written in Python (:func:`python_core_plant`) the core recorded its state x; the
    joints and the multibody configuration are the plant's own reading of each row
    (``joint_state``, ``configuration_state``)."""

    def __init__(
        self, q: np.ndarray, v: np.ndarray, xyz: np.ndarray, gap: np.ndarray, compiled, plant=None
    ) -> None:
        self.q, self.v, self.xyz, self.gap = q, v, xyz, gap
        if isinstance(compiled, core().PythonPlant):
            joints = [plant.joint_state(x) for x in q]
            self.alpha = np.array([a for a, _ in joints])
            self.alpha_dot = np.array([ad for _, ad in joints])
            full = [plant.configuration_state(x) for x in q]
            self.q = self.v = None
            if full and full[0] is not None:
                self.q, self.v = np.array([c[0] for c in full]), np.array([c[1] for c in full])
            return
        self.alpha = q[:, np.asarray(compiled.actuated_q)]  # the actuated joints (rad)
        self.alpha_dot = v[:, np.asarray(compiled.actuated_v)]  # (rad/s)
        if not compiled.has_configuration:  # the reduced Delta: q, v are alpha, alpha_dot
            self.q = self.v = None


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

    Returns ``None`` for a model the core refuses (a joint without a configuration rate).

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
    try:
        compiled = module.ClosedChainPlant(
            chain, constraints, *plant.baumgarte_gains, settings.absolute_accuracy, settings.mu,
            settings.max_iter, plant.projection_tolerance,
        )  # fmt: skip
    except (ValueError, RuntimeError):
        return None
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
    core's sampled loop (``PythonPlant`` of ``delta_pin/core/python/python_plant.cpp``), its state of
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


def run_core_sampled(
    compiled,
    x: np.ndarray,
    steps: int,
    substeps: int,
    dt: float,
    control: Callable[[int, np.ndarray], np.ndarray],
    plant=None,
) -> CompiledSampledRun:
    """Run the core's sampled loop of ``compiled`` (any core plant) from x: ``control(k, x)`` (a
    Python function, or a compiled law) gives the torque held over sample k; ``plant``: the
    Python plant of a ``PythonPlant`` (:class:`CompiledSampledRun`).

    Raises:
        SimulationError: the loops cannot be closed again or the state is no longer finite (at
            the time it happened); whatever ``control`` raises passes through unchanged.
    """
    n = steps + 1
    q = np.zeros((n, compiled.nq))
    v = np.zeros((n, compiled.nv))
    xyz = np.zeros((n, 3))
    gap = np.zeros(n)
    try:
        compiled.run_sampled(np.asarray(x, dtype=float), steps, substeps, dt, control, q, v, xyz, gap)
    except core().SimulationFailure as exc:
        time = compiled.failure_time
        raise SimulationError(str(exc), time if math.isfinite(time) else 0.0) from None
    return CompiledSampledRun(q, v, xyz, gap, compiled, plant)


def keep_core_projections(plant, compiled) -> None:
    """Add the projections the core's copy of ``plant`` made during a run to the Python plant's
    own counters, which the run's metadata reads: how many, and the largest gap brought back."""
    if compiled.projections:  # a closed chain's (the reduced Delta has no loops to project onto)
        plant.projections += compiled.projections
        plant.largest_projected_gap = max(plant.largest_projected_gap, compiled.largest_projected_gap)

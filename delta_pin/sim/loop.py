"""The closed loop (docs/architecture.md section 6): any controller on any plant, by any of the
core's integrators, as the compiled core's one run (``delta_pin/core/run/run.hpp``).

One entry, :func:`run_loop`. What differs between runs is declared once, not branched on by its
callers:

* the integrator (:data:`INTEGRATIONS`): ``"rk4"`` samples the controller once per period and
  holds its torque while the plant takes ``substeps`` RK4 steps (a digital drive: the
  controller's state advances once per period, z_{k+1} = z_k + dt z_dot_k, or to a discrete-time
  law's next state); ``"radau"`` (Radau IIA of order 5 with error control,
  ``delta_pin/core/integrate/radau.hpp``) and ``"bdf2"`` (fixed steps dt / substeps) integrate the
  plant and the controller's state as one ODE, the law evaluated inside the integrator along the
  reference's cubic Hermite table (the paper's analysis);
* the plant: its compiled copy (:meth:`Plant.build <delta_pin.sim.plants.Plant.build>`,
  :meth:`~delta_pin.sim.plants.Plant.sampled_core`; every built-in plant has one) or, under RK4
  only, a plant a user wrote in Python, its ``derivative`` called back at every stage
  (:func:`~delta_pin.sim.compiled_plant.python_core_plant`);
* the law: the controller's compiled law (:meth:`Controller.sampled_core_law
  <delta_pin.control.base.Controller.sampled_core_law>`), Python not called during the run, or the
  controller called back (:class:`CalledBack`: once per sample under RK4, at every evaluation of a
  continuous integrator). Either way the encoder and the drive are the core's
  (``delta_pin/core/run/drive.hpp``).

A continuous run in active coordinates assembles q(alpha) by Newton at every evaluation; a closed
chain with idle motions or passive joints is integrated in its whole state [q, v, z] instead,
projected back onto the loops every :data:`~delta_pin.sim.integrators.PROJECTION_CHUNK` samples.
The readable Python loop the core is tested against lives in ``tests/reference/python_loop.py``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from delta_pin.compiled.core import core
from delta_pin.control.base import Controller, ControlOutput, Reference
from delta_pin.errors import InvalidParameterError, NonFiniteError, SimulationError
from delta_pin.sim.compiled_plant import keep_core_projections, python_core_plant, run_core, set_core_truth
from delta_pin.sim.drive import Drive, Encoder
from delta_pin.sim.integrators import MAX_JOINT_SPEED, PROJECTION_CHUNK, all_finite, check_state
from delta_pin.sim.plants import Plant
from delta_pin.sim.reference import ReferenceTable
from delta_pin.utils.progress import Progress

__all__ = [
    "INTEGRATIONS",
    "RADAU_FIRST_STEP",
    "RADAU_MAX_STEP",
    "CalledBack",
    "ControlLoop",
    "Integration",
    "LoopRecord",
    "run_loop",
]

RADAU_FIRST_STEP = 1e-5  # [s]: a run starts in the reaching phase, off the path
RADAU_MAX_STEP = 1e-2  # [s]


class ControlLoop:
    """A controller on a plant: evaluates it with checks that name the time of a bad output."""

    def __init__(self, controller: Controller, plant: Plant) -> None:
        self.controller = controller
        self.plant = plant

    def control(
        self, t: float, x: np.ndarray, reference: Reference, z: np.ndarray, joints=None
    ) -> tuple[np.ndarray, np.ndarray, ControlOutput]:
        """(tau, z_dot, output) at t [s]; ``joints``: x's (alpha, alpha_dot) if already known."""
        alpha, alpha_dot = self.plant.joint_state(x) if joints is None else joints
        out = self.controller.evaluate(t, alpha, alpha_dot, reference, z)
        tau = np.asarray(out.tau, dtype=float)
        if tau.shape != (self.plant.dof,):
            raise SimulationError(
                f"controller {self.controller.name!r} returned a torque of shape {tau.shape}, "
                f"expected ({self.plant.dof},)",
                t,
            )
        if not all_finite(tau):
            raise SimulationError(
                f"controller {self.controller.name!r} returned a non-finite torque {tau.tolist()}", t
            )
        return tau, np.asarray(out.state_derivative, dtype=float), out

    def check_state(self, t: float, x: np.ndarray, z: np.ndarray) -> None:
        """:func:`~delta_pin.sim.integrators.check_state` on the plant state x and controller state z."""
        check_state(t, x, z, *self.plant.joint_state(x))


@dataclass
class LoopRecord:
    """What the loop records at every sample (N = steps + 1 rows)."""

    alpha: np.ndarray
    alpha_dot: np.ndarray
    tau: np.ndarray
    xyz: np.ndarray
    closure_residual: np.ndarray
    internals: dict[str, np.ndarray] = field(default_factory=dict)
    q: np.ndarray | None = None  # the plant's full configuration (N, nq), where it has one
    v: np.ndarray | None = None  # and its velocity (N, nv)


@dataclass(frozen=True)
class Integration:
    """How a run integrates: ``integrator`` (a key of :data:`INTEGRATIONS`), ``substeps`` (RK4 or
    BDF2 steps per sample, >= 1) and Radau's tolerances (``rtol`` relative, ``atol`` absolute in
    SI units of the state)."""

    integrator: str
    substeps: int = 1
    rtol: float = 1e-6
    atol: float = 1e-8

    @property
    def declared(self) -> IntegratorDeclaration:
        return INTEGRATIONS[self.integrator]

    def metadata(self) -> dict:
        """What a run's metadata records of the integrator: its name, and the tolerances of the
        one with error control."""
        tolerances = {"rtol": self.rtol, "atol": self.atol} if self.declared.tolerances else {}
        return {"integrator": self.integrator, **tolerances}


@dataclass(frozen=True)
class IntegratorDeclaration:
    """What an integrator of the core asks of a run.

    Attributes:
        sampled: the law is sampled once per period and its torque held (``"rk4"``), or evaluated
            inside the integrator (a continuous one).
        reference_per_sample: rows of the reference table per sample period, from the substeps
            (the integrator's grid: the samples, the BDF2 steps, or dt/4 for Radau's cubic
            Hermite table).
        counters: the run's counters the integrator reports (``RunRecords`` field, metadata
            names), or none.
        tolerances: whether it controls its error (``rtol``, ``atol`` apply and are recorded).
    """

    sampled: bool
    reference_per_sample: Callable[[int], int]
    counters: tuple[str, tuple[str, ...]] | None = None
    tolerances: bool = False


INTEGRATIONS: dict[str, IntegratorDeclaration] = {
    "rk4": IntegratorDeclaration(sampled=True, reference_per_sample=lambda substeps: 1),
    "radau": IntegratorDeclaration(
        sampled=False,
        reference_per_sample=lambda substeps: 4,
        counters=(
            "radau_counters",
            ("radau_steps", "radau_rejected", "rhs_evaluations", "jacobians", "factorizations"),
        ),
        tolerances=True,
    ),
    "bdf2": IntegratorDeclaration(
        sampled=False,
        reference_per_sample=lambda substeps: substeps,
        counters=("bdf2_counters", ("bdf2_steps", "rhs_evaluations", "split_steps", "jacobians")),
    ),
}


def run_loop(
    controller: Controller,
    plant: Plant,
    table: ReferenceTable,
    alpha0: np.ndarray,
    alpha_dot0: np.ndarray,
    t: np.ndarray,
    integration: Integration,
    *,
    progress: bool | None = False,
    sensor: Encoder | None = None,
    drive: Drive | None = None,
) -> tuple[LoopRecord, dict]:
    """Run ``controller`` on ``plant`` from (alpha0 [rad], alpha_dot0 [rad/s]) over the sample
    times t [s] (module docstring): returns the record and the integrator's counters.

    ``table`` holds the reference on the integrator's grid
    (:attr:`IntegratorDeclaration.reference_per_sample` rows per sample). With a ``sensor`` the
    controller sees its readings instead of the true joint state; with a ``drive`` its torque acts
    after the drive's delay and saturation (what is recorded as ``tau``; the controller's own
    output is the internal ``tau_command``): RK4 only (``simulate`` checks).

    Raises:
        InvalidParameterError: a continuous integrator on a plant without a compiled copy, a
            discrete-time controller or a plant without actuated joints.
        SimulationError: the loops cannot be closed, the state or the torque became non-finite,
            |alpha_dot| exceeded the divergence limit or Radau's step size collapsed (at the time
            it happened).
    """
    declared = integration.declared
    steps, dt = len(t) - 1, float(t[1] - t[0])
    controller.reset()
    z0 = np.asarray(controller.initial_state(), dtype=float)
    x0 = plant.initial_state(np.asarray(alpha0, float), np.asarray(alpha_dot0, float))
    compiled_plant = _core_plant(plant, controller, table, integration, steps, len(x0))
    if compiled_plant.has_configuration:  # the core's plant steps the multibody's [q, v]
        x0 = np.concatenate(plant.configuration_state(x0))
    settings = _run_settings(integration, steps, dt)
    if sensor is not None or drive is not None:
        settings.drive = _core_drive(sensor, drive, steps + 1, plant.dof)
    bar = Progress(round(steps * dt, 9), progress, label="simulate", unit="s")
    try:
        law, reference = _law(controller, plant, table, declared, t, z0, sensor, bar)
        z_start = None if declared.sampled else z0  # a sampled law holds its own state
        recorded = run_core(compiled_plant, law, settings, x0, plant, z_start, reference)
    finally:
        bar.close()  # a failed run ends its progress line too
    keep_core_projections(plant, compiled_plant)
    record = LoopRecord(recorded.alpha, recorded.alpha_dot, recorded.tau, recorded.xyz, recorded.gap)
    record.q, record.v = recorded.q, recorded.v
    record.internals = controller.core_law_internals(law)  # the law's records, compiled or called back
    if drive is not None:
        record.internals["tau_command"] = recorded.commands
        drive.hits = recorded.hits
    counters = {}
    if declared.counters is not None:
        field_name, names = declared.counters
        counters = dict(zip(names, map(int, getattr(recorded, field_name)), strict=True))
    return record, counters


def _core_plant(
    plant: Plant,
    controller: Controller,
    table: ReferenceTable,
    integration: Integration,
    steps: int,
    states: int,
):
    """The core's plant of a run, its truth tabulated on the integrator's grid: RK4's stage times
    (h/2 apart), or the reference table's rows for a continuous integrator (interpolated
    linearly between them); under RK4 a plant without a compiled copy is called back."""
    if integration.declared.sampled:
        h = float(table.step) / integration.substeps
        plant.precompute_truth(h / 2.0, 2 * steps * integration.substeps + 1)
        compiled = plant.sampled_core(h, 2 * steps * integration.substeps + 3)
        return compiled if compiled is not None else python_core_plant(plant, states)
    compiled, period = None, getattr(controller, "dt", None)
    if period is not None:
        why = f"controller {controller.name!r} is discrete-time (dt={period})"
    elif plant.dof == 0:
        why = "the robot has no actuated joint (a free motion)"
    else:
        compiled = plant.build()
        why = f"plant {getattr(plant, 'name', plant)!r} has no compiled copy (a plant written in Python)"
    if compiled is None:
        raise InvalidParameterError(
            f"mode='continuous' runs in the compiled core's Radau IIA, and {why}: use mode='sampled'"
        )
    set_core_truth(compiled, plant, table.step, len(table.alpha))
    return compiled


def _run_settings(integration: Integration, steps: int, dt: float):
    """The core's ``RunSettings`` of steps + 1 samples dt [s] apart by ``integration``."""
    settings = core().RunSettings()
    settings.integrator, settings.samples, settings.dt = integration.integrator, steps + 1, dt
    settings.substeps, settings.max_joint_speed = integration.substeps, MAX_JOINT_SPEED
    settings.rtol, settings.atol = integration.rtol, integration.atol
    settings.first_step, settings.max_step = RADAU_FIRST_STEP, RADAU_MAX_STEP
    settings.projection_interval = PROJECTION_CHUNK
    return settings


def _law(controller, plant, table, declared: IntegratorDeclaration, t, z0, sensor, bar):
    """(the run's law, the Hermite reference of a continuous integrator or ``None``): the
    controller's compiled law, given the reference per sample under RK4, or the controller called
    back -- also under RK4 where the encoder gives no velocity and the controller estimates its
    own."""
    law = controller.sampled_core_law()
    own_velocity = type(controller).estimate_velocity is not Controller.estimate_velocity
    estimates = sensor is not None and sensor.velocity == "none" and own_velocity
    if law is None or estimates:
        law = CalledBack(controller, plant, table.rows(1), t, z0, bar, estimates)
    reference = None
    if not declared.sampled:
        reference = core().HermiteReference()
        reference.step = table.step
        reference.alpha, reference.alpha_dot, reference.alpha_ddot, reference.alpha_dddot = (
            np.ascontiguousarray(a)
            for a in (table.alpha, table.alpha_dot, table.alpha_ddot, table.alpha_dddot)
        )
    elif not isinstance(law, CalledBack):
        dt = float(t[1] - t[0])
        law.start(*(np.ascontiguousarray(r) for r in table.rows(1)), dt, z0, len(t))
    return law, reference


class CalledBack:
    """A controller without a compiled law in the core's run: its sampled face is called once per
    sample with the joints as the run's encoder reads them (the controller's own velocity
    estimate where ``estimates``), its state advanced and checked; its continuous face
    (:meth:`evaluate`, :meth:`keep`) at every evaluation of a continuous integrator, with the
    checks of :class:`ControlLoop` (a torque of the wrong shape or not finite is a
    :class:`~delta_pin.errors.SimulationError` naming the controller and the time). Its internals
    are recorded at the samples."""

    def __init__(self, controller, plant, reference_rows, t, z, bar, estimates: bool) -> None:
        self.controller, self.loop = controller, ControlLoop(controller, plant)
        self.reference_rows, self.t, self.dt, self.z = reference_rows, t, t[1] - t[0], z
        self.bar, self.stride = bar, max((len(t) - 1) // 100, 1)
        self.estimates, self.previous_reading, self.out = estimates, None, None
        self.internals: dict[str, list] = {}

    def __call__(self, k: int, x: np.ndarray, alpha: np.ndarray, alpha_dot: np.ndarray) -> np.ndarray:
        t, dt = self.t[k], self.dt
        if k:
            self.z = self.controller.advance(self.z, self.out, dt)
            if not all_finite(self.z):
                raise SimulationError(f"the state became non-finite (alpha={alpha.tolist()})", t)
            if k % self.stride == 0:
                self.bar.update(round(self.stride * dt, 9))
        if self.estimates:
            alpha_dot = self.controller.estimate_velocity(alpha, self.previous_reading, dt)
            self.previous_reading = alpha
        rows = self.reference_rows
        reference = Reference(rows[0][k], rows[1][k], rows[2][k])
        tau, _, self.out = self.loop.control(t, x, reference, self.z, (alpha, alpha_dot))
        self._keep_internals()
        return tau

    def evaluate(self, t, q, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z):
        reference = Reference(ref_alpha, ref_alpha_dot, ref_alpha_ddot)
        tau, z_dot, self.out = self.loop.control(t, None, reference, z, (alpha, alpha_dot))
        return tau, z_dot

    def keep(self, k, tau, z) -> None:
        self._keep_internals()

    @property
    def records(self) -> dict[str, np.ndarray]:
        """The controller's internals at the samples by name, one array (N, ...) each (what a
        compiled law's ``records`` holds)."""
        return _stacked(self.internals)

    def _keep_internals(self) -> None:
        for name, value in self.out.internals.items():
            self.internals.setdefault(name, []).append(np.asarray(value, dtype=float))


def _core_drive(sensor: Encoder | None, drive: Drive | None, samples: int, dof: int):
    """The encoder and the drive of :func:`run_loop` as the core's run takes them
    (``DriveSettings``): the same readings (the encoder's noise drawn from its seed in the order
    :meth:`Encoder.read <delta_pin.sim.drive.Encoder.read>` draws it, one row of ``dof`` angles
    per sample; a velocity the controller estimates itself starts from the readings'
    difference), delay and torque limit."""
    settings = core().DriveSettings()
    settings.noise = np.zeros((0, dof))
    if sensor is not None:
        settings.sensor, settings.resolution = True, sensor.resolution
        settings.exact_velocity = sensor.velocity == "exact"
        if sensor.noise > 0.0:
            settings.noise = np.random.default_rng(sensor.seed).normal(0.0, sensor.noise, (samples, dof))
    if drive is not None:
        settings.drive, settings.delay = True, drive.delay
        settings.torque_limit = np.zeros(0) if drive.torque_limit is None else drive.torque_limit
    return settings


def _stacked(internals: dict[str, list]) -> dict[str, np.ndarray]:
    """The controller's internals, one array (N, ...) each."""
    try:
        return {name: np.array(values) for name, values in internals.items()}
    except ValueError:  # pragma: no cover - inconsistent shapes from a user controller
        raise NonFiniteError("controller internals changed shape during the run") from None

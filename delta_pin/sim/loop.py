"""The sampled closed loop (docs/architecture.md section 6): any controller on any plant, stepped
by the compiled core.

The loop, its RK4 sub-steps and its checks are the core's one run (``delta_pin/core/run/run.hpp``,
its ``HeldTorqueRk4`` stepper): a plant's
compiled copy (:meth:`Plant.sampled_core <delta_pin.sim.plants.Plant.sampled_core>`), or a plant
written in Python called back at every RK4 stage (``PythonPlant``,
:func:`~delta_pin.sim.compiled_plant.python_core_plant`). The controller runs there as its
compiled law or is called back once per sample. The readable Python loop these are tested
against lives in ``tests/reference/python_loop.py``."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from delta_pin.compiled.core import core
from delta_pin.control.base import Controller, ControlOutput, Reference
from delta_pin.errors import NonFiniteError, SimulationError
from delta_pin.sim.compiled_plant import keep_core_projections, python_core_plant, run_core
from delta_pin.sim.drive import Drive, Encoder
from delta_pin.sim.integrators import MAX_JOINT_SPEED, all_finite, check_state
from delta_pin.sim.plants import Plant
from delta_pin.sim.reference import ReferenceTable
from delta_pin.utils.progress import Progress

__all__ = ["ControlLoop", "LoopRecord", "run_sampled_loop"]


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


def run_sampled_loop(
    controller: Controller,
    plant: Plant,
    table: ReferenceTable,
    x: np.ndarray,
    t: np.ndarray,
    *,
    substeps: int,
    progress: bool | None,
    sensor: Encoder | None = None,
    drive: Drive | None = None,
) -> LoopRecord:
    """Run ``controller`` on ``plant`` from the plant state x over the sample times t [s].

    tau_k at t_k, held over the period while the plant takes ``substeps`` RK4 steps; the
    controller state advances once per period (:meth:`Controller.advance
    <delta_pin.control.base.Controller.advance>`: z_{k+1} = z_k + dt z_dot_k, or a discrete-time
    law's next state). With a ``sensor`` the controller sees its readings instead of the true
    joint state; with a ``drive`` its torque acts after the drive's delay and saturation (what is
    recorded as ``tau``; the controller's own output is the internal ``tau_command``). ``table``
    holds the reference at the samples.

    A controller with a compiled law (:meth:`Controller.sampled_core_law
    <delta_pin.control.base.Controller.sampled_core_law>`) runs in the core, Python not called
    during the run (unless the plant is a Python one); any other is called back once per sample.
    Either way the sensor and the drive are the core's (``delta_pin/core/run/drive.hpp``).
    """
    steps, dt = len(t) - 1, t[1] - t[0]
    h = dt / substeps
    controller.reset()
    z = controller.initial_state().astype(float)
    reference_rows = table.rows(1)
    settings = _sampled_settings(steps, substeps, dt)
    if sensor is not None or drive is not None:
        settings.drive = _core_drive(sensor, drive, steps + 1, plant.dof)
    bar = Progress(round(steps * dt, 9), progress, label="simulate", unit="s")
    # the plant's compiled copy, or the plant itself called back from the core's loop
    core = plant.sampled_core(h, 2 * steps * substeps + 3) or python_core_plant(plant, len(x))
    law = controller.sampled_core_law()
    own_velocity = type(controller).estimate_velocity is not Controller.estimate_velocity
    estimates = sensor is not None and sensor.velocity == "none" and own_velocity
    if law is not None and not estimates:
        # the compiled plant, loop, drive and law: Python is not called until the run ends
        law.start(*(np.ascontiguousarray(r) for r in reference_rows), dt, z, steps + 1)
        recorded = run_core(core, law, settings, x, plant)
        internals = controller.core_law_internals(law)
    else:  # the controller called back once per sample, its velocity estimate its own
        callback = _CalledBack(controller, plant, reference_rows, t, z, bar, estimates)
        recorded = run_core(core, callback, settings, x, plant)
        internals = _stacked(callback.internals)
    keep_core_projections(plant, core)
    record = LoopRecord(recorded.alpha, recorded.alpha_dot, recorded.tau, recorded.xyz, recorded.gap)
    record.q, record.v = recorded.q, recorded.v
    record.internals = internals
    if drive is not None:
        record.internals["tau_command"] = recorded.commands
        drive.hits = recorded.hits
    bar.close()
    return record


class _CalledBack:
    """A controller without a compiled law in the core's sampled run: called back once per sample
    with the joints as the run's encoder reads them (the controller's own velocity estimate where
    ``estimates``), its state advanced and checked, its output and internals recorded."""

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
        for name, value in self.out.internals.items():
            self.internals.setdefault(name, []).append(np.asarray(value, dtype=float))
        return tau


def _sampled_settings(steps: int, substeps: int, dt: float):
    """The core's run of steps + 1 samples dt [s] apart, the torque held over each while the
    plant takes ``substeps`` RK4 steps."""
    settings = core().RunSettings()
    settings.integrator, settings.samples, settings.substeps, settings.dt = "rk4", steps + 1, substeps, dt
    settings.max_joint_speed = MAX_JOINT_SPEED
    return settings


def _core_drive(sensor: Encoder | None, drive: Drive | None, samples: int, dof: int):
    """The encoder and the drive of :func:`run_sampled_loop` as the core's run takes them
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

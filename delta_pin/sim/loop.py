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
    <delta_pin.control.base.Controller.sampled_core_law>`) runs in the core with the sensor and
    the drive, Python not called during the run (unless the plant is a Python one); any other is
    called back once per sample.
    """
    steps, dt = len(t) - 1, t[1] - t[0]
    h = dt / substeps
    dof = plant.dof
    controller.reset()
    loop = ControlLoop(controller, plant)
    z = controller.initial_state().astype(float)
    internals: dict[str, list] = {}
    reference_rows = table.rows(1)
    taus = np.zeros((len(t), dof))
    previous_reading = None  # the sensor's last angles, for a controller's own velocity estimate

    def read(alpha: np.ndarray, alpha_dot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """What the controller sees of the joints: the sensor's reading (and its velocity, or the
        controller's estimate where the sensor gives none)."""
        nonlocal previous_reading
        measured, velocity = sensor.read(alpha, alpha_dot, dt)
        if velocity is None:
            velocity = controller.estimate_velocity(measured, previous_reading, dt)
        previous_reading = measured
        return measured, velocity

    bar = Progress(round(steps * dt, 9), progress, label="simulate", unit="s")
    stride = max(steps // 100, 1)
    # the plant's compiled copy, or the plant itself called back from the core's loop
    core = plant.sampled_core(h, 2 * steps * substeps + 3) or python_core_plant(plant, len(x))
    law = controller.sampled_core_law()
    own_velocity = type(controller).estimate_velocity is not Controller.estimate_velocity
    if sensor is not None and sensor.velocity == "none" and own_velocity:
        law = None  # the controller estimates the velocity from the readings itself, in Python
    if law is not None:
        # the compiled plant, loop, drive and law: Python is not called until the run ends
        if sensor is not None or drive is not None:
            _set_core_drive(law, sensor, drive, steps + 1, dof)
        reference_alpha, reference_alpha_dot, reference_alpha_ddot = (
            np.ascontiguousarray(r) for r in reference_rows
        )
        law.start(
            reference_alpha, reference_alpha_dot, reference_alpha_ddot, dt, z, steps + 1, MAX_JOINT_SPEED
        )
        recorded = run_core(core, law, _sampled_settings(steps, substeps, dt), x, plant)
        keep_core_projections(plant, core)
        record = LoopRecord(recorded.alpha, recorded.alpha_dot, recorded.tau, recorded.xyz, recorded.gap)
        record.q, record.v = recorded.q, recorded.v
        record.internals = controller.core_law_internals(law)
        if drive is not None:
            record.internals["tau_command"] = np.array(law.tau_command)
            drive.hits = int(law.hits)
        bar.close()
        return record

    out = None

    def control(k: int, x: np.ndarray) -> np.ndarray:
        """The torque acting on the plant from t_k (sensor, controller, drive), the controller's
        output recorded with its internals."""
        nonlocal z, out
        joints = plant.joint_state(x)
        if k:
            z = controller.advance(z, out, dt)
            check_state(t[k], x, z, *joints)
            if k % stride == 0:
                bar.update(round(stride * dt, 9))
        reference = Reference(reference_rows[0][k], reference_rows[1][k], reference_rows[2][k])
        tau, _, out = loop.control(t[k], x, reference, z, joints if sensor is None else read(*joints))
        if drive is not None:
            out.internals["tau_command"] = tau
            tau = drive.apply(tau)
        taus[k] = tau
        for name, value in out.internals.items():
            internals.setdefault(name, []).append(np.asarray(value, dtype=float))
        return tau

    recorded = run_core(core, control, _sampled_settings(steps, substeps, dt), x, plant)
    keep_core_projections(plant, core)
    record = LoopRecord(recorded.alpha, recorded.alpha_dot, taus, recorded.xyz, recorded.gap)
    record.q, record.v = recorded.q, recorded.v
    bar.close()
    record.internals = _stacked(internals)
    return record


def _sampled_settings(steps: int, substeps: int, dt: float):
    """The core's run of steps + 1 samples dt [s] apart, the torque held over each while the
    plant takes ``substeps`` RK4 steps."""
    settings = core().RunSettings()
    settings.integrator, settings.samples, settings.substeps, settings.dt = "rk4", steps + 1, substeps, dt
    return settings


def _set_core_drive(law, sensor: Encoder | None, drive: Drive | None, samples: int, dof: int) -> None:
    """The encoder and the drive of :func:`run_sampled_loop` in a compiled law's loop: the same
    readings (the encoder's noise drawn from its seed in the order :meth:`Encoder.read
    <delta_pin.sim.drive.Encoder.read>` draws it, one row of ``dof`` angles per sample), delay and
    torque limit."""
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
    law.set_drive(settings)


def _stacked(internals: dict[str, list]) -> dict[str, np.ndarray]:
    """The controller's internals, one array (N, ...) each."""
    try:
        return {name: np.array(values) for name, values in internals.items()}
    except ValueError:  # pragma: no cover - inconsistent shapes from a user controller
        raise NonFiniteError("controller internals changed shape during the run") from None

"""The Python closed loop: any controller on any plant, sampled or continuous (the reference that
the compiled core's loops are tested against)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from delta_pin.control.base import Controller, ControlOutput, Reference
from delta_pin.errors import InvalidParameterError, NonFiniteError, SimulationError
from delta_pin.sim.compiled_plant import core_unavailable, keep_core_projections, run_core_sampled
from delta_pin.sim.drive import Drive, Encoder
from delta_pin.sim.integrators import MAX_JOINT_SPEED, all_finite, check_state, integrate_lsoda, rk4_step
from delta_pin.sim.plants import Plant
from delta_pin.sim.reference import ReferenceTable
from delta_pin.utils.progress import Progress

__all__ = ["ControlLoop", "LoopRecord", "run_python_loop"]


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

    def take_plant_records(self, recorded) -> None:
        """The end effector, closure gap, q and v (``None`` for a plant without a multibody
        configuration) that the compiled loop recorded
        (:class:`~delta_pin.sim.compiled_plant.CompiledSampledRun`)."""
        self.xyz, self.closure_residual, self.q, self.v = recorded.xyz, recorded.gap, recorded.q, recorded.v


def run_python_loop(
    controller: Controller,
    plant: Plant,
    table: ReferenceTable,
    per_sample: int,
    x: np.ndarray,
    t: np.ndarray,
    *,
    mode: str,
    integrator: str,
    substeps: int,
    rtol: float,
    atol: float,
    progress: bool | None,
    sensor: Encoder | None = None,
    drive: Drive | None = None,
    compiled: bool | None = None,
) -> LoopRecord:
    """Run ``controller`` on ``plant`` from the plant state x over the sample times t [s].

    Sampled mode: tau_k at t_k, held over the period while the plant takes ``substeps`` RK4 steps;
    the controller state advances once per period (:meth:`Controller.advance
    <delta_pin.control.base.Controller.advance>`: z_{k+1} = z_k + dt z_dot_k, or a discrete-time
    law's next state). With a ``sensor`` the controller sees its readings instead of the true
    joint state; with a ``drive`` its torque acts after the drive's delay and saturation (what is
    recorded as ``tau``; the controller's own output is the internal ``tau_command``). Continuous
    mode: the controller inside the integrator (RK4 on [x, z] with step dt / substeps, or LSODA).
    ``table`` holds the reference on the grid dt / per_sample.

    In sampled mode a plant with a compiled copy (:meth:`Plant.sampled_core
    <delta_pin.sim.plants.Plant.sampled_core>`) is integrated by the compiled core, which calls
    the controller back once per sample (the same steps; ``compiled=False``: this loop's own
    RK4, the reference; ``compiled=True``: required). A controller with a compiled law there
    (:meth:`Controller.sampled_core_law <delta_pin.control.base.Controller.sampled_core_law>`) runs
    in the core with the sensor and the drive, Python not called during the run.
    """
    steps, dt = len(t) - 1, t[1] - t[0]
    h = dt / substeps
    dof = plant.dof
    controller.reset()
    loop = ControlLoop(controller, plant)
    z = controller.initial_state().astype(float)
    nx = len(x)
    record = LoopRecord(
        alpha=np.zeros((len(t), dof)),
        alpha_dot=np.zeros((len(t), dof)),
        tau=np.zeros((len(t), dof)),
        xyz=np.zeros((len(t), 3)),
        closure_residual=np.zeros(len(t)),
    )
    internals: dict[str, list] = {}
    reference_rows = table.rows(per_sample)

    alphas, alpha_dots, taus, xyzs, gaps = (
        record.alpha,
        record.alpha_dot,
        record.tau,
        record.xyz,
        record.closure_residual,
    )

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

    def control(k: int, x: np.ndarray, z: np.ndarray, joints) -> tuple[np.ndarray, ControlOutput]:
        """The torque acting on the plant from t_k (sensor, controller, drive) and the
        controller's output, recorded with its internals; ``joints``: x's (alpha, alpha_dot)."""
        reference = Reference(reference_rows[0][k], reference_rows[1][k], reference_rows[2][k])
        tau, _, out = loop.control(t[k], x, reference, z, joints if sensor is None else read(*joints))
        if drive is not None:
            out.internals["tau_command"] = tau
            tau = drive.apply(tau)
        taus[k] = tau
        for name, value in out.internals.items():
            values = internals.get(name)
            if values is None:
                values = internals[name] = []
            values.append(np.asarray(value, dtype=float))
        return tau, out

    def sample(k: int, x: np.ndarray, z: np.ndarray, gap: float | None = None):
        """Control at t_k and record the sample; ``gap``: x's closure residual if known. Returns
        the torque acting on the plant from t_k and the controller's output."""
        joints = plant.joint_state(x)
        alphas[k], alpha_dots[k] = joints
        tau, out = control(k, x, z, joints)
        xyzs[k] = plant.platform_position(x)
        full = plant.configuration_state(x)
        if full is not None:
            if record.q is None:
                record.q, record.v = np.zeros((len(t), len(full[0]))), np.zeros((len(t), len(full[1])))
            record.q[k], record.v[k] = full
        gaps[k] = plant.closure_residual(x) if gap is None else gap
        return tau, out

    def closed_loop(t_now: float, y: np.ndarray) -> np.ndarray:
        xs, zs = y[:nx], y[nx:]
        tau, z_dot, _ = loop.control(t_now, xs, table(t_now), zs)
        return np.concatenate([plant.derivative(t_now, xs, tau), z_dot])

    bar = Progress(round(steps * dt, 9), progress, label="simulate", unit="s")
    stride = max(steps // 100, 1)
    gap = None  # the closure residual of x when the step computed it
    wants_core = mode == "sampled" and compiled is not False
    core = plant.sampled_core(h, 2 * steps * substeps + 3) if wants_core else None
    if compiled and core is None:
        why = core_unavailable() or "the core runs sampled mode in full coordinates"
        raise InvalidParameterError(
            f"compiled=True: plant {plant.name!r} has no compiled sampled loop here ({why}); use "
            "compiled=None or False"
        )
    law = controller.sampled_core_law() if core is not None else None
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
        recorded = run_core_sampled(core, x, steps, substeps, dt, law)
        keep_core_projections(plant, core)
        record.alpha, record.alpha_dot = recorded.alpha, recorded.alpha_dot
        record.tau = np.array(law.tau)
        record.take_plant_records(recorded)
        record.internals = controller.core_law_internals(law)
        if drive is not None:
            record.internals["tau_command"] = np.array(law.tau_command)
            drive.hits = int(law.hits)
        bar.close()
        return record
    if core is not None:
        # the compiled plant and loop; the controller called back once per sample
        out = None

        def compiled_control(k: int, x: np.ndarray) -> np.ndarray:
            nonlocal z, out
            joints = plant.joint_state(x)
            alphas[k], alpha_dots[k] = joints
            if k:
                z = controller.advance(z, out, dt)
                check_state(t[k], x, z, *joints)
                if k % stride == 0:
                    bar.update(round(stride * dt, 9))
            tau, out = control(k, x, z, joints)
            return tau

        recorded = run_core_sampled(core, x, steps, substeps, dt, compiled_control)
        keep_core_projections(plant, core)
        record.take_plant_records(recorded)
        bar.close()
        record.internals = _stacked(internals)
        return record
    if integrator == "lsoda":
        x, z = integrate_lsoda(
            closed_loop, sample, loop.check_state, plant.finish_step, x, z, t, rtol, atol, bar
        )
    else:
        for k in range(steps):
            if k % stride == 0 and k:
                bar.update(round(stride * dt, 9))
            tau, out = sample(k, x, z, gap)
            if mode == "sampled":
                for j in range(substeps):
                    x = rk4_step(lambda ts, xs: plant.derivative(ts, xs, tau), t[k] + j * h, x, h)  # noqa: B023
                    x, gap = plant.finish_step(x, t[k] + (j + 1) * h), None
                z = controller.advance(z, out, dt)
            else:
                y = np.concatenate([x, z])
                for j in range(substeps):
                    y = rk4_step(closed_loop, t[k] + j * h, y, h)
                    y[:nx] = plant.finish_step(y[:nx], t[k] + (j + 1) * h)
                x, z = y[:nx], y[nx:]
            check_state(t[k + 1], x, z, *plant.joint_state(x))  # = loop.check_state, one frame less
    sample(steps, x, z, gap)
    bar.close()
    record.internals = _stacked(internals)
    return record


def _set_core_drive(law, sensor: Encoder | None, drive: Drive | None, samples: int, dof: int) -> None:
    """The encoder and the drive of :func:`run_python_loop` in a compiled law's loop: the same
    readings (the encoder's noise drawn from its seed in the order :meth:`Encoder.read
    <delta_pin.sim.drive.Encoder.read>` draws it, one row of ``dof`` angles per sample), delay and
    torque limit."""
    noise = np.zeros((0, dof))
    if sensor is not None and sensor.noise > 0.0:
        noise = np.random.default_rng(sensor.seed).normal(0.0, sensor.noise, (samples, dof))
    limit = np.zeros(0) if drive is None or drive.torque_limit is None else drive.torque_limit
    law.set_drive(
        sensor is not None,
        0.0 if sensor is None else sensor.resolution,
        noise,
        sensor is not None and sensor.velocity == "exact",
        drive is not None,
        0 if drive is None else drive.delay,
        limit,
    )


def _stacked(internals: dict[str, list]) -> dict[str, np.ndarray]:
    """The controller's internals, one array (N, ...) each."""
    try:
        return {name: np.array(values) for name, values in internals.items()}
    except ValueError:  # pragma: no cover - inconsistent shapes from a user controller
        raise NonFiniteError("controller internals changed shape during the run") from None

"""The readable Python closed loop: any controller on any plant's Python ``derivative``, sampled
(RK4 under a held torque) or continuous (RK4 on [x, z], or SciPy's LSODA in chunks) -- the
reference the compiled core's loops (:func:`delta_pin.sim.loop.run_loop`)
are tested against. It was the package's own loop until the core took every run (issue 38).

:func:`simulate_reference` sets a run up as :func:`delta_pin.simulate` does (the same reference
table, plant, initial state and checks) and runs it here, a built-in controller by its readable
law (:mod:`tests.reference.laws`).
"""

from __future__ import annotations

import numpy as np

from delta_pin.control.base import Controller, NoTorque, Reference, as_controller
from delta_pin.errors import InvalidParameterError, SimulationError
from delta_pin.model.delta_robot import analytic_delta
from delta_pin.sim.arguments import check_mode, check_substeps, check_timing, joint_vector
from delta_pin.sim.closed_chain_plant import make_plant
from delta_pin.sim.drive import Drive, Encoder, check_delay
from delta_pin.sim.integrators import PROJECTION_CHUNK, check_state, rk4_step
from delta_pin.sim.loop import ControlLoop, LoopRecord, _stacked
from delta_pin.sim.plants import Plant
from delta_pin.sim.reference import ReferenceTable, tabulate_reference
from delta_pin.sim.run import Run, run_metadata
from delta_pin.sim.runner import _check_digital, _engine_robot
from tests.reference.laws import called_back
from tests.reference.plants import readable

__all__ = ["integrate_lsoda", "run_python_loop", "simulate_reference"]

LAYER_FRACTION = 0.25  # LSODA's velocity error bound: at most this fraction of the robust term's layer


def layer_resolving_rtol(controller, table, rtol: float) -> float:
    """LSODA's ``rtol``, tightened where the controller's robust term slides in a boundary layer
    (``controller.boundary_layer``, designs I/II) thinner than LSODA would resolve: the velocity
    error it allows, rtol max|alpha_dot^d|, must stay below :data:`LAYER_FRACTION` of the layer
    (else LSODA stops with "repeated convergence failures" on the Adept cycle)."""
    layer = getattr(controller, "boundary_layer", None)
    if layer is None:
        return rtol
    width = layer(table.alpha_dot, table.alpha_ddot)  # [rad/s]
    speed = max(float(np.abs(table.alpha_dot).max()), 1.0)  # [rad/s]
    return min(rtol, LAYER_FRACTION * width / speed)


def integrate_lsoda(closed_loop, sample, check, finish_step, x, z, t, rtol, atol, bar):
    """Continuous mode with scipy's LSODA, in chunks of :data:`PROJECTION_CHUNK` samples.

    Args:
        closed_loop: f(t, [x, z]) -> d[x, z]/dt.
        sample: ``sample(k, x, z)`` records sample k.
        check: ``check(t, x, z)`` raises where the state diverged.
        finish_step: the plant's correction between chunks (``finish_step(x, t) -> x``).
        x, z: initial plant and controller states; ``t``: the sample times [s].
        rtol, atol: LSODA's tolerances; ``bar``: a progress display.

    Returns:
        (x, z) at t[-1] (not yet recorded).
    """
    from scipy.integrate import solve_ivp

    nx = len(x)
    dt = t[1] - t[0]
    k = 0
    while k < len(t) - 1:
        stop = min(k + PROJECTION_CHUNK, len(t) - 1)
        sample(k, x, z)
        solution = solve_ivp(
            closed_loop,
            (t[k], t[stop]),
            np.concatenate([x, z]),
            method="LSODA",
            t_eval=t[k : stop + 1],
            rtol=rtol,
            atol=atol,
            max_step=dt,
        )
        if solution.status != 0:  # the time of the last sample it reached, not the chunk's start
            reached = float(solution.t[-1]) if len(solution.t) else float(t[k])
            raise SimulationError(f"the integrator failed: {solution.message}", reached)
        for j in range(1, stop - k):
            xs, zs = solution.y[:nx, j], solution.y[nx:, j]
            check(t[k + j], xs, zs)
            sample(k + j, xs, zs)
        x, z = solution.y[:nx, -1], solution.y[nx:, -1]
        check(t[stop], x, z)
        x = finish_step(x, t[stop])
        bar.update(round(t[stop] - t[k], 9))
        k = stop
    return x, z


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
    rtol: float = 1e-6,
    atol: float = 1e-8,
    sensor: Encoder | None = None,
    drive: Drive | None = None,
) -> LoopRecord:
    """Run ``controller`` on ``plant`` from the plant state x over the sample times t [s], all in
    Python: sampled mode (tau_k held over the period, ``substeps`` RK4 steps of the plant's
    ``derivative`` and ``finish_step``, the controller state advanced once per period, the sensor
    and drive as the compiled loop applies them) or continuous mode (the controller inside the
    integrator: RK4 on [x, z] with step dt / substeps, or LSODA). ``table`` holds the reference on
    the grid dt / per_sample."""
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
    previous_reading = None

    def read(alpha, alpha_dot):
        nonlocal previous_reading
        measured, velocity = sensor.read(alpha, alpha_dot, dt)
        if velocity is None:
            velocity = controller.estimate_velocity(measured, previous_reading, dt)
        previous_reading = measured
        return measured, velocity

    def sample(k: int, x: np.ndarray, z: np.ndarray, gap: float | None = None):
        joints = plant.joint_state(x)
        record.alpha[k], record.alpha_dot[k] = joints
        reference = Reference(reference_rows[0][k], reference_rows[1][k], reference_rows[2][k])
        tau, _, out = loop.control(t[k], x, reference, z, joints if sensor is None else read(*joints))
        if drive is not None:
            out.internals["tau_command"] = tau
            tau = drive.apply(tau)
        record.tau[k] = tau
        for name, value in out.internals.items():
            internals.setdefault(name, []).append(np.asarray(value, dtype=float))
        record.xyz[k] = plant.platform_position(x)
        full = plant.configuration_state(x)
        if full is not None:
            if record.q is None:
                record.q, record.v = np.zeros((len(t), len(full[0]))), np.zeros((len(t), len(full[1])))
            record.q[k], record.v[k] = full
        record.closure_residual[k] = plant.closure_residual(x) if gap is None else gap
        return tau, out

    def closed_loop(t_now: float, y: np.ndarray) -> np.ndarray:
        xs, zs = y[:nx], y[nx:]
        tau, z_dot, _ = loop.control(t_now, xs, table(t_now), zs)
        return np.concatenate([plant.derivative(t_now, xs, tau), z_dot])

    class _Silent:
        def update(self, _):
            pass

    gap = None
    if integrator == "lsoda":
        x, z = integrate_lsoda(
            closed_loop, sample, loop.check_state, plant.finish_step, x, z, t, rtol, atol, _Silent()
        )
    else:
        for k in range(steps):
            tau, out = sample(k, x, z, gap)
            if mode == "sampled":
                for j in range(substeps):
                    x = rk4_step(lambda ts, xs: plant.derivative(ts, xs, tau), t[k] + j * h, x, h)  # noqa: B023
                    x, gap = plant.finish_step_residual(x, t[k] + (j + 1) * h)
                z = controller.advance(z, out, dt)
            else:
                y = np.concatenate([x, z])
                for j in range(substeps):
                    y = rk4_step(closed_loop, t[k] + j * h, y, h)
                    y[:nx] = plant.finish_step(y[:nx], t[k] + (j + 1) * h)
                x, z, gap = y[:nx], y[nx:], None
            check_state(t[k + 1], x, z, *plant.joint_state(x))
    sample(steps, x, z, gap)
    record.internals = _stacked(internals)
    return record


def simulate_reference(
    robot,
    controller,
    trajectory=None,
    *,
    plant="pinocchio",
    t_end: float,
    dt: float = 1e-3,
    mode: str = "sampled",
    alpha0=None,
    alpha_dot0=None,
    friction=None,
    uncertainty=None,
    substeps: int = 1,
    integrator: str | None = None,
    rtol: float = 1e-6,
    atol: float = 1e-8,
    sensor: Encoder | None = None,
    delay: int = 0,
    torque_limit=None,
    coordinates: str | None = None,
) -> Run:
    """:func:`delta_pin.simulate`'s run in the Python loop (:func:`run_python_loop`): the same
    arguments, ``integrator`` ``"rk4"`` (the default in sampled mode) or ``"lsoda"`` (the default
    in continuous mode; ``rtol`` tightened to the robust term's layer as it always was);
    ``coordinates``: the Pinocchio plant's (default: ``"active"`` for LSODA where the actuated
    joints carry the whole motion, else the plant's own)."""
    steps = check_timing(dt, t_end)
    if controller is None:
        controller = NoTorque(len(getattr(robot, "actuated_joints", ())) or robot.dof)
    check_mode(mode)
    check_substeps(substeps)
    integrator = integrator or ("rk4" if mode == "sampled" else "lsoda")
    if integrator not in ("rk4", "lsoda") or (integrator == "lsoda" and mode == "sampled"):
        raise InvalidParameterError(f"the reference loop takes rk4 or, continuous, lsoda; not {integrator!r}")
    described = analytic_delta(robot)
    robot = _engine_robot(robot, described, plant, trajectory)
    drive_effects = sensor is not None or check_delay(delay) > 0 or torque_limit is not None
    _check_digital(as_controller(controller), mode, dt, drive_effects, delay)
    options = {}
    if isinstance(plant, str) and plant == "pinocchio":
        if coordinates is not None:
            options["coordinates"] = coordinates
        elif integrator == "lsoda" and not robot.has_unactuated_motion:
            options["coordinates"] = "active"
    plant = readable(make_plant(plant, robot, friction, uncertainty, **options))  # Python dynamics
    controller = called_back(as_controller(controller))  # a built-in law's readable twin (laws.py)
    dof, h = plant.dof, dt / substeps
    per_sample = 1 if mode == "sampled" else {"rk4": 2 * substeps}.get(integrator, 4)
    table, sample_xyz, alpha0 = tabulate_reference(robot, trajectory, alpha0, dof, steps, dt, per_sample)
    alpha0 = joint_vector(alpha0, "alpha0", dof)
    if integrator == "lsoda":
        rtol = layer_resolving_rtol(controller, table, rtol)
    alpha_dot0 = np.zeros(dof) if alpha_dot0 is None else joint_vector(alpha_dot0, "alpha_dot0", dof)
    if integrator == "rk4":
        plant.precompute_truth(h / 2.0, 2 * steps * substeps + 1)
    t = np.arange(steps + 1) * dt
    drive = Drive(dof, delay, torque_limit) if drive_effects else None
    if sensor is not None:
        sensor.reset()
    record = run_python_loop(
        controller, plant, table, per_sample, plant.initial_state(alpha0, alpha_dot0), t, mode=mode,
        integrator=integrator, substeps=substeps, rtol=rtol, atol=atol, sensor=sensor, drive=drive,
    )  # fmt: skip
    metadata = run_metadata(
        described, controller, trajectory, plant, mode=mode, dt=dt, t_end=steps * dt, substeps=substeps,
        integrator=integrator, **({"rtol": rtol, "atol": atol} if integrator == "lsoda" else {}),
        alpha0=alpha0.tolist(), alpha_dot0=alpha_dot0.tolist(), wall_time=0.0,
    )  # fmt: skip
    if getattr(plant, "projections", 0):
        metadata["closure_projections"] = plant.projections
    if drive is not None:
        metadata.update(sensor=None if sensor is None else sensor.metadata(), **drive.metadata())
    alpha_d, alpha_dot_d, _ = table.rows(per_sample)
    return Run(
        t=t, alpha=record.alpha, alpha_dot=record.alpha_dot, alpha_d=np.array(alpha_d),
        alpha_dot_d=np.array(alpha_dot_d), xyz=record.xyz, xyz_d=np.array(sample_xyz), tau=record.tau,
        closure_residual=record.closure_residual, internals=record.internals, q=record.q, v=record.v,
        metadata=metadata,
    )  # fmt: skip

"""The digital laws (TDC, digital-robust) on a digital drive, compiled on the Delta's analytic
plant: the entry from ``sim`` to :mod:`delta_pin.compiled.digital_loop`.

``simulate(..., mode="sampled")`` sends a run here when its controller is a digital law with its
compiled step (the Delta's analytic nominal model) on the analytic plant: the same arrays as the
Python loop, bit for bit (tests/sim/test_compiled_loops.py), at compiled speed. The encoder's
noise is drawn here, from its seeded generator, in the order the Python encoder draws it. On the
Pinocchio plant the same laws run in the compiled core with its drive
(:func:`~delta_pin.sim.loop.run_python_loop`).
"""

from __future__ import annotations

import time

import numpy as np

from delta_pin.compiled import digital_loop
from delta_pin.compiled.layouts import (
    ADAPTIVE_ROBUST,
    CONTROLLER,
    DIGITAL_INFO,
    DIGITAL_LAW,
    DIGITAL_ROBUST,
    DIGITAL_SAMPLE,
    DRIVE,
    INFO,
    PLANT,
    TIMING,
    WORKSPACE,
    digital_loop_state,
    record,
    records,
)
from delta_pin.control.adaptive_robust import AdaptiveRobustController
from delta_pin.control.digital import TimeDelayControl
from delta_pin.control.digital_robust import DigitalRobustController
from delta_pin.errors import SimulationError
from delta_pin.model.delta_robot import analytic_delta
from delta_pin.model.dynamics import kernel_geometry
from delta_pin.model.kinematics import chain_trigonometry
from delta_pin.model.robot import Delta
from delta_pin.sim.arguments import check_substeps, check_timing, joint_vector
from delta_pin.sim.closed_chain_plant import make_plant
from delta_pin.sim.drive import Encoder, check_delay, check_torque_limit
from delta_pin.sim.integrators import MAX_JOINT_SPEED
from delta_pin.sim.plants import AnalyticPlant, Plant, truth_records
from delta_pin.sim.reference import tabulate_reference
from delta_pin.sim.run import Run, run_metadata

__all__ = ["digital_compilable", "simulate_digital"]

_FAILURES = {
    digital_loop.NO_FK: "the state left the workspace (no forward kinematics, or the loops do not close)",
    digital_loop.NONFINITE_TORQUE: "the controller returned a non-finite torque",
    digital_loop.DIVERGED: "the run diverged (|alpha_dot| > 1000 rad/s or a non-finite state)",
}


def digital_compilable(controller, plant, drive_effects: bool = True) -> bool:
    """Whether the compiled digital loop runs ``controller`` on ``plant``: TDC or digital-robust
    with its compiled step, or designs I/II with theirs on a drive (``drive_effects``: without
    one, their own compiled loops run them), on the analytic plant."""
    digital = isinstance(controller, TimeDelayControl | DigitalRobustController)
    design = isinstance(controller, AdaptiveRobustController) and drive_effects
    if not ((digital or design) and controller.compiled):
        return False
    return plant == "analytic" or isinstance(plant, AnalyticPlant)


def _drive_record(sensor: Encoder | None, delay: int, torque_limit) -> np.record:
    limit = check_torque_limit(torque_limit, 3)
    return record(
        DRIVE,
        resolution=0.0 if sensor is None else sensor.resolution,
        exact_velocity=sensor is None or sensor.velocity == "exact",
        delay=check_delay(delay),
        has_limit=limit is not None,
        torque_limit=np.zeros(3) if limit is None else limit,
    )


def _noise(sensor: Encoder | None, samples: int) -> np.ndarray:
    """The encoder's noise at every sample (samples, 3) [rad], drawn as its ``read`` draws it."""
    if sensor is None or sensor.noise == 0.0:
        return np.zeros((0, 3))
    sensor.reset()
    return sensor._rng.normal(0.0, sensor.noise, (samples, 3))


def simulate_digital(
    robot: Delta,
    controller: TimeDelayControl | DigitalRobustController,
    trajectory=None,
    *,
    plant: str | Plant = "analytic",
    t_end: float,
    dt: float = 1e-3,
    substeps: int = 1,
    alpha0=None,
    alpha_dot0=None,
    friction=None,
    uncertainty=None,
    sensor: Encoder | None = None,
    delay: int = 0,
    torque_limit=None,
) -> Run:
    """One sampled run of a digital law on a digital drive, compiled (the arguments of
    :func:`~delta_pin.sim.runner.simulate`).

    Raises:
        SimulationError: a run that fails, naming the time.
    """
    robot = analytic_delta(robot)
    steps = check_timing(dt, t_end)
    check_substeps(substeps)
    drive = _drive_record(sensor, delay, torque_limit)
    run_plant = plant if isinstance(plant, Plant) else make_plant(plant, robot, friction, uncertainty)
    h = dt / substeps
    table, sample_xyz, start = tabulate_reference(robot, trajectory, alpha0, 3, steps, dt, 1)
    reference = table.records()
    truth = truth_records(*run_plant.evaluate_truth(np.arange(2 * steps * substeps + 1) * (h / 2.0)))
    timing = record(
        TIMING, step=dt, substeps=substeps, samples=steps, max_speed=MAX_JOINT_SPEED, sampled=True
    )
    alpha0 = joint_vector(start, "alpha0", 3)
    alpha_dot0 = np.zeros(3) if alpha_dot0 is None else joint_vector(alpha_dot0, "alpha_dot0", 3)
    controller.reset()
    z0 = controller.initial_state()
    x0 = run_plant.initial_state(alpha0, alpha_dot0)
    state = record(digital_loop_state(len(x0), len(z0), drive["delay"]), x=x0, z=z0)
    noise = _noise(sensor, steps + 1)
    out, info = records(DIGITAL_SAMPLE, steps + 1), records(DIGITAL_INFO, steps + 1)
    counters = np.zeros(1, dtype=np.int64)
    if isinstance(controller, AdaptiveRobustController):  # the loop reads its CONTROLLER record
        law, design = record(DIGITAL_LAW, kind=ADAPTIVE_ROBUST, dt=dt), controller.kernel_parameters
    else:
        law, design = controller.kernel_parameters, record(CONTROLLER)
    design_info = records(INFO, steps + 1)
    wall = time.perf_counter()
    plant_record = record(
        PLANT, geometry=kernel_geometry(robot.params), forearm_mass=1.5 * robot.params.m_b,
        friction=run_plant.friction_parameters,
    )  # fmt: skip
    status, when = digital_loop.run_digital_analytic(
        law, design, *chain_trigonometry(), drive, noise, plant_record, truth, reference, timing, state,
        record(WORKSPACE), out, info, design_info, counters,
    )  # fmt: skip
    failure = None if status == digital_loop.OK else SimulationError(f"rk4: {_FAILURES[int(status)]}", when)
    wall = time.perf_counter() - wall
    if failure is not None:
        raise failure
    metadata = run_metadata(
        robot, controller, trajectory, run_plant, mode="sampled", dt=dt, t_end=steps * dt, substeps=substeps,
        integrator="rk4", alpha0=alpha0.tolist(), alpha_dot0=alpha_dot0.tolist(), wall_time=wall,
        rhs_evaluations=int(counters[0]), compiled=True,
    )  # fmt: skip
    if sensor is not None or drive["delay"] > 0 or drive["has_limit"]:
        metadata.update(
            sensor=None if sensor is None else sensor.metadata(),
            delay=int(drive["delay"]),
            torque_limit=drive["torque_limit"].tolist() if drive["has_limit"] else None,
            torque_limit_hits=int(state["hits"]),
        )
    alpha_d, alpha_dot_d, _ = table.rows(1)
    return Run(
        t=np.arange(steps + 1) * dt,
        alpha=out["alpha"].copy(),
        alpha_dot=out["alpha_dot"].copy(),
        alpha_d=np.array(alpha_d),
        alpha_dot_d=np.array(alpha_dot_d),
        xyz=out["xyz"].copy(),
        xyz_d=np.array(sample_xyz),
        tau=out["tau"].copy(),
        closure_residual=out["closure_gap"].copy(),
        internals=_internals(law, out, info, design_info, len(z0)),
        metadata=metadata,
    )


def _internals(law, out, info, design_info, nz: int) -> dict[str, np.ndarray]:
    """The internals the Python loop records for the law (``tau_command`` with a drive)."""
    if law["kind"] == ADAPTIVE_ROBUST:
        internals = {
            "rho_hat": out["rho_hat"][:, :nz].copy(),
            "Lambda": design_info["Lambda"].copy(),
            "robust_gain": design_info["robust_gain"].copy(),
            "omega_norm": design_info["omega_norm"].copy(),
            "robust_torque": design_info["robust_torque"].copy(),
            "adaptation_active": design_info["adaptation_active"].copy(),
        }
    elif law["kind"] == DIGITAL_ROBUST:
        internals = {
            "rho_hat": info["rho_hat"][:, None].copy(),
            "robust_torque": info["robust_torque"].copy(),
            "disturbance_estimate": info["disturbance_estimate"].copy(),
            "velocity_estimate": info["velocity_estimate"].copy(),
            "s": info["s"].copy(),
        }
    else:
        internals = {"lumped_estimate": info["lumped_estimate"].copy()}
    internals["tau_command"] = out["tau_command"].copy()
    return internals

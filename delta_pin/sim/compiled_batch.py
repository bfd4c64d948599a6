"""The Delta's numba loops (:mod:`delta_pin.compiled`): designs I and II on the Delta's analytic
model, on either plant, with the fixed-step BDF2 in continuous mode; so does the LQR baseline
(its compiled law, :mod:`delta_pin.compiled.lqr`). Every other compiled run -- sampled, Radau --
takes the compiled core (:func:`~delta_pin.sim.runner.simulate`).

:func:`simulate_compiled_batch` runs many runs that share the robot, the path and the timing but differ in
gains, uncertainty or initial state: the reference is tabulated once, then each run is one
compiled call (:func:`~delta_pin.compiled.closed_loop.run_closed_loop`). A run's result is the
same, bit for bit, as the run made alone (``simulate(..., integrator="bdf2")`` is a batch of
one). In sampled mode the compiled loop does the arithmetic of
:func:`~delta_pin.sim.loop.run_python_loop` (the same stages, truth and reference rows) and gives
its arrays (tests/sim/test_compiled_loops.py). In continuous mode on the Pinocchio plant, BDF2
and Radau integrate the active coordinates and Pinocchio (:mod:`delta_pin.compiled.native`)
completes q(alpha) at every evaluation.

Example:
    >>> robot = load_delta()
    >>> nominal = DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    >>> runs = simulate_batch(robot, [design1(nominal, xi=x) for x in (1e-3, 1e-2)], PathI(),
    ...                       t_end=3.0, friction=Friction(),
    ...                       uncertainties=[PaperUncertainty()] * 2)
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from delta_pin.compiled import closed_loop, radau
from delta_pin.compiled.layouts import (
    INFO,
    PLANT,
    REFERENCE,
    SAMPLE,
    STEP_CONTROL,
    TIMING,
    WORKSPACE,
    record,
    records,
)
from delta_pin.control.adaptive_robust import AdaptiveRobustController
from delta_pin.control.baselines import LQR
from delta_pin.errors import InvalidParameterError, SimulationError
from delta_pin.model.delta_robot import analytic_delta
from delta_pin.model.dynamics import kernel_geometry
from delta_pin.model.kinematics import chain_trigonometry
from delta_pin.model.robot import Delta
from delta_pin.sim.arguments import check_mode, check_substeps, check_timing, joint_vector
from delta_pin.sim.closed_chain_plant import ClosedChainPlant, make_plant
from delta_pin.sim.continuous_core import RADAU_FIRST_STEP, RADAU_MAX_STEP
from delta_pin.sim.integrators import MAX_JOINT_SPEED
from delta_pin.sim.plants import AnalyticPlant, Plant, truth_records
from delta_pin.sim.reference import tabulate_reference
from delta_pin.sim.run import Run, run_metadata

__all__ = ["batchable", "check_batch", "native_available", "simulate_compiled_batch"]

_RADAU_FAILURES = {closed_loop.NO_CONVERGENCE: "the step size fell below 1e-12 s"}
_FAILURES = {
    closed_loop.NO_FK: "the state left the workspace (no forward kinematics, or the loops do not close)",
    closed_loop.NO_CONVERGENCE: (
        "Newton's method did not converge even on 1024 sub-steps: the fixed-step BDF2 cannot follow this "
        "run's robust term (on the Adept cycle its damper gain reaches ~5e7 N m s/rad); "
        "integrator='radau' (the default) or 'lsoda' can"
    ),
    closed_loop.DIVERGED: "the run diverged (|alpha_dot| > 1000 rad/s or a non-finite state)",
}


def _delta_tree(plant) -> bool:
    """Whether ``plant`` is a Pinocchio plant the Delta's compiled loops take (it declares it:
    ``ClosedChainPlant.delta_tree``)."""
    return getattr(plant, "delta_tree", False)


def _is_tree(plant, mode: str = "continuous") -> bool:
    """Whether ``plant`` is the Pinocchio plant the compiled loops take: in continuous mode only,
    in either representation (BDF2 and Radau integrate the active coordinates and complete
    q(alpha) at every evaluation). Sampled runs on the Pinocchio plant take the compiled core
    (:func:`~delta_pin.sim.runner.simulate`)."""
    if mode != "continuous":
        return False
    return plant == "pinocchio" or _delta_tree(plant)


def native_available() -> bool:
    """Whether the native library (Pinocchio's C++ for the compiled loops on the Pinocchio plant)
    is available here; it is built on the first call (~45 s, then cached)."""
    from delta_pin.compiled import native

    return native.load() is not None


def batchable(controller, plant="analytic", mode: str = "continuous") -> bool:
    """Whether ``controller`` on ``plant`` can take a compiled path: design I or II with its
    compiled step (the Delta's analytic nominal model), or in continuous mode the LQR on that
    model, on the analytic plant or, in continuous mode, on the Pinocchio plant where the native
    library is available."""
    designs = isinstance(controller, AdaptiveRobustController) and controller.compiled
    lqr = isinstance(controller, LQR) and controller.compiled and mode == "continuous"
    if not (designs or lqr):
        return False
    if plant == "analytic" or isinstance(plant, AnalyticPlant):
        return True
    return _is_tree(plant, mode) and native_available()


@dataclass
class _Outcome:
    """One compiled run: its samples, the controller's info, counters and failure (or ``None``)."""

    samples: np.ndarray  # SAMPLE records (steps + 1,)
    info: np.ndarray  # INFO records (steps + 1,)
    counters: np.ndarray  # [evaluations, split steps]
    failure: Exception | None


def simulate_compiled_batch(
    robot: Delta,
    controllers: Sequence[AdaptiveRobustController | LQR],
    trajectory=None,
    *,
    plant: str | Plant = "analytic",
    t_end: float,
    dt: float = 1e-3,
    substeps: int = 1,
    mode: str = "continuous",
    alpha0=None,
    alpha_dot0=None,
    friction=None,
    uncertainties: Sequence | None = None,
    errors: str = "raise",
    integrator: str = "bdf2",
    rtol: float = 1e-6,
    atol: float = 1e-8,
) -> list:
    """:func:`~delta_pin.sim.batch.simulate_batch` on the Delta's numba loops: BDF2 in continuous
    mode (the arguments and results as there; sampled and Radau batches run on the compiled
    core)."""
    robot = analytic_delta(robot)
    controllers, uncertainties, steps, radau = check_batch(
        controllers, plant, mode, errors, integrator, rtol, atol, substeps, dt, t_end, uncertainties
    )
    count = len(controllers)
    sampled, tree = mode == "sampled", _is_tree(plant, mode)
    kind = "pinocchio" if tree else "analytic"
    plants = [
        plant if isinstance(plant, Plant) and i == 0 else make_plant(kind, robot, friction, u)
        for i, u in enumerate(uncertainties)
    ]
    h = dt / substeps

    # the reference on the integrator's grid (continuous) or at the samples (sampled), the truth on
    # the step grid (BDF2) or the half-step grid (RK4 stages), as simulate() tabulates them
    alpha0_rows = np.asarray(alpha0, dtype=float) if alpha0 is not None else None
    per_run_alpha0 = alpha0_rows is not None and alpha0_rows.ndim == 2
    per_sample = 1 if sampled else (RADAU_GRID if radau else substeps)
    table, sample_xyz, start = tabulate_reference(
        robot, trajectory, alpha0_rows[0] if per_run_alpha0 else alpha0, 3, steps, dt, per_sample
    )
    reference = table.records()
    if sampled:
        grid = np.arange(2 * steps * substeps + 1) * (h / 2.0)
    else:
        grid = np.arange(steps * per_sample + 1) * (dt / per_sample)
    timing = record(
        TIMING, step=dt if sampled or radau else h, substeps=substeps, samples=steps,
        max_speed=MAX_JOINT_SPEED, sampled=sampled,
    )  # fmt: skip

    wall = time.perf_counter()
    outcomes, initial = [], []
    for b, (controller, run_plant) in enumerate(zip(controllers, plants)):
        y0 = _initial_state(controller, alpha0_rows[b] if per_run_alpha0 else start, alpha_dot0, b)
        initial.append(y0)
        truth = truth_records(*run_plant.evaluate_truth(grid))
        if radau:
            outcomes.append(_run_radau(controller, run_plant, truth, table, y0, timing, rtol, atol))
            continue
        outcomes.append(_run_closed_loop(controller, run_plant, truth, reference, y0, timing))
    wall = (time.perf_counter() - wall) / count

    alpha_d, alpha_dot_d, _ = table.rows(per_sample)
    results = []
    for controller, run_plant, y0, outcome in zip(controllers, plants, initial, outcomes):
        if outcome.failure is not None:
            if errors == "raise":
                raise outcome.failure
            results.append(outcome.failure)
            continue
        metadata = run_metadata(
            robot, controller, trajectory, run_plant, mode=mode, dt=dt, t_end=steps * dt,
            substeps=substeps, integrator="rk4" if sampled else integrator, alpha0=y0[:3].tolist(),
            alpha_dot0=y0[3:6].tolist(), wall_time=wall, rhs_evaluations=int(outcome.counters[0]),
            batch_size=count, compiled=True,
            **({"rtol": rtol, "atol": atol, "rejected_steps": int(outcome.counters[1]),
                "accepted_steps": int(outcome.counters[2]), "jacobians": int(outcome.counters[3])}
               if radau else {"split_steps": int(outcome.counters[1])}),
        )  # fmt: skip
        if getattr(run_plant, "projections", 0):
            metadata["closure_projections"] = run_plant.projections
        results.append(
            _run_from_samples(outcome, len(y0) - 6, dt, alpha_d, alpha_dot_d, sample_xyz, metadata)
        )
    return results


def check_batch(controllers, plant, mode, errors, integrator, rtol, atol, substeps, dt, t_end, uncertainties):
    """The arguments of :func:`~delta_pin.sim.batch.simulate_batch` checked: (the controllers,
    one uncertainty per run, the samples, whether Radau integrates).

    Raises:
        InvalidParameterError: what the compiled paths cannot run, or bad values and sizes.
    """
    controllers = _check_controllers(controllers, plant, mode)
    if errors not in ("raise", "return"):
        raise InvalidParameterError(f"errors={errors!r} must be 'raise' or 'return'")
    if integrator not in ("bdf2", "radau"):
        raise InvalidParameterError(f"integrator={integrator!r} must be 'bdf2' or 'radau' (continuous mode)")
    radau = mode == "continuous" and integrator == "radau"
    if radau and not (math.isfinite(rtol) and math.isfinite(atol) and rtol > 0.0 and atol > 0.0):
        raise InvalidParameterError(f"rtol={rtol!r} and atol={atol!r} must be positive")
    check_substeps(substeps)
    steps = check_timing(dt, t_end)
    count = len(controllers)
    uncertainties = [None] * count if uncertainties is None else list(uncertainties)
    if len(uncertainties) != count:
        raise InvalidParameterError(f"uncertainties has {len(uncertainties)} entries for {count} controllers")
    return controllers, uncertainties, steps, radau


def _check_controllers(controllers, plant, mode: str) -> list:
    """The controllers as a list, each one the compiled loops can run on ``plant`` in ``mode``."""
    controllers = list(controllers)
    if not controllers:
        raise InvalidParameterError("controllers must hold at least one controller")
    check_mode(mode)
    for index, controller in enumerate(controllers):
        if not batchable(controller, plant, mode):
            raise InvalidParameterError(
                f"controllers[{index}] ({getattr(controller, 'name', controller)!r}) on plant "
                f"{getattr(plant, 'name', plant)!r} in {mode} mode: the compiled loops run designs "
                "I/II with their compiled step on the analytic plant, or in continuous mode on the "
                "Pinocchio plant with the native library (its sampled runs: simulate(), the compiled "
                "core); use integrator='lsoda' or simulate(..., compiled=False)"
            )
    if len({_rho_size(c) for c in controllers}) > 1:
        raise InvalidParameterError(
            "all controllers of a batch must have the same vector_rho (LQR runs go in a batch of their own)"
        )
    return controllers


def _rho_size(controller) -> int:
    """The controller's entries of the compiled loops' state after [alpha, alpha_dot]: rho_hat's
    size for designs I/II, none for the LQR."""
    return len(controller.initial_state())


def _initial_state(controller, alpha0, alpha_dot0, b: int) -> np.ndarray:
    """[alpha0, alpha_dot0, rho_hat(0)] of run b (``alpha_dot0``: one row or one per run)."""
    a0 = joint_vector(alpha0, "alpha0", 3)
    v0 = np.zeros(3)
    if alpha_dot0 is not None:
        rows = np.asarray(alpha_dot0, dtype=float)
        v0 = joint_vector(rows[b] if rows.ndim == 2 else rows, "alpha_dot0", 3)
    controller.reset()
    return np.concatenate([a0, v0, controller.initial_state().astype(float)])


def _plant_record(plant: Plant, controller: AdaptiveRobustController) -> np.record:
    """The plant as the compiled closed loop reads it (analytic; the tree is added by the caller)."""
    geometry = kernel_geometry(plant.robot.params)
    return record(
        PLANT,
        geometry=geometry,
        forearm_mass=1.5 * plant.robot.params.m_b,
        friction=plant.friction_parameters,
        shared_kinematics=controller.kernel_parameters["geometry"].tolist() == geometry.tolist(),
    )


def _attach_tree(plant_record, plant: ClosedChainPlant, y0) -> None:
    """The Pinocchio tree in active coordinates in the plant record: the native tree, whose
    completions of q(alpha) restart from the closed configuration at alpha0."""
    tree = plant.native_tree()
    tree.set_active(plant.active, plant.platform_q_indices, plant.robot.configuration(y0[:3]))
    plant_record["tree"] = True
    plant_record["active_dynamics"] = tree.address_active
    plant_record["tree_handle"] = tree.handle
    plant_record["nominal_platform_mass"] = plant.nominal_platform_mass
    plant_record["nominal_platform_rotational"] = plant.nominal_platform_rotational


def _run_closed_loop(controller, plant: Plant, truth, reference, y0, timing) -> _Outcome:
    """One run through :func:`~delta_pin.compiled.closed_loop.run_closed_loop`: the analytic plant,
    or the Pinocchio tree in active coordinates (continuous mode)."""
    plant_record = _plant_record(plant, controller)
    if _delta_tree(plant):
        _attach_tree(plant_record, plant, y0)
    samples, info = records(SAMPLE, timing["samples"] + 1), records(INFO, timing["samples"] + 1)
    counters = np.zeros(2, dtype=np.int64)
    status, when = closed_loop.run_closed_loop(
        controller.kernel_parameters, *chain_trigonometry(), plant_record, truth, reference, y0, timing,
        record(WORKSPACE), samples, info, counters,
    )  # fmt: skip
    failure = None
    if status != closed_loop.OK:
        method = "rk4" if timing["sampled"] else "bdf2"
        failure = SimulationError(f"{method}: {_FAILURES[int(status)]}", float(when))
    return _Outcome(samples, info, counters, failure)


RADAU_GRID = 4  # truth and reference rows per sample for the Radau integrator (dt / 4, as LSODA's)


def _run_radau(controller, plant: Plant, truth, table, y0, timing, rtol: float, atol: float) -> _Outcome:
    """One continuous run through :func:`~delta_pin.compiled.radau.run_radau`: the analytic plant
    or the Pinocchio tree in active coordinates; truth and reference on the grid dt / RADAU_GRID."""
    plant_record = _plant_record(plant, controller)
    if _delta_tree(plant):
        _attach_tree(plant_record, plant, y0)
    reference = records(REFERENCE, len(table.alpha))
    reference["alpha"], reference["alpha_dot"], reference["alpha_ddot"] = (
        table.alpha,
        table.alpha_dot,
        table.alpha_ddot,
    )
    control = record(
        STEP_CONTROL, rtol=rtol, atol=atol, first_step=RADAU_FIRST_STEP, max_step=RADAU_MAX_STEP,
        grid_step=table.step,
    )  # fmt: skip
    samples, info = records(SAMPLE, timing["samples"] + 1), records(INFO, timing["samples"] + 1)
    counters = np.zeros(4, dtype=np.int64)
    jerk = np.ascontiguousarray(table.alpha_dddot)
    status, when = radau.run_radau(
        controller.kernel_parameters, *chain_trigonometry(), plant_record, truth, reference, jerk, control,
        y0, timing, record(WORKSPACE), samples, info, counters,
    )  # fmt: skip
    failure = None
    if status != closed_loop.OK:
        failure = SimulationError(
            f"radau: {_RADAU_FAILURES.get(int(status), _FAILURES.get(int(status)))}", float(when)
        )
    return _Outcome(samples, info, counters, failure)


def _run_from_samples(outcome: _Outcome, nr: int, dt: float, alpha_d, alpha_dot_d, xyz_d, metadata) -> Run:
    """A :class:`~delta_pin.sim.run.Run` from the SAMPLE and INFO records of a compiled run."""
    samples, info = outcome.samples, outcome.info
    return Run(
        t=np.arange(len(samples)) * dt,
        alpha=samples["alpha"].copy(),
        alpha_dot=samples["alpha_dot"].copy(),
        alpha_d=np.array(alpha_d),
        alpha_dot_d=np.array(alpha_dot_d),
        xyz=samples["xyz"].copy(),
        xyz_d=np.array(xyz_d),
        tau=samples["tau"].copy(),
        closure_residual=samples["closure_gap"].copy(),
        internals={}
        if nr == 0  # the LQR: no internals, as its Python loop
        else {
            "rho_hat": samples["rho_hat"][:, :nr].copy(),
            "Lambda": info["Lambda"].copy(),
            "robust_gain": info["robust_gain"].copy(),
            "omega_norm": info["omega_norm"].copy(),
            "robust_torque": info["robust_torque"].copy(),
            "adaptation_active": info["adaptation_active"].copy(),
        },
        metadata=metadata,
    )

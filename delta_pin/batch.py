"""Batched runs of designs I and II, compiled, on either plant: continuous mode (BDF2) and sampled
mode (zero-order hold, RK4).

:func:`simulate_batch` advances many runs that share the robot, the path and the timing but differ
in gains, uncertainty or initial state through one compiled call
(:func:`delta_pin.fast_closed_loop.closed_loop_batch`). In continuous mode each run's result is
the same, bit for bit, as the run made alone (``simulate(..., integrator="bdf2")`` is a batch of
one); the integrator and its accuracy are described in :mod:`delta_pin.fast_closed_loop`. In
sampled mode the compiled loop does the arithmetic of :func:`~delta_pin.simulate.simulate`'s
sampled RK4 (same stages, same truth and reference rows): runs agree with ``simulate`` to
rounding (tests/test_batch.py: <= 1e-12 relative). On the Pinocchio plant (full coordinates) the
sampled loop of :mod:`delta_pin.fast_tree_loop` calls Pinocchio's C++ through
:mod:`delta_pin.native` and gives the arrays of ``simulate``'s sampled Pinocchio run
(tests/test_fast_tree_loop.py). In continuous mode on the Pinocchio plant, BDF2 integrates the
active coordinates and Pinocchio completes q(alpha) at every evaluation (see
:mod:`delta_pin.fast_closed_loop`). The Pinocchio plant needs the native library.

Example:
    >>> robot = load_delta()
    >>> nominal = DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    >>> runs = simulate_batch(robot, [design1(nominal, xi=x) for x in (1e-3, 1e-2)], PathI(),
    ...                       t_end=3.0, friction=Friction(),
    ...                       uncertainties=[PaperUncertainty()] * 2)
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from .control.adaptive_robust import AdaptiveRobustController
from .errors import InvalidParameterError, SimulationError
from .fast_model import chain_trigonometry, pack_geometry
from .plant import AnalyticPlant, PinocchioPlant, Plant, make_plant
from .robot import Delta

__all__ = ["batchable", "simulate_batch"]

_FAILURES = {
    1: "the state left the workspace (no forward kinematics, or the loops do not close)",
    2: "Newton's method did not converge even on 1024 sub-steps",
    3: "the run diverged (|alpha_dot| > 1000 rad/s or a non-finite state)",
}
MAX_JOINT_SPEED = 1e3  # [rad/s], as simulate's


def _is_tree(plant, mode: str = "sampled") -> bool:
    """Whether ``plant`` is the Pinocchio plant the compiled loops take in ``mode``: in full
    coordinates in sampled mode; either representation in continuous mode (BDF2 integrates the
    active coordinates and completes q(alpha) at every evaluation)."""
    if plant == "pinocchio":
        return True
    return isinstance(plant, PinocchioPlant) and (mode == "continuous" or plant.coordinates == "full")


def batchable(controller, plant="analytic", mode: str = "continuous") -> bool:
    """Whether ``controller`` on ``plant`` can take a compiled path: design I or II with its
    compiled step (the Delta's analytic nominal model), on the analytic plant or on the Pinocchio
    plant (in sampled mode in full coordinates) where the native library of
    :mod:`delta_pin.native` is available."""
    if not (
        isinstance(controller, AdaptiveRobustController)
        and getattr(controller, "_compiled", None) is not None
    ):
        return False
    if plant == "analytic" or isinstance(plant, AnalyticPlant):
        return True
    if _is_tree(plant, mode):
        from . import native

        return native.load() is not None
    return False


def _packed_plant(plant: Plant, packed_controllers: np.ndarray) -> np.ndarray:
    """The plant's numbers for :func:`~delta_pin.fast_closed_loop.closed_loop_batch`, with a flag
    saying whether every controller's nominal geometry is the plant's (then the kinematics are
    shared)."""
    from .control.fast_adaptive_robust import GEOMETRY

    params = plant.robot.params
    geometry = pack_geometry(params)
    friction = np.zeros(7)
    if plant.friction is not None:
        friction = np.array([1.0, *plant._friction_arguments, plant.friction.sign_velocity_scale])
    shared = bool(np.all(packed_controllers[:, GEOMETRY] == geometry))
    return np.concatenate([geometry, [1.5 * params.m_b], friction, [float(shared)]])


def simulate_batch(
    robot: Delta,
    controllers: Sequence[AdaptiveRobustController],
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
) -> list:
    """Simulate one run per controller (design I or II), compiled: BDF2 in continuous mode, RK4
    under a zero-order hold in sampled mode.

    Args:
        robot: the robot; every run uses it.
        controllers: designs I/II on the Delta's analytic nominal model, all with the same
            ``vector_rho``; gains and options may differ.
        trajectory: the shared path (``None``: hold ``alpha0``).
        plant: ``"analytic"``, or ``"pinocchio"`` in sampled mode (full coordinates, needs the
            native library), or such a :class:`~delta_pin.plant.Plant` (its friction and
            uncertainty then serve the first run).
        t_end, dt: duration and sample period [s]; integrator steps are dt / substeps.
        substeps: BDF2 or RK4 steps per sample (>= 1).
        mode: ``"continuous"`` (BDF2) or ``"sampled"`` (zero-order hold, RK4).
        alpha0, alpha_dot0: initial angles [rad] and velocities [rad/s] of every run, or one row
            per run ((B, 3)); defaults as :func:`~delta_pin.simulate.simulate`.
        friction: :class:`~delta_pin.plant.Friction` of every run, ``True`` or ``None``.
        uncertainties: one profile per run (``None`` entries: no uncertainty), or ``None``.
        errors: ``"raise"`` the first failure, or ``"return"`` it in place of its run.

    Returns:
        A list of :class:`~delta_pin.simulate.Run` (or :class:`~delta_pin.errors.SimulationError`
        with ``errors="return"``), in the order of ``controllers``.

    Raises:
        InvalidParameterError: a controller or plant the compiled path cannot run, bad sizes.
        SimulationError: a run that fails (with ``errors="raise"``), naming the time.
    """
    from .simulate import Run, _joint_vector, _reference, run_metadata

    controllers = list(controllers)
    if not controllers:
        raise InvalidParameterError("controllers must hold at least one controller")
    if errors not in ("raise", "return"):
        raise InvalidParameterError(f"errors={errors!r} must be 'raise' or 'return'")
    if mode not in ("continuous", "sampled"):
        raise InvalidParameterError(f"mode={mode!r} must be 'continuous' or 'sampled'")
    for index, controller in enumerate(controllers):
        if not batchable(controller, plant, mode):
            raise InvalidParameterError(
                f"controllers[{index}] ({getattr(controller, 'name', controller)!r}) on plant "
                f"{getattr(plant, 'name', plant)!r} in {mode} mode: the compiled loops run designs "
                "I/II with their compiled step on the analytic plant, or on the Pinocchio plant "
                "with the native library (in sampled mode in full coordinates); use "
                "integrator='lsoda' or simulate(..., compiled=False)"
            )
    if len({c.vector_rho for c in controllers}) > 1:
        raise InvalidParameterError("all controllers of a batch must have the same vector_rho")
    if not (isinstance(substeps, int) and substeps >= 1):
        raise InvalidParameterError(f"substeps={substeps!r} must be an integer >= 1")
    sampled = mode == "sampled"
    for name, value in (("dt", dt), ("t_end", t_end)):
        if not (isinstance(value, int | float) and value > 0.0 and np.isfinite(value)):
            raise InvalidParameterError(f"{name}={value!r} must be a positive number of seconds")
    count = len(controllers)
    uncertainties = [None] * count if uncertainties is None else list(uncertainties)
    if len(uncertainties) != count:
        raise InvalidParameterError(f"uncertainties has {len(uncertainties)} entries for {count} controllers")
    tree = _is_tree(plant, mode)
    kind = "pinocchio" if tree else "analytic"
    plants = [
        plant if isinstance(plant, Plant) and i == 0 else make_plant(kind, robot, friction, u)
        for i, u in enumerate(uncertainties)
    ]
    steps = round(t_end / dt)
    if steps < 1:
        raise InvalidParameterError(f"t_end={t_end} s is shorter than one period dt={dt} s")
    h = dt / substeps

    alpha0_rows = np.asarray(alpha0, dtype=float) if alpha0 is not None else None
    per_run_alpha0 = alpha0_rows is not None and alpha0_rows.ndim == 2
    # the reference on the integrator's grid (continuous) or at the samples (sampled), the truth on
    # the step grid (BDF2) or the half-step grid (RK4 stages), as simulate() tabulates them
    per_sample = 1 if sampled else substeps
    table, sample_xyz, start = _reference(
        robot, trajectory, alpha0_rows[0] if per_run_alpha0 else alpha0, 3, steps, dt, per_sample
    )
    reference = np.hstack([table.alpha, table.alpha_dot, table.alpha_ddot])
    grid = np.arange(2 * steps * substeps + 1) * (h / 2.0) if sampled else np.arange(steps * substeps + 1) * h
    truths = np.empty((count, len(grid), 7))
    initial = []
    for b, (controller, run_plant) in enumerate(zip(controllers, plants)):
        mass, normal, disturbance = run_plant._evaluate_truth(grid)
        truths[b] = np.column_stack([mass, normal, disturbance])
        a0 = _joint_vector(alpha0_rows[b] if per_run_alpha0 else start, "alpha0", 3)
        v0 = np.zeros(3)
        if alpha_dot0 is not None:
            rows = np.asarray(alpha_dot0, dtype=float)
            v0 = _joint_vector(rows[b] if rows.ndim == 2 else rows, "alpha_dot0", 3)
        controller.reset()
        initial.append(np.concatenate([a0, v0, controller.initial_state().astype(float)]))
    packed_controllers = np.array([c._compiled[1] for c in controllers])
    cos_phi, sin_phi = chain_trigonometry()

    wall = time.perf_counter()
    if tree and sampled:
        samples, info, gaps, failures, counters = _tree_runs(
            controllers,
            plants,
            packed_controllers,
            cos_phi,
            sin_phi,
            truths,
            reference,
            initial,
            dt,
            substeps,
            steps,
        )
    else:
        from .fast_closed_loop import closed_loop_batch

        packed_plant = _packed_plant(plants[0], packed_controllers)
        step = dt if sampled else h
        timing = (step, substeps, steps, MAX_JOINT_SPEED, sampled)
        if tree:  # one compiled call per run, each with its own plant and completion start
            parts = [
                closed_loop_batch(
                    packed_controllers[b : b + 1],
                    cos_phi,
                    sin_phi,
                    _tree_plant(packed_plant, plants[b], initial[b][:3]),
                    truths[b : b + 1],
                    reference,
                    np.array(initial[b : b + 1]),
                    *timing,
                )
                for b in range(count)
            ]
            samples, info, status, failure_time, counters = (np.concatenate(p) for p in zip(*parts))
            gaps = samples[:, :, -1]
        else:
            samples, info, status, failure_time, counters = closed_loop_batch(
                packed_controllers, cos_phi, sin_phi, packed_plant, truths, reference, np.array(initial),
                *timing,
            )  # fmt: skip
            gaps = np.zeros((count, steps + 1))
        failures = [
            None
            if status[b] == 0
            else SimulationError(
                f"{'rk4' if sampled else 'bdf2'}: {_FAILURES[int(status[b])]}", float(failure_time[b])
            )
            for b in range(count)
        ]
    wall = (time.perf_counter() - wall) / count

    t = np.arange(steps + 1) * dt
    nr = len(initial[0]) - 6
    results = []
    for b, controller in enumerate(controllers):
        error = failures[b]
        if error is not None:
            if errors == "raise":
                raise error
            results.append(error)
            continue
        out = samples[b]
        metadata = run_metadata(
            robot,
            controller,
            trajectory,
            plants[b],
            mode=mode,
            dt=dt,
            t_end=steps * dt,
            substeps=substeps,
            integrator="rk4" if sampled else "bdf2",
            alpha0=initial[b][:3].tolist(),
            alpha_dot0=initial[b][3:6].tolist(),
            wall_time=wall,
            rhs_evaluations=int(counters[b, 0]),
            split_steps=int(counters[b, 1]),
            batch_size=count,
            compiled=True,
        )
        if getattr(plants[b], "projections", 0):
            metadata["closure_projections"] = plants[b].projections
        results.append(
            Run(
                t=t,
                alpha=out[:, 0:3].copy(),
                alpha_dot=out[:, 3:6].copy(),
                alpha_d=np.array(table.alpha[::per_sample]),
                alpha_dot_d=np.array(table.alpha_dot[::per_sample]),
                xyz=out[:, 9:12].copy(),
                xyz_d=np.array(sample_xyz),
                tau=out[:, 6:9].copy(),
                closure_residual=gaps[b].copy(),
                internals={
                    "rho_hat": out[:, 12 : 12 + nr].copy(),
                    "Lambda": info[b, :, 1].copy(),
                    "robust_gain": info[b, :, 2].copy(),
                    "omega_norm": info[b, :, 3].copy(),
                    "robust_torque": info[b, :, 5:8].copy(),
                    "adaptation_active": info[b, :, 4].copy(),
                },
                metadata=metadata,
            )
        )
    return results


def _tree_runs(
    controllers, plants, packed_controllers, cos_phi, sin_phi, truths, reference, initial, dt, substeps, steps
):
    """Sampled runs on Pinocchio plants, one compiled loop each
    (:func:`~delta_pin.fast_tree_loop.tree_sampled_loop`), each reading its truth table ``truths[b]``
    (the half-step grid, as :meth:`~delta_pin.plant.Plant.precompute_truth` tabulates it for
    ``simulate``) and the platform inertia at each of its masses. Where the loop stops for a projection,
    the plant's own :meth:`~delta_pin.plant.PinocchioPlant.finish_step_residual` projects the state
    and the loop resumes; where it stops on a failure, the failing step is re-evaluated by the
    Python code that ``simulate`` runs, so that the error is the one ``simulate`` raises.

    Returns:
        (samples (B, steps + 1, 12 + nr), info (B, steps + 1, 8), gaps (B, steps + 1),
        failures (B,): ``None`` or the run's :class:`~delta_pin.errors.SimulationError`,
        counters (B, 2)).
    """
    from .fast_tree_loop import OK, PROJECT, tree_sampled_loop
    from .simulate import _Loop

    count, nr = len(controllers), len(initial[0]) - 6
    samples = np.full((count, steps + 1, 12 + nr), np.nan)
    info = np.full((count, steps + 1, 8), np.nan)
    gaps = np.full((count, steps + 1), np.nan)
    counters = np.zeros((count, 2), dtype=np.int64)
    failures: list = [None] * count
    limits = np.array([MAX_JOINT_SPEED, 0.0, 0.0])
    for b, (controller, plant) in enumerate(zip(controllers, plants)):
        model = plant._source
        active, platform = model.active_indices.astype(np.int64), model.platform_indices.astype(np.int64)
        tree = plant.native_tree()
        handles = np.array([tree.address_dynamics, tree.address_gap, tree.handle], dtype=np.int64)
        table = truths[b]
        masses, normals, disturbances = (
            np.ascontiguousarray(table[:, c]) for c in (0, slice(1, 4), slice(4, 7))
        )
        truth = (masses, plant._rotational_inertia(masses[:, None, None]), normals, disturbances)
        limits[1:] = plant.projection_tolerance, plant.failure_tolerance
        x0 = plant.initial_state(initial[b][:3], initial[b][3:6])
        state = np.concatenate([[0.0, 0.0, 0.0], x0, initial[b][6:], np.zeros(3 + nr)])
        nx = len(x0)
        packed_plant = _packed_plant(plant, packed_controllers[b : b + 1])
        while True:
            status, when = tree_sampled_loop(
                packed_controllers[b], cos_phi, sin_phi, packed_plant, handles, active, platform, truth,
                plant._friction_vector, reference, dt, substeps, steps, limits, state,
                samples[b], info[b], gaps[b], counters[b],
            )  # fmt: skip
            x, rho = state[3 : 3 + nx], state[3 + nx : 3 + nx + nr]
            if status == PROJECT:  # project with the plant's routine, then resume
                try:
                    state[3 : 3 + nx], state[2] = plant.finish_step_residual(x.copy(), when)
                except SimulationError as error:
                    failures[b] = error
                    break
                continue
            if status == OK:
                break
            loop = _Loop(controller, plant)
            failures[b] = _tree_failure(status, when, loop, x.copy(), rho.copy(), reference[int(state[0])])
            break
    return samples, info, gaps, failures, counters


def _tree_failure(status: int, when: float, loop, x: np.ndarray, rho: np.ndarray, reference_row) -> Exception:
    """The error ``simulate``'s Python loop raises where the compiled tree loop stopped with
    ``status`` at ``when`` [s] in state (x, rho): the same Python check is run on that state."""
    from .control.base import Reference
    from .errors import DeltaPinError
    from .fast_tree_loop import DIVERGED, EXPLODED, NO_FK

    try:
        if status == NO_FK:
            loop.control(when, x, Reference(reference_row[0:3], reference_row[3:6], reference_row[6:9]), rho)
        elif status == DIVERGED:
            loop.check_state(when, x, rho)
        elif status == EXPLODED:
            loop.plant.finish_step_residual(x, when)
    except DeltaPinError as error:
        return error
    reasons = {NO_FK: "the controller's kinematics failed", DIVERGED: "the run diverged"}
    return SimulationError(f"rk4 on the tree: {reasons.get(status, 'Pinocchio failed')}", when)


def _tree_plant(packed_plant: np.ndarray, plant: PinocchioPlant, alpha0: np.ndarray) -> np.ndarray:
    """The packed plant extended by the plant's native tree in active coordinates (see
    :func:`~delta_pin.fast_closed_loop._plant_acceleration_into`), its completions restarted
    from the closed configuration at ``alpha0``."""
    tree = plant.native_tree()
    source = plant._source
    tree.set_active(source.active_indices, source.platform_indices, source.configuration(alpha0))
    addresses = [tree.address_active, tree.handle]
    if max(addresses) >= 2**53:  # pragma: no cover - user-space addresses are below 2^48
        raise InvalidParameterError("native addresses beyond 2^53 cannot travel in a float64 vector")
    nominal = plant._nominal_inertia
    return np.concatenate([packed_plant, addresses, [nominal.mass], plant._nominal_rotational.ravel()])

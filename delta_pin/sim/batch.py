"""Many runs of designs I/II (the LQR in continuous mode) that share the robot, the path and the
timing but differ in gains, uncertainty or initial state: :func:`simulate_batch`, the batch of
:func:`~delta_pin.studies.experiments.run_batch` and the sweeps. Sampled and Radau batches run
one :func:`~delta_pin.sim.runner.simulate` after the other on the compiled core (a run of a
batch is the run made alone); BDF2 batches take the Delta's numba loops
(:mod:`delta_pin.sim.compiled_batch`), one compiled call each.

Example:
    >>> robot = load_delta()
    >>> nominal = DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    >>> runs = simulate_batch(robot, [design1(nominal, xi=x) for x in (1e-3, 1e-2)], PathI(),
    ...                       t_end=3.0, friction=Friction(),
    ...                       uncertainties=[PaperUncertainty()] * 2)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from delta_pin.control.adaptive_robust import AdaptiveRobustController
from delta_pin.control.baselines import LQR
from delta_pin.errors import SimulationError
from delta_pin.model.robot import Delta
from delta_pin.sim.compiled_batch import (
    _is_tree,
    batchable,
    check_batch,
    native_available,
    simulate_compiled_batch,
)
from delta_pin.sim.plants import Plant
from delta_pin.sim.runner import simulate

__all__ = ["batchable", "native_available", "simulate_batch"]


def simulate_batch(
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
    """Simulate one run per controller (design I or II; the LQR in continuous mode), compiled: BDF2
    or Radau IIA in continuous mode, RK4 under a zero-order hold in sampled mode.

    Args:
        robot: the robot; every run uses it.
        controllers: designs I/II (or, in continuous mode, LQRs) on the Delta's analytic nominal
            model, all with the same ``vector_rho``; gains and options may differ.
        trajectory: the shared path (``None``: hold ``alpha0``).
        plant: ``"analytic"`` or ``"pinocchio"`` (needs the native library), or such a
            :class:`~delta_pin.sim.plants.Plant` (its friction and uncertainty then serve the
            first run).
        t_end, dt: duration and sample period [s]; integrator steps are dt / substeps.
        substeps: BDF2 or RK4 steps per sample (>= 1).
        mode: ``"continuous"`` (BDF2) or ``"sampled"`` (zero-order hold, RK4).
        alpha0, alpha_dot0: initial angles [rad] and velocities [rad/s] of every run, or one row
            per run ((B, 3)); defaults as :func:`~delta_pin.sim.runner.simulate`.
        friction: :class:`~delta_pin.model.friction.Friction` of every run, ``True`` or ``None``.
        uncertainties: one profile per run (``None`` entries: no uncertainty), or ``None``.
        errors: ``"raise"`` the first failure, or ``"return"`` it in place of its run.
        integrator: continuous mode: ``"bdf2"`` (fixed steps dt / substeps) or ``"radau"`` (Radau
            IIA with error control, :mod:`delta_pin.compiled.radau`; its samples every dt).
        rtol, atol: ``"radau"``'s tolerances (relative; absolute in SI units of the state).

    Returns:
        A list of :class:`~delta_pin.sim.run.Run` (or :class:`~delta_pin.errors.SimulationError`
        with ``errors="return"``), in the order of ``controllers``.

    Raises:
        InvalidParameterError: a controller or plant the compiled path cannot run, bad sizes.
        SimulationError: a run that fails (with ``errors="raise"``), naming the time.
    """
    if mode == "continuous" and integrator == "bdf2":
        return simulate_compiled_batch(
            robot, controllers, trajectory, plant=plant, t_end=t_end, dt=dt, substeps=substeps, mode=mode,
            alpha0=alpha0, alpha_dot0=alpha_dot0, friction=friction, uncertainties=uncertainties,
            errors=errors, integrator=integrator, rtol=rtol, atol=atol,
        )  # fmt: skip
    controllers, uncertainties, _, _ = check_batch(
        controllers, plant, mode, errors, integrator, rtol, atol, substeps, dt, t_end, uncertainties
    )
    kind = "pinocchio" if _is_tree(plant, mode) else "analytic"
    return _core_runs(
        robot, controllers, trajectory, plant, kind, uncertainties, errors, alpha0, alpha_dot0,
        t_end=t_end, dt=dt, substeps=substeps, mode=mode, friction=friction,
        integrator="rk4" if mode == "sampled" else "radau", rtol=rtol, atol=atol,
    )  # fmt: skip


def _core_runs(
    robot, controllers, trajectory, plant, kind, uncertainties, errors, alpha0, alpha_dot0, **options
):
    """The runs of a sampled or Radau batch, each :func:`~delta_pin.sim.runner.simulate` on the
    compiled core (so that a run of a batch is the run made alone); ``plant``: a name, or a
    :class:`~delta_pin.sim.plants.Plant` for the first run (the others: ``kind`` by name)."""

    def row(values, b):
        values = None if values is None else np.asarray(values, dtype=float)
        return values[b] if values is not None and values.ndim == 2 else values

    results = []
    friction = options.pop("friction")
    for b, (controller, uncertainty) in enumerate(zip(controllers, uncertainties)):
        given = isinstance(plant, Plant) and b == 0
        try:
            run = simulate(
                robot, controller, trajectory, plant=plant if given else kind, alpha0=row(alpha0, b),
                alpha_dot0=row(alpha_dot0, b), friction=None if given else friction,
                uncertainty=None if given else uncertainty, **options,
            )  # fmt: skip
        except SimulationError as failure:
            if errors == "raise":
                raise
            results.append(failure)
            continue
        run.metadata["batch_size"] = len(controllers)
        results.append(run)
    return results

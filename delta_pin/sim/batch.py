"""Many runs that share the robot, the path and the timing but differ in controller, gains,
uncertainty or initial state: :func:`simulate_batch`, the batch of
:func:`~delta_pin.studies.experiments.run_batch` and the sweeps: one
:func:`~delta_pin.sim.runner.simulate` after the other on the compiled core (a run of a batch is
the run made alone).

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

from delta_pin.errors import InvalidParameterError, SimulationError
from delta_pin.model.frame_path import FramePath
from delta_pin.model.robot import Delta
from delta_pin.sim.plants import Plant
from delta_pin.sim.reference import SharedReference
from delta_pin.sim.runner import simulate

__all__ = ["simulate_batch"]


def simulate_batch(
    robot: Delta,
    controllers: Sequence,
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
    """Simulate one run per controller on the compiled core: BDF2 or Radau IIA in continuous mode,
    RK4 under a zero-order hold in sampled mode.

    Args:
        robot: the robot; every run uses it.
        controllers: the runs' controllers (designs I/II, the baselines, a user's own; a
            continuous-time one in continuous mode).
        trajectory: the shared path (``None``: hold ``alpha0``).
        plant: ``"analytic"`` or ``"pinocchio"``, or such a
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
            IIA with error control, :mod:`delta_pin.sim.loop`; its samples every dt).
        rtol, atol: ``"radau"``'s tolerances (relative; absolute in SI units of the state).

    Returns:
        A list of :class:`~delta_pin.sim.run.Run` (or :class:`~delta_pin.errors.SimulationError`
        with ``errors="return"``), in the order of ``controllers``.

    Raises:
        InvalidParameterError: a controller or plant the compiled path cannot run, bad sizes.
        SimulationError: a run that fails (with ``errors="raise"``), naming the time.
    """
    controllers = list(controllers)
    if not controllers:
        raise InvalidParameterError("controllers must hold at least one controller")
    if errors not in ("raise", "return"):
        raise InvalidParameterError(f"errors={errors!r} must be 'raise' or 'return'")
    if mode == "continuous" and integrator not in ("bdf2", "radau"):
        raise InvalidParameterError(f"integrator={integrator!r} must be 'bdf2' or 'radau' (continuous mode)")
    uncertainties = [None] * len(controllers) if uncertainties is None else list(uncertainties)
    if len(uncertainties) != len(controllers):
        raise InvalidParameterError(
            f"uncertainties has {len(uncertainties)} entries for {len(controllers)} controllers"
        )
    kind = plant.name if isinstance(plant, Plant) else plant
    return _core_runs(
        robot, controllers, trajectory, plant, kind, uncertainties, errors, alpha0, alpha_dot0,
        t_end=t_end, dt=dt, substeps=substeps, mode=mode, friction=friction,
        integrator="rk4" if mode == "sampled" else integrator, rtol=rtol, atol=atol,
    )  # fmt: skip


def _core_runs(
    robot, controllers, trajectory, plant, kind, uncertainties, errors, alpha0, alpha_dot0, **options
):
    """The runs of a batch, each :func:`~delta_pin.sim.runner.simulate` on the compiled core (so
    that a run of a batch is the run made alone); ``plant``: a name, or a
    :class:`~delta_pin.sim.plants.Plant` for the first run (the others: ``kind`` by name)."""

    def row(values, b):
        values = None if values is None else np.asarray(values, dtype=float)
        return values[b] if values is not None and values.ndim == 2 else values

    results = []
    friction = options.pop("friction")
    if trajectory is not None and not isinstance(trajectory, FramePath):
        trajectory = SharedReference(trajectory)  # one path, one grid: tabulated once
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

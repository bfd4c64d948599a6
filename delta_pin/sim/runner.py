"""The closed-loop runner: any controller, on either plant, along any path -> a :class:`Run`.

Two timings (docs/architecture.md section 6):

* ``mode="sampled"`` -- a digital drive: tau_k is evaluated at t_k = k dt and held (zero-order
  hold) over [t_k, t_k + dt) while the plant integrates with ``substeps`` RK4 steps; the
  controller's internal state (rho_hat) advances once per period, z_{k+1} = z_k + dt z_dot_k;
* ``mode="continuous"`` -- the analysis of the paper: the controller is evaluated inside the
  integrator (the compiled core's Radau IIA with error control by default where the plant has a
  compiled copy, :mod:`delta_pin.sim.continuous_core`; LSODA elsewhere; RK4 or the core's
  fixed-step BDF2 on request).

:func:`simulate` checks its arguments, takes the compiled core where the plant has a copy there
(the Python loop, :func:`~delta_pin.sim.loop.run_python_loop`, hands the sampled loop to it) or the
Python loop elsewhere, and wraps the result in a :class:`Run`.
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from delta_pin.choices import INTEGRATOR_CHOICES
from delta_pin.control.base import Controller, NoTorque, as_controller
from delta_pin.errors import InvalidParameterError, SimulationError
from delta_pin.model.closed_chain import ClosedChainRobot
from delta_pin.model.delta_robot import analytic_delta
from delta_pin.model.frame_path import FramePath
from delta_pin.model.friction import Friction
from delta_pin.model.robot import Delta
from delta_pin.model.trajectory import Trajectory
from delta_pin.sim.arguments import check_mode, check_substeps, check_timing, joint_vector
from delta_pin.sim.closed_chain_plant import ClosedChainPlant, closed_chain_plant, make_plant
from delta_pin.sim.compiled_plant import core_unavailable
from delta_pin.sim.continuous_core import continuous_core, run_core_continuous
from delta_pin.sim.drive import Drive, Encoder, check_delay
from delta_pin.sim.integrators import INTEGRATORS
from delta_pin.sim.loop import run_python_loop
from delta_pin.sim.plants import Plant
from delta_pin.sim.reference import tabulate_reference
from delta_pin.sim.run import Run, run_metadata
from delta_pin.sim.serial import JointSinusoid
from delta_pin.sim.uncertainty import Uncertainty

__all__ = ["INTEGRATOR_CHOICES", "simulate"]


def _choose_integrator(integrator: str, mode: str) -> str:
    """The integrator ``"auto"`` stands for in ``mode`` where the core's Radau does not take the
    run (:func:`_core_integrator` chose it already where it does): RK4 in sampled mode, LSODA in
    continuous mode; else ``integrator`` if it fits the mode."""
    if integrator == "auto":
        return "rk4" if mode != "continuous" else "lsoda"
    if integrator not in INTEGRATORS or (integrator != "rk4" and mode == "sampled"):
        raise InvalidParameterError(
            f"integrator={integrator!r} must be 'rk4' or, in continuous mode, 'lsoda', 'bdf2' or 'radau'"
        )
    return integrator


LAYER_FRACTION = 0.25  # LSODA's velocity error bound: at most this fraction of the robust term's layer


def _layer_resolving_rtol(controller, table, rtol: float) -> float:
    """LSODA's ``rtol``, tightened where the controller's robust term slides in a boundary layer
    (``controller.boundary_layer``, designs I/II) thinner than LSODA would resolve: the velocity
    error it allows, rtol max|alpha_dot^d|, must stay below :data:`LAYER_FRACTION` of the layer.
    Otherwise the corrector's iterates land outside the layer, where design I's phi has a kink and
    the unit-vector term no radial stiffness, and LSODA stops with "repeated convergence failures"
    (the Adept cycle: Lambda ~240, a layer of ~4e-6 rad/s, rtol 1.6e-7). Paths I and II keep 1e-6."""
    layer = getattr(controller, "boundary_layer", None)
    if layer is None:
        return rtol
    width = layer(table.alpha_dot, table.alpha_ddot)  # [rad/s]
    speed = max(float(np.abs(table.alpha_dot).max()), 1.0)  # [rad/s]
    return min(rtol, LAYER_FRACTION * width / speed)


def _core_options(robot, plant, integrator, compiled, friction, uncertainty, mode):
    """(compiled, plant) of a run in the compiled core's loops: the plant by name -- a closed
    chain's constrained Pinocchio plant (in active coordinates for LSODA where the actuated
    joints carry the whole motion), or the Delta's reduced one -- or the given one; its copy in
    the core steps the sampled loop (:meth:`~delta_pin.sim.plants.Plant.sampled_core`) and, in
    continuous mode, the core's Radau IIA where it applies (:func:`_core_integrator`)."""
    name = getattr(robot, "name", type(robot).__name__)
    if compiled and mode != "sampled" and integrator not in ("auto", "radau", "bdf2"):
        raise InvalidParameterError(
            f"compiled=True: {name!r} runs compiled in continuous mode with integrator='radau' or "
            f"'bdf2', not {integrator!r} (compiled=None or False)"
        )
    if isinstance(plant, str):
        options = {}
        if plant == "pinocchio" and mode == "continuous" and not robot.has_unactuated_motion:
            options["coordinates"] = "active"  # LSODA's small state
        plant = closed_chain_plant(plant, robot, friction, uncertainty, **options)
    return compiled, plant


def _core_integrator(
    integrator: str, plant, controller, compiled: bool | None = None
) -> tuple[str, tuple | None]:
    """(integrator, compiled plant and law) of a continuous run: the core's Radau IIA or, asked
    for, its BDF2 (:mod:`delta_pin.sim.continuous_core`) where the plant has a compiled copy, with
    the controller's compiled law or its own Python ``evaluate`` called per evaluation, else
    LSODA (``"auto"``; ``"radau"``, ``"bdf2"`` or ``compiled=True``: one line that says why not)."""
    if integrator not in ("auto", "radau", "bdf2"):
        return integrator, None
    in_core = continuous_core(plant, controller)
    if in_core is not None:
        return ("bdf2" if integrator == "bdf2" else "radau"), in_core
    if integrator != "auto" or compiled:
        asked = f"integrator={integrator!r}" if integrator != "auto" else "compiled=True"
        why = core_unavailable() or "a discrete-time controller, or a plant without a compiled copy"
        raise InvalidParameterError(
            f"{asked}: the compiled core runs continuous with a continuous-time controller on a plant "
            f"with a compiled copy ({why}); plant {getattr(plant, 'name', plant)!r} here takes "
            "integrator='lsoda' (compiled=None or False)"
        )
    return "lsoda", None


def _engine_robot(robot, delta, plant, trajectory):
    """The robot a run goes on: for a Delta with the analytic model of its own URDF (the robot of
    ``load_delta``, or that analytic :class:`~delta_pin.model.robot.Delta` itself) the closed
    chain of its URDF on the Pinocchio plant -- its plant in the compiled core, a controller's
    compiled law there (the Delta's analytic nominal model included) or its own Python law called
    back --, the analytic model with the analytic plant (the core's reduced Delta) or a plant of
    the caller's, and for the fixed-step BDF2 (the Delta's own compiled loops). Any other robot
    runs as it is. ``delta``: the robot's :func:`~delta_pin.model.delta_robot.analytic_delta`."""
    if not isinstance(delta, Delta):
        return robot
    chain = delta.pinocchio if robot is delta else robot
    if isinstance(plant, ClosedChainPlant) or isinstance(trajectory, FramePath):
        return chain
    return chain if plant == "pinocchio" else delta


def _check_digital(controller, mode: str, dt: float, drive_effects: bool, delay: int = 0) -> None:
    """A discrete-time controller runs only in sampled mode at its own period and with the
    computation delay it accounts for; an encoder, a delay or a torque limit exist only in
    sampled mode."""
    period = getattr(controller, "dt", None)
    if mode != "sampled" and (drive_effects or period is not None):
        what = (
            f"controller {controller.name!r} is discrete-time (dt={period})"
            if period
            else "sensor, delay and torque_limit"
        )
        raise InvalidParameterError(f"{what}: only in mode='sampled'")
    if period is not None and not math.isclose(period, dt, rel_tol=1e-12):
        raise InvalidParameterError(
            f"controller {controller.name!r} has dt={period} s but the loop samples at dt={dt} s: "
            "give both the same period"
        )
    # a law that models the delay (a discrete-time law, or any law built with delay > 0) runs with it
    accounted = getattr(controller, "delay", 0)
    if accounted != delay and (accounted > 0 or period is not None):
        raise InvalidParameterError(
            f"controller {controller.name!r} accounts for delay={accounted} sample(s) but the loop delays "
            f"its torque by delay={delay}: give simulate(..., delay={accounted}) (or build the law with "
            f"delay={delay})"
        )


def simulate(
    robot: Delta | ClosedChainRobot,
    controller: Controller | Callable | None,
    trajectory: Trajectory | FramePath | JointSinusoid | None = None,
    *,
    plant: str | Plant = "pinocchio",
    t_end: float,
    dt: float = 1e-3,
    mode: str = "sampled",
    alpha0: ArrayLike | None = None,
    alpha_dot0: ArrayLike | None = None,
    friction: Friction | bool | None = None,
    uncertainty: Uncertainty | None = None,
    substeps: int = 1,
    integrator: str = "auto",
    rtol: float = 1e-6,
    atol: float = 1e-8,
    progress: bool | None = False,
    compiled: bool | None = None,
    sensor: Encoder | None = None,
    delay: int = 0,
    torque_limit: float | ArrayLike | None = None,
) -> Run:
    """Simulate ``controller`` driving ``robot`` along ``trajectory``.

    Args:
        robot: the robot (:func:`delta_pin.load_delta`), or any closed-chain robot
            (:func:`delta_pin.load_robot`; then the Python loop on its
            :class:`~delta_pin.sim.closed_chain_plant.ClosedChainPlant`, ``friction`` and a
            ``payload_mass`` given to that plant).
        controller: a :class:`~delta_pin.control.Controller` or any ``f(t, alpha, alpha_dot) -> tau``;
            ``None``: no torque (a free motion; a mechanism without motors).
        trajectory: a task-space :class:`~delta_pin.model.trajectory.Trajectory`, a named frame's
            :class:`~delta_pin.model.frame_path.FramePath`, a joint-space path
            (:class:`~delta_pin.sim.serial.JointSinusoid`), or ``None`` to
            hold ``alpha0`` (default: a closed chain's ``home``).
        plant: ``"pinocchio"`` (constrained multibody, the default), ``"analytic"`` (reduced ODE) or
            a :class:`~delta_pin.sim.plants.Plant`.
        t_end: duration [s] (> 0).
        dt: sample (and control) period [s] (> 0).
        mode: ``"sampled"`` (zero-order hold) or ``"continuous"`` (see the module docstring).
        alpha0: initial joint angles [rad or m]; default the trajectory's start.
        alpha_dot0: initial joint velocities [rad/s or m/s]; default zero.
        friction: :class:`~delta_pin.model.friction.Friction`, ``True`` for its defaults, or ``None``.
        uncertainty: an :class:`~delta_pin.sim.uncertainty.Uncertainty` profile or ``None``.
        substeps: RK4 steps per period (>= 1) for the ``"rk4"`` integrator.
        integrator: ``"rk4"`` (fixed step dt / substeps), ``"lsoda"`` (scipy's adaptive
            stiff/non-stiff switching solver, continuous mode only), ``"radau"`` (the compiled
            core's Radau IIA of order 5 with error control, continuous mode,
            :mod:`delta_pin.sim.continuous_core`: any plant with a compiled copy and any
            continuous-time controller, its compiled law or its Python one) or ``"bdf2"`` (the
            Delta's compiled implicit BDF2 with fixed steps dt / substeps, designs I/II and the
            LQR, off by more than Radau in a reaching phase; what the sweeps of ``reproduce
            --full`` batch). ``"auto"`` takes RK4 in sampled mode and, in continuous mode, Radau
            where it applies (the robust term's boundary-layer gain makes the closed loop stiff)
            and LSODA elsewhere.
        rtol: LSODA's or Radau's relative tolerance. For designs I/II it is tightened where
            needed to resolve the robust term's boundary layer (a fast path such as the Adept
            cycle); ``metadata["rtol"]`` is the one used.
        atol: LSODA's or Radau's absolute tolerance (SI units of the state).
        progress: show the simulated time on stderr (``None``: only on a terminal).
        compiled: the compiled core's plant (:meth:`~delta_pin.sim.plants.Plant.core_plant`: a
            closed chain's, the Delta's reduced one) with a controller's compiled law (designs
            I/II, computed torque, PD, LQR, TDC, digital-robust; the drive included) or its Python
            law called back once per sample (sampled) or per evaluation (continuous, Radau).
            ``None`` (the default): where it applies; ``False``: never (the Python loop, the
            reference the core is tested against); ``True``: required (an error where it does
            not apply).
        sensor: sampled mode: an :class:`~delta_pin.sim.drive.Encoder` whose readings the
            controller gets (quantised angles; velocity by difference, by the controller's own
            estimate, or exact); ``None``: the true joint state.
        delay: sampled mode: samples of computation delay: the torque computed at sample k acts
            from sample k + delay (zero before) (>= 0).
        torque_limit: sampled mode: the drive's saturation [N m], one value or one per joint;
            ``None``: none. The run records ``tau`` as the torque that acted and the controller's
            output as the internal ``tau_command``; ``metadata["torque_limit_hits"]`` counts the
            samples at which the limit bound.

    Raises:
        InvalidParameterError: non-positive dt, t_end or substeps, unknown mode or plant.
        UnreachablePoseError: the trajectory leaves the workspace (before the run starts).
        SimulationError: a bad controller output, a diverging state or an exploding closure gap,
            with the time it happened.
    """
    steps = check_timing(dt, t_end)
    if controller is None:  # a free motion: a mechanism without motors, or the motors off
        controller = NoTorque(len(getattr(robot, "actuated_joints", ())) or robot.dof)
    check_mode(mode)
    check_substeps(substeps)
    if not (math.isfinite(rtol) and math.isfinite(atol) and rtol > 0.0 and atol > 0.0):
        raise InvalidParameterError(f"rtol={rtol!r} and atol={atol!r} must be positive")
    described = analytic_delta(robot)  # a Delta's run is described as the Delta's (its metadata)
    robot = _engine_robot(robot, described, plant, trajectory)
    # the compiled core's plant in the Python loop's sampled mode: where it applies, not with
    # compiled=False (the Python plant's RK4: the reference)
    core = False if compiled is False else None
    in_core = None  # the core's plant and law for a continuous run: where they apply
    core, plant = _core_options(robot, plant, integrator, compiled, friction, uncertainty, mode)
    friction = uncertainty = None  # now the plant's
    if mode == "continuous" and core is not False:
        controller = as_controller(controller)  # one wrapper: the core's law calls the run's controller
        integrator, in_core = _core_integrator(integrator, plant, controller, core)
    integrator = _choose_integrator(integrator, mode)
    drive_effects = sensor is not None or check_delay(delay) > 0 or torque_limit is not None
    if sensor is not None and not isinstance(sensor, Encoder):
        raise InvalidParameterError(f"sensor={sensor!r} must be a delta_pin Encoder or None")
    _check_digital(as_controller(controller), mode, dt, drive_effects, delay)
    if integrator in ("radau", "bdf2") and in_core is None:
        raise InvalidParameterError(
            f"integrator={integrator!r} is the compiled core's (continuous mode); compiled=False: 'lsoda'"
        )
    # an adaptive integrator takes the Pinocchio plant in active coordinates (loops closed by
    # construction at every evaluation; a 7-dimensional state instead of 25)
    options = {"coordinates": "active"} if integrator == "lsoda" else {}
    plant = make_plant(plant, robot, friction, uncertainty, **options)
    controller = as_controller(controller)
    dof, h = plant.dof, dt / substeps
    # the reference on a grid fine enough for the integrator: the samples in sampled mode, the RK4
    # stage times (half steps) or dt/4 for LSODA in continuous mode
    per_sample = 1 if mode == "sampled" else {"rk4": 2 * substeps, "bdf2": substeps}.get(integrator, 4)
    table, sample_xyz, alpha0 = tabulate_reference(robot, trajectory, alpha0, dof, steps, dt, per_sample)
    alpha0 = joint_vector(alpha0, "alpha0", dof)
    if integrator == "lsoda":
        rtol = _layer_resolving_rtol(controller, table, rtol)
    alpha_dot0 = np.zeros(dof) if alpha_dot0 is None else joint_vector(alpha_dot0, "alpha_dot0", dof)
    if integrator == "rk4":
        plant.precompute_truth(h / 2.0, 2 * steps * substeps + 1)
    t = np.arange(steps + 1) * dt
    drive = Drive(dof, delay, torque_limit) if drive_effects else None
    if sensor is not None:
        sensor.reset()

    wall = time.perf_counter()
    counters = {}
    try:
        if in_core is not None:
            record, counters = run_core_continuous(
                in_core, controller, plant, table, alpha0, alpha_dot0, t, rtol, atol,
                substeps if integrator == "bdf2" else 0,
            )  # fmt: skip
        else:
            record = run_python_loop(
                controller, plant, table, per_sample, plant.initial_state(alpha0, alpha_dot0), t, mode=mode,
                integrator=integrator, substeps=substeps, rtol=rtol, atol=atol, progress=progress,
                sensor=sensor, drive=drive, compiled=core,
            )  # fmt: skip
    except SimulationError as exc:
        raise _with_singularity(exc, robot) from None
    wall = time.perf_counter() - wall

    metadata = run_metadata(
        described, controller, trajectory, plant, mode=mode, dt=dt, t_end=steps * dt, substeps=substeps,
        integrator=integrator, **({"rtol": rtol, "atol": atol} if integrator in ("lsoda", "radau") else {}),
        alpha0=alpha0.tolist(), alpha_dot0=alpha_dot0.tolist(), wall_time=wall,
    )  # fmt: skip
    if getattr(plant, "projections", 0):
        metadata["closure_projections"] = plant.projections
    if getattr(plant, "stepped_in_core", False) or in_core is not None:
        metadata["core_plant"] = True  # the plant stepped in the compiled core
    metadata.update(counters)
    if drive is not None:
        metadata.update(sensor=None if sensor is None else sensor.metadata(), **drive.metadata())
    alpha_d, alpha_dot_d, _ = table.rows(per_sample)
    return Run(
        t=t,
        alpha=record.alpha,
        alpha_dot=record.alpha_dot,
        alpha_d=np.array(alpha_d),
        alpha_dot_d=np.array(alpha_dot_d),
        xyz=record.xyz,
        xyz_d=np.array(sample_xyz),
        tau=record.tau,
        closure_residual=record.closure_residual,
        internals=record.internals,
        q=record.q,
        v=record.v,
        metadata=metadata,
    )


_ASSEMBLY_FAILURES = ("cannot close the loops", "the loops cannot be re-assembled")
_SINGULAR_CONDITION = 1e6  # cond(J_p) beyond which a failed assembly is called a singularity


def _with_singularity(error: SimulationError, robot) -> SimulationError:
    """A run's failed assembly said as what it is: cond(J_p) where the loops stopped closing
    (an actuation singularity where it is large), instead of the assembly's advice for a start."""
    text = str(error).rsplit(" (at t=", 1)[0]
    if not isinstance(robot, ClosedChainRobot) or not text.startswith(_ASSEMBLY_FAILURES):
        return error
    text = text.replace("; start nearer (initial_guess=) or choose reachable actuated coordinates", "")
    found = re.search(r"alpha0?=\[([^\]]*)\]", text)
    if found is None:
        return error
    alpha = np.array([float(x) for x in found.group(1).split(",")])
    if alpha.shape != (robot.dof,):
        return error
    try:  # from the last configuration the run recorded, on the branch it was on
        condition = robot.actuation_conditioning(alpha, start=error.configuration)
    except Exception:  # the report of a failure must not fail itself
        return error
    what = (
        f"an actuation (Type II) singularity: cond(J_p) = {condition:.3g} there, the actuated joints "
        "no longer fix the loops"
        if condition > _SINGULAR_CONDITION
        else f"cond(J_p) = {condition:.3g} there"
    )
    return SimulationError(f"{text}; {what}", error.time, error.configuration)

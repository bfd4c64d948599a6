"""The closed-loop runner: any controller, on either plant, along any path -> a :class:`Run`.

Two timings (docs/architecture.md section 6):

* ``mode="sampled"`` -- a digital drive: tau_k is evaluated at t_k = k dt and held (zero-order
  hold) over [t_k, t_k + dt) while the plant integrates with ``substeps`` RK4 steps; the
  controller's internal state (rho_hat) advances once per period, z_{k+1} = z_k + dt z_dot_k;
* ``mode="continuous"`` -- the analysis of the paper: the controller is evaluated inside the
  integrator (the compiled core's Radau IIA with error control, :mod:`delta_pin.sim.loop`;
  its fixed-step BDF2 on request), on a plant with a compiled copy.

Every run goes through the compiled core: :func:`simulate` checks its arguments, hands the run to
the core's one run (:func:`~delta_pin.sim.loop.run_loop`, by the integrator the mode names), and
wraps the result in a :class:`Run`. The readable Python loop the core is tested against lives in
``tests/reference/``.
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
from delta_pin.sim.closed_chain_plant import ClosedChainPlant, make_plant
from delta_pin.sim.drive import Drive, Encoder, check_delay
from delta_pin.sim.loop import INTEGRATIONS, Integration, run_loop
from delta_pin.sim.plants import Plant
from delta_pin.sim.reference import tabulate_reference
from delta_pin.sim.run import Run, run_metadata
from delta_pin.sim.serial import JointSinusoid
from delta_pin.sim.uncertainty import Uncertainty

__all__ = ["INTEGRATOR_CHOICES", "simulate"]


def _choose_integrator(integrator: str, mode: str) -> str:
    """The integrator ``"auto"`` stands for in ``mode`` (RK4 sampled, Radau IIA continuous), or
    ``integrator`` where it fits the mode."""
    if integrator == "auto":
        return "rk4" if mode == "sampled" else "radau"
    declared = INTEGRATIONS.get(integrator)
    if declared is None or declared.sampled != (mode == "sampled"):
        raise InvalidParameterError(
            f"integrator={integrator!r} does not run mode={mode!r}: 'rk4' runs sampled mode, 'radau' or "
            "'bdf2' continuous mode ('auto' picks)"
        )
    return integrator


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
    sensor: Encoder | None = None,
    delay: int = 0,
    torque_limit: float | ArrayLike | None = None,
) -> Run:
    """Simulate ``controller`` driving ``robot`` along ``trajectory``.

    Args:
        robot: the robot (:func:`delta_pin.load_delta`), or any closed-chain robot
            (:func:`delta_pin.load_robot`; its
            :class:`~delta_pin.sim.closed_chain_plant.ClosedChainPlant`, ``friction`` and a
            ``payload_mass`` given to that plant).
        controller: a :class:`~delta_pin.control.Controller` or any ``f(t, alpha, alpha_dot) -> tau``;
            ``None``: no torque (a free motion; a mechanism without motors).
        trajectory: a task-space :class:`~delta_pin.model.trajectory.Trajectory`, a named frame's
            :class:`~delta_pin.model.frame_path.FramePath`, a joint-space path
            (:class:`~delta_pin.sim.serial.JointSinusoid`), or ``None`` to
            hold ``alpha0`` (default: a closed chain's ``home``).
        plant: ``"pinocchio"`` (constrained multibody, the default), ``"analytic"`` (reduced ODE) or
            a :class:`~delta_pin.sim.plants.Plant` (its compiled copy steps; a plant written in
            Python has its ``derivative`` called back by the core's sampled loop).
        t_end: duration [s] (> 0).
        dt: sample (and control) period [s] (> 0).
        mode: ``"sampled"`` (zero-order hold) or ``"continuous"`` (see the module docstring).
        alpha0: initial joint angles [rad or m]; default the trajectory's start.
        alpha_dot0: initial joint velocities [rad/s or m/s]; default zero.
        friction: :class:`~delta_pin.model.friction.Friction`, ``True`` for its defaults, or ``None``.
        uncertainty: an :class:`~delta_pin.sim.uncertainty.Uncertainty` profile or ``None``.
        substeps: RK4 steps per period (>= 1) for the ``"rk4"`` integrator.
        integrator: ``"rk4"`` (sampled mode: fixed steps dt / substeps), ``"radau"`` (continuous
            mode: the compiled core's Radau IIA of order 5 with error control,
            :mod:`delta_pin.sim.loop`: any plant with a compiled copy and any
            continuous-time controller, its compiled law or its Python one) or ``"bdf2"``
            (continuous mode: the compiled implicit BDF2 with fixed steps dt / substeps, off by
            more than Radau in a reaching phase; what the sweeps of ``reproduce --full`` batch).
            ``"auto"``: RK4 sampled, Radau continuous.
        rtol: Radau's relative tolerance.
        atol: Radau's absolute tolerance (SI units of the state).
        progress: show the simulated time on stderr (``None``: only on a terminal).
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
    integrator = _choose_integrator(integrator, mode)
    drive_effects = sensor is not None or check_delay(delay) > 0 or torque_limit is not None
    if sensor is not None and not isinstance(sensor, Encoder):
        raise InvalidParameterError(f"sensor={sensor!r} must be a delta_pin Encoder or None")
    _check_digital(as_controller(controller), mode, dt, drive_effects, delay)
    plant = make_plant(plant, robot, friction, uncertainty)
    controller = as_controller(controller)  # one wrapper: the core's law calls the run's controller
    integration = Integration(integrator, substeps, rtol, atol)
    dof = plant.dof
    # the reference on the integrator's grid (sim/loop.py's declaration of the integrator)
    per_sample = integration.declared.reference_per_sample(substeps)
    table, sample_xyz, alpha0 = tabulate_reference(robot, trajectory, alpha0, dof, steps, dt, per_sample)
    alpha0 = joint_vector(alpha0, "alpha0", dof)
    alpha_dot0 = np.zeros(dof) if alpha_dot0 is None else joint_vector(alpha_dot0, "alpha_dot0", dof)
    t = np.arange(steps + 1) * dt
    drive = Drive(dof, delay, torque_limit) if drive_effects else None
    if sensor is not None:
        sensor.reset()

    wall = time.perf_counter()
    try:
        record, counters = run_loop(
            controller, plant, table, alpha0, alpha_dot0, t, integration, progress=progress, sensor=sensor,
            drive=drive,
        )  # fmt: skip
    except SimulationError as exc:
        raise _with_singularity(exc, robot) from None
    wall = time.perf_counter() - wall

    metadata = run_metadata(
        described, controller, trajectory, plant, mode=mode, dt=dt, t_end=steps * dt, substeps=substeps,
        **integration.metadata(),
        alpha0=alpha0.tolist(), alpha_dot0=alpha_dot0.tolist(), wall_time=wall,
    )  # fmt: skip
    if getattr(plant, "projections", 0):
        metadata["closure_projections"] = plant.projections
    if getattr(plant, "stepped_in_core", False):
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

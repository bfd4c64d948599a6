"""One controller on any closed-chain robot (``delta-pin run --robot PATH [--frame NAME]``).

The controller's nominal model is the robot's projected dynamics
(:class:`~delta_pin.control.nominal.ClosedChainNominalModel`, no friction, no payload); the plant
is its constrained Pinocchio tree (:class:`~delta_pin.sim.closed_chain_plant.ClosedChainPlant`).
The reference is either a circle drawn by a frame (task space, :class:`~delta_pin.model.frame_path.FramePath`)
or a sinusoid of every actuated joint about home (joint space). Both start at the robot's home
configuration, so the run starts on its reference; the circle turns towards the base from there
(docs/architecture.md section 10).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from delta_pin.control.nominal import ClosedChainNominalModel
from delta_pin.control.registry import LawOptions, declaration
from delta_pin.errors import InvalidParameterError
from delta_pin.model.closed_chain import ClosedChainRobot
from delta_pin.model.frame_path import Circle, FramePath
from delta_pin.sim.run import Run
from delta_pin.sim.runner import simulate
from delta_pin.sim.serial import JointSinusoid

__all__ = [
    "JOINT_AMPLITUDE",
    "circle_plane",
    "closed_chain_controller",
    "closed_chain_reference",
    "run_closed_chain",
]

JOINT_AMPLITUDE = 0.05  # [rad or m] the joint-space sinusoid's amplitude about home


def circle_plane(robot: ClosedChainRobot, frame: str | None = None) -> str:
    """The coordinate plane a frame moves in most freely at home: for a 2-actuator robot, the two
    world axes along which the closed-loop Jacobian's rows are largest; ``"xy"`` otherwise."""
    if robot.dof != 2:
        return "xy"
    J = robot.frame_jacobian(robot.reference_configuration, frame)[:3]
    first, second = sorted(np.argsort(-np.linalg.norm(J, axis=1))[:2])
    return "xyz"[first] + "xyz"[second]


def circle_from_home(home: np.ndarray, radius: float, period: float, plane: str) -> Circle:
    """A circle through ``home`` [m] whose center lies ``radius`` from it towards the world
    origin (the robot's base) within ``plane``: a frame near the edge of its reach (an arm at
    full stretch) then moves inwards, away from that singularity."""
    i, j = ("xyz".index(plane[0]), "xyz".index(plane[1]))
    inward = -np.array([home[i], home[j]])
    if np.linalg.norm(inward) < 1e-9:
        inward = np.array([-1.0, 0.0])
    inward /= np.linalg.norm(inward)
    center = np.array(home, dtype=float)
    center[i] += radius * inward[0]
    center[j] += radius * inward[1]
    phase = math.atan2(-inward[1], -inward[0])  # home = center - radius * inward
    return Circle(center, radius, period, plane, phase)


def closed_chain_reference(
    robot: ClosedChainRobot, frame: str | None, radius: float, period: float
) -> tuple[object, dict]:
    """(the reference, its description): a circle of ``frame`` through its home position, or a
    joint-space sinusoid about home when ``frame`` is ``None``."""
    if not (math.isfinite(period) and period > 0.0):
        raise InvalidParameterError(f"--period {period!r} must be > 0 [s]")
    if frame is None:
        reference = JointSinusoid(center=robot.home, amplitude=JOINT_AMPLITUDE, frequency=1.0 / period)
        return reference, {"reference": "joint sinusoid", "amplitude": JOINT_AMPLITUDE, "period": period}
    if robot.dof > 3:
        raise InvalidParameterError(
            f"--frame moves a frame's position (3 coordinates) and {robot.name!r} has {robot.dof} actuators: "
            "omit --frame for a joint-space reference"
        )
    robot.frame_id(frame)  # names the frames that exist
    plane = circle_plane(robot, frame)
    home = robot.frame_placement(robot.reference_configuration, frame).translation
    path = FramePath(circle_from_home(home, radius, period, plane), frame=frame)
    return path, {"reference": "circle", "frame": frame, "plane": plane, "radius": radius, "period": period}


def closed_chain_controller(name: str, robot: ClosedChainRobot, dt: float, sampling_aware: bool = False):
    """A controller by its CLI name on the robot's projected nominal model (the designs' and
    baselines' default gains)."""
    law = declaration(name)  # refuses an unknown name first, before the nominal model is built
    law.check_options(sampling_aware=sampling_aware)  # one law: a switch it has not is refused
    options = LawOptions(dt=dt, sampling_aware=sampling_aware, start=robot.home)  # LQR: at home
    return law.make(ClosedChainNominalModel(robot), options)


def run_closed_chain(
    robot: ClosedChainRobot,
    *,
    controller: str = "design1",
    frame: str | None = None,
    mode: str = "continuous",
    dt: float = 1e-3,
    t_end: float | None = None,
    radius: float = 0.02,
    period: float = 2.0,
    sampling_aware: bool = False,
    announce: Callable[[str], None] | None = None,
) -> tuple[Run, dict]:
    """Simulate ``controller`` on ``robot`` (module docstring); ``t_end`` defaults to 6 s (the
    "last 5 s" indices then follow a 1 s transient), at least two periods.

    Returns:
        (the run, a description of what ran, for summary.json).
    """
    reference, description = closed_chain_reference(robot, frame, radius, period)
    t_end = max(6.0, 2.0 * period) if t_end is None else t_end
    law = closed_chain_controller(controller, robot, dt, sampling_aware)
    if announce is not None:
        what = f"a circle of {frame}" if frame else "a joint-space sinusoid"
        announce(
            f"delta-pin run: {controller} on {robot.name!r} ({robot.dof} actuators, {len(robot.closures)} "
            f"closure(s)), {what}, Pinocchio plant, {mode} mode, {t_end:g} s ..."
        )
    run = simulate(robot, law, reference, t_end=t_end, dt=dt, mode=mode, alpha0=robot.home, progress=None)
    description.update(controller=controller, mode=mode, dt=dt, t_end=t_end)
    return run, description

"""Time-optimal parametrisation of a frame's path for any fully actuated closed chain, verified on
the exact model.

Along a geometric path x(s) of a frame (:mod:`delta_pin.planning.paths`) the actuated joints
follow alpha(s), alpha'(s), alpha''(s) (the core's closed-loop inverse kinematics,
:class:`~delta_pin.model.frame_path.FramePath`), and a time law s(t) gives

    alpha_dot = alpha' s_dot,   alpha_ddot = alpha' s_ddot + alpha'' s_dot^2,

so the actuated torque of the projected dynamics the controllers use (M, C, G of
``robot.reduced_terms``, eq. 13's form for any closed chain) is affine in (s_ddot, s_dot^2):

    tau = a(s) s_ddot + b(s) s_dot^2 + c(s),   a = M alpha',  b = M alpha'' + C(alpha, alpha') alpha',
    c = G + F̄ + M̄_f(alpha' s_dot) (+ the joint dampers' D alpha' s_dot),

with the nominal model's friction (eq. 12) and dampers, which depend on s_dot itself, taken at the
previous solution's s_dot (three fixed-point passes). The time-optimal s(t) under |tau_j| <=
limit_j and |alpha_dot_j| <= v_j is TOPP-RA's reachability analysis (Pham & Pham, IEEE T-RO
2018), solved by the ``toppra`` library (its Seidel LP solver; its constraints given our a, b, c
directly), with the *interpolation* discretisation: each interval's constant s_ddot is bounded at
both of its ends, not only at the first.

The law is bang-bang: s_ddot switches between its largest and smallest feasible values, and a
grid's constant s_ddot per interval loses most of its time in the intervals around a switch. So,
before the check, the intervals on both sides of each switch (s_ddot jumping by more than
``SWITCH_JUMP`` = 5 % of its range from one interval to the next) are halved and the law solved
again, ``switch_refinements`` (2) times: the grid grows where the law needs it
(docs/measured/bench_planning.md gives the grids and times with and without).

A grid bounds the torque at its points only. So every plan is **verified afterwards on the exact
model**: the law s(t) (constant s_ddot on each interval, s_dot^2 linear in s) is sampled at
``check_rate`` (10 kHz), alpha, alpha', alpha'' recomputed by inverse kinematics at each sample's
s (not interpolated), and the torque evaluated by the same projected dynamics and friction.
Where it exceeds a limit between grid points, the limit of that interval's two grid points is
tightened by the overshoot and the law solved again (``repairs``), until the check holds:
max_t |tau_j(t)| / limit_j <= 1 (:class:`Verification`). A plan that still exceeds after
``max_repairs`` is returned with its verification saying so (``feasible`` False).

**Jerk limits.** The time-optimal law is bang-bang: s_ddot jumps at every switch, so its joint
jerk alpha_dddot = alpha_sss s_dot^3 + 3 alpha'' s_dot s_ddot + alpha' s_dddot has no bound
(alpha_sss the path's third derivative). Given |alpha_dddot_j| <= j_j, the verified law s_g(t) is
replaced by its moving average over a window w, s(t) = (1/w) int_{t-w}^t s_g (the
finite-impulse-response smoothing of Biagiotti & Melchiorri, "Trajectory Planning for Automatic
Machines and Robots", 2008): s_dot and s_ddot are the window's differences of s_g and s_dot_g, so
s_ddot is continuous and s_dddot = (s_ddot_g(t) - s_ddot_g(t - w)) / w is bounded; the path is
unchanged and the time grows by w. The window starts at the law's largest joint-acceleration jump
over the jerk limit. Then, round by round, each check at ``check_rate`` on the exact model (the
jerk as the difference quotient of the exact alpha_ddot between samples) splits the jerk into
the s_dddot share, which a wider window lowers (the window widens by its overshoot), and the
path's own share (the blends' curvature at speed), which only a slower passage lowers: the grid
points that the window averages at such a sample get a path-speed cap, s_dot <= their law's
s_dot over the cube root of the overshoot, and TOPP-RA solves the law again with it. Averaging is
not feasibility-preserving either (near a switch the averaged s_ddot meets another point's bound):
where the torque exceeds, those points' torque limits are tightened by the overshoot, as the
repairs do. Where ``JERK_PASSES`` such rounds keep trading one overshoot for another (each solve
moves the law's switches), the whole law is run slower (s_dot / k, s_ddot / k^2, the window k w:
every jerk term falls as 1 / k^3, the dynamic torque as 1 / k^2) until the check holds, or
``JERK_PASSES`` rounds more (``feasible`` False). The law is then not time-optimal under the
jerk limits (its time is an upper bound): docs/planning.md measures what the limits cost.
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from delta_pin.control.nominal import ClosedChainNominalModel
from delta_pin.errors import (
    AssemblyError,
    InvalidParameterError,
    OptionalDependencyError,
    PlanningError,
    UnreachablePoseError,
)
from delta_pin.model.frame_path import FramePath
from delta_pin.model.trajectory import JointReference

__all__ = [
    "PlannedSequence", "TimeOptimalPlan", "Verification", "path_joints", "plan_time_optimal", "task_axes",
    "torque_model",
]  # fmt: skip

FRICTION_PASSES = 3  # fixed-point passes of the friction and dampers at the previous s_dot
CHECK_RATE = 1e4  # [Hz] of the verification on the exact model
MAX_REPAIRS = 30
REPAIR_MARGIN = 1e-4  # a tightened limit lands this far inside the overshoot's ratio
REFINEMENTS = 3  # repairs that insert grid points where the torque overshoots, before tightening
SWITCH_REFINEMENTS = 2  # rounds that add grid points around the law's switches, before the check
SWITCH_JUMP = 0.05  # a switch: s_ddot jumps by more than this fraction of its range between intervals
JERK_PASSES = 12  # rounds of local changes for jerk limits, then as many of slowing the whole law
JERK_MARGIN = 1e-3  # each widening or slowing lands this far beyond the overshoot's ratio
# sigma_min / sigma_max below which a path is refused: ~1 mm from the Delta's stretched-leg locus
# (the measure falls as the square root of the distance to it)
SINGULARITY_MARGIN = 5e-3


@dataclass(frozen=True)
class Verification:
    """The plan's torque on the exact model at ``rate`` [Hz] over ``samples`` samples: the largest
    |tau_j| / limit_j (``torque_ratio``, <= 1 when the plan holds), each joint's peak |tau_j| [N m]
    and margin 1 - peak / limit, the time [s] of the largest ratio, the largest |alpha_dot_j| /
    v_j (``velocity_ratio``, None without velocity limits) and the largest |alpha_dddot_j| / j_j
    (``jerk_ratio``, None without jerk limits; the jerk is the difference quotient of the exact
    alpha_ddot between samples: its mean over each 1 / rate)."""

    rate: float
    samples: int
    torque_ratio: float
    peak_torque: np.ndarray
    margin: np.ndarray
    time_of_peak: float
    velocity_ratio: float | None = None
    jerk_ratio: float | None = None  # the largest |alpha_dddot_j| / jerk limit_j (None without them)

    @property
    def feasible(self) -> bool:
        return (
            self.torque_ratio <= 1.0
            and (self.velocity_ratio is None or self.velocity_ratio <= 1.0)
            and (self.jerk_ratio is None or self.jerk_ratio <= 1.0)
        )


@dataclass
class TimeOptimalPlan:
    """A time law s(t) along ``path`` for ``robot``'s ``frame``: the grid ``s`` (N + 1,) [m], the
    path speed ``s_dot`` there [m/s], the constant ``s_ddot`` of each interval (N,) [m/s^2], the
    grid's ``times`` [s] and the ``duration`` [s]; the limits it was planned for, its
    :class:`Verification` and the planning's counts and wall times. A trajectory ``simulate``
    takes (:meth:`joint_reference`; it holds the path's end after ``duration``)."""

    path: Any
    frame: str | None
    axes: str | None
    s: np.ndarray
    s_dot: np.ndarray
    s_ddot: np.ndarray
    times: np.ndarray
    torque_limit: np.ndarray
    velocity_limit: np.ndarray | None
    verification: Verification | None = None
    checked: tuple[np.ndarray, np.ndarray] | None = None  # (times [s], tau (N, dof) [N m]) of the last check
    singularity: np.ndarray | None = None  # the smallest (Type I, Type II) measures at the grid points
    repairs: int = 0
    # the grid points added around the law's switches (plan_time_optimal's switch_refinements)
    switch_points: int = 0
    planning_time: float = 0.0  # [s] of wall time: inverse kinematics, coefficients, TOPP-RA
    verification_time: float = 0.0  # [s] of wall time, repairs included
    name: str = field(default="time-optimal plan")
    # jerk limits [rad/s^3 or m/s^3] and the moving average that meets them (module docstring)
    jerk_limit: np.ndarray | None = None
    smoothing: float = 0.0  # [s]: s(t) is the mean of the grid's law over the last `smoothing` s

    @property
    def duration(self) -> float:
        return float(self.times[-1]) + self.smoothing

    def path_state(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s [m], s_dot [m/s], s_ddot [m/s^2]) at times t (N,) [s]: the grid's law (constant
        s_ddot on each interval), or with ``smoothing`` w its moving average over [t - w, t]
        (s_ddot then continuous, s_dddot bounded); the start before 0, the end (at rest) after
        the duration."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        w = self.smoothing
        if w <= 0.0:
            return self._grid_state(t)
        now, before = self._grid_state(t), self._grid_state(t - w)
        integral = self._grid_integral(np.concatenate([t, t - w]))  # one pass over the grid for both
        s = (integral[: len(t)] - integral[len(t) :]) / w
        s_dot, s_ddot = ((a - b) / w for a, b in zip(now[:2], before[:2]))  # of s, of s_dot
        return np.minimum(s, self.s[-1]), np.maximum(s_dot, 0.0), s_ddot

    def _grid_integral(self, t: np.ndarray) -> np.ndarray:
        """The integral of the grid's law s from 0 to t [m s], s held at its ends outside [0, T]."""
        end = float(self.times[-1])
        h = np.diff(self.times)
        pieces = self.s[:-1] * h + 0.5 * self.s_dot[:-1] * h * h + self.s_ddot * h**3 / 6.0
        cumulative = np.concatenate([[0.0], np.cumsum(pieces)])
        inside = np.clip(t, 0.0, end)
        k = np.clip(np.searchsorted(self.times, inside, side="right") - 1, 0, len(self.s_ddot) - 1)
        tau = inside - self.times[k]
        value = cumulative[k] + self.s[k] * tau + 0.5 * self.s_dot[k] * tau**2 + self.s_ddot[k] * tau**3 / 6.0
        return value + np.where(t < 0.0, self.s[0] * t, 0.0) + np.where(t > end, self.s[-1] * (t - end), 0.0)

    def _grid_state(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s, s_dot, s_ddot) of the grid's law at t: constant s_ddot per interval, at rest outside."""
        t = np.clip(t, 0.0, float(self.times[-1]))
        k = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.s_ddot) - 1)
        tau = t - self.times[k]
        u = self.s_ddot[k]
        s = np.minimum(self.s[k] + self.s_dot[k] * tau + 0.5 * u * tau * tau, self.s[-1])
        s_dot = np.maximum(self.s_dot[k] + u * tau, 0.0)
        end = t >= float(self.times[-1])
        s_dot[end], u = 0.0, np.where(end, 0.0, u)
        s[end] = self.s[-1]
        return s, s_dot, u

    def joint_reference(self, robot, t) -> JointReference:
        """alpha, alpha_dot, alpha_ddot at times t [s] from the path at s(t) (a task path: inverse
        kinematics there, exact, not interpolated), and the frame's xyz with its rates."""
        times = np.atleast_1d(np.asarray(t, dtype=float))
        s, s_dot, s_ddot = self.path_state(times)
        on_path = path_joints(robot, self.path, s, self.frame, self.axes)
        sd, sdd = s_dot[:, None], s_ddot[:, None]

        def rates(value, d1, d2):
            return value, d1 * sd, d1 * sdd + d2 * sd * sd

        return JointReference(
            times, *rates(on_path.xyz, on_path.xyz_dot, on_path.xyz_ddot),
            *rates(on_path.alpha, on_path.alpha_dot, on_path.alpha_ddot),
        )  # fmt: skip

    def metadata(self) -> dict[str, Any]:
        check = self.verification
        return {
            "type": "TimeOptimalPlan",
            "name": self.name,
            "path": self.path.metadata(),
            "duration": self.duration,
            "grid_points": len(self.s),
            "torque_limit": self.torque_limit.tolist(),
            "velocity_limit": None if self.velocity_limit is None else self.velocity_limit.tolist(),
            "repairs": self.repairs,
            "switch_points": self.switch_points,
            "jerk_limit": None if self.jerk_limit is None else self.jerk_limit.tolist(),
            "smoothing": self.smoothing,
            "torque_ratio": None if check is None else check.torque_ratio,
            "jerk_ratio": None if check is None else check.jerk_ratio,
            "check_rate_hz": None if check is None else check.rate,
        }


class PlannedSequence:
    """Plans run one after the other (a whole Adept cycle: there, then back), as one trajectory
    ``simulate`` takes; ``duration`` the sum of theirs [s]."""

    def __init__(self, plans: list[TimeOptimalPlan], name: str = "planned sequence") -> None:
        if not plans:
            raise InvalidParameterError("a planned sequence needs at least one plan")
        self.plans, self.name = list(plans), name
        self.starts = np.concatenate([[0.0], np.cumsum([p.duration for p in plans])])
        self.duration = float(self.starts[-1])

    def joint_reference(self, robot, t) -> JointReference:
        times = np.atleast_1d(np.asarray(t, dtype=float))
        k = np.clip(np.searchsorted(self.starts, times, side="right") - 1, 0, len(self.plans) - 1)
        parts = [self.plans[i].joint_reference(robot, times[k == i] - self.starts[i]) for i in np.unique(k)]
        fields = ("xyz", "xyz_dot", "xyz_ddot", "alpha", "alpha_dot", "alpha_ddot")
        return JointReference(times, *(np.concatenate([getattr(p, f) for p in parts]) for f in fields))

    def metadata(self) -> dict[str, Any]:
        return {
            "type": "PlannedSequence", "name": self.name, "duration": self.duration,
            "plans": [p.metadata() for p in self.plans],
        }  # fmt: skip


def branch_configuration(robot, alpha: np.ndarray, steps: int = 20) -> np.ndarray:
    """The closed configuration at ``alpha`` on the assembly branch of the robot's reference
    configuration: continued from it along the straight line of the actuated joints (``steps``
    assemblies, each from the one before), so that a plan's dynamics and singularity measures are
    those of one branch whatever configuration the robot assembled last."""
    start = robot.reference_configuration.copy()
    alpha0 = start[robot.actuated_q_indices]
    q = start
    for t in np.linspace(0.0, 1.0, steps + 1)[1:]:
        q = robot.configuration(alpha0 + t * (np.asarray(alpha, dtype=float) - alpha0), initial_guess=q)
    return q


def task_axes(robot, frame: str | None = None) -> str:
    """The frame's task coordinates when none are given: as many of x, y, z as the robot has
    motors, those the frame moves along most at the reference configuration (the rows of its
    closed-loop Jacobian of largest norm; a five-bar in the xz plane: ``"xz"``)."""
    if robot.dof >= 3:
        return "xyz"
    fid = robot.end_effector if frame is None else robot.frame_id(frame)
    J = robot.frame_jacobian(robot.reference_configuration, fid)[:3]
    rows = sorted(np.argsort(-np.linalg.norm(J, axis=1), kind="stable")[: robot.dof])
    return "".join("xyz"[r] for r in rows)


def path_joints(robot, path, s, frame: str | None = None, axes: str | None = None) -> JointReference:
    """The path at s (N,) in joint space, its "time" being s: alpha(s), alpha'(s), alpha''(s) and
    the frame's xyz(s), xyz'(s), xyz''(s). A task path by the core's closed-loop inverse
    kinematics (:class:`~delta_pin.model.frame_path.FramePath`, from the robot's reference
    configuration, so the same path gives the same joints whatever the robot did before); a joint
    path (``space == "joints"``) as it is, the frame's position by forward kinematics and its
    rates by the frame's closed-loop Jacobian and drift.

    Raises:
        UnreachablePoseError: a task path leaves the workspace (naming the point; an inverse
            kinematics whose iterates leave the loops' reach too).
        AssemblyError: a joint path's loops cannot be closed (naming the joints)."""
    s = np.atleast_1d(np.asarray(s, dtype=float))
    if getattr(path, "space", "task") == "task":
        axes = task_axes(robot, frame) if axes is None else axes
        try:
            # from the robot's reference configuration: one assembly mode, whatever it assembled last
            start = robot.reference_configuration
            return FramePath(path, frame, axes).joint_reference(robot, s, start=start)
        except (UnreachablePoseError, AssemblyError) as exc:  # FramePath names the "time": here it is s
            text = re.sub(r"^t=(\S+) s: ", r"at s=\1 m of the path: ", str(exc))
            raise UnreachablePoseError(text) from None
    alpha, d1, d2 = (np.atleast_2d(f(s)) for f in (path.position, path.velocity, path.acceleration))
    if alpha.shape[1] != robot.dof:
        raise InvalidParameterError(
            f"the joint path has {alpha.shape[1]} coordinates, the robot {robot.dof} actuated joints"
        )
    fid = robot.end_effector if frame is None else robot.frame_id(frame)
    xyz, x1, x2 = (np.zeros((len(s), 3)) for _ in range(3))
    q = None
    for i in range(len(s)):
        q = robot.configuration(alpha[i], initial_guess=q)
        J = robot.frame_jacobian(q, fid)[:3]  # d xyz / d alpha along the closed loops
        xyz[i] = robot.frame_placement(q, fid).translation
        x1[i] = J @ d1[i]
        x2[i] = J @ d2[i] + robot.frame_acceleration_drift(q, d1[i], fid)
    return JointReference(s, xyz, x1, x2, alpha, d1, d2)


def _limits(values, dof: int, name: str, unit: str) -> np.ndarray:
    given = np.asarray(values, dtype=float)
    limits = np.full(dof, float(given)) if given.ndim == 0 else given.reshape(-1)
    if limits.shape != (dof,) or not np.all(np.isfinite(limits)) or np.any(limits <= 0.0):
        raise InvalidParameterError(
            f"{name}={np.asarray(values).tolist()!r} must be one positive value or {dof} (one per actuated "
            f"joint) [{unit}]"
        )
    return limits


class _Dynamics:
    """The projected inverse dynamics along the path (the core's ``path_coefficients`` and
    ``actuated_torques`` over rows of states, each assembled from the one before): the coefficients
    a, b, c at path points and the torque of states, with the nominal friction and the joint
    dampers."""

    def __init__(self, robot, nominal: ClosedChainNominalModel, start: np.ndarray | None = None) -> None:
        self.robot, self.nominal = robot, nominal
        self.friction = nominal.friction_model is not None
        # every batch of states is assembled from here, the next state from the one before
        self.start = robot.reference_configuration.copy() if start is None else start

    def _assembled(self, failed: int, alpha) -> None:
        """AssemblyError naming the first state whose loops the core could not close (failed >= 0)."""
        if failed >= 0:
            raise AssemblyError(
                f"{self.robot.name}: the loops do not close at alpha={np.asarray(alpha)[failed].tolist()} "
                "on the path"
            )

    def coefficients(self, alpha, d1, d2) -> tuple[np.ndarray, ...]:
        """(a, b, c0, damping) (N, dof) each at the points: c0 the gravity, springs and F̄, and
        ``damping`` the dampers' torque per unit s_dot (D alpha') (the core's ``path_coefficients``:
        RNEA passes per point, no matrices, where the robot has no idle motions)."""
        failed, _, a, b, c0, damping = self.robot.compiled_model.path_coefficients(
            *(np.ascontiguousarray(values) for values in (alpha, d1, d2)), self.start
        )
        self._assembled(failed, alpha)
        return a, b, c0 + self.nominal.disturbance(), damping

    def velocity_terms(self, d1, damping, s_dot) -> np.ndarray:
        """The friction and dampers' torque at alpha_dot = alpha' s_dot (N, dof) [N m]."""
        torque = damping * s_dot[:, None]
        if self.friction:
            torque = torque + self.nominal.friction(d1 * s_dot[:, None])
        return torque

    def torque(self, alpha, alpha_dot, alpha_ddot) -> np.ndarray:
        """tau = M alpha_ddot + C alpha_dot + G + F̄ [+ M̄_f(alpha_dot)] at each state (N, dof) [N m]
        (the core's ``actuated_torques``: one RNEA pass per state, no matrices)."""
        failed, _, tau = self.robot.compiled_model.actuated_torques(
            np.ascontiguousarray(alpha),
            np.ascontiguousarray(alpha_dot),
            np.ascontiguousarray(alpha_ddot),
            self.start,
        )
        self._assembled(failed, alpha)
        tau = tau + self.nominal.disturbance()
        return tau + self.nominal.friction(alpha_dot) if self.friction else tau


def _solve(s, a, b, c, torque_limits, d1, velocity_limit, speed_cap=None) -> tuple[np.ndarray, np.ndarray]:
    """TOPP-RA on the grid s with tau = a u + b x + c, |tau| <= torque_limits (N + 1, dof),
    |alpha' s_dot| <= velocity_limit (N + 1, dof) or None and s_dot <= speed_cap (N + 1,) or None:
    (s_dot (N + 1,), s_ddot (N,));
    PlanningError where no law exists (a point where the torque at rest already exceeds, or a path
    TOPP-RA cannot control)."""
    try:
        import toppra
        import toppra.algorithm
        import toppra.constraint as constraint
        import toppra.interpolator
    except ImportError:
        raise OptionalDependencyError(
            "time-optimal planning needs toppra: pip install 'delta-pin[planning]'"
        ) from None

    dof = a.shape[1]
    at_rest = np.abs(c) > torque_limits
    if at_rest.any():
        i, j = np.argwhere(at_rest)[0]
        raise PlanningError(
            f"at s={s[i]:.4g} m actuated joint {j + 1} needs {c[i, j]:.4g} N m at rest (gravity, springs, "
            "friction), beyond "
            f"its limit {torque_limits[i, j]:.4g} N m: no speed makes the path feasible"
        )
    F = np.vstack([np.eye(dof), -np.eye(dof)])

    class Torque(constraint.LinearConstraint):
        def __init__(self) -> None:
            super().__init__()
            self.dof = dof
            self.set_discretization_type(constraint.DiscretizationType.Interpolation)

        def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
            g = np.hstack([torque_limits, torque_limits])
            Fs = np.broadcast_to(F, (len(gridpoints), 2 * dof, dof)).copy()
            return constraint.canlinear_colloc_to_interpolate(a, b, c, Fs, g, None, None, gridpoints)

    class Speed(constraint.LinearConstraint):
        def __init__(self) -> None:
            super().__init__()
            self.dof = dof

        def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
            bound = np.full(len(gridpoints), np.inf)
            if velocity_limit is not None:
                with np.errstate(divide="ignore"):  # per point
                    bound = np.min((velocity_limit / np.maximum(np.abs(d1), 1e-300)) ** 2, axis=1)
            if speed_cap is not None:
                bound = np.minimum(bound, speed_cap**2)
            xbound = np.column_stack([np.zeros(len(gridpoints)), bound])
            return None, None, None, None, None, None, xbound

    class GridPath(toppra.interpolator.AbstractGeometricPath):  # the grid only: the coefficients are ours
        @property
        def path_interval(self):
            return np.array([s[0], s[-1]])

        @property
        def dof(self):
            return dof

        def __call__(self, path_positions, order=0):
            raise NotImplementedError("the planner gives toppra its coefficients on the grid")

    constraints = [Torque()] + ([Speed()] if velocity_limit is not None or speed_cap is not None else [])
    solver = toppra.algorithm.TOPPRA(constraints, GridPath(), gridpoints=s, solver_wrapper="seidel")
    _, s_dot, _ = solver.compute_parameterization(0.0, 0.0)
    if s_dot is None or not np.all(np.isfinite(s_dot)):
        raise PlanningError(
            "TOPP-RA found no time law within the limits (the path is not controllable from rest to rest "
            "on this grid): raise the limits, or move the path away from a singularity"
        )
    x = s_dot * s_dot
    return s_dot, (x[1:] - x[:-1]) / (2.0 * np.diff(s))  # s_ddot from x: exactly consistent with s_dot


def plan_time_optimal(
    robot,
    path,
    torque_limit,
    *,
    velocity_limit=None,
    points: int = 100,
    frame: str | None = None,
    axes: str | None = None,
    friction=None,
    payload_mass: float = 0.0,
    check_rate: float = CHECK_RATE,
    max_repairs: int = MAX_REPAIRS,
    verify: bool = True,
    singularity_margin: float = SINGULARITY_MARGIN,
    switch_refinements: int = SWITCH_REFINEMENTS,
    jerk_limit=None,
) -> TimeOptimalPlan:
    """The time-optimal law along ``path`` (a geometric path of ``frame``, default the end
    effector; :mod:`delta_pin.planning.paths`) from rest to rest, under |tau_j| <= ``torque_limit``
    [N m] and |alpha_dot_j| <= ``velocity_limit`` [rad/s] (one value or one per actuated joint),
    on ``points`` grid points (``axes``: the frame's task coordinates, default :func:`task_axes`),
    the projected dynamics of ``robot`` with its nominal ``friction``
    (a :class:`~delta_pin.model.friction.Friction`, ``True`` for a recognised Delta's, or None) and a
    ``payload_mass`` [kg] at the end effector; verified on the exact model at ``check_rate`` [Hz]
    and repaired where it exceeds (module docstring). With ``verify``, the distance to a
    singularity is measured at the grid points too (:mod:`delta_pin.planning.singularity`,
    ``plan.singularity``: the smallest Type I and Type II measures) and a path that comes within
    ``singularity_margin`` of one is refused (0: never). ``switch_refinements`` rounds halve the
    intervals around the law's switches first (module docstring; 0: the grid of ``points`` as it is).
    ``jerk_limit`` [rad/s^3 or m/s^3] (one value or one per actuated joint) bounds |alpha_dddot_j|
    too: the verified law is then averaged over a moving window, widened (or the law slowed) until
    the check holds (module docstring, "Jerk limits"); it needs ``verify``.

    Raises:
        InvalidParameterError: a bad limit, grid, rate or margin; a robot that is not fully actuated.
        UnreachablePoseError: the path leaves the workspace (naming the point).
        PlanningError: no law exists within the limits, or the path comes within
            ``singularity_margin`` of a singularity (naming its kind and where).
    """
    dof = robot.dof
    torque = _limits(torque_limit, dof, "torque_limit", "N m")
    velocity = None if velocity_limit is None else _limits(velocity_limit, dof, "velocity_limit", "rad/s")
    jerk = None if jerk_limit is None else _limits(jerk_limit, dof, "jerk_limit", "rad/s^3")
    if jerk is not None and not verify:
        raise InvalidParameterError(
            "jerk_limit is met by checking the law on the exact model: keep verify=True"
        )
    if not (isinstance(points, int | np.integer) and 3 <= points <= 100_000):
        raise InvalidParameterError(f"points={points!r} must be an integer from 3 to 100000")
    if not (math.isfinite(check_rate) and check_rate > 0.0):
        raise InvalidParameterError(f"check_rate={check_rate!r} must be a positive rate [Hz]")
    if not (math.isfinite(singularity_margin) and 0.0 <= singularity_margin < 1.0):
        raise InvalidParameterError(f"singularity_margin={singularity_margin!r} must be in [0, 1)")
    if not (isinstance(switch_refinements, int | np.integer) and 0 <= switch_refinements <= 10):
        raise InvalidParameterError(
            f"switch_refinements={switch_refinements!r} must be an integer from 0 to 10"
        )
    length = float(getattr(path, "length", getattr(path, "duration", 0.0)) or 0.0)
    if not length > 0.0:
        raise InvalidParameterError(f"path {getattr(path, 'name', path)!r} has no length to plan along")
    wall = time.perf_counter()
    if axes is None and getattr(path, "space", "task") == "task":
        axes = task_axes(robot, frame)
    nominal = ClosedChainNominalModel(robot, payload_mass=payload_mass, friction=friction)
    robot = nominal.robot  # with the payload
    start = branch_configuration(robot, np.array(path_joints(robot, path, [0.0], frame, axes).alpha[0]))
    dynamics = _Dynamics(robot, nominal, start)
    grid = _Grid(robot, path, frame, axes, dynamics, np.linspace(0.0, length, points), torque, velocity)

    def solve() -> tuple[np.ndarray, np.ndarray]:
        law = None
        for _ in range(FRICTION_PASSES if (dynamics.friction or np.any(grid.damping)) else 1):
            c = grid.c0 + dynamics.velocity_terms(grid.d1, grid.damping, grid.s_dot)
            law = _solve(grid.s, grid.a, grid.b, c, grid.limits, grid.d1, grid.speed_limits, grid.speed_cap)
            grid.s_dot = law[0]
        return law

    s_dot, s_ddot = solve()
    uniform = len(grid.s)
    for _ in range(switch_refinements):
        switches = np.flatnonzero(np.abs(np.diff(s_ddot)) > SWITCH_JUMP * np.ptp(s_ddot))
        if not len(switches):
            break
        grid.s_dot = s_dot
        grid.refine(np.union1d(switches, switches + 1))  # the intervals on both sides of each
        s_dot, s_ddot = solve()
    plan = TimeOptimalPlan(
        path, frame, axes, grid.s, s_dot, s_ddot, _times(grid.s, s_dot), torque, velocity,
        name=f"time-optimal {getattr(path, 'name', 'path')}",
    )  # fmt: skip
    plan.switch_points = len(grid.s) - uniform
    plan.planning_time = time.perf_counter() - wall
    if not verify:
        return plan
    wall = time.perf_counter()
    plan.singularity = _singularity(robot, path, grid, frame, axes, singularity_margin, start)
    for repair in range(max_repairs + 1):
        check, ratios, plan.checked, reference = _verify(plan, robot, dynamics, check_rate)
        plan.verification, plan.repairs = check, repair
        if check.feasible or repair == max_repairs:
            break
        torque_over, speed_over = ratios  # the largest ratios inside each interval
        over = np.flatnonzero(np.maximum(torque_over, speed_over) > 1.0)
        if repair < REFINEMENTS:  # a discretisation error: more points where a limit is exceeded
            grid.refine(over)
        else:  # tighten both grid points of an interval by its overshoot
            grid.limits *= _tightening(torque_over, len(grid.s))[:, None]
            if grid.speed_limits is not None:
                grid.speed_limits *= _tightening(speed_over, len(grid.s))[:, None]
        plan.s_dot, plan.s_ddot = solve()
        plan.s, plan.times = grid.s, _times(grid.s, plan.s_dot)
    if jerk is not None and plan.verification.feasible:

        def resolve() -> None:  # the law again under the grid's tightened limits and speed caps
            plan.s_dot, plan.s_ddot = solve()
            plan.times = _times(grid.s, plan.s_dot)

        _meet_jerk_limits(plan, jerk, robot, dynamics, check_rate, grid, resolve, reference)
    plan.verification_time = time.perf_counter() - wall
    return plan


def _meet_jerk_limits(
    plan: TimeOptimalPlan,
    jerk: np.ndarray,
    robot,
    dynamics: _Dynamics,
    rate: float,
    grid: _Grid,
    resolve,
    reference: JointReference,
) -> None:
    """Smooth the verified law until its joint jerk is within ``jerk`` (module docstring, "Jerk
    limits"). The check's jerk splits into the share of s_dddot (alpha' s_dddot, which a wider
    window lowers) and the path's own (the rest: alpha_sss s_dot^3 + 3 alpha'' s_dot s_ddot). The
    window starts where the law's largest joint-acceleration jump takes it at the jerk limit. Each
    round, at the samples where a limit is exceeded, the grid points whose law the window averages
    there are changed: the torque limits tightened by the torque's overshoot, a path-speed cap (the
    law's s_dot there over the cube root of the path share's overshoot, or over the speed's), and
    the law solved again (``resolve``); where the s_dddot share exceeds, the window widens by it.
    After ``JERK_PASSES`` such rounds the whole law is run slower instead, until the check holds.
    ``reference``: the joints at the samples of the plan's last check (``_verify``'s)."""
    plan.jerk_limit = jerk
    jumps = np.abs(np.diff(np.array(reference.alpha_ddot), axis=0)).max(axis=0)
    width = max(float((jumps / jerk).max()), 2.0 / rate)
    for round_ in range(2 * JERK_PASSES):
        plan.smoothing = width
        check, _, plan.checked, reference = _verify(plan, robot, dynamics, rate)
        plan.verification = check
        if check.feasible:
            return
        if round_ < JERK_PASSES:
            width = _local_jerk_round(plan, reference, dynamics, grid, resolve, jerk, width)
            continue
        # the local rounds keep trading one overshoot for another (each solve moves the law's
        # switches): the whole law runs slower, s_dot / k, s_ddot / k^2 and the window k w
        # lowering every jerk term as 1 / k^3 and the dynamic torque as 1 / k^2
        k = (1.0 + JERK_MARGIN) * max(
            math.sqrt(max(check.torque_ratio, 1.0)),
            check.velocity_ratio or 1.0,
            max(check.jerk_ratio, 1.0) ** (1 / 3),
        )
        plan.s_dot, plan.s_ddot, plan.times = plan.s_dot / k, plan.s_ddot / k**2, plan.times * k
        width *= k


def _local_jerk_round(
    plan: TimeOptimalPlan,
    reference: JointReference,
    dynamics: _Dynamics,
    grid: _Grid,
    resolve,
    jerk: np.ndarray,
    width: float,
) -> float:
    """One local round of :func:`_meet_jerk_limits` after a failed check (``plan.checked``, its
    joints ``reference``): the grid's torque limits and speed caps changed where the samples
    exceed, the law solved again; returns the window, widened where the s_dddot share exceeds."""
    samples, tau = plan.checked
    total, path_share = _jerk_ratios(plan, reference, jerk)
    torque_over = np.max(np.abs(tau) / plan.torque_limit, axis=1)
    slower = np.ones(len(samples))
    slower[1:] = np.cbrt(np.maximum(path_share, 1.0))
    if plan.velocity_limit is not None:
        speed = np.array(reference.alpha_dot)
        slower = np.maximum(slower, (np.abs(speed) / plan.velocity_limit).max(axis=1))
    tighten = np.ones(len(grid.s))  # per grid point: the largest torque overshoot it averages into
    slow = np.ones(len(grid.s))  # and the largest slowing asked of it
    for t, torque_ratio, factor in zip(samples, torque_over, slower):
        if torque_ratio > 1.0 or factor > 1.0:
            k = np.flatnonzero((plan.times[1:] > t - width) & (plan.times[:-1] <= t))
            points = np.union1d(k, k + 1)
            tighten[points] = np.maximum(tighten[points], torque_ratio)
            slow[points] = np.maximum(slow[points], factor)
    if np.any(tighten > 1.0):  # compounded round by round, as the repairs' tightening, but never
        # below the torque the point needs at rest (gravity, springs, friction at the law's speed):
        # at most half the headroom above it goes per round
        hold = np.abs(grid.c0 + dynamics.velocity_terms(grid.d1, grid.damping, grid.s_dot))
        over = tighten > 1.0
        tightened = grid.limits[over] / (tighten[over] * (1.0 + JERK_MARGIN))[:, None]
        grid.limits[over] = np.maximum(tightened, 0.5 * (grid.limits[over] + hold[over]))
    if np.any(slow > 1.0):
        cap = np.full(len(grid.s), np.inf) if grid.speed_cap is None else grid.speed_cap
        over = slow > 1.0
        cap[over] = np.minimum(
            cap[over], np.maximum(plan.s_dot[over], 0.0) / (slow[over] * (1.0 + JERK_MARGIN))
        )
        grid.speed_cap = cap
    window = total[path_share <= 1.0]  # where the s_dddot share is what exceeds
    if len(window) and window.max() > 1.0:
        width *= window.max() * (1.0 + JERK_MARGIN)
    if np.any(tighten > 1.0) or np.any(slow > 1.0):
        resolve()
    return width


def _jerk_ratios(
    plan: TimeOptimalPlan, reference: JointReference, jerk: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Between consecutive samples of ``reference`` (the plan's joints at its times) (N - 1,): the
    largest |alpha_dddot_j| / jerk_j, and the largest |alpha_dddot_j - alpha'_j s_dddot| / jerk_j,
    the jerk's share that a wider window does not lower (difference quotients, alpha' = alpha_dot /
    s_dot where the path moves)."""
    times = np.array(reference.t)
    _, s_dot, s_ddot = plan.path_state(times)
    dt = np.diff(times)[:, None]
    alpha_dot = np.array(reference.alpha_dot)
    moving = s_dot > 1e-9 * max(float(s_dot.max()), 1e-300)
    d1 = np.where(moving[:, None], alpha_dot / np.where(moving, s_dot, 1.0)[:, None], 0.0)
    total = np.diff(np.array(reference.alpha_ddot), axis=0) / dt
    share = total - 0.5 * (d1[1:] + d1[:-1]) * (np.diff(s_ddot)[:, None] / dt)
    return (np.abs(total) / jerk).max(axis=1), (np.abs(share) / jerk).max(axis=1)


def _tightening(ratios: np.ndarray, points: int) -> np.ndarray:
    """Per grid point, the factor that brings each interval whose ratio exceeds 1 inside it: both of
    its points scaled by (1 - REPAIR_MARGIN) / ratio, the smaller where two intervals share one."""
    scale = np.ones(points)
    for i in np.flatnonzero(ratios > 1.0):
        factor = (1.0 - REPAIR_MARGIN) / ratios[i]
        scale[i], scale[i + 1] = min(scale[i], factor), min(scale[i + 1], factor)
    return scale


class _Grid:
    """The grid s of a plan with the path's joints and the coefficients at its points, the torque
    limits in force there and the last law's s_dot (the friction's speed); refined by inserting
    the midpoints of chosen intervals (the path's inverse kinematics then runs along the whole
    grid again: its Newton steps from one point to the next)."""

    def __init__(
        self, robot, path, frame, axes, dynamics: _Dynamics, s: np.ndarray, torque: np.ndarray, velocity
    ) -> None:
        self.robot, self.path, self.frame, self.axes, self.dynamics = robot, path, frame, axes, dynamics
        self.limits = np.broadcast_to(torque, (len(s), len(torque))).copy()
        self.speed_limits = (
            None if velocity is None else np.broadcast_to(velocity, (len(s), len(velocity))).copy()
        )
        self.speed_cap = None  # s_dot's own bound at each point [m/s] (the jerk limits'), or None
        self._evaluate(s, np.full(len(s), 1e-3))  # the first pass: friction's sign along the path, near rest

    def _evaluate(self, s: np.ndarray, s_dot: np.ndarray) -> None:
        on_path = path_joints(self.robot, self.path, s, self.frame, self.axes)
        self.s, self.s_dot = s, s_dot
        self.alpha, self.d1 = np.array(on_path.alpha), np.array(on_path.alpha_dot)  # alpha(s), alpha'(s)
        self.a, self.b, self.c0, self.damping = self.dynamics.coefficients(
            self.alpha, self.d1, np.array(on_path.alpha_ddot)
        )

    def refine(self, intervals: np.ndarray) -> None:
        """Insert the midpoint of each of these intervals (its limits and s_dot the mean of its
        ends')."""
        middle = 0.5 * (self.s[intervals] + self.s[intervals + 1])
        order = np.argsort(np.concatenate([self.s, middle]), kind="stable")

        def merged(values):
            return np.concatenate([values, 0.5 * (values[intervals] + values[intervals + 1])])[order]

        self.limits = merged(self.limits)
        if self.speed_limits is not None:
            self.speed_limits = merged(self.speed_limits)
        if self.speed_cap is not None:
            self.speed_cap = merged(self.speed_cap)
        s_dot = np.concatenate([self.s_dot, 0.5 * (self.s_dot[intervals] + self.s_dot[intervals + 1])])[order]
        self._evaluate(np.concatenate([self.s, middle])[order], s_dot)


def _singularity(robot, path, grid: _Grid, frame, axes, margin: float, start: np.ndarray) -> np.ndarray:
    """The smallest (Type I, Type II) measures at the grid's joints; PlanningError within ``margin``."""
    from delta_pin.planning.singularity import path_singularity

    closeness = path_singularity(robot, grid.alpha, frame, axes, start)
    worst = closeness.min(axis=0)
    if worst.min() < margin:
        kind = 0 if worst[0] <= worst[1] else 1
        at = grid.s[int(np.argmin(closeness[:, kind]))]
        raise PlanningError(
            f"{getattr(path, 'name', 'the path')} passes within {worst[kind]:.2g} of a Type "
            f"{'I' * (kind + 1)} singularity at s={at:.4g} m (singularity_margin {margin:g}): move the path, "
            "or lower the margin"
        )
    return worst


def torque_model(robot, friction=None, payload_mass: float = 0.0):
    """The torque a state needs by the planner's projected dynamics (its nominal ``friction`` and
    ``payload_mass`` [kg]): ``torque(alpha, alpha_dot, alpha_ddot)`` on rows (N, dof) -> (N, dof) [N m]."""
    nominal = ClosedChainNominalModel(robot, payload_mass=payload_mass, friction=friction)
    dynamics = _Dynamics(nominal.robot, nominal)

    def torque(alpha, alpha_dot, alpha_ddot):
        dynamics.start = branch_configuration(nominal.robot, np.asarray(alpha)[0])
        return dynamics.torque(alpha, alpha_dot, alpha_ddot)

    return torque


def _times(s: np.ndarray, s_dot: np.ndarray) -> np.ndarray:
    """The grid's times [s]: each interval takes 2 ds / (s_dot_i + s_dot_i+1) (constant s_ddot)."""
    speeds = s_dot[:-1] + s_dot[1:]
    if np.any(speeds <= 0.0):
        raise PlanningError("the time law stops inside the path (s_dot = 0 on an interval)")
    return np.concatenate([[0.0], np.cumsum(2.0 * np.diff(s) / speeds)])


def _verify(
    plan: TimeOptimalPlan, robot, dynamics: _Dynamics, rate: float
) -> tuple[Verification, np.ndarray, tuple, JointReference]:
    """The plan's torque on the exact model at ``rate`` [Hz] (module docstring), the largest ratios
    |tau| / limit and |alpha_dot| / limit inside each grid interval ((N,), (N,): zeros without a
    velocity limit), the samples (times [s], tau [N m]) and the joints there."""
    times = np.append(np.arange(0.0, plan.duration, 1.0 / rate), plan.duration)
    reference = plan.joint_reference(robot, times)
    tau = dynamics.torque(
        np.array(reference.alpha), np.array(reference.alpha_dot), np.array(reference.alpha_ddot)
    )
    ratio = np.abs(tau) / plan.torque_limit
    worst = ratio.max(axis=1)
    k = np.clip(np.searchsorted(plan.times, times, side="right") - 1, 0, len(plan.s_ddot) - 1)
    per_interval, speed_per_interval = np.zeros(len(plan.s_ddot)), np.zeros(len(plan.s_ddot))
    np.maximum.at(per_interval, k, worst)
    peak = np.abs(tau).max(axis=0)
    velocity_ratio = None
    if plan.velocity_limit is not None:
        speed = (np.abs(reference.alpha_dot) / plan.velocity_limit).max(axis=1)
        np.maximum.at(speed_per_interval, k, speed)
        velocity_ratio = float(speed.max())
    jerk_ratio = None
    if plan.jerk_limit is not None:  # the difference quotient of the exact alpha_ddot
        jerk = np.diff(np.array(reference.alpha_ddot), axis=0) / np.diff(times)[:, None]
        jerk_ratio = float((np.abs(jerk) / plan.jerk_limit).max())
    check = Verification(
        rate=rate, samples=len(times), torque_ratio=float(worst.max()), peak_torque=peak,
        margin=1.0 - peak / plan.torque_limit, time_of_peak=float(times[int(np.argmax(worst))]),
        velocity_ratio=velocity_ratio, jerk_ratio=jerk_ratio,
    )  # fmt: skip
    return check, (per_interval, speed_per_interval), (times, tau), reference

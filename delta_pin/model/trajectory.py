"""Task-space trajectories of the platform and the joint-space references they induce.

A :class:`Trajectory` gives the platform position xyz(t) [m] and its ANALYTIC derivatives
xyz_dot(t) [m/s] and xyz_ddot(t) [m/s^2]; :meth:`Trajectory.joint_reference` turns them into the
controllers' reference alpha^d, alpha_dot^d, alpha_ddot^d through the batched closed-form
kinematics (eqs. 5 and 10):

    alpha = IK(xyz),   alpha_dot = J^-1 xyz_dot,   alpha_ddot = J^-1 (xyz_ddot - J_dot alpha_dot).

Families: the paper's :class:`PathI` (eq. 66) and :class:`PathII` (eq. 69), the industry's
pick-and-place benchmark :class:`AdeptCycle`, and :class:`SplinePath` through user waypoints.
Every time argument is a float or an array (N,) of times [s]; the answers have shape (3,) or (N, 3).
"""

from __future__ import annotations

import functools
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from delta_pin.errors import InvalidParameterError, UnreachablePoseError
from delta_pin.model import kinematics
from delta_pin.model.description import DeltaParameters

__all__ = [
    "AdeptCycle",
    "JointReference",
    "PathI",
    "PathII",
    "SplinePath",
    "Trajectory",
    "check_workspace",
    "joint_reference",
]

Times = float | Sequence[float] | np.ndarray


@dataclass(frozen=True, eq=False)
class JointReference:
    """A trajectory sampled at N times, in task and joint space (arrays are read-only).

    Attributes:
        t: sample times (N,) [s].
        xyz, xyz_dot, xyz_ddot: platform position [m], velocity [m/s], acceleration [m/s^2] (N, 3).
        alpha, alpha_dot, alpha_ddot: active joint angles [rad], rates [rad/s] and
            accelerations [rad/s^2] (N, 3) of the elbow-out branch.
    """

    t: np.ndarray
    xyz: np.ndarray
    xyz_dot: np.ndarray
    xyz_ddot: np.ndarray
    alpha: np.ndarray
    alpha_dot: np.ndarray
    alpha_ddot: np.ndarray

    def __post_init__(self) -> None:
        for name in ("t", "xyz", "xyz_dot", "xyz_ddot", "alpha", "alpha_dot", "alpha_ddot"):
            array = np.array(getattr(self, name), dtype=float)
            # task space is 3-D; joint space has as many columns as the robot has joints
            columns = 3 if name.startswith("xyz") else np.shape(self.alpha)[-1]
            expected = (len(self.t),) if name == "t" else (len(self.t), columns)
            if array.shape != expected:
                raise InvalidParameterError(f"JointReference.{name} has shape {array.shape}, not {expected}")
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    def __len__(self) -> int:
        return len(self.t)

    def at(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(alpha, alpha_dot, alpha_ddot) (3,) each of sample ``k`` [rad, rad/s, rad/s^2]."""
        return self.alpha[k], self.alpha_dot[k], self.alpha_ddot[k]


def _params_of(robot_or_params: Any) -> DeltaParameters:
    """The DeltaParameters of a :class:`~delta_pin.model.robot.Delta` (or the parameters themselves)."""
    params = getattr(robot_or_params, "params", robot_or_params)
    if not isinstance(params, DeltaParameters):
        raise InvalidParameterError(
            f"this path is written for a Delta's platform (analytic IK, eq. 5) and {robot_or_params!r} "
            "is not a "
            "recognised Delta: move a frame of it with FramePath(path, frame=...)"
        )
    return params


def _vectorised(method: Callable[[Any, np.ndarray], np.ndarray]) -> Callable[[Any, Times], np.ndarray]:
    """Let ``method(self, t)`` written for times (N,) accept a float (answer (3,)) or (N,) times."""

    @functools.wraps(method)
    def wrapper(self: Any, t: Times) -> np.ndarray:
        times = np.asarray(t, dtype=float)
        if times.ndim > 1:
            raise InvalidParameterError(f"times must be a float or have shape (N,), got shape {times.shape}")
        if not np.all(np.isfinite(times)):
            raise InvalidParameterError(f"times hold a non-finite number: t={times.tolist()}")
        values = method(self, np.atleast_1d(times))
        return values[0] if times.ndim == 0 else values

    return wrapper


class Trajectory(ABC):
    """A task-space trajectory xyz(t) of the platform with analytic derivatives.

    Subclasses implement :meth:`position`, :meth:`velocity` and :meth:`acceleration` for a float
    or an array (N,) of times [s] (decorate an implementation written for arrays with
    ``_vectorised``), set :attr:`name` and :attr:`duration`, and extend :meth:`metadata`.

    Attributes:
        name: a human-readable name (used in error messages and plots).
        duration: the time [s] after which the trajectory holds still, or ``None`` if unbounded.
    """

    name: str = "trajectory"
    duration: float | None = None

    @abstractmethod
    def position(self, t: Times) -> np.ndarray:
        """Platform position xyz [m], (3,) for a float ``t`` [s] or (N, 3) for times (N,)."""

    @abstractmethod
    def velocity(self, t: Times) -> np.ndarray:
        """Platform velocity d(xyz)/dt [m/s], (3,) or (N, 3)."""

    @abstractmethod
    def acceleration(self, t: Times) -> np.ndarray:
        """Platform acceleration d^2(xyz)/dt^2 [m/s^2], (3,) or (N, 3)."""

    def metadata(self) -> dict[str, Any]:
        """The trajectory's kind and parameters as a JSON-serialisable dict."""
        return {"type": type(self).__name__, "name": self.name, "duration": self.duration}

    def joint_reference(self, robot_or_params: Any, t: Times) -> JointReference:
        """Sample the trajectory at times ``t`` [s] and map it to joint space (eqs. 5, 10).

        alpha = IK(xyz), alpha_dot = J^-1 xyz_dot, alpha_ddot = J^-1 (xyz_ddot - J_dot alpha_dot),
        solved for the whole batch at once (closed-form 3x3 solves,
        :func:`~delta_pin.model.kinematics.solve3_batched`; J is computed once).

        Args:
            robot_or_params: a :class:`~delta_pin.model.robot.Delta` or its DeltaParameters.
            t: a float or an array (N,) of times [s].

        Raises:
            UnreachablePoseError: naming the first time and point outside the workspace.
        """
        params = _params_of(robot_or_params)
        times = np.atleast_1d(np.asarray(t, dtype=float))
        xyz = self.position(times)
        xyz_dot = self.velocity(times)
        xyz_ddot = self.acceleration(times)
        alpha = self._inverse_kinematics(params, times, xyz)
        J = kinematics.jacobian(params, alpha, xyz)
        alpha_dot = kinematics.solve3_batched(J, xyz_dot)
        drift = kinematics.jacobian_derivative_times_velocity(params, alpha, alpha_dot, xyz, J=J)
        alpha_ddot = kinematics.solve3_batched(J, xyz_ddot - drift)
        return JointReference(times, xyz, xyz_dot, xyz_ddot, alpha, alpha_dot, alpha_ddot)

    def check_workspace(self, robot_or_params: Any, t_end: float | None = None, dt: float = 1e-3) -> None:
        """Raise before a simulation starts if the path leaves the workspace; see :func:`check_workspace`."""
        check_workspace(self, robot_or_params, t_end, dt)

    def _inverse_kinematics(self, params: DeltaParameters, times: np.ndarray, xyz: np.ndarray) -> np.ndarray:
        """Batched IK; on failure, locate the FIRST unreachable sample by bisection on prefixes.

        IK of a prefix xyz[:k] fails exactly when the prefix holds an unreachable point, so
        log2(N) batched calls find the first one (each call is vectorised, so this stays fast).
        """
        try:
            return kinematics.inverse_kinematics(params, xyz)
        except UnreachablePoseError:
            pass
        good, bad = 0, len(times)  # IK of xyz[:good] succeeds, of xyz[:bad] fails
        while bad - good > 1:
            middle = (good + bad) // 2
            try:
                kinematics.inverse_kinematics(params, xyz[:middle])
                good = middle
            except UnreachablePoseError:
                bad = middle
        k = bad - 1
        try:
            kinematics.inverse_kinematics(params, xyz[k])
        except UnreachablePoseError as error:
            point = [round(float(v), 6) for v in xyz[k]]
            raise UnreachablePoseError(
                f"{self.name} leaves the workspace at t={times[k]:.6g} s: xyz={point} m ({error})"
            ) from error
        raise AssertionError("unreachable: bisection found no failing point")  # pragma: no cover

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, duration={self.duration!r})"


def joint_reference(trajectory: Trajectory, robot_or_params: Any, t: Times) -> JointReference:
    """Function form of :meth:`Trajectory.joint_reference`."""
    return trajectory.joint_reference(robot_or_params, t)


def check_workspace(
    trajectory: Trajectory, robot_or_params: Any, t_end: float | None = None, dt: float = 1e-3
) -> None:
    """Sample [0, t_end] every ``dt`` [s] (t_end included) and check every point has an IK.

    Args:
        trajectory: the task-space trajectory.
        robot_or_params: a :class:`~delta_pin.model.robot.Delta` or its DeltaParameters.
        t_end: end of the check [s]; ``None`` takes ``trajectory.duration``.
        dt: sampling step [s] (e.g. the simulation's control period).

    Raises:
        UnreachablePoseError: naming the first time [s] and point [m] outside the workspace.
        InvalidParameterError: non-positive ``dt``, negative ``t_end``, or no ``t_end`` for an
            unbounded trajectory.
    """
    if t_end is None:
        t_end = trajectory.duration
        if t_end is None:
            raise InvalidParameterError(f"{trajectory.name} is unbounded (duration=None): give t_end")
    if not (math.isfinite(t_end) and t_end >= 0.0):
        raise InvalidParameterError(f"t_end={t_end} s must be finite and non-negative")
    if not (math.isfinite(dt) and dt > 0.0):
        raise InvalidParameterError(f"dt={dt} s must be finite and positive")
    steps = math.ceil(t_end / dt - 1e-9)
    times = np.minimum(np.arange(steps + 1) * dt, t_end)
    trajectory._inverse_kinematics(_params_of(robot_or_params), times, trajectory.position(times))


def _require_positive(name: str, value: float) -> float:
    """``value`` as a float if finite and > 0, else InvalidParameterError naming it."""
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise InvalidParameterError(f"{name}={value} must be finite and positive")
    return value


def _require_finite(name: str, value: Any, shape: tuple[int, ...] = ()) -> np.ndarray:
    """``value`` as a float array of ``shape`` with finite entries, else InvalidParameterError."""
    array = np.asarray(value, dtype=float)
    if array.shape != shape:
        raise InvalidParameterError(f"{name} must have shape {shape}, got {array.shape}: {name}={value!r}")
    if not np.all(np.isfinite(array)):
        raise InvalidParameterError(f"{name}={array.tolist()} holds a non-finite number")
    return array


# ------------------------------------------------------------------------------------- the paper's paths
class PathI(Trajectory):
    """The paper's path type I (eq. 66): a rising spiral of growing radius, unbounded in time.

    x = 0.05 t/15 cos(2 pi t), y = 0.05 t/15 sin(2 pi t), z = -0.35 + 0.01 t  [m, t in s]:
    one turn per second, the radius grows by 0.05/15 m per second (0.05 m at t = 15 s) and the
    platform rises by 0.01 m/s.
    """

    name = "path I"
    duration = None

    _GROWTH = 0.05 / 15.0  # [m/s] radius growth rate
    _OMEGA = 2.0 * math.pi  # [rad/s]

    @_vectorised
    def position(self, t: np.ndarray) -> np.ndarray:
        angle = 2.0 * np.pi * t
        return np.stack([0.05 * t / 15 * np.cos(angle), 0.05 * t / 15 * np.sin(angle), -0.35 + 0.01 * t], -1)

    @_vectorised
    def velocity(self, t: np.ndarray) -> np.ndarray:
        a, w = self._GROWTH, self._OMEGA
        c, s = np.cos(w * t), np.sin(w * t)
        return np.stack([a * (c - w * t * s), a * (s + w * t * c), np.full_like(t, 0.01)], -1)

    @_vectorised
    def acceleration(self, t: np.ndarray) -> np.ndarray:
        a, w = self._GROWTH, self._OMEGA
        c, s = np.cos(w * t), np.sin(w * t)
        return np.stack([-a * w * (2.0 * s + w * t * c), a * w * (2.0 * c - w * t * s), np.zeros_like(t)], -1)

    def metadata(self) -> dict[str, Any]:
        return {**super().metadata(), "equation": 66}


class PathII(Trajectory):
    """The paper's path type II (eq. 69): a rising circle, unbounded in time.

    x = 0.1 sin(pi t), y = 0.1 cos(pi t), z = -0.4 + 0.02 t/pi  [m, t in s]: radius 0.1 m,
    one turn every 2 s, rising by 0.02/pi m/s.
    """

    name = "path II"
    duration = None

    @_vectorised
    def position(self, t: np.ndarray) -> np.ndarray:
        return np.stack([0.1 * np.sin(np.pi * t), 0.1 * np.cos(np.pi * t), -0.4 + 0.02 * t / np.pi], -1)

    @_vectorised
    def velocity(self, t: np.ndarray) -> np.ndarray:
        c, s = np.cos(np.pi * t), np.sin(np.pi * t)
        return np.stack([0.1 * np.pi * c, -0.1 * np.pi * s, np.full_like(t, 0.02 / np.pi)], -1)

    @_vectorised
    def acceleration(self, t: np.ndarray) -> np.ndarray:
        c, s = np.cos(np.pi * t), np.sin(np.pi * t)
        return np.stack([-0.1 * np.pi**2 * s, -0.1 * np.pi**2 * c, np.zeros_like(t)], -1)

    def metadata(self) -> dict[str, Any]:
        return {**super().metadata(), "equation": 69}


# --------------------------------------------------------------------------------- pick and place
def _minimum_jerk(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quintic minimum-jerk law s = 10 tau^3 - 15 tau^4 + 6 tau^5 on tau in [0, 1] and its
    derivatives ds/dtau, d^2s/dtau^2 (all three of s', s'' vanish at tau = 0 and 1 but s)."""
    s = tau**3 * (10.0 + tau * (-15.0 + 6.0 * tau))
    ds = 30.0 * tau**2 * (1.0 - tau) ** 2
    dds = 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau)
    return s, ds, dds


class AdeptCycle(Trajectory):
    """The Adept pick-and-place cycle: up ``height``, across ``width``, down; then back.

    From A (low) the platform rises ``height`` [m], moves ``width`` [m] across, descends to B;
    then B up, across, down to A. Six straight segments; each follows the quintic minimum-jerk law
    s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5, so each starts and stops with zero velocity and
    acceleration: the path is C^2 (acceleration continuous, jerk bounded, jerk steps at the
    corners). The cycle time is split in proportion to sqrt(segment length): the law's peak
    acceleration is (10/sqrt(3)) L/T^2, so T ~ sqrt(L) gives every segment the same peak
    acceleration, 5.77 L/T^2 (17.4 m/s^2 ~ 1.8 g for the defaults: T = 0.091 s up/down,
    0.318 s across).

    Defaults for the paper's Table 1 robot (R=0.15, r=0.08, l_a=0.2, l_b=0.4 m): the full
    standard cycle (25 mm up, 305 mm across) is reachable, in every direction, for a bottom
    height z from about -0.53 m to -0.225 m (beyond, the ends at +-0.1525 m leave the workspace).
    The default z = -0.40 m (path II's start height) is, to 5 mm, where the smallest singular
    value of J along the cycle is largest (>= 0.136 m/rad in every direction; condition number
    <= 2.22, |alpha| <= 58.4 deg), i.e. where the worst-case joint rate per platform speed is
    least; at z = -0.45 m (reachable too) the condition number rises to 2.66 and |alpha| to
    67 deg. With cycle_time = 1 s the joint references peak at about 6.5 rad/s and 87 rad/s^2.

    Args:
        cycle_time: duration of one full cycle A -> B -> A [s].
        height: rise above the pick/place points [m].
        width: distance A -> B [m].
        z: height of A and B [m] (negative: below the base).
        center: (x, y) [m] of the midpoint between A and B.
        direction: azimuth [rad] of the across move A -> B in the base xy plane.
        periodic: repeat the cycle forever (``duration`` None); otherwise hold A after one cycle.
    """

    name = "Adept cycle"

    def __init__(
        self,
        cycle_time: float = 1.0,
        height: float = 0.025,
        width: float = 0.305,
        z: float = -0.40,
        center: Sequence[float] = (0.0, 0.0),
        direction: float = 0.0,
        periodic: bool = True,
    ) -> None:
        self.cycle_time = _require_positive("cycle_time", cycle_time)
        self.height = _require_positive("height", height)
        self.width = _require_positive("width", width)
        self.z = float(_require_finite("z", z))
        self.center = _require_finite("center", center, (2,))
        self.direction = float(_require_finite("direction", direction))
        self.periodic = bool(periodic)
        self.duration = None if self.periodic else self.cycle_time

        across = np.array([math.cos(self.direction), math.sin(self.direction), 0.0])
        up = np.array([0.0, 0.0, self.height])
        self.pick_point = np.array([*self.center, self.z]) - 0.5 * self.width * across  # A [m]
        self.place_point = self.pick_point + self.width * across  # B [m]
        A, B = self.pick_point, self.place_point
        corners = np.array([A, A + up, B + up, B, B + up, A + up, A])
        self._starts, self._moves = corners[:-1], np.diff(corners, axis=0)  # (6, 3) each [m]
        lengths = np.linalg.norm(self._moves, axis=1)
        self.segment_durations = self.cycle_time * np.sqrt(lengths) / np.sqrt(lengths).sum()  # [s]
        self.segment_starts = np.concatenate([[0.0], np.cumsum(self.segment_durations)[:-1]])  # [s]
        self.peak_acceleration = 10.0 / math.sqrt(3.0) * float(lengths[0] / self.segment_durations[0] ** 2)

    def _segment(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
        """Segment index k (N,), its duration (N,), and the time law at the local phase tau."""
        if self.periodic:
            t = np.mod(t, self.cycle_time)
        k = np.clip(np.searchsorted(self.segment_starts, t, side="right") - 1, 0, 5)
        durations = self.segment_durations[k]
        tau = np.clip((t - self.segment_starts[k]) / durations, 0.0, 1.0)
        return k, durations, _minimum_jerk(tau)

    @_vectorised
    def position(self, t: np.ndarray) -> np.ndarray:
        k, _, (s, _, _) = self._segment(t)
        return self._starts[k] + s[:, None] * self._moves[k]

    @_vectorised
    def velocity(self, t: np.ndarray) -> np.ndarray:
        k, durations, (_, ds, _) = self._segment(t)
        return (ds / durations)[:, None] * self._moves[k]

    @_vectorised
    def acceleration(self, t: np.ndarray) -> np.ndarray:
        k, durations, (_, _, dds) = self._segment(t)
        return (dds / durations**2)[:, None] * self._moves[k]

    def metadata(self) -> dict[str, Any]:
        return {
            **super().metadata(),
            "cycle_time": self.cycle_time,
            "height": self.height,
            "width": self.width,
            "z": self.z,
            "center": self.center.tolist(),
            "direction": self.direction,
            "periodic": self.periodic,
            "time_law": "quintic minimum jerk, segment durations ~ sqrt(length)",
            "segment_durations": self.segment_durations.tolist(),
        }


# ---------------------------------------------------------------------------------------- spline
class SplinePath(Trajectory):
    """A cubic spline through waypoints, at rest at both ends (scipy CubicSpline, "clamped").

    The path is C^2 on [t_0, t_M]; outside it holds the end points (zero velocity and
    acceleration). Note that a clamped cubic fixes only the end VELOCITIES: the acceleration
    generally steps from 0 to the spline's value at t_0 (and back at t_M).

    Args:
        times: strictly increasing times (M,) [s], M >= 2.
        waypoints: platform positions (M, 3) [m] at those times.
        name: a name for messages and plots.
    """

    def __init__(
        self, times: Sequence[float], waypoints: Sequence[Sequence[float]], name: str = "spline path"
    ):
        times_array = np.asarray(times, dtype=float)
        count = times_array.shape[0] if times_array.ndim == 1 else -1
        if count < 2:
            raise InvalidParameterError(f"times must have shape (M,) with M >= 2, got times={times!r}")
        self.times = _require_finite("times", times_array, (count,))
        self.waypoints = _require_finite("waypoints", waypoints, (count, 3))
        steps = np.diff(self.times)
        if np.any(steps <= 0.0):
            k = int(np.argmax(steps <= 0.0))
            raise InvalidParameterError(
                f"times must increase strictly: times[{k + 1}]={self.times[k + 1]} s "
                f"follows times[{k}]={self.times[k]} s"
            )
        self.name = name
        self.duration = float(self.times[-1])
        self._spline = CubicSpline(self.times, self.waypoints, axis=0, bc_type="clamped")

    def _evaluate(self, t: np.ndarray, order: int) -> np.ndarray:
        clamped = np.clip(t, self.times[0], self.times[-1])
        values = self._spline(clamped, order)
        if order > 0:
            values[(t < self.times[0]) | (t > self.times[-1])] = 0.0
        return values

    @_vectorised
    def position(self, t: np.ndarray) -> np.ndarray:
        return self._evaluate(t, 0)

    @_vectorised
    def velocity(self, t: np.ndarray) -> np.ndarray:
        return self._evaluate(t, 1)

    @_vectorised
    def acceleration(self, t: np.ndarray) -> np.ndarray:
        return self._evaluate(t, 2)

    def metadata(self) -> dict[str, Any]:
        return {**super().metadata(), "times": self.times.tolist(), "waypoints": self.waypoints.tolist()}

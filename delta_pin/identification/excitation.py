"""Excitation trajectories: finite Fourier series on the actuated joints, optimised for the
condition number of the stacked base regressor (Swevers et al. 1997), within limits.

Per actuated joint j, with omega = 2 pi / period and H harmonics,

    alpha_j(t) = alpha0_j + sum_k [ a_jk sin(k omega t) + b_jk (cos(k omega t) - 1) ],
    a_j1 = -sum_{k>=2} k a_jk / 1,

so alpha(0) = alpha0 and alpha_dot(0) = 0: a run starts at rest on its reference. The free
coefficients (a_jk for k >= 2, b_jk) are chosen by ``scipy.optimize.minimize`` to minimise
cond(W_b D), W_b the base regressor stacked at ``samples`` points of one period and D the scaling of
its columns to unit norm (so that units do not weigh in), subject to, at every point,

* |alpha - alpha0| <= ``position_range`` and within the joints' limits,
* |alpha_dot| <= ``velocity_limit``,
* |tau| <= ``torque_limit`` (the nominal model's torque Y theta_nominal),
* cond(J_p) <= ``jacobian_condition`` (the closures' passive Jacobian: the trajectory stays away
  from the closures' singularities),
* the loops close (a point the robot cannot reach is a violated constraint);

the optimiser holds them at ``OPTIMIZER_MARGIN`` (90 %) of the limits, for the peaks between its
points (:func:`optimize_excitation`).

:func:`check_excitation` checks a trajectory on a fine grid (1 kHz by default) and names the first
time it leaves the workspace, crosses the singularity margin or a limit.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from delta_pin.errors import AssemblyError, InvalidParameterError
from delta_pin.identification.base import BaseParameters, joint_scale
from delta_pin.identification.regressor import ClosedChainRegressor
from delta_pin.model.trajectory import JointReference

OPTIMIZER_MARGIN = (
    0.9  # the optimiser's limits are this fraction of the checked ones (peaks between its points)
)

__all__ = ["ExcitationLimits", "FourierExcitation", "check_excitation", "optimize_excitation"]


@dataclass
class FourierExcitation:
    """A finite Fourier series on the actuated joints (module docstring).

    Attributes:
        alpha0: start (and centre) positions (dof,) [rad or m].
        a, b: coefficients (dof, H) [rad or m]; ``a[:, 0]`` is set by the rest condition.
        period: the fundamental period [s].
        duration: the run's length [s] (several periods).
    """

    alpha0: np.ndarray
    a: np.ndarray
    b: np.ndarray
    period: float
    duration: float
    name: str = field(default="fourier excitation")
    joint_space = True  # a class attribute: its joints by joint_values (sim/reference.py)

    def __post_init__(self) -> None:
        self.alpha0 = np.asarray(self.alpha0, dtype=float)
        self.a = np.array(self.a, dtype=float)
        self.b = np.array(self.b, dtype=float)
        k = np.arange(1, self.a.shape[1] + 1)
        self.a[:, 0] = -(self.a[:, 1:] * k[1:]).sum(axis=1)  # alpha_dot(0) = 0
        if not (self.period > 0.0 and self.duration > 0.0):
            raise InvalidParameterError(f"period {self.period} and duration {self.duration} must be > 0 [s]")

    @property
    def harmonics(self) -> int:
        return self.a.shape[1]

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(alpha, alpha_dot, alpha_ddot) (N, dof) at times t (N,) [s]."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        omega = 2.0 * np.pi / self.period
        k = np.arange(1, self.harmonics + 1)
        w = omega * k  # (H,)
        phase = t[:, None] * w[None, :]  # (N, H)
        s, c = np.sin(phase), np.cos(phase)
        alpha = self.alpha0 + s @ self.a.T + (c - 1.0) @ self.b.T
        alpha_dot = (c * w) @ self.a.T - (s * w) @ self.b.T
        alpha_ddot = -(s * w**2) @ self.a.T - (c * w**2) @ self.b.T
        return alpha, alpha_dot, alpha_ddot

    def joint_values(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`evaluate` (a joint-space trajectory: simulate assembles the end effector's xyz
        at its samples only, :func:`~delta_pin.sim.reference.tabulate_reference`)."""
        return self.evaluate(t)

    def joint_reference(self, robot, t) -> JointReference:
        """The reference a controller tracks (``simulate``'s trajectory interface); xyz is the
        end effector's position."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        alpha, alpha_dot, alpha_ddot = self.evaluate(t)
        xyz = np.array([robot.forward_kinematics(a) for a in alpha])
        zeros = np.zeros_like(xyz)
        return JointReference(t=t, xyz=xyz, xyz_dot=zeros, xyz_ddot=zeros, alpha=alpha,
                              alpha_dot=alpha_dot, alpha_ddot=alpha_ddot)  # fmt: skip

    def metadata(self) -> dict:
        return {
            "name": self.name,
            "alpha0": self.alpha0.tolist(),
            "a": self.a.tolist(),
            "b": self.b.tolist(),
            "period": self.period,
            "duration": self.duration,
        }

    @classmethod
    def from_metadata(cls, data: dict) -> FourierExcitation:
        return cls(np.array(data["alpha0"]), np.array(data["a"]), np.array(data["b"]),
                   float(data["period"]), float(data["duration"]))  # fmt: skip


@dataclass(frozen=True)
class ExcitationLimits:
    """What an excitation must respect (module docstring); ``None`` fields take per-joint
    defaults from the robot (see :func:`default_limits`).

    Attributes:
        position_range: largest |alpha - alpha0| (dof,) [rad or m].
        velocity_limit: largest |alpha_dot| (dof,) [rad/s or m/s].
        torque_limit: largest |tau| (dof,) [N m or N].
        jacobian_condition: largest cond(J_p).
    """

    position_range: np.ndarray | float | None = None
    velocity_limit: np.ndarray | float | None = None
    torque_limit: np.ndarray | float | None = None
    jacobian_condition: float = 100.0


def default_limits(robot, limits: ExcitationLimits | None = None) -> dict:
    """The limits in force (dof,) each: 0.35 rad / 0.035 m of range, 4 rad/s / 0.4 m/s, the URDF's
    effort limit, unless given."""
    limits = limits or ExcitationLimits()
    scale = joint_scale(robot)
    dof = robot.dof
    effort = robot.model.effortLimit[robot.actuated_indices]
    effort = np.where(np.isfinite(effort) & (effort > 0), effort, np.inf)

    def pick(value, default):
        return np.broadcast_to(np.asarray(default if value is None else value, dtype=float), (dof,)).copy()

    return {
        "position": pick(limits.position_range, 0.35 * scale),
        "velocity": pick(limits.velocity_limit, 4.0 * scale),
        "torque": pick(limits.torque_limit, effort),
        "jacobian": float(limits.jacobian_condition),
        "lower": robot.model.lowerPositionLimit[robot.actuated_q_indices],
        "upper": robot.model.upperPositionLimit[robot.actuated_q_indices],
    }


def _passive_condition(robot, q: np.ndarray) -> float:
    J = robot.closure_jacobian(q)[:, robot.dependent_indices]
    singular = np.linalg.svd(J, compute_uv=False)
    rank = len(robot.dependent_indices)
    return float(singular[0] / singular[rank - 1]) if singular[rank - 1] > 0 else np.inf


class _Evaluator:
    """Regressor, torques and the closures' condition at the sample points of one coefficient set."""

    def __init__(self, regressor, base, theta, t, limits) -> None:
        self.regressor, self.base, self.theta, self.t, self.limits = regressor, base, theta, t, limits
        self._key = None
        self._value = None

    def __call__(self, trajectory: FourierExcitation):
        key = np.concatenate([trajectory.a.ravel(), trajectory.b.ravel()]).tobytes()
        if key == self._key:
            return self._value
        robot = self.regressor.robot
        alpha, alpha_dot, alpha_ddot = trajectory.evaluate(self.t)
        lim = self.limits
        margins = [
            (lim["position"] - np.abs(alpha - trajectory.alpha0)) / lim["position"],
            (lim["velocity"] - np.abs(alpha_dot)) / lim["velocity"],
            np.minimum(alpha - lim["lower"], lim["upper"] - alpha),
        ]
        rows = []
        conditions = []
        closed = True
        for k in range(len(self.t)):
            try:
                rows.append(self.regressor.rows(alpha[k], alpha_dot[k], alpha_ddot[k]))
                conditions.append(_passive_condition(robot, self.regressor._last_q))
            except AssemblyError:
                closed = False
                self.regressor._last_q = robot.reference_configuration.copy()
                break
        if not closed:
            value = (1e6, np.concatenate([m.ravel() for m in margins] + [np.full(len(self.t), -1.0)]))
        else:
            Y = np.array(rows)
            tau = Y @ self.theta
            margins.append(
                (lim["torque"] - np.abs(tau)) / np.where(np.isfinite(lim["torque"]), lim["torque"], 1.0)
            )
            margins.append((lim["jacobian"] - np.array(conditions))[:, None] / lim["jacobian"])
            W = self.base.reduce(Y).reshape(-1, self.base.rank)
            norms = np.linalg.norm(W, axis=0)
            singular = np.linalg.svd(W / np.where(norms > 0, norms, 1.0), compute_uv=False)
            cond = float(singular[0] / singular[-1]) if singular[-1] > 0 else 1e12
            value = (cond, np.concatenate([np.nan_to_num(m.ravel(), posinf=1.0) for m in margins]))
        self.regressor._last_q = robot.reference_configuration.copy()
        self._key, self._value = key, value
        return value


def optimize_excitation(
    regressor: ClosedChainRegressor,
    base: BaseParameters,
    theta: np.ndarray,
    *,
    harmonics: int = 8,
    period: float = 5.0,
    duration: float = 20.0,
    samples: int = 50,
    limits: ExcitationLimits | None = None,
    max_iterations: int = 30,
    seed: int = 0,
    alpha0: np.ndarray | None = None,
) -> tuple[FourierExcitation, dict]:
    """An excitation of ``duration`` [s] (a whole number of ``period`` is advised) optimised for
    the condition number of the base regressor (module docstring).

    Positions and velocities are linear in the coefficients, so each candidate is first scaled to
    use its position or velocity range to the full (``OPTIMIZER_MARGIN`` of it); the torque, the
    workspace and cond(J_p) then enter as a penalty 1e3 sum(min(margin, 0)^2) on log cond, minimised by
    ``scipy.optimize.minimize`` (L-BFGS-B, finite-difference gradient) from a seeded random start.

    Args:
        theta: the nominal parameters (the torque limit's torques).
        samples: points of one period the cost and the constraints are evaluated at.
        max_iterations: the optimiser's iterations.
        alpha0: the start and centre (default: the robot's home).

    Returns:
        (the trajectory, a summary: ``condition`` of the start and of the result,
        ``iterations``, the optimiser's ``message``).

    Raises:
        InvalidParameterError: no feasible excitation was found (every start violates a limit).
    """
    from scipy.optimize import minimize

    robot = regressor.robot
    dof = robot.dof
    lim = default_limits(robot, limits)
    alpha0 = robot.home.copy() if alpha0 is None else np.asarray(alpha0, dtype=float)
    t = np.linspace(0.0, period, samples, endpoint=False)
    fine = np.linspace(0.0, period, 20 * samples, endpoint=False)  # the scaling's peaks
    checked = dict(lim)
    for key in ("torque", "jacobian"):
        checked[key] = OPTIMIZER_MARGIN * lim[key]
    evaluate = _Evaluator(regressor, base, theta, t, checked)
    rng = np.random.default_rng(seed)

    def unpack(x):
        a = np.zeros((dof, harmonics))
        a[:, 1:] = x[: dof * (harmonics - 1)].reshape(dof, harmonics - 1)
        b = x[dof * (harmonics - 1) :].reshape(dof, harmonics)
        trajectory = FourierExcitation(alpha0, a, b, period, duration)
        alpha, alpha_dot, _ = trajectory.evaluate(fine)
        use = max(
            float((np.abs(alpha - alpha0).max(axis=0) / lim["position"]).max()),
            float((np.abs(alpha_dot).max(axis=0) / lim["velocity"]).max()),
            1e-12,
        )
        factor = OPTIMIZER_MARGIN / use
        return FourierExcitation(alpha0, trajectory.a * factor, trajectory.b * factor, period, duration)

    def cost(x):
        cond, margins = evaluate(unpack(x))
        return float(np.log(cond) + 1e3 * (np.minimum(margins, 0.0) ** 2).sum())

    k = np.arange(1, harmonics + 1)
    start, best_cost = None, np.inf
    for _ in range(8):  # the best of a few random starts, the k-th harmonic's size ~ k^-1.5
        amplitude = 1.0 / k[None, :] ** 1.5
        a = rng.normal(0.0, 1.0, (dof, harmonics)) * amplitude
        b = rng.normal(0.0, 1.0, (dof, harmonics)) * amplitude
        candidate = np.concatenate([a[:, 1:].ravel(), b.ravel()])
        value = cost(candidate)
        if value < best_cost:
            start, best_cost = candidate, value
    initial = evaluate(unpack(start))
    result = minimize(cost, start, method="L-BFGS-B", options={"maxiter": max_iterations})
    trajectory = unpack(result.x)
    cond, margins = evaluate(trajectory)
    if margins.min() < -1e-9:
        trajectory = unpack(start)
        cond, margins = evaluate(trajectory)
    if margins.min() < -1e-9:
        worst = int(np.argmin(margins))
        raise InvalidParameterError(
            f"robot {robot.name!r}: no excitation about alpha0={np.round(alpha0, 4).tolist()} respects "
            "the limits "
            f"(workspace, velocity, torque, cond J_p; worst margin {margins[worst]:.3g} at check {worst}); "
            "start elsewhere or relax them"
        )
    return trajectory, {
        "condition_initial": float(initial[0]),
        "condition": float(cond),
        "iterations": int(result.nit),
        "message": str(result.message),
        "harmonics": harmonics,
        "period": period,
        "samples": samples,
    }


def check_excitation(
    regressor: ClosedChainRegressor,
    trajectory: FourierExcitation,
    theta: np.ndarray,
    *,
    limits: ExcitationLimits | None = None,
    rate: float = 1000.0,
) -> dict:
    """Check ``trajectory`` at ``rate`` [Hz] over its duration (module docstring).

    Returns:
        the largest |alpha - alpha0|, |alpha_dot|, |tau| (dof,) and cond(J_p) met.

    Raises:
        InvalidParameterError: the first time it leaves the workspace, crosses the singularity
            margin, or exceeds a limit, named.
    """
    robot = regressor.robot
    lim = default_limits(robot, limits)
    t = np.arange(0.0, trajectory.duration + 0.5 / rate, 1.0 / rate)
    alpha, alpha_dot, alpha_ddot = trajectory.evaluate(t)
    for name, value, bound in (
        ("|alpha - alpha0|", np.abs(alpha - trajectory.alpha0), lim["position"]),
        ("|alpha_dot|", np.abs(alpha_dot), lim["velocity"]),
    ):
        over = np.argwhere(value > bound * (1 + 1e-9))
        if over.size:
            k, j = over[0]
            raise InvalidParameterError(
                f"excitation exceeds {name} <= {bound[j]:g} on {robot.actuated_joints[j]} "
                f"at t = {t[k]:.3f} s "
                f"({value[k, j]:.4g})"
            )
    worst = 0.0
    tau_max = np.zeros(robot.dof)
    regressor._last_q = robot.reference_configuration.copy()
    for k in range(len(t)):
        try:
            Y = regressor.rows(alpha[k], alpha_dot[k], alpha_ddot[k])
        except AssemblyError:
            raise InvalidParameterError(
                f"excitation leaves the workspace at t = {t[k]:.3f} s: the loops do not close at "
                f"alpha = {np.round(alpha[k], 5).tolist()}"
            ) from None
        cond = _passive_condition(robot, regressor._last_q)
        if cond > lim["jacobian"]:
            raise InvalidParameterError(
                f"excitation comes near a singularity of the closures at t = {t[k]:.3f} s: "
                f"cond J_p = {cond:.4g} "
                f"> {lim['jacobian']:g} at alpha = {np.round(alpha[k], 5).tolist()}"
            )
        worst = max(worst, cond)
        tau = Y @ theta
        tau_max = np.maximum(tau_max, np.abs(tau))
        over = np.flatnonzero(np.abs(tau) > lim["torque"])
        if over.size:
            j = over[0]
            raise InvalidParameterError(
                f"excitation needs |tau| = {abs(tau[j]):.4g} > {lim['torque'][j]:g} "
                f"on {robot.actuated_joints[j]} "
                f"at t = {t[k]:.3f} s"
            )
    regressor._last_q = robot.reference_configuration.copy()
    return {
        "position": np.abs(alpha - trajectory.alpha0).max(axis=0).tolist(),
        "velocity": np.abs(alpha_dot).max(axis=0).tolist(),
        "torque": tau_max.tolist(),
        "jacobian_condition": worst,
    }

"""``delta-pin validate --robot PATH``: check a closed-chain robot's projected model where no
analytic model exists to compare with.

Five checks, each against an independent reference (docs/architecture.md section 10):

1. **closure** -- the largest closure residual of the assembled random states [m or rad];
2. **plant** -- the projected alpha_ddot = M^-1 (tau - C alpha_dot - G) against the core plant's
   accelerations by Pinocchio's ``constraintDynamics`` (a KKT solve on the whole tree) under
   random torques (relative);
3. **gravity** -- G against the derivative of the potential energy V(q(alpha)) (relative);
4. **Coriolis** -- C + C^T against the derivative of M along alpha_dot (M_dot = C + C^T, the
   skew-symmetry the designs rely on) (relative);
5. **energy** -- free motion (zero torque, no friction, joint dampers off, springs on) for
   ``energy_duration`` on the compiled core's plant -- the dynamics every run steps -- in full
   coordinates (Baumgarte-stabilised; idle motions,
   passive joints and a free base move with it): the drift of kinetic + gravity + spring energy
   relative to the largest kinetic energy, and the closure gap along it. The kinetic energy is
   0.5 v^T M v with every joint's armature (:func:`kinetic_energy`; Pinocchio 4.1's
   ``computeKineticEnergy`` leaves out that of unaligned revolute joints).

With idle motions (a rod spinning between two ball joints) the assembly path q(alpha) that checks
3 and 4 difference along also turns the idle motions, which the reduced model's velocity map S
does not; where gravity acts on an idle motion (a spinning body's centre of mass off its spin
axis) or M depends on its angle, the differences see that too. Those parts are measured by
differences along the idle motions and taken out, and the report names the idle motions gravity
acts on and the size of that torque (:class:`_Idle`): physics, not a failure.

With ``frame=`` (``delta-pin validate --frame NAME``) two more checks test that frame's
closed-loop kinematics: J_x against the derivative of its position, and J_x_dot alpha_dot against
the derivative of J_x along alpha_dot.

Where the robot carries the paper's analytic model (``robot.delta``: the robot of ``load_delta``,
a Delta recognised in any file), the report adds its M, C alpha_dot and G (eqs. 7-9) against the
projection at the same states, to the recognition's tolerance (relative 1e-9): one validator for
the Delta and every other robot (``delta-pin validate`` without ``--robot`` keeps the analytic
model's own, lighter table: IK/FK, J and J_dot by differences, M, C alpha_dot, G).

An underactuated robot (passive joints, a free base) has no reduced model: checks 2-4 are then
not run, and the report says so; the closure and energy checks still are. The report's notes
open with the robot's mobility classification (:meth:`ClosedChainRobot.summary`).

Every check that rests on an approximation reports an error estimate of that approximation
beside its measured value, and fails only where the discrepancy exceeds the tolerance plus the
estimate (times a stated safety factor):

* the derivatives (checks 3 and 4) are central differences at h and h/2 with one Richardson
  extrapolation (:func:`richardson_derivative`), the step h taken from the scale of the argument
  and the rounding level of the differenced quantity; the estimate is the truncation estimate
  |D(h) - D(h/2)| / 3 plus a round-off bound, and a state fails only where the discrepancy
  exceeds :data:`DERIVATIVE_SAFETY` times the estimate plus the tolerance;
* the free motion is integrated by scipy's DOP853 at rtol = :data:`ENERGY_RTOL`, atol =
  :data:`ENERGY_ATOL` (or, with ``dt=``, by RK4 at that fixed step); the estimate of the drift's
  integration error is the difference from the same run at 10x tighter tolerances (or at dt/2),
  plus the rounding of the energy itself, and the check fails only where the drift exceeds the
  tolerance plus that estimate.

The report also gives the conditioning cond(J_p) of the closure Jacobian on the passive joints
(the matrix every projection solves with) over the checked states and the free motion.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from delta_pin.errors import AssemblyError, InvalidParameterError, SimulationError
from delta_pin.model.closed_chain import ClosedChainRobot
from delta_pin.model.delta_recognition import RELATIVE_TOLERANCE as ANALYTIC_TOLERANCE
from delta_pin.model.inertials import MASSLESS_RATIO, massless_bodies
from delta_pin.sim.closed_chain_plant import ClosedChainPlant
from delta_pin.sim.integrators import rk4_step

__all__ = [
    "ClosedChainValidation",
    "Derivative",
    "kinetic_energy",
    "passive_conditioning",
    "richardson_derivative",
    "validate_closed_chain",
]

EPS = float(np.finfo(float).eps)
DERIVATIVE_SAFETY = 10.0  # the derivative estimates are orders of magnitude (asymptotic truncation, a
# rounding level), not bounds: a discrepancy fails only beyond ten times its estimate (plus tol)
DEFAULT_TOL = 1e-6  # relative tolerance of the gravity, Coriolis and energy checks
ENERGY_RTOL, ENERGY_ATOL = 1e-10, 1e-12  # DOP853 on [q, v] (rad or m, rad/s or m/s)
ENERGY_SAMPLES = 100  # the energy is read at least this often along the free motion (max_step)
MAX_FIXED_STEPS = 1_000_000  # a fixed-step energy run longer than this (and its half-step twin) is refused
# bounds on the work validate is asked for, refused in one line before any: the energy check's
# free motion (error-controlled, its cost grows with its length; the default 0.5 s) and the states
MAX_ENERGY_DURATION = 60.0  # [s]
MAX_SAMPLES = 100_000
ASSEMBLY_TOL = 1e-14  # [m or rad] the differenced states are assembled this tightly where they can be
NEARER_DRAWS = (
    10  # a random state that does not assemble is drawn again this many times, each halfway nearer home
)
IDLE_DRIFT_SHOWN = 1e-9  # the idle notes appear where the assembly path moves an idle motion more than
# this per unit of alpha (a symmetric rod's spin: 1e-22, rounding; an off-axis one: order 1)


@dataclass(frozen=True)
class Derivative:
    """A derivative with its error estimate (:func:`richardson_derivative`).

    Attributes:
        value: the extrapolated derivative (the shape of f's values) [f's units per x's unit].
        error: the estimated absolute error, largest over the entries: truncation + round_off.
        truncation: |D(h) - D(h/2)| / 3, the truncation error estimate of D(h/2).
        round_off: 3 delta / h, where delta bounds the error of one value of f (the larger of the
            stated rounding level and the level measured by the fourth difference of the five values).
        step: h [x's unit].
    """

    value: np.ndarray
    error: float
    truncation: float
    round_off: float
    step: float


def richardson_derivative(
    f: Callable[[float], np.ndarray | float],
    x: float = 0.0,
    *,
    scale: float = 1.0,
    noise: float = EPS,
    center: np.ndarray | float | None = None,
) -> Derivative:
    """df/dx at x by central differences D(h), D(h/2) and one Richardson extrapolation
    (4 D(h/2) - D(h)) / 3, with an error estimate.

    The step is h = cbrt(noise) * max(scale, |x|), the balance of truncation (~ h^2) and round-off
    (~ noise / h) for a function that changes by its own size over ``scale``. The error estimate
    is the truncation estimate |D(h) - D(h/2)| / 3 (of D(h/2); the extrapolated value is better
    by an order of h^2) plus the round-off bound 3 delta / h of the extrapolation, where delta, the
    error of one value of f, is the larger of ``noise`` * max|f| and the noise that the fourth
    difference of f at x - h, x - h/2, x, x + h/2, x + h shows (std sqrt(70) sigma for independent
    errors), plus the rounding of the arguments, eps |x| max|df/dx|.

    Args:
        f: a smooth function of one variable, scalar or array valued.
        x: the point [x's unit].
        scale: the distance [x's unit] over which f changes by its own size (1 rad for a function
            of an angle).
        noise: the relative rounding level of f's values (>= machine epsilon), e.g. eps times the
            condition number of a linear solve inside f.
        center: f(x) if already known (one evaluation fewer).

    Raises:
        InvalidParameterError: a non-finite or non-positive ``scale`` or ``noise``, or non-finite x.
    """
    if not (math.isfinite(x) and math.isfinite(scale) and scale > 0.0):
        raise InvalidParameterError(f"x={x!r} must be finite and scale={scale!r} a finite distance > 0")
    if not (math.isfinite(noise) and noise > 0.0):
        raise InvalidParameterError(f"noise={noise!r} must be a finite relative rounding level > 0")
    noise = max(noise, EPS)
    h = math.cbrt(noise) * max(scale, abs(x))
    h = (x + h) - x  # a step that x + h represents exactly
    values = [np.asarray(f(x + s * h), dtype=float) for s in (-1.0, -0.5, 0.5, 1.0)]
    middle = np.asarray(f(x) if center is None else center, dtype=float)
    minus, half_minus, half_plus, plus = values
    coarse = (plus - minus) / (2.0 * h)
    fine = (half_plus - half_minus) / h
    value = (4.0 * fine - coarse) / 3.0
    fourth = minus - 4.0 * half_minus + 6.0 * middle - 4.0 * half_plus + plus
    largest = max(float(np.abs(v).max()) for v in (*values, middle))
    delta = max(noise * largest, float(np.abs(fourth).max()) / math.sqrt(70.0))
    delta += EPS * abs(x) * float(np.abs(value).max())
    truncation = float(np.abs(coarse - fine).max()) / 3.0
    round_off = 3.0 * delta / h
    return Derivative(
        value=value if value.ndim else float(value),
        error=truncation + round_off,
        truncation=truncation,
        round_off=round_off,
        step=h,
    )


@dataclass
class ClosedChainValidation:
    """The checks' results.

    Attributes:
        robot: the robot's name.
        states: the assembled random states the checks ran at.
        checks: name -> (measured, tolerance, what it measures).
        estimates: name -> (error estimate of the measured value, in its units; safety factor) for
            the checks that approximate: such a check passes while measured <= tolerance + factor *
            estimate.
        conditioning: (smallest, largest) cond(J_p) over the states and the free motion.
        conditioning_parts: where -> (smallest, largest) cond(J_p): ``"at the states"``,
            ``"along the free motion"``.
        notes: lines that say how the approximations were made.
    """

    robot: str
    states: int
    checks: dict[str, tuple[float, float, str]] = field(default_factory=dict)
    estimates: dict[str, tuple[float, float]] = field(default_factory=dict)
    conditioning: tuple[float, float] | None = None
    conditioning_parts: dict[str, tuple[float, float]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def check_passed(self, name: str) -> bool:
        """Whether check ``name`` passed: measured <= tolerance (+ factor * estimate where it has one)."""
        value, tol, _ = self.checks[name]
        estimate, factor = self.estimates.get(name, (0.0, 0.0))
        return bool(value <= tol + factor * estimate)

    @property
    def passed(self) -> bool:
        return all(self.check_passed(name) for name in self.checks)

    def table(self) -> str:
        lines = [
            f"{self.robot}: {self.states} assembled random states",
            f"{'check':<10} {'measured':>11}  {'estimate':>13}  {'tol':>8}  ",
        ]
        for name, (value, tol, what) in self.checks.items():
            verdict = "ok" if self.check_passed(name) else "FAILED"
            if name in self.estimates:
                estimate, factor = self.estimates[name]
                shown = f"{estimate:.1e} x{factor:g}"
            else:
                shown = "-"
            lines.append(f"{name:<10} {value:>11.3e}  {shown:>13}  {tol:>8.0e}  {verdict:<6} {what}")
        lines.extend(self.notes)
        if self.conditioning is not None:
            parts = self.conditioning_parts or {"all": self.conditioning}
            ranges = ", ".join(f"{low:.3g} to {high:.3g} {where}" for where, (low, high) in parts.items())
            lines.append(f"cond(J_p) of the passive closure Jacobian: {ranges}")
        lines.append("all checks passed" if self.passed else "some checks FAILED")
        return "\n".join(lines)


def passive_conditioning(robot: ClosedChainRobot, q: np.ndarray) -> float:
    """cond(J_p): the largest over the smallest nonzero singular value of the closure Jacobian on
    the passive joints at q (nonzero: above max(shape) eps times the largest, numpy's rank rule;
    so an idle motion's exact null direction does not count, a near-singular pose does)."""
    J = robot.closure_jacobian(q)[:, robot.passive_indices]
    if J.size == 0:
        return 1.0
    s = np.linalg.svd(J, compute_uv=False)
    if not s[0] > 0.0:
        return math.inf
    nonzero = s[s > s[0] * max(J.shape) * EPS]
    return float(nonzero[0] / nonzero[-1])


class _Evaluations:
    """The differenced states q(alpha) and M(alpha) there, assembled to :data:`ASSEMBLY_TOL` while
    Newton gets there (a robot whose rounding floor lies above it falls back to the default tol)."""

    def __init__(self, robot: ClosedChainRobot) -> None:
        self.robot = robot
        self.tight = True

    def assemble(self, alpha: np.ndarray, guess: np.ndarray) -> np.ndarray:
        if self.tight:
            try:
                return self.robot.configuration(alpha, initial_guess=guess, tol=ASSEMBLY_TOL)
            except AssemblyError:
                self.tight = False
        return self.robot.configuration(alpha, initial_guess=guess)

    def inertia(self, alpha: np.ndarray, guess: np.ndarray) -> np.ndarray:
        """M = S^T M_tree S (dof, dof) [SI] at alpha [rad or m]."""
        return self.inertia_at(self.assemble(alpha, guess))

    def inertia_at(self, q: np.ndarray) -> np.ndarray:
        """M = S^T M_tree S (dof, dof) [SI] at the configuration q."""
        S = self.robot.velocity_map(q)
        M = S.T @ self.robot.mass_matrix(q) @ S
        return 0.5 * (M + M.T)


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-9))


@dataclass
class _Worst:
    """The state nearest to failing a derivative check: (relative discrepancy, relative estimate)."""

    ratio: float = -1.0
    value: float = 0.0
    estimate: float = 0.0

    def add(self, discrepancy: float, estimate: float, scale: float, tol: float) -> None:
        value, estimate = discrepancy / scale, estimate / scale
        ratio = value / (tol + DERIVATIVE_SAFETY * estimate)
        if ratio > self.ratio:
            self.ratio, self.value, self.estimate = ratio, value, estimate


@dataclass
class _Idle:
    """The idle motions at one state, as the gravity check finds them (robots with ``idle_dof``).

    The assembly path q(alpha + s e_i) is one closure-consistent path; its tangent is S e_i plus
    some idle motion N X e_i (Newton's minimum-norm steps, not the reduced model's least kinetic
    energy map S). Differences along it therefore see the idle motions too: dV/dalpha = G +
    X^T N^T g, and dM/ds changes M along N X u as well, where N^T g is gravity's torque on the
    idle motions (nonzero where a spinning body's centre of mass is off its spin axis: physics,
    not a bug). The checks take those parts out, each measured by its own differences."""

    basis: np.ndarray  # N (nv, idle_dof): robot.idle_motions(q), columns scaled to unit length
    drift: np.ndarray  # X (idle_dof, dof): the idle motion per unit alpha_i along the assembly path
    drift_error: float  # estimate of X's largest error
    torque: np.ndarray  # N^T g (idle_dof,): gravity's torque on each idle motion (unit columns) [N m]


def _gravity_discrepancy(
    evaluations: _Evaluations, alpha: np.ndarray, q: np.ndarray, G: np.ndarray, noise: float
) -> tuple[float, float, float, _Idle | None]:
    """G against G_i = dV/dalpha_i along each unit coordinate [rad or m] (scale 1): (largest
    discrepancy, its error estimate, the scale: the larger of |G| and 1e-9) [N m or N], and with
    idle motions what the assembly path does to them (:class:`_Idle`): then the reference is
    dV/dalpha_i - X_i^T dV/dn (dV/dn: V differenced along each idle motion n, an independent
    measure of N^T g, which is compared as well)."""
    robot = evaluations.robot
    model, data = robot.model, robot.data
    V = robot.potential_energy(q)
    reference = np.empty(robot.dof)
    tangents = np.zeros((model.nv, robot.dof))  # dq/dalpha_i along the assembly path
    error = tangent_error = 0.0
    for i, e in enumerate(np.eye(robot.dof)):
        states: dict[float, np.ndarray] = {}  # one assembly per step, for V and for q

        def assembled(s: float, e=e, states=states) -> np.ndarray:
            if s not in states:
                states[s] = evaluations.assemble(alpha + s * e, q)
            return states[s]

        d = richardson_derivative(lambda s: robot.potential_energy(assembled(s)), center=V, noise=noise)
        reference[i] = d.value
        error = max(error, d.error)
        if robot.idle_dof:
            t = richardson_derivative(
                lambda s: pin.difference(model, q, assembled(s)), center=np.zeros(model.nv), noise=noise
            )
            tangents[:, i] = t.value
            tangent_error = max(tangent_error, t.error)
    idle = None
    if robot.idle_dof:
        N = robot.idle_motions(q)
        N = N / np.linalg.norm(N, axis=0)  # unit columns: N^T g is a torque per rad/s of joint velocity
        N_pinv = np.linalg.pinv(N)
        X = N_pinv @ (tangents - robot.velocity_map(q))
        drift_error = float(np.abs(N_pinv).sum(axis=1).max()) * tangent_error
        torque = N.T @ pin.computeGeneralizedGravity(model, data, q)
        measured = np.empty(robot.idle_dof)
        torque_error = 0.0
        for k, n in enumerate(N.T):
            d = richardson_derivative(
                lambda s, n=n: robot.potential_energy(pin.integrate(model, q, s * n)),
                center=V,
                noise=noise,
            )
            measured[k] = d.value
            torque_error = max(torque_error, d.error)
        reference = reference - X.T @ measured
        error += float(np.abs(X).sum(axis=0).max()) * torque_error  # of dV/dn, through X
        error += drift_error * float(np.abs(measured).sum())  # of X, through dV/dn
        idle = _Idle(N, X, drift_error, torque)
        scale = max(float(np.abs(reference).max()), float(np.abs(G).max()), float(np.abs(torque).max()), 1e-9)
        discrepancy = max(float(np.abs(G - reference).max()), float(np.abs(torque - measured).max()))
        return discrepancy, error, scale, idle
    scale = max(float(np.abs(reference).max()), float(np.abs(G).max()), 1e-9)
    return float(np.abs(G - reference).max()), error, scale, None


def _coriolis_discrepancy(
    evaluations: _Evaluations,
    alpha: np.ndarray,
    alpha_dot: np.ndarray,
    q: np.ndarray,
    M: np.ndarray,
    C: np.ndarray,
    noise: float,
    idle: _Idle | None = None,
) -> tuple[float, float, float]:
    """C + C^T against M_dot = |alpha_dot| dM/ds along the unit direction u = alpha_dot / |alpha_dot|
    (scale 1 rad or m): (largest discrepancy, its error estimate, the scale: the larger of |M_dot|
    and |M| |alpha_dot|, per rad or m, where M hardly changes) [M's units per s]. With idle
    motions, less dM/ds along the idle motion N X u the assembly path adds (:class:`_Idle`)."""
    speed = float(np.linalg.norm(alpha_dot))
    if speed == 0.0:
        return float(np.abs(C + C.T).max()), 0.0, max(float(np.abs(M).max()), 1e-300)
    u = alpha_dot / speed
    d = richardson_derivative(
        lambda s: evaluations.inertia(alpha + s * u, q),
        center=evaluations.inertia(alpha, q),
        noise=noise,
    )
    M_dot, error = speed * d.value, speed * d.error
    if idle is not None and np.any(idle.drift @ u):
        w = idle.basis @ (idle.drift @ u)  # the idle motion along the path [per rad or m of s]
        model = evaluations.robot.model
        d_idle = richardson_derivative(
            lambda s: evaluations.inertia_at(pin.integrate(model, q, s * w)),
            center=evaluations.inertia_at(q),
            noise=noise,
        )
        M_dot = M_dot - speed * d_idle.value
        w_error = float(np.abs(idle.basis).sum(axis=1).max()) * idle.drift_error * float(np.abs(u).sum())
        relative_w_error = w_error / float(np.abs(w).max())
        error += speed * (d_idle.error + float(np.abs(d_idle.value).max()) * relative_w_error)
    scale = max(float(np.abs(M_dot).max()), float(np.abs(M).max()) * float(np.abs(alpha_dot).max()))
    return float(np.abs(C + C.T - M_dot).max()), error, scale


def _checked_frame(robot: ClosedChainRobot, frame: str) -> int:
    """The id of the frame ``validate --frame`` checks.

    Raises:
        InvalidParameterError: no such frame (one line with the frames that exist), or an idle motion
            moves its origin (the actuated joints do not determine where it is).
    """
    fid = robot.frame_id(frame)
    if robot.idle_dof:
        q = robot.reference_configuration
        pin.computeJointJacobians(robot.model, robot.data, q)
        pin.updateFramePlacements(robot.model, robot.data)
        J = pin.getFrameJacobian(robot.model, robot.data, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        if np.abs(J[:3] @ robot.idle_motions(q)).max() > 1e-9:
            raise InvalidParameterError(
                f"{robot.name!r}: frame {frame!r} moves with the idle motions, so the actuated joints do not "
                "determine where it is: choose a frame the motors place"
            )
    return fid


def _frame_discrepancies(
    evaluations: _Evaluations, alpha: np.ndarray, alpha_dot: np.ndarray, q: np.ndarray, fid: int, noise: float
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """The frame's J_x (3, dof) against the derivative of its position along each alpha_i [m per
    rad or m], and J_x_dot alpha_dot (3,) against |alpha_dot| dJ_x/ds alpha_dot along u =
    alpha_dot / |alpha_dot| [m/s^2], both on the assembly path (an idle motion, which moves
    the frame's origin nowhere, changes neither): ((discrepancy, estimate, scale), ...), each
    scale the larger of the two sides (J_dot: and |J_x| |alpha_dot|^2) and 1e-9."""
    robot = evaluations.robot
    model, data = robot.model, robot.data

    def position(a: np.ndarray) -> np.ndarray:
        q_a = evaluations.assemble(a, q)
        pin.framesForwardKinematics(model, data, q_a)
        return data.oMf[fid].translation.copy()

    def jacobian(a: np.ndarray) -> np.ndarray:
        return robot.frame_jacobian(evaluations.assemble(a, q), fid)[:3]

    J = jacobian(alpha)
    reference = np.empty_like(J)
    error = 0.0
    center = position(alpha)
    for i, e in enumerate(np.eye(robot.dof)):
        d = richardson_derivative(lambda s, e=e: position(alpha + s * e), center=center, noise=noise)
        reference[:, i] = d.value
        error = max(error, d.error)
    scale = max(float(np.abs(reference).max()), float(np.abs(J).max()), 1e-9)
    found_J = (float(np.abs(J - reference).max()), error, scale)
    drift = robot.frame_acceleration_drift(evaluations.assemble(alpha, q), alpha_dot, fid)
    speed = float(np.linalg.norm(alpha_dot))
    if speed == 0.0:
        return found_J, (float(np.abs(drift).max()), 0.0, 1e-9)
    u = alpha_dot / speed
    d = richardson_derivative(lambda s: jacobian(alpha + s * u), center=J, noise=noise)
    expected = speed * d.value @ alpha_dot
    scale = max(
        float(np.abs(expected).max()),
        float(np.abs(drift).max()),
        float(np.abs(J).max()) * float(np.abs(alpha_dot).max()) ** 2,
        1e-9,
    )
    return found_J, (
        float(np.abs(drift - expected).max()),
        speed * d.error * float(np.abs(alpha_dot).sum()),
        scale,
    )


def _check_options(samples, seed, spread, energy_duration, tol, dt) -> None:
    if not 1 <= samples <= MAX_SAMPLES:
        raise InvalidParameterError(f"samples={samples} must be >= 1 and <= {MAX_SAMPLES}")
    if not (isinstance(seed, int | np.integer) and not isinstance(seed, bool) and seed >= 0):
        raise InvalidParameterError(f"seed={seed!r} must be an integer >= 0")
    if not (spread > 0.0 and math.isfinite(spread)):
        raise InvalidParameterError(f"spread={spread} must be a finite number > 0 [rad or m]")
    if not (energy_duration > 0.0 and math.isfinite(energy_duration)):
        raise InvalidParameterError(
            f"energy_duration={energy_duration} (--duration) must be a finite number of seconds > 0, e.g. 0.5"
        )
    if energy_duration > MAX_ENERGY_DURATION:
        raise InvalidParameterError(
            f"energy_duration={energy_duration:g} s (--duration) is longer than the "
            f"{MAX_ENERGY_DURATION:g} s the energy check takes (its free motion's cost grows with its "
            f"length): give at most {MAX_ENERGY_DURATION:g}, e.g. the default 0.5"
        )
    if not (math.isfinite(tol) and tol > 0.0):
        raise InvalidParameterError(
            f"tol={tol!r} must be a finite relative tolerance > 0 (e.g. the default {DEFAULT_TOL:g})"
        )
    if dt is None:
        return
    shortest = energy_duration / MAX_FIXED_STEPS
    if not (isinstance(dt, int | float) and math.isfinite(dt) and shortest <= dt <= energy_duration):
        raise InvalidParameterError(
            f"dt={dt!r} must be a fixed step in seconds with {shortest:g} <= dt <= energy_duration="
            f"{energy_duration:g} (at most {MAX_FIXED_STEPS:g} steps), e.g. 1e-4; or leave it out for "
            "the error-controlled integrator"
        )


def _random_state(robot: ClosedChainRobot, rng: np.random.Generator, spread: float):
    """One random state alpha = home + U(-spread, spread), alpha_dot ~ N(0, 0.5^2), and its
    assembly q; where the loops do not close there, the offset is halved (the same direction) up
    to :data:`NEARER_DRAWS` times, so that a home near the workspace's edge is still checked
    around it. Returns (alpha, alpha_dot, q or ``None`` if none assembles, halvings)."""
    offset = rng.uniform(-spread, spread, robot.dof)
    alpha_dot = rng.normal(0.0, 0.5, robot.dof)
    for halvings in range(NEARER_DRAWS + 1):
        alpha = robot.home + offset
        try:
            q = robot.configuration(alpha, initial_guess=robot.reference_configuration)
            return alpha, alpha_dot, q, halvings
        except AssemblyError:
            offset = 0.5 * offset
    return alpha, alpha_dot, None, NEARER_DRAWS


def validate_closed_chain(
    robot: ClosedChainRobot,
    samples: int = 20,
    seed: int = 0,
    spread: float = 0.1,
    energy_duration: float = 0.5,
    *,
    tol: float | None = None,
    dt: float | None = None,
    frame: str | None = None,
) -> ClosedChainValidation:
    """Run the five checks (module docstring) at ``samples`` random states alpha = home +
    U(-spread, spread) [rad or m], alpha_dot ~ N(0, 0.5^2) [rad/s or m/s]; a state whose loops
    do not close is drawn again halfway nearer home (up to :data:`NEARER_DRAWS` times, said in
    the report's notes).

    Args:
        energy_duration: the free motion's length [s].
        tol: relative tolerance of the gravity, Coriolis and energy checks (None: 1e-6).
        dt: a fixed RK4 step [s] for the free motion instead of the error-controlled DOP853.
        frame: also check this frame's closed-loop kinematics (``delta-pin validate --frame``):
            its Jacobian J_x (linear part of :meth:`ClosedChainRobot.frame_jacobian`) against the
            derivative of its position along each alpha_i, and J_x_dot alpha_dot
            (:meth:`ClosedChainRobot.frame_acceleration_drift`) against the derivative of J_x
            along alpha_dot: checks "frame J" and "frame Jdot" (relative, Richardson, like gravity).

    Raises:
        InvalidParameterError: bad ``samples``, ``seed``, ``spread``, ``energy_duration``, ``tol``
            or ``dt``; an unknown ``frame`` (with frames that exist), or one an idle motion moves.
        AssemblyError: no random state assembles (the home configuration is at the workspace edge).
    """
    tol = DEFAULT_TOL if tol is None else tol
    _check_options(samples, seed, spread, energy_duration, tol, dt)
    fid = None if frame is None else _checked_frame(robot, frame)
    rng = np.random.default_rng(seed)
    # the core's plant on Pinocchio's constraintDynamics (not its own axis-tree recursion): the
    # projection is checked against the library
    coordinates = "full" if robot.has_unactuated_motion else "active"
    plant = ClosedChainPlant(robot, coordinates=coordinates).build()
    plant.use_axis_tree(False)
    report = ClosedChainValidation(robot.name, 0)
    report.notes.append("robot: " + robot.summary().replace("\n", "\n  "))
    massless = massless_bodies(robot.model)
    if massless:  # what the checks cannot see (issue 35): a body that weighs nothing
        report.notes.append(
            "massless bodies: "
            + ", ".join(f"{label} ({mass:.3g} kg)" for label, mass in massless)
            + f" carry no mass (0, or < {MASSLESS_RATIO:g} of the robot's): the plant, gravity, coriolis "
            "and energy checks test nothing of their dynamics (closure and loop gap still see them), "
            "and a motion that moves only them has no inertia (a singular M fails the plant check)"
        )
    reduced = not robot.passive_joints  # an underactuated robot has no reduced model to check
    gaps, plant_errors, conditions = [], [], []
    gravity, coriolis_check = _Worst(), _Worst()
    frame_checks = {"frame J": _Worst(), "frame Jdot": _Worst()}
    analytic_errors: dict[str, float] = {}  # the analytic Delta's M, C alpha_dot, G (robot.delta)
    evaluations = _Evaluations(robot)
    idle_states: list[tuple[np.ndarray, _Idle, float]] = []  # (q, _Idle, max |G|) with idle motions
    nearer: list[float] = []  # the spreads of the states drawn nearer home
    for _ in range(samples):
        alpha, alpha_dot, q, halvings = _random_state(robot, rng, spread)
        if q is None:
            continue
        if halvings:
            nearer.append(float(np.abs(alpha - robot.home).max()))
        report.states += 1
        gaps.append(robot.closure_gap(q))
        condition = passive_conditioning(robot, q)
        conditions.append(condition)
        noise = min(
            EPS * condition, 1e-6
        )  # the rounding a solve with J_p amplifies; capped near a singularity
        if not reduced:
            continue
        M, C, G, coriolis = robot.reduced_terms(alpha, alpha_dot, q)
        if robot.delta is not None:  # the paper's analytic model against the projection
            analytic = robot.delta.analytic_dynamics(alpha, alpha_dot)
            for name, ours, theirs in (
                ("M", analytic.M, M),
                ("C a_dot", analytic.coriolis, coriolis),
                ("G", analytic.G, G),
            ):
                analytic_errors[name] = max(analytic_errors.get(name, 0.0), _relative(ours, theirs))
        tau = rng.normal(0.0, 1.0, robot.dof)
        v = robot.velocity_map(q) @ alpha_dot
        plant_alpha_ddot = plant.accelerations(q, v, tau, 0.0)[robot.actuated_indices]
        plant_errors.append(_relative(np.linalg.solve(M, tau - coriolis - G), plant_alpha_ddot))
        *discrepancy, idle = _gravity_discrepancy(evaluations, alpha, q, G, noise)
        gravity.add(*discrepancy, tol)
        if idle is not None:
            idle_states.append((q, idle, float(np.abs(G).max())))
        if robot.joint_springs:  # the dampers' S^T D S in C is not Coriolis: M_dot = C + C^T without it
            S = robot.velocity_map(q)
            C = C - S.T @ robot.joint_spring_forces(q)[1] @ S
        coriolis_check.add(*_coriolis_discrepancy(evaluations, alpha, alpha_dot, q, M, C, noise, idle), tol)
        if fid is not None:
            for name, found in zip(
                frame_checks, _frame_discrepancies(evaluations, alpha, alpha_dot, q, fid, noise)
            ):
                frame_checks[name].add(*found, tol)
        robot.configuration(alpha, initial_guess=q)  # leave the warm start here
    if report.states == 0:
        raise AssemblyError(
            f"{robot.name!r}: none of {samples} random states within {spread} of home={robot.home.tolist()} "
            f"assembles, nor any drawn {NEARER_DRAWS} times halfway nearer; "
            "lower spread= (validate_closed_chain), or assemble the robot elsewhere (home=, CLI --home)"
        )
    if nearer:
        report.notes.append(
            f"{len(nearer)} of {report.states} states were drawn nearer home (largest offset down to "
            f"{min(nearer):.2g} [rad or m]) because the loops do not close at their first draw within "
            f"{spread:g} of it: home lies near the edge of the workspace or a singularity (cond(J_p) "
            "below), or give a smaller spread"
        )
    report.checks["closure"] = (max(gaps), 1e-10, "largest closure residual of the states [m or rad]")
    if reduced:
        _reduced_model_checks(report, plant_errors, gravity, coriolis_check, tol)
        if idle_states:
            _idle_notes(report, robot, idle_states, tol)
        if fid is not None:
            what = {
                "frame J": f"{frame!r}: J_x vs its position's dx/dalpha, Richardson differences (relative)",
                "frame Jdot": f"{frame!r}: J_x_dot a_dot vs J_x's dJ_x/dt, Richardson differences (relative)",
            }
            for name, worst in frame_checks.items():
                report.checks[name] = (worst.value, tol, what[name])
                report.estimates[name] = (worst.estimate, DERIVATIVE_SAFETY)
    else:
        checks = "plant, gravity, coriolis" + (", frame" if fid is not None else "")
        report.notes.append(
            f"{checks}: not run: the robot is underactuated (passive joints "
            f"{', '.join(robot.passive_joints)}), so it has no reduced model"
        )
    for name, error in analytic_errors.items():
        report.checks[f"analytic {name}"] = (
            error,
            ANALYTIC_TOLERANCE,
            f"the paper's {name} (eqs. 7-9, robot.delta) vs the projection (relative)",
        )
    motion = _energy_drift(robot, energy_duration, rng, dt)
    report.checks["energy"] = (
        motion.drift,
        tol,
        f"energy drift over {energy_duration:g} s of free motion (relative to the largest kinetic energy)",
    )
    report.estimates["energy"] = (motion.estimate, 1.0)
    report.notes.append(f"energy: {motion.how}; fails beyond tol + estimate")
    report.checks["loop gap"] = (motion.gap, 1e-8, "largest closure gap along the free motion [m or rad]")
    report.conditioning_parts["at the states"] = (min(conditions), max(conditions))
    report.conditioning_parts["along the free motion"] = (min(motion.conditions), max(motion.conditions))
    everywhere = conditions + motion.conditions
    report.conditioning = (min(everywhere), max(everywhere))
    return report


def _reduced_model_checks(report, plant_errors, gravity, coriolis_check, tol: float) -> None:
    """Checks 2-4 of the module docstring into ``report``."""
    report.checks["plant"] = (
        max(plant_errors),
        1e-8,
        "projected alpha_ddot vs constraintDynamics (relative)",
    )
    report.checks["gravity"] = (gravity.value, tol, "G vs dV/dalpha, Richardson differences (relative)")
    report.estimates["gravity"] = (gravity.estimate, DERIVATIVE_SAFETY)
    report.checks["coriolis"] = (
        coriolis_check.value,
        tol,
        "C + C^T vs dM/dt, Richardson differences (relative)",
    )
    report.estimates["coriolis"] = (coriolis_check.estimate, DERIVATIVE_SAFETY)
    report.notes.append(
        f"gravity, coriolis: the state nearest to failing; fails beyond tol + {DERIVATIVE_SAFETY:g} x "
        "estimate (truncation + round-off of the differences)"
    )


def kinetic_energy(model: pin.Model, data: pin.Data, q: np.ndarray, v: np.ndarray) -> float:
    """0.5 v^T M(q) v [J], M from ``pin.crba`` (upper triangle, symmetrised here).

    CRBA adds ``model.armature`` (rotor inertia) to M's diagonal for every joint type, so this is
    the energy of the dynamics the plant integrates (``constraintDynamics`` factors that M).
    ``pin.computeKineticEnergy`` is not: Pinocchio 4.1 drops the armature of unaligned revolute
    joints (``JointModelRevoluteUnaligned``, a hinge whose axis is not x, y or z), so a correct
    robot with such a rotor would drift by 0.5 armature v_i^2. Matches MuJoCo's ``energy[1]``
    to rounding (tests/sim/test_validate_wolf.py)."""
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    return 0.5 * float(v @ M @ v)


def _idle_notes(report, robot: ClosedChainRobot, idle_states: list, tol: float) -> None:
    """Notes on the idle motions the gravity and Coriolis checks took out (:class:`_Idle`)."""
    drift = max(float(np.abs(idle.drift).max()) for _, idle, _ in idle_states)
    if drift <= IDLE_DRIFT_SHOWN:
        return
    report.notes.append(
        f"gravity, coriolis: the assembly path also turns the idle motion(s) (up to {drift:.3g} rad per rad "
        "or m of alpha), which the reduced model's S does not: dV/dalpha less that turn times dV along "
        "each idle motion, and dM/ds less M's change along it, are compared"
    )
    q, idle, largest_G = max(idle_states, key=lambda state: float(np.abs(state[1].torque).max()))
    torque = float(np.abs(idle.torque).max())
    if torque <= tol * max(largest_G, 1e-9):
        return
    joints = robot.classification(q)["idle"]
    acted = [" + ".join(joints[k]) for k in np.flatnonzero(np.abs(idle.torque) > tol * max(largest_G, 1e-9))]
    report.notes.append(
        f"gravity acts on idle motion(s) {', '.join(acted)}: torque up to {torque:.3g} N m (vs |G| up to "
        f"{largest_G:.3g}; a spinning body's centre of mass off its spin axis): physics, not an error; the "
        "reduced model holds at zero idle velocity, which gravity does not keep (the plant simulates it)"
    )


def _energy(robot: ClosedChainRobot, q: np.ndarray, v: np.ndarray) -> tuple[float, float]:
    """(kinetic + gravity + spring energy, kinetic energy) [J]; kinetic with every joint's armature
    (:func:`kinetic_energy`)."""
    kinetic = kinetic_energy(robot.model, robot.data, q, v)
    return kinetic + robot.potential_energy(q), kinetic


@dataclass
class _FreeMotion:
    drift: float  # largest |E(t) - E(0)| / largest kinetic energy
    estimate: float  # estimated integration error of drift, plus the rounding of E
    gap: float  # largest closure gap [m or rad]
    conditions: list[float]  # cond(J_p) along the motion
    how: str  # the integrator and the estimate, in words


def _free_motion(
    robot: ClosedChainRobot,
    alpha_dot: np.ndarray,
    duration: float,
    step: float | None,
    rtol: float,
    atol: float,
) -> tuple[float, float, float, list[float]]:
    """One run from home at alpha_dot: (drift, the rounding of E relative to the same scale, gap,
    cond(J_p) at about ENERGY_SAMPLES points)."""
    plant = ClosedChainPlant(robot, coordinates="full", joint_damping=False)  # conservative
    x0 = plant.initial_state(robot.home, alpha_dot)
    compiled = plant.build()  # its dynamics: the core's, as every run's
    nq, n = robot.model.nq, robot.dof
    zero = np.zeros(n)

    def derivative(t: float, y: np.ndarray) -> np.ndarray:
        return compiled.derivative(y, zero, 0.0)  # the nominal truth: no table, any row

    q = robot.reference_configuration
    energy0 = None
    largest_kinetic = largest_terms = drift = gap = 0.0
    conditions = []

    def record(k: int, x: np.ndarray, every: int) -> None:
        nonlocal q, energy0, largest_kinetic, largest_terms, drift, gap
        q, v = x[:nq], x[nq:]
        energy, kinetic = _energy(robot, q, v)
        energy0 = energy if energy0 is None else energy0
        largest_kinetic = max(largest_kinetic, kinetic)
        largest_terms = max(largest_terms, kinetic + abs(energy - kinetic))
        drift = max(drift, abs(energy - energy0))
        gap = max(gap, robot.closure_gap(q))
        if k % every == 0:
            conditions.append(passive_conditioning(robot, q))

    if step is None:
        from scipy.integrate import solve_ivp

        solution = solve_ivp(
            derivative,
            (0.0, duration),
            x0,
            method="DOP853",
            rtol=rtol,
            atol=atol,
            max_step=duration / ENERGY_SAMPLES,
        )
        if solution.status != 0:
            reached = float(solution.t[-1]) if len(solution.t) else 0.0
            raise SimulationError(f"the free motion's integration failed: {solution.message}", reached)
        every = max(1, len(solution.t) // ENERGY_SAMPLES)
        for k, x in enumerate(solution.y.T):
            record(k, x, every)
    else:
        steps = round(duration / step)
        every = max(1, steps // ENERGY_SAMPLES)
        x = x0
        record(0, x, every)
        for k in range(steps):
            x = rk4_step(derivative, k * step, x, step)
            record(k + 1, x, every)
    scale = max(largest_kinetic, 1e-12)
    return drift / scale, 2.0 * EPS * largest_terms / scale, gap, conditions


def _energy_drift(robot: ClosedChainRobot, duration: float, rng, dt: float | None = None) -> _FreeMotion:
    """Free motion from home with a random velocity on the plant in full coordinates where the
    joints allow (a passive mechanism may swing through a configuration where the actuated
    coordinates do not determine the rest), else in active coordinates; Baumgarte's corrector keeps
    the loops closed (no projection). DOP853 at (ENERGY_RTOL, ENERGY_ATOL), its error estimated by
    the run at 10x tighter tolerances; or RK4 at ``dt`` [s], estimated by the run at dt / 2; either
    estimate plus the rounding of the energy itself."""
    alpha_dot = rng.normal(0.0, 0.5, robot.dof)
    if dt is None:
        drift, rounding, gap, conditions = _free_motion(
            robot, alpha_dot, duration, None, ENERGY_RTOL, ENERGY_ATOL
        )
        tighter = _free_motion(robot, alpha_dot, duration, None, ENERGY_RTOL / 10, ENERGY_ATOL / 10)[0]
        how = (
            f"DOP853 at rtol={ENERGY_RTOL:g}, atol={ENERGY_ATOL:g}; estimate = |drift - drift at rtol="
            f"{ENERGY_RTOL / 10:g}, atol={ENERGY_ATOL / 10:g} ({tighter:.3e})|"
        )
    else:
        drift, rounding, gap, conditions = _free_motion(robot, alpha_dot, duration, dt, 0.0, 0.0)
        tighter = _free_motion(robot, alpha_dot, duration, dt / 2, 0.0, 0.0)[0]
        how = f"RK4 at dt={dt:g} s; estimate = |drift - drift at dt={dt / 2:g} s ({tighter:.3e})|"
    how += " + rounding 2 eps (K + |V|) / max K"
    return _FreeMotion(drift, abs(drift - tighter) + rounding, gap, conditions, how)

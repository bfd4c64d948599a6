"""Cross-check the paper's analytic model against the constrained Pinocchio model.

:func:`validate` samples random reachable poses and velocities and compares two independent
routes to each quantity:

=====================  =========================================================  ==========
check                  routes compared                                            tolerance
=====================  =========================================================  ==========
IK/FK round trip       FK(IK(xyz)) vs xyz                                         1e-12 m
FK closes Pin. loops   Pinocchio's closure gap at the analytic FK configuration    1e-12 m
J                      analytic J vs central finite differences of FK             1e-6 rel
J_dot alpha_dot        analytic vs central finite differences of J along alpha    1e-6 rel
M                      eq. 7 vs S^T M S of the Pinocchio tree                     ``tol`` rel
C alpha_dot            eq. 8 vs the Pinocchio projection                          ``tol`` rel
G                      eq. 9 (corrected sign) vs S^T g(q)                         ``tol`` rel
M SPD                  symmetry and smallest eigenvalue of M                      1e-12 rel
M_dot - 2C skew        symmetric part of M_dot - 2C (M_dot by central FD)         1e-6 rel
=====================  =========================================================  ==========

``tol`` (1e-10 by default) is the model-agreement tolerance of the issue: the lumped-mass robot
meets it to ~1e-15; a robot with ``forearm_inertia="rod"`` fails it, which is the real model error
of the paper's reduced model for that robot.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from delta_pin.errors import DeltaPinError, InvalidParameterError
from delta_pin.model import kinematics
from delta_pin.model.delta_robot import analytic_delta
from delta_pin.model.robot import Delta

__all__ = ["Check", "ValidationReport", "sample_states", "validate"]

FD_STEP = 1e-6  # [rad] central-difference step for J, J_dot alpha_dot and M_dot
FD_TOLERANCE = 1e-6  # relative, for finite-difference checks (truncation ~h^2, round-off ~1e-10)
GEOMETRY_TOLERANCE = 1e-12  # [m] for the round trips
MAX_JACOBIAN_CONDITION = 1e3  # samples closer to a singularity are redrawn


@dataclass
class Check:
    """One row of the validation table: worst absolute and relative error over the samples."""

    name: str
    tolerance: float
    relative: bool = True
    max_abs: float = 0.0
    max_rel: float = 0.0

    def update(self, computed: np.ndarray, reference: np.ndarray) -> None:
        error = float(np.linalg.norm(np.asarray(computed) - np.asarray(reference)))
        scale = float(np.linalg.norm(reference))
        self.max_abs = max(self.max_abs, error)
        self.max_rel = max(self.max_rel, error / scale if scale > 0.0 else error)

    def update_value(self, abs_error: float, rel_error: float) -> None:
        self.max_abs = max(self.max_abs, abs_error)
        self.max_rel = max(self.max_rel, rel_error)

    @property
    def error(self) -> float:
        """The error compared with the tolerance (relative or absolute)."""
        return self.max_rel if self.relative else self.max_abs

    @property
    def passed(self) -> bool:
        return bool(self.error <= self.tolerance)


@dataclass
class ValidationReport:
    """Result of :func:`validate`: one :class:`Check` per quantity."""

    robot: Delta
    samples: int
    seed: int
    checks: list[Check] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return all(check.passed for check in self.checks)

    def table(self) -> str:
        """A plain-text table of the checks (what ``delta-pin validate`` prints)."""
        lines = [
            f"{self.robot!r}",
            f"{self.samples} random reachable poses and velocities (seed {self.seed})",
            "",
            f"{'check':<22}{'max abs':>12}{'max rel':>12}{'tolerance':>12}   result",
            "-" * 68,
        ]
        for check in self.checks:
            kind = "rel" if check.relative else "abs"
            lines.append(
                f"{check.name:<22}{check.max_abs:>12.2e}{check.max_rel:>12.2e}"
                f"{check.tolerance:>8.0e} {kind}   {'ok' if check.passed else 'FAIL'}"
            )
        lines.append("")
        lines.append("all checks passed" if self.passed else "SOME CHECKS FAILED")
        return "\n".join(lines)


def sample_states(robot: Delta, samples: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Random reachable (alpha [rad], alpha_dot [rad/s]) pairs, each (samples, 3).

    Active angles are drawn in [-0.3, 1.2] rad, kept when FK and IK (elbow-out branch) both exist
    and cond(J) < 1e3 (drawn and filtered in batches); velocities are standard normal [rad/s].
    """
    if samples <= 0:
        raise InvalidParameterError(f"samples={samples} must be > 0")
    if not (isinstance(seed, int | np.integer) and not isinstance(seed, bool) and seed >= 0):
        raise InvalidParameterError(f"seed={seed!r} must be an integer >= 0")
    rng = np.random.default_rng(seed)
    params = robot.params
    kept, draws = [], 0
    while sum(len(batch) for batch in kept) < samples:
        if draws > 100 * samples + 1000:
            found = sum(len(batch) for batch in kept)
            raise DeltaPinError(
                f"found only {found} reachable poses in {draws} draws: is the geometry usable?"
            )
        candidates = rng.uniform(-0.3, 1.2, (max(2 * samples, 16), 3))
        draws += len(candidates)
        xyz, valid = kinematics.forward_kinematics_masked(params, candidates)
        xyz = xyz[valid & (xyz[:, 2] < 0.0)]
        try:
            alpha = kinematics.inverse_kinematics(params, xyz)
        except DeltaPinError:  # rare: keep the points one by one
            alpha = np.array([a for a in (_ik_or_none(params, p) for p in xyz) if a is not None]).reshape(
                -1, 3
            )
        if len(alpha) == 0:
            continue
        conditioned = np.linalg.cond(kinematics.jacobian(params, alpha)) < MAX_JACOBIAN_CONDITION
        kept.append(alpha[conditioned])
    alphas = np.concatenate(kept)[:samples]
    return alphas, rng.standard_normal((samples, 3))


def _ik_or_none(params, xyz: np.ndarray) -> np.ndarray | None:
    try:
        return kinematics.inverse_kinematics(params, xyz)
    except DeltaPinError:
        return None


def _errors(computed: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """Largest absolute error over the samples and largest error relative to each sample's norm."""
    axes = tuple(range(1, np.ndim(reference)))
    error = np.sqrt(np.sum((np.asarray(computed) - reference) ** 2, axis=axes))
    scale = np.sqrt(np.sum(np.asarray(reference) ** 2, axis=axes))
    relative = np.where(scale > 0.0, error / np.where(scale > 0.0, scale, 1.0), error)
    return float(error.max()), float(relative.max())


def validate(robot: Delta, samples: int = 100, seed: int = 0, tol: float = 1e-10) -> ValidationReport:
    """Compare the analytic and Pinocchio models at random states (see the module docstring).

    The analytic side and the finite differences are evaluated for all samples at once; the
    Pinocchio side is the projected model of the closed-chain robot of the same URDF
    (:meth:`~delta_pin.model.closed_chain.ClosedChainRobot.reduced_dynamics`), state by state.

    Args:
        robot: the robot to check.
        samples: number of random reachable states.
        seed: seed of the random generator.
        tol: relative tolerance of the M, C alpha_dot and G agreement.
    """
    robot = analytic_delta(robot)
    if not tol > 0.0:
        raise InvalidParameterError(f"tol={tol} must be > 0")
    report = ValidationReport(robot, samples, seed)
    checks = {
        "round_trip": Check("IK/FK round trip", GEOMETRY_TOLERANCE, relative=False),
        "closure": Check("FK closes Pin. loops", GEOMETRY_TOLERANCE, relative=False),
        "J": Check("J vs FD", FD_TOLERANCE),
        "Jdot": Check("J_dot a_dot vs FD", FD_TOLERANCE),
        "M": Check("M", tol),
        "coriolis": Check("C a_dot", tol),
        "G": Check("G", tol),
        "spd": Check("M SPD", GEOMETRY_TOLERANCE),
        "skew": Check("M_dot - 2C skew", FD_TOLERANCE),
    }
    report.checks = list(checks.values())
    p, h = robot.params, FD_STEP
    alpha, alpha_dot = sample_states(robot, samples, seed)

    # analytic side, all samples at once
    xyz = kinematics.forward_kinematics(p, alpha)
    checks["round_trip"].update_value(
        *_errors(kinematics.forward_kinematics(p, kinematics.inverse_kinematics(p, xyz)), xyz)
    )
    J = kinematics.jacobian(p, alpha, xyz)
    J_fd = np.stack(
        [
            (
                kinematics.forward_kinematics(p, alpha + h * e)
                - kinematics.forward_kinematics(p, alpha - h * e)
            )
            / (2 * h)
            for e in np.eye(3)
        ],
        axis=-1,
    )
    checks["J"].update_value(*_errors(J, J_fd))
    Jdot_fd = (
        kinematics.jacobian(p, alpha + h * alpha_dot) - kinematics.jacobian(p, alpha - h * alpha_dot)
    ) / (2 * h)
    checks["Jdot"].update_value(
        *_errors(
            kinematics.jacobian_derivative_times_velocity(p, alpha, alpha_dot, xyz),
            np.einsum("kij,kj->ki", Jdot_fd, alpha_dot),
        )
    )
    analytic = robot.analytic_dynamics(alpha, alpha_dot)
    M_dot = (
        robot.analytic_dynamics(alpha + h * alpha_dot, alpha_dot).M
        - robot.analytic_dynamics(alpha - h * alpha_dot, alpha_dot).M
    ) / (2 * h)
    N = M_dot - 2.0 * analytic.C
    symmetric = np.linalg.norm(0.5 * (N + np.swapaxes(N, 1, 2)), axis=(1, 2))
    checks["skew"].update_value(
        float(symmetric.max()), float((symmetric / np.linalg.norm(M_dot, axis=(1, 2))).max())
    )

    # Pinocchio side: the closed-chain robot of the same URDF (the one robot model), state by
    # state: the closure gap at the analytic configuration, then the projection (the compiled
    # core's) at the assembly Newton reaches from there
    closed = robot.pinocchio
    M_list, G_list, coriolis_list, gap_list = [], [], [], []
    starts = robot.closed_form_configurations(closed.model, closed.closures, alpha, xyz)
    for a, d, q in zip(alpha, alpha_dot, starts):
        gap_list.append(closed.closure_gap(q))
        closed_q = q if gap_list[-1] <= 1e-13 else closed.configuration(a, initial_guess=q, tol=1e-13)
        M, _, G, coriolis = closed.reduced_terms(a, d, closed_q)
        M_list.append(M)
        G_list.append(G)
        coriolis_list.append(coriolis)
    gaps = np.array(gap_list)
    pin_M, pin_G, pin_coriolis = np.array(M_list), np.array(G_list), np.array(coriolis_list)
    checks["closure"].update_value(float(gaps.max()), float(gaps.max()))
    checks["M"].update_value(*_errors(analytic.M, pin_M))
    checks["coriolis"].update_value(*_errors(analytic.coriolis, pin_coriolis))
    checks["G"].update_value(*_errors(analytic.G, pin_G))
    asymmetry = np.abs(pin_M - np.swapaxes(pin_M, 1, 2)).max(axis=(1, 2))
    positive = np.linalg.eigvalsh(0.5 * (pin_M + np.swapaxes(pin_M, 1, 2)))[:, 0] > 0.0
    relative = np.where(positive, asymmetry / np.abs(pin_M).max(axis=(1, 2)), np.inf)
    checks["spd"].update_value(float(asymmetry.max()), float(relative.max()))
    return report

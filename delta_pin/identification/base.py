"""Base parameters: the combinations of the standard parameters that the actuated torque depends on.

Many of the tree's parameters never reach the actuated joints (a massless slide's rotational
inertia) or reach them only in fixed combinations (a forearm's mass adds to its upper arm's
first moment through the elbow's lever). Stack the regressor Y (dof rows per state) at many
generic states into W (n x p) and factor it by QR with column pivoting (Gautier 1990; as in
FIGAROH), ``scipy.linalg.qr(W, pivoting=True)``: W P = Q R, |R_11| >= |R_22| >= ... The numeric
rank r is the number of diagonal entries above ``rtol |R_11|``; the first r pivoted columns are
the base (independent) parameters theta_1, the others theta_2, and

    W theta = W_1 (theta_1 + K theta_2),   K = R_11^-1 R_12,   beta = theta_1 + K theta_2,

so beta (r,) is what a fit of the log can recover. Rank tolerance: ``rtol`` = 1e-8 relative to the
largest diagonal entry. On the Delta, five-bar and Stewart platform the structurally dependent
directions sit at ~1e-15 of |R_11| (rounding) and the weakest genuine one at ~1e-5 or above at the
generic states drawn here; :attr:`BaseParameters.gap` reports both sides so that a robot whose
spectrum has no such gap is visible in the report.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from delta_pin.errors import AssemblyError, InvalidParameterError
from delta_pin.identification.regressor import ClosedChainRegressor

__all__ = ["RANK_TOLERANCE", "BaseParameters", "base_parameters", "generic_states"]

RANK_TOLERANCE = 1e-8  # |R_ii| / |R_11| below which a pivoted column counts as dependent


@dataclass(frozen=True)
class BaseParameters:
    """The base parameters of a regressor (module docstring).

    Attributes:
        names: the standard parameters' names (p,).
        independent: indices of theta_1 (r,), in pivot order.
        dependent: indices of theta_2 (p - r,).
        K: (r, p - r): beta = theta[independent] + K theta[dependent].
        diagonal: |R_ii| / |R_11| of the pivoted QR (min(n, p),).
        rtol: the rank tolerance used.
        absent: indices of standard parameters whose regressor column is zero (below ``rtol`` of
            the largest column norm): they never reach the actuated joints.
    """

    names: tuple[str, ...]
    independent: np.ndarray
    dependent: np.ndarray
    K: np.ndarray
    diagonal: np.ndarray
    rtol: float
    absent: np.ndarray

    @property
    def rank(self) -> int:
        """r, the number of base parameters."""
        return len(self.independent)

    @property
    def gap(self) -> tuple[float, float]:
        """(smallest kept |R_ii| / |R_11|, largest dropped one): the rank decision's margin."""
        kept = self.diagonal[: self.rank]
        dropped = self.diagonal[self.rank :]
        return float(kept.min()), float(dropped.max()) if dropped.size else 0.0

    def values(self, theta: np.ndarray) -> np.ndarray:
        """beta (r,) of standard parameters theta (p,)."""
        theta = np.asarray(theta, dtype=float)
        return theta[self.independent] + self.K @ theta[self.dependent]

    def reduce(self, Y: np.ndarray) -> np.ndarray:
        """The base regressor: Y's independent columns (..., r)."""
        return np.asarray(Y)[..., self.independent]

    def expressions(self, digits: int = 6) -> list[str]:
        """Each base parameter as its combination of standard ones, e.g.
        ``"Iyy[upper_arm_1] + 0.04 m[forearm_1]"`` (coefficients below 1e-9 of the row's
        largest one omitted)."""
        out = []
        for i, k in enumerate(self.independent):
            terms = [self.names[k]]
            row = self.K[i]
            scale = max(1.0, float(np.abs(row).max()) if row.size else 0.0)
            for c, j in zip(row, self.dependent, strict=True):
                if abs(c) > 1e-9 * scale:
                    sign = "-" if c < 0 else "+"
                    terms.append(f"{sign} {abs(c):.{digits}g} {self.names[j]}")
            out.append(" ".join(terms))
        return out

    def short_names(self) -> list[str]:
        """The name of each base parameter's leading standard parameter (``"Iyy[upper_arm_1]*"``
        with a star where others are lumped into it)."""
        names = []
        for i, k in enumerate(self.independent):
            lumped = np.any(np.abs(self.K[i]) > 1e-9 * max(1.0, float(np.abs(self.K[i]).max(initial=0.0))))
            names.append(self.names[k] + ("*" if lumped else ""))
        return names


def generic_states(
    robot, count: int = 200, seed: int = 0, amplitude: np.ndarray | float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``count`` generic assembled states (alpha, alpha_dot, alpha_ddot), each (count, dof), about
    the robot's home: alpha uniform within +-``amplitude`` (default 0.3 rad on revolute and
    0.03 m on prismatic actuators), velocities and accelerations standard normal (rad/s, rad/s^2)
    scaled alike; states whose loops do not close are drawn again (seeded)."""
    rng = np.random.default_rng(seed)
    if amplitude is None:
        amplitude = joint_scale(robot) * 0.3
    amplitude = np.broadcast_to(np.asarray(amplitude, dtype=float), (robot.dof,))
    states = []
    attempts = 0
    while len(states) < count:
        attempts += 1
        if attempts > 20 * count:
            raise InvalidParameterError(
                f"robot {robot.name!r}: fewer than {count} of {attempts} random states about home "
                f"(+-{amplitude.tolist()}) assemble; give a smaller amplitude"
            )
        alpha = robot.home + rng.uniform(-1.0, 1.0, robot.dof) * amplitude
        try:
            robot.configuration(alpha, initial_guess=robot.reference_configuration)
        except AssemblyError:
            continue
        scale = amplitude / 0.3
        states.append(
            (alpha, rng.normal(0.0, 1.0, robot.dof) * scale, rng.normal(0.0, 1.0, robot.dof) * scale)
        )
    alpha, alpha_dot, alpha_ddot = (np.array(x) for x in zip(*states, strict=True))
    return alpha, alpha_dot, alpha_ddot


def joint_scale(robot) -> np.ndarray:
    """1 for a revolute actuated joint [rad], 0.1 for a prismatic one [m] (dof,)."""
    model = robot.model
    scale = []
    for name in robot.actuated_joints:
        kind = model.joints[model.getJointId(name)].shortname()
        scale.append(0.1 if "Prismatic" in kind or kind.startswith("JointModelP") else 1.0)
    return np.array(scale)


def base_parameters(
    regressor: ClosedChainRegressor,
    count: int = 200,
    seed: int = 0,
    rtol: float = RANK_TOLERANCE,
    W: np.ndarray | None = None,
) -> BaseParameters:
    """The base parameters of ``regressor``'s robot by pivoted QR of its regressor at ``count``
    generic states (:func:`generic_states`) or of a given stacked regressor ``W`` (n, p).

    Args:
        rtol: rank tolerance on |R_ii| / |R_11| (module docstring).
    """
    if W is None:
        alpha, alpha_dot, alpha_ddot = generic_states(regressor.robot, count, seed)
        W = regressor.stack(alpha, alpha_dot, alpha_ddot).reshape(-1, regressor.size)
        regressor._last_q = regressor.robot.reference_configuration.copy()
    W = np.asarray(W, dtype=float)
    norms = np.linalg.norm(W, axis=0)
    absent = np.flatnonzero(norms <= rtol * norms.max())
    _, R, pivots = scipy.linalg.qr(W, mode="economic", pivoting=True)
    diagonal = np.abs(np.diag(R))
    ratio = diagonal / diagonal[0]
    rank = int((ratio > rtol).sum())
    R11, R12 = R[:rank, :rank], R[:rank, rank:]
    K = scipy.linalg.solve_triangular(R11, R12)
    K[np.abs(K) < 1e-12 * max(1.0, float(np.abs(K).max(initial=0.0)))] = 0.0
    dependent = pivots[rank:]
    if W.shape[0] < W.shape[1]:  # more columns than rows: the rest have no diagonal entry
        pass
    return BaseParameters(
        names=tuple(regressor.names),
        independent=pivots[:rank].copy(),
        dependent=dependent.copy(),
        K=K,
        diagonal=ratio,
        rtol=rtol,
        absent=absent,
    )

"""A physically consistent estimate: standard parameters with positive masses and pseudo-inertias
J ⪰ 0 whose base parameters fit the log.

Each body's pseudo-inertia (Wensing et al. 2017)

    J = [[Sigma, h], [h^T, m]],  Sigma = tr(I)/2 1 - I,  h = m c   (I about the joint frame's origin)

is positive semi-definite exactly when the body is a physical mass distribution. The
log-Cholesky parametrisation (Rucker & Wensing 2022) writes J = U U^T with

    U = e^a [[e^d1, s12, s13, t1], [0, e^d2, s23, t2], [0, 0, e^d3, t3], [0, 0, 0, 1]],

10 unconstrained numbers per body (kept here to build strictly feasible starts). The problem

    min | R_w (beta(theta) - beta_wls) |^2 + lambda | (theta - theta_prior) / s |^2
    subject to J_k(theta) ⪰ 0 per body, fv, fc, fs, Ia >= 0 (offsets free)

is convex in theta (a quadratic over linear matrix inequalities: J is linear in theta). It is
solved to optimality by the log-barrier method (:func:`_barrier_solve`: damped Newton steps on
t f - sum log det J_k - sum log x, t x10 each round) until the duality gap nu / t (nu = 4 per body
+ 1 per bound) is below ``GAP_TOLERANCE`` = 1e-8 of the cost, within ``MAX_NEWTON_STEPS`` = 400;
``success`` says whether it was reached, ``message``, ``iterations`` and ``duality_gap`` how. (It
replaced ``scipy.optimize.least_squares`` on the log-Cholesky coordinates, which stopped at its
100 evaluations on every log: an optimum on the boundary J ⪰ 0, a rod or point mass, sits at
log-coordinates -> -inf; 3000 evaluations, 16 s, still left its cost above the barrier's.)
R_w is the R factor of the whitened base regressor (so the first term is the WLS cost up to a
constant, in units of the noise's standard deviation: the fit to the log), theta_prior the nominal
(CAD) parameters with scales s (their magnitudes, floored at 1e-3 of the largest), and lambda =
``prior_weight`` = 1e-2: a parameter off its prior by its own scale costs what a tenth of a
standard deviation of the data does, so the log fixes the base parameters and the prior only the
combinations the log cannot see. Bodies whose nominal mass is 0
(the Delta's massless slides and elbow links) stay at 0. The distance to the unconstrained WLS
estimate is reported in the WLS metric (Mahalanobis, |R_w delta beta|) and relative, |delta beta| / |beta|.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from delta_pin.identification.base import BaseParameters
from delta_pin.identification.regressor import ClosedChainRegressor

__all__ = [
    "GAP_TOLERANCE",
    "MAX_NEWTON_STEPS",
    "ConsistentEstimate",
    "consistent_estimate",
    "log_cholesky_to_parameters",
    "parameters_to_log_cholesky",
]


MAX_NEWTON_STEPS = 400  # the barrier method's budget (converged fits take 40-90)
GAP_TOLERANCE = 1e-8  # the duality gap, relative to max(1, the cost), at which it stops: optimal


def _pseudo_inertia(theta: np.ndarray) -> np.ndarray:
    """J (4, 4) of one body's 10 parameters (module docstring): linear in them."""
    m, hx, hy, hz, ixx, ixy, iyy, ixz, iyz, izz = theta
    inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    Sigma = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    h = np.array([hx, hy, hz])
    return np.block([[Sigma, h[:, None]], [h[None, :], np.array([[m]])]])


_PSEUDO_BASIS = np.array([_pseudo_inertia(e) for e in np.eye(10)])  # J = sum_i theta_i E_i


def _barrier_solve(A, c, z0, blocks, bounded, max_steps):
    """min 1/2 |A z - c|^2 subject to sum_i z[idx]_i E_i ⪰ 0 for each (idx, E) of ``blocks`` and
    z[bounded] >= 0, from the strictly feasible ``z0``: the log-barrier method (Boyd & Vandenberghe
    2004, 11.3), t f - sum log det J_k - sum log z_b minimised by damped Newton steps for t = t0,
    10 t0, ...; the minimiser at t is within nu / t of the optimum (nu = 4 per body + 1 per bound),
    so a gap below ``GAP_TOLERANCE`` max(1, f) is optimal to that tolerance.

    Returns:
        (z, {"converged", "message", "iterations", "gap"}).
    """
    Q = A.T @ A
    b = A.T @ c
    n = len(z0)

    def cost(z):
        r = A @ z - c
        return 0.5 * float(r @ r)

    def barrier(z, derivatives=True):
        value, g, H = 0.0, np.zeros(n), np.zeros((n, n))
        for idx, E in blocks:
            J = np.einsum("i,iab->ab", z[idx], E)
            try:
                L = np.linalg.cholesky(J)
            except np.linalg.LinAlgError:
                return None
            value -= 2.0 * float(np.log(np.diag(L)).sum())
            if derivatives:
                ME = np.einsum("ab,ibc->iac", np.linalg.inv(J), E)  # J^-1 E_i
                g[idx] -= np.einsum("iaa->i", ME)
                H[np.ix_(idx, idx)] += np.einsum("iab,jba->ij", ME, ME)
        x = z[bounded]
        if np.any(x <= 0.0):
            return None
        value -= float(np.log(x).sum())
        if derivatives:
            g[bounded] -= 1.0 / x
            H[bounded, bounded] += 1.0 / x**2
        return value, g, H

    nu = 4 * len(blocks) + len(bounded)
    z = np.array(z0, dtype=float)
    if barrier(z, False) is None:
        raise ValueError("the barrier method's start is not strictly feasible")
    t = nu / max(cost(z), 1e-12)
    steps = 0
    while True:
        while steps < max_steps:  # centring: Newton on t f + phi
            value, g, H = barrier(z)
            grad = t * (Q @ z - b) + g
            hess = t * Q + H
            try:
                dz = -np.linalg.solve(hess, grad)
            except np.linalg.LinAlgError:
                dz = -np.linalg.lstsq(hess, grad, rcond=None)[0]
            decrement = float(-grad @ dz)
            steps += 1
            if decrement / 2.0 <= 1e-8:  # centred (t f + phi within 1e-8 of its minimum)
                break
            phi0 = t * cost(z) + value
            step, moved = 1.0, False
            while step > 1e-6:  # backtracking (Armijo), inside the feasible set
                trial = z + step * dz
                phi = barrier(trial, False)
                if phi is not None and t * cost(trial) + phi[0] <= phi0 - 0.25 * step * decrement:
                    z, moved = trial, True
                    break
                step *= 0.5
            if not moved:  # no decrease left above the rounding of t f + phi: centred as far as it goes
                break  # (t f ~ 1e10 at the last rounds: its rounding is ~1e-6)
        gap = nu / t
        f = cost(z)
        if gap <= GAP_TOLERANCE * max(1.0, f) and steps < max_steps:
            return z, {
                "converged": True,
                "message": f"optimal: duality gap {gap:.3g} (<= {GAP_TOLERANCE:g} of the cost {f:.6g}) "
                f"after {steps} Newton steps",
                "iterations": steps,
                "gap": gap,
            }
        if steps >= max_steps:
            return z, {
                "converged": False,
                "message": f"stopped after {steps} Newton steps (the limit), duality gap {gap:.3g} "
                f"above the tolerance {GAP_TOLERANCE * max(1.0, f):.3g}: not optimal",
                "iterations": steps,
                "gap": gap,
            }
        t *= 10.0


def log_cholesky_to_parameters(phi: np.ndarray) -> np.ndarray:
    """The 10 dynamic parameters (m, m c, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz) of one body from its
    log-Cholesky coordinates phi = (a, d1, d2, d3, s12, s23, s13, t1, t2, t3)."""
    a, d1, d2, d3, s12, s23, s13, t1, t2, t3 = phi
    U = np.exp(a) * np.array(
        [
            [np.exp(d1), s12, s13, t1],
            [0.0, np.exp(d2), s23, t2],
            [0.0, 0.0, np.exp(d3), t3],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )
    J = U @ U.T
    Sigma, h, m = J[:3, :3], J[:3, 3], J[3, 3]
    inertia = np.trace(Sigma) * np.eye(3) - Sigma
    return np.array(
        [m, *h, inertia[0, 0], inertia[0, 1], inertia[1, 1], inertia[0, 2], inertia[1, 2], inertia[2, 2]]
    )


def parameters_to_log_cholesky(theta: np.ndarray, floor: float = 1e-6) -> np.ndarray:
    """The log-Cholesky coordinates of one body's parameters (inverse of
    :func:`log_cholesky_to_parameters`), its pseudo-inertia's eigenvalues first raised to
    ``floor`` x its largest (a point mass or a rod is on the boundary J ⪰ 0)."""
    m, hx, hy, hz, ixx, ixy, iyy, ixz, iyz, izz = theta
    inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    Sigma = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    h = np.array([hx, hy, hz])
    J = np.block([[Sigma, h[:, None]], [h[None, :], np.array([[m]])]])
    values, vectors = np.linalg.eigh(J)
    values = np.maximum(values, floor * max(values.max(), 1e-12))
    J = (vectors * values) @ vectors.T
    # J = U U^T with U upper triangular: the Cholesky factor of the flipped matrix, flipped back
    P = np.eye(4)[::-1]
    L = np.linalg.cholesky(P @ J @ P)
    U = P @ L @ P
    alpha = np.log(U[3, 3])
    U = U / U[3, 3]
    return np.array(
        [
            alpha,
            np.log(U[0, 0]),
            np.log(U[1, 1]),
            np.log(U[2, 2]),
            U[0, 1],
            U[1, 2],
            U[0, 2],
            U[0, 3],
            U[1, 3],
            U[2, 3],
        ]
    )


@dataclass
class ConsistentEstimate:
    """The physically consistent estimate.

    Attributes:
        theta: standard parameters (p,) [SI], every body physical.
        beta: its base parameters (r,).
        distance_mahalanobis: |R_w (beta - beta_wls)| (the WLS cost's increase, in standard deviations).
        distance_relative: |beta - beta_wls| / |beta_wls|.
        success: solved to optimality (duality gap below :data:`GAP_TOLERANCE`); ``message`` the
            solver's words, ``iterations`` its Newton steps, ``duality_gap`` the bound it reached.
    """

    theta: np.ndarray
    beta: np.ndarray
    distance_mahalanobis: float
    distance_relative: float
    success: bool
    message: str
    min_eigenvalues: np.ndarray
    iterations: int = 0
    duality_gap: float = float("nan")


def consistent_estimate(
    regressor: ClosedChainRegressor,
    base: BaseParameters,
    beta_wls: np.ndarray,
    R_w: np.ndarray,
    theta_prior: np.ndarray,
    prior_weight: float = 1e-2,
    max_steps: int | None = None,
) -> ConsistentEstimate:
    """Solve the module docstring's problem.

    Args:
        beta_wls: the WLS base parameters (r,).
        R_w: the R factor (r, r) of the whitened base regressor (its information matrix R^T R).
        theta_prior: the nominal standard parameters (p,).
        prior_weight: lambda.
        max_steps: the most Newton steps (default :data:`MAX_NEWTON_STEPS`); past them the estimate
            is returned with ``success`` False and the duality gap it reached.
    """
    max_steps = MAX_NEWTON_STEPS if max_steps is None else max_steps
    p = regressor.size
    n_in = regressor.inertial_count
    bodies = [k for k in range(n_in // 10) if theta_prior[10 * k] > 0.0]
    kinds = regressor.columns.kinds()
    dof = regressor.dof
    joint_lower = []
    for prefix, _ in kinds:
        joint_lower += [0.0 if prefix in ("fv", "fc", "fs", "Ia") else -np.inf] * dof
    joint_lower = np.array(joint_lower)
    theta_fixed = np.array(theta_prior, dtype=float)
    for k in range(n_in // 10):
        if k not in bodies:
            theta_fixed[10 * k : 10 * k + 10] = 0.0

    scale = np.maximum(np.abs(theta_prior), 1e-3 * np.abs(theta_prior).max())
    prior = np.sqrt(prior_weight)  # the data rows are whitened: one unit is one standard deviation
    B = np.zeros((base.rank, p))
    B[np.arange(base.rank), base.independent] = 1.0
    B[:, base.dependent] = base.K
    A = np.vstack([R_w @ B, prior * np.diag(1.0 / scale)])
    c = np.concatenate([R_w @ beta_wls, prior * theta_prior / scale])
    # the unknowns: the kept bodies' 10 parameters and the joint columns, scaled, theta = s z there
    free = np.concatenate([np.arange(10 * k, 10 * k + 10) for k in bodies] + [np.arange(n_in, p)]).astype(int)
    bounded = np.flatnonzero(np.isfinite(joint_lower)) + 10 * len(bodies)
    # start (strictly feasible): the prior moved by the smallest change (in the prior's scaled
    # metric) that makes its base parameters the WLS ones, theta_p + D (B D)^+ (beta_wls - B theta_p),
    # each body's pseudo-inertia's eigenvalues raised to 1e-3 of its largest, the bounded joint
    # columns to at least 1e-3 of their scale
    D = np.diag(scale)
    start = theta_prior + D @ np.linalg.lstsq(B @ D, beta_wls - B @ theta_prior, rcond=None)[0]
    for k in bodies:
        body = start[10 * k : 10 * k + 10].copy()
        if body[0] <= 0.0:  # a mass the correction made non-positive: the prior's body instead
            body = theta_prior[10 * k : 10 * k + 10]
        start[10 * k : 10 * k + 10] = log_cholesky_to_parameters(parameters_to_log_cholesky(body, 1e-3))
    z0 = start[free] / scale[free]
    z0[bounded] = np.maximum(z0[bounded], 1e-3)
    blocks = [(np.arange(10 * i, 10 * i + 10), _PSEUDO_BASIS * scale[10 * k : 10 * k + 10, None, None])
              for i, k in enumerate(bodies)]  # fmt: skip
    A_z = A[:, free] * scale[free]
    c_z = c - A @ (theta_fixed * (1 - np.isin(np.arange(p), free)))
    z, status = _barrier_solve(A_z, c_z, z0, blocks, bounded, max_steps)
    theta = theta_fixed.copy()
    theta[free] = z * scale[free]
    beta = base.values(theta)
    eigen = []
    for k in bodies:
        m, hx, hy, hz, ixx, ixy, iyy, ixz, iyz, izz = theta[10 * k : 10 * k + 10]
        inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        Sigma = 0.5 * np.trace(inertia) * np.eye(3) - inertia
        J = np.block([[Sigma, np.array([[hx], [hy], [hz]])], [np.array([[hx, hy, hz, m]])]])
        eigen.append(float(np.linalg.eigvalsh(J).min()))
    return ConsistentEstimate(
        theta=theta,
        beta=beta,
        distance_mahalanobis=float(np.linalg.norm(R_w @ (beta - beta_wls))),
        distance_relative=float(np.linalg.norm(beta - beta_wls) / np.linalg.norm(beta_wls)),
        success=status["converged"],
        message=status["message"],
        iterations=status["iterations"],
        duality_gap=status["gap"],
        min_eigenvalues=np.array(eigen),
    )

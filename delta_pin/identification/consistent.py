"""A physically consistent estimate: standard parameters with positive masses and pseudo-inertias
J ⪰ 0 whose base parameters fit the log.

Each body's pseudo-inertia (Wensing et al. 2017)

    J = [[Sigma, h], [h^T, m]],  Sigma = tr(I)/2 1 - I,  h = m c   (I about the joint frame's origin)

is positive semi-definite exactly when the body is a physical mass distribution. The
log-Cholesky parametrisation (Rucker & Wensing 2022) writes J = U U^T with

    U = e^a [[e^d1, s12, s13, t1], [0, e^d2, s23, t2], [0, 0, e^d3, t3], [0, 0, 0, 1]],

10 unconstrained numbers per body, so every estimate is consistent (J ≻ 0, m = e^2a > 0). The
friction (``fv``, ``fc``, ``fs``) and rotor inertia (``Ia``) columns are bounded below by 0;
offsets are free. ``scipy.optimize.least_squares`` (trust-region reflective) minimises

    | R_w (beta(theta(phi)) - beta_wls) |^2 + lambda | (theta(phi) - theta_prior) / s |^2,

R_w the R factor of the whitened base regressor (so the first term is the WLS cost up to a
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
    "ConsistentEstimate",
    "consistent_estimate",
    "log_cholesky_to_parameters",
    "parameters_to_log_cholesky",
]


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
        success: the optimiser's verdict; ``message`` its words.
    """

    theta: np.ndarray
    beta: np.ndarray
    distance_mahalanobis: float
    distance_relative: float
    success: bool
    message: str
    min_eigenvalues: np.ndarray


def consistent_estimate(
    regressor: ClosedChainRegressor,
    base: BaseParameters,
    beta_wls: np.ndarray,
    R_w: np.ndarray,
    theta_prior: np.ndarray,
    prior_weight: float = 1e-2,
) -> ConsistentEstimate:
    """Solve the module docstring's problem.

    Args:
        beta_wls: the WLS base parameters (r,).
        R_w: the R factor (r, r) of the whitened base regressor (its information matrix R^T R).
        theta_prior: the nominal standard parameters (p,).
        prior_weight: lambda.
    """
    from scipy.optimize import least_squares

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

    def unpack(x):
        theta = theta_fixed.copy()
        for i, k in enumerate(bodies):
            theta[10 * k : 10 * k + 10] = log_cholesky_to_parameters(x[10 * i : 10 * i + 10])
        theta[n_in:] = x[10 * len(bodies) :]
        return theta

    scale = np.maximum(np.abs(theta_prior), 1e-3 * np.abs(theta_prior).max())
    prior = np.sqrt(prior_weight)  # the data rows are whitened: one unit is one standard deviation
    # the residual is linear in theta: r = A theta - c, so its Jacobian is A dtheta/dphi, the
    # latter block-diagonal (10 x 10 per body by central differences of the log-Cholesky map,
    # exact to ~1e-10 relative: a polynomial of exponentials; the identity on the joint columns)
    B = np.zeros((base.rank, p))
    B[np.arange(base.rank), base.independent] = 1.0
    B[:, base.dependent] = base.K
    A = np.vstack([R_w @ B, prior * np.diag(1.0 / scale)])
    c = np.concatenate([R_w @ beta_wls, prior * theta_prior / scale])
    nb = 10 * len(bodies)
    columns = np.concatenate([np.arange(10 * k, 10 * k + 10) for k in bodies] + [np.arange(n_in, p)])

    def residual(x):
        return A @ unpack(x) - c

    def jacobian(x):
        D = np.zeros((p, len(x)))
        for i, k in enumerate(bodies):
            phi = x[10 * i : 10 * i + 10]
            for m in range(10):
                h = 1e-6 * max(1.0, abs(phi[m]))
                up, down = phi.copy(), phi.copy()
                up[m] += h
                down[m] -= h
                D[10 * k : 10 * k + 10, 10 * i + m] = (
                    log_cholesky_to_parameters(up) - log_cholesky_to_parameters(down)
                ) / (2 * h)
        D[n_in:, nb:] = np.eye(p - n_in)
        return A @ D

    del columns
    # start: the prior moved by the smallest change (in the prior's scaled metric) that makes its
    # base parameters the WLS ones, theta_0 = theta_p + D (B D)^+ (beta_wls - B theta_p), then each
    # body's pseudo-inertia clipped to J ⪰ 0 (parameters_to_log_cholesky): near the data at once,
    # which the trust region then only polishes
    D = np.diag(scale)
    start = theta_prior + D @ np.linalg.lstsq(B @ D, beta_wls - B @ theta_prior, rcond=None)[0]
    x0 = []
    for k in bodies:
        body = start[10 * k : 10 * k + 10].copy()
        if body[0] <= 0.0:  # a mass the correction made non-positive: the prior's body instead
            body = theta_prior[10 * k : 10 * k + 10]
        x0.append(parameters_to_log_cholesky(body))
    joint0 = start[n_in:].copy()
    joint0 = np.where(np.isfinite(joint_lower), np.maximum(joint0, 1e-9), joint0)
    x0 = np.concatenate([*x0, joint0])
    # the logarithms bounded (a mass or a principal inertia within e^-30 .. e^10 of 1 kg, kg m^2):
    # no overflow of exp, and nothing a real body needs
    free = [np.inf] * 6
    lower = np.concatenate([np.tile([-15.0] * 4 + [-np.inf] * 6, len(bodies)), joint_lower])
    upper = np.concatenate([np.tile([5.0, 10.0, 10.0, 10.0, *free], len(bodies)), np.full(p - n_in, np.inf)])
    x0 = np.clip(x0, lower + 1e-9, upper - 1e-9)
    result = least_squares(residual, x0, jac=jacobian, bounds=(lower, upper), method="trf", x_scale="jac",
                           max_nfev=100, ftol=1e-10, xtol=1e-10)  # fmt: skip
    theta = unpack(result.x)
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
        success=bool(result.success),
        message=str(result.message),
        min_eigenvalues=np.array(eigen),
    )

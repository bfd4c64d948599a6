"""Closed-form kinematics of the Delta (eqs. 1-5 and 10 of the paper).

Conventions (DESIGN.md section 3): base frame z up, chain i at azimuth phi_i with radial unit
vector u_i; A_i = R u_i, elbow B_i = A_i + l_a (cos(alpha_i) u_i - sin(alpha_i) e_z) (alpha_i > 0
swings the arm down), platform attachment C_i = p + r u_i, and |C_i - B_i| = l_b (eq. 5).

The Jacobian follows from differentiating eq. 5: s_i^T (p_dot - B_i' alpha_dot_i) = 0 with
s_i = C_i - B_i, so J = S^-1 diag(s_i^T dB_i/dalpha_i) with S = [s_1 s_2 s_3]^T. (Eq. 10 prints
the same structure, with b_i = -dB_i/dalpha_i.)

Every function takes the :class:`~delta_pin.description.DeltaParameters` first and works in SI
units: positions [m], angles [rad], velocities [rad/s], [m/s].
"""

from __future__ import annotations

import math

import numpy as np

from .description import DeltaParameters, chain_azimuths
from .errors import ForwardKinematicsError, NonFiniteError, UnreachablePoseError

__all__ = [
    "elbow_positions",
    "forward_kinematics",
    "inverse_kinematics",
    "jacobian",
    "jacobian_derivative",
    "jacobian_derivative_times_velocity",
    "radial_units",
]

_E_Z = np.array([0.0, 0.0, 1.0])
_PHI = chain_azimuths()
_COS_PHI = np.cos(_PHI)
_SIN_PHI = np.sin(_PHI)
_U = np.stack([_COS_PHI, _SIN_PHI, np.zeros(3)], axis=1)  # row i: radial unit u_i


def radial_units() -> np.ndarray:
    """Rows u_i = [cos phi_i, sin phi_i, 0] (3, 3)."""
    return _U.copy()


def as_vector3(value: np.ndarray | list[float] | tuple[float, ...], name: str) -> np.ndarray:
    """Return ``value`` as a finite float array of shape (3,), or raise naming ``name``."""
    array = np.asarray(value, dtype=float)
    if array.shape != (3,):
        raise ValueError(f"{name} must have shape (3,), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise NonFiniteError(f"{name}={array.tolist()} holds a non-finite number")
    return array


def elbow_positions(params: DeltaParameters, alpha: np.ndarray) -> np.ndarray:
    """Elbow points B_i (eq. 3) as rows of a (3, 3) array [m]."""
    reach = params.R + params.l_a * np.cos(alpha)
    return np.stack([reach * _COS_PHI, reach * _SIN_PHI, -params.l_a * np.sin(alpha)], axis=1)


def _elbow_tangents(params: DeltaParameters, alpha: np.ndarray) -> np.ndarray:
    """dB_i/dalpha_i = l_a (-sin(alpha_i) u_i - cos(alpha_i) e_z), rows (3, 3) [m/rad]."""
    radial = -params.l_a * np.sin(alpha)
    return np.stack([radial * _COS_PHI, radial * _SIN_PHI, -params.l_a * np.cos(alpha)], axis=1)


def _elbow_curvatures(params: DeltaParameters, alpha: np.ndarray) -> np.ndarray:
    """d^2B_i/dalpha_i^2 = l_a (-cos(alpha_i) u_i + sin(alpha_i) e_z), rows (3, 3) [m/rad^2]."""
    radial = -params.l_a * np.cos(alpha)
    return np.stack([radial * _COS_PHI, radial * _SIN_PHI, params.l_a * np.sin(alpha)], axis=1)


def inverse_kinematics(params: DeltaParameters, xyz: np.ndarray) -> np.ndarray:
    """Active joint angles alpha [rad] (3,) that put the platform at ``xyz`` [m] (eq. 5).

    Eq. 5 for chain i reads E cos(alpha) + F sin(alpha) = K in the chain's radial plane; of its
    two roots the elbow-out one (the larger cos(alpha), Remark 1) is returned, and it must
    satisfy |alpha_i| < pi/2.

    Raises:
        UnreachablePoseError: ``xyz`` is outside the workspace or outside the elbow-out branch.
    """
    x, y, z = as_vector3(xyz, "xyz")
    if z >= 0.0:
        raise UnreachablePoseError(
            f"platform position xyz={[float(x), float(y), float(z)]} m is not below the base (z < 0)"
        )
    along = x * _COS_PHI + y * _SIN_PHI  # platform position along u_i
    across = -x * _SIN_PHI + y * _COS_PHI  # ... and along the chain's tangent
    offset = params.R - params.r - along
    E = 2.0 * offset * params.l_a
    F = np.full(3, 2.0 * z * params.l_a)
    K = params.l_b**2 - offset**2 - params.l_a**2 - across**2 - z**2
    amplitude = np.hypot(E, F)
    alpha = np.empty(3)
    for i in range(3):
        if amplitude[i] == 0.0 or abs(K[i]) > amplitude[i]:
            raise UnreachablePoseError(
                f"platform position xyz={[float(x), float(y), float(z)]} m is out of reach of "
                f"chain {i + 1} (the forearm of length l_b={params.l_b} m cannot meet the elbow circle)"
            )
        base = math.atan2(F[i], E[i])
        spread = math.acos(K[i] / amplitude[i])
        roots = [math.remainder(base + spread, 2 * math.pi), math.remainder(base - spread, 2 * math.pi)]
        alpha[i] = max(roots, key=math.cos)
        if abs(alpha[i]) >= 0.5 * math.pi:
            raise UnreachablePoseError(
                f"platform position xyz={[float(x), float(y), float(z)]} m needs "
                f"alpha_{i + 1}={alpha[i]:.4f} rad, outside the elbow-out branch |alpha| < pi/2"
            )
    return alpha


def forward_kinematics(params: DeltaParameters, alpha: np.ndarray) -> np.ndarray:
    """Platform position xyz [m] (3,) for active angles ``alpha`` [rad] (platform below base).

    The platform lies at distance l_b from each centre P_i = B_i - r u_i: two differences of the
    three sphere equations give a line, which meets the first sphere at two points; the lower
    one is returned.

    Raises:
        ForwardKinematicsError: the three spheres do not meet (no assembly for this ``alpha``).
    """
    alpha = as_vector3(alpha, "alpha")
    centres = elbow_positions(params, alpha) - params.r * _U
    rows = 2.0 * (centres[0] - centres[1:])  # (2, 3)
    squared = np.einsum("ij,ij->i", centres, centres)
    rhs = squared[0] - squared[1:]
    direction = np.cross(rows[0], rows[1])
    norm = np.linalg.norm(direction)
    if norm < 1e-12:
        raise ForwardKinematicsError(
            f"alpha={alpha.tolist()} rad puts the three forearm spheres' centres on one line"
        )
    direction /= norm
    if direction[2] > 0.0:
        direction = -direction
    point = rows.T @ np.linalg.solve(rows @ rows.T, rhs)  # min-norm point of the line
    offset = point - centres[0]
    half_b = direction @ offset
    c = offset @ offset - params.l_b**2
    discriminant = half_b**2 - c
    if discriminant < 0.0:
        raise ForwardKinematicsError(
            f"alpha={alpha.tolist()} rad has no forward kinematics: the forearms "
            f"(l_b={params.l_b} m) cannot reach a common platform position"
        )
    return point + (-half_b + math.sqrt(discriminant)) * direction


def _closure_vectors(params: DeltaParameters, alpha: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    """Rows s_i = C_i - B_i (forearm vectors, |s_i| = l_b) [m]."""
    return xyz + params.r * _U - elbow_positions(params, alpha)


def jacobian(params: DeltaParameters, alpha: np.ndarray, xyz: np.ndarray | None = None) -> np.ndarray:
    """Jacobian J (3, 3) with xyz_dot = J alpha_dot [m/rad] (eq. 10).

    Args:
        alpha: active angles [rad].
        xyz: the platform position for ``alpha`` [m] if already known (saves an FK).
    """
    if xyz is None:
        xyz = forward_kinematics(params, alpha)
    s = _closure_vectors(params, alpha, xyz)
    diagonal = np.einsum("ij,ij->i", s, _elbow_tangents(params, alpha))
    return np.linalg.solve(s, np.diag(diagonal))


def jacobian_derivative_times_velocity(
    params: DeltaParameters, alpha: np.ndarray, alpha_dot: np.ndarray, xyz: np.ndarray | None = None
) -> np.ndarray:
    """J_dot alpha_dot [m/s^2] (3,): the platform acceleration when alpha_ddot = 0.

    Differentiating s_i^T (p_dot - B_i_dot) = 0 once more gives
    s_i^T p_ddot = s_i^T B_i_ddot - |p_dot - B_i_dot|^2, with B_i_ddot = B_i'' alpha_dot_i^2.
    """
    if xyz is None:
        xyz = forward_kinematics(params, alpha)
    s = _closure_vectors(params, alpha, xyz)
    J = jacobian(params, alpha, xyz)
    xyz_dot = J @ alpha_dot
    relative = xyz_dot - _elbow_tangents(params, alpha) * alpha_dot[:, None]  # s_i_dot
    rhs = np.einsum("ij,ij->i", s, _elbow_curvatures(params, alpha)) * alpha_dot**2 - np.einsum(
        "ij,ij->i", relative, relative
    )
    return np.linalg.solve(s, rhs)


def jacobian_derivative(
    params: DeltaParameters, alpha: np.ndarray, alpha_dot: np.ndarray, xyz: np.ndarray | None = None
) -> np.ndarray:
    """Time derivative J_dot (3, 3) of the Jacobian along alpha_dot [m/(rad s)].

    From S J = diag(d) (S rows s_i^T, d_i = s_i^T B_i'):
    J_dot = S^-1 (diag(d_dot) - S_dot J) with s_i_dot = p_dot - B_i' alpha_dot_i and
    d_i_dot = s_i_dot^T B_i' + s_i^T B_i'' alpha_dot_i.
    """
    if xyz is None:
        xyz = forward_kinematics(params, alpha)
    s = _closure_vectors(params, alpha, xyz)
    tangents = _elbow_tangents(params, alpha)
    J = np.linalg.solve(s, np.diag(np.einsum("ij,ij->i", s, tangents)))
    s_dot = (J @ alpha_dot) - tangents * alpha_dot[:, None]
    d_dot = (
        np.einsum("ij,ij->i", s_dot, tangents)
        + np.einsum("ij,ij->i", s, _elbow_curvatures(params, alpha)) * alpha_dot
    )
    return np.linalg.solve(s, np.diag(d_dot) - s_dot @ J)

"""Closed-form kinematics of the Delta (eqs. 1-5 and 10 of the paper).

Conventions (docs/architecture.md section 3): base frame z up, chain i at azimuth phi_i with radial unit
vector u_i; A_i = R u_i, elbow B_i = A_i + l_a (cos(alpha_i) u_i - sin(alpha_i) e_z) (alpha_i > 0
swings the arm down), platform attachment C_i = p + r u_i, and |C_i - B_i| = l_b (eq. 5).

The Jacobian follows from differentiating eq. 5: s_i^T (p_dot - B_i' alpha_dot_i) = 0 with
s_i = C_i - B_i, so J = S^-1 diag(s_i^T dB_i/dalpha_i) with S = [s_1 s_2 s_3]^T. (Eq. 10 prints
the same structure, with b_i = -dB_i/dalpha_i.)

Every function takes the :class:`~delta_pin.model.description.DeltaParameters` first and works in SI
units: positions [m], angles [rad], velocities [rad/s], [m/s].
"""

from __future__ import annotations

import numpy as np

from delta_pin.errors import ForwardKinematicsError, NonFiniteError, UnreachablePoseError
from delta_pin.model.description import DeltaParameters, chain_azimuths

__all__ = [
    "chain_trigonometry",
    "elbow_positions",
    "forward_kinematics",
    "forward_kinematics_masked",
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


def chain_trigonometry() -> tuple[np.ndarray, np.ndarray]:
    """(cos phi_i, sin phi_i) of the chain azimuths (3,), as the compiled kernels take them."""
    phi = chain_azimuths()
    return np.cos(phi), np.sin(phi)


def radial_units() -> np.ndarray:
    """Rows u_i = [cos phi_i, sin phi_i, 0] (3, 3)."""
    return _U.copy()


def as_vector3(value: np.ndarray | list[float] | tuple[float, ...], name: str) -> np.ndarray:
    """Return ``value`` as a finite float array of shape (..., 3), or raise naming ``name``.

    Every function of this module accepts one point (3,) or a batch (..., 3) and broadcasts.
    """
    array = np.asarray(value, dtype=float)
    if array.ndim == 0 or array.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (3,) or (..., 3), got {array.shape}")
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.all(np.isfinite(array), axis=-1))[0] if array.ndim > 1 else ()
        raise NonFiniteError(f"{name}={array[tuple(bad)].tolist()} holds a non-finite number")
    return array


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product over the last axis."""
    return np.einsum("...i,...i->...", a, b)


def _diag(d: np.ndarray) -> np.ndarray:
    """Batch of diagonal matrices (..., 3, 3) from (..., 3)."""
    return d[..., :, None] * np.eye(3)


def _first_failure(mask: np.ndarray) -> tuple:
    """Index of the first True of ``mask`` over the batch axes (``()`` for a single point)."""
    return tuple(np.argwhere(mask)[0][:-1]) if mask.ndim > 1 else ()


def elbow_positions(params: DeltaParameters, alpha: np.ndarray) -> np.ndarray:
    """Elbow points B_i (eq. 3) as rows of a (..., 3, 3) array [m]."""
    reach = params.R + params.l_a * np.cos(alpha)
    return np.stack([reach * _COS_PHI, reach * _SIN_PHI, -params.l_a * np.sin(alpha)], axis=-1)


def _elbow_tangents(params: DeltaParameters, alpha: np.ndarray) -> np.ndarray:
    """dB_i/dalpha_i = l_a (-sin(alpha_i) u_i - cos(alpha_i) e_z), rows (..., 3, 3) [m/rad]."""
    radial = -params.l_a * np.sin(alpha)
    return np.stack([radial * _COS_PHI, radial * _SIN_PHI, -params.l_a * np.cos(alpha)], axis=-1)


def _elbow_curvatures(params: DeltaParameters, alpha: np.ndarray) -> np.ndarray:
    """d^2B_i/dalpha_i^2 = l_a (-cos(alpha_i) u_i + sin(alpha_i) e_z), rows (..., 3, 3) [m/rad^2]."""
    radial = -params.l_a * np.cos(alpha)
    return np.stack([radial * _COS_PHI, radial * _SIN_PHI, params.l_a * np.sin(alpha)], axis=-1)


def inverse_kinematics(params: DeltaParameters, xyz: np.ndarray) -> np.ndarray:
    """Active joint angles alpha [rad] (..., 3) that put the platform at ``xyz`` [m] (eq. 5).

    Eq. 5 for chain i reads E cos(alpha) + F sin(alpha) = K in the chain's radial plane; of its
    two roots the elbow-out one (the larger cos(alpha), Remark 1) is returned, and it must
    satisfy |alpha_i| < pi/2. The platform must hang below the base (z < 0).

    Raises:
        UnreachablePoseError: a point outside the workspace or outside the elbow-out branch
            (the message names the first such point).
    """
    xyz = as_vector3(xyz, "xyz")
    x, y, z = xyz[..., 0:1], xyz[..., 1:2], xyz[..., 2:3]
    along = x * _COS_PHI + y * _SIN_PHI  # platform position along u_i
    across = -x * _SIN_PHI + y * _COS_PHI  # ... and along the chain's tangent
    offset = params.R - params.r - along
    E = 2.0 * offset * params.l_a
    F = np.broadcast_to(2.0 * z * params.l_a, E.shape)
    K = params.l_b**2 - offset**2 - params.l_a**2 - across**2 - z**2
    amplitude = np.hypot(E, F)

    def point(mask: np.ndarray) -> list[float]:
        return xyz[_first_failure(mask)].tolist()

    above = np.broadcast_to(z >= 0.0, E.shape)
    if above.any():
        raise UnreachablePoseError(f"platform position xyz={point(above)} m is not below the base (z < 0)")
    out_of_reach = (amplitude == 0.0) | (np.abs(K) > amplitude)
    if out_of_reach.any():
        chain = int(np.argwhere(out_of_reach)[0][-1]) + 1
        raise UnreachablePoseError(
            f"platform position xyz={point(out_of_reach)} m is out of reach of chain {chain} "
            f"(the forearm of length l_b={params.l_b} m cannot meet the elbow circle)"
        )
    base = np.arctan2(F, E)
    spread = np.arccos(K / amplitude)
    roots = np.remainder(np.stack([base + spread, base - spread]) + np.pi, 2.0 * np.pi) - np.pi
    alpha = np.where(np.cos(roots[0]) >= np.cos(roots[1]), roots[0], roots[1])
    outside = np.abs(alpha) >= 0.5 * np.pi
    if outside.any():
        chain = int(np.argwhere(outside)[0][-1]) + 1
        raise UnreachablePoseError(
            f"platform position xyz={point(outside)} m needs alpha_{chain}="
            f"{alpha[_first_failure(outside)][chain - 1]:.4f} rad, outside the elbow-out branch "
            "|alpha| < pi/2"
        )
    return alpha


def forward_kinematics_masked(params: DeltaParameters, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """FK of a batch without raising: (xyz (..., 3) [m], valid (...,) bool); xyz is NaN where the
    three spheres do not meet (see :func:`forward_kinematics`)."""
    alpha = as_vector3(alpha, "alpha")
    centres = elbow_positions(params, alpha) - params.r * _U
    rows = 2.0 * (centres[..., :1, :] - centres[..., 1:, :])  # (..., 2, 3)
    squared = _dot(centres, centres)
    rhs = squared[..., :1] - squared[..., 1:]
    direction = np.cross(rows[..., 0, :], rows[..., 1, :])
    norm = np.linalg.norm(direction, axis=-1, keepdims=True)
    valid = norm[..., 0] >= 1e-12  # three centres on one line: no unique line of solutions
    direction = direction / np.where(valid[..., None], norm, 1.0)
    direction = np.where(direction[..., 2:3] > 0.0, -direction, direction)
    gram = rows @ np.swapaxes(rows, -1, -2) + np.where(valid, 0.0, 1.0)[..., None, None] * np.eye(2)
    point = np.einsum("...ji,...j->...i", rows, np.linalg.solve(gram, rhs[..., None])[..., 0])
    offset = point - centres[..., 0, :]
    half_b = _dot(direction, offset)
    discriminant = half_b**2 - (_dot(offset, offset) - params.l_b**2)
    valid = valid & (discriminant >= 0.0)
    root = np.sqrt(np.where(valid, discriminant, 0.0))
    xyz = point + (-half_b + root)[..., None] * direction
    return np.where(valid[..., None], xyz, np.nan), valid


def forward_kinematics(params: DeltaParameters, alpha: np.ndarray) -> np.ndarray:
    """Platform position xyz [m] (..., 3) for active angles ``alpha`` [rad] (platform below base).

    The platform lies at distance l_b from each centre P_i = B_i - r u_i: two differences of the
    three sphere equations give a line, which meets the first sphere at two points; the lower
    one is returned.

    Raises:
        ForwardKinematicsError: the three spheres do not meet (no assembly for this ``alpha``).
    """
    alpha = as_vector3(alpha, "alpha")
    xyz, valid = forward_kinematics_masked(params, alpha)
    if not np.all(valid):
        bad = alpha[tuple(np.argwhere(~valid)[0])] if valid.ndim else alpha
        raise ForwardKinematicsError(
            f"alpha={bad.tolist()} rad has no forward kinematics: the forearms "
            f"(l_b={params.l_b} m) cannot reach a common platform position"
        )
    return xyz


def _closure_vectors(params: DeltaParameters, alpha: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    """Rows s_i = C_i - B_i (forearm vectors, |s_i| = l_b) (..., 3, 3) [m]."""
    return xyz[..., None, :] + params.r * _U - elbow_positions(params, alpha)


def jacobian(params: DeltaParameters, alpha: np.ndarray, xyz: np.ndarray | None = None) -> np.ndarray:
    """Jacobian J (..., 3, 3) with xyz_dot = J alpha_dot [m/rad] (eq. 10).

    Args:
        alpha: active angles [rad].
        xyz: the platform position for ``alpha`` [m] if already known (saves an FK).
    """
    if xyz is None:
        xyz = forward_kinematics(params, alpha)
    s = _closure_vectors(params, alpha, xyz)
    return np.linalg.solve(s, _diag(_dot(s, _elbow_tangents(params, alpha))))


def jacobian_derivative_times_velocity(
    params: DeltaParameters, alpha: np.ndarray, alpha_dot: np.ndarray, xyz: np.ndarray | None = None
) -> np.ndarray:
    """J_dot alpha_dot [m/s^2] (..., 3): the platform acceleration when alpha_ddot = 0.

    Differentiating s_i^T (p_dot - B_i' alpha_dot_i) = 0 once more gives
    s_i^T p_ddot = s_i^T B_i'' alpha_dot_i^2 - |p_dot - B_i' alpha_dot_i|^2.
    """
    if xyz is None:
        xyz = forward_kinematics(params, alpha)
    s = _closure_vectors(params, alpha, xyz)
    xyz_dot = (jacobian(params, alpha, xyz) @ alpha_dot[..., None])[..., 0]
    relative = xyz_dot[..., None, :] - _elbow_tangents(params, alpha) * alpha_dot[..., :, None]
    rhs = _dot(s, _elbow_curvatures(params, alpha)) * alpha_dot**2 - _dot(relative, relative)
    return np.linalg.solve(s, rhs[..., None])[..., 0]


def jacobian_derivative(
    params: DeltaParameters, alpha: np.ndarray, alpha_dot: np.ndarray, xyz: np.ndarray | None = None
) -> np.ndarray:
    """Time derivative J_dot (..., 3, 3) of the Jacobian along alpha_dot [m/(rad s)].

    From S J = diag(d) (S rows s_i^T, d_i = s_i^T B_i'):
    J_dot = S^-1 (diag(d_dot) - S_dot J) with s_i_dot = p_dot - B_i' alpha_dot_i and
    d_i_dot = s_i_dot^T B_i' + s_i^T B_i'' alpha_dot_i.
    """
    if xyz is None:
        xyz = forward_kinematics(params, alpha)
    s = _closure_vectors(params, alpha, xyz)
    tangents = _elbow_tangents(params, alpha)
    J = np.linalg.solve(s, _diag(_dot(s, tangents)))
    s_dot = (J @ alpha_dot[..., None])[..., 0][..., None, :] - tangents * alpha_dot[..., :, None]
    d_dot = _dot(s_dot, tangents) + _dot(s, _elbow_curvatures(params, alpha)) * alpha_dot
    return np.linalg.solve(s, _diag(d_dot) - s_dot @ J)

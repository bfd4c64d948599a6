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
    "solve3_batched",
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
    out = np.zeros((*d.shape, 3))
    out.reshape(*d.shape[:-1], 9)[..., ::4] = d  # entries (0, 0), (1, 1), (2, 2) of each matrix
    return out


def _components_first(X: np.ndarray) -> np.ndarray:
    """A contiguous copy of a batch of matrices (..., m, n) with the batch axes last, (m, n, ...):
    numpy then runs every loop over the whole batch instead of over 3 entries at a time."""
    return np.ascontiguousarray(X.transpose(X.ndim - 2, X.ndim - 1, *range(X.ndim - 2)))


def _cross_first(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u x v for vectors stored components first, (3, ...) each."""
    return np.stack([u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]])


def solve3_batched(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with A x = b for a batch of 3x3 systems, in closed form (the adjugate, i.e. Cramer's rule).

    With a_i the rows of A, the columns of adj(A) are a_1 x a_2, a_2 x a_0 and a_0 x a_1, so
    A adj(A) = det(A) I with det(A) = a_0 . (a_1 x a_2), and x = adj(A) b / det(A). On the batches
    of this module (N ~ 1e4-1e5 systems) this is 3-5x faster than ``np.linalg.solve``, which pays
    LAPACK's per-matrix overhead. A single system (A of shape (3, 3)) goes to ``np.linalg.solve``,
    ~4 us where this costs ~25 us; the two agree to ~1e-15 relative.

    Accuracy: the relative error grows like cond(A)^2 eps instead of LU's cond(A) eps; measured
    against ``np.linalg.solve`` (relative to |x|): ~1e-15 for cond(A) <= 10, 5e-14 at 100,
    5e-12 at 1e3, 5e-10 at 1e4. The Delta's forearm matrices S and Jacobians J are well
    conditioned in its workspace (cond < 5 measured on path I and on 20000 sampled states),
    where both agree with ``np.linalg.solve`` to ~1e-15.

    Args:
        A: matrices (..., 3, 3).
        b: right-hand sides: one vector per system, (3,) or (..., 3) with ``b.ndim == A.ndim - 1``,
            or k columns per system, (..., 3, k); batch axes broadcast as in numpy.

    Returns:
        x, of b's form: (..., 3) or (..., 3, k), in b's unit over A's.

    Raises:
        numpy.linalg.LinAlgError: a system of the batch is exactly singular (det(A) = 0), where
            ``np.linalg.solve`` raises the same. Near-singular systems are not detected (nor by
            ``np.linalg.solve``): x then grows like 1 / det(A).
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float)
    if A.ndim < 2 or A.shape[-2:] != (3, 3):
        raise ValueError(f"A must have shape (..., 3, 3), got {A.shape}")
    if A.ndim == 2 and b.ndim <= 2:  # one system: LAPACK is cheaper than the batched arithmetic
        return np.linalg.solve(A, b)
    vector = b.ndim in (1, A.ndim - 1)
    if vector:
        b = b[..., None]
    if b.ndim < 2 or b.shape[-2] != 3:
        raise ValueError(f"b must have shape (..., 3) or (..., 3, k), got {b.shape}")
    a, rhs = _components_first(A), _components_first(b)  # a[i] = row a_i, rhs[j] = row j of b
    columns = [_cross_first(a[1], a[2]), _cross_first(a[2], a[0]), _cross_first(a[0], a[1])]
    adjugate = np.stack(columns, axis=1)  # adjugate[i, j] = adj(A)[i, j]
    det = a[0, 0] * adjugate[0, 0] + a[0, 1] * adjugate[1, 0] + a[0, 2] * adjugate[2, 0]
    if not det.all():
        where = f" at batch index {tuple(np.argwhere(det == 0.0)[0].tolist())}" if det.ndim else ""
        raise np.linalg.LinAlgError(f"Singular matrix{where}: det(A) = 0")
    # x[i, k] = sum_j adj(A)[i, j] b[j, k] / det(A), batch last
    x = (adjugate[:, 0, None] * rhs[0] + adjugate[:, 1, None] * rhs[1] + adjugate[:, 2, None] * rhs[2]) / det
    x = np.ascontiguousarray(x.transpose(*range(2, x.ndim), 0, 1))
    return x[..., 0] if vector else x


def _first_failure(mask: np.ndarray) -> tuple:
    """Index of the first True of ``mask`` over the batch axes (``()`` for a single point)."""
    return tuple(np.argwhere(mask)[0][:-1]) if mask.ndim > 1 else ()


def _chain_rows(radial: np.ndarray, vertical: np.ndarray) -> np.ndarray:
    """Rows radial_i u_i + vertical_i e_z (..., 3, 3) from per-chain coefficients (..., 3)."""
    return np.stack([radial * _COS_PHI, radial * _SIN_PHI, vertical], axis=-1)


def elbow_positions(params: DeltaParameters, alpha: np.ndarray) -> np.ndarray:
    """Elbow points B_i (eq. 3) as rows of a (..., 3, 3) array [m]."""
    return _chain_rows(params.R + params.l_a * np.cos(alpha), -params.l_a * np.sin(alpha))


def _elbow_geometry(params: DeltaParameters, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The elbows B_i [m] and their derivatives B_i' = dB_i/dalpha_i [m/rad] and
    B_i'' = d^2B_i/dalpha_i^2 [m/rad^2], rows of (..., 3, 3) arrays, from one cos and one sin of alpha:

        B_i = R u_i + l_a (cos(alpha_i) u_i - sin(alpha_i) e_z),
        B_i' = l_a (-sin(alpha_i) u_i - cos(alpha_i) e_z),
        B_i'' = l_a (-cos(alpha_i) u_i + sin(alpha_i) e_z).
    """
    arm_cos, arm_sin = params.l_a * np.cos(alpha), params.l_a * np.sin(alpha)
    elbows = _chain_rows(params.R + arm_cos, -arm_sin)
    return elbows, _chain_rows(-arm_sin, -arm_cos), _chain_rows(-arm_cos, arm_sin)


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
    # The roots are base +- spread, and cos(base + spread) - cos(base - spread)
    # = -2 sin(base) sin(spread) >= 0 because sin(base) = F / amplitude < 0 (z < 0) and spread is
    # in [0, pi]: base + spread is the elbow-out root, and it lies in (-pi, pi) as base is in (-pi, 0).
    base = np.arctan2(F, E)
    spread = np.arccos(K / amplitude)
    alpha = base + spread
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


def _closure_vectors(params: DeltaParameters, xyz: np.ndarray, elbows: np.ndarray) -> np.ndarray:
    """Rows s_i = C_i - B_i (forearm vectors, |s_i| = l_b) (..., 3, 3) [m] from the elbows B_i."""
    return xyz[..., None, :] + params.r * _U - elbows


def jacobian(params: DeltaParameters, alpha: np.ndarray, xyz: np.ndarray | None = None) -> np.ndarray:
    """Jacobian J (..., 3, 3) with xyz_dot = J alpha_dot [m/rad] (eq. 10).

    Args:
        alpha: active angles [rad].
        xyz: the platform position for ``alpha`` [m] if already known (saves an FK).
    """
    if xyz is None:
        xyz = forward_kinematics(params, alpha)
    elbows, tangents, _ = _elbow_geometry(params, alpha)
    s = _closure_vectors(params, xyz, elbows)
    return solve3_batched(s, _diag(_dot(s, tangents)))


def jacobian_derivative_times_velocity(
    params: DeltaParameters,
    alpha: np.ndarray,
    alpha_dot: np.ndarray,
    xyz: np.ndarray | None = None,
    *,
    J: np.ndarray | None = None,
) -> np.ndarray:
    """J_dot alpha_dot [m/s^2] (..., 3): the platform acceleration when alpha_ddot = 0.

    Differentiating s_i^T (p_dot - B_i' alpha_dot_i) = 0 once more gives
    s_i^T p_ddot = s_i^T B_i'' alpha_dot_i^2 - |p_dot - B_i' alpha_dot_i|^2.

    Args:
        alpha: active angles [rad].
        alpha_dot: active joint rates [rad/s].
        xyz: the platform position for ``alpha`` [m] if already known (saves an FK).
        J: the Jacobian :func:`jacobian` at ``alpha`` [m/rad] if already known (saves computing it
            again; it is used as given).
    """
    if xyz is None:
        xyz = forward_kinematics(params, alpha)
    if J is None:
        J = jacobian(params, alpha, xyz)
    elbows, tangents, curvatures = _elbow_geometry(params, alpha)
    s = _closure_vectors(params, xyz, elbows)
    xyz_dot = (J @ alpha_dot[..., None])[..., 0]
    relative = xyz_dot[..., None, :] - tangents * alpha_dot[..., :, None]
    rhs = _dot(s, curvatures) * alpha_dot**2 - _dot(relative, relative)
    return solve3_batched(s, rhs)


def jacobian_derivative(
    params: DeltaParameters,
    alpha: np.ndarray,
    alpha_dot: np.ndarray,
    xyz: np.ndarray | None = None,
    *,
    J: np.ndarray | None = None,
) -> np.ndarray:
    """Time derivative J_dot (..., 3, 3) of the Jacobian along alpha_dot [m/(rad s)].

    From S J = diag(d) (S rows s_i^T, d_i = s_i^T B_i'):
    J_dot = S^-1 (diag(d_dot) - S_dot J) with s_i_dot = p_dot - B_i' alpha_dot_i and
    d_i_dot = s_i_dot^T B_i' + s_i^T B_i'' alpha_dot_i.

    Args:
        alpha: active angles [rad].
        alpha_dot: active joint rates [rad/s].
        xyz: the platform position for ``alpha`` [m] if already known (saves an FK).
        J: the Jacobian :func:`jacobian` at ``alpha`` [m/rad] if already known (saves computing it
            again; it is used as given).
    """
    if xyz is None:
        xyz = forward_kinematics(params, alpha)
    elbows, tangents, curvatures = _elbow_geometry(params, alpha)
    s = _closure_vectors(params, xyz, elbows)
    if J is None:
        J = solve3_batched(s, _diag(_dot(s, tangents)))
    s_dot = (J @ alpha_dot[..., None])[..., 0][..., None, :] - tangents * alpha_dot[..., :, None]
    d_dot = _dot(s_dot, tangents) + _dot(s, curvatures) * alpha_dot
    return solve3_batched(s, _diag(d_dot) - s_dot @ J)

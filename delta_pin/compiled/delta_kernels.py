"""Fast single-state kernels of the analytic model (the hot path of plants and controllers).

:mod:`delta_pin.model.kinematics` and :mod:`delta_pin.model.dynamics` are the readable specification and the
test oracle; they broadcast over batches but cost ~0.4 ms per single state in numpy. The kernels
here compute the same FK, J, J_dot, M, C, G for ONE state with explicit scalar arithmetic (3x3
inverses by cross products). They are compiled with numba when it is installed (~1 us per call)
and run as plain Python otherwise (same results, slower): ``FAST_BACKEND`` says which.

Every kernel reads the robot's constants from a :data:`~delta_pin.compiled.layouts.GEOMETRY`
record (built once per robot by :func:`delta_pin.model.dynamics.kernel_geometry`) and the chain
azimuths as (cos phi_i, sin phi_i) arrays (:func:`delta_pin.model.kinematics.chain_trigonometry`).
"""

from __future__ import annotations

import math

import numpy as np

from delta_pin.compiled.jit import as_record, njit

__all__ = [
    "delta_dynamics",
    "delta_dynamics_into",
    "delta_kinematics",
    "delta_kinematics_into",
    "delta_terms",
    "friction_torque",
    "solve3",
    "solve3_into",
    "stribeck_kernel",
]


@njit(cache=True)
def _inverse_into(s, inverse):
    """inverse = S^-1 for S with rows s_i, by cross products: columns (s_2 x s_3, s_3 x s_1,
    s_1 x s_2) / det(S). No pivoting: for the well-conditioned S and M of this model."""
    for column in range(3):
        a, b = (column + 1) % 3, (column + 2) % 3
        inverse[0, column] = s[a, 1] * s[b, 2] - s[a, 2] * s[b, 1]
        inverse[1, column] = s[a, 2] * s[b, 0] - s[a, 0] * s[b, 2]
        inverse[2, column] = s[a, 0] * s[b, 1] - s[a, 1] * s[b, 0]
    det = s[0, 0] * inverse[0, 0] + s[0, 1] * inverse[1, 0] + s[0, 2] * inverse[2, 0]
    for i in range(3):
        for j in range(3):
            inverse[i, j] /= det


@njit(cache=True)
def _inverse_columns(s):
    """Columns of S^-1 for S with rows s_i (see :func:`_inverse_into`)."""
    inverse = np.empty((3, 3))
    _inverse_into(s, inverse)
    return inverse


@njit(cache=True)
def solve3_into(A, b, x, work):
    """x = A^-1 b for a 3x3 A by cross products (``work``: a 3x3 scratch array)."""
    _inverse_into(A, work)
    for i in range(3):
        x[i] = work[i, 0] * b[0] + work[i, 1] * b[1] + work[i, 2] * b[2]


@njit(cache=True)
def solve3(A, b):
    """Solve A x = b for a 3x3 matrix by Cramer's rule (no pivoting: for SPD M and S only)."""
    x = np.empty(3)
    solve3_into(A, b, x, np.empty((3, 3)))
    return x


@njit(cache=True)
def delta_terms(geometry, cos_phi, sin_phi, m_eq, alpha, alpha_dot):
    """FK, J, J_dot, M, C, G of eqs. 3-10 at one state; ``ok`` is False without an FK solution.

    Args:
        geometry: a :data:`~delta_pin.compiled.layouts.GEOMETRY` record of the robot (or a
            one-record array, from Python).
        cos_phi, sin_phi: cos and sin of the chain azimuths (3,).
        m_eq: m_o + 3/2 m_b [kg].
        alpha, alpha_dot: active angles [rad] and velocities [rad/s], (3,).

    Returns:
        ``(ok, xyz, J, J_dot, M, C, G)``.
    """
    geometry = as_record(geometry)
    ok, xyz, J, J_dot = delta_kinematics(geometry, cos_phi, sin_phi, alpha, alpha_dot)
    if not ok:
        empty = np.zeros((3, 3))
        return False, xyz, empty, empty, empty, empty, np.zeros(3)
    M, C, G = delta_dynamics(geometry, m_eq, alpha, J, J_dot)
    return True, xyz, J, J_dot, M, C, G


@njit(cache=True)
def delta_dynamics(geometry, m_eq, alpha, J, J_dot):
    """M, C, G of eqs. 7-9 from the kinematics of :func:`delta_kinematics` (linear in m_eq [kg]:
    one kinematics serves several platform masses)."""
    geometry = as_record(geometry)
    M, C, G = np.empty((3, 3)), np.empty((3, 3)), np.empty(3)
    delta_dynamics_into(geometry, m_eq, alpha, J, J_dot, M, C, G)
    return M, C, G


@njit(cache=True)
def delta_dynamics_into(geometry, m_eq, alpha, J, J_dot, M, C, G):
    """:func:`delta_dynamics` into preallocated M, C (3, 3) and G (3,)."""
    arm_inertia, arm_gravity, g = geometry.arm_inertia, geometry.arm_gravity, geometry.g
    for i in range(3):
        for j in range(3):
            M[i, j] = m_eq * (J[0, i] * J[0, j] + J[1, i] * J[1, j] + J[2, i] * J[2, j])
            C[i, j] = m_eq * (J[0, i] * J_dot[0, j] + J[1, i] * J_dot[1, j] + J[2, i] * J_dot[2, j])
        M[i, i] += arm_inertia
        G[i] = -arm_gravity * math.cos(alpha[i]) + m_eq * g * J[2, i]


@njit(cache=True)
def delta_kinematics(geometry, cos_phi, sin_phi, alpha, alpha_dot):
    """FK, J and J_dot of eqs. 3-6 and 10 at one state: ``(ok, xyz, J, J_dot)``; ``ok`` is False
    without an FK solution (then xyz, J, J_dot are zeros)."""
    geometry = as_record(geometry)
    xyz, J, J_dot = np.zeros(3), np.zeros((3, 3)), np.zeros((3, 3))
    ok = delta_kinematics_into(
        geometry, cos_phi, sin_phi, alpha, alpha_dot, xyz, J, J_dot, np.empty((6, 3, 3))
    )
    if not ok:
        return False, np.zeros(3), np.zeros((3, 3)), np.zeros((3, 3))
    return True, xyz, J, J_dot


@njit(cache=True)
def delta_kinematics_into(geometry, cos_phi, sin_phi, alpha, alpha_dot, xyz, J, J_dot, work):
    """:func:`delta_kinematics` into preallocated xyz (3,), J, J_dot (3, 3) with a (6, 3, 3)
    scratch array; returns ``ok``."""
    R, r, l_a, l_b = geometry.R, geometry.r, geometry.l_a, geometry.l_b
    centres, tangents, curvatures, s, inverse, W = work[0], work[1], work[2], work[3], work[4], work[5]
    for i in range(3):
        ca = math.cos(alpha[i])
        sa = math.sin(alpha[i])
        reach = R - r + l_a * ca
        centres[i, 0] = reach * cos_phi[i]
        centres[i, 1] = reach * sin_phi[i]
        centres[i, 2] = -l_a * sa
        tangents[i, 0] = -l_a * sa * cos_phi[i]
        tangents[i, 1] = -l_a * sa * sin_phi[i]
        tangents[i, 2] = -l_a * ca
        curvatures[i, 0] = -l_a * ca * cos_phi[i]
        curvatures[i, 1] = -l_a * ca * sin_phi[i]
        curvatures[i, 2] = l_a * sa
    # FK: planes 2 (P_0 - P_k) . p = |P_0|^2 - |P_k|^2 meet on a line p0 + t n
    n1x = 2.0 * (centres[0, 0] - centres[1, 0])
    n1y = 2.0 * (centres[0, 1] - centres[1, 1])
    n1z = 2.0 * (centres[0, 2] - centres[1, 2])
    n2x = 2.0 * (centres[0, 0] - centres[2, 0])
    n2y = 2.0 * (centres[0, 1] - centres[2, 1])
    n2z = 2.0 * (centres[0, 2] - centres[2, 2])
    q0 = centres[0, 0] ** 2 + centres[0, 1] ** 2 + centres[0, 2] ** 2
    d1 = q0 - (centres[1, 0] ** 2 + centres[1, 1] ** 2 + centres[1, 2] ** 2)
    d2 = q0 - (centres[2, 0] ** 2 + centres[2, 1] ** 2 + centres[2, 2] ** 2)
    nx, ny, nz = n1y * n2z - n1z * n2y, n1z * n2x - n1x * n2z, n1x * n2y - n1y * n2x
    nn = nx * nx + ny * ny + nz * nz
    if nn < 1e-24:
        return False
    # p0 = (d1 (n2 x n) + d2 (n x n1)) / |n|^2
    p0x = (d1 * (n2y * nz - n2z * ny) + d2 * (ny * n1z - nz * n1y)) / nn
    p0y = (d1 * (n2z * nx - n2x * nz) + d2 * (nz * n1x - nx * n1z)) / nn
    p0z = (d1 * (n2x * ny - n2y * nx) + d2 * (nx * n1y - ny * n1x)) / nn
    norm = math.sqrt(nn)
    ux, uy, uz = nx / norm, ny / norm, nz / norm
    if uz > 0.0:
        ux, uy, uz = -ux, -uy, -uz
    ox, oy, oz = p0x - centres[0, 0], p0y - centres[0, 1], p0z - centres[0, 2]
    half_b = ux * ox + uy * oy + uz * oz
    discriminant = half_b * half_b - (ox * ox + oy * oy + oz * oz - l_b * l_b)
    if discriminant < 0.0:
        return False
    t = -half_b + math.sqrt(discriminant)
    xyz[0], xyz[1], xyz[2] = p0x + t * ux, p0y + t * uy, p0z + t * uz
    # J = S^-1 diag(s_i . B_i'), s_i = p - P_i
    for i in range(3):
        for k in range(3):
            s[i, k] = xyz[k] - centres[i, k]
    _inverse_into(s, inverse)
    for i in range(3):
        d_i = s[i, 0] * tangents[i, 0] + s[i, 1] * tangents[i, 1] + s[i, 2] * tangents[i, 2]
        for k in range(3):
            J[k, i] = inverse[k, i] * d_i
    # xyz_dot = J alpha_dot, written out: alpha_dot may be a strided view
    vx = J[0, 0] * alpha_dot[0] + J[0, 1] * alpha_dot[1] + J[0, 2] * alpha_dot[2]
    vy = J[1, 0] * alpha_dot[0] + J[1, 1] * alpha_dot[1] + J[1, 2] * alpha_dot[2]
    vz = J[2, 0] * alpha_dot[0] + J[2, 1] * alpha_dot[1] + J[2, 2] * alpha_dot[2]
    # J_dot = S^-1 (diag(d_dot) - S_dot J), s_i_dot = p_dot - B_i' alpha_dot_i
    for i in range(3):
        sx = vx - tangents[i, 0] * alpha_dot[i]
        sy = vy - tangents[i, 1] * alpha_dot[i]
        sz = vz - tangents[i, 2] * alpha_dot[i]
        for j in range(3):
            W[i, j] = -(sx * J[0, j] + sy * J[1, j] + sz * J[2, j])
        curvature = s[i, 0] * curvatures[i, 0] + s[i, 1] * curvatures[i, 1] + s[i, 2] * curvatures[i, 2]
        W[i, i] += sx * tangents[i, 0] + sy * tangents[i, 1] + sz * tangents[i, 2] + curvature * alpha_dot[i]
    for i in range(3):
        for j in range(3):
            J_dot[i, j] = inverse[i, 0] * W[0, j] + inverse[i, 1] * W[1, j] + inverse[i, 2] * W[2, j]
    return True


@njit(cache=True)
def stribeck_kernel(r_a, v_s, mu_s, mu_d, mu_v, alpha_dot, normal_force, sign_velocity_scale):
    """Eq. 12 for three joints, like :func:`delta_pin.model.friction.stribeck_torque` [N m].

    ``normal_force`` is (3,) [N]; ``sign_velocity_scale`` > 0 smooths sgn by tanh [rad/s].
    """
    torque = np.empty(3)
    for i in range(3):
        v = alpha_dot[i]
        sliding = v * r_a / v_s
        if sign_velocity_scale > 0.0:
            sign = math.tanh(v / sign_velocity_scale)
        else:
            sign = 0.0 if v == 0.0 else math.copysign(1.0, v)
        level = mu_d * normal_force[i] + (mu_s - mu_d) * normal_force[i] * math.exp(-(sliding * sliding))
        torque[i] = level * sign * r_a + mu_v * v * r_a
    return torque


@njit(cache=True)
def friction_torque(friction, alpha_dot, normal_force):
    """:func:`stribeck_kernel` for a :data:`~delta_pin.compiled.layouts.FRICTION` record (or a
    one-record array; it must be ``on``) [N m]."""
    friction = as_record(friction)
    return stribeck_kernel(
        friction.r_a,
        friction.v_s,
        friction.mu_s,
        friction.mu_d,
        friction.mu_v,
        alpha_dot,
        normal_force,
        friction.sign_velocity_scale,
    )

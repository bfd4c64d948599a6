"""Fast single-state kernels of the analytic model (the hot path of plants and controllers).

:mod:`delta_pin.kinematics` and :mod:`delta_pin.dynamics` are the readable specification and the
test oracle; they broadcast over batches but cost ~0.4 ms per single state in numpy. The kernels
here compute the same FK, J, J_dot, M, C, G for ONE state with explicit scalar arithmetic (3x3
inverses by cross products). They are compiled with numba when it is installed (~1 us per call)
and run as plain Python otherwise (same results, slower): ``FAST_BACKEND`` says which.

The geometry is packed once per robot by :func:`pack_geometry`:
``[R, r, l_a, l_b, (m_a/3 + m_b/2) l_a^2, (m_a + m_b) g l_a / 2, g]`` (SI units).
"""

from __future__ import annotations

import math

import numpy as np

from .description import DeltaParameters, chain_azimuths

try:  # pragma: no cover - which branch runs depends on the environment
    from numba import njit

    FAST_BACKEND = "numba"
except ImportError:  # pragma: no cover
    FAST_BACKEND = "python"

    def njit(*args, **kwargs):
        """Identity decorator standing in for ``numba.njit``."""
        if args and callable(args[0]):
            return args[0]
        return lambda function: function


__all__ = ["FAST_BACKEND", "delta_dynamics", "delta_kinematics", "delta_terms", "pack_geometry", "solve3"]

_COS = np.cos(chain_azimuths())
_SIN = np.sin(chain_azimuths())


def pack_geometry(params: DeltaParameters) -> np.ndarray:
    """The constants :func:`delta_terms` needs, as a float array (see the module docstring)."""
    return np.array(
        [
            params.R,
            params.r,
            params.l_a,
            params.l_b,
            params.arm_equivalent_inertia,
            0.5 * (params.m_a + params.m_b) * params.g * params.l_a,
            params.g,
        ]
    )


@njit(cache=True)
def _cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@njit(cache=True)
def _inverse_columns(s):
    """Columns of S^-1 for S with rows s_i: (s_2 x s_3, s_3 x s_1, s_1 x s_2) / det(S)."""
    inverse = np.empty((3, 3))
    c0 = _cross(s[1], s[2])
    c1 = _cross(s[2], s[0])
    c2 = _cross(s[0], s[1])
    det = s[0, 0] * c0[0] + s[0, 1] * c0[1] + s[0, 2] * c0[2]
    for k in range(3):
        inverse[k, 0] = c0[k] / det
        inverse[k, 1] = c1[k] / det
        inverse[k, 2] = c2[k] / det
    return inverse


@njit(cache=True)
def solve3(A, b):
    """Solve A x = b for a 3x3 matrix by Cramer's rule (no pivoting: for SPD M and S only)."""
    return _inverse_columns(A) @ b


@njit(cache=True)
def delta_terms(geometry, cos_phi, sin_phi, m_eq, alpha, alpha_dot):
    """FK, J, J_dot, M, C, G of eqs. 3-10 at one state; ``ok`` is False without an FK solution.

    Args:
        geometry: :func:`pack_geometry` of the robot.
        cos_phi, sin_phi: cos and sin of the chain azimuths (3,).
        m_eq: m_o + 3/2 m_b [kg].
        alpha, alpha_dot: active angles [rad] and velocities [rad/s], (3,).

    Returns:
        ``(ok, xyz, J, J_dot, M, C, G)``.
    """
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
    arm_inertia, arm_gravity, g = geometry[4], geometry[5], geometry[6]
    M = m_eq * (J.T @ J)
    C = m_eq * (J.T @ J_dot)
    G = np.empty(3)
    for i in range(3):
        M[i, i] += arm_inertia
        G[i] = -arm_gravity * math.cos(alpha[i]) + m_eq * g * J[2, i]
    return M, C, G


@njit(cache=True)
def delta_kinematics(geometry, cos_phi, sin_phi, alpha, alpha_dot):
    """FK, J and J_dot of eqs. 3-6 and 10 at one state: ``(ok, xyz, J, J_dot)``; ``ok`` is False
    without an FK solution."""
    R, r, l_a, l_b = geometry[0], geometry[1], geometry[2], geometry[3]
    centres = np.empty((3, 3))
    tangents = np.empty((3, 3))
    curvatures = np.empty((3, 3))
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
    n1 = 2.0 * (centres[0] - centres[1])
    n2 = 2.0 * (centres[0] - centres[2])
    q0 = centres[0] @ centres[0]
    d1 = q0 - centres[1] @ centres[1]
    d2 = q0 - centres[2] @ centres[2]
    n = _cross(n1, n2)
    nn = n @ n
    xyz = np.zeros(3)
    empty = np.zeros((3, 3))
    if nn < 1e-24:
        return False, xyz, empty, empty
    p0 = (d1 * _cross(n2, n) + d2 * _cross(n, n1)) / nn
    direction = n / math.sqrt(nn)
    if direction[2] > 0.0:
        direction = -direction
    offset = p0 - centres[0]
    half_b = direction @ offset
    discriminant = half_b * half_b - (offset @ offset - l_b * l_b)
    if discriminant < 0.0:
        return False, xyz, empty, empty
    xyz = p0 + (-half_b + math.sqrt(discriminant)) * direction
    # J = S^-1 diag(s_i . B_i'), s_i = p - P_i
    s = np.empty((3, 3))
    for i in range(3):
        s[i] = xyz - centres[i]
    inverse = _inverse_columns(s)
    J = np.empty((3, 3))
    for i in range(3):
        d_i = s[i] @ tangents[i]
        for k in range(3):
            J[k, i] = inverse[k, i] * d_i
    xyz_dot = np.zeros(3)  # J @ alpha_dot, written out: alpha_dot may be a strided view
    for k in range(3):
        for i in range(3):
            xyz_dot[k] += J[k, i] * alpha_dot[i]
    # J_dot = S^-1 (diag(d_dot) - S_dot J), s_i_dot = p_dot - B_i' alpha_dot_i
    W = np.empty((3, 3))
    for i in range(3):
        s_dot = xyz_dot - tangents[i] * alpha_dot[i]
        for j in range(3):
            W[i, j] = -(s_dot[0] * J[0, j] + s_dot[1] * J[1, j] + s_dot[2] * J[2, j])
        W[i, i] += s_dot @ tangents[i] + (s[i] @ curvatures[i]) * alpha_dot[i]
    return True, xyz, J, inverse @ W


def chain_trigonometry() -> tuple[np.ndarray, np.ndarray]:
    """(cos phi_i, sin phi_i) arrays to pass to :func:`delta_terms`."""
    return _COS.copy(), _SIN.copy()


@njit(cache=True)
def stribeck_kernel(r_a, v_s, mu_s, mu_d, mu_v, alpha_dot, normal_force, sign_velocity_scale):
    """Eq. 12 for three joints, like :func:`delta_pin.friction.stribeck_torque` [N m].

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


def friction_kernel_arguments(stribeck) -> tuple[float, float, float, float, float]:
    """(r_a, v_s, mu_s, mu_d, mu_v) of a :class:`~delta_pin.description.StribeckParameters`."""
    return (stribeck.r_a, stribeck.v_s, stribeck.mu_s, stribeck.mu_d, stribeck.mu_v)

"""Trajectories: the paper's formulas, analytic derivatives against finite differences, the joint
references against finite differences of the IK, the Adept cycle's geometry, workspace errors.

Finite-difference tolerance (docs/architecture.md section 9: tier 1e-6): errors are compared
with 1e-6 times the largest magnitude of the checked quantity over the samples (a pure rtol
fails where a component crosses zero). Central differences with h = 1e-5 s have truncation error
h^2/6 |x'''| and rounding error
~eps |x| / h; both stay below 1e-7 relative here (measured: <= 2e-8 for the velocities, <= 1.3e-7
for the Adept cycle's accelerations, whose 4th derivative reaches 1.3e5 m/s^4). The joint
accelerations use the five-point stencil (error O(H^4)) with H = 3e-4 s (measured <= 2e-8).
Samples keep clear of the points where a path is only C^2 (Adept corners, spline knots and ends),
where a stencil straddling the point would see the jump of the third derivative.
"""

import json
import re

import numpy as np
import pytest

from delta_pin.errors import InvalidParameterError, UnreachablePoseError
from delta_pin.model import kinematics
from delta_pin.model.trajectory import (
    AdeptCycle,
    JointReference,
    PathI,
    PathII,
    SplinePath,
    Trajectory,
    check_workspace,
    joint_reference,
)

FD_TOL = 1e-6  # relative to the largest magnitude of the checked quantity
SPLINE_TIMES = [0.0, 0.5, 1.2, 2.0]  # [s]
SPLINE_POINTS = [[0.0, 0.0, -0.40], [0.05, 0.02, -0.38], [-0.03, 0.08, -0.45], [0.10, -0.05, -0.42]]  # [m]


def spline() -> SplinePath:
    return SplinePath(SPLINE_TIMES, SPLINE_POINTS)


# (trajectory factory, sampled interval [s], times where the path is only C^2 [s])
CASES = {
    "path I": (PathI, 15.0, []),
    "path II": (PathII, 15.0, []),
    "adept": (AdeptCycle, 2.0, np.concatenate([AdeptCycle().segment_starts + n for n in range(3)])),
    "adept rotated": (
        lambda: AdeptCycle(cycle_time=0.8, z=-0.45, center=(0.02, -0.03), direction=1.0),
        1.6,
        np.concatenate([AdeptCycle(cycle_time=0.8).segment_starts + 0.8 * n for n in range(3)]),
    ),
    "spline": (spline, 2.0, SPLINE_TIMES),
}


def sample_times(case: str, count: int = 120, clearance: float = 2e-3) -> tuple[Trajectory, np.ndarray]:
    """The case's trajectory and seeded random times at least ``clearance`` from its C^2 points."""
    factory, t_end, kinks = CASES[case]
    t = np.random.default_rng(7).uniform(0.0, t_end, count)
    if len(kinks):
        t = t[np.min(np.abs(t[:, None] - np.asarray(kinks)[None, :]), axis=1) > clearance]
    return factory(), t


def assert_close_scaled(actual: np.ndarray, expected: np.ndarray, tol: float = FD_TOL) -> None:
    scale = np.abs(expected).max()
    np.testing.assert_allclose(actual, expected, rtol=0.0, atol=tol * scale)


# ------------------------------------------------------------------------------------ paper's paths
def test_path_i_is_eq_66():
    t = np.linspace(0.0, 15.0, 151)
    expected = np.stack(
        [0.05 * t / 15 * np.cos(2 * np.pi * t), 0.05 * t / 15 * np.sin(2 * np.pi * t), -0.35 + 0.01 * t], -1
    )
    np.testing.assert_allclose(PathI().position(t), expected, rtol=0.0, atol=1e-15)


def test_path_ii_is_eq_69():
    t = np.linspace(0.0, 15.0, 151)
    expected = np.stack([0.1 * np.sin(np.pi * t), 0.1 * np.cos(np.pi * t), -0.4 + 0.02 * t / np.pi], -1)
    np.testing.assert_allclose(PathII().position(t), expected, rtol=0.0, atol=1e-15)


def test_float_time_gives_one_point_and_arrays_give_rows():
    path = PathII()
    t = np.array([0.0, 0.3, 2.7])
    for method in (path.position, path.velocity, path.acceleration):
        assert method(0.3).shape == (3,)
        np.testing.assert_array_equal(method(t)[1], method(0.3))
        assert method(t).shape == (3, 3)
    with pytest.raises(InvalidParameterError, match="shape"):
        path.position(np.zeros((2, 2)))
    with pytest.raises(InvalidParameterError, match="non-finite"):
        path.position(np.nan)


# -------------------------------------------------------------------------- analytic derivatives
@pytest.mark.parametrize("case", sorted(CASES))
def test_derivatives_match_central_differences(case):
    path, t = sample_times(case)
    h = 1e-5  # [s]
    assert_close_scaled(path.velocity(t), (path.position(t + h) - path.position(t - h)) / (2 * h))
    assert_close_scaled(path.acceleration(t), (path.velocity(t + h) - path.velocity(t - h)) / (2 * h))


@pytest.mark.parametrize("case", sorted(CASES))
def test_joint_reference_matches_differences_of_the_ik(robot, case):
    path, t = sample_times(case)
    reference = path.joint_reference(robot, t)
    H = 3e-4  # [s]
    ik = [kinematics.inverse_kinematics(robot.params, path.position(t + j * H)) for j in (-2, -1, 0, 1, 2)]
    np.testing.assert_allclose(reference.alpha, ik[2], rtol=0.0, atol=1e-12)
    alpha_dot = (ik[0] - 8 * ik[1] + 8 * ik[3] - ik[4]) / (12 * H)
    alpha_ddot = (-ik[0] + 16 * ik[1] - 30 * ik[2] + 16 * ik[3] - ik[4]) / (12 * H**2)
    assert_close_scaled(reference.alpha_dot, alpha_dot)
    assert_close_scaled(reference.alpha_ddot, alpha_ddot)
    # and back to task space: J alpha_dot = xyz_dot (identity tier)
    J = kinematics.jacobian(robot.params, reference.alpha, reference.xyz)
    np.testing.assert_allclose((J @ reference.alpha_dot[..., None])[..., 0], reference.xyz_dot, atol=1e-12)


def test_joint_reference_container(robot):
    reference = joint_reference(PathI(), robot.params, 0.5)  # parameters instead of the robot, float t
    assert isinstance(reference, JointReference)
    assert len(reference) == 1
    assert reference.t.shape == (1,)
    assert all(getattr(reference, name).shape == (1, 3) for name in ("xyz", "alpha", "alpha_ddot"))
    expected = np.stack([reference.alpha[0], reference.alpha_dot[0], reference.alpha_ddot[0]])
    np.testing.assert_array_equal(np.stack(reference.at(0)), expected)
    with pytest.raises(ValueError):
        reference.alpha[0, 0] = 1.0  # read-only


# -------------------------------------------------------------------------------------- Adept cycle
def test_adept_geometry():
    cycle = AdeptCycle(cycle_time=0.9, height=0.03, width=0.2, z=-0.42, center=(0.01, 0.02), direction=0.5)
    xyz = cycle.position(np.linspace(0.0, 0.9, 9001))
    assert xyz[:, 2].max() == pytest.approx(-0.42 + 0.03, abs=1e-12)
    assert xyz[:, 2].min() == pytest.approx(-0.42, abs=1e-12)
    across = np.array([np.cos(0.5), np.sin(0.5)])
    travel = (xyz[:, :2] - [0.01, 0.02]) @ across
    assert travel.min() == pytest.approx(-0.1, abs=1e-12)
    assert travel.max() == pytest.approx(0.1, abs=1e-12)
    np.testing.assert_allclose((xyz[:, :2] - [0.01, 0.02]) @ [-across[1], across[0]], 0.0, atol=1e-15)
    # corners: A -> up -> across -> B -> up -> across -> A
    corners = cycle.position(np.append(cycle.segment_starts, 0.9))
    A, B = cycle.pick_point, cycle.place_point
    up = [0.0, 0.0, 0.03]
    np.testing.assert_allclose(corners, [A, A + up, B + up, B, B + up, A + up, A], atol=1e-15)
    assert np.linalg.norm(B - A) == pytest.approx(0.2)
    # the sqrt(length) split gives every segment the same peak acceleration
    assert cycle.segment_durations.sum() == pytest.approx(0.9)
    lengths = np.array([0.03, 0.2, 0.03, 0.03, 0.2, 0.03])
    np.testing.assert_allclose(
        10 / np.sqrt(3) * lengths / cycle.segment_durations**2, cycle.peak_acceleration
    )
    peak = np.linalg.norm(cycle.acceleration(np.linspace(0.0, 0.9, 20001)), axis=1).max()
    assert peak == pytest.approx(cycle.peak_acceleration, rel=1e-4)


def test_adept_is_c2_at_the_segment_joints():
    cycle = AdeptCycle()
    joints = np.append(cycle.segment_starts, cycle.cycle_time)
    eps = 1e-9  # [s]
    scale_v = np.abs(cycle.velocity(np.linspace(0, 1, 2001))).max()
    scale_a = np.abs(cycle.acceleration(np.linspace(0, 1, 2001))).max()
    for get, scale in ((cycle.position, 1.0), (cycle.velocity, scale_v), (cycle.acceleration, scale_a)):
        np.testing.assert_allclose(get(joints - eps), get(joints + eps), atol=1e-6 * scale)
    # the corners are stops: zero velocity and acceleration
    np.testing.assert_allclose(cycle.velocity(joints), 0.0, atol=1e-12)
    np.testing.assert_allclose(cycle.acceleration(joints), 0.0, atol=1e-12)


def test_adept_periodicity_and_single_cycle():
    t = np.linspace(0.0, 1.0, 101)
    periodic = AdeptCycle()
    assert periodic.duration is None
    for get in (periodic.position, periodic.velocity, periodic.acceleration):
        np.testing.assert_allclose(get(t + 3.0), get(t), atol=1e-9)
    once = AdeptCycle(periodic=False)
    assert once.duration == 1.0
    later = np.array([-0.5, 1.0, 1.3, 7.0])
    np.testing.assert_allclose(once.position(later), np.tile(once.pick_point, (4, 1)), atol=1e-15)
    np.testing.assert_array_equal(once.velocity(later), 0.0)
    np.testing.assert_array_equal(once.acceleration(later), 0.0)


@pytest.mark.parametrize("direction", [0.0, np.pi / 6, np.pi / 2])
def test_default_adept_cycle_is_reachable_on_table_1_robot(robot, direction):
    check_workspace(AdeptCycle(direction=direction), robot, t_end=1.0, dt=1e-3)


# ---------------------------------------------------------------------------------------- spline
def test_spline_interpolates_starts_and_ends_at_rest():
    path = spline()
    np.testing.assert_allclose(path.position(np.array(SPLINE_TIMES)), SPLINE_POINTS, atol=1e-15)
    np.testing.assert_allclose(path.velocity(np.array([0.0, 2.0])), 0.0, atol=1e-15)
    outside = np.array([-1.0, 2.5])
    np.testing.assert_allclose(path.position(outside), np.array(SPLINE_POINTS)[[0, -1]], atol=1e-15)
    np.testing.assert_array_equal(path.velocity(outside), 0.0)
    np.testing.assert_array_equal(path.acceleration(outside), 0.0)
    assert path.duration == 2.0


# ------------------------------------------------------------------------------ workspace errors
def test_path_out_of_the_workspace_names_time_and_point(robot):
    path = SplinePath([0.0, 2.0], [[0.0, 0.0, -0.4], [0.0, 0.0, -0.9]], name="dive")
    dt = 1e-3
    with pytest.raises(UnreachablePoseError, match=r"dive leaves the workspace at t=") as info:
        check_workspace(path, robot, dt=dt)
    match = re.search(r"t=([0-9.eE+-]+) s: xyz=\[([^\]]+)\] m", str(info.value))
    assert match, str(info.value)
    t_fail = float(match.group(1))
    np.testing.assert_allclose(
        [float(v) for v in match.group(2).split(",")], path.position(t_fail), atol=1e-6
    )
    assert 0.0 < t_fail < 2.0
    kinematics.inverse_kinematics(robot.params, path.position(t_fail - dt))  # the sample before is fine
    with pytest.raises(UnreachablePoseError):
        kinematics.inverse_kinematics(robot.params, path.position(t_fail))
    # joint_reference finds the same first failure, also on a denser grid with later failures
    with pytest.raises(UnreachablePoseError, match=f"t={t_fail:.6g} s"):
        path.joint_reference(robot, np.arange(0.0, 2.0 + dt / 2, dt))


def test_too_wide_adept_cycle_is_refused(robot):
    with pytest.raises(UnreachablePoseError, match="Adept cycle leaves the workspace at t="):
        AdeptCycle(width=0.8).check_workspace(robot, t_end=1.0)


def test_check_workspace_arguments(robot):
    with pytest.raises(InvalidParameterError, match="unbounded"):
        check_workspace(PathI(), robot)
    with pytest.raises(InvalidParameterError, match="dt=0"):
        check_workspace(PathI(), robot, t_end=1.0, dt=0.0)
    with pytest.raises(InvalidParameterError, match="t_end=-1"):
        check_workspace(PathI(), robot, t_end=-1.0)
    check_workspace(PathI(), robot, t_end=15.0)
    check_workspace(PathII(), robot, t_end=15.0)


# ------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"cycle_time": 0.0}, "cycle_time=0.0"),
        ({"cycle_time": -1.0}, "cycle_time=-1.0"),
        ({"height": -0.01}, "height=-0.01"),
        ({"width": float("nan")}, "width=nan"),
        ({"z": float("inf")}, "z="),
        ({"center": (0.0, 0.0, 0.0)}, "center"),
    ],
)
def test_adept_refuses_bad_parameters(kwargs, message):
    with pytest.raises(InvalidParameterError, match=re.escape(message)):
        AdeptCycle(**kwargs)


@pytest.mark.parametrize(
    ("times", "waypoints", "message"),
    [
        ([0.0, 1.0, 1.0], [[0, 0, -0.4]] * 3, "times[2]=1.0 s follows times[1]=1.0 s"),
        ([0.0, 2.0, 1.0], [[0, 0, -0.4]] * 3, "increase strictly"),
        ([0.0, 1.0], [[0, 0, -0.4]] * 3, "waypoints must have shape (2, 3)"),
        ([0.0, 1.0], [[0, 0], [0, 0]], "waypoints must have shape (2, 3)"),
        ([0.0], [[0, 0, -0.4]], "M >= 2"),
        ([0.0, np.nan], [[0, 0, -0.4]] * 2, "times=[0.0, nan]"),
        ([0.0, 1.0], [[0, 0, -0.4], [0, np.inf, -0.4]], "non-finite"),
    ],
)
def test_spline_refuses_bad_input(times, waypoints, message):
    with pytest.raises(InvalidParameterError, match=re.escape(message)):
        SplinePath(times, waypoints)


# -------------------------------------------------------------------------------------- metadata
@pytest.mark.parametrize("case", sorted(CASES))
def test_metadata_is_json(case):
    path = CASES[case][0]()
    data = json.loads(json.dumps(path.metadata()))
    assert data["type"] == type(path).__name__
    assert data["name"] == path.name
    assert type(path).__name__ in repr(path)


def lu_joint_reference(params, xyz: np.ndarray, xyz_dot: np.ndarray, xyz_ddot: np.ndarray):
    """(alpha, alpha_dot, alpha_ddot) the way joint_reference computed them before the closed-form
    solver, written out independently of delta_pin.model.kinematics: eq. 5's two roots and the
    larger cosine, then LU solves (np.linalg.solve) with the forearm matrix S and with J."""
    phi = (2 * np.arange(1, 4) / 3 - 0.5) * np.pi
    u = np.stack([np.cos(phi), np.sin(phi), np.zeros(3)], axis=1)  # rows u_i
    e_z = np.array([0.0, 0.0, 1.0])
    x, y, z = xyz[:, :1], xyz[:, 1:2], xyz[:, 2:]
    offset = params.R - params.r - (x * np.cos(phi) + y * np.sin(phi))
    across = -x * np.sin(phi) + y * np.cos(phi)
    E, F = 2.0 * offset * params.l_a, np.broadcast_to(2.0 * z * params.l_a, offset.shape)
    K = params.l_b**2 - offset**2 - params.l_a**2 - across**2 - z**2
    base, spread = np.arctan2(F, E), np.arccos(K / np.hypot(E, F))
    roots = np.remainder(np.stack([base + spread, base - spread]) + np.pi, 2.0 * np.pi) - np.pi
    alpha = np.where(np.cos(roots[0]) >= np.cos(roots[1]), roots[0], roots[1])
    c, s = np.cos(alpha)[..., None], np.sin(alpha)[..., None]
    elbows = params.R * u + params.l_a * (c * u - s * e_z)
    tangents = params.l_a * (-s * u - c * e_z)
    curvatures = params.l_a * (-c * u + s * e_z)
    S = xyz[:, None, :] + params.r * u - elbows
    J = np.linalg.solve(S, np.einsum("nij,nij->ni", S, tangents)[..., None] * np.eye(3))
    alpha_dot = np.linalg.solve(J, xyz_dot[..., None])[..., 0]
    relative = xyz_dot[:, None, :] - tangents * alpha_dot[..., None]
    rhs = np.einsum("nij,nij->ni", S, curvatures) * alpha_dot**2 - np.einsum(
        "nij,nij->ni", relative, relative
    )
    drift = np.linalg.solve(S, rhs[..., None])[..., 0]
    alpha_ddot = np.linalg.solve(J, (xyz_ddot - drift)[..., None])[..., 0]
    return alpha, alpha_dot, alpha_ddot


def test_joint_reference_matches_lu_solves_on_path_i(robot):
    # the closed-form 3x3 solves (Cramer's rule) against LU on a 15 s run's 1 ms grid: S and J have
    # cond < 5 along path I, where both agree to ~1e-15 (measured <= 6e-15 relative per sample)
    path, t = PathI(), np.arange(15001) * 1e-3
    reference = path.joint_reference(robot, t)
    expected = lu_joint_reference(robot.params, path.position(t), path.velocity(t), path.acceleration(t))
    for name, value in zip(("alpha", "alpha_dot", "alpha_ddot"), expected):
        error = np.linalg.norm(getattr(reference, name) - value, axis=1)
        assert np.all(error <= 1e-12 * np.linalg.norm(value, axis=1)), name

"""Closed-form IK, FK, J and J_dot alpha_dot against round trips and finite differences."""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.model import kinematics
from delta_pin.model.validation import sample_states

H = 1e-6  # [rad] central-difference step; truncation ~h^2 and round-off ~1e-10 => rtol 1e-6


def test_paper_initial_angles_erratum_4(robot):
    # Path I starts at (0, 0, -0.35): IK gives 0.2492 rad, not the paper's alpha_0 = 0.3322 rad,
    # which is the IK of z = -0.37 (docs/architecture.md section 4, erratum 4).
    assert robot.inverse_kinematics([0, 0, -0.35]) == pytest.approx(np.full(3, 0.24925), abs=5e-5)
    assert robot.inverse_kinematics([0, 0, -0.37]) == pytest.approx(np.full(3, 0.3322), abs=5e-5)


def test_ik_satisfies_eq5_and_round_trips(robot, other_robot, rng):
    for r in (robot, other_robot):
        p = r.params
        alphas, _ = sample_states(r, 50, seed=1)
        for alpha in alphas:
            xyz = r.forward_kinematics(alpha)
            assert xyz[2] < 0.0
            assert r.inverse_kinematics(xyz) == pytest.approx(alpha, abs=1e-12)
            # eq. 5, written out independently of the implementation
            for i, phi in enumerate((2 * np.arange(1, 4) / 3 - 0.5) * np.pi):
                c = p.R - p.r + p.l_a * np.cos(alpha[i])
                lhs = (
                    (c * np.cos(phi) - xyz[0]) ** 2
                    + (c * np.sin(phi) - xyz[1]) ** 2
                    + (p.l_a * np.sin(alpha[i]) + xyz[2]) ** 2
                )
                assert lhs == pytest.approx(p.l_b**2, rel=1e-13)


def test_jacobian_matches_finite_differences(robot, other_robot):
    for r in (robot, other_robot):
        for alpha in sample_states(r, 20, seed=2)[0]:
            fd = np.column_stack(
                [
                    (r.forward_kinematics(alpha + H * e) - r.forward_kinematics(alpha - H * e)) / (2 * H)
                    for e in np.eye(3)
                ]
            )
            np.testing.assert_allclose(r.jacobian(alpha), fd, rtol=1e-6, atol=1e-9)


def test_jacobian_rate_matches_finite_differences(robot, other_robot):
    for r in (robot, other_robot):
        for alpha, alpha_dot in zip(*sample_states(r, 20, seed=3)):
            fd = (r.jacobian(alpha + H * alpha_dot) - r.jacobian(alpha - H * alpha_dot)) / (2 * H)
            np.testing.assert_allclose(
                r.jacobian_derivative_times_velocity(alpha, alpha_dot), fd @ alpha_dot, rtol=1e-6, atol=1e-9
            )
            np.testing.assert_allclose(
                kinematics.jacobian_derivative(r.params, alpha, alpha_dot), fd, rtol=1e-6, atol=1e-9
            )


def test_unreachable_point_names_the_point(robot):
    with pytest.raises(dp.UnreachablePoseError, match=r"xyz=\[0.0, 0.0, -0.9\]"):
        robot.inverse_kinematics([0.0, 0.0, -0.9])


def test_point_above_the_branch_is_refused(robot):
    # the mirror configuration above the base is not on the FK branch (platform below the base)
    with pytest.raises(dp.UnreachablePoseError, match="not below the base"):
        robot.inverse_kinematics([0.0, 0.0, 0.3])


def test_forward_kinematics_without_solution_names_alpha():
    # short forearms: at alpha = 0 the sphere centres lie 0.27 m from the axis, beyond l_b = 0.25 m
    short = dp.load_delta(l_b=0.25)
    with pytest.raises(dp.ForwardKinematicsError, match=r"alpha=\[0.0, 0.0, 0.0\]"):
        short.forward_kinematics([0.0, 0.0, 0.0])


@pytest.mark.parametrize("bad", [[np.nan, 0, 0], [0, np.inf, 0]])
def test_non_finite_input_is_refused(robot, bad):
    with pytest.raises(dp.NonFiniteError):
        robot.forward_kinematics(bad)
    with pytest.raises(dp.NonFiniteError):
        robot.inverse_kinematics(bad)

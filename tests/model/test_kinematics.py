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


# ------------------------------------------------------------------------ closed-form 3x3 solver
# Cramer's rule errs like cond(A)^2 eps (LU: cond(A) eps); for cond(A) <= 10 both stay within
# ~1e-14 of the exact x (measured <= 2e-15), so 1e-12 relative to |x| leaves a wide margin.
SOLVE_RTOL = 1e-12


def conditioned_matrices(rng, shape: tuple[int, ...], cond: float = 10.0) -> np.ndarray:
    """Random A = Q1 diag(sigma) Q2 (..., 3, 3) with cond(A) = ``cond`` and scales over 1e-3..1e3."""
    q1 = np.linalg.qr(rng.standard_normal((*shape, 3, 3)))[0]
    q2 = np.linalg.qr(rng.standard_normal((*shape, 3, 3)))[0]
    sigma = np.stack([np.ones(shape), np.full(shape, cond), rng.uniform(1.0, cond, shape)], axis=-1)
    return (q1 * sigma[..., None, :]) @ q2 * 10.0 ** rng.uniform(-3, 3, (*shape, 1, 1))


def assert_solutions_close(x: np.ndarray, expected: np.ndarray, batch_ndim: int) -> None:
    """Each system's solution within SOLVE_RTOL of the reference, relative to its norm."""
    axes = tuple(range(batch_ndim, expected.ndim))
    error = np.sqrt(np.sum((x - expected) ** 2, axis=axes))
    assert np.all(error <= SOLVE_RTOL * np.sqrt(np.sum(expected**2, axis=axes)))


@pytest.mark.parametrize("shape", [(2000,), (4, 5)])
def test_solve3_batched_matches_lu_on_well_conditioned_batches(rng, shape):
    A = conditioned_matrices(rng, shape)
    b = rng.standard_normal((*shape, 3))
    x = kinematics.solve3_batched(A, b)
    assert x.shape == b.shape
    assert_solutions_close(x, np.linalg.solve(A, b[..., None])[..., 0], len(shape))
    B = rng.standard_normal((*shape, 3, 2))
    X = kinematics.solve3_batched(A, B)
    assert X.shape == B.shape
    assert_solutions_close(X, np.linalg.solve(A, B), len(shape))
    # one right-hand side (3,) shared by the whole batch
    b0 = b[(0,) * len(shape)]
    expected = np.linalg.solve(A, np.broadcast_to(b0, b.shape)[..., None])[..., 0]
    assert_solutions_close(kinematics.solve3_batched(A, b0), expected, len(shape))


def test_solve3_batched_on_one_system(rng):
    A = conditioned_matrices(rng, ())
    b, B = rng.standard_normal(3), rng.standard_normal((3, 3))
    x = kinematics.solve3_batched(A, b)
    assert x.shape == (3,)
    assert_solutions_close(x, np.linalg.solve(A, b), 0)
    X = kinematics.solve3_batched(A, B)
    assert X.shape == (3, 3)
    assert_solutions_close(X, np.linalg.solve(A, B), 0)
    np.testing.assert_allclose(A @ X, B, rtol=0.0, atol=1e-12 * np.abs(B).max())


def test_solve3_batched_matches_lu_on_the_delta(robot, other_robot, rng):
    # the forearm matrices S (rows s_i) and Jacobians of sampled states: cond < 5
    for r in (robot, other_robot):
        alpha, _ = sample_states(r, 500, seed=4)
        J = kinematics.jacobian(r.params, alpha)
        assert np.linalg.cond(J).max() < 10.0
        b = rng.standard_normal((len(alpha), 3))
        assert_solutions_close(kinematics.solve3_batched(J, b), np.linalg.solve(J, b[..., None])[..., 0], 1)


def test_solve3_batched_raises_like_lu_on_a_singular_system(rng):
    A = conditioned_matrices(rng, (5,))
    A[3] = [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.5, -1.0, 2.0]]  # rows 0 and 1 parallel: det = 0 exactly
    b = rng.standard_normal((5, 3))
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.solve(A, b[..., None])
    with pytest.raises(np.linalg.LinAlgError, match=r"batch index \(3,\)"):
        kinematics.solve3_batched(A, b)
    with pytest.raises(np.linalg.LinAlgError, match="Singular"):
        kinematics.solve3_batched(A[3], b[3])


@pytest.mark.parametrize(("A_shape", "b_shape"), [((3, 2), (3,)), ((4, 3, 3), (4, 2))])
def test_solve3_batched_refuses_bad_shapes(A_shape, b_shape):
    with pytest.raises(ValueError, match="must have shape"):
        kinematics.solve3_batched(np.ones(A_shape), np.ones(b_shape))


def test_given_jacobian_gives_the_same_derivatives(robot):
    alpha, alpha_dot = sample_states(robot, 50, seed=5)
    p = robot.params
    J = kinematics.jacobian(p, alpha)
    np.testing.assert_array_equal(
        kinematics.jacobian_derivative_times_velocity(p, alpha, alpha_dot, J=J),
        kinematics.jacobian_derivative_times_velocity(p, alpha, alpha_dot),
    )
    np.testing.assert_array_equal(
        kinematics.jacobian_derivative(p, alpha, alpha_dot, J=J),
        kinematics.jacobian_derivative(p, alpha, alpha_dot),
    )

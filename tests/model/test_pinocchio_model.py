"""The batched routines of ``DeltaPinocchioModel`` (used by ``validate``) against the readable
one-state methods they speed up: same configurations, closure gaps and projected dynamics."""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.model import kinematics
from delta_pin.model.validation import sample_states


@pytest.fixture(scope="module")
def rod_robot():
    """Uniform-rod forearms: Pinocchio's M and C a_dot differ from the paper's lumped model."""
    return dp.load_delta(forearm_inertia="rod")


def _states(robot, samples=25, seed=11):
    alpha, alpha_dot = sample_states(robot, samples, seed=seed)
    return alpha, 3.0 * alpha_dot


def test_analytic_configurations_equal_the_one_state_version(robot, other_robot):
    for r in (robot, other_robot):
        model = r.pinocchio
        alpha, _ = _states(r)
        xyz = kinematics.forward_kinematics(r.params, alpha)
        expected = np.array([model.analytic_configuration(a, x) for a, x in zip(alpha, xyz)])
        np.testing.assert_allclose(model.analytic_configurations(alpha, xyz), expected, rtol=0, atol=1e-14)
        np.testing.assert_allclose(model.analytic_configurations(alpha), expected, rtol=0, atol=1e-14)


def test_closure_residuals_equal_the_one_state_version(robot, rng):
    model = robot.pinocchio
    alpha, _ = _states(robot)
    closed = model.analytic_configurations(alpha)
    # configurations that do not close: the gaps are centimetres, read from Pinocchio either way
    perturbed = closed + rng.normal(scale=0.05, size=closed.shape)
    for q in (closed, perturbed):
        expected = np.array([model.closure_residual(q_k) for q_k in q])
        np.testing.assert_allclose(model.closure_residuals(q), expected, rtol=0, atol=1e-15)
    assert np.abs(model.closure_residuals(closed)).max() < 1e-13
    assert np.abs(model.closure_residuals(perturbed)).max() > 1e-3


def _assert_same_dynamics(batch, one_by_one):
    for name in ("M", "G", "coriolis"):
        computed = getattr(batch, name)
        expected = np.array([getattr(reduced, name) for reduced in one_by_one])
        assert computed.shape == expected.shape
        scale = np.abs(expected).max()
        np.testing.assert_allclose(computed, expected, rtol=0, atol=1e-12 * scale, err_msg=name)


def test_batched_projection_equals_the_readable_one(robot, other_robot, rod_robot):
    for r in (robot, other_robot, rod_robot):
        model = r.pinocchio
        alpha, alpha_dot = _states(r)
        q = np.array([model.configuration(a) for a in alpha])
        expected = [model.reduced_dynamics(a, d, q_k) for a, d, q_k in zip(alpha, alpha_dot, q)]
        _assert_same_dynamics(model.reduced_dynamics_batch(alpha, alpha_dot, q), expected)
        _assert_same_dynamics(model.reduced_dynamics_batch(alpha, alpha_dot), expected)


def test_batched_projection_is_pinocchio_not_the_analytic_model(rod_robot):
    """On the rod-forearm robot the batch reproduces Pinocchio's numbers, which differ from eqs. 7-9."""
    model = rod_robot.pinocchio
    alpha, alpha_dot = _states(rod_robot, samples=10)
    batch = model.reduced_dynamics_batch(alpha, alpha_dot)
    analytic = rod_robot.analytic_dynamics(alpha, alpha_dot)
    assert np.abs(batch.M - analytic.M).max() > 1e-3 * np.abs(analytic.M).max()
    np.testing.assert_allclose(batch.G, analytic.G, rtol=1e-10, atol=1e-14)  # same masses and centres


def test_batched_projection_closes_the_loops_by_newton_when_needed(robot, monkeypatch):
    """A start that does not close the loops goes through ``configuration``'s Newton iterations."""
    model = robot.pinocchio
    alpha, alpha_dot = _states(robot, samples=6)
    exact = model.analytic_configurations(alpha)
    start = exact.copy()
    start[::2, model.passive_indices] += 1e-3  # every other state starts off the closure
    monkeypatch.setattr(model, "analytic_configurations", lambda a, xyz=None: start.copy())
    assert np.abs(model.closure_residuals(start[::2])).min() > 1e-6
    batch = model.reduced_dynamics_batch(alpha, alpha_dot)
    expected = [model.reduced_dynamics(a, d, q_k) for a, d, q_k in zip(alpha, alpha_dot, exact)]
    _assert_same_dynamics(batch, expected)


def test_one_state_batch_has_a_leading_axis(robot):
    alpha, alpha_dot = np.array([0.3, 0.2, 0.4]), np.array([0.5, -0.2, 0.1])
    batch = robot.pinocchio.reduced_dynamics_batch(alpha, alpha_dot)
    assert batch.M.shape == (1, 3, 3) and batch.G.shape == (1, 3) and batch.coriolis.shape == (1, 3)
    _assert_same_dynamics(batch, [robot.pinocchio.reduced_dynamics(alpha, alpha_dot)])

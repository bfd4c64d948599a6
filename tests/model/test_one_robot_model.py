"""``dp.load_delta()`` is a ClosedChainRobot like every other robot, carrying the paper's analytic
model as ``robot.delta``: its generic projection equals eqs. 7-9, its runs are the analytic
Delta's own, and a closure-plant run of the same robot agrees with them."""

from __future__ import annotations

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.model.delta_robot import analytic_delta, carries_own_delta
from delta_pin.model.robot import Delta
from tests.reference.python_loop import simulate_reference


@pytest.fixture(scope="module")
def robot() -> dp.ClosedChainRobot:
    return dp.load_delta()


def test_load_delta_is_a_closed_chain_robot_carrying_the_analytic_model(robot):
    assert isinstance(robot, dp.ClosedChainRobot) and isinstance(robot.delta, Delta)
    assert carries_own_delta(robot) and analytic_delta(robot) is robot.delta
    assert robot.actuated_joints == ("active_1", "active_2", "active_3") and robot.idle_dof == 0
    assert robot.classification()["mobility"] == 3
    assert robot.closure_gap(robot.reference_configuration) < 1e-12
    # the Delta-only API reaches robot.delta
    assert robot.params is robot.delta.params and robot.pinocchio is robot.delta.pinocchio
    alpha = np.array([0.1, -0.2, 0.3])
    np.testing.assert_array_equal(robot.jacobian(alpha), robot.delta.jacobian(alpha))
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = robot.nope


def test_generic_projection_equals_the_papers_model(robot):
    """The tree's dynamics projected through the closures (no Delta knowledge) against eqs. 7-9:
    1e-12 relative (measured ~1e-16 on the xacro Delta, docs/architecture.md section 10)."""
    rng = np.random.default_rng(2)
    for _ in range(3):
        alpha, alpha_dot = rng.uniform(-0.3, 0.6, 3), rng.normal(size=3)
        M, _, G, coriolis = robot.reduced_terms(alpha, alpha_dot)
        paper = robot.analytic_dynamics(alpha, alpha_dot)
        np.testing.assert_allclose(M, paper.M, rtol=0, atol=1e-12 * np.abs(paper.M).max())
        np.testing.assert_allclose(G, paper.G, rtol=0, atol=1e-12 * np.abs(paper.G).max())
        np.testing.assert_allclose(coriolis, paper.coriolis, rtol=0, atol=1e-12 * np.abs(paper.M).max())
        # frame kinematics of the platform: the generic assembly equals the closed form (1e-12 m)
        q = robot.configuration(alpha)
        np.testing.assert_allclose(
            robot.frame_placement(q).translation, robot.forward_kinematics(alpha), atol=1e-12, rtol=0
        )


def test_its_runs_are_the_analytic_deltas_and_the_closure_plant_agrees(robot):
    """simulate(load_delta()) runs the analytic Delta's own path (the same arithmetic: equal to
    the last bit); the same robot on the generic closed-chain plant, given explicitly and run in
    the Python reference loop (its Python ``derivative``), follows the same motion: measured
    6e-16 rad over 0.3 s; bound 1e-12 (two implementations of the same constrained dynamics, RK4
    at 1 ms, projections at different moments)."""
    path = dp.PathI()
    nominal = dp.DeltaNominalModel(robot)
    assert nominal.robot is robot.delta
    run = dp.simulate(robot, dp.design1(nominal), path, t_end=0.3)
    direct = dp.simulate(robot.delta, dp.design1(dp.DeltaNominalModel(robot.delta)), path, t_end=0.3)
    np.testing.assert_array_equal(run.alpha, direct.alpha)
    assert run.metadata["robot"] == direct.metadata["robot"]
    plant = dp.ClosedChainPlant(robot)
    generic = simulate_reference(robot, dp.design1(nominal), path, t_end=0.3, plant=plant)
    assert generic.metadata["plant"] == "pinocchio" and not generic.metadata.get("core_plant")
    np.testing.assert_allclose(generic.alpha, run.alpha, atol=1e-12, rtol=0)

"""MuJoCo as a second plant (delta_pin.model.mjcf, delta_pin.sim.mujoco_delta) against Pinocchio.

References: Table 1's masses (the MJCF's total, exactly), Pinocchio's assembled start pose (the
MJCF's closure sites must coincide on it, to rounding), and Pinocchio's constrained dynamics over
1 s of the same PD law under RK4 at 1 ms: the benchmark measures 2.7e-8 rad after 2 s with the
stiff connects; 1e-6 rad leaves room for the connects' compliance on other machines while still
catching any wrong axis, placement or inertia (those give 1e-3 rad and more within 0.1 s).
"""

import numpy as np
import pytest

from delta_pin.sim.integrators import rk4_step

mujoco = pytest.importorskip("mujoco")
from delta_pin.sim.mujoco_delta import MujocoDelta  # noqa: E402
from tests.reference.plants import ReadableClosedChainPlant  # noqa: E402

ALPHA0 = np.full(3, 0.3322)


@pytest.fixture(scope="module")
def assembled(robot):
    plant = ReadableClosedChainPlant(robot)
    x0 = plant.initial_state(ALPHA0, np.zeros(3))
    sim = MujocoDelta(robot)
    sim.set_state(x0[: plant.nq], x0[plant.nq :])
    return plant, x0, sim


def test_the_mjcf_has_table_1_masses_and_closes_its_loops(robot, assembled):
    _, _, sim = assembled
    p = robot.params
    assert float(sim.model.body_subtreemass[0]) == pytest.approx(3 * p.m_a + 3 * p.m_b + p.m_o, rel=1e-12)
    assert sim.closure_gap() < 1e-12  # [m] on Pinocchio's assembled pose
    alpha, alpha_dot = sim.joint_state()
    np.testing.assert_allclose(alpha, ALPHA0, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(alpha_dot, np.zeros(3))


def test_mujoco_and_pinocchio_agree_over_a_second_of_pd(robot, assembled):
    plant, x0, _ = assembled
    sim = MujocoDelta(robot)  # a fresh one: the fixture's is shared
    sim.set_state(x0[: plant.nq], x0[plant.nq :])
    gravity = robot.analytic_dynamics(ALPHA0, np.zeros(3)).G
    x = x0.copy()
    for k in range(1000):
        target = ALPHA0 + 0.1 * np.sin(2 * np.pi * 0.5 * k * 1e-3 + np.array([0.0, 2.0, 4.0]))
        alpha, alpha_dot = sim.joint_state()
        sim.step(gravity + 40.0 * (target - alpha) - 2.0 * alpha_dot)
        pin_alpha, pin_rate = x[plant.active], x[plant.nq + plant.active]
        tau = gravity + 40.0 * (target - pin_alpha) - 2.0 * pin_rate
        x = rk4_step(lambda t, s: plant.derivative(t, s, tau), k * 1e-3, x, 1e-3)  # noqa: B023
    moved = np.abs(x[plant.active] - ALPHA0).max()
    assert moved > 0.05  # it really moved
    np.testing.assert_allclose(sim.joint_state()[0], x[plant.active], rtol=0, atol=1e-6)

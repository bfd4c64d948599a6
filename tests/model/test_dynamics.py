"""The paper's reduced model (eqs. 7-9, corrected G) against the constrained Pinocchio model,
finite differences of Pinocchio's potential energy, and Pinocchio's constrained forward dynamics."""

import numpy as np
import pinocchio as pin
import pytest

import delta_pin as dp
from delta_pin.model.validation import sample_states

H = 1e-6  # [rad] central differences: rtol 1e-6


def test_analytic_equals_pinocchio_projection(robot, other_robot):
    for r in (robot, other_robot):
        for alpha, alpha_dot in zip(*sample_states(r, 10, seed=4)):
            a = r.analytic_dynamics(alpha, alpha_dot)
            b = r.pinocchio_dynamics(alpha, alpha_dot)
            np.testing.assert_allclose(a.M, b.M, rtol=1e-10, atol=1e-14)
            np.testing.assert_allclose(a.G, b.G, rtol=1e-10, atol=1e-14)
            np.testing.assert_allclose(a.coriolis, b.coriolis, rtol=1e-10, atol=1e-14)
            np.testing.assert_allclose(a.coriolis, a.C @ alpha_dot, rtol=1e-13, atol=1e-16)


def test_mass_matrix_is_symmetric_positive_definite(robot, other_robot):
    for r in (robot, other_robot):
        for alpha, alpha_dot in zip(*sample_states(r, 20, seed=5)):
            M = r.pinocchio_dynamics(alpha, alpha_dot).M
            np.testing.assert_allclose(M, M.T, atol=1e-15)
            # eq. 7: M >= (m_a/3 + m_b/2) l_a^2 I, a bound of Assumption 1
            assert np.linalg.eigvalsh(M).min() >= r.params.arm_equivalent_inertia * (1 - 1e-12)


def test_mdot_minus_2c_is_skew(robot):
    for alpha, alpha_dot in zip(*sample_states(robot, 20, seed=6)):
        M_dot = (
            robot.analytic_dynamics(alpha + H * alpha_dot, alpha_dot).M
            - robot.analytic_dynamics(alpha - H * alpha_dot, alpha_dot).M
        ) / (2 * H)
        N = M_dot - 2 * robot.analytic_dynamics(alpha, alpha_dot).C
        assert np.linalg.norm(N + N.T) <= 1e-6 * np.linalg.norm(M_dot)


def _potential_energy(robot, alpha):
    """Sum of m_k g z_k over the links, from Pinocchio's link placements at q(alpha) (assembled
    to 1e-15 m: the central difference at H divides its rounding by H)."""
    model = robot.pinocchio.model
    data = model.createData()
    pin.forwardKinematics(model, data, robot.pinocchio.configuration(alpha, tol=1e-15))
    return sum(
        inertia.mass * robot.params.g * (placement.act(inertia.lever))[2]
        for placement, inertia in zip(data.oMi, model.inertias)
    )


def test_gravity_is_the_gradient_of_pinocchio_potential_energy(robot, other_robot):
    for r in (robot, other_robot):
        for alpha in sample_states(r, 5, seed=7)[0]:
            grad = [
                (_potential_energy(r, alpha + H * e) - _potential_energy(r, alpha - H * e)) / (2 * H)
                for e in np.eye(3)
            ]
            np.testing.assert_allclose(r.analytic_dynamics(alpha, np.zeros(3)).G, grad, rtol=1e-6, atol=1e-8)


def test_paper_printed_gravity_sign_is_wrong(robot):
    # Erratum 1: with the printed "+" the arm term is off by (m_a + m_b) g l_a cos(alpha).
    p = robot.params
    alpha = np.zeros(3)
    xyz = robot.forward_kinematics(alpha)
    J = robot.jacobian(alpha)
    printed = 0.5 * (p.m_a + p.m_b) * p.g * p.l_a * np.cos(alpha) + p.platform_equivalent_mass * p.g * J[2]
    truth = robot.pinocchio_dynamics(alpha, np.zeros(3)).G
    assert xyz[2] < 0
    np.testing.assert_allclose(printed - truth, (p.m_a + p.m_b) * p.g * p.l_a, rtol=1e-12)
    assert (p.m_a + p.m_b) * p.g * p.l_a == pytest.approx(0.784)


def test_holding_torque_gives_zero_constrained_acceleration(robot):
    """tau = G on the active joints holds the robot still in Pinocchio's constraintDynamics."""
    model, pm = robot.pinocchio.model, robot.pinocchio
    data = model.createData()
    pin.initConstraintDynamics(model, data, pm.constraint_models, pm.constraint_datas)
    settings = pin.ProximalSettings(1e-12, 0.0, 1)  # mu = 0: the exact KKT solve
    for alpha in sample_states(robot, 5, seed=8)[0]:
        q = pm.configuration(alpha)
        tau = np.zeros(model.nv)
        tau[pm.actuated_indices] = robot.analytic_dynamics(alpha, np.zeros(3)).G
        ddq = pin.constraintDynamics(
            model, data, q, np.zeros(model.nv), tau, pm.constraint_models, pm.constraint_datas, settings
        )
        assert np.abs(ddq).max() < 1e-9
        # and without the holding torque it falls
        ddq_free = pin.constraintDynamics(
            model,
            data,
            q,
            np.zeros(model.nv),
            np.zeros(model.nv),
            pm.constraint_models,
            pm.constraint_datas,
            settings,
        )
        assert np.abs(ddq_free[pm.actuated_indices]).max() > 1.0


def test_rod_forearm_differs_from_the_lumped_model():
    robot = dp.load_delta(forearm_inertia="rod")
    alpha, alpha_dot = np.full(3, 0.4), np.array([1.0, -0.5, 0.3])
    a = robot.analytic_dynamics(alpha, alpha_dot)
    b = robot.pinocchio_dynamics(alpha, alpha_dot)
    assert np.abs(a.M - b.M).max() > 1e-3  # kg m^2: the paper's model ignores the rod's own inertia
    np.testing.assert_allclose(a.G, b.G, rtol=1e-10)  # same masses and centres: same gravity


def test_friction_torque_eq12(robot):
    f = robot.params.friction
    F_n = 15.0
    # at alpha_dot = 1 rad/s: sliding speed 0.04 m/s, (0.04/0.1)^2 = 0.16
    expected = (0.1 * F_n + (0.2 - 0.1) * F_n * np.exp(-0.16)) * 0.04 + 2.0 * 1.0 * 0.04
    assert robot.friction_torque(np.array([1.0, -1.0, 0.0]), F_n) == pytest.approx(
        [expected, -expected, 0.0], rel=1e-14
    )
    assert f.mu_s * F_n * f.r_a == pytest.approx(0.12)  # stiction torque limit [N m]
    smooth = robot.friction_torque(np.array([1.0]), F_n, sign_velocity_scale=0.01)
    assert smooth == pytest.approx(expected, rel=1e-12)

"""The closed-chain regressor against independent references: the robot's projected inverse
dynamics, Pinocchio's constrained forward dynamics (the plant), the Delta's eqs. 7-9, and the
plant's eq. 12 friction; the base parameters against the definition W theta = W_b beta and the
paper's lumped terms."""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.errors import InvalidParameterError
from delta_pin.identification.base import base_parameters, generic_states
from delta_pin.identification.regressor import ClosedChainRegressor, JointColumns
from delta_pin.identification.workflow import delta_lumped_map, friction_truth
from delta_pin.model.friction import stribeck_torque
from tests.reference.plants import ReadableClosedChainPlant

SHIPPED = ("five_bar.urdf", "stewart.urdf")


@pytest.fixture(scope="module")
def delta():
    return dp.load_delta()


@pytest.fixture(scope="module", params=SHIPPED)
def shipped(request):
    return dp.load_robot(f"delta_pin/robots/{request.param}")


def _states(robot, count, seed):
    return zip(*generic_states(robot, count, seed), strict=True)


def test_regressor_equals_projected_inverse_dynamics_delta(delta):
    """Y theta = M alpha_ddot + C alpha_dot + G of the robot's projection (reduced_terms), the
    same S and drift read two ways; measured agreement ~1e-16 relative, asked 1e-12."""
    regressor = ClosedChainRegressor(delta, JointColumns(rotor_inertia=False, viscous=False, coulomb=False,
                                                         offset=False))  # fmt: skip
    theta = regressor.parameters()
    for alpha, alpha_dot, alpha_ddot in _states(delta, 20, 3):
        q = delta.configuration(alpha)
        M, _, G, coriolis = delta.reduced_terms(alpha, alpha_dot, q)
        reference = M @ alpha_ddot + coriolis + G
        tau = regressor.rows(alpha, alpha_dot, alpha_ddot, q) @ theta
        np.testing.assert_allclose(tau, reference, rtol=0, atol=1e-12 * np.abs(reference).max())


def test_regressor_equals_the_papers_equations_7_to_9(delta):
    """On the xacro Delta (lumped forearms) the tree's regressor reproduces the analytic model
    M alpha_ddot + C alpha_dot + G of eqs. 7-9 (G with erratum 1's sign): a route sharing nothing
    with the projection; measured ~1e-15 relative, asked 1e-10 (the identity tier)."""
    regressor = ClosedChainRegressor(delta, JointColumns(rotor_inertia=False, viscous=False, coulomb=False,
                                                         offset=False))  # fmt: skip
    theta = regressor.parameters()
    for alpha, alpha_dot, alpha_ddot in _states(delta, 20, 4):
        d = delta.delta.analytic_dynamics(alpha, alpha_dot)
        reference = d.M @ alpha_ddot + d.coriolis + d.G
        tau = regressor.rows(alpha, alpha_dot, alpha_ddot) @ theta
        np.testing.assert_allclose(tau, reference, rtol=0, atol=1e-10 * np.abs(reference).max())


def test_regressor_inverts_constrained_forward_dynamics(delta, shipped):
    """tau = Y theta (with eq. 12's friction on the Delta) fed to the plant's constrained forward
    dynamics (pin.constraintDynamics, the KKT route) gives alpha_ddot back. Measured 1e-13 (Delta,
    five-bar) to 1e-11 rad/s^2 (Stewart: the KKT solve of 21 joints and 30 closure rows at
    cond ~1e3), asked 1e-9 relative to |alpha_ddot| + 1."""
    for robot in (delta, shipped):
        friction = dp.Friction() if robot is delta else None
        regressor = ClosedChainRegressor(robot)
        theta = regressor.parameters(joint_values=friction_truth(robot, friction))
        plant = ReadableClosedChainPlant(robot, friction=friction, coordinates="full")
        for alpha, alpha_dot, alpha_ddot in _states(robot, 5, 5):
            q, v = robot.state(alpha, alpha_dot)
            tau = regressor.rows(alpha, alpha_dot, alpha_ddot) @ theta
            ddq = plant.accelerations(0.0, q, v, tau)
            np.testing.assert_allclose(ddq[robot.actuated_indices], alpha_ddot, rtol=0,
                                       atol=1e-9 * (np.abs(alpha_ddot).max() + 1.0))  # fmt: skip


def test_regressor_equals_projected_inverse_dynamics_shipped(shipped):
    """The five-bar and the Stewart platform: Y theta against reduced_terms at the same assembled
    q, asked 1e-12 relative (measured ~1e-15; with two separate Newton solves to 1e-12 m the
    Stewart's differ by 5e-12, the assembly's tolerance times cond J_p)."""
    regressor = ClosedChainRegressor(shipped)
    theta = regressor.parameters()
    for alpha, alpha_dot, alpha_ddot in _states(shipped, 5, 6):
        q = shipped.configuration(alpha)
        M, _, G, coriolis = shipped.reduced_terms(alpha, alpha_dot, q)
        reference = M @ alpha_ddot + coriolis + G
        tau = regressor.rows(alpha, alpha_dot, alpha_ddot, q) @ theta
        np.testing.assert_allclose(tau, reference, rtol=0, atol=1e-12 * np.abs(reference).max())


def test_friction_columns_are_eq_12(delta, rng):
    """fv alpha_dot + fc tanh + fs exp(-(alpha_dot r_a / v_s)^2) tanh with the plant's values
    equals stribeck_torque (eq. 12, the plant's smooth sign) to rounding (1e-15 N m)."""
    friction = dp.Friction()
    regressor = ClosedChainRegressor(delta)
    block = regressor.columns.block(rng.normal(0.0, 3.0, (50, 3)), np.zeros((50, 3)))
    values = regressor.parameters(joint_values=friction_truth(delta, friction))[regressor.inertial_count :]
    alpha_dot = np.diagonal(block[:, :, 3:6], axis1=1, axis2=2)  # the fv columns are alpha_dot
    reference = stribeck_torque(delta.delta.params.friction, alpha_dot, 15.0, friction.sign_velocity_scale)
    np.testing.assert_allclose(block @ values, reference, rtol=0, atol=1e-15)


def test_base_parameters_reproduce_the_regressor(delta, shipped):
    """W theta = W_b beta at states the QR never saw (1e-12 relative: K = R11^-1 R12 is exact up to
    cond(R11) eps), W_b has full column rank there, and the rank decision has a wide gap (kept
    >= 1e-6, dropped <= 1e-12 of |R_11|, against the tolerance 1e-8)."""
    for robot in (delta, shipped):
        regressor = ClosedChainRegressor(robot)
        base = base_parameters(regressor, count=60)
        kept, dropped = base.gap
        assert kept > 1e-6 and dropped < 1e-12
        theta = np.random.default_rng(7).normal(size=regressor.size)
        alpha, alpha_dot, alpha_ddot = generic_states(robot, 30, 99)
        W = regressor.stack(alpha, alpha_dot, alpha_ddot).reshape(-1, regressor.size)
        W_b = base.reduce(W)
        np.testing.assert_allclose(
            W_b @ base.values(theta), W @ theta, rtol=0, atol=1e-12 * np.abs(W @ theta).max()
        )
        singular = np.linalg.svd(W_b / np.linalg.norm(W_b, axis=0), compute_uv=False)
        assert singular[-1] / singular[0] > 1e-8


@pytest.mark.parametrize("masses", [{}, {"m_a": 0.26, "m_b": 0.14, "m_o": 0.39}])
def test_delta_base_parameters_hold_the_papers_lumped_terms(masses):
    """The paper's regressor (per arm I_i = (m_a/3 + m_b/2) l_a^2 and k_i = (m_a + m_b) l_a / 2, and
    m_eq = m_o + 3/2 m_b) lies in the span of the base regressor (residual ~1e-13, asked 1e-10),
    and at a lumped-forearm URDF beta = A theta_paper (asked 1e-10 relative): the base parameters
    contain eqs. 7-9's m_eq terms exactly."""
    robot = dp.load_delta(**masses)
    p = robot.delta.params
    regressor = ClosedChainRegressor(robot)
    base = base_parameters(regressor, count=60)
    names, A, residual = delta_lumped_map(regressor, base)
    assert residual < 1e-10
    paper = np.array([(p.m_a / 3 + p.m_b / 2) * p.l_a**2] * 3 + [(p.m_a + p.m_b) * p.l_a / 2] * 3
                     + [p.m_o + 1.5 * p.m_b])  # fmt: skip
    inertial = np.zeros(regressor.size)
    inertial[: regressor.inertial_count] = regressor.parameters()[: regressor.inertial_count]
    beta = base.values(inertial)
    np.testing.assert_allclose(A @ paper, beta, rtol=0, atol=1e-10 * np.abs(beta).max())
    np.testing.assert_allclose(np.linalg.lstsq(A, beta, rcond=None)[0], paper, rtol=1e-10)
    assert names[-1] == "m_eq"


def test_a_robot_with_idle_motions_is_refused_in_one_line():
    """S of least kinetic energy depends on the inertias: no linear regressor; the error says why."""
    robot = dp.load_robot("delta_pin/robots/delta_ballrods.xml")
    if not robot.idle_dof:
        pytest.skip("this file has no idle motion here")
    with pytest.raises(InvalidParameterError, match="idle motion"):
        ClosedChainRegressor(robot)

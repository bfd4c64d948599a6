"""ClosedChainRobot: assembly, closure Jacobians, frame kinematics and the projected dynamics,
against independent references (the Delta's analytic model, closed forms, finite differences)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import delta_pin as dp
from delta_pin.errors import AssemblyError, InvalidParameterError, UnreachablePoseError, URDFConventionError
from delta_pin.model.closed_chain import closure_rank
from tests.model.closed_chain_fixtures import BASE, DISTAL, PROXIMAL, five_bar_urdf

STATES = [
    (np.array([0.3, 0.45, 0.6]), np.array([0.7, -1.1, 0.4])),
    (np.array([-0.1, 0.2, 0.05]), np.array([-0.5, 0.9, 1.3])),
]


@pytest.fixture(scope="module")
def delta_file():
    """The xacro Delta loaded as a closed-chain robot from its URDF (gravity 9.8 as the paper's)."""
    return dp.load_robot(dp.model.description.default_xacro_path().parent / "delta.urdf", g=9.8)


@pytest.fixture(scope="module")
def five_bar(tmp_path_factory):
    path = tmp_path_factory.mktemp("five_bar") / "five_bar.urdf"
    path.write_text(five_bar_urdf())
    return dp.load_robot(path, end_effector="tip")


def test_the_delta_urdf_loads_as_a_recognised_closed_chain_robot(delta_file):
    assert delta_file.dof == 3 and len(delta_file.closures) == 3
    assert delta_file.delta is not None
    assert delta_file.end_effector_name == "platform_z"  # the paper's xyz: the platform's slides
    assert delta_file.delta.params == dp.load_delta().params


@pytest.mark.parametrize("alpha, alpha_dot", STATES)
def test_projected_dynamics_equal_the_papers_analytic_model(delta_file, alpha, alpha_dot):
    """M, C alpha_dot, G by projection of the 12-joint tree equal eqs. 7-9 (corrected G): both are
    exact for the lumped forearm, so they agree to rounding (1e-12 relative)."""
    reference = dp.load_delta().analytic_dynamics(alpha, alpha_dot)
    M, C, G, coriolis = delta_file.reduced_terms(alpha, alpha_dot)
    np.testing.assert_allclose(M, reference.M, rtol=0, atol=1e-12 * np.abs(reference.M).max())
    np.testing.assert_allclose(G, reference.G, rtol=0, atol=1e-12 * np.abs(reference.G).max())
    np.testing.assert_allclose(
        coriolis, reference.coriolis, rtol=0, atol=1e-12 * np.abs(reference.coriolis).max()
    )
    np.testing.assert_allclose(C @ alpha_dot, coriolis, rtol=0, atol=1e-12)  # the matrix and the vector agree


def test_coriolis_matrix_keeps_m_dot_minus_2c_skew_symmetric(delta_file):
    """M_dot = C + C^T (central differences along alpha_dot, step 1e-4: truncation ~1e-8 and the
    assemblies' 1e-12 m residual / 1e-4 ~1e-8, so 1e-6 relative)."""
    alpha, alpha_dot = STATES[0]
    h = 1e-4
    M_dot = (
        delta_file.reduced_terms(alpha + h * alpha_dot, alpha_dot)[0]
        - delta_file.reduced_terms(alpha - h * alpha_dot, alpha_dot)[0]
    ) / (2 * h)
    _, C, _, _ = delta_file.reduced_terms(alpha, alpha_dot)
    np.testing.assert_allclose(C + C.T, M_dot, rtol=0, atol=1e-6 * np.abs(M_dot).max())


def test_closure_jacobian_derivative_is_the_time_derivative_of_the_jacobian(five_bar):
    """J_c_dot against central differences of J_c along v (step 1e-6), and J_c_dot v against the
    classical-acceleration drift."""
    robot = five_bar
    q, v = robot.state(robot.home + 0.1, np.array([0.8, -0.5]))
    h = 1e-6
    J = lambda q: robot.closure_jacobian(q)  # noqa: E731
    numeric = (J(pin.integrate(robot.model, q, h * v)) - J(pin.integrate(robot.model, q, -h * v))) / (2 * h)
    analytic = robot.closure_jacobian_derivative(q, v)
    np.testing.assert_allclose(analytic, numeric, rtol=0, atol=1e-8)
    np.testing.assert_allclose(analytic @ v, robot.closure_drift(q, v), rtol=0, atol=1e-12)


def test_five_bar_assembles_and_its_tip_follows_the_closed_form(five_bar):
    """Planar five-bar: the tip at zero is (0, 0, -0.4) by construction; after moving the motors,
    the tip is the intersection of two circles of radius DISTAL around the elbows (closed form)."""
    np.testing.assert_allclose(five_bar.forward_kinematics(five_bar.home), [0.0, 0.0, -0.4], atol=1e-12)
    alpha = np.array([0.15, -0.1])
    q = five_bar.configuration(alpha)
    assert five_bar.closure_gap(q) < 1e-12
    data = five_bar.model.createData()
    pin.framesForwardKinematics(five_bar.model, data, q)
    elbows = [data.oMi[five_bar.model.getJointId(f"elbow_{i}")].translation for i in (1, 2)]
    tip = five_bar.frame_placement(q, "tip").translation
    for elbow in elbows:
        assert abs(np.linalg.norm(tip - elbow) - DISTAL) < 1e-12
    motors = [data.oMi[five_bar.model.getJointId(f"motor_{i}")].translation for i in (1, 2)]
    for motor, elbow in zip(motors, elbows):
        assert abs(np.linalg.norm(elbow - motor) - PROXIMAL) < 1e-12
    assert abs(motors[1][0] - motors[0][0] - BASE) < 1e-15


def test_planar_point_closure_is_redundant_and_handled(five_bar):
    """A point closure in a plane has 3 equations of which 2 are independent."""
    assert five_bar.closure_size == 3
    assert closure_rank(five_bar, five_bar.reference_configuration) == 2


def test_frame_jacobian_matches_finite_differences_of_frame_positions(five_bar):
    alpha = five_bar.home + np.array([0.05, -0.03])
    J = five_bar.frame_jacobian(five_bar.configuration(alpha))[:3]
    h = 1e-4  # truncation ~1e-9 m/rad; assembly residual 1e-12 m / h ~1e-8
    numeric = np.column_stack(
        [
            (five_bar.forward_kinematics(alpha + h * e) - five_bar.forward_kinematics(alpha - h * e))
            / (2 * h)
            for e in np.eye(2)
        ]
    )
    np.testing.assert_allclose(J, numeric, rtol=0, atol=1e-7)


def test_inverse_kinematics_returns_to_the_actuated_coordinates(five_bar):
    alpha = np.array([0.12, -0.07])
    target = five_bar.forward_kinematics(alpha)
    found = five_bar.inverse_kinematics(target, axes="xz", initial_guess=alpha + 0.05)
    np.testing.assert_allclose(found, alpha, atol=1e-10)
    before = five_bar.configuration(alpha)
    with pytest.raises(UnreachablePoseError, match="cannot reach"):
        five_bar.inverse_kinematics([0.0, 0.0, -2.0], axes="xz")
    np.testing.assert_array_equal(five_bar.configuration(alpha), before)  # the same assembly mode


def test_frame_acceleration_drift_matches_the_second_derivative_along_a_path(five_bar):
    """x_ddot = J alpha_ddot + drift: check it along alpha(t) = a0 + b t + c t^2 / 2 by central
    differences of the frame position (step 1e-4 s: error ~1e-7 m/s^2)."""
    a0, b, c = five_bar.home + 0.05, np.array([0.4, -0.3]), np.array([1.0, 0.5])
    h = 1e-4
    x = [five_bar.forward_kinematics(a0 + b * t + c * t * t / 2) for t in (-h, 0.0, h)]
    numeric = (x[0] - 2 * x[1] + x[2]) / h**2
    q = five_bar.configuration(a0)
    analytic = five_bar.frame_jacobian(q)[:3] @ c + five_bar.frame_acceleration_drift(q, b)
    np.testing.assert_allclose(analytic, numeric, rtol=0, atol=1e-5)


def test_a_loop_that_cannot_close_names_the_closure(five_bar):
    with pytest.raises(AssemblyError, match=r"closure 'loop' \(five_bar.urdf line \d+\)"):
        five_bar.configuration(np.array([1.5, -1.5]))


def test_bad_inputs_are_one_line_errors(tmp_path, five_bar):
    path = tmp_path / "robot.urdf"
    path.write_text(five_bar_urdf(closure_type="hinge"))
    with pytest.raises(
        URDFConventionError, match=r"constraint 'loop' \(robot.urdf line \d+\) has type 'hinge'"
    ):
        dp.load_robot(path)
    path.write_text(
        five_bar_urdf().replace(
            '<child link="distal_2"/><child_origin', '<child link="nowhere"/><child_origin'
        )
    )
    with pytest.raises(URDFConventionError, match="names link 'nowhere'"):
        dp.load_robot(path)
    path.write_text(five_bar_urdf())
    with pytest.raises(InvalidParameterError, match="actuated joint 'motor_9' is not in the model"):
        dp.load_robot(path, actuated=["motor_1", "motor_9"])
    with pytest.raises(AssemblyError, match=r"2 degree\(s\) of freedom .* but 1 actuator"):
        dp.load_robot(path, actuated=["motor_1"])
    path.write_text(five_bar_urdf(transmissions=False))
    with pytest.raises(URDFConventionError, match="names no actuated joint"):
        dp.load_robot(path)
    with pytest.raises(InvalidParameterError, match="has no frame 'hand'"):
        five_bar.set_end_effector("hand")
    with pytest.raises(URDFConventionError, match="does not exist"):
        dp.load_robot(tmp_path / "missing.urdf")
    (tmp_path / "robot.sdf").write_text("<sdf/>")
    with pytest.raises(URDFConventionError, match="unknown robot file type"):
        dp.load_robot(tmp_path / "robot.sdf")


def test_with_payload_adds_the_mass_at_the_frame(five_bar):
    """A 0.5 kg point mass at the tip adds m g to the tip's vertical force: G changes by
    J_z^T m g (J_z the tip's vertical closed-loop Jacobian row)."""
    heavier = five_bar.with_payload(0.5, "tip")
    alpha = five_bar.home + 0.02
    q = five_bar.configuration(alpha, initial_guess=five_bar.reference_configuration)
    G0 = five_bar.reduced_terms(alpha, np.zeros(2), q)[2]
    G1 = heavier.reduced_terms(alpha, np.zeros(2), q)[2]
    J_z = five_bar.frame_jacobian(q, "tip")[2]
    g = -five_bar.model.gravity.linear[2]
    np.testing.assert_allclose(G1 - G0, J_z * 0.5 * g, rtol=0, atol=1e-12)


def test_shipped_robot_names_are_one_list():
    from delta_pin.choices import SHIPPED_ROBOT_NAMES
    from delta_pin.model.loaders import SHIPPED_ROBOTS

    assert tuple(SHIPPED_ROBOTS) == SHIPPED_ROBOT_NAMES

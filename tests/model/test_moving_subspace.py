"""A closed chain with a universal joint, whose motion subspace turns with q (its bias c_J = S_dot v
is not zero): the reduced model's C alpha_dot must include it. Pinocchio 4.1's
``computeCoriolisMatrix`` misses it for universal, ZYX-spherical and composite joints
(C(q, v) v differs from RNEA's nle - g by 0.8-26 N m at random states), so the core takes nle from
the RNEA for such a model (closed_chain_model.cpp).

The mechanism: a motor turning a 0.6 m crank about the x axis at (1, 0, 0); a universal joint at
the origin (z, then y) carrying a slider along its x axis; the crank's tip and the slider's origin
held together (a point closure). One degree of freedom; as the crank turns, both angles of the
universal joint move. References: Pinocchio's ``constraintDynamics`` (the actuated part of the
constrained accelerations equals M^-1 (tau - C alpha_dot - G) of the reduced model, 1e-9
relative: the proximal solve converges to 1e-14) and the readable twin (tests/reference)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import delta_pin as dp
from delta_pin.model.closures import Closure
from tests.model.closed_chain_fixtures import pinocchio_accelerations
from tests.reference import projection as readable

CRANK = 0.6  # [m]


@pytest.fixture(scope="module")
def universal() -> dp.ClosedChainRobot:
    model = pin.Model()
    motor = model.addJoint(0, pin.JointModelRX(), pin.SE3(np.eye(3), np.array([1.0, 0.0, 0.0])), "motor")
    model.appendBodyToJoint(
        motor,
        pin.Inertia(0.5, np.array([0.0, CRANK / 2, 0.0]), np.diag([0.02, 1e-3, 0.02])),
        pin.SE3.Identity(),
    )
    axes = pin.JointModelUniversal(np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0]))
    cross = model.addJoint(0, axes, pin.SE3.Identity(), "universal")
    model.appendBodyToJoint(
        cross, pin.Inertia(0.4, np.array([0.2, 0.0, 0.05]), np.diag([3e-3, 4e-3, 5e-3])), pin.SE3.Identity()
    )
    slider = model.addJoint(cross, pin.JointModelPX(), pin.SE3.Identity(), "slider")
    model.appendBodyToJoint(
        slider, pin.Inertia(0.3, np.array([0.05, 0.0, 0.0]), np.diag([1e-3, 2e-3, 2e-3])), pin.SE3.Identity()
    )
    closure = Closure(
        "tip", "3d", motor, pin.SE3(np.eye(3), np.array([0.0, CRANK, 0.0])), slider, pin.SE3.Identity()
    )
    q0 = np.array([0.0, np.arctan2(CRANK, 1.0), 0.0, np.hypot(1.0, CRANK)])  # closed at alpha = 0
    return dp.ClosedChainRobot(model, [closure], ["motor"], reference_configuration=q0)


def test_pinocchio_41_coriolis_matrix_misses_the_universal_joints_bias(universal):
    """Why the core takes nle from the RNEA here (if this starts to fail, Pinocchio fixed it)."""
    robot = universal
    q = robot.configuration(np.array([0.4]))
    v = robot.velocity_map(q) @ np.array([2.0])
    data = robot.model.createData()
    C = pin.computeCoriolisMatrix(robot.model, data, q, v)
    bias = pin.nonLinearEffects(robot.model, data, q, v) - pin.computeGeneralizedGravity(robot.model, data, q)
    assert np.abs(C @ v - bias).max() > 1e-3


def test_the_reduced_model_of_a_universal_joint_equals_constraint_dynamics(universal):
    robot = universal
    assert robot.dof == 1 and robot.idle_dof == 0
    accelerations = pinocchio_accelerations(robot)
    rng = np.random.default_rng(5)
    for _ in range(4):
        alpha, alpha_dot = rng.uniform(0.2, 0.7, 1), rng.uniform(1.0, 3.0, 1)
        q = robot.configuration(alpha)
        v = robot.velocity_map(q) @ alpha_dot
        M, C, G, coriolis = robot.reduced_terms(alpha, alpha_dot, q)
        for got, expected in zip(
            (M, C, G, coriolis), readable.reduced_terms(robot, q, alpha_dot), strict=True
        ):
            np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-12)
        tau = rng.normal(0.0, 5.0, 1)
        tau_full = np.zeros(robot.model.nv)
        tau_full[robot.actuated_indices] = tau
        expected = accelerations(q, v, tau_full)[robot.actuated_indices]
        projected = np.linalg.solve(M, tau - coriolis - G)
        np.testing.assert_allclose(projected, expected, rtol=0, atol=1e-9 * np.abs(expected).max())

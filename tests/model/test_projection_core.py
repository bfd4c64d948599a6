"""``ClosedChainRobot``'s projection (``velocity_map``, ``reduced_terms``, ``frame_jacobian``,
``frame_acceleration_drift``, ``project_state``) is the compiled core's; its readable twin
(``tests/reference/projection.py``) is the oracle here for what tests/sim/test_core_plant.py and
test_core_unactuated.py do not cover: joint springs and dampers in the reduced model, and a
frame's closed-loop Jacobian.

Tolerances: 1e-10 relative to the largest entry (both sides project the same Pinocchio terms
through the same S; the five-bar's cond(J_p) stays below 1e2 near home, its idle motion's
N^T M N far from zero)."""

from __future__ import annotations

import numpy as np
import pytest

import delta_pin as dp
from tests.reference import projection as readable

DATA = "tests/data/gepetto/5bar_linkage/robot.urdf"
RELATIVE = 1e-10  # the module docstring's bound


def _relative(a, b) -> float:
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / max(1e-300, np.abs(b).max()))


@pytest.fixture(scope="module")
def five_bar() -> dp.ClosedChainRobot:
    return dp.load_robot(DATA)


@pytest.fixture(scope="module")
def sprung(five_bar) -> dp.ClosedChainRobot:
    """The same five-bar with a spring-damper on one motor and one passive elbow (a torsion spring
    and a bearing's damping: what an MJCF <joint stiffness damping> gives)."""
    passive = next(
        five_bar.model.names[j]
        for j in range(1, five_bar.model.njoints)
        if five_bar.model.nvs[j] == 1 and five_bar.model.idx_vs[j] in set(five_bar.dependent_indices)
    )
    springs = {five_bar.actuated_joints[0]: (2.0, 0.1, 0.05), passive: (0.7, -0.2, 0.02)}
    return dp.ClosedChainRobot(
        five_bar.tree, five_bar.closures, five_bar.actuated_joints, joint_springs=springs
    )


def test_joint_springs_and_dampers_enter_the_core_reduced_model_as_in_its_twin(five_bar, sprung):
    rng = np.random.default_rng(3)
    for _ in range(4):
        alpha = sprung.home + rng.uniform(-0.1, 0.1, sprung.dof)
        alpha_dot = rng.normal(size=sprung.dof)
        q = sprung.configuration(alpha)
        terms = sprung.reduced_terms(alpha, alpha_dot, q)
        for got, expected in zip(terms, readable.reduced_terms(sprung, q, alpha_dot), strict=True):
            assert _relative(got, expected) < RELATIVE
        # the springs are really there: G gains S^T k (q - ref), C gains S^T D S (exactly the
        # spring forces; the plain five-bar's terms at the same state)
        plain = five_bar.reduced_terms(alpha, alpha_dot, q)
        S = sprung.velocity_map(q)
        stiffness, damping = sprung.joint_spring_forces(q)
        assert np.abs(stiffness).max() > 0.01  # the state strains the springs
        # (to 1e-10 of the larger of the two sides' terms: the Coriolis torque reaches 1e6 N m
        # here, the idle motion's tiny inertia, and the difference cancels it)
        for k, expected in ((2, S.T @ stiffness), (1, S.T @ damping @ S), (3, S.T @ damping @ S @ alpha_dot)):
            scale = max(np.abs(terms[k]).max(), np.abs(expected).max())
            assert np.abs(terms[k] - plain[k] - expected).max() < RELATIVE * scale
            assert np.abs(expected).max() > 1e-3  # a real contribution, not zeros on both sides


def test_a_frame_jacobian_and_drift_equal_the_twin_on_the_paper_delta():
    robot = dp.load_delta()
    rng = np.random.default_rng(4)
    frame = robot.end_effector
    for _ in range(4):
        alpha = robot.home + rng.uniform(-0.1, 0.1, robot.dof)
        alpha_dot = rng.normal(size=robot.dof)
        q = robot.configuration(alpha)
        assert _relative(robot.frame_jacobian(q), readable.frame_jacobian(robot, q, frame)) < RELATIVE
        drift = robot.frame_acceleration_drift(q, alpha_dot)
        assert _relative(drift, readable.frame_acceleration_drift(robot, q, alpha_dot, frame)) < RELATIVE


def test_a_bad_configuration_is_one_line(five_bar):
    with pytest.raises(dp.InvalidParameterError, match=r"q has shape \(2,\) or a non-finite entry; expected"):
        five_bar.velocity_map(np.zeros(2))
    with pytest.raises(dp.InvalidParameterError, match=r"q has shape .* or a non-finite entry"):
        five_bar.frame_jacobian(np.full(five_bar.model.nq, np.nan))


def test_model_changed_hands_an_in_place_change_to_the_compiled_model():
    """The compiled model holds a copy of ``robot.model``: G follows a changed gravity after
    ``model_changed()`` (doubled gravity, doubled G, to round-off), and not before (the copy)."""
    robot = dp.load_robot(DATA)
    alpha, alpha_dot = robot.home + 0.05, np.zeros(robot.dof)
    G = robot.reduced_terms(alpha, alpha_dot)[2]
    assert np.abs(G).max() > 1e-3
    robot.model.gravity.linear = 2.0 * robot.model.gravity.linear
    np.testing.assert_array_equal(robot.reduced_terms(alpha, alpha_dot)[2], G)  # the copy, until told
    robot.model_changed()
    np.testing.assert_allclose(robot.reduced_terms(alpha, alpha_dot)[2], 2.0 * G, rtol=1e-12, atol=0.0)


def _sprung_copy(robot) -> dp.ClosedChainRobot:
    """``robot`` with a spring-damper on its first motor and on one dependent revolute joint."""
    passive = next(
        robot.model.names[j]
        for j in range(1, robot.model.njoints)
        if robot.model.nvs[j] == 1 and robot.model.idx_vs[j] in set(robot.dependent_indices)
    )
    springs = {robot.actuated_joints[0]: (2.0, 0.1, 0.05), passive: (0.7, -0.2, 0.02)}
    return dp.ClosedChainRobot(robot.tree, robot.closures, robot.actuated_joints, joint_springs=springs)


@pytest.mark.parametrize(
    "name", ["delta", "five_bar", "stewart", "sprung five_bar", "sprung gepetto five-bar"]
)
def test_the_one_pass_torque_is_the_projected_dynamics(name, sprung):
    """``ClosedChainModel.actuated_torques`` (S^T RNEA(q, S alpha_dot, S alpha_ddot + S_dot alpha_dot)
    with the springs' forces: the planner's torque) and ``path_coefficients`` (the planner's a, b,
    c0 and dampers' term, by RNEA passes) against M alpha_ddot + C alpha_dot + G of the
    readable projection (tests/reference/projection.py), on robots without idle motions (the
    RNEA pass) and Gepetto's five-bar with its springs (an idle motion: the matrices' path), each
    state assembled from the one before; RELATIVE of the largest torque (measured <= 1.5e-15)."""
    robot = {
        "delta": lambda: dp.load_delta(),
        "five_bar": lambda: dp.load_robot("five_bar", end_effector="tip"),
        "stewart": lambda: dp.load_robot("stewart"),
        "sprung five_bar": lambda: _sprung_copy(dp.load_robot("five_bar", end_effector="tip")),
        "sprung gepetto five-bar": lambda: sprung,
    }[name]()
    rng = np.random.default_rng(5)
    alpha = robot.home + rng.uniform(-0.05, 0.05, (6, robot.dof))
    alpha_dot, alpha_ddot = rng.normal(size=(2, 6, robot.dof))
    failed, _, tau = robot.compiled_model.actuated_torques(
        alpha, alpha_dot, alpha_ddot, robot.reference_configuration.copy()
    )
    assert failed == -1
    # the planner's path coefficients at alpha' = alpha_dot, alpha'' = alpha_ddot: a = M alpha',
    # b = M alpha'' + Q(alpha') (the quadratic Coriolis part), c0 = G, damping = D alpha'
    failed, _, *coefficients = robot.compiled_model.path_coefficients(
        alpha, alpha_dot, alpha_ddot, robot.reference_configuration.copy()
    )
    assert failed == -1
    q = None
    for i in range(len(alpha)):
        q = robot.configuration(alpha[i], initial_guess=q)
        M, _, G, c_dot = readable.reduced_terms(robot, q, alpha_dot[i])
        expected = M @ alpha_ddot[i] + c_dot + G
        assert _relative(tau[i], expected) < RELATIVE, (name, i)
        quadratic = 0.5 * (readable.reduced_terms(robot, q, 2.0 * alpha_dot[i])[3] - 2.0 * c_dot)
        wanted = (M @ alpha_dot[i], M @ alpha_ddot[i] + quadratic, G, c_dot - quadratic)
        scale = max(np.abs(w).max() for w in wanted)  # the dampers' term is 0 on robots without
        for got, want in zip(coefficients, wanted, strict=True):
            assert np.abs(got[i] - want).max() < RELATIVE * scale, (name, i)

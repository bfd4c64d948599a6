"""The analytic Delta's closed-form start of the assembly (``Delta.closed_form_configuration``) on
the one robot model: the analytic FK (eqs. 1-5) puts the platform where the closures need it, so
the configuration it builds closes Pinocchio's loops to rounding, and it is the configuration
Newton converges to (the elbow-out assembly mode)."""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.model.validation import sample_states


@pytest.mark.parametrize("options", [{}, {"forearm_inertia": "rod", "l_b": 0.45, "r": 0.05}])
def test_the_closed_form_configuration_closes_the_loops(options):
    """Closure gap <= 1e-13 m at 30 random reachable states (the analytic FK and the forearm
    direction are exact; what is left is the rounding of ~10 placements of 0.1-0.5 m), and Newton
    started there moves no coordinate by more than 1e-12 rad or m: the same assembly."""
    robot = dp.load_delta(**options)
    alpha, _ = sample_states(robot, 30, seed=4)
    for a in alpha:
        q = robot.delta.closed_form_configuration(robot.model, robot.closures, a)
        assert robot.closure_gap(q) <= 1e-13
        assembled = robot.configuration(a, initial_guess=q)
        np.testing.assert_allclose(assembled, q, rtol=0, atol=1e-12)


def test_the_analytic_deltas_pinocchio_model_is_the_one_robot_model():
    """``robot.delta.pinocchio`` is the closed-chain robot itself (no second Pinocchio model of
    the Delta), and its projected dynamics is what ``pinocchio_dynamics`` returns (at the
    assembly from the closed-form start: equal to that of a tight Newton to 1e-13 relative)."""
    robot = dp.load_delta()
    assert robot.delta.pinocchio is robot
    alpha, alpha_dot = np.array([0.1, -0.2, 0.3]), np.array([0.4, 0.1, -0.6])
    reduced = robot.reduced_dynamics(alpha, alpha_dot, robot.configuration(alpha, tol=1e-15))
    got = robot.delta.pinocchio_dynamics(alpha, alpha_dot)
    for field in ("M", "coriolis", "G"):
        np.testing.assert_allclose(getattr(got, field), getattr(reduced, field), rtol=1e-13, atol=1e-15)

"""ClosedChainNominalModel's nominal friction M̄_f (eq. 12 with F̄_n) on the actuated joints.

It must equal :func:`delta_pin.model.friction.stribeck_torque` with the Stribeck parameters in
force (the recognised Delta's from its URDF for ``friction=True``, else the given ones), the
nominal normal force and the sgn smoothing of the :class:`Friction`. Both sides evaluate the same
closed form in double precision: 1e-15 relative (round-off; the values are 1e-5 to 0.5 N m).
"""

from __future__ import annotations

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.errors import InvalidParameterError
from delta_pin.model.friction import stribeck_torque

VELOCITIES = (
    [0.0, 0.0, 0.0],
    [0.3, -0.004, 2.0],  # one inside the sgn smoothing (|v| < 0.01 rad/s)
    [-5.0, 1e-6, 0.05],
)


def test_delta_nominal_friction_equals_stribeck_torque():
    robot = dp.load_robot("delta_gepetto")
    assert robot.delta is not None  # recognised: its URDF carries the Stribeck parameters
    nominal = dp.ClosedChainNominalModel(robot, friction=True)
    stribeck = robot.delta.params.friction
    assert nominal.stribeck == stribeck
    for v in VELOCITIES:
        v = np.array(v)
        expected = stribeck_torque(stribeck, v, 15.0, 0.01)  # Friction()'s F̄_n and smoothing
        np.testing.assert_allclose(nominal.friction(v), expected, rtol=1e-15, atol=0.0)
        np.testing.assert_allclose(nominal.compensation(v, friction=True), expected, rtol=1e-15, atol=0.0)
        np.testing.assert_array_equal(nominal.compensation(v, friction=False), np.zeros(3))
    assert np.abs(nominal.friction(np.array(VELOCITIES[1]))).min() > 0.0  # a friction worth comparing


def test_five_bar_nominal_friction_with_given_parameters():
    robot = dp.load_robot("five_bar")
    stribeck = dp.StribeckParameters(r_a=0.02, v_s=0.005, mu_s=0.3, mu_d=0.2, mu_v=4.0)
    friction = dp.Friction(stribeck=stribeck, normal_force=20.0, sign_velocity_scale=0.002)
    nominal = dp.ClosedChainNominalModel(robot, friction=friction)
    assert nominal.stribeck == stribeck
    for v in ([0.0, 0.0], [0.4, -0.001], [-3.0, 0.02]):
        v = np.array(v)
        expected = stribeck_torque(stribeck, v, 20.0, 0.002)
        np.testing.assert_allclose(nominal.friction(v), expected, rtol=1e-15, atol=0.0)
    # without friction: zero, and no Stribeck parameters
    plain = dp.ClosedChainNominalModel(robot)
    assert plain.stribeck is None
    np.testing.assert_array_equal(plain.friction(np.array([0.4, -0.1])), np.zeros(2))
    # friction=True needs a recognised Delta
    with pytest.raises(InvalidParameterError, match="friction=True needs a recognised Delta"):
        dp.ClosedChainNominalModel(robot, friction=True)

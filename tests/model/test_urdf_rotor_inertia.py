"""Rotor inertia in a URDF, as Drake writes it: ``<drake:rotor_inertia value="I"/>`` and
``<drake:gear_ratio value="N"/>`` in a transmission's actuator (Drake's URDF parser and its test
file multibody/parsing/test/detail_urdf_parser_test.cc; Drake reflects I N^2 onto the joint).
delta-pin reads it into ``model.armature``; the reference is Pinocchio's CRBA on the same tree
with that armature set by hand (exact: the same numbers added to M's diagonal)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import delta_pin as dp
from delta_pin.errors import URDFConventionError

FIVE_BAR = Path(dp.__file__).parent / "robots" / "five_bar.urdf"
MOTOR = '<actuator name="active_1_motor"><mechanicalReduction>1</mechanicalReduction></actuator>'


def _with_rotor(tmp_path: Path, actuator: str) -> Path:
    text = FIVE_BAR.read_text().replace("<robot ", '<robot xmlns:drake="http://drake.mit.edu" ', 1)
    assert MOTOR in text
    path = tmp_path / "five_bar.urdf"
    path.write_text(text.replace(MOTOR, actuator, 1))
    return path


def test_a_drake_rotor_inertia_is_the_joints_armature(tmp_path):
    actuator = (
        '<actuator name="active_1_motor"><drake:rotor_inertia value="2.5e-5"/>'
        '<drake:gear_ratio value="20"/></actuator>'
    )
    robot, plain = dp.load_robot(_with_rotor(tmp_path, actuator)), dp.load_robot(FIVE_BAR)
    v = robot.model.idx_vs[robot.model.getJointId("active_1")]
    expected = np.zeros(robot.model.nv)
    expected[v] = 2.5e-5 * 20**2  # 0.01 kg m^2 reflected through the gearbox
    np.testing.assert_allclose(robot.model.armature, expected, rtol=1e-14, atol=0.0)  # I N^2, round-off
    q = robot.reference_configuration
    reference = pin.Model(plain.model)
    reference.armature[v] = expected[v]
    np.testing.assert_allclose(
        robot.mass_matrix(q), pin.crba(reference, reference.createData(), q), rtol=0, atol=1e-15
    )
    # and through the projection: the reduced M gains S^T diag(armature) S
    alpha, alpha_dot = robot.home + 0.1, np.zeros(robot.dof)
    S = plain.velocity_map(plain.configuration(alpha))
    gained = robot.reduced_terms(alpha, alpha_dot)[0] - plain.reduced_terms(alpha, alpha_dot)[0]
    np.testing.assert_allclose(gained, S.T @ np.diag(expected) @ S, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("actuator", "message"),
    [
        (
            '<drake:rotor_inertia value="-1e-5"/>',
            r"line \d+: drake:rotor_inertia value='-1e-5' must be a finite number >= 0",
        ),
        ('<drake:rotor_inertia value="nan"/>', r"drake:rotor_inertia value='nan' must be a finite number"),
        (
            '<drake:rotor_inertia value="1e-5"/><drake:gear_ratio value="0"/>',
            r"drake:gear_ratio value='0' must be",
        ),
        ("<drake:rotor_inertia/>", r"drake:rotor_inertia value=None must be a finite number"),
    ],
)
def test_a_bad_rotor_inertia_is_one_line_naming_the_file_and_line(tmp_path, actuator, message):
    path = _with_rotor(tmp_path, f'<actuator name="active_1_motor">{actuator}</actuator>')
    with pytest.raises(URDFConventionError, match=message) as caught:
        dp.load_robot(path)
    assert "five_bar.urdf" in str(caught.value) and "\n" not in str(caught.value)


def test_a_rotor_on_a_joint_the_model_lacks_is_refused(tmp_path):
    path = _with_rotor(
        tmp_path, '<actuator name="active_1_motor"><drake:rotor_inertia value="1e-5"/></actuator>'
    )
    path.write_text(
        path.read_text().replace('<joint name="active_1"><hardware', '<joint name="no_such"><hardware', 1)
    )
    with pytest.raises(
        URDFConventionError, match=r"transmission names joints \['no_such'\]; expected one joint"
    ):
        dp.load_robot(path)

"""read_gepetto: URDF + Gepetto robot.yaml, its joint replacements and its errors.

The dynamics of the shipped Gepetto Delta are checked against the xacro Delta in
test_example_robots.py; here the five-bar in Gepetto's shape is checked against the same robot
written with a URDF ``<constraint>`` (the same tree and closure read by two loaders: 1e-12 on the
reduced terms, i.e. round-off).
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from delta_pin.errors import AssemblyError, URDFConventionError
from delta_pin.model.gepetto_loader import _replace_joints
from delta_pin.model.loaders import load_robot

ROBOTS = Path(__file__).resolve().parents[2] / "delta_pin" / "robots"
GEPETTO_DELTA = ROBOTS / "delta_gepetto"


def _five_bar_gepetto(tmp_path: Path, yaml: str) -> Path:
    """The shipped five-bar without its <constraint>, with the tips as fixed-joint links and the
    given robot.yaml beside it."""
    text = (ROBOTS / "five_bar.urdf").read_text()
    text = re.sub(r"<!--.*?-->", "", text, flags=re.S)
    text = re.sub(r"\s*<constraint .*?</constraint>", "", text, flags=re.S)
    tip_2 = (
        '  <joint name="tip_2_joint" type="fixed">\n    <parent link="distal_2"/>\n'
        '    <child link="tip_2"/>\n    <origin xyz="0 0 -0.3"/>\n  </joint>\n'
        '  <link name="tip_2"/>\n</robot>'
    )
    text = text.replace("</robot>", tip_2)
    (tmp_path / "robot.urdf").write_text(text)
    (tmp_path / "robot.yaml").write_text(yaml)
    return tmp_path / "robot.urdf"


FIVE_BAR_YAML = "closed_loop: [['tip', 'tip_2']]\ntype: ['3D']\nname_mot: ['active_1', 'active_2']\n"


def test_five_bar_in_gepettos_shape_equals_the_constraint_shape(tmp_path):
    gepetto = load_robot(_five_bar_gepetto(tmp_path, FIVE_BAR_YAML))
    reference = load_robot(ROBOTS / "five_bar.urdf")
    assert gepetto.actuated_joints == ("active_1", "active_2")
    assert gepetto.source == "robot.urdf + robot.yaml"
    for alpha, alpha_dot in ((np.array([0.2, -0.1]), np.array([0.5, -1.0])), (np.zeros(2), np.ones(2))):
        for mine, theirs in zip(
            gepetto.reduced_terms(alpha, alpha_dot), reference.reduced_terms(alpha, alpha_dot)
        ):
            np.testing.assert_allclose(mine, theirs, rtol=0, atol=1e-12)


def test_type_defaults_to_6d_as_in_gepettos_loader(tmp_path):
    # without a type the pair is a 6D weld: it also locks the tips' relative rotation, leaving
    # the planar five-bar 1 degree of freedom for 2 actuators; the same pair as 3D loads (test above)
    path = _five_bar_gepetto(
        tmp_path, "closed_loop: [['tip', 'tip_2']]\nname_mot: ['active_1', 'active_2']\n"
    )
    with pytest.raises(AssemblyError, match=r"has 1 degree\(s\) of freedom .* but 2 actuator\(s\)"):
        load_robot(path)


def test_actuated_argument_replaces_name_mot(tmp_path):
    path = _five_bar_gepetto(tmp_path, "closed_loop: [['tip', 'tip_2']]\ntype: ['3d']\n")
    robot = load_robot(path, actuated=["active_2", "active_1"])
    assert robot.actuated_joints == ("active_2", "active_1")


@pytest.mark.parametrize(
    ("yaml", "message"),
    [
        (
            "closed_loop: [['tip', 'nowhere']]\ntype: ['3D']\nname_mot: ['active_1', 'active_2']\n",
            r"robot.yaml line 1: closed_loop pair 0 names frame 'nowhere', which robot.urdf does not have",
        ),
        (
            "closed_loop:\n  - ['tip', 'tip_2']\n  - ['tip', 'base']\ntype: ['3D']\nname_mot: ['active_1']\n",
            r"robot.yaml line 4: 'type' has 1 item\(s\) but 'closed_loop' has 2",
        ),
        (
            "closed_loop: [['tip', 'tip_2']]\ntype: ['2D']\nname_mot: ['active_1', 'active_2']\n",
            r"robot.yaml line 2: type '2D' of closed_loop pair 0 \(tip, tip_2\) is not supported",
        ),
        ("type: ['3D']\nname_mot: ['active_1', 'active_2']\n", r"key 'closed_loop' is missing"),
        ("closed_loop: [['tip', 'tip_2']]\ntype: ['3D']\n", r"key 'name_mot' is missing"),
        (
            "closed_loop: [['tip', 'tip_2']]\ntype: ['3D']\nname_mot: ['active_1', 'motor_9']\n",
            r"robot.yaml line 3: motor joint 'motor_9' is not in robot.urdf",
        ),
        (
            "closed_loop: [['tip', 'tip_2']\ntype: ['3D']\n",
            r"robot.yaml line \d+: not valid YAML",
        ),
        (
            "closed_loop: [['tip', 'tip_2']]\nloops: 3\n",
            r"robot.yaml line 2: unknown key 'loops'",
        ),
        (
            "closed_loop: [['tip']]\n",
            r"robot.yaml line 1: closed_loop item 0 must be a pair of frame names",
        ),
        (
            "closed_loop: [['tip', 'tip_2']]\nname_mot: ['active_1', 'active_2']\njoint_name: ['passive_1']\n"
            "joint_type: ['PRISMATIC']\n",
            r"robot.yaml line 4: joint_type 'PRISMATIC' \(for joint 'passive_1'\) is not supported",
        ),
        (
            "closed_loop: [['tip', 'tip_2']]\nname_mot: ['active_1', 'active_2']\njoint_name: ['elbow_9']\n"
            "joint_type: ['SPHERICAL']\n",
            r"robot.yaml line 3: joint 'elbow_9' is not in the URDF",
        ),
    ],
)
def test_bad_robot_yaml_is_named_with_its_line(tmp_path, yaml, message):
    path = _five_bar_gepetto(tmp_path, yaml)
    with pytest.raises(URDFConventionError, match=message) as error:
        load_robot(path)
    assert "\n" not in str(error.value)


def test_frames_on_one_joint_close_no_loop(tmp_path):
    # 'tip' is a fixed-joint child of distal_1: both ride on joint passive_1
    path = _five_bar_gepetto(
        tmp_path, "closed_loop: [['tip', 'distal_1']]\ntype: ['3D']\nname_mot: ['active_1']\n"
    )
    with pytest.raises(
        URDFConventionError, match=r"robot.yaml line 1: frames 'tip' and 'distal_1' move together"
    ):
        load_robot(path)


def test_joint_replacements_follow_gepettos_loader():
    model = pin.buildModelFromUrdf(str(GEPETTO_DELTA / "robot.urdf"))

    def where(key, index=None):
        return "robot.yaml"

    spherical = _replace_joints(model, ["elbow_1_roll"], ["SPHERICAL"], where)
    assert spherical.nq == model.nq + 3 and spherical.nv == model.nv + 2
    assert spherical.joints[spherical.getJointId("elbow_1_roll")].shortname() == "JointModelSpherical"
    cardan = _replace_joints(model, ["platform_z"], ["CARDAN"], where)
    assert cardan.existJointName("platform_z_X") and cardan.existJointName("platform_z_Y")
    platform = cardan.frames[cardan.getFrameId("platform", pin.FrameType.BODY)]
    assert cardan.names[platform.parentJoint] == "platform_z_Y"  # the link rides on the second joint
    assert cardan.frames[cardan.getFrameId("closure_1_B")].parentJoint == platform.parentJoint
    fixed = _replace_joints(model, ["platform_x"], ["FIXED"], where)
    assert not fixed.existJointName("platform_x") and fixed.nq == model.nq - 1
    # the inertias are carried over: same total mass
    assert sum(i.mass for i in cardan.inertias) == pytest.approx(
        sum(i.mass for i in model.inertias), abs=1e-15
    )


def test_shipped_gepetto_delta_copies_and_loads(tmp_path):
    for name in ("robot.urdf", "robot.yaml"):
        shutil.copy(GEPETTO_DELTA / name, tmp_path / name)
    robot = load_robot(tmp_path / "robot.urdf", recognise=False)
    assert [c.name for c in robot.closures] == [f"closure_{i}_A_closure_{i}_B" for i in (1, 2, 3)]
    assert robot.closures[0].source == "robot.yaml line 2"
    assert robot.model.gravity.linear[2] == pytest.approx(-9.81)  # Pinocchio's default: a URDF has none

"""read_mjcf: the Pinocchio tree and closures built from MuJoCo's compiled model, checked against
MuJoCo itself (an independent implementation of the same file), and its errors.

Tolerances: body poses 1e-12 m / 1e-12 (rotation matrix entries), mass matrix and gravity
1e-12 (SI): both are double-precision evaluations of the same tree, differing by round-off only.
Closure residuals vs MuJoCo's equality residuals (``efc_pos``) 1e-12 m; for a weld's rotation,
MuJoCo's residual is the axis part of a quaternion (sin(theta/2)) and ours log3 (theta), so the
angles are compared (1e-10 rad).
"""

from __future__ import annotations

import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from delta_pin.errors import AssemblyError, OptionalDependencyError, URDFConventionError
from delta_pin.model.loaders import load_robot

mujoco = pytest.importorskip("mujoco")

from delta_pin.model.mjcf_loader import _closures, _to_pinocchio_q, mjcf_to_pinocchio, read_mjcf  # noqa: E402

ROBOTS = Path(__file__).resolve().parents[2] / "delta_pin" / "robots"

# a tree with every joint kind: several joints in one body with anchors off the body origin, a
# non-zero ref, an unaligned axis, a ball, a slide, a free-floating body, a jointless body
TREE = """
<mujoco model="tree">
  <compiler angle="radian"/>
  <option gravity="0.3 -0.2 -9.81"/>
  <worldbody>
    <body name="a" pos="0.1 0.2 0.3" quat="0.9 0.1 -0.3 0.2">
      <joint name="a1" type="hinge" axis="0 0 1" pos="0.05 0 0" ref="0.4"/>
      <joint name="a2" type="hinge" axis="1 1 0" pos="0 0.03 -0.02"/>
      <geom type="capsule" size="0.02 0.1" pos="0.1 0 0" quat="0.7 0 0.7 0"/>
      <body name="b" pos="0.2 0 0" euler="0.3 0.2 0.1">
        <joint name="b1" type="ball" pos="0.01 0.02 0"/>
        <inertial pos="0.05 0.01 0" mass="0.3" fullinertia="0.002 0.003 0.004 0.0001 0.0002 -0.0001"/>
        <body name="c" pos="0 0 -0.1">
          <joint name="c1" type="slide" axis="0 0.6 0.8" ref="0.1"/>
          <geom type="box" size="0.02 0.03 0.04"/>
          <body name="c_fixed" pos="0.05 0 0"><geom type="sphere" size="0.03"/></body>
        </body>
      </body>
    </body>
    <body name="f" pos="1 0 0"><freejoint name="free"/><geom type="cylinder" size="0.05 0.1"/></body>
  </worldbody>
</mujoco>
"""


def _write(tmp_path: Path, text: str, name: str = "robot.xml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _random_qpos(m, rng) -> np.ndarray:
    qpos = m.qpos0 + rng.uniform(-0.5, 0.5, m.nq)
    for j in range(m.njnt):  # quaternions: random unit ones
        a = m.jnt_qposadr[j]
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
            qpos[a : a + 4] = rng.normal(size=4) / 1.0
            qpos[a : a + 4] /= np.linalg.norm(qpos[a : a + 4])
        elif m.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            qpos[a + 3 : a + 7] = rng.normal(size=4)
            qpos[a + 3 : a + 7] /= np.linalg.norm(qpos[a + 3 : a + 7])
    return qpos


def test_tree_matches_mujocos_kinematics_inertia_and_gravity():
    m = mujoco.MjModel.from_xml_string(TREE)
    d = mujoco.MjData(m)
    model, bodies, q_maps = mjcf_to_pinocchio(m)
    data = model.createData()
    assert model.nq == m.nq and model.nv == m.nv
    assert model.gravity.linear == pytest.approx([0.3, -0.2, -9.81], abs=1e-15)
    rng = np.random.default_rng(7)
    for _ in range(3):
        qpos = _random_qpos(m, rng)
        d.qpos[:] = qpos
        mujoco.mj_forward(m, d)
        q = _to_pinocchio_q(model, q_maps, qpos)
        pin.framesForwardKinematics(model, data, q)
        for b in range(1, m.nbody):
            joint, placement = bodies[b]
            pose = data.oMi[joint] * placement
            np.testing.assert_allclose(pose.translation, d.xpos[b], atol=1e-12)
            np.testing.assert_allclose(pose.rotation, d.xmat[b].reshape(3, 3), atol=1e-12)
        # mass matrix and gravity on the joints whose velocities mean the same in both (all but
        # the free joint: MuJoCo's free linear velocity is in the world frame, Pinocchio's local)
        same = np.arange(m.nv - 6)
        M = np.zeros((m.nv, m.nv))
        if hasattr(d, "qM"):  # MuJoCo 3
            mujoco.mj_fullM(m, M, d.qM)
        else:  # MuJoCo 4
            mujoco.mj_fullM(m, d, M)
        M_pin = pin.crba(model, data, q)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        np.testing.assert_allclose(M_pin[np.ix_(same, same)], M[np.ix_(same, same)], atol=1e-12)
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)  # qfrc_bias at rest = the gravity torques
        gravity = pin.computeGeneralizedGravity(model, data, q)
        np.testing.assert_allclose(gravity[same], d.qfrc_bias[same], atol=1e-12)


CLOSED = """
<mujoco model="closures">
  <worldbody>
    <body name="l1" pos="0 0 0"><joint name="j1" axis="0 1 0"/>
      <inertial pos="0 0 -0.1" mass="0.1" diaginertia="1e-3 1e-3 1e-5"/>
      <site name="s1" pos="0.02 0.01 -0.2" quat="0.9 0.3 0.1 0.2"/>
      <body name="l1b" pos="0 0 -0.2"><joint name="j1b" type="ball"/>
        <inertial pos="0 0 -0.1" mass="0.1" diaginertia="1e-3 1e-3 1e-5"/></body>
    </body>
    <body name="l2" pos="0.1 0 0">
      <joint name="j2" axis="1 0 0"/><joint name="j2b" axis="0 0 1" pos="0 0.01 0"/>
      <inertial pos="0 0 -0.1" mass="0.1" diaginertia="1e-3 1e-3 1e-5"/>
      <site name="s2" pos="-0.05 0 -0.25" quat="0.8 -0.2 0.4 0.1"/>
    </body>
  </worldbody>
  <equality>
    <connect name="c_sites" site1="s1" site2="s2"/>
    <connect name="c_bodies" body1="l1b" body2="l2" anchor="0.01 0.02 -0.2"/>
    <weld name="w_sites" site1="s1" site2="s2"/>
    <weld name="w_bodies" body1="l1b" body2="l2" anchor="0.03 0 -0.1" relpose="0.1 0 -0.2 0.9 0.1 0.3 0.2"/>
    <weld name="w_default" body1="l2" body2="l1b" anchor="0.01 0.01 0.01" torquescale="3"/>
  </equality>
</mujoco>
"""


def test_connect_and_weld_residuals_match_mujocos(tmp_path):
    """Body and site semantics, explicit and default relpose: at random configurations, our
    closure frames' gap equals MuJoCo's equality residual."""
    path = _write(tmp_path, CLOSED)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    model, bodies, q_maps = mjcf_to_pinocchio(m)
    data = model.createData()
    closures = _closures(mujoco, m, bodies, path, path.name)
    assert [c.kind for c in closures] == ["3d", "3d", "6d", "6d", "6d"]
    line = next(n for n, text in enumerate(CLOSED.splitlines(), 1) if 'name="c_bodies"' in text)
    assert closures[1].source == f"robot.xml line {line}"
    rng = np.random.default_rng(11)
    for _ in range(3):
        qpos = _random_qpos(m, rng)
        d.qpos[:] = qpos
        mujoco.mj_forward(m, d)
        q = _to_pinocchio_q(model, q_maps, qpos)
        pin.forwardKinematics(model, data, q)
        row = 0
        for closure in closures:
            M1 = data.oMi[closure.joint1] * closure.placement1
            M2 = data.oMi[closure.joint2] * closure.placement2
            theirs = d.efc_pos[row : row + closure.size]
            np.testing.assert_allclose(M1.translation - M2.translation, theirs[:3], atol=1e-12)
            if closure.size == 6:  # MuJoCo: torquescale * sin(theta / 2) * axis
                angle = np.linalg.norm(pin.log3(M1.rotation.T @ M2.rotation))
                torquescale = m.eq_data[closures.index(closure), 10]
                half = np.linalg.norm(theirs[3:]) / torquescale
                assert 2 * np.arcsin(min(half, 1.0)) == pytest.approx(angle, abs=1e-10)
            row += closure.size
    # at qpos0 the default-relpose weld holds (MuJoCo computes relpose there)
    pin.forwardKinematics(model, data, _to_pinocchio_q(model, q_maps, m.qpos0))
    w = closures[4]
    gap = (data.oMi[w.joint1] * w.placement1).actInv(data.oMi[w.joint2] * w.placement2)
    assert np.abs(pin.log6(gap).vector).max() < 1e-12


# a five-bar under one jointless root body (Pinocchio's own parser keeps only the first root
# body's subtree, so this is the shape it reads whole); b2 has ref="12" (degrees, MuJoCo's default)
ONE_ROOT = """
<mujoco model="five_bar_one_root">
  <worldbody>
    <body name="base">
      <body name="p1" pos="-0.1 0 0"><joint name="a1" axis="0 1 0"/>
        <inertial pos="0 0 -0.125" mass="0.2" diaginertia="1e-3 1e-3 1e-5"/>
        <body name="d1" pos="0 0 -0.25"><joint name="b1" axis="0 1 0"/>
          <inertial pos="0 0 -0.15" mass="0.15" diaginertia="1e-3 1e-3 1e-5"/></body></body>
      <body name="p2" pos="0.1 0 0"><joint name="a2" axis="0 1 0"/>
        <inertial pos="0 0 -0.125" mass="0.2" diaginertia="1e-3 1e-3 1e-5"/>
        <body name="d2" pos="0 0 -0.25"><joint name="b2" axis="0 1 0" ref="12"/>
          <inertial pos="0 0 -0.15" mass="0.15" diaginertia="1e-3 1e-3 1e-5"/></body></body>
    </body>
  </worldbody>
  <equality><connect name="tips" body1="d1" body2="d2" anchor="0.05 0 -0.3"/></equality>
  <actuator><motor joint="a1"/><motor joint="a2"/></actuator>
</mujoco>
"""


def test_agrees_with_pinocchios_mjcf_parser_where_it_reads_the_file(tmp_path):
    """Same joint placements (ref folded in the same way), inertias and connect anchors as
    ``pin.buildModelAndConstraintsFromMJCF`` (1e-12: round-off)."""
    path = _write(tmp_path, ONE_ROOT)
    robot = read_mjcf(path)
    theirs, points, _frames = pin.buildModelAndConstraintsFromMJCF(str(path))
    ours = robot.model
    assert list(theirs.names) == list(ours.names)
    for j in range(1, ours.njoints):
        assert (
            np.abs(
                (theirs.jointPlacements[j].inverse() * ours.jointPlacements[j]).homogeneous - np.eye(4)
            ).max()
            < 1e-12
        )
        np.testing.assert_allclose(theirs.inertias[j].matrix(), ours.inertias[j].matrix(), atol=1e-12)
    (point,) = points
    closure = robot.closures[0]
    assert (point.joint1_id, point.joint2_id) == (closure.joint1, closure.joint2)
    np.testing.assert_allclose(point.joint1_placement.translation, closure.placement1.translation, atol=1e-12)
    np.testing.assert_allclose(point.joint2_placement.translation, closure.placement2.translation, atol=1e-12)
    # the reference is MuJoCo's qpos0: b2 at its ref, 12 degrees, and the loop closed there
    np.testing.assert_allclose(robot.reference_configuration, [0, 0, 0, np.radians(12)], atol=1e-12)


def test_delta_xml_reads_motors_gravity_sites_and_visuals():
    robot = load_robot(ROBOTS / "delta.xml", recognise=False)
    assert robot.actuated_joints == ("active_1", "active_2", "active_3")
    assert robot.model.gravity.linear == pytest.approx([0, 0, -9.8], abs=1e-15)
    assert robot.model.existFrame("closure_1_parent")  # sites are frames
    assert read_mjcf(ROBOTS / "delta.xml", g=3.0).model.gravity.linear[2] == -3.0
    assert isinstance(robot.visual_model, pin.GeometryModel)


def test_home_keyframe_is_the_reference(tmp_path):
    text = (ROBOTS / "delta.xml").read_text()
    home = "0.3 0 0 0.2 0 0 0.1 0 0 0 0 0"  # MuJoCo's qpos order: bodies in file order
    path = _write(
        tmp_path,
        text.replace("</mujoco>", f'  <keyframe><key name="home" qpos="{home}"/></keyframe>\n</mujoco>'),
    )
    robot = read_mjcf(path)
    np.testing.assert_allclose(robot.home, [0.3, 0.2, 0.1])
    assert robot.closure_gap(robot.reference_configuration) < 1e-12


def _delta_with(tmp_path, old: str, new: str) -> Path:
    text = (ROBOTS / "delta.xml").read_text()
    assert old in text
    return _write(tmp_path, text.replace(old, new))


def test_unsupported_equality_is_named_with_its_line(tmp_path):
    path = _delta_with(
        tmp_path,
        "  <equality>",
        '  <tendon><fixed name="pull"><joint joint="active_1" coef="1"/></fixed></tendon>\n  <equality>\n'
        '    <tendon name="hold" tendon1="pull"/>',
    )
    with pytest.raises(
        URDFConventionError, match=r"equality 'hold' \(robot.xml line \d+\) is a 'tendon' equality"
    ):
        load_robot(path)


def test_a_joint_equality_is_a_coupling_named_where_it_takes_a_motors_freedom(tmp_path):
    """A joint equality is a closure equation of its own (a JointCoupling): tying two of the
    Delta's motors together leaves 2 degrees of freedom for 3 motors, and the error names it."""
    path = _delta_with(
        tmp_path,
        "  </equality>",
        '    <joint name="couple" joint1="active_1" joint2="active_2"/>\n  </equality>',
    )
    line = next(n for n, text in enumerate(path.read_text().splitlines(), 1) if 'name="couple"' in text)
    with pytest.raises(
        AssemblyError,
        match=rf"2 degree\(s\) of freedom .*joint coupling 'couple' \(robot.xml line {line}\) among "
        r"them\) but 3 actuator\(s\)",
    ):
        load_robot(path)


def test_disabled_equality_is_an_error(tmp_path):
    path = _delta_with(tmp_path, 'site2="closure_2_child"', 'site2="closure_2_child" active="false"')
    with pytest.raises(URDFConventionError, match=r"equality 'closure_2' \(robot.xml line \d+\) is disabled"):
        load_robot(path)


def test_actuator_on_unknown_joint_names_the_line(tmp_path):
    path = _delta_with(tmp_path, 'joint="active_3"', 'joint="active_9"')
    with pytest.raises(URDFConventionError, match=r"MuJoCo cannot compile it: .*active_9.*line \d+"):
        load_robot(path)


def test_servos_are_read_as_force_sources_and_said_so_filtered_and_site_actuators_are_refused(tmp_path):
    """A position servo is a force source with a servo law: read as the force source, and the
    law left out is said (a warning and the summary's notes), not dropped silently. Activation
    dynamics (a filtered servo) would be a state of its own: refused."""
    path = _delta_with(
        tmp_path,
        '<motor name="motor_3" joint="active_3"/>',
        '<position name="servo" joint="active_3" kp="10"/>',
    )
    said = (
        r"actuator 'servo' \(robot.xml line \d+\) is a position servo in the file "
        r"\(force = 10 ctrl - 10 length\)"
    )
    with pytest.warns(UserWarning, match=said):
        robot = load_robot(path)
    assert robot.actuated_joints == ("active_1", "active_2", "active_3")
    assert re.search("note: " + said + r": read as a force source on active_3", robot.summary())
    path = _delta_with(
        tmp_path,
        '<motor name="motor_3" joint="active_3"/>',
        '<position name="servo" joint="active_3" kp="10" timeconst="0.01"/>',
    )
    with pytest.raises(
        URDFConventionError, match=r"actuator 'servo' \(robot.xml line \d+\) is not a force source"
    ):
        load_robot(path)
    path = _delta_with(
        tmp_path, '<motor name="motor_3" joint="active_3"/>', '<motor name="pusher" site="closure_3_child"/>'
    )
    with pytest.raises(
        URDFConventionError, match=r"actuator 'pusher' \(robot.xml line \d+\) drives a 'site'"
    ):
        load_robot(path)


def test_closure_between_missing_sites_is_named(tmp_path):
    path = _delta_with(tmp_path, 'site2="closure_3_child"', 'site2="nowhere"')
    with pytest.raises(URDFConventionError, match=r"nowhere.*line \d+"):
        load_robot(path)


def test_wrong_number_of_actuators_is_a_mobility_error():
    with pytest.raises(AssemblyError, match=r"3 degree\(s\) of freedom .* but 2 actuator"):
        read_mjcf(ROBOTS / "delta.xml", actuated=["active_1", "active_2"])


def test_loop_that_cannot_assemble(tmp_path):
    text = re.sub(
        r'(<site name="closure_2_child" pos=")[^"]*', r"\g<1>0.9 0 0", (ROBOTS / "delta.xml").read_text()
    )
    # the global solve (every joint free) spreads the broken loop's gap over the platform's three
    # loops: the message names the worst at the best pose found, with its line
    with pytest.raises(
        AssemblyError,
        match=r"loops do not close anywhere near the file's pose .* closure 'closure_\d' "
        r"\(robot.xml line \d+\) stays",
    ):
        load_robot(_write(tmp_path, text))


def test_missing_mujoco_is_an_optional_dependency_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(OptionalDependencyError, match="pip install mujoco"):
        read_mjcf(ROBOTS / "delta.xml")


def test_armature_and_damping_are_read_not_ignored(tmp_path):
    """A rotor inertia on active_1 adds exactly that to the reduced inertia's (1, 1) entry (S's
    actuated rows are the identity); a damper becomes a joint spring of zero stiffness, and
    nothing is warned about (1e-12: the same numbers, one sum)."""
    plain = load_robot(_delta_with(tmp_path, "", ""), recognise=False)
    path = _delta_with(
        tmp_path, '<joint name="active_1" type="hinge"', '<joint name="active_1" armature="0.01" type="hinge"'
    )
    robot = load_robot(path, recognise=False)
    alpha, alpha_dot = np.array([0.2, 0.3, 0.1]), np.zeros(3)
    added = robot.reduced_terms(alpha, alpha_dot)[0] - plain.reduced_terms(alpha, alpha_dot)[0]
    np.testing.assert_allclose(added, np.diag([0.01, 0.0, 0.0]), atol=1e-12, rtol=0)
    path = _delta_with(
        tmp_path, '<joint name="active_1" type="hinge"', '<joint name="active_1" damping="0.1" type="hinge"'
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        damped = load_robot(path, recognise=False)
    assert damped.joint_springs == {"active_1": (0.0, 0.0, 0.1)}
    assert damped.passive_joints == ()  # a damper alone does not make a joint passive


TO_THE_WORLD = """
<mujoco model="to_the_world">
  <worldbody>
    <site name="s_world" pos="0.05 0.1 -0.3" quat="0.7 0.1 0.6 0.2"/>
    <body name="ground" pos="0.2 -0.1 0.05" quat="0.9 0.2 -0.1 0.3">
      <site name="s_ground" pos="0.01 0 -0.02"/>
    </body>
    <body name="l1" pos="0 0 0"><joint name="j1" axis="0 1 0"/>
      <inertial pos="0 0 -0.1" mass="0.1" diaginertia="1e-3 1e-3 1e-5"/>
      <body name="l1b" pos="0 0 -0.2"><joint name="j1b" type="ball"/>
        <inertial pos="0 0 -0.1" mass="0.1" diaginertia="1e-3 1e-3 1e-5"/>
        <site name="s1" pos="0.02 0.01 -0.2" quat="0.9 0.3 0.1 0.2"/></body>
    </body>
  </worldbody>
  <equality>
    <connect name="c_world" body1="l1b" anchor="0.01 0.02 -0.2"/>
    <connect name="c_world_first" body1="world" body2="l1b" anchor="0.1 0.02 -0.3"/>
    <connect name="c_ground" body1="l1b" body2="ground" anchor="0 0.01 -0.1"/>
    <connect name="c_sites" site1="s1" site2="s_world"/>
    <weld name="w_world" body1="l1b" relpose="0.1 0 -0.2 0.9 0.1 0.3 0.2"/>
    <weld name="w_ground_first" body1="ground" body2="l1b" anchor="0.03 0 -0.1"/>
    <weld name="w_sites" site1="s_ground" site2="s1"/>
  </equality>
</mujoco>
"""


def test_closures_to_the_world_match_mujocos(tmp_path):
    """An equality on the world body (body2 left out, or body1="world"), on a jointless body fixed
    to the world, or on a site of either, is a closure with one frame on joint 0: its gap equals
    MuJoCo's equality residual at random configurations (the tolerances of the test above)."""
    path = _write(tmp_path, TO_THE_WORLD)
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    model, bodies, q_maps = mjcf_to_pinocchio(m)
    data = model.createData()
    closures = _closures(mujoco, m, bodies, path, path.name)
    assert [(c.name, c.kind) for c in closures] == [
        ("c_world", "3d"), ("c_world_first", "3d"), ("c_ground", "3d"), ("c_sites", "3d"),
        ("w_world", "6d"), ("w_ground_first", "6d"), ("w_sites", "6d"),
    ]  # fmt: skip
    assert [(c.joint1 == 0, c.joint2 == 0) for c in closures] == [
        (False, True),
        (True, False),
        (False, True),
        (False, True),
        (False, True),
        (True, False),
        (True, False),
    ]
    rng = np.random.default_rng(12)
    for _ in range(3):
        qpos = _random_qpos(m, rng)
        d.qpos[:] = qpos
        mujoco.mj_forward(m, d)
        q = _to_pinocchio_q(model, q_maps, qpos)
        pin.forwardKinematics(model, data, q)
        row = 0
        for e, closure in enumerate(closures):
            M1 = data.oMi[closure.joint1] * closure.placement1
            M2 = data.oMi[closure.joint2] * closure.placement2
            theirs = d.efc_pos[row : row + closure.size]
            np.testing.assert_allclose(M1.translation - M2.translation, theirs[:3], atol=1e-12)
            if closure.size == 6:  # MuJoCo: torquescale * sin(theta / 2) * axis
                angle = np.linalg.norm(pin.log3(M1.rotation.T @ M2.rotation))
                half = np.linalg.norm(theirs[3:]) / m.eq_data[e, 10]
                assert 2 * np.arcsin(min(half, 1.0)) == pytest.approx(angle, abs=1e-10)
            row += closure.size


def test_equality_within_the_ground_is_refused(tmp_path):
    path = _delta_with(
        tmp_path,
        "  </worldbody>",
        '    <body name="ground" pos="0 0 0.1"/>\n  </worldbody>',
    )
    text = path.read_text().replace(
        "  </equality>", '    <connect name="pin_down" body1="ground" anchor="0 0 -0.3"/>\n  </equality>'
    )
    path.write_text(text)
    with pytest.raises(
        URDFConventionError,
        match=r"equality 'pin_down' \(robot.xml line \d+\) joins bodies 'ground' and 'world', which are one "
        r"rigid body \(both fixed to the world\)",
    ) as error:
        load_robot(path)
    assert "\n" not in str(error.value)

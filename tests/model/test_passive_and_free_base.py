"""Joints no motor drives that the closures leave free: sprung MJCF joints (with armature and
dampers, checked against MuJoCo's own simulation), a motorless MuJoCo test model as shipped
(tests/data/mujoco/jdotv_connect_2d.xml), Gepetto's ``name_passive`` and universal joints, and
a free-flyer base (the centre of mass falls at g: a closed form)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

import delta_pin as dp
from delta_pin.errors import InvalidParameterError, URDFConventionError
from delta_pin.model.gepetto_loader import _universal_axes
from delta_pin.sim.integrators import rk4_step
from tests.model.closed_chain_fixtures import SPRUNG_FIVE_BAR, pinocchio_accelerations
from tests.reference.plants import ReadableClosedChainPlant

mujoco = pytest.importorskip("mujoco")

DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.fixture(scope="module")
def sprung(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("sprung") / "sprung.xml"
    path.write_text(SPRUNG_FIVE_BAR)
    return path


def plant_motion(robot, t_end, h, tau=None):
    plant = ReadableClosedChainPlant(robot)
    x = plant.initial_state(robot.home, np.zeros(robot.dof))
    tau = np.zeros(robot.dof) if tau is None else tau
    for k in range(round(t_end / h)):
        x = rk4_step(lambda t, y: plant.derivative(t, y, tau), k * h, x, h)
        x = plant.finish_step(x, (k + 1) * h)
    return plant, x


def mujoco_motion(path, t_end, timeconst):
    """MuJoCo's own simulation: RK4 at 0.1 ms, the equality made stiff (solref timeconst) and
    hard (solimp near 1)."""
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.timestep = 1e-4
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    m.eq_solref[:] = [timeconst, 1.0]
    m.eq_solimp[:] = [0.99, 0.999, 0.001, 0.5, 2.0]
    d = mujoco.MjData(m)
    for _ in range(round(t_end / m.opt.timestep)):
        mujoco.mj_step(m, d)
    return np.array(d.qpos)


def test_sprung_joints_are_read_not_ignored(sprung):
    robot = dp.load_robot(sprung)
    assert robot.actuated_joints == ("motor_joint",)
    assert robot.passive_joints == ("spring_joint",)  # sprung, and no motor drives it
    assert robot.joint_springs == {"spring_joint": (3.0, 0.2, 0.05), "left_elbow": (0.0, 0.0, 0.01)}
    found = robot.classification()
    assert found["mobility"] == 2 and not found["fully_actuated"]
    assert "underactuated" in robot.summary()
    # the rotor inertia is in the tree's mass matrix exactly as in MuJoCo's (1e-12: the same numbers)
    m = mujoco.MjModel.from_xml_path(str(sprung))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    if hasattr(d, "qM"):  # MuJoCo 3
        mujoco.mj_fullM(m, M, d.qM)
    else:  # MuJoCo 4
        mujoco.mj_fullM(m, d, M)
    np.testing.assert_allclose(robot.mass_matrix(robot.reference_configuration), M, atol=1e-12, rtol=0)
    assert robot.model.armature[0] == 0.002


def test_sprung_five_bar_moves_as_mujoco_simulates_it(sprung):
    """0.3 s from rest under gravity, the spring and the dampers, no motor torque. MuJoCo's
    constraints are soft: its distance to our plant shrinks with the constraint time constant
    (measured over 0.5 s: 2.7e-3 rad at MuJoCo's default 0.02 s, 8.3e-5 at 2e-3 s, 1.3e-6 at
    2e-4 s), so at 2e-4 s the bound 1e-5 rad is MuJoCo's softness, not ours."""
    robot = dp.load_robot(sprung)
    _, x = plant_motion(robot, 0.3, 1e-4)
    qpos = mujoco_motion(sprung, 0.3, 2e-4)
    assert np.abs(x[:4] - robot.reference_configuration).max() > 0.05  # it moved
    np.testing.assert_allclose(x[:4], qpos, atol=1e-5, rtol=0)


def test_controllers_refuse_underactuated_robots_in_one_line(sprung):
    robot = dp.load_robot(sprung)
    with pytest.raises(InvalidParameterError, match=r"underactuated.*spring_joint"):
        dp.ClosedChainNominalModel(robot)
    # naming the sprung joint actuated makes it fully actuated (the spring stays)
    driven = dp.load_robot(sprung, actuated=["motor_joint", "spring_joint"], passive=[])
    assert driven.passive_joints == () and driven.joint_springs["spring_joint"][0] == 3.0
    dp.ClosedChainNominalModel(driven).terms(driven.home, np.zeros(2))


def test_springs_on_ball_joints_are_refused(tmp_path):
    """A ball joint takes one damper (delta_ballrods' test checks it against MuJoCo), not a spring."""
    text = SPRUNG_FIVE_BAR.replace(
        '<joint name="left_elbow" type="hinge" axis="0 1 0" damping="0.01"/>',
        '<joint name="left_elbow" type="ball" stiffness="2"/>',
    )
    path = tmp_path / "ball.xml"
    path.write_text(text)
    with pytest.raises(
        URDFConventionError, match="ball joint 'left_elbow' has a stiffness or unequal dampers"
    ):
        dp.load_robot(path)


def test_mujoco_test_model_without_motors_loads_as_shipped_and_falls_as_references_do():
    """MuJoCo's jdotv_connect_2d.xml (no motors, unnamed joints): a passive mechanism of two
    degrees of freedom, whose independent joints the loader chooses. 0.3 s of free fall (0.93 rad
    of swing) against Pinocchio alone (constraintDynamics, proximal settings, DOP853 at rtol 1e-11;
    measured 4.3e-13 rad with RK4 at 0.1 ms, bound 1e-10) and against MuJoCo with stiff constraints
    (measured 1.1e-8 rad, bound 1e-7: MuJoCo's softness at time constant 2e-4 s, see above)."""
    path = DATA / "mujoco" / "jdotv_connect_2d.xml"
    robot = dp.load_robot(path)
    assert robot.dof == 0 and len(robot.passive_joints) == 2
    assert robot.classification()["mobility"] == 2
    _, x = plant_motion(robot, 0.3, 1e-4)
    nq = robot.model.nq
    accelerations = pinocchio_accelerations(robot)

    def f(t, y):
        return np.concatenate([y[nq:], accelerations(y[:nq], y[nq:], np.zeros(nq))])

    y0 = np.concatenate([robot.reference_configuration, np.zeros(nq)])
    reference = solve_ivp(f, (0.0, 0.3), y0, method="DOP853", rtol=1e-11, atol=1e-12).y[:nq, -1]
    assert np.abs(reference - robot.reference_configuration).max() > 0.1  # it fell
    np.testing.assert_allclose(x[:nq], reference, atol=1e-10, rtol=0)
    np.testing.assert_allclose(x[:nq], mujoco_motion(path, 0.3, 2e-4), atol=1e-7, rtol=0)


def gepetto_copy(tmp_path: Path, yaml_text: str) -> Path:
    folder = tmp_path / "five_bar"
    folder.mkdir(parents=True)
    shutil.copy(DATA / "gepetto" / "5bar_linkage" / "robot.urdf", folder / "robot.urdf")
    (folder / "robot.yaml").write_text(yaml_text)
    return folder / "robot.urdf"


def test_gepetto_name_passive_and_universal_joints(tmp_path):
    urdf = gepetto_copy(
        tmp_path,
        "closed_loop: [['closedloop1_A', 'closedloop1_B']]\ntype: ['6d']\nname_mot: ['mot1']\n"
        "name_passive: ['mot2']\n",
    )
    robot = dp.load_robot(urdf)
    assert robot.actuated_joints == ("mot1",) and robot.passive_joints == ("mot2",)
    assert _universal_axes("UJOINT_ZY") == ("Z", "Y") and _universal_axes("CARDAN") == ("X", "Y")
    assert _universal_axes("UJOINT_ZZ") is None
    # free1 as Gepetto's UJOINT_ZX: revolutes free1_Z then free1_X; the weld locks X, so the
    # reduced dynamics are the shipped model's (1e-10 relative: two assemblies to 1e-12)
    other = tmp_path / "ujoint"
    other.mkdir()
    shutil.copy(urdf, other / "robot.urdf")
    (other / "robot.yaml").write_text(
        "closed_loop: [['closedloop1_A', 'closedloop1_B']]\ntype: ['6d']\nname_mot: ['mot1', 'mot2']\n"
        "joint_name: ['free1']\njoint_type: ['UJOINT_ZX']\n"
    )
    ujoint = dp.load_robot(other / "robot.urdf")
    assert {"free1_Z", "free1_X"} <= set(ujoint.model.names) and "free1" not in ujoint.model.names
    shipped = dp.load_robot(DATA / "gepetto" / "5bar_linkage" / "robot.urdf")
    alpha, alpha_dot = shipped.home + 0.03, np.array([0.4, -0.2])
    for a, b in zip(shipped.reduced_terms(alpha, alpha_dot), ujoint.reduced_terms(alpha, alpha_dot)):
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-10 * np.abs(a).max())
    with pytest.raises(URDFConventionError, match=r"passive joint 'nope' is not in robot\.urdf"):
        dp.load_robot(gepetto_copy(tmp_path / "bad", "closed_loop: [['closedloop1_A', 'closedloop1_B']]\n"
                                    "name_mot: ['mot1']\nname_passive: ['nope']\n"))  # fmt: skip


def test_free_flyer_base_falls_at_g_and_controllers_refuse_it():
    """Gepetto's freeflyer=True: the five-bar on a free-flyer root. With no external force the
    centre of mass falls at g whatever the motors do inside (closed form). RK4 at 0.25 ms with
    quaternion renormalisation: measured 1.6e-11 m over 0.2 s, bound 1e-9 m. (At 1 ms it is
    1.1e-7 m: the closure projections correct velocities by the minimum-norm change, which does
    not conserve momentum.)"""
    robot = dp.load_robot(DATA / "gepetto" / "5bar_linkage" / "robot.urdf", free_flyer=True)
    assert "root_joint" in robot.passive_joints and robot.model.nq == robot.model.nv + 1
    _, x = plant_motion(robot, 0.2, 2.5e-4, tau=np.array([2e3, -2e3]))  # the motors move the inside
    model, data = robot.model, robot.model.createData()
    start = pin.centerOfMass(model, data, robot.reference_configuration).copy()
    end = pin.centerOfMass(model, data, x[: model.nq]).copy()
    np.testing.assert_allclose(end - start, [0.0, 0.0, -0.5 * 9.81 * 0.2**2], atol=1e-9, rtol=0)
    assert abs(np.linalg.norm(x[3:7]) - 1.0) < 1e-15 * 10  # the base quaternion stays unit
    assert np.abs(x[robot.actuated_q_indices] - robot.home).max() > 0.01  # the inside moved
    with pytest.raises(InvalidParameterError, match=r"its base is free \(root_joint\)"):
        dp.ClosedChainNominalModel(robot)


def test_validate_checks_an_underactuated_robot_without_a_reduced_model(sprung):
    """The sprung five-bar: closure and energy (springs on, dampers off: conserved) are checked;
    the reduced-model checks are not run, and the report says why."""
    from delta_pin.sim.closed_chain_validation import validate_closed_chain

    report = validate_closed_chain(dp.load_robot(sprung), samples=5, energy_duration=0.2)
    assert report.passed, report.table()
    assert set(report.checks) == {"closure", "energy", "loop gap"}
    assert "not run: the robot is underactuated (passive joints spring_joint)" in report.table()

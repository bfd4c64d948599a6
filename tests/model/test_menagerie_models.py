"""MuJoCo Menagerie's Agility Cassie and Robotiq 2F-85 as shipped (tests/data/menagerie, README
there): each loads unedited, is classified, assembles, moves as a Pinocchio-only reference and as
MuJoCo's own simulation moves it, and passes ``validate``.

The references are the tests' own:

* **Pinocchio only**: ``pin.constraintDynamics`` on the robot's tree and closure models with tight
  proximal settings (accuracy 1e-14, mu 1e-10, 1000 iterations: the planar loops of both robots
  make their closure equations redundant), the joints' springs, dampers and armature taken from
  MuJoCo's compiled model (not from the loader), quaternions integrated by the tests' own rates,
  DOP853 at rtol 1e-11. Pinocchio has no constraint for the Robotiq's ``<equality joint>`` (and its
  mimic joints are refused by ``constraintDynamics``), so the reference adds that coupling's
  multiplier by the one row it is: ddq is affine in the torques, so two solves fix it.
* **MuJoCo**: RK4, contacts and joint limits off (delta-pin models neither), the equalities made
  stiff and hard (solref time constant 2e-4 s or 1e-4 s, solimp 0.9999): MuJoCo's constraints are
  soft, so its distance to the exact dynamics shrinks with the time constant, and each bound is
  that softness (both time constants are checked, and the distance halves at least).
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

import delta_pin as dp
from delta_pin.errors import InvalidParameterError, URDFConventionError
from delta_pin.sim.closed_chain_validation import validate_closed_chain
from delta_pin.sim.integrators import rk4_step
from tests.model.closed_chain_fixtures import configuration_rate

mujoco = pytest.importorskip("mujoco")

from delta_pin.model.mjcf_loader import _to_pinocchio_q, mjcf_to_pinocchio  # noqa: E402
from tests.reference.plants import ReadableClosedChainPlant  # noqa: E402

MENAGERIE = Path(__file__).resolve().parents[1] / "data" / "menagerie"
CASSIE = MENAGERIE / "agility_cassie" / "cassie.xml"
ROBOTIQ = MENAGERIE / "robotiq_2f85" / "2f85.xml"
SERVO = r"actuator 'fingers_actuator' \(2f85.xml line 188\) is a position servo in the file"


@pytest.fixture(scope="module")
def cassie():
    return dp.load_robot(CASSIE)


@pytest.fixture(scope="module")
def robotiq():
    with pytest.warns(UserWarning, match=SERVO):
        return dp.load_robot(ROBOTIQ)


# ------------------------------------------------------------------------------------- references
def _joint_name(m, j: int) -> str:
    return m.joint(j).name or f"joint_{j}"  # the loader's name for an unnamed joint


def _mujoco_joints(m, model: pin.Model):
    """Per MuJoCo joint: (v slice in Pinocchio's v, q index, MuJoCo dof address, dofs, stiffness,
    spring reference, kind)."""
    rows = []
    for j in range(m.njnt):
        jid = model.getJointId(_joint_name(m, j))
        dofs = {0: 6, 1: 3}.get(int(m.jnt_type[j]), 1)
        velocities = slice(model.idx_vs[jid], model.idx_vs[jid] + dofs)
        spring = (float(m.jnt_stiffness[j]), float(m.qpos_spring[m.jnt_qposadr[j]]))
        rows.append((velocities, model.idx_qs[jid], int(m.jnt_dofadr[j]), dofs, *spring, int(m.jnt_type[j])))
    return rows


def pinocchio_reference(robot, m, x0, t_end, joint_force=None):
    """(q, v) at t_end by Pinocchio alone (module docstring); ``joint_force`` (nv,) a constant
    generalised force. The tree's armature, springs and dampers are MuJoCo's numbers."""
    model = pin.Model(robot.model)
    joints = _mujoco_joints(m, model)
    model.armature[:] = 0.0
    for rows, _, dof, dofs, *_ in joints:
        model.armature[rows] = m.dof_armature[dof : dof + dofs]
    data = model.createData()
    models, datas = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    for constraint in robot.constraint_models:
        models.append(pin.RigidConstraintModel(constraint))
        datas.append(models[-1].createData())
    pin.initConstraintDynamics(model, data, models, datas)
    settings = pin.ProximalSettings(1e-14, 1e-10, 1000)
    rows = []  # <equality joint>: q1 - q1_0 = c0 + c1 (q2 - q2_0), a velocity row e1 - c1 e2
    for e in np.flatnonzero(m.eq_type == int(mujoco.mjtEq.mjEQ_JOINT)):
        assert not np.any(m.eq_data[e, 2:5]), "a linear coupling"
        row = np.zeros(model.nv)
        row[joints[int(m.eq_obj1id[e])][0]] = 1.0
        row[joints[int(m.eq_obj2id[e])][0]] = -m.eq_data[e, 1]
        rows.append(row)
    applied = np.zeros(model.nv) if joint_force is None else joint_force

    def accelerations(q, v):
        tau = applied.copy()
        for rows_v, iq, dof, dofs, stiffness, reference, kind in joints:
            tau[rows_v] -= m.dof_damping[dof : dof + dofs] * v[rows_v]
            if stiffness:
                assert kind in (2, 3)
                tau[rows_v] -= stiffness * (q[iq] - reference)
        a = pin.constraintDynamics(model, data, q, v, tau, models, datas, settings).copy()
        for row in rows:  # the coupling's multiplier: a(tau + lambda row) is affine in lambda
            moved = pin.constraintDynamics(model, data, q, v, tau + row, models, datas, settings) - a
            a = a - (row @ a) / (row @ moved) * moved
        return a

    nq = model.nq
    solution = solve_ivp(
        lambda t, y: np.r_[configuration_rate(model, y[:nq], y[nq:]), accelerations(y[:nq], y[nq:])],
        (0.0, t_end), x0, method="DOP853", rtol=1e-11, atol=1e-12,
    )  # fmt: skip
    assert solution.status == 0
    return solution.y[:nq, -1], solution.y[nq:, -1]


def plant_motion(robot, x0, t_end, h, tau):
    """The plant in full coordinates from x0 = (q, v), RK4 at h with its projections."""
    plant = ReadableClosedChainPlant(robot, coordinates="full")
    x = np.array(x0, dtype=float)
    for k in range(round(t_end / h)):
        x = rk4_step(lambda t, y: plant.derivative(t, y, tau), k * h, x, h)
        x = plant.finish_step(x, (k + 1) * h)
    return x[: robot.model.nq], x[robot.model.nq :], plant


def mujoco_motion(path, x0, robot, t_end, timestep, time_constant, ctrl=None, prepare=None):
    """MuJoCo's own simulation from x0 (Pinocchio's q, v): RK4 at ``timestep``, contacts and
    limits off, stiff equalities; ``ctrl`` None turns the actuators off, else it is applied
    (``prepare(m)`` may change the model first). Returns Pinocchio's q at t_end."""
    m = mujoco.MjModel.from_xml_path(str(path))
    if prepare is not None:
        prepare(m)
    _, _, q_maps = mjcf_to_pinocchio(m)
    m.opt.timestep = timestep
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    off = mujoco.mjtDisableBit
    m.opt.disableflags |= int(off.mjDSBL_CONTACT) | int(off.mjDSBL_LIMIT)
    if ctrl is None:
        m.opt.disableflags |= int(off.mjDSBL_ACTUATION)
    m.eq_solref[:] = [time_constant, 1.0]
    m.eq_solimp[:, :3] = (0.9999, 0.9999, 0.001)
    d = mujoco.MjData(m)
    q, v = x0[: robot.model.nq], x0[robot.model.nq :]
    for kind, a, i in q_maps:  # Pinocchio's q as MuJoCo's qpos (quaternions w first)
        if kind in ("hinge", "slide"):
            d.qpos[a] = q[i]
        elif kind == "ball":
            d.qpos[a : a + 4] = np.r_[q[i + 3], q[i : i + 3]]
        else:
            d.qpos[a : a + 3] = q[i : i + 3]
            d.qpos[a + 3 : a + 7] = np.r_[q[i + 6], q[i + 3 : i + 6]]
    np.testing.assert_allclose(_to_pinocchio_q(robot.model, q_maps, d.qpos), q, rtol=0, atol=1e-15)
    # MuJoCo's free-joint linear velocity is in the world, Pinocchio's in the body frame
    velocity = np.array(v, dtype=float)
    model = robot.model
    for j in range(1, model.njoints):
        if model.joints[j].shortname() == "JointModelFreeFlyer":
            iq, iv = model.idx_qs[j], model.idx_vs[j]
            velocity[iv : iv + 3] = pin.Quaternion(q[iq + 3 : iq + 7]).matrix() @ v[iv : iv + 3]
    d.qvel[:] = velocity  # the dofs in the same order as Pinocchio's v (the trees are the same)
    if ctrl is not None:
        d.ctrl[:] = ctrl
    mujoco.mj_forward(m, d)
    assert set(d.efc_type) == {int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)}  # nothing but the closures
    mujoco.mj_step(m, d, nstep=round(t_end / timestep))
    return _to_pinocchio_q(robot.model, q_maps, d.qpos)


def start_state(robot, offset, seed):
    """An assembled state away from home with random closure-consistent velocities [rad/s]."""
    rng = np.random.default_rng(seed)
    q = robot.configuration(robot.home + offset)
    q, v = robot.project_state(q, rng.normal(0.0, 1.0, robot.model.nv))
    assert robot.closure_gap(q) < 1e-12 and np.abs(robot.closure_jacobian(q) @ v).max() < 1e-12
    return np.r_[q, v]


# ------------------------------------------------------------------------------------------ Cassie
def test_cassie_loads_as_shipped_classified(cassie):
    """A free-floating biped: 6 + 2 x 3 (achilles balls) + 20 hinge velocities, four connects, ten
    motors. Mobility 22 = 10 actuated + 10 passive (the free base's and the four sprung shin and
    heel joints) + 2 idle (each achilles rod's spin between its ball and its connect)."""
    robot = cassie
    assert (robot.model.nq, robot.model.nv) == (35, 32)
    assert [c.kind for c in robot.closures] == ["3d"] * 4 and not robot.joint_couplings
    found = robot.classification()
    assert (found["mobility"], found["closure_equations"], found["independent_closure_equations"]) == (
        22,
        12,
        10,
    )
    sides = ("left", "right")
    assert robot.actuated_joints == tuple(
        f"{s}-{j}" for s in sides for j in ("hip-roll", "hip-yaw", "hip-pitch", "knee", "foot")
    )
    assert robot.passive_joints == (
        "joint_0",
        "left-shin",
        "left-heel-spring",
        "right-shin",
        "right-heel-spring",
    )
    assert len(robot.passive_joint_indices) == 10 and robot.idle_dof == 2
    assert found["idle"] == [["left-achilles-rod"], ["right-achilles-rod"]]
    assert "mobility: 22 = 10 actuated + 10 passive + 2 idle" in robot.summary()
    # springs, dampers (the balls' too) and rotor inertias read, none dropped
    assert robot.joint_springs["left-shin"] == (1500.0, 0.0, 0.1)
    assert robot.joint_springs["right-heel-spring"] == (1250.0, 0.0, 0.0)
    assert robot.joint_springs["left-achilles-rod"] == (0.0, 0.0, 0.01)
    assert len(robot.joint_springs) == 20  # every joint but the free base and the plantar rods
    m = mujoco.MjModel.from_xml_path(str(CASSIE))
    for rows, _, dof, dofs, *_ in _mujoco_joints(m, robot.model):
        np.testing.assert_array_equal(robot.model.armature[rows], m.dof_armature[dof : dof + dofs])
    assert robot.model.armature.max() == 0.09344
    assert robot.closure_gap(robot.reference_configuration) < 1e-12  # assembled near the home keyframe
    with pytest.raises(InvalidParameterError, match=r"its base is free \(joint_0\)"):
        dp.ClosedChainNominalModel(robot)


def test_cassie_moves_as_pinocchio_alone_and_mujoco_move_it(cassie):
    """0.1 s from an assembled state off home (motors +-0.1 rad) with random closure-consistent
    velocities (1 rad/s), no torque: the centre of mass falls at g and the joints move by 0.13 rad
    under gravity, the springs and the dampers. The plant (RK4 at 0.1 ms) is within 1e-8 of Pinocchio
    alone (measured 1.4e-10 in q, 7.5e-8 rad/s in v: the RK4 error); MuJoCo within 3e-7 at time
    constant 2e-4 s and 1e-7 at 1e-4 s (measured 5.0e-8 and 1.2e-8: its softness, shrinking with
    the time constant). q is compared on the group (pin.difference: the base and the balls too)."""
    robot = cassie
    rng = np.random.default_rng(1)
    x0 = start_state(robot, rng.uniform(-0.1, 0.1, robot.dof), seed=1)
    m = mujoco.MjModel.from_xml_path(str(CASSIE))
    q_ref, v_ref = pinocchio_reference(robot, m, x0, 0.1)
    q, v, plant = plant_motion(robot, x0, 0.1, 1e-4, np.zeros(robot.dof))
    model = robot.model
    assert np.abs(pin.difference(model, x0[: model.nq], q_ref)[6:]).max() > 0.1  # the joints moved
    # nothing but gravity acts from outside: the centre of mass falls at g (closed form; measured
    # 5.6e-16 m for the reference, 3.1e-13 m for the plant)
    data = model.createData()
    com0 = pin.centerOfMass(model, data, x0[: model.nq], x0[model.nq :]).copy()
    falling = com0 + 0.1 * data.vcom[0] + 0.5 * 0.1**2 * model.gravity.linear
    for q_end in (q_ref, q):
        np.testing.assert_allclose(pin.centerOfMass(model, data, q_end), falling, rtol=0, atol=1e-11)
    assert robot.closure_gap(q_ref) < 1e-12 and plant.projections == 0
    assert np.abs(pin.difference(model, q_ref, q)).max() < 1e-8
    assert np.abs(v - v_ref).max() < 1e-6
    distances = []
    for timestep, time_constant, bound in ((1e-4, 2e-4, 3e-7), (5e-5, 1e-4, 1e-7)):
        q_mujoco = mujoco_motion(CASSIE, x0, robot, 0.1, timestep, time_constant)
        distances.append(np.abs(pin.difference(model, q_ref, q_mujoco)).max())
        assert distances[-1] < bound, (time_constant, distances[-1])
    assert distances[1] < 0.5 * distances[0]


def test_cassie_passes_validate(cassie):
    """The closure and energy checks (a free base is underactuated: no reduced model to check)."""
    report = validate_closed_chain(cassie, samples=5, energy_duration=0.1)
    assert report.passed, report.table()
    assert set(report.checks) == {"closure", "energy", "loop gap"}
    assert report.checks["energy"][0] < 1e-10  # measured 1.8e-14


# ----------------------------------------------------------------------------------------- Robotiq
def test_robotiq_loads_as_shipped_classified_and_says_how_its_actuator_was_read(robotiq):
    """Two planar four-bars (connects: 6 equations, 4 independent) and the drivers' <equality
    joint> (a joint coupling, one equation): mobility 8 - 5 = 3 = 1 actuated (the tendon's drivers,
    as left_driver_joint: the right one follows it) + 2 passive (the sprung spring links) + 0 idle.
    The file's actuator is a position servo on the tendon: read as a force source, and said."""
    robot = robotiq
    assert (robot.model.nq, robot.model.nv) == (8, 8)
    found = robot.classification()
    assert (found["mobility"], found["closure_equations"], found["independent_closure_equations"]) == (
        3,
        7,
        5,
    )
    assert robot.actuated_joints == ("left_driver_joint",)
    assert robot.passive_joints == ("right_spring_link_joint", "left_spring_link_joint")
    assert robot.idle_dof == 0 and found["idle"] == []
    (coupling,) = robot.joint_couplings
    assert (coupling.joint1, coupling.joint2, coupling.coefficients) == (
        "right_driver_joint", "left_driver_joint", (0.0, 1.0),
    )  # fmt: skip
    assert coupling.source == "2f85.xml line 175"
    summary = robot.summary()
    assert "closures: 2 point, 1 joint coupling (7 equations, 5 independent)" in summary
    assert "mobility: 3 = 1 actuated + 2 passive + 0 idle" in summary
    assert "coupled: right_driver_joint follows left_driver_joint" in summary
    assert "pulls tendon 'split' (right_driver_joint + left_driver_joint): read as a torque on " in summary
    assert "left_driver_joint = 1 x its force" in summary
    assert "force = 0.313725 ctrl - 100 length - 10 length rate, within [-5, 5]): read as a force" in summary
    assert robot.joint_springs["left_spring_link_joint"] == (0.05, 2.62, 0.00125)
    assert robot.joint_springs["right_driver_joint"] == (0.0, 0.0, 0.1)
    assert robot.closure_gap(robot.reference_configuration) < 1e-15  # qpos0 is assembled
    # the tree's inertia (armature included) is MuJoCo's to rounding
    m = mujoco.MjModel.from_xml_path(str(ROBOTIQ))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    if hasattr(d, "qM"):  # MuJoCo 3
        mujoco.mj_fullM(m, M, d.qM)
    else:  # MuJoCo 4
        mujoco.mj_fullM(m, d, M)
    np.testing.assert_allclose(robot.mass_matrix(robot.reference_configuration), M, rtol=0, atol=1e-15)
    with pytest.raises(InvalidParameterError, match="it is underactuated"):
        dp.ClosedChainNominalModel(robot)


@pytest.mark.parametrize("force", [0.0, 1.0])
def test_robotiq_moves_as_pinocchio_alone_and_mujoco_move_it(robotiq, force):
    """0.1 s from an assembled state (drivers at 0.3 rad, random consistent velocities) under
    gravity, the springs and dampers, and a constant force [N] on the tendon: the plant's torque
    on left_driver_joint (1 x the force), the reference's half the force on each driver (the
    tendon's coefficients), MuJoCo's actuator made a plain force source (no servo bias, gain 1; turned
    off without the force).
    The drivers stay together (the coupling, 1e-12 rad). Plant against Pinocchio alone within 1e-11
    rad (measured 2.5e-13); against MuJoCo within 2e-9 at time constant 2e-4 s and 6e-10 at 1e-4 s
    (measured 6.7e-10 and 1.7e-10 with the force, 2.9e-10 and 7.0e-11 without)."""
    robot = robotiq
    x0 = start_state(robot, 0.3, seed=2)
    m = mujoco.MjModel.from_xml_path(str(ROBOTIQ))
    joints = _mujoco_joints(m, robot.model)
    tendon = np.zeros(robot.model.nv)
    for w in range(m.tendon_adr[0], m.tendon_adr[0] + m.tendon_num[0]):
        tendon[joints[int(m.wrap_objid[w])][0]] = m.wrap_prm[w]
    np.testing.assert_array_equal(tendon[np.flatnonzero(tendon)], [0.5, 0.5])
    q_ref, v_ref = pinocchio_reference(robot, m, x0, 0.1, joint_force=force * tendon)
    q, v, plant = plant_motion(robot, x0, 0.1, 1e-4, np.array([force]))
    right, left = (robot.model.idx_qs[robot.model.getJointId(f"{s}_driver_joint")] for s in ("right", "left"))
    assert np.abs(q_ref - x0[:8]).max() > 0.2  # it moved (measured 0.22 rad, 0.38 with the force)
    assert abs(q[right] - q[left]) < 1e-12 and abs(q_ref[right] - q_ref[left]) < 1e-12
    assert robot.closure_gap(q) < 1e-12 and plant.projections == 0
    assert np.abs(q - q_ref).max() < 1e-11
    assert np.abs(v - v_ref).max() < 1e-10  # measured 1.6e-12 rad/s
    distances = []
    for timestep, time_constant, bound in ((1e-4, 2e-4, 2e-9), (5e-5, 1e-4, 6e-10)):
        q_mujoco = mujoco_motion(
            ROBOTIQ, x0, robot, 0.1, timestep, time_constant,
            ctrl=np.array([force]) if force else None, prepare=_plain_force,
        )  # fmt: skip
        distances.append(np.abs(q_mujoco - q_ref).max())
        assert distances[-1] < bound, (time_constant, distances[-1])
    assert distances[1] < 0.5 * distances[0]


def _plain_force(m) -> None:
    """The Robotiq's servo made a plain force source on its tendon (gain 1, no bias, no force or
    control range): ctrl is then the tendon's force [N]."""
    m.actuator_gainprm[:, 0] = 1.0
    m.actuator_biasprm[:] = 0.0
    m.actuator_forcelimited[:] = 0
    m.actuator_ctrllimited[:] = 0


def test_robotiq_passes_validate(robotiq):
    report = validate_closed_chain(robotiq, samples=10, energy_duration=0.3)
    assert report.passed, report.table()
    assert set(report.checks) == {"closure", "energy", "loop gap"}
    assert report.checks["energy"][0] < 1e-10  # measured 8.1e-16
    assert "not run: the robot is underactuated (passive joints right_spring_link_joint" in report.table()


# ------------------------------------------------------------------------------------- bad input
def _robotiq_variant(tmp_path: Path, old: str, new: str) -> Path:
    """The shipped 2f85.xml with one edit, beside a link to its meshes."""
    text = ROBOTIQ.read_text(encoding="utf-8")
    assert old in text
    os.symlink(ROBOTIQ.parent / "assets", tmp_path / "assets")
    path = tmp_path / "2f85.xml"
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


def test_a_tendon_over_joints_nothing_couples_is_refused_in_one_line(tmp_path):
    """Without the drivers' <equality joint>, the tendon pulls two joints that move independently:
    one actuator for two degrees of freedom, refused naming the actuator, its line and the tendon."""
    coupling = (
        '<joint joint1="right_driver_joint" joint2="left_driver_joint" polycoef="0 1 0 0 0" '
        'solimp="0.95 0.99 0.001"\n      solref="0.005 1"/>'
    )
    path = _robotiq_variant(tmp_path, coupling, "<!-- no coupling -->\n")  # two lines: the rest stays put
    with pytest.raises(URDFConventionError) as error:
        dp.load_robot(path)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith(
        "actuator 'fingers_actuator' (2f85.xml line 188) pulls tendon 'split' over joints "
    )
    assert (
        "right_driver_joint, left_driver_joint, which no linear <equality joint> ties to one of them"
        in message
    )


def test_a_disabled_joint_coupling_is_refused(tmp_path):
    path = _robotiq_variant(tmp_path, 'polycoef="0 1 0 0 0"', 'polycoef="0 1 0 0 0" active="false"')
    disabled = r"equality #2 \(unnamed\) \(2f85.xml line 175\) is disabled"
    with pytest.raises(URDFConventionError, match=disabled), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dp.load_robot(path)


def test_a_polynomial_joint_coupling_moves_as_mujoco_moves_it(tmp_path):
    """polycoef "0.02 1 0.4 0 0" (right = 0.02 + left + 0.4 left^2 about qpos0) and the actuator
    put on left_driver_joint itself (a tendon needs a linear coupling): the coupling row's
    velocity row and drift agree with central differences of the residual and of J v (1e-8;
    measured 4.2e-11 and 4.8e-11), and 0.1 s of free motion keeps it (1e-12) and moves as MuJoCo
    moves it: 1e-8 at time constant 2e-4 s, 3e-9 at 1e-4 s (measured 2.6e-9 and 6.5e-10)."""
    path = _robotiq_variant(tmp_path, 'polycoef="0 1 0 0 0"', 'polycoef="0.02 1 0.4 0 0"')
    path.write_text(path.read_text().replace('tendon="split"', 'joint="left_driver_joint"'))
    with pytest.warns(UserWarning, match=SERVO):
        robot = dp.load_robot(path)
    assert robot.joint_couplings[0].coefficients == (0.02, 1.0, 0.4)
    x0 = start_state(robot, 0.3, seed=3)
    q, v = x0[:8], x0[8:]
    right, left = (robot.model.idx_qs[robot.model.getJointId(f"{s}_driver_joint")] for s in ("right", "left"))
    assert abs(q[right] - (0.02 + q[left] + 0.4 * q[left] ** 2)) < 1e-15
    h = 1e-6
    differences = np.array(
        [(robot.closure_residual(q + h * e) - robot.closure_residual(q - h * e)) / (2 * h) for e in np.eye(8)]
    ).T
    np.testing.assert_allclose(robot.closure_jacobian(q), differences, rtol=0, atol=1e-8)
    rate = (robot.closure_jacobian(q + h * v) @ v - robot.closure_jacobian(q - h * v) @ v) / (2 * h)
    np.testing.assert_allclose(robot.closure_drift(q, v), rate, rtol=0, atol=1e-8)
    np.testing.assert_allclose(
        robot.closure_jacobian_derivative(q, v) @ v, robot.closure_drift(q, v), atol=1e-14
    )
    q_end, _, plant = plant_motion(robot, x0, 0.1, 1e-4, np.zeros(1))
    assert plant.projections == 0
    assert np.abs(q_end - q).max() > 0.2 and abs(robot.closure_residual(q_end)[-1]) < 1e-12
    distances = []
    for timestep, time_constant, bound in ((1e-4, 2e-4, 1e-8), (5e-5, 1e-4, 3e-9)):
        distances.append(np.abs(mujoco_motion(path, x0, robot, 0.1, timestep, time_constant) - q_end).max())
        assert distances[-1] < bound, (time_constant, distances[-1])
    assert distances[1] < 0.5 * distances[0]

"""``delta-pin validate --robot`` does not cry wolf (issue 35, item 5).

1. The energy check's kinetic energy carries every joint's armature: 0.5 v^T M v with M from
   CRBA (Pinocchio 4.1's ``computeKineticEnergy`` drops the armature of an unaligned revolute
   joint), checked against MuJoCo's own ``energy[1]``.
2. Gravity on an idle motion (a rod spinning between two ball joints with its centre of mass off
   the spin axis) is physics: the gravity and Coriolis checks take the idle part of their
   differences out and say so, and still catch a wrong G or C.
3. ``--frame NAME`` picks the end effector and checks its closed-loop J_x and J_x_dot alpha_dot.

The robot of every test is a small MJCF written here: a crank on a hinge (motor), a rod hanging
from the crank's tip by a ball joint, and a slider on a slide joint whose pin holds the rod's tip
(a connect): 5 joint velocities, 3 closure equations, mobility 2 = the crank + the rod's spin
about its own axis (idle). Each validate takes well under a second.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pinocchio as pin
import pytest

import delta_pin as dp
import delta_pin.sim.closed_chain_validation as validation
from delta_pin.cli import main
from delta_pin.errors import InvalidParameterError
from delta_pin.sim.closed_chain_validation import kinetic_energy, richardson_derivative, validate_closed_chain

mujoco = pytest.importorskip("mujoco")

ROD = math.sqrt(0.1)  # [m] the rod: from the crank's tip (0, 0, 0.1) to the slider's pin (0.3, 0, 0)
ROD_MASS, GRAVITY, OFFSET = 0.1, 9.81, 0.02  # [kg], [m/s^2], [m] the off-axis rod's centre of mass
TILTED = "0 0.6 0.8"  # the crank's hinge axis in the armature case: a JointModelRevoluteUnaligned
ARMATURE = 0.01  # [kg m^2] the crank's rotor inertia


def rod_slider(offset: float = 0.0, axis: str = "0 1 0", armature: float = 0.0) -> str:
    """The crank-rod-slider MJCF (module docstring); the rod's centre of mass ``offset`` [m] off its
    axis along the rod body's y (horizontal at home: gravity then turns the spin), an off-axis site
    ``rod_mark`` that the spin moves, and the energy flag on (MuJoCo's ``data.energy``)."""
    return f"""<mujoco model="rod_slider">
  <option gravity="0 0 -{GRAVITY!r}"><flag energy="enable"/></option>
  <worldbody>
    <body name="crank">
      <joint name="crank" type="hinge" axis="{axis}" armature="{armature!r}"/>
      <inertial pos="0 0 0.05" mass="0.2" diaginertia="2e-4 2e-4 1e-5"/>
      <body name="rod" pos="0 0 0.1" zaxis="0.3 0 -0.1">
        <joint name="rod_ball" type="ball" armature="{armature / 3!r}"/>
        <inertial pos="0 {offset!r} {ROD / 2!r}" mass="{ROD_MASS!r}" diaginertia="1e-3 1e-3 1e-5"/>
        <site name="rod_mark" pos="0.01 0 0.1"/>
        <site name="rod_tip" pos="0 0 {ROD!r}"/>
      </body>
    </body>
    <body name="slider" pos="0.3 0 0">
      <joint name="slide" type="slide" axis="1 0 0" armature="{2 * armature!r}"/>
      <inertial pos="0 0 0" mass="0.3" diaginertia="1e-4 1e-4 1e-4"/>
      <site name="slider_pin"/>
    </body>
  </worldbody>
  <equality><connect site1="slider_pin" site2="rod_tip"/></equality>
  <actuator><motor joint="crank"/></actuator>
</mujoco>"""


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("wolf")
    paths = {
        "armature": rod_slider(axis=TILTED, armature=ARMATURE),
        "offset": rod_slider(offset=OFFSET),
        "symmetric": rod_slider(),
    }
    for name, text in paths.items():
        (folder / f"{name}.xml").write_text(text)
    return {name: str(folder / f"{name}.xml") for name in paths}


# ---------------------------------------------------------------------------- 1. armature
def _pinocchio_state(robot, m, qpos: np.ndarray, qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's (qpos, qvel) as Pinocchio's (q, v), joint by joint: a ball's quaternion (w, x, y, z)
    -> (x, y, z, w); velocities (a ball's local angular velocity included) in the same order."""
    q, v = pin.neutral(robot.model), np.zeros(robot.model.nv)
    for j in range(m.njnt):
        jid = robot.model.getJointId(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j))
        iq, iv, nv = robot.model.idx_qs[jid], robot.model.idx_vs[jid], robot.model.nvs[jid]
        a, d = m.jnt_qposadr[j], m.jnt_dofadr[j]
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
            q[iq : iq + 4] = np.roll(qpos[a : a + 4], -1)
        else:
            q[iq] = qpos[a]
        v[iv : iv + nv] = qvel[d : d + nv]
    return q, v


def test_kinetic_energy_matches_mujoco_with_armature_on_a_tilted_hinge(files):
    """20 random states (qpos, qvel) of the armature robot (crank on the hinge axis 0 0.6 0.8 with
    armature 0.01 kg m^2, the ball 0.0033 per axis, the slide 0.02 kg): kinetic_energy equals
    MuJoCo's energy[1] (0.5 qvel^T M qvel, armature in M) to 1e-12 relative (measured 3.4e-16:
    two algorithms on the same inertias, a few eps apart; 1e-12 is still 3e5 times under the
    smallest crank rotor term of these states, 3e-7 to 0.2 of the total). Pinocchio's
    computeKineticEnergy falls short by exactly the unaligned hinge's 0.5 armature v_crank^2 (the
    ball's and slide's armature it keeps), the term that made a correct robot's energy drift. The
    potential energies agree too (1e-12 J; the same state, so the mapping of q is right)."""
    robot = dp.load_robot(files["armature"])
    crank = robot.model.getJointId("crank")
    assert robot.model.joints[crank].shortname() == "JointModelRevoluteUnaligned"
    assert robot.model.armature[robot.model.idx_vs[crank]] == ARMATURE
    m = mujoco.MjModel.from_xml_path(files["armature"])
    data = mujoco.MjData(m)
    rng = np.random.default_rng(7)
    for _ in range(20):
        qpos = rng.normal(size=m.nq)
        ball = m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "rod_ball")]
        qpos[ball : ball + 4] /= np.linalg.norm(qpos[ball : ball + 4])
        data.qpos[:], data.qvel[:] = qpos, rng.normal(size=m.nv)
        mujoco.mj_forward(m, data)
        q, v = _pinocchio_state(robot, m, data.qpos, data.qvel)
        ours = kinetic_energy(robot.model, robot.data, q, v)
        theirs = float(data.energy[1])
        assert abs(ours - theirs) <= 1e-12 * theirs, (ours, theirs)
        rotor = 0.5 * ARMATURE * v[robot.model.idx_vs[crank]] ** 2
        pinocchio = pin.computeKineticEnergy(robot.model, robot.data, q, v)
        assert abs(theirs - pinocchio - rotor) <= 1e-12 * theirs
        potential = pin.computePotentialEnergy(robot.model, robot.data, q)
        assert abs(potential - float(data.energy[0])) <= 1e-12


def test_a_robot_with_armature_on_an_unaligned_hinge_passes_the_energy_check(files, monkeypatch):
    """The whole closed-chain robot: its free motion (0.2 s, DOP853) keeps kinetic + potential
    energy to 1e-9 of the largest kinetic energy (measured 1.5e-14: the integrator's error); with
    the old kinetic energy (computeKineticEnergy, the negative control) the same motion "drifts" by
    more than 1e-2 (measured 0.23: the crank's rotor energy, missing from E, comes and goes as
    the crank speeds up and slows down) and the check fails: a wolf cried on a correct robot."""
    robot = dp.load_robot(files["armature"])
    report = validate_closed_chain(robot, samples=2, energy_duration=0.2)
    assert report.passed, report.table()
    assert report.checks["energy"][0] < 1e-9
    monkeypatch.setattr(
        validation, "kinetic_energy", lambda model, data, q, v: pin.computeKineticEnergy(model, data, q, v)
    )
    old = validate_closed_chain(robot, samples=2, energy_duration=0.2)
    assert old.checks["energy"][0] > 1e-2 and not old.check_passed("energy"), old.table()


# ---------------------------------------------------------------------------- 2. idle motions
def _torque_in_note(report) -> float | None:
    for line in report.notes:
        found = re.match(r"gravity acts on idle motion\(s\) rod_ball: torque up to (\S+) N m", line)
        if found:
            return float(found.group(1))
    return None


def test_gravity_on_an_idle_spin_is_reported_and_the_checks_pass(files):
    """The rod's centre of mass 2 cm off its spin axis: gravity turns the idle spin, with the torque
    m g d sin(axis, vertical) = 0.1 x 9.81 x 0.02 x 0.949 = 0.0186 N m at home (the offset is
    horizontal there); over the states (crank +-0.1 rad) the note's largest torque stays within 3%
    of it (measured 0.0186). The gravity and Coriolis checks pass at 1e-7 (measured 1.8e-10 and
    2.4e-10, estimates 2e-8 and 6e-10), the tolerance of the shipped robots' test.

    Negative control, the old reference (dV/dalpha and dM/ds along the assembly path, which turns
    the spin 1.4 rad per rad of crank while the reduced model's least-kinetic-energy S does not):
    at alpha = home + 0.1 G = -0.0349 N m against dV/dalpha = -0.0147 (58% of |G|; the old check
    measured 1.86 over its states) and C + C^T against dM/ds 7.8e-3 relative, where the checks'
    tolerance is 1e-6."""
    robot = dp.load_robot(files["offset"])
    assert robot.idle_dof == 1
    report = validate_closed_chain(robot, samples=4, energy_duration=0.1)
    assert report.passed, report.table()
    for check in ("gravity", "coriolis"):
        assert report.checks[check][0] < 1e-7 and report.estimates[check][0] < 1e-7
    expected = ROD_MASS * GRAVITY * OFFSET * 0.3 / ROD
    assert _torque_in_note(report) == pytest.approx(expected, rel=0.03), report.table()
    assert "physics, not an error" in report.table()

    alpha = robot.home + 0.1
    q = robot.configuration(alpha, initial_guess=robot.reference_configuration, tol=1e-14)
    _, C, G, _ = robot.reduced_terms(alpha, np.ones(1), q)

    def assembled(s: float) -> np.ndarray:
        return robot.configuration(alpha + s, initial_guess=q, tol=1e-14)

    raw_G = richardson_derivative(lambda s: pin.computePotentialEnergy(robot.model, robot.data, assembled(s)))
    assert abs(G[0] - raw_G.value) > 0.3 * abs(G[0])

    def reduced_inertia(s: float) -> np.ndarray:
        S = robot.velocity_map(assembled(s))
        return S.T @ robot.mass_matrix(assembled(s)) @ S

    raw_M_dot = richardson_derivative(reduced_inertia, center=reduced_inertia(0.0))
    assert abs((C + C.T)[0, 0] - raw_M_dot.value[0, 0]) > 1e-3 * abs(raw_M_dot.value[0, 0])


def test_a_symmetric_rod_says_nothing_about_idle_gravity(files):
    """The rod's centre of mass on its axis: no gravity on the spin, and the assembly path leaves
    the spin alone (measured 5e-22 rad per rad), so neither idle note appears."""
    report = validate_closed_chain(dp.load_robot(files["symmetric"]), samples=3, energy_duration=0.1)
    assert report.passed, report.table()
    assert _torque_in_note(report) is None and "idle motion(s)" not in "\n".join(report.notes)


@pytest.mark.parametrize(("term", "check"), [(2, "gravity"), (1, "coriolis")])
def test_a_wrong_G_or_C_still_fails_on_the_idle_robot(files, monkeypatch, term, check):
    """Taking the idle part out hides no error: G or C 1e-4 off (100x the tolerance) fails."""
    robot = dp.load_robot(files["offset"])
    right = robot.reduced_terms

    def wrong(*args, **kwargs):
        terms = list(right(*args, **kwargs))
        terms[term] = terms[term] * (1.0 + 1e-4)
        return tuple(terms)

    monkeypatch.setattr(robot, "reduced_terms", wrong)
    report = validate_closed_chain(robot, samples=2, energy_duration=0.05)
    assert not report.check_passed(check), report.table()


# ---------------------------------------------------------------------------- 3. --frame
def test_cli_frame_checks_that_frames_kinematics(files, capsys):
    """``--frame rod_tip`` (on the spin axis: the spin leaves it in place) adds 'frame J' and
    'frame Jdot' to the table, both ok (measured 1.5e-10 and 4e-10 against 1e-6) and the summary's
    end effector is that frame."""
    argv = ["validate", "--robot", files["offset"], "--frame", "rod_tip", "--samples", "2"]
    assert main([*argv, "--duration", "0.05"]) == 0
    out = capsys.readouterr().out
    for check in ("frame J ", "frame Jdot"):
        line = next(line for line in out.splitlines() if line.startswith(check))
        assert " ok " in line and "'rod_tip'" in line
    assert "end effector: rod_tip" in out


def test_a_wrong_frame_jacobian_fails(files, monkeypatch):
    """J_x or J_x_dot alpha_dot 1e-4 off fails its frame check (100x the tolerance)."""
    robot = dp.load_robot(files["offset"], end_effector="rod_tip")
    right_J, right_drift = robot.frame_jacobian, robot.frame_acceleration_drift
    monkeypatch.setattr(robot, "frame_jacobian", lambda *a, **k: right_J(*a, **k) * (1.0 + 1e-4))
    report = validate_closed_chain(robot, samples=2, energy_duration=0.05, frame="rod_tip")
    assert not report.check_passed("frame J"), report.table()
    monkeypatch.setattr(robot, "frame_jacobian", right_J)
    monkeypatch.setattr(robot, "frame_acceleration_drift", lambda *a, **k: right_drift(*a, **k) * 1.0001)
    report = validate_closed_chain(robot, samples=2, energy_duration=0.05, frame="rod_tip")
    assert report.check_passed("frame J") and not report.check_passed("frame Jdot"), report.table()


@pytest.mark.parametrize(
    ("argv", "text"),
    [
        (["--robot", "{offset}", "--frame", "nope"], "has no frame 'nope' (frames: crank, "),
        (["--frame", "tip"], "--frame tip picks a frame of validate --robot"),
        (
            ["--robot", "{offset}", "--frame", "rod_mark"],
            "'rod_mark'",
        ),
    ],
)
def test_cli_bad_frame_is_one_line(files, capsys, argv, text):
    """An unknown frame, --frame without --robot, a frame the idle spin moves (the loader's own
    refusal, whose wording is the loader's): exit 2, one line naming the frame."""
    argv = [arg.format(**files) for arg in argv]
    assert main(["validate", "--samples", "1", *argv]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1 and text in err, err
    assert err.startswith("delta-pin validate: error: ")


def test_a_frame_the_idle_spin_moves_is_refused_by_the_function(files):
    robot = dp.load_robot(files["offset"])
    with pytest.raises(InvalidParameterError, match="frame 'rod_mark' moves with the idle motions"):
        validate_closed_chain(robot, samples=1, frame="rod_mark")

"""Assembly that finds the robot (docs/architecture.md, "Assembly"): published files whose pose
leaves the loops open, CAD exports whose loops agree only to rounding, ``home=`` and
``--home``, and mechanisms without motors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.cli import main
from delta_pin.errors import AssemblyError, InvalidParameterError
from tests.reference.python_loop import simulate_reference

DATA = Path(__file__).resolve().parents[1] / "data"
ROBOTS = Path(dp.__file__).resolve().parent / "robots"
EXACT = 1e-12  # [m or rad] Newton's tolerance: what "closed exactly" means at load


@pytest.mark.parametrize("name", ["cassie_like", "digit_like", "wl16_like"])
def test_a_gepetto_leg_saved_open_loads_as_shipped(name):
    """Gepetto's exported legs store every joint at zero, loops metres or radians apart (gap at the
    file's pose > 1); the assembly closes them from there (Newton with the motors at zero does
    not: it was refused before), deterministically (the same home twice), and says so."""
    path = DATA / "gepetto" / name / "robot.urdf"
    robot = dp.load_robot(path)
    assert robot.assembly_gap_at_start > 1.0
    assert robot.closure_gap(robot.reference_configuration) <= EXACT
    assert "the file's pose leaves the loops" in robot.summary()
    again = dp.load_robot(path)
    np.testing.assert_array_equal(again.reference_configuration, robot.reference_configuration)


def test_home_puts_the_actuated_joints_there_and_refuses_an_unreachable_one(tmp_path):
    robot = dp.load_robot("five_bar", home=[0.1, -0.05])
    np.testing.assert_array_equal(robot.home, [0.1, -0.05])
    assert robot.closure_gap(robot.reference_configuration) <= EXACT
    # a whole configuration: its actuated coordinates are home
    whole = dp.load_robot("five_bar", home=robot.reference_configuration)
    np.testing.assert_allclose(whole.reference_configuration, robot.reference_configuration, atol=1e-12)
    with pytest.raises(InvalidParameterError, match=r"home=\[1.0\] must be 2 finite actuated coordinates"):
        dp.load_robot("five_bar", home=[1.0])
    # the proximal links (0.3 m) swung 3 rad apart leave the tips too far apart to meet
    with pytest.raises(AssemblyError, match=r"with the actuated joints at home=\[1.5, -1.5\]: closure"):
        dp.load_robot("five_bar", home=[1.5, -1.5])


def test_home_on_the_command_line(capsys):
    assert main(["validate", "--robot", "five_bar", "--home", "0.1,-0.05", "--duration", "0.05"]) == 0
    assert "home = [0.1, -0.05]" in capsys.readouterr().out
    assert main(["validate", "--robot", "five_bar", "--home", "a,b"]) == 2
    assert (
        capsys.readouterr()
        .err.strip()
        .endswith("--home 'a,b' must be comma-separated numbers, e.g. 0.1,0,-0.2")
    )


def _five_bar_hinged_by_two_points(tmp_path: Path, rounding: float) -> Path:
    """The shipped five-bar with its tips closed as a hinge, by two points 20 mm apart along the
    hinge axis (y), as CAD exports write a hinge; the second point's child anchor is off by
    ``rounding`` [m] along the rod (the export's rounding)."""
    text = (ROBOTS / "five_bar.urdf").read_text()
    second = f"""  <constraint name="distal_tips_b" type="point">
    <parent link="distal_1"/>
    <parent_origin xyz="0 0.02 -0.3"/>
    <child link="distal_2"/>
    <child_origin xyz="0 0.02 {-0.3 + rounding!r}"/>
  </constraint>
  <transmission name="active_1_transmission">"""
    path = tmp_path / "five_bar_hinge.urdf"
    path.write_text(text.replace('  <transmission name="active_1_transmission">', second, 1))
    return path


def test_a_cad_rounded_hinge_is_re_anchored_and_said(tmp_path):
    """Loops consistent to 5e-8 m (< the default closure_tolerance 1e-6 m) load, re-anchored so
    that they close exactly (1e-12) at home, and summary() names the gap; a tolerance below the
    rounding refuses them in one line that names the option."""
    path = _five_bar_hinged_by_two_points(tmp_path, 5e-8)
    robot = dp.load_robot(path)
    assert 1e-8 < robot.assembly_gap <= 1e-7  # the least-squares gap: part of the 5e-8 rounding
    assert robot.closure_gap(robot.reference_configuration) <= EXACT
    assert "re-anchored to close exactly at home" in robot.summary()
    assert robot.dof == 2 and robot.idle_dof == 0
    # the re-anchored robot moves: assembled elsewhere, the loops still close exactly
    q = robot.configuration(robot.home + 0.2)
    assert robot.closure_gap(q) <= EXACT
    with pytest.raises(AssemblyError, match=r"beyond closure_tolerance=1e-09; give a reachable home="):
        dp.load_robot(path, closure_tolerance=1e-9)


def test_a_mechanism_without_motors_simulates_and_controllers_refuse_it():
    """MuJoCo's own test model (no actuator): a passive mechanism, not an error. A free motion
    (controller=None) in the core's sampled loop (RK4 at 1 ms) against the Python reference under
    LSODA (rtol 1e-6, tests/reference): 1e-5 rad, the RK4 and LSODA error over 0.1 s of a
    swinging loop (measured 2e-9 rad); continuous mode (the core's Radau IIA needs an actuated
    joint) and a controller refuse it in one line."""
    robot = dp.load_robot(DATA / "mujoco" / "jdotv_connect_2d.xml")
    assert robot.dof == 0 and len(robot.passive_joints) == 2
    sampled = dp.simulate(robot, None, None, t_end=0.1)
    continuous = simulate_reference(robot, None, None, t_end=0.1, mode="continuous")
    assert np.ptp(sampled.q[:, 0]) > 0.05  # it swings
    np.testing.assert_allclose(sampled.q[-1], continuous.q[-1], atol=1e-5, rtol=0)
    with pytest.raises(InvalidParameterError, match=r"no actuated joint.*mode='sampled'") as error:
        dp.simulate(robot, None, None, t_end=0.1, mode="continuous")
    assert "\n" not in str(error.value)
    with pytest.raises(InvalidParameterError, match=r"underactuated") as error:
        dp.ComputedTorque(dp.ClosedChainNominalModel(robot))
    assert "\n" not in str(error.value)


def test_a_spring_on_a_joint_the_loops_determine_does_not_make_it_passive(tmp_path):
    """The MJCF Delta with a spring on an elbow (which the loops fix once the three motors are
    held): it stays a fully actuated robot (before: the elbow was made passive and the robot was
    refused with "drop an actuator"); the plant keeps the spring (joint_springs)."""
    text = (
        (ROBOTS / "delta.xml")
        .read_text()
        .replace(
            '<joint name="elbow_1_pitch" type="hinge" axis="0 1 0"/>',
            '<joint name="elbow_1_pitch" type="hinge" axis="0 1 0" stiffness="2" damping="0.1"/>',
        )
    )
    path = tmp_path / "delta_sprung_elbow.xml"
    path.write_text(text)
    robot = dp.load_robot(path, recognise=False)
    assert robot.passive_joints == () and robot.dof == 3
    assert robot.joint_springs["elbow_1_pitch"] == (2.0, 0.0, 0.1)


def test_the_projected_model_carries_the_springs_and_dampers(tmp_path):
    """The sprung elbow's spring (k = 2 N m/rad about 0.3 degrees) and damper (0.1 N m s/rad) in the
    controllers' projected model: alpha_ddot = M^-1 (tau - C alpha_dot - G) against Pinocchio's
    constraintDynamics on the tree with the spring torque the test writes from the file's numbers
    (1e-9 relative: two exact routes, one solve each; before: 1.68 relative, the springs left out),
    and validate's plant, gravity (spring energy in V) and Coriolis (dampers taken out of C) pass."""
    import pinocchio as pin

    from delta_pin.sim.closed_chain_validation import validate_closed_chain
    from tests.model.closed_chain_fixtures import pinocchio_accelerations

    text = (
        (ROBOTS / "delta.xml")
        .read_text()
        .replace(
            '<joint name="elbow_1_pitch" type="hinge" axis="0 1 0"/>',
            '<joint name="elbow_1_pitch" type="hinge" axis="0 1 0" stiffness="2" springref="0.3" '
            'damping="0.1"/>',
        )
    )
    path = tmp_path / "delta_sprung_elbow.xml"
    path.write_text(text)
    robot = dp.load_robot(path, recognise=False)
    rng = np.random.default_rng(3)
    alpha, alpha_dot, tau = robot.home + 0.1, rng.normal(0, 1, 3), rng.normal(0, 1, 3)
    q, v = robot.state(alpha, alpha_dot)
    M, _, G, coriolis = robot.reduced_terms(alpha, alpha_dot, q)
    ours = np.linalg.solve(M, tau - coriolis - G)
    elbow = robot.model.getJointId("elbow_1_pitch")
    tau_full = np.zeros(robot.model.nv)
    tau_full[robot.actuated_indices] = tau
    iq, iv = robot.model.idx_qs[elbow], robot.model.idx_vs[elbow]
    # MuJoCo's default <compiler angle="degree"> (delta.xml keeps it): springref is in degrees
    tau_full[iv] -= 2.0 * (q[iq] - np.radians(0.3)) + 0.1 * v[iv]
    reference = pinocchio_accelerations(robot, pin.ProximalSettings(1e-14, 0.0, 1))(q, v, tau_full)
    np.testing.assert_allclose(ours, reference[robot.actuated_indices], rtol=1e-9, atol=0)
    report = validate_closed_chain(robot, samples=3, energy_duration=0.05)
    assert all(report.check_passed(name) for name in ("plant", "gravity", "coriolis", "energy"))


def test_a_fall_into_an_actuation_singularity_is_said_as_one():
    """Gepetto's battobot_6d falls (no torque) into a pose where its ankle loops stop being fixed
    by the motors (~0.148 s): the run stops with the singularity and cond(J_p) > 1e6 named, and
    no advice about a start (initial_guess=) that a run does not take."""
    robot = dp.load_robot(DATA / "gepetto" / "battobot_6d" / "robot.urdf")
    with pytest.raises(dp.SimulationError) as error:
        dp.simulate(robot, None, None, t_end=0.2, mode="continuous")
    message = str(error.value)
    assert "actuation (Type II) singularity: cond(J_p) = " in message and "initial_guess" not in message
    condition = float(message.split("cond(J_p) = ")[1].split(" ")[0])
    assert condition > 1e6
    assert "\n" not in message


def test_every_option_a_message_suggests_exists():
    """Messages that tell the user to pass ``name=`` or ``--flag`` name one that exists: every
    such keyword in delta_pin's source is a parameter of a public entry point, every flag one
    the CLI defines."""
    import argparse
    import inspect
    import re

    from delta_pin.cli import build_parser

    source = "\n".join(p.read_text() for p in (ROBOTS.parent).rglob("*.py"))
    flags = set(re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]+)", source))
    defined = set()

    def walk(parser: argparse.ArgumentParser) -> None:  # every command and subcommand
        for action in parser._actions:
            defined.update(action.option_strings)
            if isinstance(action, argparse._SubParsersAction):
                for command in action.choices.values():
                    walk(command)

    walk(build_parser())
    pip_flags = {"--force-reinstall", "--no-deps", "--upgrade"}  # in messages naming pip commands
    assert {"--home", "--passive", "--actuated"} <= flags  # the scan finds the flags
    assert flags - defined - pip_flags == set()
    # keywords suggested as `name=)` or `(name=[...])` in messages
    suggestion = r"(\w+)=(?:\)|\[\.\.\.\]|\.\.\.\)|,? \(validate_closed_chain\)| \(CLI)"
    suggested = set(re.findall(suggestion, source))
    from delta_pin.sim.closed_chain_validation import validate_closed_chain

    parameters = set()
    for entry in (
        dp.load_robot,
        dp.simulate,
        dp.ClosedChainRobot,
        dp.ClosedChainRobot.configuration,
        dp.ClosedChainRobot.inverse_kinematics,
        validate_closed_chain,
    ):
        parameters |= set(inspect.signature(entry).parameters)
    from delta_pin.model.description import xacro_arguments

    parameters |= set(xacro_arguments())  # load_delta(**xacro arguments)
    assert {"actuated", "passive", "home", "spread"} <= suggested  # the scan finds the suggestions
    assert suggested - parameters == set()


TENDON_STOP = """<mujoco model="tendon_stop">
  <worldbody>
    <body name="a" pos="-0.1 0 0">
      <joint name="j1" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.01" mass="0.3"/>
      <body name="a2" pos="0 0 -0.2">
        <joint name="j2" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.1 0 -0.1" size="0.01" mass="0.2"/>
        <site name="s1" pos="0.1 0 -0.1"/>
      </body>
    </body>
    <body name="b" pos="0.1 0 0">
      <joint name="j3" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.01" mass="0.3"/>
      <body name="b2" pos="0 0 -0.2">
        <joint name="j4" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 -0.1 0 -0.1" size="0.01" mass="0.2"/>
        <site name="s2" pos="-0.1 0 -0.1"/>
      </body>
    </body>
  </worldbody>
  <tendon>
    <fixed name="stop" limited="true" range="-0.5 0.5">
      <joint joint="j1" coef="1"/>
      <joint joint="j3" coef="-1"/>
    </fixed>
  </tendon>
  <equality><connect site1="s1" site2="s2"/></equality>
  <actuator><motor joint="j1"/><motor joint="j3"/></actuator>
</mujoco>
"""


def test_a_tendon_limit_is_said_not_dropped(tmp_path):
    """A fixed tendon's range (a one-sided coupling of two joints) is not modelled: the load warns
    and summary() notes it, naming the tendon and its range."""
    path = tmp_path / "five_bar_tendon_stop.xml"
    path.write_text(TENDON_STOP)
    with pytest.warns(UserWarning, match=r"the limit of tendon 'stop' \(range -0.5 to 0.5\) is not modelled"):
        robot = dp.load_robot(path)
    assert "note: the limit of tendon 'stop'" in robot.summary()

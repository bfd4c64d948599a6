"""Inertial checks at load (issue 35, item 4): a robot file whose mass or inertia is impossible or
unreadable is refused in one line naming the file, the line, the link or body and the element;
the shipped and third-party models still load.

The hostile files are shipped models with one value changed, written to tmp_path."""

import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

import delta_pin as dp
from delta_pin.cli import main
from delta_pin.errors import URDFConventionError
from delta_pin.model.inertials import (
    INERTIA_RTOL,
    check_compiled_inertials,
    check_mjcf_inertials,
    check_urdf_inertials,
    inertial_problem,
    massless_bodies,
)
from delta_pin.model.loaders import shipped_robot
from delta_pin.sim.closed_chain_validation import validate_closed_chain

DATA = Path(__file__).resolve().parents[1] / "data"

FIVE_BAR = shipped_robot("five_bar").read_text()
MASS = '<mass value="0.20000000000000001"/>'  # link proximal_1's, the first in the file
INERTIA = (
    'ixx="0.0010466666666666667" ixy="0" ixz="0" iyy="0.0010466666666666667" iyz="0" '
    'izz="1.0000000000000001e-05"'
)

# (case, text replaced in five_bar.urdf, its replacement, what the one line must say)
URDF_CASES = [
    (
        "negative mass",
        MASS,
        '<mass value="-1"/>',
        '<mass value="-1">: a mass must be a finite number >= 0 [kg]',
    ),
    ("mass heavy", MASS, '<mass value="heavy"/>', '<mass value="heavy"> (urdfdom would drop this <inertial>'),
    ("mass nan", MASS, '<mass value="nan"/>', '<mass value="nan"> (urdfdom would drop'),
    ("mass inf", MASS, '<mass value="inf"/>', '<mass value="inf"> (urdfdom would drop'),
    ("mass empty", MASS, '<mass value=""/>', '<mass value=""> (urdfdom would drop'),
    ("mass missing", MASS, "", "<inertial> has no <mass value=...>"),
    (
        "ixy unreadable",
        INERTIA,
        INERTIA.replace('ixy="0"', 'ixy="abc"'),
        '<inertia ixy="abc">: ixy must be a finite',
    ),
    ("iyz missing", INERTIA, INERTIA.replace('iyz="0" ', ""), "urdfdom needs all six"),
    (
        "negative ixx",
        INERTIA,
        INERTIA.replace('ixx="0.0010466666666666667"', 'ixx="-1"'),
        "the inertia matrix is not positive semi-definite (principal moments -1, 1e-05, 0.00104667",
    ),
    (
        "triangle violated",
        INERTIA,
        'ixx="1e-3" ixy="0" ixz="0" iyy="1e-3" iyz="0" izz="1"',
        "break the triangle inequality (0.001 + 0.001 < 1)",
    ),
    (
        "not positive definite",  # |ixy| > ixx = iyy: a negative principal moment
        INERTIA,
        INERTIA.replace('ixy="0"', 'ixy="0.01"'),
        "not positive semi-definite (principal moments -0.00895333",
    ),
    ("mass 0 with an inertia", MASS, '<mass value="0"/>', "a body of mass 0 has no inertia"),
]


def _one_line_error(path: Path) -> str:
    with pytest.raises(URDFConventionError) as caught:
        dp.load_robot(path)
    assert type(caught.value) is URDFConventionError
    message = str(caught.value)
    assert "\n" not in message
    return message


@pytest.mark.parametrize(("case", "old", "new", "says"), URDF_CASES, ids=[c[0] for c in URDF_CASES])
def test_an_impossible_urdf_inertial_is_one_line_naming_file_line_and_link(tmp_path, case, old, new, says):
    assert FIVE_BAR.count(old) >= 1
    path = tmp_path / "robot.urdf"
    path.write_text(FIVE_BAR.replace(old, new, 1))
    message = _one_line_error(path)
    line = FIVE_BAR[: FIVE_BAR.index(old)].count("\n") + 1
    # the element at fault: the <inertial> that lacks its <mass> (<inertial>, <origin>, <mass>), or
    # the <inertia> below a mass 0
    line += {"mass missing": -2, "mass 0 with an inertia": 1}.get(case, 0)
    assert message.startswith(f"robot.urdf line {line}: link 'proximal_1' <"), message
    assert says in message, message


def test_a_xacro_line_is_said_to_be_of_the_expanded_text():
    with pytest.raises(
        URDFConventionError, match=r"^robot\.urdf\.xacro \(expanded\) line 23: link 'proximal_1'"
    ):
        check_urdf_inertials(FIVE_BAR.replace(MASS, '<mass value="-1"/>'), "robot.urdf.xacro")


def test_every_urdf_path_checks_the_inertials(tmp_path):
    """The Gepetto shape (URDF + robot.yaml) goes through the same tree builder."""
    folder = tmp_path / "gepetto"
    folder.mkdir()
    shipped = shipped_robot("delta_gepetto")
    text = shipped.read_text()
    first = text.index("<mass value=")
    end = text.index("/>", first)
    folder.joinpath("robot.urdf").write_text(text[:first] + '<mass value="nan"' + text[end:])
    folder.joinpath("robot.yaml").write_text(shipped.with_name("robot.yaml").read_text())
    message = _one_line_error(folder / "robot.urdf")
    assert message.startswith(f"robot.urdf line {text[:first].count(chr(10)) + 1}: link "), message
    assert '<mass value="nan">' in message


THREE_RRR = shipped_robot("three_rrr_mjcf").read_text()
INERTIAL = (
    'mass="0.20000000000000001" fullinertia="0.00020897777777777779 0.00038000000000000008 '
    '0.00018102222222222229 0 -0.00018447119484731235 0"'
)  # body proximal_1's <inertial>, on line 8
SITE = '<site name="centre" pos="-4.8985871965894128e-18 -0 -0.080000000000000002"/>'  # in body platform
LUMP = '<body name="lump"><inertial pos="0 0 0" mass="{mass}" diaginertia="1e-3 1e-3 1e-3"/></body>'

# (case, text replaced in three_rrr.xml, its replacement, the start of the one line, what it must say)
MJCF_CASES = [
    (
        "negative mass",
        INERTIAL,
        INERTIAL.replace('mass="0.20000000000000001"', 'mass="-1"'),
        "three_rrr.xml line 8: body 'proximal_1' <inertial",
        'mass="-1">: a mass must be a finite number >= 0 [kg]',
    ),
    (
        "infinite mass (MuJoCo compiles it)",
        INERTIAL,
        INERTIAL.replace('mass="0.20000000000000001"', 'mass="inf"'),
        "three_rrr.xml line 8: body 'proximal_1' <inertial",
        'mass="inf">',
    ),
    (
        "mass nan",
        INERTIAL,
        INERTIAL.replace('mass="0.20000000000000001"', 'mass="nan"'),
        "three_rrr.xml line 8: body 'proximal_1' <inertial",
        'mass="nan">',
    ),
    (
        "diaginertia breaks the triangle inequality",
        INERTIAL,
        'mass="0.2" diaginertia="1e-3 1e-3 1"',
        "three_rrr.xml line 8: body 'proximal_1' <inertial",
        'diaginertia="1e-3 1e-3 1">: its principal moments 0.001, 0.001, 1 [kg m^2] break the triangle',
    ),
    (
        "fullinertia not positive definite",
        INERTIAL,
        'mass="0.2" fullinertia="1e-3 1e-3 1e-3 1e-2 0 0"',
        "three_rrr.xml line 8: body 'proximal_1' <inertial",
        "not positive semi-definite (principal moments -0.009, 0.001, 0.011",
    ),
    (
        "unreadable diaginertia",
        INERTIAL,
        'mass="0.2" diaginertia="1e-3 big 1e-3"',
        "three_rrr.xml line 8: body 'proximal_1' <inertial",
        'diaginertia="1e-3 big 1e-3">: diaginertia must be 3 finite numbers [kg m^2]',
    ),
    (
        "negative mass of a jointless body (MuJoCo clamps it to 0)",
        SITE,
        SITE + LUMP.format(mass="-1"),
        "three_rrr.xml line 15: body 'lump' <inertial",
        'mass="-1">',
    ),
    (
        "massless moving body (MuJoCo's own error, one line)",
        INERTIAL,
        'mass="0" diaginertia="0 0 0"',
        "three_rrr.xml: MuJoCo cannot compile it: Error: mass and inertia of moving bodies",
        "Element name 'proximal_1', id 1, line 6",
    ),
]


@pytest.mark.parametrize(("case", "old", "new", "start", "says"), MJCF_CASES, ids=[c[0] for c in MJCF_CASES])
def test_an_impossible_mjcf_inertial_is_one_line_naming_file_line_and_body(
    tmp_path, case, old, new, start, says
):
    assert THREE_RRR.count(old) >= 1
    path = tmp_path / "three_rrr.xml"
    path.write_text(THREE_RRR.replace(old, new, 1))
    message = _one_line_error(path)
    assert message.startswith(start), message
    assert says in message, message


def test_an_included_file_is_checked_as_compiled(tmp_path):
    """The <inertial> of an <include>d file is not in the main file's XML: the compiled body is
    checked (an infinite mass, which MuJoCo accepts)."""
    (tmp_path / "lump.xml").write_text(f"<mujoco>{LUMP.format(mass='inf')}</mujoco>")
    path = tmp_path / "three_rrr.xml"
    path.write_text(THREE_RRR.replace("</worldbody>", '<include file="lump.xml"/></worldbody>'))
    message = _one_line_error(path)
    assert message.startswith("three_rrr.xml: body 'lump' as MuJoCo compiled it"), message
    assert "mass inf [kg]" in message


def test_mujocos_balanceinertia_is_honoured(tmp_path):
    """The file asks MuJoCo to fix the triangle inequality: it is not refused before."""
    path = tmp_path / "three_rrr.xml"
    text = THREE_RRR.replace(INERTIAL, 'mass="0.2" diaginertia="1e-3 1e-3 1"')
    path.write_text(text.replace("<option", '<compiler balanceinertia="true"/>\n  <option', 1))
    robot = dp.load_robot(path)
    assert robot.model.inertias[1].mass == pytest.approx(0.2)


@pytest.mark.parametrize(
    "name",
    ["five_bar", "three_rrr", "three_rrr_mjcf", "delta_mjcf", "delta_gepetto", "stewart", "delta_ballrods"],
)
def test_the_shipped_models_load(name):
    assert dp.load_robot(name).dof >= 2


URDF_FILES = sorted(DATA.glob("**/*.urdf"))
MJCF_FILES = sorted(p for p in DATA.glob("**/*.xml") if "menagerie" in p.parts or p.parent.name == "mujoco")


@pytest.mark.parametrize("path", URDF_FILES, ids=[str(p.relative_to(DATA)) for p in URDF_FILES])
def test_the_third_party_urdfs_pass(path):
    """Loading them is tested elsewhere (tests/model/test_gepetto_loader.py); their inertials,
    massless links written out as mass 0 with zero moments among them, pass the check."""
    check_urdf_inertials(path.read_text(), path.name)


@pytest.mark.parametrize("path", MJCF_FILES, ids=[str(p.relative_to(DATA)) for p in MJCF_FILES])
def test_the_third_party_mjcf_files_pass(path):
    check_mjcf_inertials(path, path.name)
    check_compiled_inertials(mujoco.MjModel.from_xml_path(str(path)), path, path.name)


def test_the_rule_at_its_edges():
    """Point mass, thin rod and flat plate are possible; the tolerance (INERTIA_RTOL = 1e-5 of the
    largest moment) covers a plate printed to 6 significant digits and no more than 1e-5."""
    assert inertial_problem(1e-9, np.zeros((3, 3))) is None  # Gepetto's robot_delta writes one
    assert inertial_problem(0.0, np.zeros((3, 3))) is None  # a massless link written out
    assert inertial_problem(0.3, np.diag([0.0, 1e-3, 1e-3])) is None  # the Delta's rods
    plate = np.diag([float(f"{v:.6g}") for v in (1 / 3, 2 / 3, 1.0)])  # I1 + I2 = I3, rounded
    assert inertial_problem(1.0, plate) is None
    assert inertial_problem(1.0, np.diag([0.5, 0.5, 1.0 + 0.5 * INERTIA_RTOL])) is None
    assert "triangle" in inertial_problem(1.0, np.diag([0.5, 0.5, 1.0 + 2 * INERTIA_RTOL]))
    assert "not symmetric" in inertial_problem(1.0, np.array([[1.0, 0.1, 0], [0, 1.0, 0], [0, 0, 1.0]]))
    assert "not finite" in inertial_problem(1.0, np.diag([np.nan, 1.0, 1.0]))
    assert "mass -1" in inertial_problem(-1.0, np.eye(3))


def test_validate_names_the_massless_bodies():
    """The Gepetto Delta's elbows and platform slides weigh nothing (links without <inertial>):
    the report's notes name them and the checks that cannot see them (2 states and a 0.02 s free
    motion: the note is written whatever the checks find)."""
    robot = dp.load_robot("delta_gepetto")
    names = ["'elbow_1'", "'elbow_2'", "'elbow_3'", "'platform_slide_x'", "'platform_slide_y'"]
    assert [label for label, _ in massless_bodies(robot.model)] == names
    assert massless_bodies(dp.load_robot("five_bar").model) == []
    report = validate_closed_chain(robot, samples=2, energy_duration=0.02)
    notes = [note for note in report.notes if note.startswith("massless bodies: ")]
    assert len(notes) == 1, report.notes
    assert notes[0].startswith("massless bodies: 'elbow_1' (0 kg), 'elbow_2' (0 kg)"), notes[0]
    assert "carry no mass (0, or < 1e-06 of the robot's): the plant, gravity, coriolis and energy" in notes[0]


def test_cli_validate_refuses_a_bad_file_in_one_line(tmp_path, capsys):
    path = tmp_path / "robot.urdf"
    path.write_text(FIVE_BAR.replace(INERTIA, 'ixx="1e-3" ixy="0" ixz="0" iyy="1e-3" iyz="0" izz="1"', 1))
    assert main(["validate", "--robot", str(path)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert err.startswith("delta-pin validate: error: robot.urdf line 24: link 'proximal_1' <inertia"), err


def test_cli_stderr_has_no_urdfdom_noise(tmp_path):
    """urdfdom prints its own errors on file descriptor 2 when it parses a mass 'heavy': the check
    runs before it, so the command's stderr is the one line (a subprocess, to see descriptor 2)."""
    path = tmp_path / "robot.urdf"
    path.write_text(FIVE_BAR.replace(MASS, '<mass value="heavy"/>', 1))
    done = subprocess.run(
        [sys.executable, "-m", "delta_pin.cli", "validate", "--robot", str(path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    assert lines[0].startswith(
        "delta-pin validate: error: robot.urdf line 23: link 'proximal_1' <mass value=\"heavy\">"
    )

"""`delta-pin plan` and its CSV (delta_pin.planning.files): the files it writes, read back after
parsing (never compared as bytes), the plan file as a reference `simulate` takes, hostile files and
options refused in one line, and the output folder's safety."""

from __future__ import annotations

import json

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.cli import main
from delta_pin.errors import InvalidParameterError
from delta_pin.planning import adept_paths, plan_time_optimal
from delta_pin.planning.files import read_plan, write_plan
from delta_pin.planning.time_optimal import torque_model


def _table(path) -> np.ndarray:
    """The CSV's numbers: the lines after its # header and its column names."""
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    return np.loadtxt(lines[1:], delimiter=",", ndmin=2)


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """One `delta-pin plan` of the standard Adept cycle (|tau| <= 20 N m, the Delta's friction)."""
    out = tmp_path_factory.mktemp("plan")
    assert main(["plan", "--torque-limit", "20", "--friction", "--map", "--out", str(out)]) == 0
    return out


def test_plan_writes_the_trajectory_its_summary_and_figures(planned, capsys):
    """plan.json's cycle time is the CSV's last time (to its 17 digits), the sum of the halves; every
    CSV torque within the limit (1 kHz rows of the verified law, to 1e-6 of it: the check is at
    10 kHz); the figures are PNGs; the manifest lists the outputs."""
    summary = json.loads((planned / "plan.json").read_text())
    table = _table(planned / "plan.csv")
    assert abs(table[-1, 0] - summary["duration_s"]) <= 1e-12
    assert abs(sum(p["duration_s"] for p in summary["plans"]) - summary["duration_s"]) <= 1e-12
    tau = table[:, 10:13]
    assert np.abs(tau).max() <= 20.0 * (1 + 1e-6)
    assert all(p["torque_ratio_10kHz"] <= 1.0 for p in summary["plans"])
    # the default grid: 100 points and those added around the law's switches, recorded
    assert summary["options"]["switch_refinements"] == 2
    assert all(
        p["grid_points"] >= 100 + p["switch_points"] and p["switch_points"] > 0 for p in summary["plans"]
    )
    for name in ("plan.png", "singularity_map.png"):
        assert (planned / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    listed = json.loads((planned / "manifest.json").read_text())
    assert listed["complete"] and {"plan.csv", "plan.json", "plan.png", "singularity_map.png"} <= set(
        listed["files"]
    )


def test_the_plan_file_is_a_reference_simulate_takes(planned):
    """read_plan gives the rows exactly at their times (1e-12 rad) and a trajectory simulate runs:
    design I in continuous time on the constrained plant with friction follows it within 5e-4 rad."""
    robot = dp.load_delta()
    reference = read_plan(planned / "plan.csv")
    table = _table(planned / "plan.csv")
    again = reference.joint_reference(robot, table[:50, 0])
    assert np.abs(again.alpha - table[:50, 1:4]).max() <= 1e-12
    assert np.abs(again.alpha_ddot - table[:50, 7:10]).max() <= 1e-9 * np.abs(table[:, 7:10]).max()
    nominal = dp.ClosedChainNominalModel(robot, friction=True)
    run = dp.simulate(
        robot, dp.design1(nominal), reference, t_end=0.27, dt=1e-3, friction=True, mode="continuous"
    )
    assert np.abs(run.alpha - run.alpha_d).max() <= 5e-4


def test_write_and_read_back_a_plan(tmp_path):
    """A plan written and read: the same joints at the rows (1e-12), between rows the quintic
    interpolation of the rows within 1e-4 rad of the plan itself (measured 1.4e-5: its acceleration
    jumps are smoothed)."""
    robot = dp.load_delta()
    plan = plan_time_optimal(robot, adept_paths()[0], 20.0)
    path = write_plan(tmp_path / "plan.csv", plan, robot, torque_model(robot), 1000.0)
    reference = read_plan(path)
    t = np.linspace(0.0, plan.duration, 777)
    assert (
        np.abs(reference.joint_reference(robot, t).alpha - plan.joint_reference(robot, t).alpha).max() <= 1e-4
    )
    assert reference.duration == pytest.approx(plan.duration, abs=1e-15)


HEAD = "# delta-pin planned trajectory\nt,q[a],qd[a],qdd[a],tau[a],x,y,z\n"


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("t,q[a]\n0,1\n", "first line"),
        ("# delta-pin planned trajectory\nt,q[a],qd[a],qdd[a],tau[a],x,y\n0,0,0,0,0,0,0\n", "columns"),
        ("# delta-pin planned trajectory\nt,q[a],qd[a],qdd[a],tau[a],x,y,z\n0,0,0,0,0,0,0,0\n", "rows"),
        (HEAD + "0,0,0,0,0,0,0,0\n1,nan,0,0,0,0,0,0\n", "non-finite"),
        (HEAD + "0,0,0,0,0,0,0,0\n0,1,0,0,0,0,0,0\n", "increase"),
        ("# delta-pin planned trajectory\nt,q[a],qd[a],qdd[a],tau[a],x,y,z\n0,0,0,0,0,0,0,0\n1,2,3\n", "row"),
        ("# delta-pin planned trajectory\n", "header without"),
    ],
)
def test_hostile_plan_files_are_one_line(tmp_path, text, named):
    path = tmp_path / "plan.csv"
    path.write_text(text)
    with pytest.raises(InvalidParameterError) as error:
        read_plan(path)
    assert named in str(error.value) and "\n" not in str(error.value)


def test_bad_plan_options_exit_2_with_one_line(tmp_path, capsys):
    cases = [
        (["--torque-limit", "-1"], "torque_limit"),
        (["--torque-limit", "0.5"], "at rest"),
        (["--torque-limit", "20", "--corners=0,0,-0.4;0,0"], "--corners"),
        (["--torque-limit", "20", "--rate", "0"], "--rate"),
        (["--torque-limit", "20", "--z", "-0.7"], "cannot reach"),
        (["--torque-limit", "20", "--singularity-margin", "1.5"], "--singularity-margin"),
        (["--torque-limit", "20", "--switch-refinements", "11"], "--switch-refinements"),
        (["--torque-limit", "20", "--jerk-limit", "0"], "jerk_limit"),
        (["--torque-limit", "20", "--jerk-limit", "1e5,x"], "--jerk-limit"),
    ]
    for extra, named in cases:
        assert main(["plan", *extra, "--out", str(tmp_path / "out")]) == 2
        err = capsys.readouterr().err.strip()
        assert named in err and len(err.splitlines()) == 1, err


def test_plan_refuses_a_folder_of_someone_elses_files(tmp_path, capsys):
    (tmp_path / "plan.csv").write_text("mine\n")
    assert main(["plan", "--torque-limit", "20", "--out", str(tmp_path)]) == 2
    assert (tmp_path / "plan.csv").read_text() == "mine\n"
    assert "plan.csv" in capsys.readouterr().err


def test_a_jerk_limited_plan_keeps_its_limits_in_the_files(tmp_path):
    """--jerk-limit 1e6 (rad/s^3): plan.json records the limit, the window and each half's check
    (jerk and torque ratios <= 1 at 10 kHz); the CSV's 1 kHz rows keep the torque limit and their
    acceleration differences stay under the limit (a 1 ms mean of the jerk: <= the 0.1 ms means the
    check bounds), and the cycle is slower than the unsmoothed one's by less than 10 % (measured
    +1.5 %: at 1e6 rad/s^3 the window is 1.8 ms)."""
    out = tmp_path / "jerk"
    assert main(["plan", "--torque-limit", "20", "--jerk-limit", "1e6", "--out", str(out)]) == 0
    summary = json.loads((out / "plan.json").read_text())
    assert summary["options"]["jerk_limit"] == [1e6]
    for half in summary["plans"]:
        assert half["jerk_ratio_10kHz"] <= 1.0 and half["torque_ratio_10kHz"] <= 1.0
        assert half["smoothing_s"] > 0.0
    table = _table(out / "plan.csv")
    assert np.abs(table[:, 10:13]).max() <= 20.0 * (1 + 1e-6)
    alpha_ddot = table[:, 7:10]
    assert np.abs(np.diff(alpha_ddot, axis=0) / np.diff(table[:, 0])[:, None]).max() <= 1e6
    free = sum(
        plan_time_optimal(dp.load_delta(), path, 20.0, verify=False).duration for path in adept_paths()
    )
    assert free < summary["duration_s"] < 1.1 * free

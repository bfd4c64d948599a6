"""`identify fit` refuses, or warns about, a log that would give a silent wrong result (issue 36,
item 5). Each case was reproduced before the change on a 2 s excitation of the packaged Delta:
another Delta's log (l_a 0.25 m, simulated) fitted with residual 0.2 % and exit 0; a log whose
header named another robot, exit 0; all-zero torques, "residual nan, nan, nan" and exit 0; torques
in mN m (1000x), exit 0 without a word; a second tau[active_2] column (zeros) taken instead of the
first, "residual 0.00766, inf, 0.00523", exit 0.
"""

import json
from pathlib import Path

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.cli import main
from delta_pin.errors import InvalidParameterError
from delta_pin.identification.log import IdentificationLog, check_log_robot, kinematics_digest, read_log
from delta_pin.identification.workflow import TORQUE_SCALE_LIMIT, identify, validate

EXCITE = ["identify", "excite", "--duration", "2", "--period", "2", "--iterations", "0"]
FIT = ["identify", "fit", "--no-consistent", "--no-figures"]
ERROR = "delta-pin identify: error: "


def _one_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(ERROR), err
    return lines[0][len(ERROR) :]


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """A 2 s excitation of the packaged Delta, its log (m_a off by 30 %) and the log of a Delta
    with other arms (--set l_a=0.25), all through the command line."""
    root = tmp_path_factory.mktemp("wrong_log")
    trajectory, log, other = root / "traj.csv", root / "log.csv", root / "other.csv"
    assert main([*EXCITE, "--out", str(trajectory)]) == 0
    simulate = ["identify", "simulate", "--trajectory", str(trajectory)]
    assert main([*simulate, "--true-set", "m_a=0.26", "--out", str(log)]) == 0
    # the other Delta's own excitation: simulate refuses one made for another robot (test_log_limits)
    assert main([*EXCITE, "--set", "l_a=0.25", "--out", str(root / "other_traj.csv")]) == 0
    other_simulate = ["identify", "simulate", "--trajectory", str(root / "other_traj.csv")]
    assert main([*other_simulate, "--set", "l_a=0.25", "--out", str(other)]) == 0
    return {"root": root, "log": log, "other": other}


def _edited(logs, name: str, edit) -> Path:
    """A copy of the log with ``edit(header lines, column line, data rows as lists of str)``."""
    lines = logs["log"].read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    header, columns, rows = lines[:first], lines[first], [line.split(",") for line in lines[first + 1 :]]
    header, columns, rows = edit(header, columns, rows)
    path = logs["root"] / name
    path.write_text("\n".join([*header, columns, *(",".join(r) for r in rows)]) + "\n")
    return path


def _scaled(factor: float):
    def edit(header, columns, rows):
        return header, columns, [[*r[:4], *(repr(float(x) * factor) for x in r[4:7]), *r[7:]] for r in rows]

    return edit


# ------------------------------------------------------------------------------ another robot
def test_another_delta_s_log_is_refused_naming_both(logs, tmp_path, capsys):
    """Before: the l_a = 0.25 m Delta's log fitted to the Table 1 Delta (l_a 0.2 m) with residual
    0.18-0.21 % and exit 0. Now the header's kinematics_sha256 (the digest of the robot simulate
    was given) differs from the fitted robot's: exit 2, one line with both digests."""
    capsys.readouterr()
    code = main([*FIT, "--data", str(logs["other"]), "--out", str(tmp_path / "fit")])
    line = _one_line(capsys)
    assert code == 2
    other, given = kinematics_digest(dp.load_delta(l_a=0.25)), kinematics_digest(dp.load_delta())
    assert other != given
    assert f"log {logs['other']} was written for a robot 'delta' of other kinematics" in line
    assert f"kinematics_sha256: {other}, the robot given: {given}" in line
    assert not (tmp_path / "fit" / "parameters.json").exists()
    # the same robot fits: the log of --set l_a=0.25 with --set l_a=0.25
    code = main([*FIT, "--set", "l_a=0.25", "--data", str(logs["other"]), "--out", str(tmp_path / "ok")])
    assert code == 0, capsys.readouterr().err


def test_a_log_whose_header_names_another_robot_is_refused(logs, tmp_path, capsys):
    """Before: exit 0. Now one line naming both robots; without a '# robot:' line (a drive's log,
    written by anyone) the same numbers are accepted."""
    named = _edited(logs, "named.csv", lambda h, c, r: ([x.replace("# robot: delta", "# robot: five_bar")
                                                          for x in h], c, r))  # fmt: skip
    capsys.readouterr()
    assert main([*FIT, "--data", str(named), "--out", str(tmp_path / "a")]) == 2
    line = _one_line(capsys)
    assert f"log {named} was written for robot 'five_bar'" in line
    assert "not for robot 'delta', the one given" in line
    drive = _edited(logs, "drive.csv", lambda h, c, r: ([x for x in h if not x.startswith(("# robot",
                                                         "# kinematics"))], c, r))  # fmt: skip
    assert main([*FIT, "--data", str(drive), "--out", str(tmp_path / "b")]) == 0, capsys.readouterr().err


def test_check_log_robot_in_python():
    """The same checks on logs built in Python (identify and validate call them): the joints, the
    name, the digest; no robot key accepted. The digest ignores what a fit identifies (masses,
    friction) and gravity (load_delta's 9.8 vs load_robot's 9.81 m/s^2 for the same URDF)."""
    delta = dp.load_delta()
    n = 20
    t = np.arange(n) / 1000.0
    alpha, tau = np.zeros((n, 3)), np.outer(np.arange(n), [1.0, 2.0, 3.0])

    def log(header, joints=delta.actuated_joints):
        return IdentificationLog(t, alpha, tau, tuple(joints), header=header)

    digest = kinematics_digest(delta)
    assert digest == kinematics_digest(dp.load_delta(m_a=0.3, m_b=0.1, mu_v=1.0, g=9.81))
    assert digest != kinematics_digest(dp.load_delta(R=0.2))
    check_log_robot(log({}), delta)
    check_log_robot(log({"robot": "delta", "kinematics_sha256": digest}), delta)
    with pytest.raises(InvalidParameterError, match=r"written for robot 'five_bar'.*not for robot 'delta'"):
        check_log_robot(log({"robot": "five_bar"}), delta)
    with pytest.raises(InvalidParameterError, match="kinematics_sha256: 0123456789abcdef, the robot given"):
        check_log_robot(log({"robot": "delta", "kinematics_sha256": "0123456789abcdef"}), delta)
    with pytest.raises(InvalidParameterError, match=r"joints \['a', 'b', 'c'\] are not the actuated joints"):
        check_log_robot(log({}, ("a", "b", "c")), delta)


def test_a_torque_of_a_joint_the_robot_does_not_actuate_is_refused(logs):
    """Before: a tau[active_4] column (a motor the model leaves out) was ignored."""
    extra = _edited(logs, "extra.csv", lambda h, c, r: (h, c + ",tau[active_4]", [[*x, "0.5"] for x in r]))
    with pytest.raises(InvalidParameterError, match=r"column 'tau\[active_4\]' is the torque of joint "
                       r"'active_4', which the robot does not actuate") as error:  # fmt: skip
        read_log(extra, dp.load_delta().actuated_joints)
    assert "\n" not in str(error.value)


# --------------------------------------------------------------------------- no information
def test_all_zero_torques_are_refused(logs, tmp_path, capsys):
    """Before: 'residual nan, nan, nan of the torque's RMS' (two RuntimeWarnings) and exit 0."""
    zeros = _edited(logs, "zeros.csv", lambda h, c, r: (h, c, [[*x[:4], "0", "0", "0", *x[7:]] for x in r]))
    capsys.readouterr()
    assert main([*FIT, "--data", str(zeros), "--out", str(tmp_path / "fit")]) == 2
    line = _one_line(capsys)
    assert line.startswith(f"log {zeros}: column 'tau[active_1]' is 0 on every line: the torques carry no "
                           "information")  # fmt: skip


def test_a_constant_torque_is_refused_in_python(logs):
    """A log built in Python with one constant column (0.7 N m on joint 2), in identify and in
    validate."""
    log = read_log(logs["log"], dp.load_delta().actuated_joints)
    flat = IdentificationLog(log.t, log.alpha, log.tau.copy(), log.joints, header=log.header)
    flat.tau[:, 1] = 0.7
    with pytest.raises(
        InvalidParameterError, match=r"the log: column 'tau\[active_2\]' is 0.7 on every line"
    ):
        identify(dp.load_delta(), flat, consistent=False)
    result = identify(dp.load_delta(), log, consistent=False)
    with pytest.raises(InvalidParameterError, match=r"column 'tau\[active_2\]' is 0.7 on every line"):
        validate(result, flat)


# --------------------------------------------------------------------------------- wrong unit
def test_torques_in_mn_m_are_warned_about(logs, tmp_path, capsys):
    """Before: a log in mN m fitted without a word (the same residual, every parameter 1000x).
    Now stdout and report.md say "torques in N m? the log's torques are 1.07e+03x the CAD model's";
    parameters.json holds the ratio. The N m log's ratio (m_a 30 % heavier than the CAD file's):
    measured 1.07; within [0.5, 2] here, no warning. The ratio is linear in the torque: the mN m
    log's is 1000x the N m log's to 1e-9. kN m (0.001x) warns too."""
    capsys.readouterr()
    assert main([*FIT, "--data", str(logs["log"]), "--out", str(tmp_path / "nm")]) == 0
    assert "warning" not in capsys.readouterr().out
    plain = json.loads((tmp_path / "nm" / "parameters.json").read_text())
    assert plain["warnings"] == []
    ratio = plain["torque_scale"]["ratio"]
    assert 0.5 < ratio < 2.0

    milli = _edited(logs, "milli.csv", _scaled(1000.0))
    assert main([*FIT, "--data", str(milli), "--out", str(tmp_path / "mnm")]) == 0
    out = capsys.readouterr().out
    record = json.loads((tmp_path / "mnm" / "parameters.json").read_text())
    assert record["torque_scale"]["ratio"] == pytest.approx(1000.0 * ratio, rel=1e-9)
    [warning] = [line for line in out.splitlines() if line.startswith("warning")]
    assert warning.startswith(f"warning: torques in N m? the log's torques are {1000 * ratio:.3g}x the "
                              "CAD model's")  # fmt: skip
    assert f"beyond a factor {TORQUE_SCALE_LIMIT:g} either way" in warning
    assert record["warnings"] == [warning]
    assert f"**{warning}**" in (tmp_path / "mnm" / "report.md").read_text()

    kilo = _edited(logs, "kilo.csv", _scaled(0.001))
    assert main([*FIT, "--data", str(kilo), "--out", str(tmp_path / "knm")]) == 0
    assert f"the log's torques are {ratio / 1000:.3g}x the CAD model's" in capsys.readouterr().out


# ------------------------------------------------------------------------------- a column twice
def test_a_column_named_twice_is_refused_naming_both_positions(logs, tmp_path, capsys):
    """Before: the second tau[active_2] (zeros) was taken, 'residual 0.00766, inf, 0.00523', exit 0."""
    twice = _edited(logs, "twice.csv", lambda h, c, r: (h, c + ",tau[active_2]", [[*x, "0"] for x in r]))
    capsys.readouterr()
    assert main([*FIT, "--data", str(twice), "--out", str(tmp_path / "fit")]) == 2
    line = _one_line(capsys)
    number = 1 + [x.startswith("t,") for x in twice.read_text().splitlines()].index(True)
    assert line == (f"log {twice}: column 'tau[active_2]' is named twice on line {number}, as columns 6 and "
                    "8: which one is the joint's is not known; remove or rename one")  # fmt: skip

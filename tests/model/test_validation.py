"""``validate`` and the ``delta-pin urdf | validate`` commands."""

import subprocess
import sys

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.cli import main
from delta_pin.errors import InvalidParameterError
from delta_pin.model.validation import sample_states, validate

from ..conftest import OTHER_ROBOTS


def test_default_robot_validates(robot):
    report = validate(robot, samples=30, seed=0)
    assert report.passed, report.table()
    errors = {check.name: check.max_rel for check in report.checks}
    assert errors["M"] < 1e-12 and errors["G"] < 1e-12 and errors["C a_dot"] < 1e-11


@pytest.mark.parametrize("name", sorted(OTHER_ROBOTS))
def test_other_dimension_and_mass_sets_validate(name):
    report = validate(dp.load_delta(**OTHER_ROBOTS[name]), samples=15, seed=1)
    assert report.passed, report.table()


def test_rod_forearm_fails_with_the_real_model_error():
    report = validate(dp.load_delta(forearm_inertia="rod"), samples=15, seed=0)
    assert not report.passed
    failed = {check.name for check in report.checks if not check.passed}
    assert failed == {"M", "C a_dot"}  # gravity is unchanged: same masses, same centres
    m_check = next(c for c in report.checks if c.name == "M")
    assert 0.01 < m_check.max_rel < 1.0


def test_report_errors_equal_the_one_state_pinocchio_route():
    """``validate`` reports the errors of the one robot model's projection (checked where they
    are real numbers: the rod-forearm robot's model error), its configurations assembled here by
    Newton from the robot's own warm start to 1e-15 m (validate starts at the closed-form
    configuration: both are the assembly to rounding, so the errors agree to rtol 1e-9)."""
    robot = dp.load_delta(forearm_inertia="rod")
    report = validate(robot, samples=40, seed=2)
    alpha, alpha_dot = sample_states(robot, 40, seed=2)
    analytic = robot.analytic_dynamics(alpha, alpha_dot)
    closed = robot.pinocchio
    truth = [
        closed.reduced_dynamics(a, d, closed.configuration(a, tol=1e-15)) for a, d in zip(alpha, alpha_dot)
    ]
    checks = {check.name: check for check in report.checks}
    for name, field in (("M", "M"), ("C a_dot", "coriolis"), ("G", "G")):
        reference = np.array([getattr(t, field) for t in truth])
        axes = tuple(range(1, reference.ndim))
        error = np.sqrt(np.sum((getattr(analytic, field) - reference) ** 2, axis=axes))
        relative = error / np.sqrt(np.sum(reference**2, axis=axes))
        np.testing.assert_allclose(checks[name].max_abs, error.max(), rtol=1e-9, atol=1e-14)
        np.testing.assert_allclose(checks[name].max_rel, relative.max(), rtol=1e-9, atol=1e-14)
    assert checks["M"].max_rel > 0.01 and checks["G"].max_rel < 1e-12


def test_tolerance_and_samples_are_checked(robot):
    with pytest.raises(dp.InvalidParameterError, match="tol=0"):
        validate(robot, tol=0)
    with pytest.raises(dp.InvalidParameterError, match="samples=0"):
        validate(robot, samples=0)


def test_cli_validate_exit_codes(capsys):
    assert main(["validate", "--samples", "5"]) == 0
    out = capsys.readouterr().out
    assert "all checks passed" in out and "M_dot - 2C skew" in out
    assert main(["validate", "--samples", "5", "--set", "forearm_inertia=rod"]) == 1
    assert "FAIL" in capsys.readouterr().out


def test_cli_urdf_writes_a_loadable_file(tmp_path):
    out = tmp_path / "sub" / "delta.urdf"
    assert main(["urdf", "--set", "l_a=0.25", "--set", "m_o=0.5", "-o", str(out)]) == 0
    robot = dp.load_delta(urdf=out)
    assert (robot.params.l_a, robot.params.m_o) == (0.25, 0.5)
    assert main(["validate", "--urdf", str(out), "--samples", "3"]) == 0


def test_cli_bad_argument_is_a_clear_error(capsys):
    assert main(["urdf", "--set", "l_a=-1"]) == 2
    assert "l_a='-1'" in capsys.readouterr().err
    assert main(["validate", "--set", "wingspan=3"]) == 2
    assert "unknown xacro argument 'wingspan'" in capsys.readouterr().err


def test_console_script_is_installed():
    result = subprocess.run(
        [sys.executable, "-m", "delta_pin.cli", "validate", "--samples", "2"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr


def test_a_bad_seed_is_one_clear_line(robot, capsys):
    """A negative seed used to end in numpy's traceback (issue 15)."""
    assert main(["validate", "--samples", "3", "--seed", "-1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "seed=-1" in err[0] and ">= 0" in err[0]
    with pytest.raises(InvalidParameterError, match=r"seed=1\.5"):
        validate(robot, samples=3, seed=1.5)

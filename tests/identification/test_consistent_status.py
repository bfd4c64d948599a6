"""The physically consistent estimate is solved to optimality (a convex problem, the log-barrier
method) and says so: its status in parameters.json, report.md and stdout, and robot.urdf is written
from it only when it converged (issue 37)."""

import json

import numpy as np
import pytest

import delta_pin as dp
import delta_pin.identification.consistent as consistent_module
from delta_pin.cli import main
from delta_pin.identification.report import write_report
from delta_pin.identification.workflow import identify, simulate_log
from tests.identification.delta_excitation import delta_excitation


@pytest.fixture(scope="module")
def delta_log():
    """A 3 s noisy log (17-bit encoders, 1 % torque noise) of a Delta whose masses are off the CAD
    file's by +30 %, -30 %, +30 %."""
    nominal, true, _, _, trajectory = delta_excitation()
    log, _ = simulate_log(true, trajectory, nominal=nominal, seed=11)
    return nominal, log


def test_the_consistent_estimate_converges_and_says_so(delta_log, tmp_path):
    """Optimal (duality gap <= 1e-8 of the cost) in at most 400 Newton steps (measured 98, 0.05 s;
    scipy's least_squares before stopped at its 100 evaluations here, cost 2245.8 against the
    optimum's 2241.71); physical (pseudo-inertias' eigenvalues >= -1e-12); its status in
    parameters.json and report.md, and robot.urdf written from it, which loads with its motors."""
    nominal, log = delta_log
    result = identify(nominal, log, essential=False)
    c = result.consistent
    assert c.success, c.message
    assert 0 < c.iterations <= 400
    assert c.message.startswith("optimal: duality gap")
    assert c.min_eigenvalues.min() > -1e-12
    assert not any("did not converge" in w for w in result.warnings)
    written = {p.name for p in write_report(result, log, tmp_path / "ident", figures=False)}
    assert "robot.urdf" in written
    record = json.loads((tmp_path / "ident" / "parameters.json").read_text())
    assert record["consistent"]["converged"] is True
    assert record["consistent"]["iterations"] == c.iterations
    assert record["consistent"]["duality_gap"] <= 1e-8 * 2300
    report = (tmp_path / "ident" / "report.md").read_text()
    assert "consistent estimate: converged (optimal: duality gap" in report
    # a Delta's robot.urdf is the packaged xacro at the identified masses and friction: loaded
    # back, it is recognised as a Delta (before: per-link inertials, three different arms, so not)
    back = dp.load_robot(str(tmp_path / "ident" / "robot.urdf"))
    assert back.actuated_joints == nominal.actuated_joints
    assert back.delta is not None, "the identified Delta is not recognised"
    params, expected = back.delta.params, result.xacro_arguments
    identified = {"m_a": params.m_a, "m_b": params.m_b, "m_o": params.m_o}
    identified.update(mu_v=params.friction.mu_v, mu_d=params.friction.mu_d, mu_s=params.friction.mu_s)
    assert set(expected) <= set(identified)
    for name, value in expected.items():  # the file's 12-17 digits
        assert identified[name] == pytest.approx(value, rel=1e-9), name
    assert params.friction.mu_v != nominal.delta.params.friction.mu_v  # not the CAD file's friction


def test_a_consistent_estimate_that_did_not_converge_writes_no_urdf(delta_log, tmp_path, monkeypatch):
    """One Newton step allowed: not converged, said in the warnings, parameters.json and report.md,
    and no robot.urdf."""
    nominal, log = delta_log
    monkeypatch.setattr(consistent_module, "MAX_NEWTON_STEPS", 1)
    result = identify(nominal, log, essential=False)
    c = result.consistent
    assert not c.success
    assert c.iterations == 1
    assert "stopped after 1 Newton steps" in c.message
    assert any("did not converge" in w for w in result.warnings)
    written = {p.name for p in write_report(result, log, tmp_path / "ident", figures=False)}
    assert "robot.urdf" not in written and not (tmp_path / "ident" / "robot.urdf").exists()
    record = json.loads((tmp_path / "ident" / "parameters.json").read_text())
    assert record["consistent"]["converged"] is False and record["consistent"]["iterations"] == 1
    report = (tmp_path / "ident" / "report.md").read_text()
    assert "consistent estimate: NOT converged" in report and "robot.urdf is not written" in report


@pytest.fixture(scope="module")
def five_bar_log(tmp_path_factory):
    """A 3 s log of the five-bar, masses off the file's by up to 30 %, by the command line."""
    folder = tmp_path_factory.mktemp("five_bar")
    traj, log = folder / "traj.csv", folder / "log.csv"
    common = ["--robot", "five_bar"]
    assert main(["identify", "excite", *common, "--out", str(traj), "--duration", "3", "--period", "3",
                 "--iterations", "0"]) == 0  # fmt: skip
    assert main(["identify", "simulate", *common, "--trajectory", str(traj), "--mass-spread", "0.3",
                 "--out", str(log)]) == 0  # fmt: skip
    return log


def test_the_command_line_says_when_it_did_not_converge(five_bar_log, tmp_path, capsys, monkeypatch):
    """identify fit on the five-bar: converged and robot.urdf written by default; with one Newton
    step allowed, stdout says NOT converged and robot.urdf is not written, and none is."""
    log, common = five_bar_log, ["--robot", "five_bar"]
    capsys.readouterr()
    fit = ["identify", "fit", *common, "--data", str(log), "--no-figures"]
    assert main([*fit, "--out", str(tmp_path / "a")]) == 0
    out = capsys.readouterr().out
    assert "consistent estimate: converged (optimal" in out, out
    assert (tmp_path / "a" / "robot.urdf").is_file()
    monkeypatch.setattr(consistent_module, "MAX_NEWTON_STEPS", 1)
    assert main([*fit, "--out", str(tmp_path / "b")]) == 0
    out = capsys.readouterr().out
    assert "consistent estimate: NOT converged (stopped after 1 Newton steps" in out, out
    assert "robot.urdf is not written" in out
    assert not (tmp_path / "b" / "robot.urdf").exists()


def test_a_robot_urdf_carries_the_identified_model_with_friction_and_rotor_inertia(five_bar_log, tmp_path):
    """The five-bar (not a Delta): robot.urdf loaded back has the identified model's projected
    M, C alpha_dot and G (the consistent estimate's bodies and rotor inertias, the latter as
    Drake's drake:rotor_inertia, read into model.armature), to 1e-9 relative (the file's 12
    digits), and each motor's <dynamics damping friction> is the estimate's fv, fc."""
    from lxml import etree

    from delta_pin.identification import identified_robot
    from delta_pin.identification.log import read_log

    log = five_bar_log

    robot = dp.load_robot("five_bar")
    data = read_log(log, robot.actuated_joints)
    result = identify(robot, data)
    assert result.consistent.success
    write_report(result, data, tmp_path / "ident", figures=False)
    path = tmp_path / "ident" / "robot.urdf"
    back, model = dp.load_robot(str(path)), identified_robot(result)
    values = dict(zip(result.regressor.names, result.consistent.theta, strict=True))
    rotor = np.array([values[f"Ia[{j}]"] for j in robot.actuated_joints])
    assert rotor.max() > 0.0  # a rotor inertia identified (the bound Ia >= 0 may hold some at 0)
    np.testing.assert_allclose(back.model.armature[back.actuated_indices], rotor, rtol=1e-9, atol=1e-15)
    rng = np.random.default_rng(2)
    for _ in range(3):
        alpha, alpha_dot = robot.home + rng.uniform(-0.2, 0.2, 2), rng.normal(size=2)
        for got, expected in zip(back.reduced_terms(alpha, alpha_dot), model.reduced_terms(alpha, alpha_dot)):
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    joints = {j.get("name"): j for j in etree.parse(str(path)).getroot().iter("joint")}
    for name in robot.actuated_joints:
        dynamics = joints[name].find("dynamics")
        assert float(dynamics.get("damping")) == pytest.approx(values[f"fv[{name}]"], rel=1e-11)
        assert float(dynamics.get("friction")) == pytest.approx(values[f"fc[{name}]"], rel=1e-11)

"""Velocities from the positions by default, a log's qd only on request, and qd's lag measured
(issue 37: "a velocity column half a sample late (a drive's backward difference) silently gave
k2, k3 -20 % and a Coulomb term -100 %, with normal-looking residuals"). Before, a log with qd
columns was fitted on its qd, whatever its timing, and nothing measured it."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.cli import main
from delta_pin.errors import InvalidParameterError
from delta_pin.identification.estimation import VELOCITY_LAG_SAMPLES, velocity_lag
from delta_pin.identification.log import write_log
from delta_pin.identification.workflow import identify, simulate_log
from tests.identification.delta_excitation import delta_excitation


@pytest.fixture(scope="module")
def logs():
    """The shared 3 s Delta case simulated with Table 1 friction, 17-bit encoders and 1 % torque
    noise, as three logs: without qd; with the true velocity at each sample; with a drive's
    backward difference of the logged (quantised) positions, (q_k - q_(k-1)) / dt: half a sample
    late."""
    nominal, true, _, _, trajectory = delta_excitation()
    log, run = simulate_log(true, trajectory, nominal=nominal, seed=1)
    dt = log.t[1] - log.t[0]
    backward = np.vstack([np.zeros((1, log.alpha.shape[1])), np.diff(log.alpha, axis=0) / dt])
    return {
        "robot": nominal,
        "dt": dt,
        "plain": log,
        "exact": dataclasses.replace(log, alpha_dot=run.alpha_dot.copy()),
        "backward": dataclasses.replace(log, alpha_dot=backward),
    }


def test_the_lag_of_a_backward_difference_is_half_a_sample(logs):
    """velocity_lag's first-order least squares against a known lag: a backward difference is
    0.5 samples late (measured 0.50001-0.50004), the true velocity 0 (measured |lag| < 1e-3
    samples); bound 0.01 samples, a tenth of the reporting threshold VELOCITY_LAG_SAMPLES. A log
    without qd has no lag (NaN)."""
    dt = logs["dt"]
    np.testing.assert_allclose(velocity_lag(logs["backward"]) / dt, 0.5, atol=0.01)
    np.testing.assert_allclose(velocity_lag(logs["exact"]) / dt, 0.0, atol=0.01)
    assert 0.01 < VELOCITY_LAG_SAMPLES < 0.5  # the bound above separates what is reported
    assert np.isnan(velocity_lag(logs["plain"])).all()


def test_the_default_fit_takes_the_velocities_from_the_positions(logs):
    """A log with a lagging qd is fitted as if it had none (the same WLS estimate to the bit), and
    its lag is a note; the same log fitted on its qd (velocities="logged") warns, naming each
    joint's lag; a qd without lag is no line at all."""
    robot = logs["robot"]
    plain = identify(robot, logs["plain"], consistent=False)
    default = identify(robot, logs["backward"], consistent=False)
    assert default.velocities == "positions"
    np.testing.assert_array_equal(default.wls.beta, plain.wls.beta)
    assert plain.velocity_lag is None and not any("qd" in line for line in plain.warnings)
    (note,) = [line for line in default.warnings if "qd" in line]
    assert note.startswith("note: the log's qd lags the derivative of q (active_1 0.5 ms (0.50 samples)")
    logged = identify(robot, logs["backward"], consistent=False, velocities="logged")
    (warning,) = [line for line in logged.warnings if "qd" in line]
    assert (
        warning.startswith("warning: the log's qd lags the derivative of q")
        and "--velocities logged" in warning
    )
    assert not np.array_equal(logged.wls.beta, plain.wls.beta)
    exact = identify(robot, logs["exact"], consistent=False, velocities="logged")
    assert not any("qd" in line for line in exact.warnings)
    with pytest.raises(InvalidParameterError, match="has no qd columns: its velocities can only come from"):
        identify(robot, logs["plain"], velocities="logged")
    with pytest.raises(InvalidParameterError, match="velocities='measured' must be 'positions'"):
        identify(robot, logs["backward"], velocities="measured")


def test_fit_velocities_on_the_command_line(logs, tmp_path, capsys):
    """``identify fit --velocities logged`` on a log with qd: the warning in stdout, report.md and
    parameters.json (with the lag per joint, seconds); on a log without qd: one line, exit 2,
    before any file is written."""
    lagged = write_log(tmp_path / "lagged.csv", logs["backward"])
    out = tmp_path / "fit"
    fit = ["identify", "fit", "--data", str(lagged), "--no-figures", "--no-consistent"]
    capsys.readouterr()
    assert main([*fit, "--out", str(out), "--velocities", "logged"]) == 0
    stdout = capsys.readouterr().out
    assert "warning: the log's qd lags the derivative of q" in stdout
    record = json.loads((out / "parameters.json").read_text())
    assert record["velocities"] == "logged"
    np.testing.assert_allclose(np.array(record["velocity_lag_s"]) / logs["dt"], 0.5, atol=0.01)
    report = (out / "report.md").read_text()
    assert "velocities from the log's qd" in report and "warning: the log's qd lags" in report
    plain = write_log(tmp_path / "plain.csv", logs["plain"])
    none = tmp_path / "none"
    code = main(["identify", "fit", "--data", str(plain), "--out", str(none), "--velocities", "logged"])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "has no qd columns" in err, err
    assert not none.exists()


@pytest.mark.parametrize(("integrator", "lag"), [("RK4", 0.0), ("EULER", 0.5), ("IMPLICITFAST", 0.5)])
def test_the_lag_of_mujoco_s_own_velocities(integrator, lag):
    """A log from another simulator: the shipped 3-RRR's MJCF run by MuJoCo under a PD law along
    three sinusoids, (qpos, qvel) of the actuated joints logged before each mj_step. MuJoCo's
    semi-implicit Euler steps (Euler, implicitfast) set q_(k+1) = q_k + h v_(k+1), so the v logged
    beside q_k is exactly (q_k - q_(k-1)) / h: half a sample late, which velocity_lag measures
    (0.5000-0.5005 samples); its RK4 logs the state's own velocity (|lag| < 0.002 samples). Bound
    0.01 samples, as for delta-pin's own logs."""
    mujoco = pytest.importorskip("mujoco")
    from delta_pin.identification.log import IdentificationLog

    model = mujoco.MjModel.from_xml_path(str(Path(dp.__file__).parent / "robots" / "three_rrr.xml"))
    model.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator}")
    data = mujoco.MjData(model)
    joints = ("active_1", "active_2", "active_3")
    q_at = [model.joint(name).qposadr[0] for name in joints]
    v_at = [model.joint(name).dofadr[0] for name in joints]
    h, start = model.opt.timestep, data.qpos[q_at].copy()
    rows = []
    for k in range(3500):  # 0.5 s to settle onto the loops, then 3 s logged
        t = k * h
        target = start + 0.2 * np.sin(2 * np.pi * np.array([1.0, 1.3, 0.7]) * t)
        data.ctrl[:] = 20.0 * (target - data.qpos[q_at]) - 1.0 * data.qvel[v_at]
        if k >= 500:
            rows.append((t, *data.qpos[q_at], *data.qvel[v_at], *data.ctrl))
        mujoco.mj_step(model, data)
    table = np.array(rows)
    log = IdentificationLog(table[:, 0], table[:, 1:4], table[:, 7:10], joints, table[:, 4:7])
    np.testing.assert_allclose(velocity_lag(log) / h, lag, atol=0.01)

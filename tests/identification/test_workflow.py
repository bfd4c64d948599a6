"""Identification of robots whose true parameters the test knows and the fit does not: a Delta with
its masses changed by up to 30 % (the fit sees only the CAD robot and the log), the five-bar
through the command line, and the physically consistent estimate."""

import json

import numpy as np
import pinocchio as pin
import pytest

import delta_pin as dp
from delta_pin.cli import main
from delta_pin.identification.base import base_parameters
from delta_pin.identification.consistent import log_cholesky_to_parameters, parameters_to_log_cholesky
from delta_pin.identification.excitation import ExcitationLimits, optimize_excitation
from delta_pin.identification.regressor import ClosedChainRegressor
from delta_pin.identification.workflow import friction_truth, identify, simulate_log, validate

TRUE_MASSES = {"m_a": 0.26, "m_b": 0.14, "m_o": 0.39}  # Table 1's 0.2, 0.2, 0.3 by +30 %, -30 %, +30 %


@pytest.fixture(scope="module")
def delta_case():
    """The CAD Delta, the true one, a 3 s excitation (the optimiser's best seeded start, no
    iterations) and the true base parameters' standard values."""
    nominal = dp.load_delta()
    true = dp.load_delta(**TRUE_MASSES)
    regressor = ClosedChainRegressor(nominal)
    base = base_parameters(regressor, count=80)
    limits = ExcitationLimits(position_range=0.6)
    trajectory, _ = optimize_excitation(regressor, base, regressor.parameters(), alpha0=nominal.home + 0.3,
                                        limits=limits, max_iterations=0, period=3.0, duration=3.0,
                                        harmonics=6)  # fmt: skip
    theta_true = ClosedChainRegressor(true).parameters(true, friction_truth(true, dp.Friction()))
    return nominal, true, trajectory, theta_true


def test_exact_data_recovers_the_true_parameters(delta_case):
    """Exact positions (32-bit encoder) and torques: every nonzero base parameter within 2 %
    (measured at most 0.8 %: what the parallel filter's transition band and the spline of the
    tree's columns leave), the true Delta's masses within 2 % (measured 0.4 %), residual < 1e-4."""
    nominal, true, trajectory, theta_true = delta_case
    log, _ = simulate_log(true, trajectory, nominal=nominal, encoder_bits=32, torque_noise=0.0)
    result = identify(nominal, log, consistent=False, essential=False)
    truth = result.base.values(theta_true)
    nonzero = np.abs(truth) > 1e-9
    relative = np.abs(result.wls.beta - truth)[nonzero] / np.abs(truth[nonzero])
    assert relative.max() < 0.02, dict(zip(np.array(result.names)[nonzero], relative, strict=True))
    assert np.all(result.residual_rms / result.tau_rms < 1e-4)
    for name, value in TRUE_MASSES.items():
        assert result.xacro_arguments[name] == pytest.approx(value, rel=0.02)
    mu = result.xacro_arguments
    assert (mu["mu_v"], mu["mu_d"], mu["mu_s"]) == pytest.approx((2.0, 0.1, 0.2), rel=0.02)


def test_noisy_data_lies_within_its_covariance(delta_case):
    """17-bit encoders and torque noise of 1 % of the RMS torque: every base parameter's error is
    within 4.5 of its reported standard deviations (measured at most 2.2-3.3 over 46 parameters:
    the decimated rows make the covariance honest; without the decimation it was 60), and the
    essential fit keeps every base parameter whose true value is far from 0."""
    nominal, true, trajectory, theta_true = delta_case
    log, _ = simulate_log(true, trajectory, nominal=nominal, seed=11)
    result = identify(nominal, log, consistent=False, essential=False)
    truth = result.base.values(theta_true)
    z = (result.wls.beta - truth) / result.wls.std
    assert np.abs(z).max() < 4.5, dict(zip(result.names, np.round(z, 2), strict=True))
    essential = identify(nominal, log, consistent=False)
    kept = np.abs(essential.wls.beta) > 0
    strong = np.abs(truth) > 10 * result.wls.std
    assert np.all(kept[strong]), [
        n for n, k, s in zip(result.names, kept, strong, strict=True) if s and not k
    ]


def test_validation_on_an_unseen_trajectory(delta_case):
    """A fit on one excitation predicts the torque of another (a different seed's start) to 1 %
    of its RMS with exact data (measured 0.01-0.02 %)."""
    nominal, true, trajectory, _ = delta_case
    log, _ = simulate_log(true, trajectory, nominal=nominal, encoder_bits=32, torque_noise=0.0)
    result = identify(nominal, log, consistent=False, essential=False)
    regressor = ClosedChainRegressor(nominal)
    other, _ = optimize_excitation(regressor, result.base, regressor.parameters(), alpha0=nominal.home + 0.2,
                                   limits=ExcitationLimits(position_range=0.4), max_iterations=0, period=2.0,
                                   duration=2.0, harmonics=5, seed=5)  # fmt: skip
    unseen, _ = simulate_log(true, other, nominal=nominal, encoder_bits=32, torque_noise=0.0)
    report = validate(result, unseen)
    assert max(report["rms_relative"]) < 0.01, report


def test_log_cholesky_round_trip_and_boundary():
    """A solid body (a 0.7 kg box off its joint's origin) survives the round trip to 1e-12; a point
    mass on the boundary J ⪰ 0 comes back within the eigenvalue floor (1e-6 of J's largest
    eigenvalue ~0.5, entering I = tr(Sigma) 1 - Sigma up to twice: 3e-6 absolute)."""
    box = pin.Inertia.FromBox(0.7, 0.1, 0.2, 0.3)
    theta = pin.Inertia(0.7, np.array([0.05, -0.02, 0.1]), box.inertia).toDynamicParameters()
    back = log_cholesky_to_parameters(parameters_to_log_cholesky(theta, floor=0.0))
    np.testing.assert_allclose(back, theta, rtol=0, atol=1e-12)
    point = np.array([0.5, 0.05, 0.0, 0.0, 0.0, 0.0, 0.005, 0.0, 0.0, 0.005])  # 0.5 kg at x = 0.1 m
    back = log_cholesky_to_parameters(parameters_to_log_cholesky(point))
    np.testing.assert_allclose(back, point, rtol=0, atol=3e-6)


def test_consistent_estimate_is_physical_and_near_wls(delta_case):
    """Every body's pseudo-inertia of the consistent estimate has eigenvalues >= -1e-12 (it is
    U U^T), masses > 0, and with exact data its base parameters are within 1e-2 of WLS, relative
    (measured ~1e-3: the lumped forearms sit on the boundary J ⪰ 0 the log-Cholesky only nears)."""
    nominal, true, trajectory, _ = delta_case
    log, _ = simulate_log(true, trajectory, nominal=nominal, encoder_bits=32, torque_noise=0.0)
    result = identify(nominal, log, essential=False)
    c = result.consistent
    assert c.min_eigenvalues.min() > -1e-12
    assert np.all(c.theta[: result.regressor.inertial_count : 10] > 0)
    assert c.distance_relative < 1e-2


def test_the_command_line_workflow_on_the_five_bar(tmp_path, capsys):
    """excite -> simulate (masses off by up to 30 %) -> fit with validation: the files of
    docs/identification.md, the identified URDF read back by load_robot with the consistent
    masses, and a validation torque error below 2 % (exact data: measured ~0.1 %)."""
    traj, log, unseen, out = (tmp_path / n for n in ("traj.csv", "log.csv", "unseen.csv", "ident"))
    common = ["--robot", "five_bar"]
    assert main(["identify", "excite", *common, "--out", str(traj), "--duration", "3", "--period", "3",
                 "--iterations", "0"]) == 0  # fmt: skip
    sim = ["--trajectory", str(traj), "--mass-spread", "0.3", "--encoder-bits", "32", "--torque-noise", "0"]
    assert main(["identify", "simulate", *common, *sim, "--out", str(log)]) == 0
    assert main(["identify", "simulate", *common, *sim, "--out", str(unseen), "--seed", "0"]) == 0
    code = main(
        ["identify", "fit", *common, "--data", str(log), "--validate", str(unseen), "--out", str(out)]
    )
    assert code == 0, capsys.readouterr().err
    names = {p.name for p in out.iterdir()}
    assert {
        "parameters.json",
        "report.md",
        "robot.urdf",
        "torque.png",
        "residual.png",
        "condition.png",
    } <= names
    record = json.loads((out / "parameters.json").read_text())
    assert record["rank"]["base_parameters"] == len(record["base_parameters"])
    assert max(record["validation"]["rms_relative"]) < 0.02
    back = dp.load_robot(str(out / "robot.urdf"))
    masses = {b: v["m"] for b, v in record["consistent"]["bodies"].items()}
    body_masses = sorted(back.model.inertias[j].mass for j in range(1, back.model.njoints))
    np.testing.assert_allclose(body_masses, sorted(masses.values()), rtol=1e-9)

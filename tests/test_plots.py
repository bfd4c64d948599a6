"""Figures of runs: the plotted data are the run's numbers; files are whole PNGs; bad input is named."""

import numpy as np
import pytest
from matplotlib.figure import Figure

import delta_pin as dp
from delta_pin.viz import plots

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def runs():
    robot = dp.load_delta()
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    options = {
        "plant": "analytic",
        "t_end": 0.4,
        "alpha0": np.full(3, 0.3322),
        "friction": dp.Friction(),
        "uncertainty": dp.PaperUncertainty(),
    }
    start = robot.inverse_kinematics([0.0, 0.0, -0.35])
    return {
        "design I": dp.simulate(robot, dp.design1(nominal, sampling_period=1e-3), dp.PathI(), **options),
        "LQR": dp.simulate(robot, dp.LQR(nominal, start), dp.PathI(), **options),
    }


def test_plotted_lines_are_the_runs_numbers(runs):
    run = runs["design I"]
    fig = plots.plot_tracking_errors(run)
    np.testing.assert_allclose(
        plots.find_artist(fig, "error_norm").get_ydata(), np.linalg.norm(run.error, axis=1), rtol=1e-12
    )
    np.testing.assert_allclose(
        plots.find_artist(fig, "error_rate_norm").get_ydata(),
        np.linalg.norm(run.error_rate, axis=1),
        rtol=1e-12,
    )
    fig = plots.plot_rho_hat(run)
    np.testing.assert_allclose(plots.find_artist(fig, "rho_hat").get_ydata(), run.internals["rho_hat"][:, 0])
    fig = plots.plot_torques(run)
    np.testing.assert_allclose(plots.find_artist(fig, "tau_2").get_ydata(), run.tau[:, 1])
    fig = plots.plot_error_comparison(runs, log=True)
    np.testing.assert_allclose(
        plots.find_artist(fig, "error:LQR").get_ydata(), np.linalg.norm(runs["LQR"].error, axis=1)
    )


def test_every_figure_saves_as_a_whole_png(runs, tmp_path):
    table = {name: {"path I": {"iae": float(i + 1)}} for i, name in enumerate(runs)}
    grid = np.array([[0.7, 0.8], [0.9, 1.1]])
    figures = {
        "errors": plots.plot_tracking_errors(runs["design I"]),
        "rho": plots.plot_rho_hat(runs["design I"]),
        "torques": plots.plot_torques(runs["design I"]),
        "paths": plots.plot_paths_3d(runs),
        "comparison": plots.plot_error_comparison(runs, rate=True),
        "bars": plots.plot_metric_bars(table, "iae"),
        "surface": plots.plot_rho_surface([0.0, 0.9], [0.0, 0.9], grid, "Δ_m", "Δ_f"),
    }
    for name, fig in figures.items():
        assert isinstance(fig, Figure)
        path = plots.save_figure(fig, tmp_path / "figs" / f"{name}.png")
        data = path.read_bytes()
        assert data.startswith(PNG) and len(data) > 5000, name
    assert sorted(p.name for p in (tmp_path / "figs").iterdir()) == sorted(f"{n}.png" for n in figures)


def test_a_run_without_an_estimate_is_refused_by_name(runs):
    with pytest.raises(dp.InvalidParameterError, match="rho_hat"):
        plots.plot_rho_hat(runs["LQR"])


def test_unknown_file_format_is_refused(runs, tmp_path):
    with pytest.raises(dp.InvalidParameterError, match="xyz"):
        plots.save_figure(plots.plot_torques(runs["LQR"]), tmp_path / "figure.xyz")
    assert list(tmp_path.iterdir()) == []

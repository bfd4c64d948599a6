"""Matplotlib figures of runs (delta_pin.viz.plots): PNGs that are written, not blank, and draw the
run's own numbers; clear errors on bad input; atomic saving."""

import dataclasses
import os
import threading

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")

import matplotlib.image as mpimg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

import delta_pin as dp  # noqa: E402
from delta_pin.errors import DeltaPinError, InvalidParameterError  # noqa: E402
from delta_pin.studies.metrics import compute_metrics  # noqa: E402
from delta_pin.viz.plots import (  # noqa: E402
    METRIC_LABELS,
    controller_label,
    find_artist,
    plot_against_rate,
    plot_error_comparison,
    plot_metric_bars,
    plot_paths_3d,
    plot_rho_hat,
    plot_rho_surface,
    plot_torques,
    plot_tracking_errors,
    plot_trade_off,
    run_label,
    save_figure,
)

T_END = 0.4  # [s] short runs: the figures, not the control, are under test
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def runs(robot):
    """Design I, design II and LQR on path I, design I on path II (analytic plant)."""
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    kw = {
        "plant": "analytic",
        "t_end": T_END,
        "alpha0": np.full(3, 0.3322),
        "friction": dp.Friction(),
        "uncertainty": dp.PaperUncertainty(),
    }
    lqr = dp.LQR(nominal, robot.inverse_kinematics([0, 0, -0.35]))
    return {
        "design I": dp.simulate(robot, dp.design1(nominal, sampling_period=1e-3), dp.PathI(), **kw),
        "design II": dp.simulate(robot, dp.design2(nominal, sampling_period=1e-3), dp.PathI(), **kw),
        "LQR": dp.simulate(robot, lqr, dp.PathI(), **kw),
        "design I, path II": dp.simulate(robot, dp.design1(nominal, sampling_period=1e-3), dp.PathII(), **kw),
    }


@pytest.fixture(scope="module")
def path1(runs):
    return {label: runs[label] for label in ("design I", "design II", "LQR")}


def assert_png(path, min_bytes=5_000):
    """A PNG file of some size whose pixels are not all one colour, and no temporary left over."""
    assert path.is_file()
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE
    assert len(data) > min_bytes
    image = mpimg.imread(path)
    assert image.ndim == 3 and image.shape[0] > 100 and image.shape[1] > 100
    assert image[..., :3].std() > 0.02  # not blank
    assert [p.name for p in path.parent.iterdir() if ".tmp" in p.name] == []


# ------------------------------------------------------------------------------------ labels
def test_labels_come_from_the_metadata(runs):
    assert controller_label(runs["design I"]) == "design I"
    assert controller_label(runs["design II"]) == "design II"
    assert controller_label(runs["LQR"]) == "LQR"
    assert run_label(runs["design I, path II"]) == "design I, path II"
    no_comp = dataclasses.replace(
        runs["LQR"],
        metadata={**runs["LQR"].metadata, "controller": {"name": "lqr", "friction_compensation": False}},
    )
    assert controller_label(no_comp) == "LQR (no friction comp.)"
    assert controller_label(dataclasses.replace(runs["LQR"], metadata={})) == "controller"


# ------------------------------------------------------------------------------ one-run figures
def test_tracking_errors_draw_the_error_norms(runs, tmp_path):
    run = runs["design I"]
    fig = plot_tracking_errors(run)
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    line_r = find_artist(fig, "error_norm")
    line_rdot = find_artist(fig, "error_rate_norm")
    np.testing.assert_allclose(line_r.get_xdata(), run.t, rtol=0, atol=0)
    np.testing.assert_allclose(line_r.get_ydata(), np.linalg.norm(run.error, axis=1), rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        line_rdot.get_ydata(), np.linalg.norm(run.error_rate, axis=1), rtol=0, atol=1e-12
    )
    ax_r, ax_rdot = fig.axes
    assert "[rad]" in ax_r.get_ylabel() and "[rad/s]" in ax_rdot.get_ylabel()
    assert "[s]" in ax_rdot.get_xlabel()
    assert "design I" in ax_r.get_title()
    assert_png(save_figure(fig, tmp_path / "fig6.png"))


def test_tracking_errors_on_given_axes(runs, tmp_path):
    run = runs["design II"]
    fig = Figure()
    ax = fig.add_subplot()
    assert plot_tracking_errors(run, ax=ax) is fig
    assert len(fig.axes) == 2  # ax and its twin
    assert find_artist(fig, "error_norm").axes is ax
    fig2 = Figure()
    pair = fig2.subplots(1, 2)
    plot_tracking_errors(run, ax=pair)
    assert find_artist(fig2, "error_rate_norm").axes is pair[1]
    with pytest.raises(InvalidParameterError, match="ax"):
        plot_tracking_errors(run, ax="left")
    assert_png(save_figure(fig, tmp_path / "twin.png"))


def test_rho_hat_draws_the_estimate(runs, tmp_path):
    run = runs["design I"]
    fig = plot_rho_hat(run)
    line = find_artist(fig, "rho_hat")
    np.testing.assert_allclose(line.get_ydata(), run.internals["rho_hat"][:, 0], rtol=0, atol=1e-12)
    peak = find_artist(fig, "rho_hat_max")
    assert peak.get_ydata()[0] == pytest.approx(compute_metrics(run).rho_hat_max, abs=1e-12)
    ax = fig.axes[0]
    assert "rho" in ax.get_ylabel() and "[s]" in ax.get_xlabel() and "design I" in ax.get_title()
    assert_png(save_figure(fig, tmp_path / "fig7.png"))


def test_rho_hat_vector_draws_components_and_norm(runs):
    run = runs["design II"]
    rho = np.column_stack([run.internals["rho_hat"][:, 0] * k for k in (1.0, 0.5, 0.25)])
    vector_run = dataclasses.replace(run, internals={**run.internals, "rho_hat": rho})
    fig = plot_rho_hat(vector_run)
    for i in range(3):
        np.testing.assert_allclose(find_artist(fig, f"rho_hat_{i + 1}").get_ydata(), rho[:, i], atol=1e-12)
    np.testing.assert_allclose(
        find_artist(fig, "rho_hat").get_ydata(), np.linalg.norm(rho, axis=1), atol=1e-12
    )


def test_rho_hat_of_a_run_without_it_is_a_clear_error(runs):
    with pytest.raises(InvalidParameterError, match="rho_hat") as info:
        plot_rho_hat(runs["LQR"])
    assert isinstance(info.value, ValueError) and isinstance(info.value, DeltaPinError)
    assert "LQR" in str(info.value)


def test_torques_draw_the_three_torques(runs, tmp_path):
    run = runs["design I"]
    fig = plot_torques(run)
    for i in range(3):
        np.testing.assert_allclose(find_artist(fig, f"tau_{i + 1}").get_ydata(), run.tau[:, i], atol=1e-12)
    ax = fig.axes[0]
    assert "[N·m]" in ax.get_ylabel()
    assert len(ax.get_legend().get_texts()) == 3
    assert_png(save_figure(fig, tmp_path / "fig8.png"))


# ------------------------------------------------------------------------------ comparison figures
@pytest.mark.parametrize("unit, scale", [("mm", 1e3), ("m", 1.0)])
def test_paths_3d_draw_desired_once_and_each_run(path1, tmp_path, unit, scale):
    fig = plot_paths_3d(path1, unit=unit)
    ax = fig.axes[0]
    assert ax.name == "3d"
    desired = [line for line in ax.get_lines() if line.get_gid() == "path_desired"]
    assert len(desired) == 1
    x, y, z = desired[0].get_data_3d()
    np.testing.assert_allclose(np.column_stack([x, y, z]), path1["design I"].xyz_d * scale, atol=1e-12)
    for label, run in path1.items():
        x, y, z = find_artist(fig, f"path:{label}").get_data_3d()
        np.testing.assert_allclose(np.column_stack([x, y, z]), run.xyz * scale, atol=1e-12)
    assert f"[{unit}]" in ax.get_xlabel() and f"[{unit}]" in ax.get_zlabel()
    assert "path I" in ax.get_title()
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert {"desired", *path1} <= set(legend)
    assert_png(save_figure(fig, tmp_path / f"fig20_{unit}.png"))


def test_paths_3d_rejects_bad_input(path1):
    with pytest.raises(InvalidParameterError, match="non-empty"):
        plot_paths_3d({})
    with pytest.raises(InvalidParameterError, match="unit"):
        plot_paths_3d(path1, unit="in")
    with pytest.raises(InvalidParameterError, match="3-D"):
        plot_paths_3d(path1, ax=Figure().add_subplot())
    with pytest.raises(InvalidParameterError, match="Run"):
        plot_paths_3d({"x": np.zeros((3, 3))})


@pytest.mark.parametrize("rate", [False, True])
def test_error_comparison_draws_each_run(path1, tmp_path, rate):
    fig = plot_error_comparison(path1, rate=rate, log=True)
    ax = fig.axes[0]
    for label, run in path1.items():
        expected = np.linalg.norm(run.error_rate if rate else run.error, axis=1)
        np.testing.assert_allclose(find_artist(fig, f"error:{label}").get_ydata(), expected, atol=1e-12)
    assert ax.get_yscale() == "log"
    assert ("[rad/s]" if rate else "[rad]") in ax.get_ylabel()
    assert [t.get_text() for t in ax.get_legend().get_texts()] == list(path1)
    assert_png(save_figure(fig, tmp_path / f"fig22_{rate}.png"))
    assert plot_error_comparison(path1).axes[0].get_yscale() == "linear"


def test_metric_bars_from_numbers_and_from_metrics(runs, tmp_path):
    table = {
        "design I": {
            "path I": compute_metrics(runs["design I"]),
            "path II": compute_metrics(runs["design I, path II"]),
        },
        "design II": {"path I": compute_metrics(runs["design II"])},  # no path II: a gap
        "LQR": {"path I": compute_metrics(runs["LQR"]).as_dict()},
    }
    fig = plot_metric_bars(table, "iae")
    ax = fig.axes[0]
    assert find_artist(fig, "bar:design I:path I").get_height() == pytest.approx(
        compute_metrics(runs["design I"]).iae, abs=1e-12
    )
    assert find_artist(fig, "bar:design I:path II").get_height() == pytest.approx(
        compute_metrics(runs["design I, path II"]).iae, abs=1e-12
    )
    assert find_artist(fig, "bar:LQR:path I").get_height() == pytest.approx(compute_metrics(runs["LQR"]).iae)
    assert not find_artist(fig, "bar:design II:path II").get_visible()
    assert [t.get_text() for t in ax.get_xticklabels()] == ["design I", "design II", "LQR"]
    assert [c.get_label() for c in ax.containers] == ["path I", "path II"]
    assert METRIC_LABELS["iae"][1] in ax.get_ylabel() and "IAE" in ax.get_title()
    assert_png(save_figure(fig, tmp_path / "fig26.png"))

    numbers = {"design I": {"S": 62262.0}, "design II": {"S": 62197.0}}
    fig = plot_metric_bars(numbers, "control_effort_sum", log=True, title="Fig. 18")
    assert find_artist(fig, "bar:design II:S").get_height() == 62197.0
    assert fig.axes[0].get_yscale() == "log" and fig.axes[0].get_title() == "Fig. 18"
    assert_png(save_figure(fig, tmp_path / "fig18.png"))

    # rho_hat_max of an LQR run is None: a gap, not an error
    fig = plot_metric_bars(
        {"LQR": {"path I": compute_metrics(runs["LQR"])}, "design I": {"path I": 1.0}}, "rho_hat_max"
    )
    assert not find_artist(fig, "bar:LQR:path I").get_visible()


def test_metric_bars_reject_bad_tables():
    with pytest.raises(InvalidParameterError, match="non-empty"):
        plot_metric_bars({}, "iae")
    with pytest.raises(InvalidParameterError, match="dict"):
        plot_metric_bars({"a": 1.0}, "iae")
    with pytest.raises(InvalidParameterError, match="no metric 'iae'"):
        plot_metric_bars({"a": {"b": {"ise": 1.0}}}, "iae")
    with pytest.raises(InvalidParameterError, match="not a number"):
        plot_metric_bars({"a": {"b": "fast"}}, "iae")


# --------------------------------------------------------------------------- sensitivity surfaces
@pytest.mark.parametrize("kind", ["surface", "contour"])
@pytest.mark.parametrize("n", [3, 11])
def test_rho_surface_coarse_and_fine(tmp_path, kind, n):
    x = np.linspace(0.0, 1.0, n)
    y = np.linspace(0.0, 2.0, n + 1)  # a non-square grid pins the indexing
    grid = 0.5 + 0.3 * x[:, None] + 0.1 * y[None, :] ** 2
    fig = plot_rho_surface(x, y, grid, r"$\Delta_m$", r"$\Delta_f$", kind=kind)
    ax = fig.axes[0]
    assert ax.name == ("3d" if kind == "surface" else "rectilinear")
    assert len(fig.axes) == 2  # the plot and its colorbar
    assert ax.get_xlabel() == r"$\Delta_m$" and ax.get_ylabel() == r"$\Delta_f$"
    nodes = find_artist(fig, "rho_nodes")
    assert len(nodes.get_offsets()) == grid.size
    n_labels = sum(1 for t in ax.texts if t.get_text()) if kind == "surface" else len(ax.texts)
    assert n_labels == (grid.size if grid.size <= 25 else 0)
    if kind == "contour":
        np.testing.assert_allclose(np.sort(nodes.get_offsets()[:, 0]), np.sort(np.repeat(x, len(y))))
    assert_png(save_figure(fig, tmp_path / f"rho_{kind}_{n}.png"))


def test_rho_surface_indexing_and_holes(tmp_path):
    x, y = np.array([0.0, 0.5, 1.0]), np.array([0.0, 1.0])
    grid_ij = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, np.nan]])
    fig_ij = plot_rho_surface(x, y, grid_ij, "a", "b", kind="contour")
    fig_xy = plot_rho_surface(x, y, grid_ij.T, "a", "b", kind="contour", indexing="xy")
    texts = sorted(t.get_text() for t in fig_ij.axes[0].texts)
    assert texts == sorted(t.get_text() for t in fig_xy.axes[0].texts) == ["1", "2", "3", "4", "5"]
    assert len(find_artist(fig_ij, "rho_nodes").get_offsets()) == 5  # the NaN node is not marked
    assert_png(save_figure(fig_ij, tmp_path / "hole.png"))
    with pytest.raises(InvalidParameterError, match="shape"):
        plot_rho_surface(x, y, grid_ij.T, "a", "b")
    with pytest.raises(InvalidParameterError, match="kind"):
        plot_rho_surface(x, y, grid_ij, "a", "b", kind="heatmap")
    with pytest.raises(InvalidParameterError, match="finite"):
        plot_rho_surface(x, y, np.full((3, 2), np.nan), "a", "b")
    with pytest.raises(InvalidParameterError, match="2-D"):
        plot_rho_surface(x, y, grid_ij, "a", "b", kind="contour", ax=Figure().add_subplot(projection="3d"))
    # a constant grid still gets a colour scale
    assert_png(save_figure(plot_rho_surface(x, y, np.ones((3, 2)), "a", "b"), tmp_path / "flat.png"))


# ------------------------------------------------------------------------------------------ saving
def test_save_figure_is_atomic_and_creates_folders(runs, tmp_path, monkeypatch):
    target = tmp_path / "deep" / "er" / "fig.png"
    assert save_figure(plot_torques(runs["LQR"]), target, dpi=60) == target
    assert_png(target)
    old = target.read_bytes()

    # a failing write leaves the old file as it was and no temporary behind
    fig = plot_torques(runs["design I"])

    def boom(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(fig, "savefig", boom)
    with pytest.raises(RuntimeError, match="disk full"):
        save_figure(fig, target)
    assert target.read_bytes() == old
    assert sorted(os.listdir(target.parent)) == ["fig.png"]

    with pytest.raises(InvalidParameterError, match="format"):
        save_figure(plot_torques(runs["LQR"]), tmp_path / "fig.xyz")
    with pytest.raises(InvalidParameterError, match="Figure"):
        save_figure(None, tmp_path / "none.png")
    assert save_figure(plot_torques(runs["LQR"]), tmp_path / "fig.svg").read_bytes().lstrip().startswith(b"<")


def test_figures_are_headless_and_thread_safe(runs, tmp_path):
    """No pyplot figure is created; four threads draw and save at once."""
    import sys

    pyplot = sys.modules.get("matplotlib.pyplot")
    before = len(pyplot.get_fignums()) if pyplot else 0
    errors = []

    def work(i):
        try:
            save_figure(plot_tracking_errors(runs["design I"]), tmp_path / f"t{i}.png", dpi=50)
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    assert all((tmp_path / f"t{i}.png").read_bytes()[:8] == PNG_SIGNATURE for i in range(4))
    pyplot = sys.modules.get("matplotlib.pyplot")
    assert (len(pyplot.get_fignums()) if pyplot else 0) == before


RATE_ROWS = [
    {"controller": "A", "rate_hz": 1000.0, "metric": 3e-4, "diverged_at": None},
    {"controller": "A", "rate_hz": 4000.0, "metric": 1e-4, "diverged_at": None},
    {"controller": "B", "rate_hz": 1000.0, "metric": None, "diverged_at": 0.02},
    {"controller": "B", "rate_hz": 4000.0, "metric": 2e-4, "diverged_at": None},
]


def test_plot_against_rate_draws_each_controller_its_divergences_and_the_reference():
    fig = plot_against_rate(RATE_ROWS, "metric", reference={"continuous": 5e-5})
    line = find_artist(fig, "rate:A")
    np.testing.assert_array_equal(line.get_xdata(), [1000.0, 4000.0])
    np.testing.assert_array_equal(line.get_ydata(), [3e-4, 1e-4])
    np.testing.assert_array_equal(find_artist(fig, "rate:B").get_xdata(), [4000.0])
    marker = find_artist(fig, "diverged:B")
    np.testing.assert_array_equal(marker.get_xdata(), [1000.0])
    assert marker.get_ydata()[0] > 3e-4  # above every kept value
    assert find_artist(fig, "reference:continuous").get_ydata()[0] == 5e-5
    ax = fig.axes[0]
    assert ax.get_xscale() == ax.get_yscale() == "log"
    assert any(text.get_text() == "0.02 s" for text in ax.texts)


def test_plot_trade_off_pairs_roughness_and_error_per_gain():
    rows = [
        {"controller": "C", "gain": "k", "value": 1.0, "max_joint_error_last_5s": 1e-3,
         "torque_increment_rms_last_5s": 0.01, "diverged_at": None},
        {"controller": "C", "gain": "k", "value": 2.0, "max_joint_error_last_5s": 5e-4,
         "torque_increment_rms_last_5s": 0.05, "diverged_at": None},
        {"controller": "C", "gain": "k", "value": 4.0, "diverged_at": 0.1},
    ]  # fmt: skip
    fig = plot_trade_off(rows)
    line = find_artist(fig, "trade-off:C")
    np.testing.assert_array_equal(line.get_xdata(), [0.01, 0.05])
    np.testing.assert_array_equal(line.get_ydata(), [1e-3, 5e-4])
    # the diverged gains in the legend (a title listing them was clipped at the figure's edge)
    legend = [text.get_text() for text in fig.axes[0].get_legend().get_texts()]
    assert "C: diverged at k=4" in legend and "diverged" not in fig.axes[0].get_title()


def test_diverged_marks_of_controllers_at_one_rate_do_not_pile_up():
    """Fig. 30 drew the x of every controller that diverged at 1 kHz at one point (only the last
    one visible): each controller's marks now have a row of their own, DIVERGED_ROW_STEP apart."""
    from delta_pin.viz.plots import DIVERGED_ROW_STEP

    rows = [*RATE_ROWS, {"controller": "C", "rate_hz": 1000.0, "metric": None, "diverged_at": 0.05}]
    fig = plot_against_rate(rows, "metric")
    b, c = find_artist(fig, "diverged:B").get_ydata()[0], find_artist(fig, "diverged:C").get_ydata()[0]
    assert c / b == pytest.approx(DIVERGED_ROW_STEP, rel=1e-12)


def test_the_error_comparison_s_legend_is_beside_the_curves(path1):
    """Fig. 22's legend sat on the curves (loc="best" on curves that fill the axes): it is now
    outside the axes, to their right (checked on the rendered figure)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = plot_error_comparison(path1, log=True)
    FigureCanvasAgg(fig).draw()
    ax = fig.axes[0]
    assert ax.get_legend().get_window_extent().x0 >= ax.get_window_extent().x1


def test_rate_plots_refuse_rows_without_a_rate():
    with pytest.raises(InvalidParameterError, match="rate_hz"):
        plot_against_rate([{"controller": "A", "metric": 1.0}], "metric")
    with pytest.raises(InvalidParameterError, match="non-empty"):
        plot_against_rate([], "metric")

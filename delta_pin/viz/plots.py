"""Matplotlib figures of runs (the paper's Section V, Figs. 6-29), headless.

Every figure is built on a bare :class:`matplotlib.figure.Figure` -- no pyplot state, no GUI
backend, no ``plt.show()`` -- so the functions are safe in scripts, tests, servers and threads.
Each ``plot_*`` function takes data (a :class:`~delta_pin.sim.runner.Run`, a dict of runs, a table
of numbers) plus an optional ``ax`` to draw into, and returns the :class:`~matplotlib.figure.Figure`
that holds the drawing (a new one when no ``ax`` is given). :func:`save_figure` writes it to a
PNG atomically.

Which figure of the paper each function draws:

=========================  ================================================================
``plot_tracking_errors``   ||r(t)|| and ||r_dot(t)|| of one run (Figs. 6, 12)
``plot_rho_hat``           the adaptive parameter rho_hat(t) (Figs. 7, 13)
``plot_torques``           tau_1..tau_3 (Figs. 8, 14)
``plot_rho_surface``       rho_hat_max over a grid of uncertainty magnitudes (Figs. 9-11, 15-17)
``plot_metric_bars``       grouped bars of S, wall time, IAE, ISE (Figs. 18, 19, 26-29)
``plot_paths_3d``          desired and actual end-effector paths in 3-D (Figs. 20, 21)
``plot_error_comparison``  ||r|| (or ||r_dot||) of several controllers (Figs. 22-25)
=========================  ================================================================

The key lines carry a ``gid`` (e.g. ``"error_norm"``, ``"rho_hat"``, ``"tau_1"``,
``"path_desired"``, ``"path:<label>"``) so that a caller or a test can find them with
:func:`find_artist`.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from delta_pin.control.registry import label as controller_name
from delta_pin.errors import InvalidParameterError
from delta_pin.sim.run import Run
from delta_pin.utils.atomic import atomic_open

__all__ = [
    "METRIC_LABELS",
    "controller_label",
    "find_artist",
    "plot_against_rate",
    "plot_error_comparison",
    "plot_metric_bars",
    "plot_paths_3d",
    "plot_rho_hat",
    "plot_rho_surface",
    "plot_torques",
    "plot_tracking_errors",
    "plot_trade_off",
    "run_label",
    "save_figure",
]

# (name on the axis, unit) of the indices of delta_pin.studies.metrics.RunMetrics
METRIC_LABELS: dict[str, tuple[str, str]] = {
    "iae": ("IAE = ∫‖r‖ dt", "rad·s"),
    "ise": ("ISE = ∫‖r‖² dt", "rad²·s"),
    "control_effort": ("S = ∫‖τ‖ dt", "N·m·s"),
    "control_effort_sum": ("S = Σₖ‖τₖ‖", "N·m"),
    "wall_time": ("wall time", "s"),
    "rho_hat_max": (r"$\hat{\rho}_{max}$", ""),
    "rho_hat_final": (r"$\hat{\rho}(T)$", ""),
    "max_task_error_mm_last_5s": ("max task-space error, last 5 s", "mm"),
    "max_joint_error_last_5s": ("max ‖r‖, last 5 s", "rad"),
    "torque_increment_rms_last_5s": ("RMS ‖τₖ − τₖ₋₁‖, last 5 s", "N·m"),
}

_R_NORM = r"$\|r\|$"
_RDOT_NORM = r"$\|\dot{r}\|$"
_RHO_HAT = r"$\hat{\rho}$"
_DESIRED_STYLE = {"color": "black", "linestyle": "--", "linewidth": 1.2}


# ------------------------------------------------------------------------------------------ labels
def controller_label(run: Run) -> str:
    """A short name of the run's controller from its metadata: ``"design I"``, ``"LQR"``, ...,
    with ``" (no friction comp.)"`` when friction compensation was off."""
    meta = run.metadata.get("controller") or {}
    name = meta.get("name")
    label = controller_name(name)
    if meta.get("friction_compensation") is False:
        label += " (no friction comp.)"
    return label


def run_label(run: Run) -> str:
    """``"<controller>, <path>"`` (e.g. ``"design I, path I"``) from the run's metadata."""
    trajectory = run.metadata.get("trajectory") or {}
    path = trajectory.get("name")
    return f"{controller_label(run)}, {path}" if path else controller_label(run)


def _common_path_name(runs: Mapping[str, Run]) -> str | None:
    names = {(run.metadata.get("trajectory") or {}).get("name") for run in runs.values()}
    return names.pop() if len(names) == 1 else None


def find_artist(fig: Figure, gid: str):
    """The first artist of ``fig`` (over all its axes) whose gid is ``gid``.

    Raises:
        KeyError: no artist has that gid.
    """
    for ax in fig.axes:
        for artist in ax.get_children():
            if artist.get_gid() == gid:
                return artist
    raise KeyError(f"no artist with gid {gid!r} in the figure")


# ----------------------------------------------------------------------------------------- helpers
def _new_axes(ax: Axes | None, figsize: tuple[float, float], projection: str | None = None):
    """(figure, axes): ``ax`` and its figure, or a new headless figure with one axes."""
    if ax is not None:
        if not isinstance(ax, Axes):
            raise InvalidParameterError(f"ax must be a matplotlib Axes, got {type(ax).__name__}")
        if projection == "3d" and getattr(ax, "name", None) != "3d":
            raise InvalidParameterError(
                "ax must be a 3-D axes (fig.add_subplot(projection='3d')), "
                f"got a {getattr(ax, 'name', type(ax).__name__)!r} axes"
            )
        return ax.figure, ax
    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.add_subplot(projection=projection)


def _check_run(run: Any, what: str = "run") -> Run:
    if not isinstance(run, Run):
        raise InvalidParameterError(f"{what} must be a delta_pin Run, got {type(run).__name__}")
    if len(run.t) == 0:
        raise InvalidParameterError(f"{what} has no samples")
    return run


def _check_runs(runs: Any) -> dict[str, Run]:
    if not isinstance(runs, Mapping) or not runs:
        raise InvalidParameterError("runs must be a non-empty dict {label: Run}")
    return {str(label): _check_run(run, f"run {label!r}") for label, run in runs.items()}


def _linewidth(i: int) -> float:
    """Thinner lines for later runs, so that a run drawn over an earlier one leaves it visible."""
    return max(0.8, 2.2 - 0.5 * i)


def _time_axis(ax: Axes, run: Run) -> None:
    ax.set_xlabel("time t [s]")
    ax.set_xlim(run.t[0], run.t[-1])
    ax.grid(True, alpha=0.3)


# -------------------------------------------------------------------------------- one-run figures
def plot_tracking_errors(run: Run, ax: Axes | Sequence[Axes] | None = None) -> Figure:
    """||r(t)|| [rad] and ||r_dot(t)|| [rad/s] of one run (Figs. 6, 12).

    Args:
        run: the run (r = alpha - alpha^d, r_dot = alpha_dot - alpha_dot^d).
        ax: None (a new figure with two stacked panels sharing the time axis), one Axes (||r|| on
            its left y axis, ||r_dot|| on a twin right y axis), or a pair of Axes (one per norm).

    Returns:
        The figure; the two lines have gids ``"error_norm"`` and ``"error_rate_norm"``.
    """
    run = _check_run(run)
    e = np.linalg.norm(run.error, axis=1)
    e_dot = np.linalg.norm(run.error_rate, axis=1)
    twin = False
    if ax is None:
        fig = Figure(figsize=(7.0, 5.0), layout="constrained")
        ax_r, ax_rdot = fig.subplots(2, 1, sharex=True)
    elif isinstance(ax, Axes):
        fig, ax_r = ax.figure, ax
        ax_rdot = ax.twinx()
        twin = True
    elif (
        isinstance(ax, (Sequence, np.ndarray))
        and np.size(ax) == 2
        and all(isinstance(a, Axes) for a in np.ravel(np.asarray(ax, dtype=object)))
    ):  # a pair: a list, a tuple, or the array fig.subplots(1, 2) returns
        ax_r, ax_rdot = np.ravel(np.asarray(ax, dtype=object))
        fig = ax_r.figure
    else:
        raise InvalidParameterError("ax must be None, one Axes, or a pair of Axes")

    (line_r,) = ax_r.plot(run.t, e, color="C0", label=_R_NORM, gid="error_norm")
    (line_rdot,) = ax_rdot.plot(run.t, e_dot, color="C1", label=_RDOT_NORM, gid="error_rate_norm")
    ax_r.set_ylabel(f"{_R_NORM} [rad]")
    ax_rdot.set_ylabel(f"{_RDOT_NORM} [rad/s]")
    _time_axis(ax_r, run)
    title = f"Joint tracking errors — {run_label(run)}"
    if twin:
        ax_r.set_title(title)
        ax_r.legend(handles=[line_r, line_rdot], loc="upper right")
        ax_rdot.grid(False)
        ax_r.yaxis.label.set_color("C0")
        ax_rdot.yaxis.label.set_color("C1")
    else:
        _time_axis(ax_rdot, run)
        ax_r.set_xlabel("")
        ax_r.set_title(title)
        ax_r.legend(loc="upper right")
        ax_rdot.legend(loc="upper right")
    return fig


def plot_rho_hat(run: Run, ax: Axes | None = None) -> Figure:
    """The adaptive parameter rho_hat(t) of an adaptive robust run (Figs. 7, 13).

    A scalar rho_hat (N, 1) is drawn as one line (gid ``"rho_hat"``); a vector one (N, k) as its
    components (gids ``"rho_hat_1"``...) and its norm (gid ``"rho_hat"``). The maximum
    rho_hat_max = max_t ||rho_hat|| is marked.

    Raises:
        InvalidParameterError: the run has no ``rho_hat`` internal (e.g. an LQR or CTC run).
    """
    run = _check_run(run)
    rho = run.internals.get("rho_hat")
    if rho is None:
        raise InvalidParameterError(
            f"the run of {controller_label(run)!r} has no 'rho_hat' internal (it has "
            f"{sorted(run.internals) or 'none'}): only the adaptive robust designs I and II estimate rho"
        )
    rho = np.reshape(np.asarray(rho, dtype=float), (len(run.t), -1))
    fig, ax = _new_axes(ax, (7.0, 3.6))
    norm = np.linalg.norm(rho, axis=1)
    if rho.shape[1] == 1:
        ax.plot(run.t, rho[:, 0], color="C0", label=_RHO_HAT, gid="rho_hat")
    else:
        for i in range(rho.shape[1]):
            ax.plot(run.t, rho[:, i], linewidth=1.0, label=rf"$\hat{{\rho}}_{i + 1}$", gid=f"rho_hat_{i + 1}")
        ax.plot(run.t, norm, color="black", label=rf"$\|{_RHO_HAT[1:-1]}\|$", gid="rho_hat")
    k = int(np.argmax(norm))
    ax.plot(
        run.t[k],
        norm[k],
        "o",
        color="C3",
        gid="rho_hat_max",
        label=rf"$\hat{{\rho}}_{{max}}$ = {norm[k]:.3g} at t = {run.t[k]:.3g} s",
    )
    ax.set_ylabel(f"{_RHO_HAT} [–]")
    _time_axis(ax, run)
    ax.set_title(f"Adaptive parameter {_RHO_HAT}(t) — {run_label(run)}")
    ax.legend(loc="best")
    return fig


def plot_torques(run: Run, ax: Axes | None = None) -> Figure:
    """The motor torques tau_1, tau_2, tau_3 [N·m] vs time (Figs. 8, 14); gids ``"tau_1"``..."""
    run = _check_run(run)
    fig, ax = _new_axes(ax, (7.0, 3.6))
    for i in range(run.tau.shape[1]):
        ax.plot(run.t, run.tau[:, i], linewidth=1.0, label=rf"$\tau_{i + 1}$", gid=f"tau_{i + 1}")
    ax.set_ylabel(r"torque $\tau$ [N·m]")
    _time_axis(ax, run)
    ax.set_title(f"Control torques — {run_label(run)}")
    ax.legend(loc="best", ncols=3)
    return fig


# ------------------------------------------------------------------------------ comparison figures
def plot_paths_3d(runs: Mapping[str, Run], ax: Axes | None = None, unit: str = "mm") -> Figure:
    """The desired end-effector path (once, from the first run) and each run's actual path, in 3-D
    (Figs. 20, 21).

    Args:
        runs: ``{legend label: Run}``.
        ax: a 3-D axes (``fig.add_subplot(projection="3d")``) or None for a new figure.
        unit: ``"mm"`` or ``"m"`` for the axes.

    Returns:
        The figure; the desired path has gid ``"path_desired"``, each run's ``"path:<label>"``.
    """
    runs = _check_runs(runs)
    scales = {"mm": 1e3, "m": 1.0}
    if unit not in scales:
        raise InvalidParameterError(f"unit must be 'mm' or 'm', got {unit!r}")
    scale = scales[unit]
    fig, ax = _new_axes(ax, (7.0, 6.0), projection="3d")
    first = next(iter(runs.values()))
    desired = first.xyz_d * scale
    ax.plot(*desired.T, label="desired", gid="path_desired", **_DESIRED_STYLE)
    points = [desired]
    for i, (label, run) in enumerate(runs.items()):
        xyz = run.xyz * scale
        ax.plot(*xyz.T, color=f"C{i}", linewidth=_linewidth(i), label=label, gid=f"path:{label}")
        ax.scatter(*xyz[0], color=f"C{i}", marker="o", s=18)
        points.append(xyz)
    ax.scatter(*desired[0], color="black", marker="x", s=30, label="start (desired)")

    # equal-ish aspect: the box follows the data ranges, no side below half of the longest
    allpts = np.concatenate(points)
    lo, hi = allpts.min(axis=0), allpts.max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    pad = 0.05 * span.max()
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_zlim(lo[2] - pad, hi[2] + pad)
    ax.set_box_aspect(tuple(np.maximum(span + 2 * pad, 0.5 * (span.max() + 2 * pad))), zoom=0.9)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(5))
    ax.set_xlabel(f"x [{unit}]")
    ax.set_ylabel(f"y [{unit}]")
    ax.tick_params(axis="z", pad=6)  # keeps the minus signs clear of the tick marks
    ax.set_zlabel(f"z [{unit}]", labelpad=12)
    path = _common_path_name(runs)
    ax.set_title("End-effector paths" + (f" — {path}" if path else ""))
    ax.legend(loc="upper left", fontsize="small")
    return fig


def plot_error_comparison(
    runs: Mapping[str, Run], ax: Axes | None = None, rate: bool = False, log: bool = False
) -> Figure:
    """||r(t)|| (or ||r_dot(t)|| with ``rate=True``) of several runs on one axes (Figs. 22-25).

    Args:
        runs: ``{legend label: Run}``.
        ax: an Axes or None for a new figure.
        rate: plot ||r_dot|| [rad/s] instead of ||r|| [rad].
        log: logarithmic y axis (the designs' errors are orders of magnitude below LQR's).

    Returns:
        The figure; each run's line has gid ``"error:<label>"``.
    """
    runs = _check_runs(runs)
    fig, ax = _new_axes(ax, (8.0, 3.8))
    symbol, unit = (_RDOT_NORM, "rad/s") if rate else (_R_NORM, "rad")
    t0, t1 = math.inf, -math.inf
    for i, (label, run) in enumerate(runs.items()):
        values = np.linalg.norm(run.error_rate if rate else run.error, axis=1)
        ax.plot(run.t, values, color=f"C{i}", linewidth=_linewidth(i), label=label, gid=f"error:{label}")
        t0, t1 = min(t0, run.t[0]), max(t1, run.t[-1])
    if log:
        ax.set_yscale("log")
    ax.set_xlim(t0, t1)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(f"{symbol} [{unit}]")
    ax.grid(True, which="both" if log else "major", alpha=0.3)
    path = _common_path_name(runs)
    ax.set_title(f"Tracking error {symbol} by controller" + (f" — {path}" if path else ""))
    # beside the axes: the curves fill the whole time axis, so any place inside covers some
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5))
    return fig


def _metric_value(entry: Any, metric: str, where: str) -> float:
    """A number from a table cell: a number itself, or ``metric`` of a mapping / RunMetrics."""
    if entry is None:
        return math.nan
    if isinstance(entry, Mapping):
        if metric not in entry:
            raise InvalidParameterError(f"{where} has no metric {metric!r} (it has {sorted(entry)})")
        entry = entry[metric]
    elif not isinstance(entry, (int, float, np.number)) and hasattr(entry, metric):
        entry = getattr(entry, metric)
    if entry is None:
        return math.nan
    try:
        return float(entry)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{where}: {entry!r} is not a number") from None


def plot_metric_bars(
    table: Mapping[str, Mapping[str, Any]],
    metric: str,
    ax: Axes | None = None,
    log: bool = False,
    title: str | None = None,
) -> Figure:
    """Grouped bars of one index (Figs. 18, 19, 26-29): ``table[group][series]``.

    The outer keys are the groups along the x axis (e.g. controllers), the inner keys the bars of
    each group, one colour each with a legend (e.g. path I / path II). A cell is a number (the
    value of ``metric``), or a dict / :class:`~delta_pin.studies.metrics.RunMetrics` from which ``metric``
    is read; None or NaN leaves a gap. Each bar is labelled with its value.

    Args:
        table: ``{group: {series: value}}``.
        metric: the index, a key of :data:`METRIC_LABELS` (``"iae"``, ``"ise"``,
            ``"control_effort"``, ``"control_effort_sum"``, ``"wall_time"``, ...) for a name and unit
            on the axis, or any other name (used as is).
        ax: an Axes or None for a new figure.
        log: logarithmic value axis.
        title: the title; by default the metric's name.

    Returns:
        The figure; the bar of group ``g`` and series ``s`` has gid ``"bar:<g>:<s>"`` (and the bars
        of series ``s`` form the BarContainer of ``ax.containers`` labelled ``s``).
    """
    if not isinstance(table, Mapping) or not table:
        raise InvalidParameterError("table must be a non-empty dict {group: {series: value}}")
    groups = [str(g) for g in table]
    series: list[str] = []
    for group, row in table.items():
        if not isinstance(row, Mapping):
            raise InvalidParameterError(f"table[{group!r}] must be a dict {{series: value}}")
        series.extend(str(s) for s in row if str(s) not in series)
    if not series:
        raise InvalidParameterError("table has no values")
    values = np.array(
        [
            [
                _metric_value({str(k): v for k, v in row.items()}.get(s), metric, f"table[{group!r}][{s!r}]")
                for s in series
            ]
            for group, row in table.items()
        ]
    )
    name, unit = METRIC_LABELS.get(metric, (metric, ""))
    fig, ax = _new_axes(ax, (max(5.0, 1.2 + 1.1 * len(groups) * max(1, len(series)) ** 0.5), 3.8))
    x = np.arange(len(groups))
    width = 0.8 / len(series)
    for j, s in enumerate(series):
        heights = values[:, j]
        bars = ax.bar(
            x + (j - (len(series) - 1) / 2) * width,
            np.nan_to_num(heights, nan=0.0),
            width,
            color=f"C{j}",
            label=s,
            edgecolor="black",
            linewidth=0.5,
        )
        for group, patch, h in zip(groups, bars.patches, heights):
            patch.set_gid(f"bar:{group}:{s}")
            if not np.isfinite(h):
                patch.set_visible(False)
        ax.bar_label(bars, labels=[f"{h:.4g}" if np.isfinite(h) else "" for h in heights], fontsize=8)
    ax.set_xticks(x, groups)
    if log:
        ax.set_yscale("log")
    else:
        finite = values[np.isfinite(values)]
        if finite.size and finite.max() > 0:
            ax.set_ylim(0, finite.max() * 1.15)  # room for the value labels
    ax.set_ylabel(f"{name} [{unit}]" if unit else name)
    ax.grid(True, axis="y", alpha=0.3)
    ax.set_axisbelow(True)
    ax.set_title(title if title is not None else name)
    if len(series) > 1 or series[0] != "":
        ax.legend(loc="best", fontsize="small")
    return fig


# --------------------------------------------------------------------------- sensitivity surfaces
def plot_rho_surface(
    x_values: Sequence[float],
    y_values: Sequence[float],
    rho_max_grid: Any,
    x_label: str,
    y_label: str,
    ax: Axes | None = None,
    kind: str = "surface",
    indexing: str = "ij",
    z_label: str = r"$\hat{\rho}_{max}$",
    title: str | None = None,
) -> Figure:
    """rho_hat_max over a 2-D grid of uncertainty magnitudes (Figs. 9-11, 15-17).

    Args:
        x_values, y_values: the grid's values along each axis (e.g. Δ_m and Δ_fc).
        rho_max_grid: the values; with ``indexing="ij"`` (default) of shape
            (len(x_values), len(y_values)), cell [i, j] at (x_values[i], y_values[j]); with
            ``indexing="xy"`` the transpose (rows along y, matplotlib's convention). NaN (a run
            that failed) leaves a hole.
        x_label, y_label: names of the two magnitudes (e.g. ``r"$\\Delta_m$"``).
        ax: a 3-D axes for ``kind="surface"``, a 2-D one for ``kind="contour"``, or None.
        kind: ``"surface"`` (a 3-D surface, as in the paper) or ``"contour"`` (filled contours).
        indexing: ``"ij"`` or ``"xy"``, see ``rho_max_grid``.
        z_label: name of the plotted value (colorbar and z axis).
        title: the title; by default "<z_label> over (<x_label>, <y_label>)".

    Grids of up to 5 x 5 nodes get their values written at the nodes; every node is marked, so
    that a coarse 3 x 3 sweep reads as nine numbers rather than as an interpolated landscape.

    Returns:
        The figure; the surface (or contour set) has gid ``"rho_surface"``, the nodes ``"rho_nodes"``.
    """
    x = np.asarray(x_values, dtype=float).ravel()
    y = np.asarray(y_values, dtype=float).ravel()
    z = np.asarray(rho_max_grid, dtype=float)
    if kind not in ("surface", "contour"):
        raise InvalidParameterError(f"kind must be 'surface' or 'contour', got {kind!r}")
    if indexing not in ("ij", "xy"):
        raise InvalidParameterError(f"indexing must be 'ij' or 'xy', got {indexing!r}")
    if len(x) < 2 or len(y) < 2:
        raise InvalidParameterError(f"need at least 2 values along each axis, got {len(x)} x {len(y)}")
    if indexing == "xy":
        z = z.T
    if z.shape != (len(x), len(y)):
        expected = (len(x), len(y)) if indexing == "ij" else (len(y), len(x))
        raise InvalidParameterError(
            f"rho_max_grid has shape {np.shape(rho_max_grid)}, expected {expected} "
            f"for {len(x)} x values and {len(y)} y values with indexing={indexing!r}"
        )
    if not np.any(np.isfinite(z)):
        raise InvalidParameterError("rho_max_grid has no finite value")
    X, Y = np.meshgrid(x, y, indexing="ij")
    Zm = np.ma.masked_invalid(z)
    finite = np.isfinite(z)
    vmin, vmax = float(Zm.min()), float(Zm.max())
    if vmax <= vmin:
        vmin, vmax = vmin - 0.5 * max(abs(vmin), 1e-3), vmax + 0.5 * max(abs(vmax), 1e-3)
    annotate = z.size <= 25
    node_size = 10 if annotate else 3
    cmap = "viridis"

    if kind == "surface":
        fig, ax = _new_axes(ax, (7.0, 5.6), projection="3d")
        mappable = ax.plot_surface(
            X, Y, Zm.filled(np.nan), cmap=cmap, vmin=vmin, vmax=vmax, edgecolor="k",
            linewidth=0.3, alpha=0.9, rstride=1, cstride=1,
        )  # fmt: skip
        mappable.set_gid("rho_surface")
        nodes = ax.scatter(X[finite], Y[finite], z[finite], color="k", s=node_size, depthshade=False)
        nodes.set_gid("rho_nodes")
        if annotate:
            dz = 0.03 * (vmax - vmin)
            for xi, yi, zi in zip(X[finite], Y[finite], z[finite]):
                ax.text(xi, yi, zi + dz, f"{zi:.3g}", fontsize=7, ha="center", va="bottom")
        ax.set_zlabel(z_label)
        ax.view_init(elev=28, azim=-125)
    else:
        if ax is not None and getattr(ax, "name", None) == "3d":
            raise InvalidParameterError("kind='contour' needs a 2-D axes, got a 3-D one")
        fig, ax = _new_axes(ax, (6.4, 5.0))
        levels = np.linspace(vmin, vmax, 15)
        mappable = ax.contourf(X, Y, Zm, levels=levels, cmap=cmap, extend="neither")
        mappable.set_gid("rho_surface")
        ax.contour(X, Y, Zm, levels=levels[::2], colors="k", linewidths=0.4, alpha=0.5)
        nodes = ax.scatter(X[finite], Y[finite], color="k", s=node_size)
        nodes.set_gid("rho_nodes")
        if annotate:
            for xi, yi, zi in zip(X[finite], Y[finite], z[finite]):
                # labels lean inwards at the edges of the grid, so none leaves the frame
                ha = "left" if xi == x.min() else "right" if xi == x.max() else "center"
                dx = {"left": 4, "right": -4, "center": 0}[ha]
                top = yi == y.max()
                ax.annotate(
                    f"{zi:.3g}", (xi, yi), textcoords="offset points", xytext=(dx, -5 if top else 5),
                    ha=ha, va="top" if top else "bottom", fontsize=8,
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "alpha": 0.7, "lw": 0},
                )  # fmt: skip
        ax.set_xlim(x.min(), x.max())
        ax.set_ylim(y.min(), y.max())
    # a coarse grid gets its own values as ticks, a fine one about five round ticks
    for values, axis in ((x, ax.xaxis), (y, ax.yaxis)):
        if len(values) <= 6:
            axis.set_ticks(values)
        else:
            axis.set_major_locator(MaxNLocator(6))
    ax.set_xlabel(x_label)
    ax.set_ylabel(y_label)
    fig.colorbar(
        mappable, ax=ax, label=z_label, shrink=0.7 if kind == "surface" else 1.0, pad=0.08,
        ticks=MaxNLocator(6), format="%.3g",
    )  # fmt: skip
    ax.set_title(title if title is not None else f"{z_label} over ({x_label}, {y_label})")
    return fig


# -------------------------------------------------------------------------------------------- save
def _rows_by_controller(rows: Sequence[Mapping[str, Any]], x_name: str, metric: str) -> dict[str, list]:
    """{controller: [(x, value or None when the run diverged, diverged_at)]} in the rows' order."""
    if not rows:
        raise InvalidParameterError("rows must be a non-empty list of dicts")
    lines: dict[str, list] = {}
    for row in rows:
        try:
            x, label = float(row[x_name]), str(row["controller"])
        except (KeyError, TypeError, ValueError):
            raise InvalidParameterError(
                f"every row needs 'controller' and a numeric {x_name!r}: {row!r}"
            ) from None
        diverged = row.get("diverged_at") is not None
        value = None if diverged else row.get(metric)
        if not diverged and (value is None or not math.isfinite(float(value))):
            continue  # no value (e.g. a "last 5 s" index of a shorter run): no point
        lines.setdefault(label, []).append((x, None if diverged else float(value), row.get("diverged_at")))
    return lines


def plot_against_rate(
    rows: Sequence[Mapping[str, Any]],
    metric: str,
    reference: Mapping[str, float] | None = None,
    ax: Axes | None = None,
) -> Figure:
    """One index of sampled runs against the sample rate, log-log, one line per controller.

    Args:
        rows: dicts with ``controller``, ``rate_hz`` [Hz], ``metric``'s value and ``diverged_at``
            (``None``, or the time [s] the run diverged: drawn as an x on the top edge, labelled
            with that time).
        metric: the index (e.g. ``"max_joint_error_last_5s"``).
        reference: horizontal dashed lines ``{label: value}`` (e.g. the continuous designs).
        ax: an Axes or None for a new figure.

    Returns:
        The figure; controller ``c``'s line has gid ``"rate:<c>"``, a reference ``"reference:<label>"``.
    """
    lines = _rows_by_controller(rows, "rate_hz", metric)
    fig, ax = _new_axes(ax, (9.0, 4.5))
    top = max((v for points in lines.values() for _, v, _ in points if v is not None), default=1.0)
    for label, value in (reference or {}).items():
        ax.axhline(value, linestyle="--", linewidth=1.0, color="gray", gid=f"reference:{label}")
        ax.annotate(f"{label} (continuous)", (0.01, value), xycoords=("axes fraction", "data"), fontsize=8,
                    color="gray", va="bottom")  # fmt: skip
        top = max(top, value)
    for i, (label, points) in enumerate(lines.items()):
        color = f"C{i}"
        kept = [(x, v) for x, v, _ in points if v is not None]
        if kept:
            xs, ys = zip(*kept)
            ax.plot(xs, ys, "o-", color=color, label=label, gid=f"rate:{label}", linewidth=_linewidth(i))
        lost = [(x, when) for x, v, when in points if v is None]
        # each controller's diverged runs on a row of their own above the data, so that the
        # markers of several controllers diverging at one rate do not hide each other
        row = top * 2.0 * DIVERGED_ROW_STEP**i
        if lost:
            ax.plot([x for x, _ in lost], [row] * len(lost), "x", color=color,
                    label=None if kept else f"{label} (diverged)", gid=f"diverged:{label}")  # fmt: skip
        for x, when in lost:
            if when is not None and not math.isnan(when):
                ax.annotate(f"{when:.2g} s", (x, row), fontsize=7, color=color, va="center",
                            textcoords="offset points", xytext=(6, 0))  # fmt: skip
    ax.set_xscale("log")
    ax.set_yscale("log")
    name, unit = METRIC_LABELS.get(metric, (metric, ""))
    ax.set_xlabel("sample rate [Hz]")
    ax.set_ylabel(f"{name} [{unit}]" if unit else name)
    ax.set_title(f"{name} against the sample rate (x: diverged, at the time shown)", fontsize=10)
    if ax.get_legend_handles_labels()[0]:  # a study whose rows all lack a value draws no line
        ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))
    ax.grid(True, which="both", alpha=0.3)
    return fig


DIVERGED_ROW_STEP = 1.35  # plot_against_rate: the ratio between two controllers' rows of x marks


def plot_trade_off(rows: Sequence[Mapping[str, Any]], ax: Axes | None = None) -> Figure:
    """Tracking error against torque roughness, one line per controller through its gain values
    (log-log; each point labelled with its gain's value, the later controllers' markers smaller so
    that coinciding points stay visible; diverged runs left out and listed in the legend).

    Args:
        rows: dicts with ``controller``, ``gain``, ``value``, ``max_joint_error_last_5s`` [rad],
            ``torque_increment_rms_last_5s`` [N m] and ``diverged_at``.

    Returns:
        The figure; controller ``c``'s line has gid ``"trade-off:<c>"``.
    """
    lines = _rows_by_controller(rows, "value", "max_joint_error_last_5s")
    roughness = {
        (str(r["controller"]), float(r["value"])): r.get("torque_increment_rms_last_5s") for r in rows
    }
    gains = {str(r["controller"]): str(r.get("gain", "")) for r in rows}
    fig, ax = _new_axes(ax, (9.0, 5.0))
    lost_entries = []  # legend-only marks (an empty line on log axes breaks their autoscale)
    for i, (label, points) in enumerate(lines.items()):
        kept = [(roughness[(label, x)], v, x) for x, v, _ in points if v is not None]
        lost = [x for x, v, _ in points if v is None]
        if lost:  # a legend entry of its own: a title that lists them is clipped at the figure's edge
            values = ", ".join(f"{x:g}" for x in lost)
            mark = Line2D([], [], marker="x", linestyle="", color=f"C{i}")
            lost_entries.append((mark, f"{label}: diverged at {gains[label]}={values}"))
        if not kept:
            continue
        xs, ys, _ = zip(*kept)
        ax.plot(xs, ys, "o-", color=f"C{i}", markersize=max(3.0, 9.0 - 2.5 * i),
                label=f"{label} (over {gains[label]})", gid=f"trade-off:{label}")  # fmt: skip
        for x, y, value in kept:
            ax.annotate(f"{value:g}", (x, y), fontsize=7, textcoords="offset points", xytext=(4, 2))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.margins(x=0.1, y=0.08)  # room for the value labels of the outermost points
    ax.set_xlabel("torque roughness, RMS ‖τₖ − τₖ₋₁‖ over the last 5 s [N·m]")
    ax.set_ylabel("max ‖r‖, last 5 s [rad]")
    ax.set_title("error against roughness over each design's main gain", fontsize=9)
    handles, labels = ax.get_legend_handles_labels()
    handles += [mark for mark, _ in lost_entries]
    labels += [text for _, text in lost_entries]
    if handles:  # a study whose rows all lack a value and none diverged draws nothing
        ax.legend(handles, labels, fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))
    ax.grid(True, which="both", alpha=0.3)
    return fig


def save_figure(fig: Figure, path: str | Path, dpi: float = 120, close: bool = True) -> Path:
    """Write ``fig`` to ``path`` atomically (a temporary file in the same folder, then
    :func:`os.replace`), creating the parent folders.

    The format follows the suffix (``.png`` by default, e.g. ``.pdf`` / ``.svg`` also work).
    With ``close=True`` the figure is released afterwards (closed in pyplot if it was made there).

    Returns:
        The path written.
    """
    if not isinstance(fig, Figure):
        raise InvalidParameterError(f"fig must be a matplotlib Figure, got {type(fig).__name__}")
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or "png"
    supported = fig.canvas.get_supported_filetypes()
    if fmt not in supported:
        raise InvalidParameterError(
            f"cannot write {str(path)!r}: format {fmt!r} is not one of {sorted(supported)}"
        )
    with atomic_open(path, "wb") as handle:
        fig.savefig(handle, format=fmt, dpi=dpi)
    if close:
        pyplot = sys.modules.get("matplotlib.pyplot")
        if pyplot is not None:
            pyplot.close(fig)  # a no-op for a figure pyplot does not manage
    return path

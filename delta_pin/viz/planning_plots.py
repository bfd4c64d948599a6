"""Figures of a time-optimal plan (:mod:`delta_pin.planning`) and of a robot's singularity map,
on bare headless matplotlib figures (as :mod:`delta_pin.viz.plots`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

__all__ = ["plot_plan", "plot_singularity_map"]


def plot_plan(plans: Sequence, title: str = "time-optimal plan") -> Figure:
    """Two panels over the plans run one after the other: |tau_j| / limit_j of each plan's last
    check on the exact model (the limit at 1), and the path speed s_dot [m/s] at its samples."""
    fig = Figure(figsize=(8.0, 5.5), layout="constrained")
    torque, speed = fig.subplots(2, 1, sharex=True)
    start = 0.0
    for number, plan in enumerate(plans):
        times, tau = plan.checked
        ratio = np.abs(tau) / plan.torque_limit
        for j in range(ratio.shape[1]):
            torque.plot(start + times, ratio[:, j], color=f"C{j}", linewidth=1.0, gid=f"tau_ratio_{j + 1}",
                        label=f"joint {j + 1}" if number == 0 else None)  # fmt: skip
        speed.plot(
            start + times, plan.path_state(times)[1], color="C0", linewidth=1.2, gid=f"s_dot_{number + 1}"
        )
        if number:
            for ax in (torque, speed):
                ax.axvline(start, color="0.6", linewidth=0.8, linestyle=":")
        start += plan.duration
    torque.axhline(1.0, color="black", linestyle="--", linewidth=1.0, gid="limit")
    torque.set_ylabel("|τ| / limit")
    torque.set_ylim(0.0, 1.15)
    torque.legend(loc="lower right", ncols=min(6, ratio.shape[1]), fontsize="small")
    torque.set_title(f"{title}: {start * 1e3:.1f} ms", loc="left")
    speed.set_ylabel("path speed ṡ [m/s]")
    speed.set_xlabel("t [s]")
    return fig


def plot_singularity_map(measure: np.ndarray, xs: np.ndarray, ys: np.ndarray, labels=("x [m]", "y [m]"),
                         title: str = "distance to a singularity", paths=()) -> Figure:  # fmt: skip
    """The smaller singularity measure over a grid of positions (NaN: unreachable, left blank), with
    ``paths`` ((N, 2) points each, in the map's plane) drawn over it."""
    fig = Figure(figsize=(6.0, 5.0), layout="constrained")
    ax = fig.add_subplot()
    image = ax.pcolormesh(xs, ys, measure, shading="nearest", cmap="viridis", gid="measure")
    fig.colorbar(image, ax=ax, label="min(Type I, Type II) σ_min/σ_max")
    for number, points in enumerate(paths):
        ax.plot(points[:, 0], points[:, 1], color="white", linewidth=1.5, gid=f"path_{number + 1}")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.set_aspect("equal")
    ax.set_title(title, loc="left")
    return fig

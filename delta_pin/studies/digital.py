"""The "digital implementation" study of ``delta-pin reproduce``: the designs on a digital drive.

Path I, the paper's uncertainty and friction, 17-bit encoders (velocity by difference of the
readings) and one sample of computation delay, at 1-10 kHz: designs I and II (plain and
sampling-aware), time-delay control (with the mean pairing, :data:`FIXED_GAINS`) and the
sampled-data adaptive robust law. For each run: the
largest ||alpha - alpha^d|| over the last 5 s, the torque's roughness there (RMS of
||tau_k - tau_{k-1}||), or the time it diverged. Against the rate on log-log axes, with the
continuous-time designs as the reference line; and at 1 kHz, each design's error against its
roughness as its main gain varies (the trade-off a user tunes).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass

from delta_pin.control.registry import declaration
from delta_pin.studies.experiments import RunSpec

__all__ = [
    "DIGITAL_CONTROLLERS",
    "FIXED_GAINS",
    "MAIN_GAINS",
    "DigitalStudy",
    "digital_report_lines",
    "digital_rows",
    "digital_specs",
    "write_digital_figures",
]

# (controller, sampling-aware) -> label, in the order of the tables and figures
DIGITAL_CONTROLLERS = {
    ("design1", False): "design I",
    ("design1", True): "design I, sampling-aware",
    ("design2", False): "design II",
    ("design2", True): "design II, sampling-aware",
    ("tdc", False): "TDC, mean pairing",
    ("digital-robust", False): "digital robust",
}
# each design's main gain and the values of the trade-off at 1 kHz (the defaults among them)
MAIN_GAINS = {
    ("design1", True): ("sampling_margin", (0.25, 0.5, 1.0, 1.5)),
    ("design2", True): ("sampling_margin", (0.25, 0.5, 1.0, 1.5)),
    ("tdc", False): ("bandwidth", (20.0, 40.0, 80.0, 160.0)),
    ("digital-robust", False): ("observer_bandwidth", (75.0, 100.0, 150.0, 200.0, 300.0)),
}
# fixed options of a design in this study: TDC pairs the second difference with the mean of the two
# torques that acted over it, the form for a drive with a delay (the textbook pairing alternates by
# 45-49 N m RMS per sample at 1 kHz and by 2e4 N m at 10 kHz, where the tree then needs a projection at
# every step: docs/architecture.md section 6)
FIXED_GAINS = {"tdc": {"pairing": "mean"}}
ENCODER_BITS = 17
DELAY = 1  # [samples]
TRADE_OFF_RATE = 1000.0  # [Hz]


@dataclass(frozen=True)
class DigitalStudy:
    """The size of the study.

    Attributes:
        plant: ``"analytic"`` or ``"pinocchio"``.
        rates: sample rates [Hz] (empty: no digital study).
        trade_off_points: how many of each design's :data:`MAIN_GAINS` values to run at 1 kHz
            (spread over the list; 0: no trade-off).
        t_end: duration [s] (``None``: path I's 15 s).
    """

    plant: str = "analytic"
    rates: tuple[float, ...] = (1000.0, 4000.0)
    trade_off_points: int = 3
    t_end: float | None = None

    def gain_values(self, values: tuple[float, ...]) -> tuple[float, ...]:
        """``trade_off_points`` of ``values``, first and last included."""
        count = min(self.trade_off_points, len(values))
        if count <= 0:
            return ()
        if count == 1:
            return (values[len(values) // 2],)
        return tuple(values[round(i * (len(values) - 1) / (count - 1))] for i in range(count))


def _spec(
    study: DigitalStudy, controller: str, aware: bool, rate: float, gains: Mapping | None = None
) -> RunSpec:
    return RunSpec(
        controller=controller,
        path="I",
        plant=study.plant,
        mode="sampled",
        dt=1.0 / rate,
        sampling_aware=aware,
        t_end=study.t_end,
        encoder_bits=ENCODER_BITS,
        velocity="difference",
        delay=DELAY,
        gains={**FIXED_GAINS.get(controller, {}), **(gains or {})},
    )


def _default_gain(controller: str, gain: str):
    """The default of ``gain`` in ``controller``'s constructor (``None`` if it has none)."""
    import inspect

    parameter = inspect.signature(declaration(controller).law).parameters.get(gain)
    return None if parameter is None or parameter.default is inspect.Parameter.empty else parameter.default


def digital_specs(study: DigitalStudy) -> tuple[dict, dict]:
    """The runs: ``{(label, rate [Hz]): spec}`` and ``{(label, gain name, value): spec}``."""
    by_rate = {
        (label, rate): _spec(study, controller, aware, rate)
        for (controller, aware), label in DIGITAL_CONTROLLERS.items()
        for rate in study.rates
    }
    trade_off = {}
    for (controller, aware), (gain, values) in MAIN_GAINS.items():
        default = _default_gain(controller, gain)
        for value in study.gain_values(values):
            # the law's default value is the run of the rate table at 1 kHz: one spec, so one run
            gains = {} if value == default else {gain: value}
            spec = _spec(study, controller, aware, TRADE_OFF_RATE, gains)
            trade_off[(DIGITAL_CONTROLLERS[(controller, aware)], gain, value)] = spec
    return by_rate, trade_off


_DIVERGED_AT = re.compile(r"\(at t=([0-9.eE+-]+) s\)")


def _row(point, **fields) -> dict:
    """One table row from a sweep point: its error and roughness, or when and why it failed."""
    row = dict(fields)
    if point.ok:  # None (a shorter run's "last 5 s" index) reads as NaN
        for name in ("max_joint_error_last_5s", "torque_increment_rms_last_5s"):
            value = point.metrics[name]
            row[name] = math.nan if value is None else value
        row["diverged_at"] = None
    else:
        found = _DIVERGED_AT.search(point.error or "")
        row["diverged_at"] = float(found.group(1)) if found else math.nan
        row["error"] = point.error
    return row


def digital_rows(by_rate: dict, trade_off: dict, points: list) -> tuple[list[dict], list[dict]]:
    """Rows of the two tables from the sweep ``points`` of ``[*by_rate.values(),
    *trade_off.values()]``, in that order."""
    points = list(points)
    if len(points) != len(by_rate) + len(trade_off):
        raise ValueError(f"{len(points)} points for {len(by_rate) + len(trade_off)} digital runs")
    rate_points, trade_points = points[: len(by_rate)], points[len(by_rate) :]
    rate_rows = [
        _row(point, controller=label, rate_hz=rate) for (label, rate), point in zip(by_rate, rate_points)
    ]
    trade_rows = [
        _row(point, controller=label, gain=gain, value=value)
        for (label, gain, value), point in zip(trade_off, trade_points)
    ]
    return rate_rows, trade_rows


def _number(value: float, form: str) -> str:
    return "n/a" if math.isnan(value) else format(value, form)


def _cell(row: dict, name: str) -> str:
    if row.get("diverged_at") is not None:
        when = row["diverged_at"]
        return "diverged" + ("" if math.isnan(when) else f" at t = {when:.3g} s")
    return _number(row[name], ".2e")


def digital_report_lines(
    rate_rows: list[dict], trade_rows: list[dict], reference: Mapping[str, float]
) -> list[str]:
    """The report's Markdown section. ``reference``: the continuous designs' error on path I
    ({label: rad}), the line a digital design is held to."""
    if not rate_rows:
        return []
    rates = sorted({row["rate_hz"] for row in rate_rows})
    labels = list(dict.fromkeys(row["controller"] for row in rate_rows))
    cells = {(row["controller"], row["rate_hz"]): row for row in rate_rows}
    header = "| controller | " + " | ".join(f"{rate / 1e3:g} kHz" for rate in rates) + " |"
    lines = [
        "## Digital implementation",
        "",
        f"Path I, {ENCODER_BITS}-bit encoders (velocity by difference of the readings), {DELAY} sample of "
        "computation delay, the paper's uncertainty and friction, sampled mode. Each cell: the largest "
        "‖α − α_d‖ over the last 5 s [rad] / the torque's roughness there, RMS of ‖τ_k − τ_(k−1)‖ [N·m]; "
        "or when the run diverged.",
        "",
    ]
    if reference:
        lines += [
            "Continuous-time reference: "
            + ", ".join(f"{label} {value:.2e} rad" for label, value in reference.items())
            + ".",
            "",
        ]
    lines += [header, "|---|" + "---|" * len(rates)]
    for label in labels:
        row_cells = []
        for rate in rates:
            row = cells.get((label, rate))
            if row is None:
                row_cells.append("")
            elif row.get("diverged_at") is not None:
                row_cells.append(_cell(row, ""))
            else:
                row_cells.append(
                    f"{_number(row['max_joint_error_last_5s'], '.2e')} / "
                    f"{_number(row['torque_increment_rms_last_5s'], '.3g')}"
                )
        lines.append(f"| {label} | " + " | ".join(row_cells) + " |")
    if trade_rows:
        lines += [
            "",
            f"Trade-off at {TRADE_OFF_RATE / 1e3:g} kHz over each design's main gain:",
            "",
            "| controller | gain | value | max ‖α − α_d‖, last 5 s [rad] | roughness [N·m] |",
            "|---|---|---|---|---|",
        ]
        for row in trade_rows:
            roughness = (
                ""
                if row.get("diverged_at") is not None
                else _number(row["torque_increment_rms_last_5s"], ".3g")
            )
            lines.append(
                f"| {row['controller']} | {row['gain']} | {row['value']:g} | "
                f"{_cell(row, 'max_joint_error_last_5s')} | {roughness} |"
            )
    return lines


def write_digital_figures(
    rate_rows: list[dict], trade_rows: list[dict], reference: Mapping[str, float], figures
) -> list[str]:
    """fig30 (error against rate), fig31 (roughness against rate), fig32 (the 1 kHz trade-off),
    as PNG files in ``figures``; returns their names."""
    if not rate_rows:
        return []
    from delta_pin.viz import plots

    names = []
    figure = plots.plot_against_rate(rate_rows, "max_joint_error_last_5s", reference=reference)
    names.append(plots.save_figure(figure, figures / "fig30_digital_error_vs_rate.png").name)
    figure = plots.plot_against_rate(rate_rows, "torque_increment_rms_last_5s")
    names.append(plots.save_figure(figure, figures / "fig31_digital_roughness_vs_rate.png").name)
    if trade_rows:
        figure = plots.plot_trade_off(trade_rows)
        names.append(plots.save_figure(figure, figures / "fig32_digital_trade_off_1khz.png").name)
    return names

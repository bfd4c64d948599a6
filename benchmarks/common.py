"""Shared timing helpers: repeat a callable, report median / min / max, print a table."""

from __future__ import annotations

import json
import os
import platform
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass

WARMUP_S = 0.05  # [s] least time spent in warm-up calls before per-call timings


@dataclass
class Timing:
    """Wall times [s] of repeated calls of one benchmark case."""

    name: str
    times: list[float]
    note: str = ""

    @property
    def median(self) -> float:
        return statistics.median(self.times)


def measure(
    name: str,
    function: Callable[[], object],
    repeats: int = 5,
    note: str = "",
    warmup: Callable[[], object] | None = None,
) -> Timing:
    """Call ``function`` ``repeats`` times (after one warm-up call of ``warmup``, by default
    ``function`` itself: a short run of a long one is enough) and keep the wall times."""
    (warmup or function)()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return Timing(name, times, note)


def per_call(function: Callable[[], object], calls: int, repeats: int, per: int = 1) -> list[float]:
    """Seconds per call (divided by ``per`` items) of ``repeats`` batches of ``calls`` calls,
    after warm-up calls (numba compilation, caches) for at least ``WARMUP_S``."""
    start = time.perf_counter()
    function()
    while time.perf_counter() - start < WARMUP_S:
        function()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(calls):
            function()
        times.append((time.perf_counter() - start) / (calls * per))
    return times


def _format(seconds: float) -> str:
    if seconds < 1e-3:
        return f"{seconds * 1e6:.1f} us"
    if seconds < 1.0:
        return f"{seconds * 1e3:.1f} ms"
    return f"{seconds:.2f} s"


def machine_info() -> str:
    return (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}"
    )


def print_table(title: str, timings: list[Timing], reference: Timing | None = None) -> None:
    """Median, min and max per case; the ratio to ``reference`` (measured in the same run)."""
    print(f"\n## {title}\n")
    header = (
        "| case | median | min | max | repeats |" + (" time / reference |" if reference else "") + " note |"
    )
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for timing in timings:
        ratio = f" {timing.median / reference.median:.2f} |" if reference else ""
        if reference is timing:
            ratio = " reference |"
        print(
            f"| {timing.name} | {_format(timing.median)} | {_format(min(timing.times))} | "
            f"{_format(max(timing.times))} | {len(timing.times)} |{ratio} {timing.note} |"
        )


TARGET_PREFIX = "TARGET "


def report_target(target: str, value: float, limit: float | None, unit: str = "s") -> None:
    """Print one machine-readable line that ``run_all.py`` collects into its summary table:
    ``TARGET {"target": ..., "value": ..., "limit": ..., "unit": "s"}``; the target is met when
    value <= limit (``limit`` null: a reference figure without a target)."""
    line = {"target": target, "value": value, "limit": limit, "unit": unit}
    print(TARGET_PREFIX + json.dumps(line), flush=True)


def format_value(value: float, unit: str = "s") -> str:
    """``value`` in seconds as us / ms / s, anything else as ``1.2e-10 m``."""
    return _format(value) if unit == "s" else f"{value:.1e} {unit}"

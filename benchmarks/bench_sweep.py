"""Time the paper's surface sweep: one run at a time (the core's Radau IIA, the default) vs the
sweep's batches (the core's BDF2, the reference tabulated once per batch).

Run: ``python benchmarks/bench_sweep.py [--repeats 3] [--t-end 15] [--runs 8] [--full]``

Scenario: design I on the analytic plant, path I, rho_0 = 0.02, Delta_m swept over [0, 0.9], the
other magnitudes 0.3 (a slice of the 3 planes x 2 designs x 11 x 11 = 726-run grid of Figs. 9-11).
Per-run times are measured on ``--runs`` runs; the 726-run figure is extrapolated over this
machine's cores (the sweep engine runs one batch per process), unless ``--full`` runs the whole
grid through :func:`delta_pin.studies.sweep.run_sweep` (docs/measured/bench_sweep.md).
"""

from __future__ import annotations

import argparse
import os
import tempfile

import numpy as np
from common import machine_info, measure, print_table, report_target

from delta_pin import load_delta
from delta_pin.studies.experiments import RunSpec, run_batch, run_spec
from delta_pin.studies.reproduce import SURFACE_PLANES
from delta_pin.studies.sweep import grid_specs, run_sweep

GRID_RUNS = 726


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--t-end", type=float, default=15.0)
    parser.add_argument("--runs", type=int, default=8, help="runs per measurement")
    parser.add_argument("--full", action="store_true", help="also run the whole 726-run grid")
    args = parser.parse_args()
    robot = load_delta()
    base = RunSpec(controller="design1", plant="analytic", t_end=args.t_end, gains={"rho0": 0.02})
    specs = [base.with_(delta_m=float(m)) for m in np.linspace(0.0, 0.9, args.runs)]
    batched = [spec.with_(integrator="bdf2") for spec in specs]

    unbatched_timing = measure(
        f"one by one: Radau IIA (the default), {args.runs} runs",
        lambda: [run_spec(spec, robot) for spec in specs],
        max(1, args.repeats - 1),
        note=f"{args.t_end:g} s each",
        warmup=lambda: run_spec(specs[0].with_(t_end=0.1), robot),
    )
    batched_timing = measure(
        f"batched: BDF2, {args.runs} runs in one run_batch",
        lambda: run_batch(batched, robot),
        args.repeats,
        note=f"{args.t_end:g} s each",
        warmup=lambda: run_batch([s.with_(t_end=0.1) for s in batched[:2]], robot),
    )
    cores = os.cpu_count() or 1
    timings = [unbatched_timing, batched_timing]
    print(f"machine: {machine_info()}")
    print_table(f"surface sweep: {args.runs} runs of {args.t_end:g} s", timings, reference=timings[0])
    per_run = {t.name: t.median / args.runs for t in timings}
    for name, seconds in per_run.items():
        print(
            f"{name}: {seconds:.3f} s per run -> {GRID_RUNS} runs on {cores} cores ~ "
            f"{seconds * GRID_RUNS / cores:.0f} s (extrapolated)"
        )
    estimate = per_run[batched_timing.name] * GRID_RUNS / cores
    if args.full:
        grid = list(np.round(np.linspace(0.0, 0.9, 11), 6))
        grid_specs_all = [
            spec
            for controller in ("design1", "design2")
            for x, y in SURFACE_PLANES
            for spec in grid_specs(base.with_(controller=controller, integrator="bdf2"), {x: grid, y: grid})
        ]
        with tempfile.TemporaryDirectory() as cache:
            result = run_sweep(grid_specs_all, cache, workers=cores, progress=True)
        print(f"full grid: {result.summary()}")
        estimate = result.wall_time
    report_target(
        f"{GRID_RUNS}-run sweep of {args.t_end:g} s runs ({'measured' if args.full else 'extrapolated'})",
        estimate,
        31.0 * args.t_end / 15.0,  # issue 23: keep the numba engine's 31 s
    )


if __name__ == "__main__":
    main()

"""Time the headless meshcat export of a 15 s run and report the page size.

Run: ``python benchmarks/bench_meshcat_export.py [--repeats 5] [--t-end 15]``

The run is simulated once (analytic plant, 1 kHz, path II, a joint PD with gravity compensation),
then exported several times per setting; the table gives the median wall time and the file size.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import delta_pin as dp
from delta_pin.sim.runner import simulate
from delta_pin.viz.meshcat_export import export_html

SETTINGS = {
    "fps=30": {"fps": 30.0},
    "fps=30, desired ghost": {"fps": 30.0, "show_desired_ghost": True},
    "fps=60": {"fps": 60.0},
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="exports per setting (median reported)")
    parser.add_argument("--t-end", type=float, default=15.0, help="run duration [s]")
    args = parser.parse_args()

    robot = dp.load_delta()
    start = time.perf_counter()
    run = simulate(
        robot,
        dp.PDGravity(dp.DeltaNominalModel(robot)),
        dp.PathII(),
        plant="analytic",
        t_end=args.t_end,
        dt=1e-3,
    )
    print(
        f"simulated {args.t_end:g} s at 1 kHz ({len(run.t)} samples) in {time.perf_counter() - start:.2f} s"
    )
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        export_html(run, Path(folder) / "warmup.html")  # imports and first-use costs out of the timings
        for label, options in SETTINGS.items():
            path = Path(folder) / "run.html"
            times = []
            for _ in range(args.repeats):
                start = time.perf_counter()
                export_html(run, path, **options)
                times.append(time.perf_counter() - start)
            rows.append((label, statistics.median(times), min(times), path.stat().st_size))

    print(f"\nexport_html of a {args.t_end:g} s run, {args.repeats} repeats")
    print(f"{'setting':<24} {'median [s]':>10} {'min [s]':>9} {'size [MB]':>10}")
    for label, median, best, size in rows:
        print(f"{label:<24} {median:>10.3f} {best:>9.3f} {size / 1e6:>10.3f}")


if __name__ == "__main__":
    main()

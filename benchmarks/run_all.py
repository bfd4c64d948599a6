"""Run every benchmark and print its table: ``python benchmarks/run_all.py [--quick]``.

Speed is measured here, not in the test suite. Each table gives median, min and max over repeats
and ratios against a reference measured in the same run.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).parent
BENCHMARKS = {
    "bench_model.py": ["--repeats", "5"],
    "bench_controllers.py": ["--repeats", "5"],
    "bench_simulate.py": ["--repeats", "3"],
    "bench_meshcat_export.py": ["--repeats", "5"],
}
QUICK = {
    "bench_model.py": ["--repeats", "3", "--calls", "500"],
    "bench_controllers.py": ["--repeats", "3", "--calls", "500"],
    "bench_simulate.py": ["--repeats", "1", "--t-end", "3"],
    "bench_meshcat_export.py": ["--repeats", "2"],
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats, shorter runs")
    args = parser.parse_args()
    failures = 0
    for script, options in (QUICK if args.quick else BENCHMARKS).items():
        print(f"\n# {script}", flush=True)
        failures += subprocess.call([sys.executable, str(HERE / script), *options], cwd=HERE) != 0
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

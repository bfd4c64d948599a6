"""CLI start-up: ``delta-pin CMD --help`` against a bare Python start in the same run.

Run: ``python benchmarks/bench_cli.py [--repeats 5]``

Issue 14's target: ``delta-pin run --help`` in at most 0.5 s (it took 2.4 s while the choices it
lists lived in the modules that load SciPy, numba and Pinocchio).
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from pathlib import Path

from common import machine_info, measure, print_table, report_target

HELP_LIMIT = 0.5  # [s]


def _run(argv: list[str]):
    return lambda: subprocess.run(argv, check=True, capture_output=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    # the script of this interpreter's environment (a venv not activated has it beside python), else PATH's
    beside = Path(sys.executable).with_name("delta-pin")
    cli = str(beside) if beside.is_file() else shutil.which("delta-pin") or "delta-pin"
    timings = [measure("python -c pass (the floor)", _run([sys.executable, "-c", "pass"]), args.repeats)]
    for command in ("run", "sweep", "reproduce", "validate"):
        timings.append(measure(f"delta-pin {command} --help", _run([cli, command, "--help"]), args.repeats))
    print(f"machine: {machine_info()}")
    print_table("CLI start-up", timings, reference=timings[0])
    report_target("delta-pin run --help", timings[1].median, HELP_LIMIT)


if __name__ == "__main__":
    main()

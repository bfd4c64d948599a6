"""One step of design I in the standalone C++ library (examples/drive_cpp: Eigen only, no Python,
no Pinocchio) against the same step through delta-pin from Python (the numba kernel behind
``AdaptiveRobustController.evaluate``), measured in the same run.

Run: ``python benchmarks/bench_drive_cpp.py [--repeats 3]`` (needs cmake and a C++ compiler)
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from common import Timing, machine_info, per_call, print_table, report_target

import delta_pin as dp
from delta_pin.control.base import Reference

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "drive_cpp"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(f"machine: {machine_info()}")
    if shutil.which("cmake") is None:
        print("cmake is not installed: nothing to measure")
        return
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        subprocess.run([sys.executable, str(EXAMPLE / "make_golden.py"), str(folder / "golden")], check=True)
        configure = ["cmake", "-S", str(EXAMPLE), "-B", str(folder / "build"), "-DCMAKE_BUILD_TYPE=Release"]
        subprocess.run([*configure, f"-DPython_EXECUTABLE={sys.executable}"], check=True, capture_output=True)
        subprocess.run(["cmake", "--build", str(folder / "build")], check=True, capture_output=True)
        steps = []
        for _ in range(args.repeats):
            out = subprocess.run(
                [str(folder / "build" / "drive_replay"), str(folder / "golden" / "parameters.txt"),
                 str(folder / "golden" / "golden.csv")], check=True, capture_output=True, text=True,
            ).stdout  # fmt: skip
            steps.append(float(re.search(r"time per step ([0-9.]+) ns", out).group(1)) * 1e-9)
            allocations = int(re.search(r"heap allocations during the steps (\d+)", out).group(1))
    c_library = Timing("design I step, C library (drive_replay)", steps, f"{allocations} heap allocations")
    robot = dp.load_delta()
    controller = dp.design1(dp.DeltaNominalModel(robot), sampling_period=1e-3)
    alpha, rate = np.full(3, 0.33), np.array([0.1, -0.2, 0.3])
    reference = Reference(alpha + 0.01, rate, np.zeros(3))
    state = controller.initial_state()
    python = Timing(
        "the same step through delta-pin from Python (numba kernel)",
        per_call(lambda: controller.evaluate(0.0, alpha, rate, reference, state), 2000, args.repeats),
    )
    print_table(
        "one design I step (sampling-aware), Delta analytic nominal model", [c_library, python], python
    )
    report_target("one design I step in the standalone C++ library", c_library.median, 3e-6)


if __name__ == "__main__":
    main()

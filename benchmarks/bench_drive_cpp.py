"""One step of design I and one of the digital-robust law in the standalone C++ library
(examples/drive_cpp: Eigen only, no Python, no Pinocchio) against the same steps through delta-pin
from Python (the compiled core's copies of the laws, ``sampled_core_law().evaluate``; the
readable ``evaluate`` is numpy, ~0.4 ms), measured in the same run.

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


def _replays(folder: Path, design: str, repeats: int) -> Timing:
    """drive_replay's time per step [s] over ``repeats`` replays of ``design``'s golden vectors."""
    golden = folder / f"golden-{design}"
    subprocess.run(
        [sys.executable, str(EXAMPLE / "make_golden.py"), str(golden), "--design", design],
        check=True,
        capture_output=True,
    )
    replay = [
        str(folder / "build" / "drive_replay"),
        str(golden / "parameters.txt"),
        str(golden / "golden.csv"),
    ]
    steps = []
    for _ in range(repeats):
        out = subprocess.run(replay, check=True, capture_output=True, text=True).stdout
        steps.append(float(re.search(r"time per step ([0-9.]+) ns", out).group(1)) * 1e-9)
        allocations = int(re.search(r"heap allocations during the steps (\d+)", out).group(1))
        error = float(
            re.search(r"largest torque error \(relative to the largest torque\) (\S+)", out).group(1)
        )
    return Timing(
        f"{design} step, C library (drive_replay)",
        steps,
        f"{allocations} heap allocations, error {error:.1e}",
    )


def _rows(reference: Reference) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """alpha^d, alpha_dot^d, alpha_ddot^d as a compiled law's ``evaluate`` takes them."""
    return reference.alpha, reference.alpha_dot, reference.alpha_ddot


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
        configure = ["cmake", "-S", str(EXAMPLE), "-B", str(folder / "build"), "-DCMAKE_BUILD_TYPE=Release"]
        subprocess.run([*configure, f"-DPython_EXECUTABLE={sys.executable}"], check=True, capture_output=True)
        subprocess.run(["cmake", "--build", str(folder / "build")], check=True, capture_output=True)
        design_c = _replays(folder, "I", args.repeats)
        digital_c = _replays(folder, "digital-robust", args.repeats)
    robot = dp.load_delta()
    nominal = dp.DeltaNominalModel(robot)
    alpha, rate = np.full(3, 0.33), np.array([0.1, -0.2, 0.3])
    reference = Reference(alpha + 0.01, rate, np.zeros(3))
    design = dp.design1(nominal, sampling_period=1e-3)
    state = design.initial_state()
    design_law = design.sampled_core_law()
    design_python = Timing(
        "the design I step through delta-pin from Python (the compiled core's law)",
        per_call(lambda: design_law.evaluate(alpha, rate, *_rows(reference), state), 2000, args.repeats),
    )
    digital = dp.digital_robust(nominal, 1e-3, delay=1, torque_limit=5.0)
    digital_state = digital.evaluate(0.0, alpha, rate, reference, digital.initial_state()).next_state
    digital_law = digital.sampled_core_law()
    digital_python = Timing(
        "the digital-robust step through delta-pin from Python (the compiled core's law)",
        per_call(
            lambda: digital_law.evaluate(alpha, rate, *_rows(reference), digital_state), 2000, args.repeats
        ),
    )
    print_table(
        "one design I step (sampling-aware), Delta analytic nominal model",
        [design_c, design_python],
        design_python,
    )
    print_table(
        "one digital-robust step (one sample of delay), Delta analytic nominal model",
        [digital_c, digital_python],
        digital_python,
    )
    report_target("one design I step in the standalone C++ library", design_c.median, 3e-6)
    report_target("one digital-robust step in the standalone C++ library", digital_c.median, 3e-6)


if __name__ == "__main__":
    main()

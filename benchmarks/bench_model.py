"""Cost of one evaluation of the Delta's dynamics (M, C, G at one state) by each implementation.

Run: ``python benchmarks/bench_model.py [--repeats 5] [--calls 2000]``

References measured in the same run: the readable numpy model (delta_pin.model.dynamics, the test
oracle), the same kernel as plain scalar Python (a child process with ``NUMBA_DISABLE_JIT=1``, so
that every helper it calls is Python too), the numba-compiled kernel,
the numpy model on a batch of 10 000 states (per state), and Pinocchio's projected reduced
dynamics (closure solve, projection).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

import numpy as np
from common import Timing, machine_info, per_call, print_table, report_target

import delta_pin as dp
from delta_pin.compiled.delta_kernels import delta_terms
from delta_pin.compiled.layouts import as_table
from delta_pin.model.dynamics import analytic_dynamics, kernel_geometry
from delta_pin.model.kinematics import chain_trigonometry

SCALAR_FLAG = "--scalar-python-only"  # the child process that times the kernel as plain Python


def _scalar_python_times(calls: int, repeats: int) -> list[float]:
    """Per-call times of ``delta_terms`` as plain Python: this script again, with numba off."""
    command = [sys.executable, __file__, SCALAR_FLAG, "--calls", str(calls), "--repeats", str(repeats)]
    done = subprocess.run(
        command, capture_output=True, text=True, check=True, env={**os.environ, "NUMBA_DISABLE_JIT": "1"}
    )
    return json.loads(done.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--calls", type=int, default=2000)
    parser.add_argument(SCALAR_FLAG, action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    robot = dp.load_delta()
    params = robot.params
    alpha, alpha_dot = np.array([0.3, 0.2, 0.4]), np.array([0.1, 0.2, -0.3])
    # a one-record array, as the nominal model and the analytic plant pass it (compiled.jit.as_record)
    geometry, (cos_phi, sin_phi) = as_table(kernel_geometry(params)), chain_trigonometry()
    m_eq = params.platform_equivalent_mass
    batch = 10_000
    alphas, alpha_dots = np.tile(alpha, (batch, 1)), np.tile(alpha_dot, (batch, 1))
    n, r = args.calls, args.repeats
    if args.scalar_python_only:  # the child of _scalar_python_times: numba is off here
        terms = lambda: delta_terms(geometry, cos_phi, sin_phi, m_eq, alpha, alpha_dot)  # noqa: E731
        print(json.dumps(per_call(terms, n, r)))
        return
    timings = [
        Timing(
            "numba kernel (compiled.delta_kernels.delta_terms)",
            per_call(lambda: delta_terms(geometry, cos_phi, sin_phi, m_eq, alpha, alpha_dot), n, r),
        ),
        Timing(
            "same kernel as scalar Python (NUMBA_DISABLE_JIT=1)", _scalar_python_times(max(n // 10, 10), r)
        ),
        Timing(
            "readable numpy model, one state",
            per_call(lambda: analytic_dynamics(params, alpha, alpha_dot), max(n // 10, 10), r),
        ),
        Timing(
            f"readable numpy model, batch of {batch} (per state)",
            per_call(lambda: analytic_dynamics(params, alphas, alpha_dots), 1, r, per=batch),
        ),
        Timing(
            "Pinocchio reduced dynamics (closure + projection)",
            per_call(lambda: robot.pinocchio_dynamics(alpha, alpha_dot), max(n // 10, 10), r),
        ),
    ]
    print(f"machine: {machine_info()}")
    print_table("one evaluation of M, C, G", timings, reference=timings[0])
    report_target("M, C, G per call: numba kernel", timings[0].median, None)
    report_target("M, C, G per call: scalar Python (reference, about 40 us)", timings[1].median, None)
    report_target("M, C, G per call: plain numpy (reference, 190-260 us)", timings[2].median, None)


if __name__ == "__main__":
    main()

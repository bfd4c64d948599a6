"""Cost of one evaluation of the Delta's dynamics (M, C, G at one state) by each implementation.

Run: ``python benchmarks/bench_model.py [--repeats 5] [--calls 2000]``

References measured in the same run: the readable numpy model (delta_pin.model.dynamics, the test
oracle, what the Python loop's analytic plant and the Delta's nominal model evaluate), the same
model on a batch of 10 000 states (per state), the compiled core's reduced Delta (one
[alpha_dot, alpha_ddot] of eq. 13 from Python: M, C, G and the solve,
``delta_pin/core/plant/analytic_plant.hpp``), and Pinocchio's projected reduced dynamics (closure solve,
projection).
"""

from __future__ import annotations

import argparse

import numpy as np
from common import Timing, machine_info, per_call, print_table, report_target

import delta_pin as dp
from delta_pin.model.dynamics import analytic_dynamics


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--calls", type=int, default=2000)
    args = parser.parse_args()
    robot = dp.load_delta()
    params = robot.params
    alpha, alpha_dot = np.array([0.3, 0.2, 0.4]), np.array([0.1, 0.2, -0.3])
    batch = 10_000
    alphas, alpha_dots = np.tile(alpha, (batch, 1)), np.tile(alpha_dot, (batch, 1))
    n, r = args.calls, args.repeats
    timings = [
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
    compiled = dp.AnalyticPlant(robot).core_plant()
    if compiled is not None:  # the core is importable here
        x, tau = np.concatenate([alpha, alpha_dot]), np.zeros(3)
        timings.append(
            Timing(
                "compiled core's reduced Delta, one derivative from Python (M, C, G and the solve)",
                per_call(lambda: compiled.derivative(x, tau, 0.0), n, r),
            )
        )
    print(f"machine: {machine_info()}")
    print_table("one evaluation of M, C, G", timings, reference=timings[0])
    report_target("M, C, G per call: plain numpy (reference, 190-260 us)", timings[0].median, None)
    if compiled is not None:
        report_target("eq. 13's derivative per call: the compiled core from Python", timings[-1].median, None)


if __name__ == "__main__":
    main()

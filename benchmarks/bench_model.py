"""Cost of one evaluation of the Delta's dynamics (M, C, G at one state) by each implementation.

Run: ``python benchmarks/bench_model.py [--repeats 5] [--calls 2000]``

References measured in the same run: the readable numpy model (delta_pin.model.dynamics, the test
oracle, what the Python loop's analytic plant and the Delta's nominal model evaluate), the same
model on a batch of 10 000 states (per state), the compiled core's reduced Delta (one
[alpha_dot, alpha_ddot] of eq. 13 from Python: M, C, G and the solve,
``delta_pin/core/plant/analytic_plant.hpp``), and Pinocchio's projected reduced dynamics (closure solve,
projection). A second table: one assembly q(alpha) of the closures from the reference
configuration, by ``ClosedChainRobot.configuration`` (the core's Newton) against its readable twin
(``tests/reference/assembly.py``, what the robot ran before).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from common import Timing, machine_info, per_call, print_table, report_target

import delta_pin as dp
from delta_pin.model.dynamics import analytic_dynamics

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository root: tests.reference
from tests.reference.assembly import newton_configuration


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
    compiled = dp.AnalyticPlant(robot).build()
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
    _assembly(robot, n, r)


def _assembly(robot, n: int, r: int) -> None:
    """One closure solve from the reference configuration, alpha 0.03 rad from home."""
    alpha, start = robot.home + 0.03, robot.reference_configuration
    timings = [
        Timing(
            "readable Newton (tests/reference/assembly.py)",
            per_call(lambda: newton_configuration(robot, alpha, start), max(n // 10, 10), r),
        ),
        Timing(
            "robot.configuration (the core's Newton)",
            per_call(lambda: robot.configuration(alpha, initial_guess=start), n, r),
        ),
    ]
    print_table("one assembly q(alpha), 0.03 rad from home", timings, reference=timings[0])
    report_target("assembly per call: robot.configuration", timings[-1].median, None)


if __name__ == "__main__":
    main()

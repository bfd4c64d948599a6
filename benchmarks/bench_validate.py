"""Cost of ``validate`` (analytic model vs the constrained Pinocchio model) on 10 000 states.

Run: ``python benchmarks/bench_validate.py [--repeats 5] [--samples 10000]``

Cases: ``validate(robot, samples)`` in-process (imports and the robot's compilation excluded);
its Pinocchio side alone as ``validate`` runs it (the closed-form starts for all states, then the
closure gap and the projection of the one robot model in the compiled core) and, as the
reference, the same through the robot's Python methods (``closure_gap``, ``reduced_terms``) on a
subset scaled to the same number of states; and the command ``delta-pin validate --samples N``
end to end in a fresh interpreter (imports included: the issue's target is 2 s).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

from common import Timing, machine_info, measure, print_table, report_target

import delta_pin as dp
from delta_pin.model.core_model import core_model
from delta_pin.model.kinematics import forward_kinematics
from delta_pin.model.validation import sample_states, validate

TARGET = 2.0  # [s] delta-pin validate --samples 10000 (issue 7)


def _pinocchio_side_core(robot, core, alpha, alpha_dot, xyz) -> None:
    closed = robot.pinocchio
    for d, q in zip(
        alpha_dot, robot.delta.closed_form_configurations(closed.model, closed.closures, alpha, xyz)
    ):
        core.closure_gap(q)
        core.reduced_terms(q, d)


def _pinocchio_side_python(robot, alpha, alpha_dot, xyz) -> None:
    closed = robot.pinocchio
    for a, d, x in zip(alpha, alpha_dot, xyz):
        q = robot.delta.closed_form_configuration(closed.model, closed.closures, a, x)
        closed.closure_gap(q)
        closed.reduced_terms(a, d, q)


def _command(samples: int) -> None:
    subprocess.run(
        [sys.executable, "-m", "delta_pin.cli", "validate", "--samples", str(samples)],
        check=True,
        stdout=subprocess.DEVNULL,
    )


def _scaled(name: str, function, repeats: int, factor: float, note: str) -> Timing:
    """Wall times of ``function`` multiplied by ``factor`` (a subset scaled to the full count)."""
    function()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append((time.perf_counter() - start) * factor)
    return Timing(name, times, note)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--samples", type=int, default=10_000)
    args = parser.parse_args()
    robot = dp.load_delta()
    core, n, r = core_model(robot), args.samples, args.repeats
    alpha, alpha_dot = sample_states(robot, n)
    xyz = forward_kinematics(robot.params, alpha)
    subset = max(n // 20, 1)
    timings = [
        measure(f"delta-pin validate --samples {n} (fresh process)", lambda: _command(n), r),
        measure(f"validate(robot, samples={n}), in-process", lambda: validate(robot, samples=n), r),
        measure(
            f"Pinocchio side in the core, as validate runs it ({n} states)",
            lambda: _pinocchio_side_core(robot, core, alpha, alpha_dot, xyz),
            r,
        ),
        _scaled(
            f"Pinocchio side through the robot's Python methods ({n} states)",
            lambda: _pinocchio_side_python(robot, alpha[:subset], alpha_dot[:subset], xyz[:subset]),
            r,
            n / subset,
            f"{subset} states timed, scaled",
        ),
    ]
    print(f"machine: {machine_info()}")
    print_table(f"validate on {n} random states", timings, reference=timings[0])
    command = timings[0].median
    report_target(f"delta-pin validate --samples {n}", command, TARGET if n == 10_000 else None)


if __name__ == "__main__":
    main()

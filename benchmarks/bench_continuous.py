"""Continuous mode of closed chains in the compiled core (issue 23): five-bar, 3-RRR, Stewart.

Run: ``python benchmarks/bench_continuous.py [--repeats 3] [--t-end 15]``

Each case is a whole ``dp.simulate`` call as a user waits for it (reference tabulation, the core's
plant and law built, the run): design I on the projected nominal model along a joint sinusoid
(0.5 Hz; 0.1 rad on the five-bar, 0.05 rad phase-shifted on the 3-RRR, 10 mm phase-shifted on the
Stewart platform's legs), from the robot's home, so the run starts with a reaching phase.

* the core's Radau IIA (the default, ``delta_pin/core/integrate/radau.hpp``) at rtol 1e-6, atol 1e-8;
* on the five-bar, the same with the readable design I in Python called back from the core's loop
  once per evaluation (what a user's own continuous-time law gets);
* the Python route it replaced, now the test oracle: the Python plant in active coordinates and
  the readable law under LSODA in the Python reference loop (tests/reference's
  ``simulate_reference(..., integrator="lsoda")``), the reference of the ratio;
* accuracy: the largest joint difference from the core's Radau at rtol 1e-10, atol 1e-12 (a
  tight run of the same ODE; tests/sim/test_core_continuous.py holds the core to LSODA at
  rtol 1e-10 over a short horizon).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from common import format_value, machine_info, measure, print_table, report_target

import delta_pin as dp

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository root: tests.reference
from tests.reference.laws import called_back
from tests.reference.python_loop import simulate_reference

CASES = {
    "five_bar": (0.1, 0.0),
    "three_rrr": (0.05, [0.0, 2.1, 4.2]),
    "stewart": (0.01, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--t-end", type=float, default=15.0, help="simulated time [s]")
    parser.add_argument("--robots", nargs="*", default=list(CASES), choices=list(CASES))
    args = parser.parse_args()
    print(f"machine: {machine_info()}")
    for name in args.robots:
        amplitude, phase = CASES[name]
        robot = dp.load_robot(name)
        path = dp.JointSinusoid(robot.home, amplitude=amplitude, frequency=0.5, phase=phase)
        nominal = dp.ClosedChainNominalModel(robot)

        def run(robot=robot, path=path, nominal=nominal, simulate=dp.simulate, **options):
            return simulate(
                robot, dp.design1(nominal), path, t_end=args.t_end, mode="continuous", alpha0=robot.home,
                **options,
            )  # fmt: skip

        core = measure(f"{name}: the core's Radau IIA", run, args.repeats)
        python = measure(
            f"{name}: the Python plant and law, LSODA, Python reference (tests/reference)",
            lambda run=run: run(simulate=simulate_reference, integrator="lsoda"),
            1,
        )
        cases = [core, python]
        if name == "five_bar":  # a law in Python (the readable design I) called back per evaluation

            def callback(robot=robot, path=path, nominal=nominal):
                controller = called_back(dp.design1(nominal))
                return dp.simulate(
                    robot, controller, path, t_end=args.t_end, mode="continuous", alpha0=robot.home
                )  # fmt: skip

            cases.insert(
                1, measure(f"{name}: the core's Radau IIA, the law in Python", callback, args.repeats)
            )
        print_table(f"{args.t_end:g} s of {name} ({robot.dof} DOF), design I continuous", cases, python)
        default, tight = run(), run(rtol=1e-10, atol=1e-12)
        assert default.metadata["integrator"] == "radau" and tight.metadata["integrator"] == "radau"
        error = float(np.abs(default.alpha - tight.alpha).max())
        meta = default.metadata
        print(
            f"  Radau: {meta['radau_steps']} steps ({meta['radau_rejected']} rejected), "
            f"{meta['rhs_evaluations']} evaluations, {meta['jacobians']} Jacobians; loop "
            f"{format_value(meta['wall_time'])}; |alpha - alpha_tight| max {error:.2e} rad"
        )
        report_target(f"{name}, {args.t_end:g} s continuous design I (core Radau)", core.median, 1.0)
        report_target(f"{name}, continuous, max |alpha - tight run|", error, 1e-6, "rad")


if __name__ == "__main__":
    main()

"""Time a 15 s closed-loop run on both plants in both timing modes.

Run: ``python benchmarks/bench_simulate.py [--repeats 3] [--t-end 15]``

Scenario: path I from alpha_0 = 0.3322 rad, Stribeck friction and the paper's uncertainty
(Delta_m = Delta_fc = Delta_f = 0.3), controller C1 + C2 (computed torque) with friction compensation.
Sampled mode: RK4 at 1 kHz with zero-order hold; continuous mode: LSODA (rtol 1e-6) with the
controller inside the integrator.
"""

from __future__ import annotations

import argparse

import numpy as np
from common import machine_info, measure, print_table

import delta_pin as dp


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--t-end", type=float, default=15.0)
    args = parser.parse_args()
    robot = dp.load_delta()
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))

    def run(plant: str, mode: str):
        return lambda: dp.simulate(
            robot,
            dp.ComputedTorque(nominal),
            dp.PathI(),
            plant=plant,
            mode=mode,
            t_end=args.t_end,
            alpha0=np.full(3, 0.3322),
            friction=dp.Friction(),
            uncertainty=dp.PaperUncertainty(),
        )

    timings = [
        measure(f"{plant}, {mode}", run(plant, mode), args.repeats, note=f"{args.t_end:g} s simulated")
        for plant in ("pinocchio", "analytic")
        for mode in ("sampled", "continuous")
    ]
    print(f"machine: {machine_info()}")
    print_table(f"simulate(): {args.t_end:g} s of path I", timings, reference=timings[0])


if __name__ == "__main__":
    main()

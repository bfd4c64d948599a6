"""Tune design I's boundary layer xi with a batch: one compiled call simulates every candidate.

Run: ``python examples/batch_tune_xi.py [--t-end 5] [--xi 0.0005,0.001,0.005,0.02,0.1]``

Continuous mode, analytic plant, the paper's Section V scenario (path I, Stribeck friction,
Delta = 0.3 sinusoids): for each xi the tracking error after the first second and the peak
robust torque, i.e. the accuracy a wider boundary layer gives away and the chattering it saves.
"""

import argparse

import numpy as np

import delta_pin as dp
from delta_pin.sim.uncertainty import PAPER_NOMINAL_DISTURBANCE


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=5.0)
    parser.add_argument("--xi", default="0.0005,0.001,0.005,0.02,0.1", help="comma-separated [N m]")
    args = parser.parse_args()
    xis = [float(x) for x in args.xi.split(",")]

    robot = dp.load_delta()
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=PAPER_NOMINAL_DISTURBANCE)
    controllers = [dp.design1(nominal, xi=xi) for xi in xis]
    uncertainty = dp.PaperUncertainty(0.3, 0.3, 0.3, PAPER_NOMINAL_DISTURBANCE)
    runs = dp.simulate_batch(
        robot,
        controllers,
        dp.PathI(),
        t_end=args.t_end,
        alpha0=np.full(3, 0.3322),
        friction=dp.Friction(),
        uncertainties=[uncertainty] * len(xis),
    )
    print(f"{'xi [N m]':>10} {'max |r| after 1 s [rad]':>24} {'peak |C3| [N m]':>16} {'wall [s]':>9}")
    for xi, run in zip(xis, runs):
        late = run.t >= min(1.0, run.t[-1] / 2)
        error = np.abs(run.error[late]).max()
        robust = np.abs(run.internals["robust_torque"][late]).max()
        print(f"{xi:>10g} {error:>24.3e} {robust:>16.3f} {run.metadata['wall_time']:>9.3f}")


if __name__ == "__main__":
    main()

"""Robots whose motors do not determine their whole motion, in the compiled core (issue 23).

Run: ``python benchmarks/bench_unactuated.py [--repeats 3] [--t-end 1]``

Each case is a whole ``dp.simulate`` call as a user waits for it, the core (the only engine of
``dp.simulate``) against the Python reference loop on the Python plant (tests/reference's
``simulate_reference``), the reference of the ratio:

* Gepetto's ``5bar_linkage`` and ``robot_delta`` as shipped (tests/data/gepetto: welded coaxial
  revolutes that spin freely) and the ball-ball Delta (six rod spins): design I on the projected
  nominal model along a 0.02 rad, 1 Hz joint sinusoid, started on it; sampled at 1 kHz with the
  sampling-aware gains (robot_delta's gram-weight links put any 1 kHz loop with these gains past
  stability: it runs continuous only), and continuous (the core's Radau IIA on the whole state
  [q, v, rho_hat] and its fixed-step BDF2 at 1 ms against LSODA, Python reference
  (tests/reference), on the Python plant in full coordinates, both at rtol 1e-6, and each one's
  largest deviation from LSODA at rtol 1e-9; robot_delta's stiff whole state makes Radau IIA
  slower than LSODA there, timed once: its Newton iterations fail, not its error test);
* menagerie's Robotiq 2F-85 (two sprung passive links, the drivers tied by a joint coupling) under
  a constant 1 N tendon force of the user's (a Python function), sampled with 4 RK4 sub-steps.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
from common import machine_info, measure, print_table

import delta_pin as dp

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository root: tests.reference
from tests.reference.python_loop import simulate_reference

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"


def _load(name: str) -> dp.ClosedChainRobot:
    if name == "delta_ballrods":
        return dp.load_robot(name)
    return dp.load_robot(DATA / "gepetto" / name / "robot.urdf")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--t-end", type=float, default=1.0, help="simulated time [s]")
    args = parser.parse_args()
    print(f"machine: {machine_info()}")
    for name, modes in (
        ("5bar_linkage", ("sampled", "continuous")),
        ("robot_delta", ("continuous",)),
        ("delta_ballrods", ("sampled", "continuous")),
    ):
        robot = _load(name)
        path = dp.JointSinusoid(robot.home, amplitude=0.02, frequency=1.0)
        nominal = dp.ClosedChainNominalModel(robot)
        alpha_dot0 = np.full(robot.dof, 0.02 * 2 * np.pi)
        for mode in modes:
            period = 1e-3 if mode == "sampled" else None

            def run(
                simulate,
                robot=robot,
                path=path,
                nominal=nominal,
                mode=mode,
                period=period,
                v0=alpha_dot0,
                **options,
            ):
                law = dp.design1(nominal, sampling_period=period)
                return simulate(robot, law, path, t_end=args.t_end, mode=mode, alpha_dot0=v0, **options)

            # robot_delta's continuous run takes seconds per simulated second (module docstring): once
            repeats = 1 if name == "robot_delta" else args.repeats
            core = measure(f"{name}, {mode}: the core", lambda run=run: run(dp.simulate), repeats)
            python = measure(
                f"{name}, {mode}: "
                + ("LSODA, Python reference" if mode == "continuous" else "the Python reference loop")
                + " (tests/reference)",
                lambda run=run: run(simulate_reference),
                1,
            )
            cases = [core, python]
            if mode == "continuous":  # the core's fixed-step BDF2 (1 ms) too
                bdf2 = measure(
                    f"{name}, {mode}: the core's BDF2 (1 ms)",
                    lambda run=run: run(dp.simulate, integrator="bdf2"),
                    repeats,
                )
                cases.insert(1, bdf2)
            print_table(
                f"{args.t_end:g} s of {name} ({robot.dof} actuated, {robot.idle_dof} idle), design I {mode}",
                cases,
                python,
            )
            meta = run(dp.simulate).metadata
            if mode == "continuous":
                tight = run(simulate_reference, rtol=1e-9, atol=1e-11).alpha
                radau, bdf2 = run(dp.simulate).alpha, run(dp.simulate, integrator="bdf2").alpha
                print(
                    f"  Radau: {meta['radau_steps']} steps ({meta['radau_rejected']} rejected), "
                    f"{meta['rhs_evaluations']} evaluations, {meta['jacobians']} Jacobians; largest |alpha - "
                    f"LSODA at rtol 1e-9|: Radau {np.abs(radau - tight).max():.2e} rad, BDF2 "
                    f"{np.abs(bdf2 - tight).max():.2e} rad"
                )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the file's position servo, read as a force source
        robotiq = dp.load_robot(DATA / "menagerie" / "robotiq_2f85" / "2f85.xml")

    def pull(t, alpha, alpha_dot):
        return np.array([1.0])

    def gripper(simulate):
        return simulate(
            robotiq, pull, None, t_end=args.t_end, mode="sampled", substeps=4, alpha0=robotiq.home
        )

    core = measure("Robotiq, sampled: the core", lambda: gripper(dp.simulate), args.repeats)
    python = measure(
        "Robotiq, sampled: the Python reference loop (tests/reference)",
        lambda: gripper(simulate_reference),
        1,
    )
    print_table(f"{args.t_end:g} s of the Robotiq 2F-85 (joint coupling, 2 passive)", [core, python], python)


if __name__ == "__main__":
    main()

"""Median time of one controller step (torque and state derivative) from Python.

Run: ``python benchmarks/bench_controllers.py [--repeats 5] [--calls 2000]``

Each controller is evaluated at the paper's initial state on path I (alpha_0 = 0.3322 rad) with
its Delta nominal model; the time is per call, the median over ``repeats`` batches of ``calls``.
Three rows per law, measured in the same run: the readable law (Python and numpy,
``tests/reference/laws.py``: the reference of the ratios), ``Controller.evaluate`` (the compiled
law through the controller, what ``Controller.step`` calls) and the compiled law alone
(``sampled_core_law().evaluate``, what the compiled loops run, called once from Python).
"""

from __future__ import annotations

import argparse

import numpy as np
from common import Timing, machine_info, per_call, print_table, report_target

import delta_pin as dp
from delta_pin.control import Reference
from tests.reference.laws import readable_evaluate

STEP_LIMIT = 10e-6  # [s] issue 7: a controller step of designs I and II fit for a 10 kHz drive


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--calls", type=int, default=2000)
    args = parser.parse_args()
    robot = dp.load_delta()
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    reference = dp.PathI().joint_reference(robot, np.array([0.0]))
    ref = Reference(reference.alpha[0], reference.alpha_dot[0], reference.alpha_ddot[0])
    alpha, alpha_dot = np.full(3, 0.3322), np.array([0.1, -0.2, 0.05])
    controllers = {
        "design I": dp.design1(nominal),
        "design II": dp.design2(nominal),
        "design I, sampling-aware": dp.design1(nominal, sampling_period=1e-3),
        "computed torque": dp.ComputedTorque(nominal),
        "PD + gravity": dp.PDGravity(nominal),
        "LQR": dp.LQR(nominal, reference.alpha[0]),
        "digital robust (delay 1)": dp.digital_robust(nominal, 1e-3, delay=1),
        "TDC (delay 1)": dp.tdc(nominal, 1e-3, delay=1),
    }
    timings = []
    note = f"per call, {args.calls} calls per repeat"
    for name, controller in controllers.items():
        state = controller.initial_state()
        if controller.dt is not None:  # a discrete-time law: from a running state, not the first sample
            state = controller.evaluate(0.0, alpha, alpha_dot, ref, state).next_state
        readable = readable_evaluate(controller)
        times = per_call(
            lambda f=readable, z=state: f(0.0, alpha, alpha_dot, ref, z), args.calls, args.repeats
        )
        timings.append(Timing(f"{name}, readable (tests/reference)", times, note=note))
        times = per_call(
            lambda c=controller, z=state: c.evaluate(0.0, alpha, alpha_dot, ref, z), args.calls, args.repeats
        )
        timings.append(Timing(f"{name}, Controller.evaluate", times, note=note))
        law = controller.sampled_core_law()
        if law is not None:  # the core is importable here
            times = per_call(
                lambda law=law, z=state: law.evaluate(
                    alpha, alpha_dot, ref.alpha, ref.alpha_dot, ref.alpha_ddot, z
                ),
                args.calls,
                args.repeats,
            )
            timings.append(Timing(f"{name}, compiled core", times, note=note))
    print(f"machine: {machine_info()}")
    print_table("one controller step (torque + state derivative)", timings, reference=timings[0])
    for timing in timings:
        if timing.name in (
            "design I, compiled core",
            "design II, compiled core",
            "digital robust (delay 1), compiled core",
        ):
            report_target(f"one controller step, {timing.name}", timing.median, STEP_LIMIT)


if __name__ == "__main__":
    main()

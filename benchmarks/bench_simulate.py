"""Time closed-loop runs on both plants in both timing modes, and the two run-time targets of
issue 7.

Run: ``python benchmarks/bench_simulate.py [--repeats 3] [--t-end 15]``

Scenario of the first table: path I from alpha_0 = 0.3322 rad, Stribeck friction and the paper's
uncertainty (Delta_m = Delta_fc = Delta_f = 0.3), controller C1 + C2 (computed torque) with
friction compensation. Sampled mode: RK4 at 1 kHz with zero-order hold; continuous mode: the
integrator of ``delta_pin.sim.runner`` with the controller inside.

Second table: design I on the Pinocchio plant as ``delta_pin.studies.experiments.RunSpec`` runs it
(Section V conditions), sampled at 1 kHz with the sampling-aware gain cap (target: 15 s in at most
1 s, closure residual <= 1e-9 m; the compiled core's plant and law) and continuous
with the paper's gains: the default, the compiled Radau IIA (issue 14: at most 1.0 s, within 1e-6
rad of a tight reference), and the fixed-step BDF2 (at most 1.3 s). Each target row has its
reference in the same table: the Python reference loop (tests/reference: RK4 on the Python plant)
and LSODA in that loop (timed once: ~20 s). The accuracy is measured against LSODA at rtol 1e-11
in the reference loop (~30 s). With ``--t-end`` shorter than 15 s the time limits are scaled by
t_end / 15. Then the LQR's continuous run (``reproduce --full``'s two slowest runs before issue
14): the compiled Radau IIA against LSODA (the reference loop), and against LSODA at rtol 1e-10.

Each case is warmed up by a 0.2 s run (numba compilation, caches), then timed ``repeats`` times.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from common import machine_info, measure, print_table, report_target

import delta_pin as dp
from delta_pin.sim.runner import simulate
from delta_pin.studies.experiments import (
    RunSpec,
    build_controller,
    build_trajectory,
    build_uncertainty,
    run_spec,
)

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository root: tests.reference
from tests.reference.python_loop import simulate_reference


def run_reference(spec: RunSpec, robot, **options):
    """``run_spec(spec, robot)`` in the Python reference loop (tests/reference): the same
    trajectory, controller, uncertainty, friction and drive; its integrator the loop's default for
    the mode (RK4 sampled, LSODA continuous), ``spec.integrator`` ignored; ``options`` (e.g.
    ``integrator``, ``rtol``, ``atol``) go to ``simulate_reference``."""
    trajectory = build_trajectory(spec.path)
    return simulate_reference(
        robot, build_controller(spec, robot, trajectory), trajectory, plant=spec.plant,
        t_end=spec.duration, dt=spec.dt, mode=spec.mode,
        alpha0=None if spec.alpha0 is None else np.full(3, spec.alpha0),
        friction=dp.Friction() if spec.friction else None, uncertainty=build_uncertainty(spec),
        sensor=spec.sensor(), delay=spec.delay, torque_limit=spec.torque_limit, **options,
    )  # fmt: skip


WARMUP_T_END = 0.2  # [s]
PAPER_T_END = 15.0  # [s] the duration the targets are stated for
SAMPLED = RunSpec(controller="design1", plant="pinocchio", mode="sampled", sampling_aware=True)
CONTINUOUS = RunSpec(controller="design1", plant="pinocchio", mode="continuous", integrator="bdf2")
TARGETS = {  # label: (spec, its runner, limit for 15 s [s] or None for a reference, repeats)
    "design I, sampling-aware, sampled (RK4 1 kHz), compiled": (SAMPLED, run_spec, 1.0, None),
    "the same, the Python reference loop (tests/reference)": (SAMPLED, run_reference, None, 1),
    "design I, paper gains, continuous, the default (compiled Radau IIA)": (
        CONTINUOUS.with_(integrator="auto"),
        run_spec,
        1.0,
        None,
    ),
    "design I, paper gains, continuous, compiled BDF2 (1 ms)": (CONTINUOUS, run_spec, 1.3, None),
    "the same, LSODA, Python reference (tests/reference; SciPy, rtol 1e-6: the default before Radau)": (
        CONTINUOUS,
        run_reference,
        None,
        1,
    ),
}
CLOSURE_LIMIT = 1e-9  # [m]
# issue 13: the digital laws on a digital drive (17-bit encoders, one sample of delay), Pinocchio plant
DRIVE = {"encoder_bits": 17, "delay": 1}
DIGITAL = {  # label: (spec, its runner, repeats or None)
    "design I, sampling-aware, exact state, compiled (the reference)": (SAMPLED, run_spec, None),
    "digital robust, compiled": (SAMPLED.with_(controller="digital-robust", **DRIVE), run_spec, None),
    "digital robust, the Python reference loop (tests/reference)": (
        SAMPLED.with_(controller="digital-robust", **DRIVE),
        run_reference,
        1,
    ),
    "TDC, mean pairing, compiled": (
        SAMPLED.with_(controller="tdc", gains={"pairing": "mean"}, **DRIVE),
        run_spec,
        None,
    ),
}


def _timed(function):
    """``function()`` and its wall time [s] (the reference loop's runs carry no ``wall_time``)."""
    start = time.perf_counter()
    result = function()
    return result, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--t-end", type=float, default=PAPER_T_END)
    args = parser.parse_args()
    robot = dp.load_delta()
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))

    def run(plant: str, mode: str, t_end: float):
        return lambda: simulate(
            robot,
            dp.ComputedTorque(nominal),
            dp.PathI(),
            plant=plant,
            mode=mode,
            t_end=t_end,
            alpha0=np.full(3, 0.3322),
            friction=dp.Friction(),
            uncertainty=dp.PaperUncertainty(),
        )

    note = f"{args.t_end:g} s simulated"
    timings = [
        measure(
            f"{plant}, {mode}",
            run(plant, mode, args.t_end),
            args.repeats,
            note,
            warmup=run(plant, mode, WARMUP_T_END),
        )
        for plant in ("pinocchio", "analytic")
        for mode in ("sampled", "continuous")
    ]
    print(f"machine: {machine_info()}")
    print_table(f"simulate(): {args.t_end:g} s of path I, computed torque", timings, reference=timings[0])

    scale = args.t_end / PAPER_T_END
    targets, residuals = [], {}
    for label, (spec, runner, limit, repeats) in TARGETS.items():
        timed = spec.with_(t_end=args.t_end)

        def call(timed=timed, label=label, runner=runner):
            residuals[label] = float(np.max(runner(timed, robot).closure_residual))

        goal = "reference" if limit is None else f"target <= {limit * scale:.3g} s"
        timing = measure(
            f"Pinocchio plant, {label}",
            call,
            repeats or args.repeats,
            f"{args.t_end:g} s; {goal}",
            warmup=lambda spec=spec, runner=runner: runner(spec.with_(t_end=WARMUP_T_END), robot),
        )
        timing.note += f"; closure residual {residuals[label]:.1e} m"
        targets.append((label, timing, limit))
    print_table(
        f"issue 7 run-time targets: design I, {args.t_end:g} s of path I",
        [t for _, t, _ in targets],
    )
    (sampled, compiled, _), (_, python_loop, _) = targets[0], targets[1]
    print(f"{sampled}: {python_loop.median / compiled.median:.1f}x faster than the Python reference loop")
    lsoda = targets[-1][1]
    for label, timing, _ in targets[2:4]:
        print(f"{label}: {lsoda.median / timing.median:.1f}x faster than LSODA")

    for label, timing, limit in targets:
        if limit is not None:
            suffix = "" if scale == 1.0 else f" (scaled to {args.t_end:g} s)"
            report_target(f"15 s {label}, Pinocchio plant{suffix}", timing.median, limit * scale)
    sampled = next(iter(TARGETS))
    report_target(f"closure residual of the {sampled} run", residuals[sampled], CLOSURE_LIMIT, unit="m")

    # issue 14: accuracy of the continuous default against a tight reference (LSODA at rtol 1e-11 in
    # the Python reference loop, which agrees with itself at 1e-10 to 4e-8 rad and across the two
    # plants to 3e-11 rad)
    default = run_spec(CONTINUOUS.with_(integrator="auto", t_end=args.t_end), robot)
    tight, seconds = _timed(
        lambda: run_reference(
            CONTINUOUS.with_(t_end=args.t_end), robot, integrator="lsoda", rtol=1e-11, atol=1e-13
        )
    )
    deviation = float(np.abs(default.alpha - tight.alpha).max())
    print(
        f"\ncontinuous default ({default.metadata['integrator']}) against LSODA at rtol 1e-11: "
        f"{deviation:.1e} rad over {args.t_end:g} s (the reference took {seconds:.1f} s)"
    )
    report_target(
        "continuous design I default: deviation from a tight reference", deviation, 1e-6, unit="rad"
    )

    # issue 14: the LQR's continuous runs of ``reproduce --full`` (path I, Pinocchio plant): the
    # compiled Radau IIA with the LQR's compiled law (the default since issue 14) against LSODA
    # (the only integrator the LQR had before; now in the Python reference loop), same run; and the
    # Radau run's deviation from LSODA at rtol 1e-10 (the test at 2 s: tests/sim/test_radau.py)
    lqr = RunSpec(controller="lqr", plant="pinocchio", t_end=args.t_end)
    lqr_timings = [
        measure(
            "LQR, continuous, the default (compiled Radau IIA)",
            lambda: run_spec(lqr, robot),
            args.repeats,
            f"{args.t_end:g} s, Pinocchio plant",
            warmup=lambda: run_spec(lqr.with_(t_end=WARMUP_T_END), robot),
        ),
        measure(
            "the same, LSODA, Python reference (tests/reference; rtol 1e-6: the LQR's integrator "
            "before issue 14)",
            lambda: run_reference(lqr, robot),
            1,
            f"{args.t_end:g} s, Pinocchio plant",
            warmup=lambda: run_reference(lqr.with_(t_end=WARMUP_T_END), robot),
        ),
    ]
    print_table(
        f"issue 14: the LQR, continuous, {args.t_end:g} s of path I", lqr_timings, reference=lqr_timings[1]
    )
    fast = run_spec(lqr, robot)
    tight, seconds = _timed(lambda: run_reference(lqr, robot, integrator="lsoda", rtol=1e-10, atol=1e-13))
    print(
        f"LQR default ({fast.metadata['integrator']}) against LSODA at rtol 1e-10: "
        f"{np.abs(fast.alpha - tight.alpha).max():.1e} rad over {args.t_end:g} s "
        f"(the reference took {seconds:.1f} s)"
    )

    digital = [
        measure(
            label,
            lambda spec=spec, runner=runner: runner(spec.with_(t_end=args.t_end), robot),
            repeats or args.repeats,
            f"{args.t_end:g} s, Pinocchio plant",
            warmup=lambda spec=spec, runner=runner: runner(spec.with_(t_end=WARMUP_T_END), robot),
        )
        for label, (spec, runner, repeats) in DIGITAL.items()
    ]
    print_table(
        f"issue 13: digital laws, 17-bit encoders and one sample of delay, {args.t_end:g} s of path I",
        digital,
        reference=digital[0],
    )
    report_target(
        "digital robust compiled / design I compiled, 15 s Pinocchio plant (issue 13: no longer)",
        digital[1].median / digital[0].median,
        1.0,
        unit="x",
    )


if __name__ == "__main__":
    main()

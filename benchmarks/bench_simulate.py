"""Time closed-loop runs on both plants in both timing modes, and the two run-time targets of
issue 7.

Run: ``python benchmarks/bench_simulate.py [--repeats 3] [--t-end 15]``

Scenario of the first table: path I from alpha_0 = 0.3322 rad, Stribeck friction and the paper's
uncertainty (Delta_m = Delta_fc = Delta_f = 0.3), controller C1 + C2 (computed torque) with
friction compensation. Sampled mode: RK4 at 1 kHz with zero-order hold; continuous mode: the
integrator of ``delta_pin.simulate`` with the controller inside.

Second table: design I on the Pinocchio plant as ``delta_pin.experiments.RunSpec`` runs it
(Section V conditions), sampled at 1 kHz with the sampling-aware gain cap (target: 15 s in at most
1 s, closure residual <= 1e-9 m) and continuous with the paper's gains (target: 15 s in at most
1.3 s). With ``--t-end`` shorter than 15 s the time limits are scaled by t_end / 15.

Each case is warmed up by a 0.2 s run (numba compilation, caches), then timed ``repeats`` times.
"""

from __future__ import annotations

import argparse

import numpy as np
from common import machine_info, measure, print_table, report_target

import delta_pin as dp
from delta_pin.experiments import RunSpec, run_spec
from delta_pin.simulate import simulate

WARMUP_T_END = 0.2  # [s]
PAPER_T_END = 15.0  # [s] the duration the targets are stated for
TARGETS = {  # label: (spec, limit for 15 s [s])
    "design I, sampling-aware, sampled (RK4 1 kHz)": (
        RunSpec(controller="design1", plant="pinocchio", mode="sampled", sampling_aware=True),
        1.0,
    ),
    "design I, paper gains, continuous": (
        RunSpec(controller="design1", plant="pinocchio", mode="continuous"),
        1.3,
    ),
}
CLOSURE_LIMIT = 1e-9  # [m]


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
    for label, (spec, limit) in TARGETS.items():
        timed = spec.with_(t_end=args.t_end)

        def call(timed=timed, label=label):
            residuals[label] = float(np.max(run_spec(timed, robot).closure_residual))

        timing = measure(
            f"Pinocchio plant, {label}",
            call,
            args.repeats,
            f"{args.t_end:g} s; target <= {limit * scale:.3g} s",
            warmup=lambda spec=spec: run_spec(spec.with_(t_end=WARMUP_T_END), robot),
        )
        timing.note += f"; closure residual {residuals[label]:.1e} m"
        targets.append((label, timing, limit))
    print_table(f"issue 7 run-time targets: design I, {args.t_end:g} s of path I", [t for _, t, _ in targets])

    for label, timing, limit in targets:
        suffix = "" if scale == 1.0 else f" (scaled to {args.t_end:g} s)"
        report_target(f"15 s {label}, Pinocchio plant{suffix}", timing.median, limit * scale)
    sampled = next(iter(TARGETS))
    report_target(f"closure residual of the {sampled} run", residuals[sampled], CLOSURE_LIMIT, unit="m")


if __name__ == "__main__":
    main()

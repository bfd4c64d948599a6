"""Closed-chain identification (issue 24): the targets table on the Table-1 Delta, and the five-bar
and Stewart platform identified and validated.

Run: ``python benchmarks/bench_identification.py [--repeats 3] [--iterations 40] [--quick]``

Scenario (the issue's): the CAD robot is the packaged Delta (Table 1); the true one has its masses
changed by +-30 % (m_a = 0.26, m_b = 0.14, m_o = 0.39 kg against 0.2, 0.2, 0.3) and the paper's
friction (eq. 12, F_n = 15 N), on the Pinocchio plant; a 20 s excitation at 1 kHz optimised on the
CAD robot (``optimize_excitation``: 6 harmonics, period 2.5 s, +-0.6 rad about alpha = 0.3 rad,
8 rad/s, 40 iterations); 17-bit encoders; torque noise 1 % of each joint's RMS torque. The fit never sees the
true robot; the table compares its base parameters with the true robot's
(``BaseParameters.values`` of the true standard parameters):

* base parameters recovered: the relative error of each base parameter whose true value is not
  0, split into mass-like (inertial) and friction; the essential fit (the default) and the fit of
  every base parameter;
* torque prediction on an unseen trajectory (another seed's excitation, 10 s): RMS of the error over
  RMS of the torque;
* design I (the paper's gains, continuous mode, path I, 15 s, on the true robot's Pinocchio plant with
  its friction) with the identified Delta (``load_delta(**xacro_arguments)``: the lumped terms, the
  friction) as nominal model against the same with the true Delta's: max |r| over the last 5 s;
* the fit's time (20 s at 1 kHz: read from memory, filter, regressor, least squares; and with the
  physically consistent estimate), median of ``--repeats``.

The five-bar and the Stewart platform: true robot = each body's inertia scaled by a seeded factor in
[0.7, 1.3] (``perturbed_robot``), no friction in their files, 20 s (five-bar) / 10 s (Stewart) logs.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np
from common import machine_info

import delta_pin as dp
from delta_pin.identification.base import base_parameters
from delta_pin.identification.excitation import ExcitationLimits, FourierExcitation, optimize_excitation
from delta_pin.identification.regressor import ClosedChainRegressor, JointColumns
from delta_pin.identification.workflow import (
    friction_truth,
    identify,
    perturbed_robot,
    simulate_log,
    validate,
)
from delta_pin.studies.metrics import compute_metrics

TRUE_MASSES = {"m_a": 0.26, "m_b": 0.14, "m_o": 0.39}
TARGETS = {"mass": 0.01, "friction": 0.05, "torque": 0.02, "design": 0.10, "time": 2.0}


def recovery(result, theta_true) -> dict:
    """Relative errors of the base parameters with a nonzero true value, by kind."""
    truth = result.base.values(theta_true)
    n = result.regressor.inertial_count
    out = {"mass": [], "friction": [], "names_mass": [], "names_friction": []}
    for i, k in enumerate(result.base.independent):
        if abs(truth[i]) < 1e-9:
            continue
        error = abs(result.wls.beta[i] - truth[i]) / abs(truth[i])
        prefix = result.names[i].split("[")[0]
        kind = "friction" if k >= n and prefix in ("fv", "fc", "fs") else "mass"
        out[kind].append(float(error))
        out["names_" + kind].append(result.names[i])
    return out


def excitation(robot, alpha0, limits, iterations, duration, seed, harmonics=8, period=5.0):
    regressor = ClosedChainRegressor(robot)
    base = base_parameters(regressor)
    start = time.perf_counter()
    trajectory, info = optimize_excitation(regressor, base, regressor.parameters(), alpha0=alpha0,
                                           limits=limits,
                                           max_iterations=iterations, duration=duration, seed=seed,
                                           harmonics=harmonics, period=period)  # fmt: skip
    info["seconds"] = time.perf_counter() - start
    return trajectory, info


def design1_error(nominal_robot, true_robot, rtol: float = 1e-6) -> float:
    """max |r| [rad] over the last 5 s of design I on path I (continuous, Radau at ``rtol``, atol
    rtol / 100) on the true robot's plant."""
    control = dp.design1(dp.DeltaNominalModel(nominal_robot, friction=dp.Friction()))
    run = dp.simulate(true_robot, control, dp.PathI(), plant="pinocchio", t_end=15.0, mode="continuous",
                      friction=dp.Friction(), rtol=rtol, atol=rtol * 1e-2)  # fmt: skip
    return compute_metrics(run).max_joint_error_last_5s


def delta_case(args) -> dict:
    nominal = dp.load_delta()
    true = dp.load_delta(**TRUE_MASSES)
    limits = ExcitationLimits(position_range=0.6, velocity_limit=8.0)
    if args.excitation:
        with open(args.excitation) as handle:
            trajectory = FourierExcitation.from_metadata(json.load(handle))
        info = {"condition": float("nan"), "seconds": 0.0, "from": args.excitation}
    else:
        trajectory, info = excitation(nominal, nominal.home + 0.3, limits, args.iterations, 20.0, 0,
                                      harmonics=6, period=2.5)  # fmt: skip
    unseen_trajectory, _ = excitation(nominal, nominal.home + 0.3, limits, 0, 10.0, 7)
    start = time.perf_counter()
    log, _ = simulate_log(true, trajectory, nominal=nominal, seed=1)
    simulate_s = time.perf_counter() - start
    unseen, _ = simulate_log(true, unseen_trajectory, nominal=nominal, seed=2)
    theta_true = ClosedChainRegressor(true).parameters(true, friction_truth(true, dp.Friction()))
    times, times_consistent, steps = [], [], []
    for _ in range(args.repeats):
        start = time.perf_counter()
        result = identify(nominal, log, consistent=False)
        times.append(time.perf_counter() - start)
        steps.append(result.timings)
    start = time.perf_counter()
    full = identify(nominal, log, essential=False)
    times_consistent.append(time.perf_counter() - start)
    essential = recovery(result, theta_true)
    every = recovery(full, theta_true)
    validation = validate(result, unseen)
    validation_full = validate(full, unseen)
    validation_consistent = validate(full, unseen, estimate="consistent")
    out = {
        "excitation": info,
        "simulate_s": simulate_s,
        "fit_s": sorted(times),
        "fit_with_consistent_s": times_consistent,
        "fit_steps_s": steps,
        "essential": essential,
        "every_base_parameter": every,
        "dropped": result.dropped,
        "validation": validation,
        "validation_every": validation_full,
        "validation_consistent": validation_consistent,
        "consistent_distance_relative": full.consistent.distance_relative,
        "consistent_distance_mahalanobis": full.consistent.distance_mahalanobis,
        "xacro_arguments": result.xacro_arguments,
        "lumped": result.lumped,
        "condition": result.condition,
        "rank": result.base.rank,
    }
    if not args.quick:
        identified = dp.load_delta(**result.xacro_arguments)
        error_identified = design1_error(identified, true)
        error_true = design1_error(true, true)
        error_cad = design1_error(nominal, true)
        out["design1"] = {"identified": error_identified, "true": error_true, "cad": error_cad,
                          "ratio": error_identified / error_true}  # fmt: skip
        # at the default tolerance both errors sit at Radau's resolution (~3e-8 rad, docs/architecture.md
        # section 6); at rtol 1e-8 the runs resolve the identified model's remaining error
        tight = {name: design1_error(robot, true, 1e-8) for name, robot in
                 (("identified", identified), ("true", true), ("cad", nominal))}  # fmt: skip
        out["design1_rtol_1e-8"] = {**tight, "ratio": tight["identified"] / tight["true"]}
    return out


def other_case(name: str, duration: float, iterations: int, args) -> dict:
    nominal = dp.load_robot(name)  # a shipped robot, by name
    true = perturbed_robot(nominal, 0.3, seed=3)
    trajectory, info = excitation(
        nominal, None, None, iterations, duration, 0, harmonics=6, period=duration / 2
    )
    unseen_trajectory, _ = excitation(
        nominal, None, None, 0, duration / 2, 7, harmonics=6, period=duration / 2
    )
    start = time.perf_counter()
    log, _ = simulate_log(true, trajectory, nominal=nominal, friction=None, seed=1)
    simulate_s = time.perf_counter() - start
    unseen, _ = simulate_log(true, unseen_trajectory, nominal=nominal, friction=None, seed=2)
    start = time.perf_counter()
    # the files carry no friction and their plants have none: no Coulomb column (its reversal
    # rows would go, and the Stewart's legs move at a few cm/s)
    columns = JointColumns(coulomb=False)
    result = identify(nominal, log, columns=columns)
    fit_s = time.perf_counter() - start
    theta_true = ClosedChainRegressor(true, columns).parameters(true)
    return {
        "excitation": info,
        "simulate_s": simulate_s,
        "fit_s": fit_s,
        "rank": result.base.rank,
        "kept": result.base.rank - len(result.dropped),
        "recovery": recovery(result, theta_true),
        "validation": validate(result, unseen),
        "validation_consistent": validate(result, unseen, estimate="consistent"),
        "condition": result.condition,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--iterations", type=int, default=40, help="excitation optimiser iterations (Delta)")
    parser.add_argument("--excitation", default=None, help="a FourierExcitation's metadata JSON instead")
    parser.add_argument("--quick", action="store_true", help="skip design I and the other robots")
    parser.add_argument("--json", default=None, help="write the numbers here")
    parser.add_argument(
        "--previous", default=None, help="take the Delta's numbers from this JSON (a run before)"
    )
    args = parser.parse_args()
    warnings.simplefilter("ignore", RuntimeWarning)
    print(machine_info())
    numbers = {}
    if args.previous:  # the Delta's numbers of an earlier run (its JSON)
        with open(args.previous) as handle:
            numbers["delta"] = json.load(handle)["delta"]
    else:
        numbers["delta"] = delta_case(args)
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(numbers, handle, indent=2, default=str)
    if not args.quick:
        numbers["five_bar"] = other_case("five_bar", 20.0, 10, args)
        numbers["stewart"] = other_case("stewart", 10.0, 3, args)
    d = numbers["delta"]
    e, every = d["essential"], d["every_base_parameter"]
    print("\n| metric | target | measured | met |\n|---|---|---|---|")

    def row(metric, target, value, ok):
        print(f"| {metric} | {target} | {value} | {'met' if ok else 'not met'} |")

    row("base parameters, mass-like (essential fit, max relative)", "<= 1 %", f"{max(e['mass']):.2%}",
        max(e["mass"]) <= TARGETS["mass"])  # fmt: skip
    row("base parameters, friction (essential fit, max relative)", "<= 5 %", f"{max(e['friction']):.2%}",
        max(e["friction"]) <= TARGETS["friction"])  # fmt: skip
    row("base parameters, mass-like (every base parameter fitted)", "<= 1 %", f"{max(every['mass']):.2%}",
        max(every["mass"]) <= TARGETS["mass"])  # fmt: skip
    row("base parameters, friction (every base parameter fitted)", "<= 5 %", f"{max(every['friction']):.2%}",
        max(every["friction"]) <= TARGETS["friction"])  # fmt: skip
    rms = d["validation"]["rms_relative_all"]
    row("torque prediction, unseen trajectory, RMS relative", "<= 2 %", f"{rms:.2%} (per joint "
        + ", ".join(f"{x:.2%}" for x in d["validation"]["rms_relative"]) + ")",
        rms <= TARGETS["torque"])  # fmt: skip
    if "design1" in d:
        g = d["design1"]
        row("design I identified vs true, path I, max norm of r, last 5 s", "within 10 %",
            f"{g['identified']:.4g} vs {g['true']:.4g} rad ({g['ratio'] - 1:+.1%}; CAD model {g['cad']:.4g})",
            abs(g["ratio"] - 1) <= TARGETS["design"])  # fmt: skip
    if "design1_rtol_1e-8" in d:
        g = d["design1_rtol_1e-8"]
        row("the same at rtol 1e-8", "within 10 %",
            f"{g['identified']:.4g} vs {g['true']:.4g} rad (x{g['ratio']:.3g}; CAD model {g['cad']:.4g})",
            abs(g["ratio"] - 1) <= TARGETS["design"])  # fmt: skip
    fit = float(np.median(d["fit_s"]))
    row("fit of 20 s at 1 kHz (WLS, essential)", "<= 2 s",
        f"{fit:.2f} s (median of {len(d['fit_s'])}; with the "
        f"consistent estimate {d['fit_with_consistent_s'][0]:.2f} s)", fit <= TARGETS["time"])  # fmt: skip
    for name in ("five_bar", "stewart"):
        if name in numbers:
            o = numbers[name]
            worst = max(o["recovery"]["mass"]) if o["recovery"]["mass"] else float("nan")
            row(f"{name}: identifies, validates", "reported",
                f"{o['kept']}/{o['rank']} base parameters kept, worst relative {worst:.2%}, "
                "unseen torque RMS "
                f"{o['validation']['rms_relative_all']:.2%}, fit {o['fit_s']:.2f} s", True)  # fmt: skip
    print(
        "\nDelta details:",
        json.dumps({k: v for k, v in d.items() if k not in ("lumped",)}, default=str)[:4000],
    )
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(numbers, handle, indent=2, default=str)


if __name__ == "__main__":
    main()

"""The compiled core on robots other than the paper's Delta (issue 23).

Run: ``python benchmarks/bench_engine.py [--repeats 3] [--t-end 15]``

Cases, each a whole ``dp.simulate`` call as a user waits for it (reference tabulation, set-up and
the loop), on the shipped five-bar: design I (sampling-aware) along a circle of its tip, sampled
at 1 kHz with RK4, with a 0-0.4 kg payload the controller does not know:

* plant, loop and law compiled (the default: design I in the core, no Python during the run);
* the compiled plant and loop with the readable law called back once per sample (what any
  other controller, a user's own included, gets; tests/reference's ``called_back``);
* the Python reference loop on the Python plant (tests/reference's ``simulate_reference``; the
  projection and IK still compiled), the reference;
* the joint reference alone (``FramePath.joint_reference``): the core's loop and the Python loop.

The core can no longer be turned off (``DELTA_PIN_NATIVE`` is gone): there is no row without it.

And the 3-RRR's MJCF for ``mujoco.rollout`` (MuJoCo's C++ loop, zero control, RK4 1 ms) against
the compiled plant under a user's PD law from Python, both 15 s: the issue's reference figure.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from common import machine_info, measure, print_table, report_target

import delta_pin as dp
from delta_pin.model import frame_path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository root: tests.reference
from tests.reference.laws import called_back
from tests.reference.python_loop import simulate_reference


def _five_bar_case(t_end: float):
    robot = dp.load_robot("five_bar", end_effector="tip")
    home = robot.frame_placement(robot.reference_configuration).translation
    circle = dp.Circle(
        center=home + np.array([0.0, 0.0, 0.03]), radius=0.03, period=2.0, plane="xz", phase=-np.pi / 2
    )
    path = dp.FramePath(circle)
    nominal = dp.ClosedChainNominalModel(robot)

    def run(simulate=dp.simulate, law_in_core=True):
        plant = dp.ClosedChainPlant(robot, payload_mass=lambda t: 0.2 * (1.0 + np.sin(np.pi * t)))
        controller = dp.design1(nominal, sampling_period=1e-3)
        if not law_in_core:  # the readable law, called back from the compiled loop
            controller = called_back(controller)
        return simulate(robot, controller, path, plant=plant, t_end=t_end, mode="sampled", alpha0=robot.home)

    return robot, path, run


def _python_reference(path, robot, t):
    original = frame_path.FramePath.__dict__["_compiled_reference"]
    frame_path.FramePath._compiled_reference = staticmethod(lambda *arguments: None)
    try:
        return path.joint_reference(robot, t)
    finally:
        frame_path.FramePath._compiled_reference = original


def delta_cases(args) -> None:
    """The paper's Delta, sampled design I (sampling-aware) on path I: the robot of load_delta and
    the same URDF through load_robot, both on the projected nominal model (the core's plant and
    law), and load_delta's robot with the Delta's analytic nominal model (the core's plant and its
    law on that model)."""
    import tempfile

    delta = dp.load_delta()
    with tempfile.TemporaryDirectory() as folder:
        urdf = Path(folder) / "delta.urdf"
        urdf.write_text(delta.delta.description.urdf)
        loaded = dp.load_robot(str(urdf))

    def run(robot, nominal):
        controller = dp.design1(nominal(robot), sampling_period=1e-3)
        return dp.simulate(robot, controller, dp.PathI(), t_end=args.t_end, mode="sampled")

    cases = [
        measure(
            "load_robot, projected nominal: the core",
            lambda: run(loaded, dp.ClosedChainNominalModel),
            args.repeats,
        ),
        measure(
            "load_delta, projected nominal: the core",
            lambda: run(delta, dp.ClosedChainNominalModel),
            args.repeats,
        ),
        measure(
            "load_delta, analytic nominal: the core's plant and law",
            lambda: run(delta, dp.DeltaNominalModel),
            args.repeats,
        ),
    ]
    print_table(f"{args.t_end:g} s of the Delta, design I sampled 1 kHz, path I", cases, cases[1])

    home = delta.home

    def law(t, alpha, alpha_dot):
        return -5.0 * (alpha - home) - 0.5 * alpha_dot

    samples = round(args.t_end / 1e-3) + 1
    alpha, rate = np.full(3, 0.3), np.zeros(3)
    own = measure(
        "a PD law in Python, alone (one call per sample)",
        lambda: [law(0.0, alpha, rate) for _ in range(samples)],
        args.repeats,
    )
    options = {"t_end": args.t_end, "mode": "sampled", "alpha0": home}
    python_law = [
        own,
        measure("the law on the compiled plant (plant=ClosedChainPlant)",
                lambda: dp.simulate(delta, law, None, plant=dp.ClosedChainPlant(delta), **options),
                args.repeats),
        measure("the law on the Delta's Pinocchio plant (the Python reference loop, tests/reference)",
                lambda: simulate_reference(delta, law, None, **options), 1),
        measure("a compiled PD + gravity instead (the plant and loop's own cost)",
                lambda: dp.simulate(delta, dp.PDGravity(dp.DeltaNominalModel(delta), K_p=5.0, K_d=0.5),
                                    None, plant=dp.ClosedChainPlant(delta), **options),
                args.repeats),
    ]  # fmt: skip
    print_table(f"{args.t_end:g} s of the Delta holding still under a Python law", python_law, python_law[0])
    report_target("a Python law in the compiled loop, Delta, minus the law's own cost",
                  python_law[1].median - own.median, 0.15)  # fmt: skip
    report_target("the same, beyond a compiled law's run (the call-back's own cost)",
                  python_law[1].median - own.median - python_law[3].median, None)  # fmt: skip
    report_target(
        "the Delta through load_robot / through load_delta", cases[0].median / cases[1].median, 1.05, "x"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--t-end", type=float, default=15.0, help="simulated time [s]")
    args = parser.parse_args()
    print(f"machine: {machine_info()}")
    robot, path, run = _five_bar_case(args.t_end)
    compiled = measure("five-bar, design I, sampled 1 kHz: plant, loop and law compiled", run, args.repeats)
    callback = measure(
        "the same, the readable law called back from the compiled loop",
        lambda: run(law_in_core=False),
        args.repeats,
    )
    python = measure(
        "the same run: the Python plant in the Python reference loop (tests/reference)",
        lambda: run(simulate_reference),
        args.repeats,
    )
    cases = [compiled, callback, python]
    print_table(f"{args.t_end:g} s on the five-bar, whole simulate call", cases, python)
    a, b, d = run(), run(simulate_reference), run(law_in_core=False)
    print(
        f"\nlargest difference from the compiled run: {np.abs(a.alpha - d.alpha).max():.1e} rad (law called "
        f"back), {np.abs(a.alpha - b.alpha).max():.1e} rad (the Python reference loop)"
    )
    report_target(f"five-bar, {args.t_end:g} s design I sampled 1 kHz", compiled.median, 0.5)

    delta_cases(args)

    t = np.arange(round(args.t_end / 1e-3) + 1) * 1e-3
    reference = [
        measure(
            "FramePath.joint_reference: the core's loop", lambda: path.joint_reference(robot, t), args.repeats
        ),
        measure("FramePath.joint_reference: the Python loop", lambda: _python_reference(path, robot, t), 1),
    ]
    print_table(
        "the five-bar's joint reference (IK, rates, accelerations per sample)", reference, reference[1]
    )

    try:
        import mujoco
        from mujoco import rollout
    except ImportError:
        print("\nmujoco is not installed (pip install -e '.[bench]'): no MuJoCo reference")
        return
    rrr = dp.load_robot("three_rrr_mjcf")
    model = mujoco.MjModel.from_xml_path(str(Path(dp.__file__).parent / "robots" / "three_rrr.xml"))
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    model.opt.timestep = 1e-3
    data = mujoco.MjData(model)
    steps = round(args.t_end / 1e-3)
    state = np.zeros((1, mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)))
    mujoco.mj_getState(model, data, state[0], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    controls = np.zeros((1, steps, model.nu))

    def law(t, alpha, alpha_dot):
        return -2.0 * (alpha - rrr.home) - 0.2 * alpha_dot

    mujoco_case = measure(
        "3-RRR: mujoco.rollout (C++, zero control, RK4 1 ms)",
        lambda: rollout.rollout(model, data, state, controls),
        args.repeats,
    )
    ours = measure(
        "3-RRR: compiled plant, a PD law from Python (RK4 1 ms)",
        lambda: dp.simulate(rrr, law, None, t_end=args.t_end, mode="sampled", alpha0=rrr.home),
        args.repeats,
    )
    pd = dp.PDGravity(dp.ClosedChainNominalModel(rrr), K_p=2.0, K_d=0.2)
    compiled_pd = measure(
        "3-RRR: compiled plant and PD + gravity law (RK4 1 ms)",
        lambda: dp.simulate(rrr, pd, None, t_end=args.t_end, mode="sampled", alpha0=rrr.home),
        args.repeats,
    )
    print_table(f"{args.t_end:g} s of the 3-RRR", [mujoco_case, ours, compiled_pd], mujoco_case)
    report_target(
        "3-RRR, compiled plant + Python law / mujoco.rollout", ours.median / mujoco_case.median, None, "x"
    )
    report_target(
        "3-RRR, compiled plant and law / mujoco.rollout", compiled_pd.median / mujoco_case.median, 0.7, "x"
    )


if __name__ == "__main__":
    main()

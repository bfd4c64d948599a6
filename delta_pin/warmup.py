"""Compile everything a first run would compile, so that a user's first run does not.

An editable ``pip install`` runs this after compiling the core (``CMakeLists.txt``): numba
writes its caches next to the kernels' sources (``__pycache__``), which is where an editable
install finds them at run time. Also runnable by hand
after an upgrade: ``python -m delta_pin.warmup``.

Each compiled path runs once for a few samples, on both plants: the continuous integrators (Radau
IIA, BDF2), the sampled loops of designs I/II and of the digital laws (with a drive), the
controllers' steps called from Python, a batch, and the single-state model kernels.
"""

from __future__ import annotations

import sys
import time

__all__ = ["main", "warm_up"]


def warm_up(verbose: bool = True) -> float:
    """Run every compiled path once; returns the seconds it took."""
    import numpy as np

    import delta_pin as dp
    from delta_pin.model.validation import validate
    from delta_pin.sim.batch import native_available, simulate_batch

    start = time.perf_counter()
    robot = dp.load_delta()
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    plants = ["analytic"] + (["pinocchio"] if native_available() else [])
    common = {"alpha0": np.full(3, 0.3322), "friction": dp.Friction(), "uncertainty": dp.PaperUncertainty()}
    drive = {"sensor": dp.Encoder(bits=17), "delay": 1, "torque_limit": 20.0}

    def say(what: str) -> None:
        if verbose:
            print(
                f"delta-pin warm-up: {what} ({time.perf_counter() - start:.0f} s)",
                file=sys.stderr,
                flush=True,
            )

    for plant in plants:
        for integrator in ("radau", "bdf2"):
            dp.simulate(robot, dp.design1(nominal), dp.PathI(), plant=plant, t_end=0.01, mode="continuous",
                        integrator=integrator, **common)  # fmt: skip
        say(f"continuous, {plant} plant")
        dp.simulate(robot, dp.design2(nominal, sampling_period=1e-3), dp.PathI(), plant=plant, t_end=0.01,
                    mode="sampled", **common)  # fmt: skip
        for law in (dp.tdc(nominal, 1e-3, delay=1), dp.digital_robust(nominal, 1e-3, delay=1)):
            dp.simulate(robot, law, dp.PathI(), plant=plant, t_end=0.01, mode="sampled", **common, **drive)
        say(f"sampled and digital, {plant} plant")
    # the Python loop's kernels: a controller step from Python, the plants' derivatives
    for plant in plants:
        dp.simulate(robot, dp.design1(nominal, sampling_period=1e-3), dp.PathI(), plant=plant, t_end=0.01,
                    mode="sampled", **common, **drive)  # fmt: skip
        dp.simulate(robot, dp.ComputedTorque(nominal), dp.PathI(), plant=plant, t_end=0.01, mode="continuous",
                    integrator="lsoda", **common)  # fmt: skip
    simulate_batch(
        robot, [dp.design1(nominal), dp.design2(nominal)], dp.PathI(), t_end=0.01, alpha0=common["alpha0"],
        friction=common["friction"], uncertainties=[common["uncertainty"]] * 2,
    )  # fmt: skip
    validate(robot, samples=2)
    say("Python loops, batches and the model")
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    """``python -m delta_pin.warmup [--core-folder DIR]``: DIR holds a compiled core not yet
    installed (the build's staging folder: ``CMakeLists.txt`` passes it)."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m delta_pin.warmup", description=__doc__.splitlines()[0])
    parser.add_argument("--core-folder", help="where the compiled core lies, if not installed yet")
    args = parser.parse_args(argv)
    if args.core_folder:
        from delta_pin.model.core_model import add_core_folder

        add_core_folder(args.core_folder)
    seconds = warm_up()
    print(f"delta-pin warm-up: done in {seconds:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

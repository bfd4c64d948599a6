"""Command-line interface: ``delta-pin urdf | validate | run | compare | sweep | reproduce | view``."""

from __future__ import annotations

import argparse
import importlib
import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from delta_pin.errors import DeltaPinError, XacroArgumentError
from delta_pin.utils.atomic import write_text_atomically

__all__ = ["main"]


class _Choices(Sequence):
    """A tuple constant of a submodule as argparse ``choices``, imported only when argparse reads
    it: ``experiments`` and ``simulate`` load SciPy, numba and the controllers (~0.6 s) that
    ``delta-pin validate`` and ``delta-pin urdf`` do not need."""

    def __init__(self, module: str, name: str) -> None:
        self._module, self._name = module, name

    def _values(self) -> tuple:
        return getattr(importlib.import_module(self._module), self._name)

    def __getitem__(self, index):
        return self._values()[index]

    def __len__(self) -> int:
        return len(self._values())


CONTROLLERS = _Choices("delta_pin.studies.experiments", "CONTROLLERS")
PATHS = _Choices("delta_pin.studies.experiments", "PATHS")
MODES = _Choices("delta_pin.sim.arguments", "MODES")
INTEGRATOR_CHOICES = _Choices("delta_pin.sim.runner", "INTEGRATOR_CHOICES")
VELOCITIES = _Choices("delta_pin.sim.drive", "VELOCITIES")


def _add_choice_argument(parser: argparse.ArgumentParser, flag: str, choices: _Choices, **options) -> None:
    """``parser.add_argument(flag, choices=choices, **options)`` without reading ``choices`` now
    (``add_argument`` formats the choices once to check the metavar)."""
    parser.add_argument(flag, **options).choices = choices


def _parse_settings(settings: list[str]) -> dict[str, str]:
    """``["l_a=0.25", "m_o=0.5"]`` -> ``{"l_a": "0.25", "m_o": "0.5"}``."""
    parsed = {}
    for item in settings:
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise XacroArgumentError(f"--set expects NAME=VALUE, got {item!r}")
        parsed[name.strip()] = value.strip()
    return parsed


def _add_robot_arguments(parser: argparse.ArgumentParser, allow_urdf: bool = True) -> None:
    group = parser.add_mutually_exclusive_group() if allow_urdf else parser
    if allow_urdf:
        group.add_argument("--urdf", type=Path, help="a URDF (or xacro) file following the convention")
    group.add_argument(
        "--set",
        dest="settings",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="xacro argument of the packaged Delta, SI units (repeatable), e.g. l_a=0.25",
    )


def _load_robot(args: argparse.Namespace):
    from delta_pin.model.robot import load_delta

    return load_delta(getattr(args, "urdf", None), **_parse_settings(args.settings))


def _cmd_urdf(args: argparse.Namespace) -> int:
    from delta_pin.model.description import compile_urdf

    text = compile_urdf(**_parse_settings(args.settings))
    if args.output is None:
        sys.stdout.write(text)
    else:
        write_text_atomically(args.output, text)
        print(f"wrote {args.output}")
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    from delta_pin.model.validation import validate

    report = validate(_load_robot(args), samples=args.samples, seed=args.seed, tol=args.tol)
    print(report.table())
    return 0 if report.passed else 1


def _cmd_run(args: argparse.Namespace) -> int:
    from delta_pin.studies.experiments import run_spec
    from delta_pin.studies.metrics import compute_metrics

    spec = _spec_from_args(
        args,
        controller=args.controller,
        path=args.path,
        friction_compensation=not args.no_friction_compensation,
        delta_m=args.uncertainty,
        delta_fc=args.uncertainty,
        delta_f=args.uncertainty,
        seed=args.seed,
        encoder_bits=args.encoder_bits,
        velocity=args.velocity,
        delay=args.delay,
        torque_limit=args.torque_limit,
    )
    robot = _load_robot(args)
    print(
        f"delta-pin run: {spec.controller} on path {spec.path}, {spec.plant} plant, {spec.mode} mode, "
        f"{spec.duration:g} s ...",
        flush=True,
    )
    run = run_spec(spec, robot, progress=None)  # a progress bar on a terminal
    metrics = compute_metrics(run)
    out = Path(args.out)
    run.save(out / "run.npz")
    warnings = []
    if metrics.torque_limit_hits and metrics.torque_limit_hits > 0.5 * len(run.t):
        warnings.append(
            f"the drive saturates most of the time: the torque limit bound at {metrics.torque_limit_hits} "
            f"of {len(run.t)} samples"
        )
    summary = {
        "spec": spec.as_dict(),
        "metrics": metrics.as_dict(),
        "closure_residual_max": float(run.closure_residual.max()),
        "warnings": warnings,
    }
    for warning in warnings:
        print(f"  warning: {warning}", flush=True)
    write_text_atomically(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    for name, value in metrics.as_dict().items():
        print(f"  {name:<28} {value if value is None else f'{value:.6g}'}")
    print(f"wrote {out / 'run.npz'} and {out / 'summary.json'}")
    if args.html is not None:
        from delta_pin.viz.meshcat_export import export_html

        print(f"wrote {export_html(run, args.html, robot)}")
    return 0


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from delta_pin.studies.reproduce import reproduce

    result = reproduce(args.out, quick=not args.full, **_executor_options(args))
    holds = sum(c["holds"] == "yes" for c in result.claims)
    print(
        f"{holds} of {len(result.claims)} of the paper's claims hold on this plant: "
        f"see {result.out}/report.md"
    )
    return 0


def _split(text: str) -> list[str]:
    return [item.strip() for item in text.split(",") if item.strip()]


def _spec_from_args(args: argparse.Namespace, **changes):
    """The RunSpec of the timing options every study command shares, plus ``changes``."""
    from delta_pin.studies.experiments import RunSpec

    return RunSpec(
        plant=args.plant,
        mode=args.mode,
        integrator=args.integrator,
        t_end=args.t_end,
        dt=args.dt,
        sampling_aware=args.sampling_aware,
        **changes,
    )


def _cmd_compare(args: argparse.Namespace) -> int:
    from delta_pin.studies.reproduce import compare, markdown_table

    specs = [
        _spec_from_args(args, controller=c, path=p, friction_compensation=fc)
        for p in _split(args.paths)
        for c in _split(args.controllers)
        for fc in ((True, False) if args.with_and_without_fc else (True,))
    ]
    metrics = compare(specs, args.out, **_executor_options(args))
    print(markdown_table(metrics))
    print(f"wrote {args.out}/metrics.csv, metrics.md and figures/")
    return _failures([row.get("error") for row in metrics], args)


def _cmd_sweep(args: argparse.Namespace) -> int:
    from delta_pin.studies.reproduce import sweep
    from delta_pin.studies.sweep import parse_axes

    base = _spec_from_args(args, controller=args.controller, path=args.path)
    rows = sweep(
        base,
        parse_axes(args.param),
        args.out,
        metric=args.metric,
        **_executor_options(args),
    )
    print(f"{len(rows)} points: wrote {args.out}/results.csv")
    return _failures([row.get("error") for row in rows], args)


def _failures(errors: list, args: argparse.Namespace) -> int:
    """Say how many runs of a study failed and why; exit 1 then, unless --allow-failures."""
    failed = [error for error in errors if error]
    if not failed:
        return 0
    print(f"{len(failed)} of {len(errors)} runs failed; the first: {failed[0]}", file=sys.stderr)
    return 0 if args.allow_failures else 1


_INTEGRATOR_HELP = (
    "auto: RK4 sampled, LSODA continuous; bdf2: compiled implicit BDF2 (designs I/II, continuous, "
    "either plant (Pinocchio: native library); sweeps batch it)"
)


def _add_study_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--plant", choices=("pinocchio", "analytic"), default="analytic")
    _add_choice_argument(parser, "--mode", MODES, default="continuous")
    _add_choice_argument(parser, "--integrator", INTEGRATOR_CHOICES, default="auto", help=_INTEGRATOR_HELP)
    parser.add_argument("--t-end", type=float, default=None, help="duration [s] (path default)")
    parser.add_argument("--dt", type=float, default=1e-3, help="sample / control period [s]")
    parser.add_argument("--sampling-aware", action="store_true")
    parser.add_argument("--out", type=Path, required=True, help="output directory")
    parser.add_argument(
        "--allow-failures",
        action="store_true",
        help="exit 0 even when some runs fail (they are still listed)",
    )
    _add_executor_arguments(parser)


def _executor_options(args: argparse.Namespace) -> dict:
    """Where the runs of a study execute, and on which robot (xacro arguments)."""
    robot_args = _parse_settings(args.settings)
    if robot_args:
        from delta_pin.model.description import compile_urdf

        compile_urdf(**robot_args)  # refuse a bad argument before any worker starts
    return {"workers": args.workers, "scheduler": args.scheduler, "robot_args": robot_args or None}


def _add_executor_arguments(parser: argparse.ArgumentParser) -> None:
    _add_robot_arguments(parser, allow_urdf=False)
    parser.add_argument(
        "--workers",
        type=int,
        default=os.cpu_count() or 1,
        help="local worker processes (default: one per core)",
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        help="Dask scheduler address ('local' for a local cluster; needs the [dask] extra)",
    )


def _cmd_view(args: argparse.Namespace) -> int:
    from delta_pin.viz.meshcat_export import view_live

    viewer = view_live(args.run, open_browser=args.open)
    print(f"meshcat viewer at {viewer.url()} -- press Ctrl-C to stop")
    try:
        import time

        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="delta-pin",
        description="Model-based control of Delta parallel robots, built on Pinocchio.",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    urdf = sub.add_parser("urdf", help="compile the parametric Delta xacro to a URDF")
    _add_robot_arguments(urdf, allow_urdf=False)
    urdf.add_argument("-o", "--output", type=Path, help="output file (default: standard output)")
    urdf.set_defaults(func=_cmd_urdf)

    validate = sub.add_parser(
        "validate", help="compare the analytic model with the constrained Pinocchio model"
    )
    _add_robot_arguments(validate)
    validate.add_argument("--samples", type=int, default=100, help="random states (default 100)")
    validate.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    validate.add_argument(
        "--tol",
        type=float,
        default=1e-10,
        help="relative tolerance of the M, C a_dot, G agreement (default 1e-10)",
    )
    validate.set_defaults(func=_cmd_validate)

    run = sub.add_parser("run", help="simulate one controller on one path (the paper's Section V scenario)")
    _add_choice_argument(run, "--controller", CONTROLLERS, default="design1")
    _add_choice_argument(run, "--path", PATHS, default="I")
    run.add_argument("--plant", choices=("pinocchio", "analytic"), default="pinocchio")
    _add_choice_argument(run, "--mode", MODES, default="continuous")
    _add_choice_argument(run, "--integrator", INTEGRATOR_CHOICES, default="auto", help=_INTEGRATOR_HELP)
    run.add_argument("--t-end", type=float, default=None, help="duration [s] (15 for path I, 10 for path II)")
    run.add_argument("--dt", type=float, default=1e-3, help="sample / control period [s] (default 1e-3)")
    run.add_argument("--no-friction-compensation", action="store_true")
    run.add_argument(
        "--sampling-aware",
        action="store_true",
        help="cap the robust gain so a sampled loop of period dt stays stable",
    )
    run.add_argument(
        "--uncertainty", type=float, default=0.3, help="magnitude Delta_m = Delta_fc = Delta_f (default 0.3)"
    )
    run.add_argument(
        "--seed",
        type=int,
        default=None,
        help="seeded band-limited random uncertainty instead of the paper's sinusoids",
    )
    drive = run.add_argument_group("digital drive (sampled mode)")
    drive.add_argument(
        "--encoder-bits",
        type=int,
        default=None,
        help="encoders of 2^bits counts per turn, 8-32 (default: exact state)",
    )
    _add_choice_argument(
        drive,
        "--velocity",
        VELOCITIES,
        default="difference",
        help="with an encoder, the velocity the controller gets (default: difference of readings)",
    )
    drive.add_argument("--delay", type=int, default=0, help="samples of computation delay (default 0)")
    drive.add_argument(
        "--torque-limit", type=float, default=None, help="the drive's saturation [N m] (default none)"
    )
    run.add_argument("--out", type=Path, required=True, help="output directory (run.npz, summary.json)")
    run.add_argument("--html", type=Path, default=None, help="also export a standalone meshcat page")
    _add_robot_arguments(run)
    run.set_defaults(func=_cmd_run)

    reproduce = sub.add_parser(
        "reproduce", help="the paper's Section V study: runs, surfaces, figures, report"
    )
    size = reproduce.add_mutually_exclusive_group()
    size.add_argument("--quick", action="store_true", help="analytic plant, 3 x 3 surfaces (the default)")
    size.add_argument("--full", action="store_true", help="Pinocchio plant, 11 x 11 surfaces")
    reproduce.add_argument("--out", type=Path, default=Path("out/reproduce"), help="output directory")
    _add_executor_arguments(reproduce)
    reproduce.set_defaults(func=_cmd_reproduce)

    compare = sub.add_parser("compare", help="several controllers on several paths: metrics and figures")
    compare.add_argument("--controllers", default="design1,design2,lqr", help="comma-separated")
    compare.add_argument("--paths", default="I,II", help="comma-separated: I, II, adept")
    compare.add_argument(
        "--with-and-without-fc",
        action="store_true",
        help="each controller with and without friction compensation",
    )
    _add_study_arguments(compare)
    compare.set_defaults(func=_cmd_compare)

    sweep = sub.add_parser("sweep", help="a grid over uncertainty magnitudes or gains")
    sweep.add_argument(
        "--param",
        action="append",
        required=True,
        metavar="NAME=SPEC",
        help="an axis: delta_m=0:0.9:4 (start:stop:count) or xi=0.001,0.01 (repeatable)",
    )
    _add_choice_argument(sweep, "--controller", CONTROLLERS, default="design1")
    _add_choice_argument(sweep, "--path", PATHS, default="I")
    sweep.add_argument("--metric", default="rho_hat_max", help="surface of this metric for two axes")
    _add_study_arguments(sweep)
    sweep.set_defaults(func=_cmd_sweep)

    view = sub.add_parser("view", help="open a live meshcat viewer of a saved run")
    view.add_argument("run", type=Path, help="a run.npz written by delta-pin run")
    view.add_argument("--open", action="store_true", help="open the browser")
    view.set_defaults(func=_cmd_view)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``delta-pin`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except DeltaPinError as exc:
        print(f"delta-pin {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

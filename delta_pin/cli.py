"""Command-line interface: ``delta-pin urdf | validate | run | compare | sweep | reproduce | view``."""

from __future__ import annotations

import argparse
import errno
import json
import math
import os
import re
import signal
import sys
from pathlib import Path

from delta_pin.choices import CONTROLLERS, INTEGRATOR_CHOICES, MODES, PATHS, SHIPPED_ROBOT_NAMES, VELOCITIES
from delta_pin.errors import DeltaPinError, InvalidParameterError, SimulationError, XacroArgumentError
from delta_pin.utils.atomic import write_text_atomically
from delta_pin.utils.interrupts import interrupt_of

__all__ = ["MAX_SWEEP_POINTS", "main"]

MAX_SWEEP_POINTS = 100_000  # a larger grid needs --force
RESUMABLE = ("compare", "sweep", "reproduce")  # commands whose finished runs are cached on disk
EXIT_BAD_INPUT, EXIT_FAILED, EXIT_INTERRUPTED, EXIT_TERMINATED = 2, 1, 130, 143  # 143: 128 + SIGTERM
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, what a shell reports for a writer whose reader left


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Each option's help ends with its default (not for required options and plain flags)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        if action.required or isinstance(action, argparse._StoreTrueAction):
            return action.help or ""
        return super()._get_help_string(action)


class _UsageError(Exception):
    """A command-line error of argparse, already worded as one line."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (``delta-pin run: error: ...``, no usage block), so that
    every failure of the command is one line; :func:`main` returns exit code 2 for them."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        # a negative number in any notation is a value, not an option: argparse's own pattern
        # knows -1 and -0.5 only, so `--dt -1e-3` was "expected one argument"
        self._negative_number_matcher = _NEGATIVE_NUMBER

    def error(self, message: str):
        raise _UsageError(f"{self.prog}: error: {message}")


_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$", re.IGNORECASE)


def _seconds(text: str) -> float:
    """An argparse type: a finite duration > 0 [s], naming the value otherwise."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not (math.isfinite(value) and value > 0.0):
        raise argparse.ArgumentTypeError(f"{text} must be a finite number of seconds > 0, e.g. 0.001")
    return value


def _page_file(text: str) -> Path:
    """An argparse type: the file name of a page (``--html``), refusing a folder's (``o/x/``)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"{text!r} is not a file name: give one, e.g. run.html")
    if text.endswith(("/", os.sep)) or (os.altsep and text.endswith(os.altsep)):
        folder = text.rstrip("/" + os.sep + (os.altsep or ""))
        raise argparse.ArgumentTypeError(
            f"{text!r} names a folder, not a page: give a file name, e.g. {folder or ''}/run.html"
        )
    return Path(text)


def _integer(minimum: int, maximum: int | None = None):
    """An argparse type: an integer >= ``minimum`` (and <= ``maximum``), naming the value otherwise."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < minimum or (maximum is not None and value > maximum):
            within = f">= {minimum}" + ("" if maximum is None else f" and <= {maximum}")
            raise argparse.ArgumentTypeError(f"{text} must be an integer {within}")
        return value

    parse.__name__ = f"integer >= {minimum}"
    return parse


def _number(
    minimum: float | None = None, *, above: bool = False, maximum: float | None = None, below: bool = False
):
    """An argparse type: a finite number within the bounds (``above``/``below``: strictly),
    naming the value and the range otherwise."""
    low = "" if minimum is None else f"{'>' if above else '>='} {minimum:g}"
    high = "" if maximum is None else f"{'<' if below else '<='} {maximum:g}"
    wanted = " and ".join(x for x in (low, high) if x)

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        ok = math.isfinite(value)
        if ok and minimum is not None:
            ok = value > minimum if above else value >= minimum
        if ok and maximum is not None:
            ok = value < maximum if below else value <= maximum
        if not ok:
            raise argparse.ArgumentTypeError(
                f"{text} must be a finite number{' ' + wanted if wanted else ''}"
            )
        return value

    parse.__name__ = f"number {wanted}".strip()
    return parse


def _size(count: float) -> str:
    """A byte count in words: ``"2.3 TiB"``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if count < 1024 or unit == "PiB":
            return f"{count:.3g} {unit}"
        count /= 1024
    raise AssertionError  # pragma: no cover


def _check_output_dir(flag: str, path: Path) -> None:
    """Refuse, before any work, an output folder that is a file or cannot be created or written."""
    if path.exists() and not path.is_dir():
        raise InvalidParameterError(f"{flag} {path} is a file; give a directory")
    _check_writable(flag, path, "directory")


def _check_output_file(flag: str, path: Path) -> None:
    """Refuse, before any work, an output file that is a folder, a dangling symbolic link (someone's
    link, which a write would replace) or cannot be written."""
    if path.is_symlink() and not path.exists():
        raise InvalidParameterError(
            f"{flag} {path} is a symbolic link to {os.readlink(path)}, which does not exist: writing would "
            "replace the link; give another name"
        )
    if path.is_dir():
        raise InvalidParameterError(f"{flag} {path} is a directory; give a file name")
    if path.exists() and not os.access(path, os.W_OK):
        raise InvalidParameterError(f"{flag} {path} is not writable; give a file you can write")
    _check_writable(flag, path.parent, "file")


def _check_writable(flag: str, path: Path, what: str) -> None:
    existing = path.absolute()
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        raise InvalidParameterError(f"{flag} {path}: {existing} is a file, not a folder; give a {what} path")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise InvalidParameterError(
            f"{flag} {path} is not writable (no write permission in {existing}); give a writable {what}"
        )


def _check_memory(specs, args: argparse.Namespace, what: str = "") -> None:
    """Refuse a run whose arrays would not fit (about half of this machine's memory), unless
    --force; the message gives the estimate (:func:`delta_pin.studies.experiments.estimated_memory`)
    of the largest of ``specs`` (every run of a study, every point of a sweep), ``what`` first."""
    from delta_pin.studies.experiments import estimated_memory, memory_limit

    spec = max(specs, key=estimated_memory)
    need, limit = estimated_memory(spec), memory_limit()
    if need > limit and not args.force:
        samples = spec.samples
        raise InvalidParameterError(
            f"{what}--t-end {spec.duration:g} at --dt {spec.dt:g} is {samples:.3g} samples: about "
            f"{_size(need)} of arrays, more than {_size(limit)} (half of this machine's memory); "
            "shorten --t-end, lengthen --dt, or give --force"
        )


def _add_choice_argument(parser: argparse.ArgumentParser, flag: str, choices: tuple, **options) -> None:
    """``parser.add_argument(flag, choices=choices, **options)``."""
    parser.add_argument(flag, choices=choices, **options)


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
    from delta_pin.model.delta_robot import load_delta

    return load_delta(getattr(args, "urdf", None), **_parse_settings(args.settings))


# (no "--" inside an XML comment); standard output gets the bare URDF
URDF_MARK = "<!-- written by delta-pin urdf to this file; the next such write replaces it -->"


def _check_urdf_output(path: Path) -> None:
    """``urdf --output`` replaces an existing file only when it is provably an earlier ``urdf
    --output``'s (its second line is :data:`URDF_MARK`): anyone else's URDF of the same name is
    refused (issue 36: it was replaced silently)."""
    _check_output_file("--output", path)
    if not os.path.lexists(path):  # a dangling symbolic link is someone's too: read, and refused
        return
    try:
        with open(path, encoding="utf-8", errors="replace") as file:
            head = [file.readline().strip() for _ in range(2)]
    except OSError as exc:
        raise InvalidParameterError(
            f"--output {path} cannot be read ({exc.strerror}); give another name"
        ) from None
    if URDF_MARK not in head:
        raise InvalidParameterError(
            f"--output {path} exists and was not written by delta-pin urdf: give another name, or remove "
            "it yourself"
        )


def _cmd_urdf(args: argparse.Namespace) -> int:
    from delta_pin.model.description import compile_urdf

    if args.output is not None:
        _check_urdf_output(args.output)
    text = compile_urdf(**_parse_settings(args.settings))
    if args.output is None:
        sys.stdout.write(text)
    else:
        first, _, rest = text.partition("\n")  # the mark after the XML declaration
        marked = f"{first}\n{URDF_MARK}\n{rest}" if first.startswith("<?xml") else f"{URDF_MARK}\n{text}"
        write_text_atomically(args.output, marked)
        print(f"wrote {args.output}")
    return 0


def _robot_file_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("any closed-chain robot (instead of the packaged Delta)")
    group.add_argument(
        "--robot",
        type=str,
        default=None,
        help="a robot file: .urdf/.xacro with <constraint> elements, .urdf with robot.yaml beside it, or "
        f"MJCF .xml; or a shipped robot: {', '.join(SHIPPED_ROBOT_NAMES)}",
    )
    group.add_argument(
        "--actuated", default=None, metavar="A,B,...", help="the actuated joints (default: from the file)"
    )
    group.add_argument(
        "--passive",
        default=None,
        metavar="A,B,...",
        help="joints no motor drives that the loops leave free, an underactuated robot (default: from the "
        "file: robot.yaml name_passive, MJCF sprung joints)",
    )
    group.add_argument(
        "--free-flyer",
        action="store_true",
        help="URDF: put the robot on a free-flyer base (Gepetto's freeflyer=True); controllers refuse it",
    )
    group.add_argument(
        "--home",
        default=None,
        metavar="A,B,...",
        help="where to assemble the robot: its actuated coordinates [rad or m], or a whole configuration "
        "(default: the file's pose, closed by a global solve)",
    )
    group.add_argument(
        "--closure-tolerance",
        type=float,
        default=None,
        metavar="GAP",
        help="the largest gap [m or rad] accepted in the file's loops, re-anchored to close exactly "
        "(default: 1e-6; CAD exports round)",
    )


def _closed_chain_robot(args: argparse.Namespace):
    from delta_pin.model.loaders import load_robot

    if getattr(args, "urdf", None) is not None or args.settings:
        raise InvalidParameterError("--robot replaces --urdf and --set: give one of them")

    def names(text: str | None) -> list[str] | None:
        return None if text is None else [name.strip() for name in text.split(",") if name.strip()]

    assembly = {}
    if getattr(args, "home", None) is not None:
        assembly["home"] = _numbers("--home", args.home)
    if getattr(args, "closure_tolerance", None) is not None:
        assembly["closure_tolerance"] = args.closure_tolerance
    return load_robot(
        args.robot, actuated=names(args.actuated), passive=names(getattr(args, "passive", None)),
        free_flyer=bool(getattr(args, "free_flyer", False)), end_effector=getattr(args, "frame", None),
        **assembly,
    )  # fmt: skip


def _numbers(flag: str, text: str) -> list[float]:
    """Comma-separated numbers of an option, or one line naming it."""
    message = f"{flag} {text!r} must be comma-separated numbers, e.g. 0.1,0,-0.2"
    try:
        values = [float(item) for item in text.split(",") if item.strip()]
    except ValueError:
        raise InvalidParameterError(message) from None
    if not values:
        raise InvalidParameterError(message)
    return values


def _cmd_validate(args: argparse.Namespace) -> int:
    if args.robot is not None:
        from delta_pin.sim.closed_chain_validation import validate_closed_chain

        robot = _closed_chain_robot(args)
        report = validate_closed_chain(
            robot,
            samples=args.samples,
            seed=args.seed,
            tol=args.tol,
            dt=args.dt,
            frame=args.frame,
            **({} if args.duration is None else {"energy_duration": args.duration}),
        )
        print(report.table())
        return 0 if report.passed else 1
    for flag, value in (("--dt", args.dt), ("--duration", args.duration)):
        if value is not None:
            raise InvalidParameterError(
                f"{flag} {value:g} sets the energy check of validate --robot; the packaged Delta's "
                "validation (analytic model vs Pinocchio) integrates nothing: give --robot or drop it"
            )
    if args.frame is not None:
        raise InvalidParameterError(
            f"--frame {args.frame} picks a frame of validate --robot; the packaged Delta's validation "
            "checks its platform (IK/FK, J, J_dot): give --robot or drop --frame"
        )
    from delta_pin.model.validation import validate

    tol = 1e-10 if args.tol is None else args.tol
    report = validate(_load_robot(args), samples=args.samples, seed=args.seed, tol=tol)
    print(report.table())
    return 0 if report.passed else 1


# run's options that only one of its two paths applies (the packaged Delta's scenario, or any
# robot of --robot): given to the other, each is refused, never ignored
_DELTA_RUN_OPTIONS = {
    "path": "--path", "plant": "--plant", "integrator": "--integrator", "uncertainty": "--uncertainty",
    "no_friction_compensation": "--no-friction-compensation", "seed": "--seed",
    "encoder_bits": "--encoder-bits", "velocity": "--velocity", "delay": "--delay",
    "torque_limit": "--torque-limit",
}  # fmt: skip
_ROBOT_RUN_OPTIONS = {"frame": "--frame", "radius": "--radius", "period": "--period"}


GIVEN = "given_options"  # the namespace's set of the destinations given on the command line


def _record_given(parser: argparse.ArgumentParser) -> None:
    """Make each of ``parser``'s options note its destination in ``namespace.given_options`` when
    it appears on the command line, so that a flag given at its default value is still known to be
    given (argparse's own namespace cannot tell ``--path I`` from no ``--path``)."""
    for action in parser._actions:
        if not action.option_strings or isinstance(action, argparse._HelpAction):
            continue
        base = type(action)

        def call(self, parser, namespace, values, option_string=None, _base=base):
            given = getattr(namespace, GIVEN, None)
            if given is None:
                given = set()
                setattr(namespace, GIVEN, given)
            given.add(self.dest)
            _base.__call__(self, parser, namespace, values, option_string)

        action.__class__ = type(f"Given{base.__name__}", (base,), {"__call__": call})


def _given_options(args: argparse.Namespace, options: dict[str, str]) -> list[str]:
    """The flags among ``options`` given on the command line, at their default value or not."""
    given = getattr(args, GIVEN, None) or set()
    return [flag for name, flag in options.items() if name in given]


def _cmd_run(args: argparse.Namespace) -> int:
    if args.robot is not None:
        given = _given_options(args, _DELTA_RUN_OPTIONS)
        if given:
            raise InvalidParameterError(
                f"{', '.join(given)} {'applies' if len(given) == 1 else 'apply'} to the packaged Delta's "
                "scenario, not to --robot (which runs "
                "the robot's constrained plant with the projected nominal model, without a drive): drop "
                "them, or drop --robot"
            )
        return _cmd_run_robot(args)
    given = _given_options(args, _ROBOT_RUN_OPTIONS)
    if given:
        raise InvalidParameterError(
            f"{', '.join(given)} {'applies' if len(given) == 1 else 'apply'} with --robot PATH only: give "
            "--robot too"
        )
    from delta_pin.control.registry import declaration
    from delta_pin.studies.experiments import check_specs

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
    # one law: a switch it has not (--no-friction-compensation for TDC, --sampling-aware for the
    # LQR) is refused rather than ignored; compare and sweep apply them to the laws that have them
    declaration(spec.controller).check_options(
        friction_compensation=spec.friction_compensation, sampling_aware=spec.sampling_aware
    )
    out = Path(args.out)
    _check_output_dir("--out", out)
    _check_page(args.html, out)
    _check_memory([spec], args)
    robot = _load_robot(args)
    check_specs([spec], robot)  # a bad gain, magnitude or seed fails before the run
    options = {"spec": spec.as_dict(), "urdf": None if args.urdf is None else str(args.urdf.resolve())}
    with _claim_run_folder(args, out, options, _parse_settings(args.settings)) as folder:
        return _write_run(args, out, spec, robot, folder)


def _write_run(args: argparse.Namespace, out: Path, spec, robot, folder) -> int:
    """``run``: simulate the packaged Delta's scenario ``spec`` and write it (:func:`_save_run`)."""
    from delta_pin.studies.experiments import run_spec

    print(
        f"delta-pin run: {spec.controller} on path {spec.path}, {spec.plant} plant, {spec.mode} mode, "
        f"{spec.duration:g} s ...",
        flush=True,
    )
    run = run_spec(spec, robot, progress=None)  # a progress bar on a terminal
    return _save_run(args, out, robot, folder, run, {"spec": spec.as_dict()})


def _save_run(args: argparse.Namespace, out: Path, robot, folder, run, head: dict) -> int:
    """Write a computed run into the locked ``folder``: run.npz, summary.json (``head``, then the
    metrics, the closures' record, warnings and the files written) and the --html page; print
    the metrics. One writer for both scenarios of ``run`` (the packaged Delta's and --robot's)."""
    from delta_pin.studies.metrics import compute_metrics, window_note

    metrics = compute_metrics(run)
    folder.start()  # the new run is computed: the earlier one's files go now, not before
    run.save(out / "run.npz")
    folder.record([out / "run.npz"])
    warnings = []
    if metrics.torque_limit_hits and metrics.torque_limit_hits > 0.5 * len(run.t):
        warnings.append(
            f"the drive saturates most of the time: the torque limit bound at {metrics.torque_limit_hits} "
            f"of {len(run.t)} samples"
        )
    written = [out / "run.npz"]
    if args.html is not None:
        from delta_pin.viz.meshcat_export import export_html

        written.append(export_html(run, args.html, robot))
        if _inside(written[-1], out) is not None:
            folder.record(written[-1:])
    summary = {
        **head,
        "metrics": metrics.as_dict(),
        "closure_residual_max": float(run.closure_residual.max()),
        # steps whose loop-closure gap was projected back (Pinocchio plant; null on the analytic)
        "closure_projections": run.metadata.get("closure_projections"),
        "closure_gap_projected_max": run.metadata.get("closure_gap_projected_max"),
        "warnings": warnings,
        # the files this run wrote, absolute (a rerun removes only those that manifest.json lists)
        "outputs": [str(path.resolve()) for path in [*written, out / "summary.json"]],
    }
    for warning in warnings:
        print(f"  warning: {warning}", flush=True)
    write_text_atomically(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    _finish_run_folder(folder, out, [*written, out / "summary.json"])
    for name, value in metrics.as_dict().items():
        print(f"  {name:<28} {value if value is None else f'{value:.6g}'}")
    print(f"  {'closure_residual_max':<28} {summary['closure_residual_max']:.3g}")
    if run.metadata.get("closure_projections"):
        largest = run.metadata.get("closure_gap_projected_max")
        largest = "not recorded" if largest is None else f"{largest:.3g}"
        print(
            f"  {'closure_projections':<28} {run.metadata['closure_projections']} (largest gap projected "
            f"back: {largest})"
        )
    note = window_note(run)
    if note:
        print(f"  note: {note}")
    for path in [*written, out / "summary.json"]:
        print(f"wrote {path}")
    return 0


def _cmd_run_robot(args: argparse.Namespace) -> int:
    """``run --robot PATH [--frame NAME]``: one controller on any closed-chain robot, on its
    constrained Pinocchio plant with the projected nominal model; with ``--frame`` the frame
    draws a circle (task space), else the actuated joints follow a sinusoid (joint space)."""
    out = Path(args.out)
    _check_output_dir("--out", out)
    _check_page(args.html, out)
    robot = _closed_chain_robot(args)
    _check_robot_memory(args, robot)
    options = {
        name: getattr(args, name)
        for name in ("robot", "actuated", "passive", "free_flyer", "controller", "frame", "mode", "dt",
                     "t_end", "radius", "period", "sampling_aware")
    }  # fmt: skip
    with _claim_run_folder(args, out, options) as folder:
        return _write_robot_run(args, out, robot, folder)


def _check_robot_memory(args: argparse.Namespace, robot) -> None:
    """``run --robot``'s memory guard, like the Delta's (:func:`_check_memory`): the Delta's bytes
    per sample scaled by the robot's recorded width (q, v and about 8 arrays per actuated joint;
    the Delta: 12 + 12 + 8 x 3 = 48 numbers a sample)."""
    from delta_pin.studies.experiments import BYTES_PER_SAMPLE, memory_limit

    t_end = max(6.0, 2.0 * args.period) if args.t_end is None else args.t_end  # run_closed_chain's default
    samples = min(t_end / args.dt, 1e30) + 1
    width = robot.model.nq + robot.model.nv + 8 * robot.dof
    need, limit = samples * BYTES_PER_SAMPLE[args.mode] * max(1.0, width / 48.0), memory_limit()
    if need > limit and not args.force:
        raise InvalidParameterError(
            f"--t-end {t_end:g} at --dt {args.dt:g} is {samples:.3g} samples of {robot.name!r}: about "
            f"{_size(need)} of arrays, more than {_size(limit)} (half of this machine's memory); "
            "shorten --t-end, lengthen --dt, or give --force"
        )


def _write_robot_run(args: argparse.Namespace, out: Path, robot, folder) -> int:
    """``run --robot``: simulate the robot's scenario and write it (:func:`_save_run`)."""
    from delta_pin.studies.closed_chain_run import run_closed_chain

    run, description = run_closed_chain(
        robot, controller=args.controller, frame=args.frame, mode=args.mode, dt=args.dt,
        t_end=args.t_end, radius=args.radius, period=args.period, sampling_aware=args.sampling_aware,
        announce=lambda text: print(text, flush=True),
    )  # fmt: skip
    return _save_run(args, out, robot, folder, run, {"robot": run.metadata["robot"], "run": description})


RUN_FILES = ("run.npz", "summary.json")  # what `run` writes into --out, besides --html


def _check_page(page: Path | None, out: Path) -> None:
    """Refuse, before any work, an --html that cannot be written or would take the place of the
    output folder or of one of the run's own files (run.npz was overwritten by the page, exit 0;
    a page named like the folder failed after the whole simulation)."""
    if page is None:
        return
    _check_output_file("--html", page)
    from delta_pin.utils.manifest import LOCK, MANIFEST

    where, folder = page.resolve(), out.resolve()
    if where == folder or where in folder.parents:
        raise InvalidParameterError(
            f"--html {page} is the output folder --out {out} or a folder above it; give a page's file "
            f"name, e.g. {out / 'run.html'}"
        )
    if where.parent == folder and where.name in (*RUN_FILES, MANIFEST, LOCK):
        raise InvalidParameterError(
            f"--html {page} would overwrite the run's own {where.name} in --out {out}; give another file "
            f"name, e.g. {out / 'run.html'}"
        )


def _inside(path: Path, out: Path) -> str | None:
    """``path`` relative to folder ``out`` (POSIX), if it lies inside it; else ``None``."""
    try:
        return path.resolve().relative_to(out.resolve()).as_posix()
    except ValueError:
        return None


def _claim_run_folder(args: argparse.Namespace, out: Path, options: dict, robot_args: dict | None = None):
    """Lock --out for `run` and check that the files it will write there are an earlier run's own
    (listed in its manifest.json, unchanged) or absent; nothing is removed yet (the earlier run
    stays whole until the new one has been computed: :meth:`OutputFolder.start`)."""
    from delta_pin.utils.manifest import claim

    page = None if args.html is None else _inside(args.html, out)
    names = [*RUN_FILES, *([] if page is None else [page])]
    return claim(
        out,
        "run",
        options,
        robot_args=robot_args,
        command_line=args.command_line,
        outputs=names,
        replace_same_command=True,
    )


def _finish_run_folder(folder, out: Path, written: list[Path]) -> None:
    """List the run's files inside --out in its manifest, with their SHA-256 (a page outside --out
    is the user's to keep: never listed, never removed by a later run)."""
    folder.finish([path for path in written if _inside(path, out) is not None])


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from delta_pin.studies.reproduce import reproduce

    _check_output_dir("--out", args.out)
    result = reproduce(args.out, quick=not args.full, **_executor_options(args), **_folder_options(args))
    holds = sum(c["holds"] == "yes" for c in result.claims)
    partly = sum(c["holds"] == "partly" for c in result.claims)
    print(
        f"{holds} of {len(result.claims)} of the paper's claims hold on this plant"
        + (f", {partly} partly" if partly else "")
        + f": see {result.out}/report.md"
    )
    return 0


def _split(text: str, flag: str | None = None) -> list[str]:
    """The comma-separated items of ``text``; with ``flag``, at least one (else a one-line error)."""
    items = [item.strip() for item in text.split(",") if item.strip()]
    if flag is not None and not items:
        raise InvalidParameterError(f"{flag} {text!r} names nothing: give one or more, separated by commas")
    return items


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
        for p in _split(args.paths, "--paths")
        for c in _split(args.controllers, "--controllers")
        for fc in ((True, False) if args.with_and_without_fc else (True,))
    ]
    _check_output_dir("--out", args.out)
    _check_memory(specs, args)
    metrics = compare(specs, args.out, **_executor_options(args), **_folder_options(args))
    print(markdown_table(metrics))
    print(f"wrote {args.out}/metrics.csv, metrics.md and figures/")
    return _failures([row.get("error") for row in metrics], args)


def _cmd_sweep(args: argparse.Namespace) -> int:
    from delta_pin.studies.reproduce import sweep
    from delta_pin.studies.sweep import parse_axes

    base = _spec_from_args(args, controller=args.controller, path=args.path)
    _check_output_dir("--out", args.out)
    axes = parse_axes(args.param)
    count = math.prod(len(values) for values in axes.values())
    if count > MAX_SWEEP_POINTS and not args.force:
        shape = " x ".join(f"{name} {len(values)}" for name, values in axes.items())
        raise InvalidParameterError(
            f"the grid has {count:,} points ({shape}), more than {MAX_SWEEP_POINTS:,}; "
            "give fewer values or --force"
        )
    from delta_pin.studies.sweep import grid_specs

    _check_memory(grid_specs(base, axes), args, "the grid's largest point: ")  # every point, not the base's
    rows = sweep(
        base,
        axes,
        args.out,
        metric=args.metric,
        **_executor_options(args),
        **_folder_options(args),
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
    "auto: RK4 sampled, the Radau IIA with error control continuous; rk4 (sampled), radau, bdf2 (continuous, "
    "fixed 1 ms steps, batched by sweeps): all the compiled core's"
)


_PLANT_HELP = "the simulated robot: constrained Pinocchio model or the paper's analytic model"
_MODE_HELP = "sampled: a digital drive (zero-order hold); continuous: the controller inside the integrator"


def _add_study_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--plant", choices=("pinocchio", "analytic"), default="analytic",
        help=_PLANT_HELP + "; studies of many runs default to the analytic model (the paper's own, "
        "and faster), while `run` defaults to Pinocchio's",
    )  # fmt: skip
    _add_choice_argument(parser, "--mode", MODES, default="continuous", help=_MODE_HELP)
    _add_choice_argument(parser, "--integrator", INTEGRATOR_CHOICES, default="auto", help=_INTEGRATOR_HELP)
    parser.add_argument(
        "--t-end", type=_seconds, default=None, help="duration [s] (None: the path's default)"
    )
    parser.add_argument("--dt", type=_seconds, default=1e-3, help="sample / control period [s]")
    parser.add_argument(
        "--sampling-aware",
        action="store_true",
        help="cap the robust gain so a sampled loop of period dt stays stable",
    )
    parser.add_argument("--out", type=Path, required=True, help="output directory")
    parser.add_argument(
        "--allow-failures",
        action="store_true",
        help="exit 0 even when some runs fail (they are still listed)",
    )
    _add_force_argument(parser)
    _add_executor_arguments(parser)


def _add_force_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--force",
        action="store_true",
        help="run even when a run's arrays would take more than half of this machine's memory, "
        f"or a sweep has more than {MAX_SWEEP_POINTS:,} points",
    )


# one local worker process with delta-pin, Pinocchio and a run loaded: 164 MiB of peak RSS measured
# for a 0.5 s run of the Delta (2026-12-06), 220 MB in the sweeps' workers; counted as 250 MiB
WORKER_MEMORY = 250 * 1024**2  # [bytes]


def _check_workers(args: argparse.Namespace) -> None:
    """Refuse more local worker processes than half of this machine's memory holds, unless --force
    (before: --workers 64 on a 24 GiB machine started its processes for minutes, then ended in
    distributed's tracebacks)."""
    from delta_pin.studies.experiments import memory_limit

    if args.scheduler not in (None, "local"):
        return  # the workers are the remote scheduler's
    need, limit = args.workers * WORKER_MEMORY, memory_limit()
    if need > limit and not getattr(args, "force", False):
        raise InvalidParameterError(
            f"--workers {args.workers} local processes take about {_size(need)} (~{_size(WORKER_MEMORY)} "
            f"each), more than {_size(limit)} (half of this machine's memory): give at most "
            f"{max(1, limit // WORKER_MEMORY)}" + (", or --force" if hasattr(args, "force") else "")
        )


def _executor_options(args: argparse.Namespace) -> dict:
    """Where the runs of a study execute, and on which robot (xacro arguments)."""
    _check_workers(args)
    robot_args = _parse_settings(args.settings)
    if robot_args:
        from delta_pin.model.description import compile_urdf

        compile_urdf(**robot_args)  # refuse a bad argument before any worker starts
    return {"workers": args.workers, "scheduler": args.scheduler, "robot_args": robot_args or None}


def _folder_options(args: argparse.Namespace) -> dict:
    """How a study treats its output folder (delta_pin.utils.manifest)."""
    return {"overwrite": args.overwrite, "command_line": args.command_line}


def _add_executor_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the outputs of a different study in --out (by default such a folder is refused; "
        "its cache/ is kept either way)",
    )
    _add_robot_arguments(parser, allow_urdf=False)
    parser.add_argument(
        "--workers",
        type=_integer(1),
        default=os.cpu_count() or 1,
        help="local worker processes (one per core)",
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        help="Dask scheduler address ('local' for a local cluster; needs the [dask] extra)",
    )


def _stop(signum, frame) -> None:
    raise KeyboardInterrupt


def _cmd_view(args: argparse.Namespace) -> int:
    """The live viewer until Ctrl-C or SIGTERM (or SIGHUP), either of which also ends its meshcat
    server (a SIGTERM used to leave the server on port 7000)."""
    import time

    from delta_pin.viz.meshcat_export import close_live, view_live

    stops = [signal.SIGTERM] + ([signal.SIGHUP] if hasattr(signal, "SIGHUP") else [])
    previous = {signum: signal.signal(signum, _stop) for signum in stops}
    viewer = None
    try:
        robot = None
        if args.robot is not None:  # a run on a robot its file alone rebuilds (MJCF, robot.yaml)
            from delta_pin.model.loaders import load_robot

            robot = load_robot(args.robot)
        viewer = view_live(args.run, robot, open_browser=args.open)
        print(f"meshcat viewer at {viewer.url()} -- press Ctrl-C to stop", flush=True)
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        if viewer is None:
            raise  # stopped while starting: interrupted
        return 0
    finally:
        if viewer is not None:
            close_live(viewer)
        for signum, handler in previous.items():
            signal.signal(signum, handler)


_DEBUG_HELP = "on an error, show Python's traceback instead of one line"


# ---------------------------------------------------------------- identify (issue 24) ----------
# delta-pin identify excite | simulate | fit: closed-chain dynamic identification
# (delta_pin/identification, docs/identification.md); this block is its whole command.
#
# identify never replaces a file it did not write (issue 36): --out is never one of the command's
# inputs (compared as files: os.path.samefile, through links and '..'); excite and simulate replace
# an existing --out only if its header proves it their own output (_IDENTIFY_OWN_FILES); fit writes
# like `run`: its folder claimed (manifest.json, lock, "complete": false until done) with the fixed
# names of report.OUTPUTS, an earlier `identify fit`'s outputs replaced, anyone else's refused.

# the header lines that make an existing --out provably this command's own output: the file's first
# line, and a line its header must hold too (a log a drive records in the format of
# docs/identification.md may start with the same first line; only simulate writes its `source`)
_IDENTIFY_OWN_FILES = {
    "excite": ("an excitation trajectory", "# delta-pin excitation trajectory", "# fourier:"),
    "simulate": (
        "a simulated log",
        "# delta-pin identification log",
        "# source: delta-pin identify simulate",
    ),
}


def _identify_robot(args: argparse.Namespace):
    """The robot of --robot (any closed chain) or of --urdf/--set (the packaged Delta)."""
    return _closed_chain_robot(args) if args.robot is not None else _load_robot(args)


def _identify_inputs(args: argparse.Namespace) -> list[tuple[str, Path]]:
    """(flag, file) of every existing file the command reads: --robot's file and the robot.yaml
    beside it, --urdf, --trajectory, --data, --validate."""
    inputs = []
    if args.robot is not None and Path(args.robot).is_file():
        robot = Path(args.robot)
        inputs.append(("--robot", robot))
        if robot.with_name("robot.yaml").is_file():
            inputs.append(("--robot", robot.with_name("robot.yaml")))
    for flag in ("--urdf", "--trajectory", "--data", "--validate"):
        path = getattr(args, flag[2:], None)
        if path is not None and Path(path).is_file():
            inputs.append((flag, Path(path)))
    return inputs


def _input_at(args: argparse.Namespace, path: Path) -> tuple[str, Path] | None:
    """The (flag, file) of an input that ``path`` is (the same file: links and '..' resolved)."""
    for flag, source in _identify_inputs(args):
        try:
            if os.path.samefile(path, source):
                return flag, source
        except OSError:  # path does not exist (or is a dangling link): no input
            continue
    return None


def _check_identify_out_file(args: argparse.Namespace, command: str) -> None:
    """excite/simulate: refuse, before any work, an --out that is one of the inputs, or an existing
    file whose header does not prove it an earlier output of this command (_IDENTIFY_OWN_FILES)."""
    out = args.out
    _check_output_file("--out", out)
    found = _input_at(args, out)
    if found is not None:
        flag, source = found
        raise InvalidParameterError(
            f"--out {out} is the file {flag} reads ({source}): identify {command} would write over it; "
            "give another --out file"
        )
    if not os.path.lexists(out):  # a dangling symbolic link is someone's too: refused below
        return
    what, first, mark = _IDENTIFY_OWN_FILES[command]
    if not _has_header(out, first, mark):
        raise InvalidParameterError(
            f"--out {out} exists and is not {what} delta-pin identify {command} wrote (its header has "
            f"no '{first}' and '{mark}' lines): it may be anyone's file; move it away, or give another "
            "--out file"
        )


def _has_header(path: Path, first: str, mark: str) -> bool:
    """Whether the ``#`` lines that open ``path`` start with ``first`` and hold one starting with
    ``mark``."""
    header = []
    try:
        with open(path, "rb") as handle:
            for line in iter(lambda: handle.readline(1 << 20), b""):
                if not line.startswith(b"#") or len(header) >= 64:
                    break
                header.append(line.decode("utf-8", errors="replace").rstrip("\r\n"))
    except OSError:
        return False
    return bool(header) and header[0] == first and any(line.startswith(mark) for line in header[1:])


def _check_identify_out_folder(args: argparse.Namespace) -> None:
    """fit: refuse, before any work, an --out that is one of the inputs or holds one of them under
    a name the fit writes (report.OUTPUTS: a Gepetto folder's robot.urdf given as --robot)."""
    from delta_pin.identification.report import OUTPUTS

    out = args.out
    found = _input_at(args, out)
    if found is not None:
        raise InvalidParameterError(
            f"--out {out} is the file {found[0]} reads; give a folder for the fit's outputs, e.g. "
            f"--out {out.parent / 'identified'}"
        )
    _check_output_dir("--out", out)
    for name in OUTPUTS:
        found = _input_at(args, out / name)
        if found is not None:
            raise InvalidParameterError(
                f"--out {out} holds {name}, the file {found[0]} reads ({found[1]}), and identify fit "
                f"writes its own {name} there; give another folder, e.g. --out {out / 'identified'}"
            )


def _claim_fit_folder(args: argparse.Namespace):
    """Lock --out for ``identify fit`` (:func:`delta_pin.utils.manifest.claim` with the fixed
    names of report.OUTPUTS, replacing an earlier ``identify fit`` whatever its options): each of
    those names present must be an earlier fit's, listed in its manifest.json and unchanged; the
    folder's other files are left alone. Nothing is removed until the fit is computed."""
    from delta_pin.identification.report import COMMAND, OUTPUTS
    from delta_pin.utils.manifest import claim

    def where(path):
        return None if path is None else str(Path(path).resolve())

    options = {
        "robot": where(args.robot) if args.robot is not None and Path(args.robot).is_file() else args.robot,
        "urdf": where(getattr(args, "urdf", None)),
        **{name: getattr(args, name, None) for name in ("actuated", "passive", "free_flyer", "home")},
        "data": where(args.data),
        "validate": where(args.validate),
        "cutoff": args.cutoff,
        "velocities": args.velocities,
        "consistent": not args.no_consistent,
        "figures": not args.no_figures,
    }
    return claim(
        args.out,
        COMMAND,
        options,
        robot_args=None if args.robot is not None else _parse_settings(args.settings),
        command_line=args.command_line,
        outputs=list(OUTPUTS),
        replace_same_command=True,
    )


def _identify_excite(args: argparse.Namespace) -> int:
    from delta_pin.identification.base import base_parameters
    from delta_pin.identification.excitation import ExcitationLimits, check_excitation, optimize_excitation
    from delta_pin.identification.regressor import ClosedChainRegressor
    from delta_pin.identification.workflow import write_trajectory

    _check_identify_out_file(args, "excite")
    samples = args.duration * args.rate
    if samples > MAX_TRAJECTORY_SAMPLES:
        raise InvalidParameterError(
            f"--duration {args.duration:g} s at --rate {args.rate:g} Hz is {samples:.3g} samples; at most "
            f"{MAX_TRAJECTORY_SAMPLES:.0e} are written (shorten --duration or lower --rate)"
        )
    if args.harmonics / args.period >= args.rate / 2.0:
        raise InvalidParameterError(
            f"--harmonics {args.harmonics} over --period {args.period:g} s reach "
            f"{args.harmonics / args.period:g} Hz, at or above the Nyquist frequency of --rate "
            f"{args.rate:g} Hz: use fewer harmonics, a longer period or a higher rate"
        )
    robot = _identify_robot(args)
    regressor = ClosedChainRegressor(robot)
    base = base_parameters(regressor)
    theta = regressor.parameters()
    limits = ExcitationLimits(position_range=args.position_range, velocity_limit=args.velocity_limit,
                              jacobian_condition=args.jacobian_condition)  # fmt: skip
    trajectory, info = optimize_excitation(
        regressor, base, theta, harmonics=args.harmonics, period=args.period, duration=args.duration,
        limits=limits, max_iterations=args.iterations, seed=args.seed, alpha0=robot.home + args.center,
    )  # fmt: skip
    met = check_excitation(regressor, trajectory, theta, limits=limits, rate=args.rate)
    write_trajectory(args.out, trajectory, robot, args.rate)
    print(
        f"wrote {args.out}: {args.duration:g} s at {args.rate:g} Hz, {base.rank} base parameters, cond "
        f"{info['condition_initial']:.4g} -> {info['condition']:.4g} ({info['iterations']} iterations); "
        f"max |alpha - alpha0| {max(met['position']):.3g}, |alpha_dot| {max(met['velocity']):.3g}, "
        f"cond J_p {met['jacobian_condition']:.3g}"
    )
    return 0


def _identify_simulate(args: argparse.Namespace) -> int:
    from delta_pin.identification.log import write_log
    from delta_pin.identification.workflow import perturbed_robot, read_trajectory, simulate_log
    from delta_pin.model.delta_robot import load_delta

    if args.robot_seed is not None and (args.mass_spread == 0.0 or args.true_settings):
        why = "--true-set gives the true robot" if args.true_settings else "--mass-spread is 0"
        raise InvalidParameterError(
            f"--robot-seed {args.robot_seed} seeds the true robot of --mass-spread, and {why}: give "
            "--mass-spread S (e.g. 0.3) without --true-set, or drop --robot-seed"
        )
    _check_identify_out_file(args, "simulate")
    robot = _identify_robot(args)
    trajectory = read_trajectory(args.trajectory, robot)
    # --seed seeds the noise, and the true robot too unless --robot-seed is given (as before)
    robot_seed = args.seed if args.robot_seed is None else args.robot_seed
    if args.true_settings:
        if args.robot is not None:
            raise InvalidParameterError(
                "--true-set takes the packaged Delta's xacro arguments; with --robot use --mass-spread"
            )
        true = load_delta(
            getattr(args, "urdf", None),
            **{**_parse_settings(args.settings), **_parse_settings(args.true_settings)},
        )
    elif args.mass_spread > 0.0:
        true = perturbed_robot(robot, args.mass_spread, robot_seed)
    else:
        true = robot
    friction = True if getattr(true, "delta", None) is not None and not args.no_friction else None
    log, run = simulate_log(
        true, trajectory, nominal=robot, friction=friction, payload_mass=args.payload, dt=1.0 / args.rate,
        encoder_bits=args.encoder_bits, torque_noise=args.torque_noise, seed=args.seed,
    )  # fmt: skip
    if args.mass_spread > 0.0 and not args.true_settings:
        log.header["robot_seed"] = robot_seed  # the true robot's seed, beside the noise's "seed"
    write_log(args.out, log)
    error = float(abs(run.alpha - run.alpha_d).max()) if len(run.t) else 0.0
    print(
        f"wrote {args.out}: {len(log)} samples of {trajectory.duration:g} s; "
        f"largest tracking error {error:.3g}"
    )
    return 0


def _friction_columns(robot, model: str | None):
    """The regressor's joint columns for ``identify fit --friction-model`` (``None``: the default,
    a Stribeck column where the robot is a Delta with URDF friction)."""
    from delta_pin.identification.regressor import JointColumns

    if model is None:
        return None
    if model == "viscous":
        return JointColumns(coulomb=False)
    if model == "coulomb":
        return JointColumns()
    delta = getattr(robot, "delta", None)
    friction = None if delta is None else delta.params.friction
    if friction is None:
        raise InvalidParameterError(
            f"--friction-model stribeck needs a Stribeck velocity, which robot {robot.name!r} does not carry "
            "(not a Delta with URDF friction); use --friction-model coulomb or viscous"
        )
    return JointColumns(stribeck_velocity=friction.v_s, friction_arm=friction.r_a)


def _identify_fit(args: argparse.Namespace) -> int:
    from delta_pin.identification.log import read_log
    from delta_pin.identification.report import write_report
    from delta_pin.identification.workflow import check_log_memory, identify, validate

    _check_identify_out_folder(args)
    robot = _identify_robot(args)
    columns = _friction_columns(robot, args.friction_model)  # before any file is read or claimed
    for path in (args.data, args.validate):  # before either is read: a fit holds ~9 kB a Delta sample
        if path is not None:
            check_log_memory(path, robot)
    log = read_log(args.data, robot.actuated_joints)
    unseen = None if args.validate is None else read_log(args.validate, robot.actuated_joints)
    with _claim_fit_folder(args) as folder:
        result = identify(
            robot, log, cutoff=args.cutoff, consistent=not args.no_consistent, columns=columns,
            velocities=args.velocities,
        )  # fmt: skip
        validation = None if unseen is None else validate(result, unseen)
        written = write_report(result, log, args.out, validation, figures=not args.no_figures, folder=folder)
    relative = ", ".join(f"{x:.3g}" for x in result.residual_rms / result.tau_rms)
    print(f"{result.base.rank} base parameters identified in {result.timings['total']:.2f} s; "
          f"residual {relative} "
          f"of the torque's RMS; cond {result.condition:.4g}")  # fmt: skip
    for line in [*result.warnings, *result.notes]:  # one line each (a torque scale far from the CAD model's)
        print(line)
    if result.consistent is not None:
        from delta_pin.identification.report import consistent_status

        print(consistent_status(result))
    if validation is not None:
        from delta_pin.identification.report import validation_summary

        print(validation_summary(validation))
    print(f"wrote {', '.join(str(p) for p in written)}")
    return 0


VALIDATE_MAX_SAMPLES = 100_000  # validate's random states (closed_chain_validation.MAX_SAMPLES)

# Bounds of identify excite, refused in one line before any work: each harmonic adds 2 Fourier
# coefficients per joint to the excitation optimiser (published excitations use 5-15 harmonics),
# and the trajectory CSV takes ~200 bytes a sample (1e7 samples: ~2 GB, 2.8 h at 1 kHz).
MAX_HARMONICS = 100
# L-BFGS-B iterations of the excitation's condition number, each a few regressor evaluations along
# the whole trajectory (the default is 30)
MAX_EXCITATION_ITERATIONS = 1000
MAX_TRAJECTORY_SAMPLES = 1e7


def _add_identify_command(add) -> None:
    identify = add(
        "identify", help="identify a closed-chain robot's dynamics from joint data (docs/identification.md)"
    )
    actions = identify.add_subparsers(dest="identify_command", required=True)

    def action(name: str, **options) -> argparse.ArgumentParser:
        parser = actions.add_parser(name, formatter_class=_HelpFormatter, **options)
        _add_robot_arguments(parser)
        _robot_file_arguments(parser)
        return parser

    excite = action(
        "excite", help="an excitation trajectory (Fourier series optimised for the regressor's condition)"
    )
    excite.add_argument(
        "--out", type=Path, required=True,
        help="the trajectory CSV (t, q[J], qd[J], qdd[J]); never an input, and an existing file only if "
        "excite wrote it (its header)",
    )  # fmt: skip
    excite.add_argument("--duration", type=_seconds, default=20.0, help="length [s]")
    excite.add_argument("--period", type=_seconds, default=5.0, help="the Fourier series' period [s]")
    excite.add_argument(
        "--harmonics", type=_integer(1, MAX_HARMONICS), default=8,
        help=f"harmonics per joint (at most {MAX_HARMONICS})",
    )  # fmt: skip
    excite.add_argument(
        "--iterations", type=_integer(0, MAX_EXCITATION_ITERATIONS), default=30,
        help=f"optimiser iterations (at most {MAX_EXCITATION_ITERATIONS})",
    )  # fmt: skip
    excite.add_argument(
        "--rate", type=_number(0, above=True), default=1000.0, help="sample rate of the file [Hz]"
    )
    excite.add_argument(
        "--position-range",
        type=_number(0, above=True),
        default=None,
        help="largest |alpha - alpha0| [rad or m]",
    )
    excite.add_argument(
        "--velocity-limit",
        type=_number(0, above=True),
        default=None,
        help="largest |alpha_dot| [rad/s or m/s]",
    )
    excite.add_argument(
        "--jacobian-condition", type=_number(1), default=100.0, help="largest cond J_p along the path"
    )
    excite.add_argument(
        "--center", type=_number(), default=0.0, help="alpha0 = home + CENTER on every joint [rad or m]"
    )
    excite.add_argument("--seed", type=_integer(0), default=0, help="seed of the optimiser's start")
    excite.set_defaults(func=_identify_excite)

    simulate = action(
        "simulate", help="a log of the Pinocchio plant running an excitation (encoders, torque noise)"
    )
    simulate.add_argument(
        "--trajectory", type=Path, required=True, help="a file of delta-pin identify excite"
    )
    simulate.add_argument(
        "--out", type=Path, required=True,
        help="the log CSV (t, q[J], tau[J]); never an input, and an existing file only if simulate wrote "
        "it (its header's '# source: delta-pin identify simulate')",
    )  # fmt: skip
    simulate.add_argument(
        "--true-set", dest="true_settings", action="append", default=[], metavar="NAME=VALUE",
        help="the simulated (true) Delta's xacro arguments, e.g. m_a=0.26 (repeatable)",
    )  # fmt: skip
    simulate.add_argument(
        "--mass-spread", type=_number(0, maximum=1, below=True), default=0.0,
        help="scale each body's inertia by a seeded factor in [1 - s, 1 + s] (the true robot)",
    )  # fmt: skip
    simulate.add_argument(
        "--payload", type=_number(0), default=0.0, help="a point mass at the end effector [kg]"
    )
    simulate.add_argument(
        "--encoder-bits", type=_integer(8), default=17, help="encoder resolution (2^bits per turn)"
    )
    simulate.add_argument(
        "--torque-noise", type=_number(0), default=0.01, help="torque noise, relative to its RMS"
    )
    simulate.add_argument(
        "--rate", type=_number(0, above=True), default=1000.0, help="sample and control rate [Hz]"
    )
    simulate.add_argument("--no-friction", action="store_true", help="no joint friction in the plant (Delta)")
    simulate.add_argument(
        "--seed", type=_integer(0), default=0,
        help="seed of the noise and, without --robot-seed, of --mass-spread",
    )  # fmt: skip
    simulate.add_argument(
        "--robot-seed", type=_integer(0), default=None,
        help="seed of --mass-spread's true robot alone (default: --seed), so that a second log has new "
        "noise (--seed) on the same true robot",
    )  # fmt: skip
    simulate.set_defaults(func=_identify_simulate)

    fit = action("fit", help="fit base parameters to a log; write parameters.json, report.md, figures")
    fit.add_argument("--data", type=Path, required=True, help="the log CSV (docs/identification.md)")
    fit.add_argument(
        "--out", type=Path, required=True,
        help="output folder, like run's: manifest.json and a lock; parameters.json, xacro_arguments.json, "
        "robot.urdf, report.md and the PNGs present must be an earlier fit's (its manifest.json lists "
        "them), and are replaced; a file of those names it did not write is refused, other files are "
        "left alone",
    )  # fmt: skip
    fit.add_argument("--validate", type=Path, default=None, help="a second log the fit does not see")
    fit.add_argument(
        "--cutoff", type=_number(0, above=True), default=20.0, help="the parallel filter's cut-off [Hz]"
    )
    fit.add_argument(
        "--velocities", choices=("positions", "logged"), default="positions",
        help="the joint velocities: the derivative of the filtered positions (the default), or the log's "
        "qd columns, filtered alike; a qd's lag behind the positions' derivative is reported either way",
    )  # fmt: skip
    fit.add_argument(
        "--friction-model", choices=("viscous", "coulomb", "stribeck"), default=None,
        help="friction columns per joint: viscous (fv), coulomb (fv, fc) or stribeck (fv, fc, fs); default: "
        "stribeck for a Delta with URDF friction, coulomb otherwise (rotor inertia and offset always)",
    )  # fmt: skip
    fit.add_argument("--no-consistent", action="store_true", help="skip the physically consistent estimate")
    fit.add_argument("--no-figures", action="store_true", help="write no figures")
    fit.set_defaults(func=_identify_fit)


PLAN_FILES = ("plan.csv", "plan.json", "plan.png")  # what `plan` writes into --out (and singularity_map.png)
# the plan CSV's rate: a pick-and-place lasts about a second, ~200 bytes a row (1e5 Hz: ~20 MB a second)
MAX_PLAN_RATE = 1e5


def _add_plan_command(add) -> None:
    plan = add(
        "plan",
        help="a time-optimal, torque-feasible pick-and-place of any closed chain, verified on the exact "
        "model "
        "(docs/planning.md)",
    )
    _add_robot_arguments(plan)
    _robot_file_arguments(plan)
    plan.add_argument(
        "--path", choices=("adept",), default="adept",
        help="adept: the Adept cycle (--height up, --width across, down, and back; rest at both ends of each "
        "half); --corners replaces it with your own pick-and-place polyline",
    )  # fmt: skip
    plan.add_argument(
        "--corners", default=None, metavar="X,Y,Z;X,Y,Z;...",
        help="the frame's path through these points [m], from rest to rest, its corners blended; quote it "
        "(the shell ends a command at ';') and join it with '=' (a first number may be negative): "
        "--corners='-0.02,0,-0.53;-0.02,0,-0.52;0.02,0,-0.52'",
    )  # fmt: skip
    plan.add_argument("--height", type=float, default=0.025, help="the Adept cycle's rise [m]")
    plan.add_argument("--width", type=float, default=0.305, help="the Adept cycle's move across [m]")
    plan.add_argument("--z", type=float, default=-0.40, help="the height of its pick and place points [m]")
    plan.add_argument("--center", default="0,0", metavar="X,Y", help="the midpoint of pick and place [m]")
    plan.add_argument("--blend", type=float, default=0.01, help="the corners' blend distance [m]")
    plan.add_argument(
        "--torque-limit", required=True, metavar="T[,T...]",
        help="|tau| per actuated joint [N m or N]: one value for all, or one per joint",
    )  # fmt: skip
    plan.add_argument("--velocity-limit", default=None, metavar="V[,V...]", help="|alpha_dot| [rad/s or m/s]")
    plan.add_argument("--points", type=_integer(3, 100_000), default=100, help="grid points per path")
    plan.add_argument(
        "--switch-refinements", type=_integer(0, 10), default=2,
        help="rounds that halve the grid's intervals around the law's switches of s_ddot before the check "
        "(0: the grid of --points as it is; each round costs a solve and the new points' kinematics)",
    )  # fmt: skip
    plan.add_argument(
        "--jerk-limit", default=None, metavar="J[,J...]",
        help="|alpha_dddot| per actuated joint [rad/s^3 or m/s^3]: the time-optimal law averaged over a "
        "moving window (or run slower) until the exact model's check holds (docs/planning.md)",
    )  # fmt: skip
    plan.add_argument("--friction", action="store_true", help="the nominal friction (a recognised Delta's)")
    plan.add_argument("--payload", type=float, default=0.0, help="a payload at the end effector [kg]")
    plan.add_argument(
        "--frame", default=None, help="the frame that follows the path (default the end effector)"
    )
    plan.add_argument(
        "--axes", default=None, help="its controlled coordinates (default xyz, or xz for 2 motors)"
    )
    plan.add_argument(
        "--rate", type=float, default=1000.0, help=f"the CSV's sample rate [Hz], at most {MAX_PLAN_RATE:g}"
    )
    plan.add_argument(
        "--singularity-margin", type=float, default=5e-3,
        help="refuse a path that comes this close to a Type I or II singularity (sigma_min/sigma_max; "
        "0: never)",
    )  # fmt: skip
    plan.add_argument(
        "--map", action="store_true",
        help="also draw singularity_map.png: the distance to a singularity over the plane of the path's "
        "pick and place points (xy at their height; xz for a robot of 2 motors)",
    )  # fmt: skip
    plan.add_argument("--out", type=Path, required=True, help="the output folder: " + ", ".join(PLAN_FILES))
    plan.set_defaults(func=_cmd_plan)


def _cmd_plan(args: argparse.Namespace) -> int:
    from delta_pin.model.trajectory import AdeptCycle
    from delta_pin.planning import BlendedPath, PlannedSequence, adept_paths, plan_time_optimal
    from delta_pin.planning.files import write_plan
    from delta_pin.planning.time_optimal import torque_model
    from delta_pin.utils.manifest import claim
    from delta_pin.viz.planning_plots import plot_plan
    from delta_pin.viz.plots import save_figure

    out = Path(args.out)
    _check_output_dir("--out", out)
    for flag, value in (("--rate", args.rate), ("--blend", args.blend), ("--payload", args.payload)):
        if not (math.isfinite(value) and value >= 0.0 and (flag != "--rate" or value > 0.0)):
            raise InvalidParameterError(
                f"{flag} {value!r} must be a finite number >= 0{' (> 0)' if flag == '--rate' else ''}"
            )
    if args.rate > MAX_PLAN_RATE:
        raise InvalidParameterError(f"--rate {args.rate:g} Hz: at most {MAX_PLAN_RATE:g} Hz (the CSV's rows)")
    if not (math.isfinite(args.singularity_margin) and 0.0 <= args.singularity_margin < 1.0):
        raise InvalidParameterError(f"--singularity-margin {args.singularity_margin!r} must be in [0, 1)")
    robot = _closed_chain_robot(args) if args.robot is not None else _load_robot(args)
    torque = _numbers("--torque-limit", args.torque_limit)
    velocity = None if args.velocity_limit is None else _numbers("--velocity-limit", args.velocity_limit)
    jerk = None if args.jerk_limit is None else _numbers("--jerk-limit", args.jerk_limit)
    if args.map and robot.dof > 3:
        raise InvalidParameterError(f"--map places a frame's position: {robot.name!r} has {robot.dof} motors")
    if args.corners is not None:
        corners = [_numbers("--corners", point) for point in args.corners.split(";") if point.strip()]
        if any(len(c) != 3 for c in corners):
            raise InvalidParameterError(f"--corners {args.corners!r} must be points X,Y,Z separated by ';'")
        paths = [BlendedPath(corners, args.blend)]
        paths[0].name = "pick and place"
    else:
        center = _numbers("--center", args.center)
        if len(center) != 2:
            raise InvalidParameterError(f"--center {args.center!r} must be X,Y [m]")
        cycle = AdeptCycle(height=args.height, width=args.width, z=args.z, center=center)
        paths = list(adept_paths(cycle, args.blend))
    options = {
        "torque_limit": torque, "velocity_limit": velocity, "points": args.points, "frame": args.frame,
        "axes": args.axes, "friction": True if args.friction else None, "payload_mass": args.payload,
        "switch_refinements": args.switch_refinements, "jerk_limit": jerk,
    }  # fmt: skip
    plans = [
        plan_time_optimal(
            robot, path, torque if len(torque) > 1 else torque[0],
            velocity_limit=None if velocity is None else (velocity if len(velocity) > 1 else velocity[0]),
            points=args.points, frame=args.frame, axes=args.axes, friction=options["friction"],
            payload_mass=args.payload, singularity_margin=args.singularity_margin,
            switch_refinements=args.switch_refinements,
            jerk_limit=None if jerk is None else (jerk if len(jerk) > 1 else jerk[0]),
        )
        for path in paths
    ]  # fmt: skip
    sequence = PlannedSequence(plans, " + ".join(p.path.name for p in plans))
    summary = {
        "robot": robot.name,
        "path": [p.path.metadata() for p in plans],
        "duration_s": sequence.duration,
        "plans": [
            {
                "path": p.path.name, "duration_s": p.duration, "grid_points": len(p.s),
                "switch_points": p.switch_points, "repairs": p.repairs,
                "torque_ratio_10kHz": p.verification.torque_ratio,
                "jerk_ratio_10kHz": p.verification.jerk_ratio, "smoothing_s": p.smoothing,
                "peak_torque": p.verification.peak_torque.tolist(),
                "torque_margin": p.verification.margin.tolist(),
                "singularity_type_I_min": float(p.singularity[0]),
                "singularity_type_II_min": float(p.singularity[1]), "planning_time_s": p.planning_time,
                "verification_time_s": p.verification_time,
            }
            for p in plans
        ],
        "options": options,
    }  # fmt: skip
    names = [*PLAN_FILES, *(["singularity_map.png"] if args.map else [])]
    with claim(out, "plan", options, command_line=args.command_line, outputs=names,
               replace_same_command=True) as folder:  # fmt: skip
        folder.start()
        written = [
            write_plan(
                out / "plan.csv", sequence, robot, torque_model(robot, options["friction"], args.payload),
                args.rate, {"torque_limit": torque, "paths": [p.path.name for p in plans]},
            ),
        ]  # fmt: skip
        write_text_atomically(out / "plan.json", json.dumps(summary, indent=2) + "\n")
        written.append(out / "plan.json")
        written.append(save_figure(plot_plan(plans, sequence.name), out / "plan.png"))
        if args.map:
            figure = _singularity_map(robot, paths, args.frame, args.axes)
            written.append(save_figure(figure, out / "singularity_map.png"))
        folder.finish(written)
    feasible = all(p.verification.feasible for p in plans)
    halves = ", ".join(f"{p.path.name} {p.duration * 1e3:.1f} ms" for p in plans)
    print(
        f"{sequence.name}: {sequence.duration * 1e3:.1f} ms ({halves}); largest |tau|/limit on the exact "
        "model "
        f"at 10 kHz {max(p.verification.torque_ratio for p in plans):.4f}; wrote "
        f"{', '.join(str(w) for w in written)}"
    )
    if not feasible:
        print(
            "  the verification still exceeds a limit after the repairs: the plan is not feasible",
            file=sys.stderr,
        )
    return 0 if feasible else 1


def _singularity_map(robot, paths, frame: str | None, axes: str | None):
    """The figure of :func:`~delta_pin.planning.singularity.workspace_map` in the plane of the paths'
    first corner, 61 x 61 points over a square around their corners (half-width the larger of
    0.35 m and 1.5 times their spread), the paths drawn over it."""
    import numpy as np

    from delta_pin.planning.singularity import workspace_map
    from delta_pin.viz.planning_plots import plot_singularity_map

    corners = np.vstack([p.corners for p in paths])
    plane = "xy" if robot.dof >= 3 else "xz"
    u, v, fixed = (0, 1, 2) if plane == "xy" else (0, 2, 1)
    centre = 0.5 * (corners.min(axis=0) + corners.max(axis=0))
    half = max(0.35, 1.5 * float(np.ptp(corners[:, [u, v]], axis=0).max()))
    xs, ys = (np.linspace(centre[i] - half, centre[i] + half, 61) for i in (u, v))
    measure = workspace_map(robot, xs, ys, float(corners[0, fixed]), plane, frame, axes)
    labels = (f"{plane[0]} [m]", f"{plane[1]} [m]")
    where = f"{'xyz'[fixed]} = {corners[0, fixed]:g} m"
    drawn = [p.position(np.linspace(0.0, p.length, 200))[:, [u, v]] for p in paths]
    return plot_singularity_map(
        measure, xs, ys, labels, f"{robot.name}: distance to a singularity at {where}", drawn
    )


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="delta-pin",
        description="Model-based control of Delta parallel robots, built on Pinocchio.",
        epilog="Exit codes: 0 done, 1 a run or check failed, 2 bad input, 130 interrupted (Ctrl-C), 141 its "
        "output pipe closed (| head), "
        "143 terminated (SIGTERM).",
    )
    parser.add_argument("--debug", action="store_true", help=_DEBUG_HELP)
    sub = parser.add_subparsers(dest="command", required=True)

    def add(name: str, **options) -> argparse.ArgumentParser:
        command = sub.add_parser(name, formatter_class=_HelpFormatter, **options)
        command.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=_DEBUG_HELP)
        return command

    urdf = add("urdf", help="compile the parametric Delta xacro to a URDF")
    _add_robot_arguments(urdf, allow_urdf=False)
    urdf.add_argument("-o", "--output", type=Path, help="output file (None: standard output)")
    urdf.set_defaults(func=_cmd_urdf)

    validate = add("validate", help="compare the analytic model with the constrained Pinocchio model")
    _add_robot_arguments(validate)
    validate.add_argument(
        "--samples", type=_integer(1, VALIDATE_MAX_SAMPLES), default=100, help="random states"
    )
    validate.add_argument("--seed", type=int, default=0, help="random seed")
    validate.add_argument(
        "--tol",
        type=float,
        default=None,
        help="relative tolerance of the M, C a_dot, G agreement (None: 1e-10); with --robot, of the "
        "gravity, Coriolis and energy checks (None: 1e-6)",
    )
    validate.add_argument(
        "--dt",
        type=float,
        default=None,
        help="with --robot: integrate the energy check's free motion by RK4 at this fixed step [s] "
        "(None: DOP853 with error control)",
    )
    validate.add_argument(
        "--duration",
        type=float,
        default=None,
        help="with --robot: length of the energy check's free motion [s] (None: 0.5)",
    )
    validate.add_argument(
        "--frame",
        default=None,
        metavar="NAME",
        help="with --robot: the end effector (a link, joint, site or closure frame; None: the file's "
        "default); adds the checks 'frame J' (its closed-loop Jacobian vs its position by differences) "
        "and 'frame Jdot' (J_dot alpha_dot vs J by differences)",
    )
    _robot_file_arguments(validate)
    validate.set_defaults(func=_cmd_validate)

    run = add("run", help="simulate one controller on one path (the paper's Section V scenario)")
    _add_choice_argument(run, "--controller", CONTROLLERS, default="design1", help="the control law")
    _add_choice_argument(run, "--path", PATHS, default="I", help="the reference path")
    run.add_argument(
        "--plant", choices=("pinocchio", "analytic"), default="pinocchio",
        help=_PLANT_HELP + "; one run defaults to Pinocchio's exact model, while compare, sweep and "
        "reproduce --quick default to the analytic one",
    )  # fmt: skip
    _add_choice_argument(run, "--mode", MODES, default="continuous", help=_MODE_HELP)
    _add_choice_argument(run, "--integrator", INTEGRATOR_CHOICES, default="auto", help=_INTEGRATOR_HELP)
    run.add_argument(
        "--t-end",
        type=_seconds,
        default=None,
        help="duration [s] (None: 15 for path I, 10 for II, 3 for adept; with --robot 6, or two periods)",
    )
    run.add_argument("--dt", type=_seconds, default=1e-3, help="sample / control period [s]")
    run.add_argument(
        "--no-friction-compensation", action="store_true", help="leave the friction out of the controller"
    )
    run.add_argument(
        "--sampling-aware",
        action="store_true",
        help="cap the robust gain so a sampled loop of period dt stays stable",
    )
    run.add_argument("--uncertainty", type=float, default=0.3, help="magnitude Delta_m = Delta_fc = Delta_f")
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
        help="encoders of 2^bits counts per turn, 8-32 (None: the exact state)",
    )
    _add_choice_argument(
        drive,
        "--velocity",
        VELOCITIES,
        default="difference",
        help="with an encoder, the velocity the controller gets (difference: of the readings)",
    )
    drive.add_argument("--delay", type=int, default=0, help="samples of computation delay")
    drive.add_argument(
        "--torque-limit", type=float, default=None, help="the drive's saturation [N m] (None: none)"
    )
    run.add_argument(
        "--out",
        type=Path,
        required=True,
        help="output directory (run.npz, summary.json, manifest.json); a rerun replaces an earlier run's "
        "files once the new run is computed, and refuses files that are not an earlier run's own",
    )
    run.add_argument(
        "--html", type=_page_file, default=None, help="also export a standalone meshcat page (a file name)"
    )
    _add_force_argument(run)
    _add_robot_arguments(run)
    _robot_file_arguments(run)
    run.add_argument(
        "--frame",
        default=None,
        help="with --robot: the frame that draws a circle (None: a joint-space sinusoid)",
    )
    run.add_argument(
        "--radius", type=float, default=0.02, help="with --robot --frame: the circle's radius [m]"
    )
    run.add_argument(
        "--period", type=float, default=2.0, help="with --robot: the circle's or sinusoid's period [s]"
    )
    run.set_defaults(func=_cmd_run)
    _record_given(run)

    reproduce = add("reproduce", help="the paper's Section V study: runs, surfaces, figures, report")
    size = reproduce.add_mutually_exclusive_group()
    size.add_argument("--quick", action="store_true", help="analytic plant, 3 x 3 surfaces (the default)")
    size.add_argument("--full", action="store_true", help="Pinocchio plant, 11 x 11 surfaces")
    reproduce.add_argument("--out", type=Path, default=Path("out/reproduce"), help="output directory")
    _add_executor_arguments(reproduce)
    reproduce.set_defaults(func=_cmd_reproduce)

    compare = add("compare", help="several controllers on several paths: metrics and figures")
    compare.add_argument("--controllers", default="design1,design2,lqr", help="comma-separated")
    compare.add_argument("--paths", default="I,II", help="comma-separated: I, II, adept")
    compare.add_argument(
        "--with-and-without-fc",
        action="store_true",
        help="each controller with and without friction compensation",
    )
    _add_study_arguments(compare)
    compare.set_defaults(func=_cmd_compare)

    sweep = add("sweep", help="a grid over uncertainty magnitudes or gains")
    sweep.add_argument(
        "--param",
        action="append",
        required=True,
        metavar="NAME=SPEC",
        help="an axis: delta_m=0:0.9:4 (start:stop:count) or xi=0.001,0.01 (repeatable)",
    )
    _add_choice_argument(sweep, "--controller", CONTROLLERS, default="design1", help="the control law")
    _add_choice_argument(sweep, "--path", PATHS, default="I", help="the reference path")
    sweep.add_argument("--metric", default="rho_hat_max", help="surface of this metric for two axes")
    _add_study_arguments(sweep)
    sweep.set_defaults(func=_cmd_sweep)

    view = add("view", help="open a live meshcat viewer of a saved run")
    view.add_argument("run", type=Path, help="a run.npz written by delta-pin run")
    view.add_argument("--open", action="store_true", help="open the browser")
    view.add_argument(
        "--robot", default=None, help="the robot file of a run on a closed-chain robot (None: from the run)"
    )
    view.set_defaults(func=_cmd_view)
    _add_identify_command(add)  # identify excite | simulate | fit (issue 24)
    _add_plan_command(add)  # plan (issue 40)
    return parser


def _one_line(text: str) -> str:
    return " ".join(part.strip() for part in str(text).splitlines() if part.strip())


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``delta-pin`` console script; returns the exit code.

    Every expected failure is one line on stderr, ``delta-pin COMMAND: error: ...``: exit code 2
    for bad input (arguments, files), 1 for a run or check that failed, 130 for Ctrl-C, 143 for
    SIGTERM (the same line as Ctrl-C). With
    ``--debug`` the error is raised instead, with its traceback.
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except _UsageError as exc:
        print(_one_line(exc), file=sys.stderr)
        return EXIT_BAD_INPUT
    except SystemExit as exc:  # --help
        return exc.code if isinstance(exc.code, int) else 0
    prefix = f"delta-pin {args.command}"
    args.command_line = ["delta-pin", *(sys.argv[1:] if argv is None else argv)]
    terminated: list[int] = []
    previous = _on_sigterm(terminated)
    try:
        return args.func(args)
    except (KeyboardInterrupt, SystemError) as exc:
        # a SystemError that carries a KeyboardInterrupt is Ctrl-C or SIGTERM inside a compiled call
        if args.debug or interrupt_of(exc) is None:
            raise
        resume = "; rerun the same command to resume" if args.command in RESUMABLE else ""
        print(f"{prefix}: interrupted{resume}", file=sys.stderr)
        return EXIT_TERMINATED if terminated else EXIT_INTERRUPTED
    except Exception as exc:
        if args.debug:
            raise
        if isinstance(exc, BrokenPipeError):  # `delta-pin ... | head`: the reader is gone, say nothing
            _silence_stdout()
            return EXIT_BROKEN_PIPE
        code, message = _error_line(exc, args)
        print(f"{prefix}: error: {message}", file=sys.stderr)
        return code
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _on_sigterm(terminated: list[int]):
    """Handle SIGTERM as Ctrl-C: a KeyboardInterrupt where the command is (a study stops its
    workers, its folder stays marked unfinished, the same one line), exit code 143 instead of 130;
    a second SIGTERM ends the process at once. Returns the handler it replaced (``None`` where
    handlers cannot be set: not the main thread)."""

    def stop(signum, frame) -> None:
        terminated.append(signum)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        raise KeyboardInterrupt

    try:
        return signal.signal(signal.SIGTERM, stop)
    except ValueError:  # not the main thread of the interpreter
        return None


def _silence_stdout() -> None:
    """Point stdout at /dev/null, so that the interpreter's last flush of a closed pipe raises
    nothing (Python's documented handling of SIGPIPE, docs.python.org/3/library/signal.html)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def _error_line(exc: Exception, args: argparse.Namespace | None = None) -> tuple[int, str]:
    """(exit code, one-line message) of an exception that ends a command."""
    if isinstance(exc, SimulationError):
        return EXIT_FAILED, _one_line(exc)
    if isinstance(exc, DeltaPinError):
        return EXIT_BAD_INPUT, _one_line(exc)
    if isinstance(exc, OSError) and exc.filename is not None:
        return EXIT_BAD_INPUT, _one_line(f"{exc.filename}: {exc.strerror or exc}")
    if isinstance(exc, OSError) and exc.errno == errno.ENOSPC:
        return EXIT_FAILED, (
            "no space left on the device (the outputs are written to temporaries and renamed, so no "
            "earlier file was replaced by a partial one): free some space and rerun the same command"
        )
    if isinstance(exc, MemoryError):
        if args is not None and hasattr(args, "t_end"):
            return EXIT_FAILED, "out of memory; shorten the run (--t-end) or lengthen --dt"
        return EXIT_FAILED, "out of memory: the command asked for more than this machine has; ask for less"
    detail = f"{type(exc).__name__}: {_one_line(exc)}"
    return EXIT_FAILED, f"unexpected {detail} (rerun with --debug for the traceback)"


if __name__ == "__main__":
    sys.exit(main())

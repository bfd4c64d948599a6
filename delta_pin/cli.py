"""Command-line interface: ``delta-pin urdf | validate`` (more subcommands join as they land)."""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

from .errors import DeltaPinError, XacroArgumentError

__all__ = ["main"]


def _parse_settings(settings: list[str]) -> dict[str, str]:
    """``["l_a=0.25", "m_o=0.5"]`` -> ``{"l_a": "0.25", "m_o": "0.5"}``."""
    parsed = {}
    for item in settings:
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise XacroArgumentError(f"--set expects NAME=VALUE, got {item!r}")
        parsed[name.strip()] = value.strip()
    return parsed


def write_text_atomically(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename (never half-written)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as handle:
            handle.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


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
    from .robot import load_delta

    return load_delta(getattr(args, "urdf", None), **_parse_settings(args.settings))


def _cmd_urdf(args: argparse.Namespace) -> int:
    from .description import compile_urdf

    text = compile_urdf(**_parse_settings(args.settings))
    if args.output is None:
        sys.stdout.write(text)
    else:
        write_text_atomically(args.output, text)
        print(f"wrote {args.output}")
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    from .validation import validate

    report = validate(_load_robot(args), samples=args.samples, seed=args.seed, tol=args.tol)
    print(report.table())
    return 0 if report.passed else 1


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

"""The install a newcomer waits for: ``pip install -e '.[viz]'`` from a fresh clone (issue 38, item 4).

Run: ``python benchmarks/bench_install.py [--cache warm|cold|both] [--cxx g++|clang++] [--extra viz]
[--commit REV]``

Each case clones the repository's committed ``HEAD`` into a temporary folder, makes a fresh
virtual environment there and runs the README's install into it with ``HOME`` in that folder too.
``warm``: pip's cache is the user's (the wheels already downloaded once); ``cold``: an empty
cache (everything downloaded again; needs the package index). The reference, measured in the
same run and the same way, is the install of delta-pin's dependencies alone into another fresh
environment: what a pure-Python package with the same dependencies would cost, so that the
ratio is the compiled core's price. The compile's own figures come from ninja's log of the
clone's build folder: the wall time from the first unit to the link and the seconds of every unit.

``--cxx`` compiles with that compiler (``CXX``); by default CMakeLists.txt picks clang++ where it
is installed, else the system's c++. ``--commit`` measures another commit (an earlier one, for a
before and after on one machine).
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import tomllib
from common import Timing, machine_info, print_table, report_target

ROOT = Path(__file__).resolve().parent.parent
LIMITS = {"warm": 90.0, "cold": 150.0}  # [s] issue 38's targets


def _dependencies(extra: str) -> list[str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    return [*project["dependencies"], *project["optional-dependencies"][extra]]


def _environment(home: Path, cache: str, cxx: str | None) -> dict[str, str]:
    env = {key: value for key, value in os.environ.items() if not key.startswith(("PIP_", "VIRTUAL_ENV"))}
    env["HOME"] = str(home)
    if cache == "cold":
        env["PIP_CACHE_DIR"] = str(home / "pip-cache")
    else:  # the user's own cache, wherever HOME points
        env["PIP_CACHE_DIR"] = str(Path(os.environ.get("PIP_CACHE_DIR", Path.home() / ".cache" / "pip")))
    if cxx:
        env["CXX"] = cxx
    env.pop("PYTHONPATH", None)
    return env


def _install(folder: Path, arguments: list[str], env: dict[str, str], cwd: Path) -> float:
    """Seconds of ``python -m venv`` + ``pip install ARGUMENTS`` in a fresh environment."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "venv", str(folder)], check=True, env=env)
    pip = [str(folder / "bin" / "python"), "-m", "pip", "install", "-q", *arguments]
    done = subprocess.run(pip, cwd=cwd, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(
            f"pip install {' '.join(arguments)} failed:\n{done.stdout[-3000:]}{done.stderr[-3000:]}"
        )
    return time.perf_counter() - start


def _compile_log(clone: Path) -> tuple[float, float, list[tuple[str, float]]]:
    """(compile wall [s], sum of the units' seconds, (unit, seconds) longest first) from ninja's log."""
    logs = list((clone / "build").glob("*/.ninja_log"))
    if not logs:
        return float("nan"), float("nan"), []
    units, first, last = [], None, 0.0
    for line in logs[0].read_text().splitlines()[1:]:
        start, end, _, target, _ = line.split("\t")
        if not target.endswith((".o", ".so")):
            continue
        start_s, end_s = int(start) / 1000, int(end) / 1000
        first = start_s if first is None else min(first, start_s)
        last = max(last, end_s)
        units.append((Path(target).name, end_s - start_s))
    units.sort(key=lambda unit: -unit[1])
    return last - (first or 0.0), sum(seconds for _, seconds in units), units


def _compiler(clone: Path) -> str:
    """The compiler CMake used (its compiler file: CMakeLists.txt may set it without the cache)."""
    for found in (clone / "build").glob("*/CMakeFiles/*/CMakeCXXCompiler.cmake"):
        for line in found.read_text().splitlines():
            if line.startswith("set(CMAKE_CXX_COMPILER "):
                return line.split('"')[1]
    return "?"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", choices=("warm", "cold", "both"), default="warm")
    parser.add_argument(
        "--cxx", default=None, help="the C++ compiler (CXX); default: CMakeLists.txt's choice"
    )
    parser.add_argument("--extra", default="viz", help="the extra of the README's install (default viz)")
    parser.add_argument("--commit", default="HEAD", help="the commit to install (default HEAD)")
    args = parser.parse_args()
    dirty = subprocess.run(
        ["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT, capture_output=True, text=True
    )
    if dirty.stdout.strip() and args.commit == "HEAD":
        print("note: uncommitted changes are not measured (the clone is of HEAD)")
    print(f"machine: {machine_info()}")
    caches = ("warm", "cold") if args.cache == "both" else (args.cache,)
    for cache in caches:
        with tempfile.TemporaryDirectory(prefix="delta-pin-install-") as scratch:
            scratch = Path(scratch)
            home = scratch / "home"
            home.mkdir()
            env = _environment(home, cache, args.cxx)
            clone = scratch / "delta-pin"
            subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
            subprocess.run(["git", "-C", str(clone), "checkout", "-q", args.commit], check=True)
            ours = _install(clone / ".venv", ["-e", f".[{args.extra}]"], env, clone)
            wall, unit_seconds, units = _compile_log(clone)
            compiler = _compiler(clone)
            if cache == "cold":  # the reference downloads everything again too
                shutil.rmtree(home / "pip-cache", ignore_errors=True)
            reference = _install(scratch / "deps", _dependencies(args.extra), env, scratch)
        deps = Timing(f"the dependencies alone ({cache} cache)", [reference])
        mine = Timing(
            f"delta-pin, compiled by {Path(compiler).name}", [ours], note=f"compile {wall:.0f} s wall"
        )
        commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", args.commit],
                                capture_output=True, text=True).stdout.strip()  # fmt: skip
        title = f"pip install -e '.[{args.extra}]' of {commit}, fresh clone, venv and HOME, {cache} pip cache"
        print_table(title, [deps, mine], reference=deps)
        print(f"\ncompile: {wall:.1f} s wall, {unit_seconds:.1f} s of units ({compiler}); the longest:")
        for name, seconds in units[:6]:
            print(f"  {seconds:6.1f} s  {name}")
        target = f"pip install -e '.[{args.extra}]' from a fresh clone, {cache} pip cache"
        report_target(target, ours, LIMITS[cache], "s")
        report_target(f"its compile ({Path(compiler).name}, wall)", wall, None, "s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

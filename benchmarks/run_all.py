"""Run every benchmark and print its table: ``python benchmarks/run_all.py [--quick] [--docs DIR]
[--only SCRIPT ...]``.

``--docs docs/measured`` also writes each script's tables, as printed, and its targets to
``DIR/<script>.md`` (dated, with the machine and the command), then ``DIR/index.md``, every target
of every page read back from the pages (``--index``: that index alone): the documentation's
measured pages are generated here, never typed.

Speed is measured here, not in the test suite. Each table gives median, min and max over repeats
and ratios against a reference measured in the same run. The run ends with the targets of issue 7
that the benchmarks measure: every script prints its measured figures as
``TARGET {"target": ..., "value": ..., "limit": ..., "unit": ...}`` lines
(``common.report_target``), which are collected here instead of being echoed.
"""

from __future__ import annotations

import argparse
import datetime
import json
import subprocess
import sys
import time
from pathlib import Path

from common import TARGET_PREFIX, format_value, machine_info

from delta_pin.utils.atomic import write_text_atomically

HERE = Path(__file__).parent
BENCHMARKS = {
    "bench_model.py": ["--repeats", "5"],
    "bench_controllers.py": ["--repeats", "5"],
    "bench_simulate.py": ["--repeats", "3"],
    "bench_mujoco.py": ["--repeats", "3"],
    "bench_validate.py": ["--repeats", "5"],
    "bench_sweep.py": ["--repeats", "3", "--full"],
    "bench_meshcat_export.py": ["--repeats", "5"],
    "bench_cli.py": ["--repeats", "5"],
    "bench_engine.py": ["--repeats", "3"],
    "bench_drive_cpp.py": ["--repeats", "3"],
    "bench_continuous.py": ["--repeats", "3"],
    "bench_unactuated.py": ["--repeats", "3"],
    "bench_identification.py": ["--repeats", "3"],
    "bench_identification_mujoco.py": [],  # ~1 min: three noise draws
    "bench_planning.py": ["--repeats", "3"],
    "bench_install.py": ["--cache", "warm"],  # ~5 min: two fresh installs
}
QUICK = {
    "bench_model.py": ["--repeats", "3", "--calls", "500"],
    "bench_controllers.py": ["--repeats", "3", "--calls", "500"],
    "bench_simulate.py": ["--repeats", "1", "--t-end", "3"],
    "bench_mujoco.py": ["--repeats", "2", "--t-end", "3", "--calls", "500"],
    "bench_validate.py": ["--repeats", "2"],
    "bench_sweep.py": ["--repeats", "1", "--t-end", "3", "--runs", "4"],
    "bench_meshcat_export.py": ["--repeats", "2"],
    "bench_cli.py": ["--repeats", "3"],
    "bench_engine.py": ["--repeats", "1", "--t-end", "3"],
    "bench_drive_cpp.py": ["--repeats", "1"],
    "bench_continuous.py": ["--repeats", "1", "--t-end", "3"],
    "bench_unactuated.py": ["--repeats", "1", "--t-end", "0.2"],
    "bench_identification.py": ["--repeats", "1", "--quick"],
    "bench_identification_mujoco.py": ["--quick"],
    "bench_planning.py": ["--repeats", "1"],
}
# targets of issue 7 measured by a script that may not report them (missing, skipped or failed)
EXPECTED = {
    "bench_controllers.py": "one controller step of designs I and II <= 10 us",
    "bench_simulate.py": "15 s runs of design I on the Pinocchio plant <= 1 s / 1.3 s",
    "bench_validate.py": "`delta-pin validate --samples 10000` <= 2 s",
    "bench_sweep.py": "the 726-run sweep of 15 s runs <= 60 s",
}


def run(script: str, options: list[str], lines: list[str] | None = None) -> tuple[int, list[dict]]:
    """Run one benchmark, echo its output (and keep it in ``lines``), return its exit status and its
    TARGET lines."""
    targets = []
    with subprocess.Popen(
        [sys.executable, "-u", str(HERE / script), *options],
        cwd=HERE,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    ) as process:
        for line in process.stdout:
            if line.startswith(TARGET_PREFIX):
                try:
                    targets.append(json.loads(line[len(TARGET_PREFIX) :]))
                except json.JSONDecodeError:
                    print(f"(unreadable target line: {line.strip()})")
                continue
            print(line, end="", flush=True)
            if lines is not None:
                lines.append(line.rstrip("\n"))
    return process.returncode, targets


def target_rows(targets: list[dict]) -> list[str]:
    """The targets as Markdown table rows: target, measured, limit, met (``reference`` without a limit)."""
    rows = ["| target | measured | limit | met |", "|---|---|---|---|"]
    for row in targets:
        unit = row.get("unit", "s")
        value, limit = row["value"], row.get("limit")
        met = "reference" if limit is None else ("yes" if value <= limit else "no")
        shown = "" if limit is None else format_value(limit, unit)
        name = row["target"].replace("|", "\\|")  # a pipe would end the cell
        rows.append(f"| {name} | {format_value(value, unit)} | {shown} | {met} |")
    return rows


def write_page(
    folder: Path, script: str, options: list[str], lines: list[str], targets: list[dict], status: int
):
    """``folder/<script stem>.md``: the script's output as printed (its Markdown tables) and its
    targets, dated, with the machine and the command (written whole or not at all)."""
    command = " ".join(["python", "benchmarks/" + script, *options])
    body = [
        f"# {script}",
        "",
        f"Generated by `python benchmarks/run_all.py --docs {folder.as_posix()}` on "
        f"{datetime.date.today().isoformat()} ({machine_info()}): `{command}`"
        + ("" if status == 0 else f", which FAILED (exit {status})")
        + ". Do not edit: run it again.",
        "",
        *(line for line in lines if not line.startswith("machine: ")),
        "",
        "## Targets",
        "",
        *target_rows(targets),
        "",
        f"{TARGETS_COMMENT}{json.dumps(targets)} -->",
        "",
    ]
    _write(folder / (Path(script).stem + ".md"), body)


def _write(path: Path, lines: list[str]) -> None:
    """``path`` written whole or not at all (the package's atomic writer)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomically(path, "\n".join(lines))


TARGETS_COMMENT = "<!-- targets: "


def write_index(folder: Path) -> None:
    """``folder/index.md``: every target of every page in ``folder``, read back from the exact values
    each page recorded, with the page and its date (a summary generated from generated pages)."""
    rows = ["| target | measured | limit | met | page, date |", "|---|---|---|---|---|"]
    for page in sorted(folder.glob("bench_*.md")):
        lines = page.read_text().splitlines()
        date = next((line.split(" on ", 1)[1][:10] for line in lines if line.startswith("Generated by")), "")
        comment = next((line for line in lines if line.startswith(TARGETS_COMMENT)), None)
        targets = [] if comment is None else json.loads(comment[len(TARGETS_COMMENT) : -len(" -->")])
        for row in target_rows(targets)[2:]:
            rows.append(f"{row} [{page.stem}]({page.name}), {date} |")
    _write(
        folder / "index.md",
        [
            "# Measured: every target",
            "",
            f"Generated by `python benchmarks/run_all.py --docs {folder.as_posix()}` from the pages beside "
            "it (each run of a script rewrites its page, then this table). Do not edit: run it again.",
            "",
            *rows,
            "",
        ],
    )


def summary(rows: list[tuple[str, dict | None]]) -> None:
    print("\n## issue 7 targets (medians, this run)\n")
    print("| target | measured median | limit | met? |")
    print("|---|---|---|---|")
    for script, row in rows:
        if row is None:
            print(f"| {EXPECTED[script]} | not measured ({script}) | | no |")
            continue
        unit = row.get("unit", "s")
        value, limit = row["value"], row.get("limit")
        if limit is None:
            print(f"| {row['target']} | {format_value(value, unit)} | | reference |")
        else:
            met = "yes" if value <= limit else "NO"
            print(f"| {row['target']} | {format_value(value, unit)} | {format_value(limit, unit)} | {met} |")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats, shorter runs")
    parser.add_argument("--docs", type=Path, help="also write each script's tables to DIR/<script>.md")
    parser.add_argument("--only", nargs="+", metavar="SCRIPT", help="run these scripts only")
    parser.add_argument("--index", action="store_true", help="with --docs: only rewrite DIR/index.md")
    args = parser.parse_args()
    if args.index:
        if args.docs is None:
            parser.error("--index rewrites the index of --docs DIR: give --docs")
        write_index(args.docs)
        return 0
    chosen = QUICK if args.quick else BENCHMARKS
    unknown = sorted(set(args.only or ()) - set(chosen))
    if unknown:
        parser.error(f"--only {' '.join(unknown)}: not a benchmark; choose from {', '.join(chosen)}")
    print(f"machine: {machine_info()}")
    start = time.perf_counter()
    failures, rows = [], []
    for script, options in chosen.items():
        if args.only and script not in args.only:
            continue
        print(f"\n# {script} {' '.join(options)}".rstrip(), flush=True)
        lines: list[str] = []
        status, targets = run(script, options, lines)
        if args.docs is not None:
            write_page(args.docs, script, options, lines, targets, status)
        if status != 0:
            failures.append(script)
        rows.extend((script, target) for target in targets)
        if not targets and script in EXPECTED:
            rows.append((script, None))
    summary(rows)
    if args.docs is not None:
        write_index(args.docs)
    print(
        f"\nall benchmarks: {time.perf_counter() - start:.0f} s wall" + (" (--quick)" if args.quick else "")
    )
    if failures:
        print(f"FAILED: {', '.join(failures)}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

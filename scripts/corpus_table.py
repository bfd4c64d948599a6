"""How delta-pin does on every corpus model as shipped: a markdown status table.

For each model of ``tests/model/corpus_models.py``, in its own subprocess with a time limit:

1. ``dp.load_robot(path)`` with no keyword arguments (as shipped; and again with the manifest's
   ``kwargs`` where it has some);
2. ``robot.classification()`` and ``robot.summary()``;
3. ``validate_closed_chain(robot, samples=5, energy_duration=0.2)``;
4. a 0.2 s free fall: ``dp.simulate`` with zero torque on the actuated joints, from home at rest,
   in continuous time (error-controlled Radau IIA, or LSODA where the core cannot take the robot)
   and sampled at 1 kHz (RK4, one step a sample: the default of ``dp.simulate``).

Usage::

    python scripts/corpus_table.py [--timeout 300] [--only ID ...] [--out /tmp/corpus_table.md]

Each stage that fails shows its exception's type and the first line of its message; a stage
that raises something other than a ``DeltaPinError`` is marked ``(not a DeltaPinError)``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


GROUPS = {  # what each subprocess runs after loading the model (a crash ends only its group)
    "main": ("load", "kwargs", "classification", "validate"),
    "sampled": ("freefall_sampled",),
    "continuous": ("freefall",),
}
SIMULATE = {"freefall": {"mode": "continuous"}, "freefall_sampled": {"mode": "sampled"}}


def _error(exc: BaseException) -> dict:
    from delta_pin.errors import DeltaPinError

    message = str(exc).strip()
    lines = message.splitlines()
    where = ""
    if not isinstance(exc, DeltaPinError):  # name the raising line (the innermost in delta_pin)
        frames = traceback.extract_tb(exc.__traceback__)
        ours = [f for f in frames if "delta_pin" in f.filename] or frames
        if ours:
            frame = ours[-1]
            where = f" [raised at {Path(frame.filename).name}:{frame.lineno} in {frame.name}]"
    return {
        "ok": False,
        "error": f"{type(exc).__name__}: {lines[0] if lines else ''}{where}",
        "multiline": len(lines) > 1,
        "delta_pin": isinstance(exc, DeltaPinError),
    }


def _emit(stage: str, result: dict) -> None:
    print(json.dumps({"stage": stage, **result}), flush=True)


def _load(model, emit: bool):
    import warnings

    import delta_pin as dp

    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            robot = dp.load_robot(model.file)
        except Exception as exc:
            if emit:
                _emit("load", {**_error(exc), "seconds": time.perf_counter() - start})
            return None
    if emit:
        warned = sorted({str(w.message).strip().splitlines()[0] for w in caught if str(w.message).strip()})
        _emit("load", {"ok": True, "seconds": time.perf_counter() - start, "warnings": warned})
    return robot


def run_one(model_id: str, group: str) -> None:
    """Run one group of stages for one model, printing one JSON line per stage as it ends."""
    import warnings

    import numpy as np

    import delta_pin as dp
    from delta_pin.sim.closed_chain_validation import validate_closed_chain
    from tests.model.corpus_models import corpus_model

    model = corpus_model(model_id)
    stages = GROUPS[group]
    robot = _load(model, emit="load" in stages)
    if "kwargs" in stages and model.kwargs:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                dp.load_robot(model.file, **model.kwargs)
            _emit("kwargs", {"ok": True})
        except Exception as exc:
            _emit("kwargs", _error(exc))
    if robot is None:
        return
    if "classification" in stages:
        try:
            c = robot.classification()
            summary = robot.summary()
            _emit(
                "classification",
                {
                    "ok": True,
                    "mobility": c["mobility"],
                    "dof": robot.dof,
                    "idle": robot.idle_dof,
                    "passive": len(robot.passive_joint_indices),
                    "nv": c["joint_velocities"],
                    "closure": f"{c['independent_closure_equations']}/{c['closure_equations']}",
                    "summary": summary,
                },
            )
        except Exception as exc:
            _emit("classification", _error(exc))
    if "validate" in stages:
        start = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                report = validate_closed_chain(robot, samples=5, energy_duration=0.2)
            failed = [name for name in report.checks if not report.check_passed(name)]
            _emit(
                "validate",
                {
                    "ok": report.passed,
                    "failed": failed,
                    "states": report.states,
                    "seconds": time.perf_counter() - start,
                    "measured": {
                        name: f"{value:.1e} (tol {tol:.0e})"
                        for name, (value, tol, _) in report.checks.items()
                        if name in failed
                    },
                },
            )
        except Exception as exc:
            _emit("validate", {**_error(exc), "seconds": time.perf_counter() - start})
    dof = robot.dof

    def zero(t, alpha, alpha_dot):
        return np.zeros(dof)

    for stage in (s for s in stages if s in SIMULATE):
        start = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                run = dp.simulate(robot, zero, None, alpha0=robot.home, t_end=0.2, **SIMULATE[stage])
            q = np.asarray(run.q)
            _emit(
                stage,
                {
                    "ok": bool(np.all(np.isfinite(q))),
                    "moved": float(np.abs(q[-1] - q[0]).max()) if q.size else 0.0,
                    "integrator": run.metadata.get("integrator"),
                    "seconds": time.perf_counter() - start,
                },
            )
        except Exception as exc:
            _emit(stage, {**_error(exc), "seconds": time.perf_counter() - start})


def _child(model_id: str, group: str, timeout: float) -> dict:
    """Run one group for one model in a subprocess (with faulthandler on, so that a crash names
    its Python line); the stages it reported, a timeout or crash recorded on the first stage of
    the group it did not report."""
    env = dict(os.environ, PYTHONHASHSEED="0")
    try:
        done = subprocess.run(
            [sys.executable, "-X", "faulthandler", __file__, "--one", model_id, "--group", group],
            capture_output=True,
            text=True,
            timeout=timeout,
            cwd=ROOT,
            env=env,
        )
        stdout, stderr, code, timed_out = done.stdout, done.stderr, done.returncode, False
    except subprocess.TimeoutExpired as exc:
        stdout = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        stderr = exc.stderr.decode() if isinstance(exc.stderr, bytes) else (exc.stderr or "")
        code, timed_out = None, True
    results = {}
    for line in stdout.splitlines():
        if line.startswith("{"):
            entry = json.loads(line)
            results[entry.pop("stage")] = entry
    if timed_out or code:
        why = f"timed out after {timeout:g} s" if timed_out else f"crashed (exit {code})"
        if not timed_out:
            frames = [s.strip() for s in stderr.splitlines() if s.strip().startswith("File ")]
            ours = [f for f in frames if "delta_pin" in f]
            if ours or frames:
                why += f" in {(ours or frames)[0]}"
        for stage in GROUPS[group]:
            if stage not in results and stage != "kwargs":
                results[stage] = {"ok": False, "error": why, "delta_pin": False, "aborted": True}
                break
    return results


def run_model(model_id: str, timeout: float) -> dict:
    start = time.perf_counter()
    results = _child(model_id, "main", timeout)
    if results.get("load", {}).get("ok"):
        for group in ("sampled", "continuous"):
            results.update(_child(model_id, group, timeout))
    results["_seconds"] = time.perf_counter() - start
    return results


def _cell(entry: dict | None, ok_text: str) -> str:
    if entry is None:
        return "-"
    if entry.get("ok"):
        return ok_text
    text = entry.get("error", "failed")
    if len(text) > 160:
        text = text[:160] + " ..."
    if entry.get("aborted"):
        return f"**{text}**"
    if not entry.get("delta_pin", True):
        text += " (not a DeltaPinError)"
    if entry.get("multiline"):
        text += " [message has several lines]"
    return text.replace("|", "\\|")


def table(results: dict[str, dict]) -> str:
    from tests.model.corpus_models import corpus_model

    rows = [
        "| model | source | loads as shipped | classification (dof, idle, passive) | validate "
        "| free fall (0.2 s) |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for model_id, r in results.items():
        model = corpus_model(model_id)
        load = r.get("load")
        load_text = _cell(load, f"yes ({load['seconds']:.1f} s)" if load and load.get("ok") else "")
        if load and load.get("ok") and load.get("warnings"):
            load_text += f"; {len(load['warnings'])} warning(s)"
        if "kwargs" in r:
            load_text += f"; with kwargs {model.kwargs}: " + _cell(r["kwargs"], "yes")
        c = r.get("classification")
        c_text = _cell(
            c,
            f"{c['dof']}, {c['idle']}, {c['passive']} (mobility {c['mobility']}; nv {c['nv']}; "
            f"closure rank {c['closure']})"
            if c and c.get("ok")
            else "",
        )
        v = r.get("validate")
        if v and not v.get("ok") and "failed" in v:
            v_text = "fail: " + ", ".join(f"{n} {v['measured'][n]}" for n in v["failed"])
            if not v["failed"]:
                v_text = f"fail ({v['states']} states)"
        else:
            v_text = _cell(
                v, f"pass ({v['states']} states, {v['seconds']:.0f} s)" if v and v.get("ok") else ""
            )
        f_text = (
            "; ".join(
                f"{label}: "
                + _cell(f, f"ran ({f['seconds']:.1f} s, moved {f['moved']:.2g})" if f and f.get("ok") else "")
                for label, f in (("continuous", r.get("freefall")), ("sampled", r.get("freefall_sampled")))
                if f is not None
            )
            or "-"
        )
        source = model.source.split("@")[0].split("/")[0] + "@" + model.source.split("@")[1][:7]
        rows.append(f"| {model_id} | {source} | {load_text} | {c_text} | {v_text} | {f_text} |")
    rows += ["", "Each failure's whole first line:", "", "| model | stage | error |", "| --- | --- | --- |"]
    for model_id, r in results.items():
        for stage in ("load", "kwargs", "classification", "validate", "freefall_sampled", "freefall"):
            entry = r.get(stage)
            if entry and not entry.get("ok") and "error" in entry:
                rows.append(
                    f"| {model_id} | {stage} | {entry['error'].replace('|', '/')}"
                    + ("" if entry.get("delta_pin", True) else " (not a DeltaPinError)")
                    + (" [several lines]" if entry.get("multiline") else "")
                    + " |"
                )
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--one", help=argparse.SUPPRESS)
    parser.add_argument("--group", default="main", choices=sorted(GROUPS), help=argparse.SUPPRESS)
    parser.add_argument("--only", nargs="*", help="corpus ids to run (default: all)")
    parser.add_argument(
        "--timeout", type=float, default=300.0, help="seconds per model (default 300) and group"
    )
    parser.add_argument("--out", type=Path, help="also write the table here")
    parser.add_argument("--json", type=Path, help="also write the raw results here")
    args = parser.parse_args(argv)
    if args.one:
        run_one(args.one, args.group)
        return 0
    from tests.model.corpus_models import corpus_ids

    ids = args.only or corpus_ids()
    results = {}
    for model_id in ids:
        results[model_id] = run_model(model_id, args.timeout)
        print(f"{model_id}: {results[model_id]['_seconds']:.0f} s", file=sys.stderr, flush=True)
    text = table(results)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

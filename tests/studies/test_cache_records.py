"""Cache records are validated on read (issue 25): a record with "metrics": null blocked its
folder with "unexpected AttributeError" (the file not named), and swapped cached runs were
trusted. A record or run that does not hold up is now named in one warning line and recomputed."""

import json

import pytest

from delta_pin.cli import main
from delta_pin.sim.run import load_run
from delta_pin.studies.experiments import RunSpec
from delta_pin.studies.sweep import run_sweep, spec_key

SWEEP = ["sweep", "--t-end", "0.01", "--workers", "1", "--param", "delta_m=0,0.3"]


SPECS = [RunSpec(plant="analytic", mode="sampled", controller=c, t_end=0.01) for c in ("pd", "ctc")]


def test_a_cache_record_with_null_metrics_is_named_and_recomputed(tmp_path, capsys, caplog):
    """One record with "metrics": null blocked the folder ("unexpected AttributeError", the file
    not named; two axes: the surface reads the metrics), after results.csv was removed."""
    out = tmp_path / "out"
    argv = [*SWEEP, "--param", "delta_f=0,0.3"]
    assert main([*argv, "--out", str(out)]) == 0
    results = (out / "results.csv").read_text()
    record = sorted((out / "cache").glob("*.json"))[0]
    data = json.loads(record.read_text())
    data["metrics"] = None
    record.write_text(json.dumps(data))
    capsys.readouterr()
    assert main([*argv, "--out", str(out)]) == 0, capsys.readouterr().err
    warned = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert warned == [
        f"cache file {record} is not a valid sweep point (metrics is null without an error): recomputing it"
    ]

    # the recomputed point's metrics are the same numbers: the simulation is deterministic (only
    # the wall times differ), so every column but those compares equal as text
    def table(text):
        rows = [line.split(",") for line in text.splitlines()]
        keep = [i for i, name in enumerate(rows[0]) if "wall_time" not in name]
        return [[row[i] for i in keep] for row in rows]

    assert table((out / "results.csv").read_text()) == table(results)
    assert json.loads(record.read_text())["metrics"] is not None  # rewritten


@pytest.mark.parametrize(
    ("change", "problem"),
    [
        (
            lambda r: r.update(metrics={**r["metrics"], "iae": "abc"}),
            'metrics.iae is "abc", not a number or null',
        ),
        (lambda r: r["metrics"].pop("iae"), "metrics lack iae"),
        (lambda r: r.update(metrics=[1, 2]), "metrics is [1, 2] without an error"),
        (lambda r: r.update(wall_time="soon"), 'wall_time is "soon", not a number or null'),
        (lambda r: r.update(error=5), "error is 5, not a string or null"),
        (lambda r: r["spec"].update(controller="lqr"), "its spec does not hash to its key"),
        (lambda r: r.update(robot_args={"l_a": 0.3}), 'robot_args {"l_a": 0.3}, not this sweep\'s {}'),
    ],
    ids=["metric text", "metric missing", "metrics list", "wall time", "error type", "spec", "robot"],
)
def test_a_record_that_does_not_hold_up_is_recomputed(tmp_path, caplog, change, problem):
    cache = tmp_path / "cache"
    first = run_sweep(SPECS, cache)
    record = cache / f"{first[0].key}.json"
    data = json.loads(record.read_text())
    change(data)
    record.write_text(json.dumps(data))
    again = run_sweep(SPECS, cache)
    assert again.computed == 1 and again.skipped == 1
    # recomputed: the simulation is deterministic, so every index is the same number (not its wall time)
    assert {**again[0].metrics, "wall_time": None} == {**first[0].metrics, "wall_time": None}
    assert [r.getMessage() for r in caplog.records if r.levelname == "WARNING"] == [
        f"cache file {record} is not a valid sweep point ({problem}): recomputing it"
    ]


def test_swapped_cached_runs_are_not_trusted(tmp_path, caplog):
    """The cached runs' names were trusted: two swapped .npz files swapped the rows of `compare`
    (exit 0). The key is now checked against the spec in each run's metadata."""
    cache = tmp_path / "cache"
    first = run_sweep(SPECS, cache, save_runs=True)
    a, b = (cache / f"{point.key}.npz" for point in first)
    a.rename(tmp_path / "a.npz")
    b.rename(a)
    (tmp_path / "a.npz").rename(b)
    again = run_sweep(SPECS, cache, save_runs=True)
    assert again.computed == 2
    warned = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert warned == [
        f"cached run {a} is the run of another point (key {first[1].key}): recomputing it",
        f"cached run {b} is the run of another point (key {first[0].key}): recomputing it",
    ]
    for point in again:
        run = load_run(cache / f"{point.key}.npz")
        assert spec_key(RunSpec(**run.metadata["spec"])) == point.key


def test_many_bad_records_are_counted_after_the_first_few(tmp_path, caplog, monkeypatch):
    from delta_pin.studies import sweep as sweep_module

    monkeypatch.setattr(sweep_module, "NAMED_BAD_RECORDS", 1)
    cache = tmp_path / "cache"
    run_sweep(SPECS, cache)
    for record in cache.glob("*.json"):
        record.write_text(record.read_text().replace('"wall_time": ', '"wall_time": "x", "w": '))
    assert run_sweep(SPECS, cache).computed == 2
    warned = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert (
        len(warned) == 2
        and warned[1] == f"1 more cache files of {cache} do not hold up either: recomputing them"
    )


def test_a_cli_warning_is_one_line_on_stderr(tmp_path, capsys, monkeypatch):
    """From the command line (logging not set up: Python's last-resort handler writes the warning
    to stderr; pytest's capture handler is taken off the root logger to see that) the warning is
    one line on stderr, and no traceback."""
    import logging

    out = tmp_path / "out"
    assert main([*SWEEP, "--out", str(out)]) == 0
    record = sorted((out / "cache").glob("*.json"))[0]
    record.write_text(record.read_text().replace('"metrics": {', '"metrics": null, "old": {'))
    capsys.readouterr()
    monkeypatch.setattr(logging.root, "handlers", [])
    assert main([*SWEEP, "--out", str(out)]) == 0
    assert capsys.readouterr().err.strip().splitlines() == [
        f"cache file {record} is not a valid sweep point (metrics is null without an error): recomputing it"
    ]

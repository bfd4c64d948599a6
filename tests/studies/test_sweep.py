"""Sweeps: identical results on every executor, resume from the on-disk cache, failing points,
grids and axis parsing."""

import concurrent.futures
import hashlib
import importlib.util
import json
import pickle
import sys

import pytest

from delta_pin.errors import InvalidParameterError, SimulationError, XacroArgumentError
from delta_pin.sim.run import load_run
from delta_pin.studies.experiments import RunSpec
from delta_pin.studies.metrics import compute_metrics
from delta_pin.studies.sweep import (
    OptionalDependencyError,
    SweepPoint,
    evaluate_spec,
    grid_specs,
    parse_axes,
    parse_axis,
    run_sweep,
    spec_key,
)

BASE = RunSpec(
    controller="design1", path="I", plant="analytic", mode="sampled", sampling_aware=True, t_end=0.2
)
AXES = {"delta_m": [0.0, 0.5], "delta_f": [0.0, 0.3]}
DIVERGING = RunSpec(
    controller="pd", path="I", plant="analytic", mode="sampled", t_end=0.2, gains={"K_d": 1e3}
)


class RecordingExecutor(concurrent.futures.Executor):
    """Runs each call at once in this process and remembers the specs it was asked for (a task
    carries a list of specs: one, or a compiled batch)."""

    def __init__(self):
        self.spec_dicts = []

    def submit(self, fn, /, *args, **kwargs):
        self.spec_dicts.extend(args[0])
        future = concurrent.futures.Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:
            future.set_exception(exc)
        return future


def _metrics(points):
    """The metrics of every point without the simulation's wall time (the only non-deterministic one)."""
    return [{k: v for k, v in point.metrics.items() if k != "wall_time"} for point in points]


@pytest.fixture(scope="module")
def grid():
    return grid_specs(BASE, AXES)


@pytest.fixture(scope="module")
def serial(grid, tmp_path_factory):
    return run_sweep(grid, tmp_path_factory.mktemp("serial"), executor="serial")


def test_serial_sweep_returns_points_in_order_and_caches_them(grid, serial):
    assert [point.spec for point in serial] == grid
    assert all(isinstance(point, SweepPoint) and point.ok and not point.cached for point in serial)
    assert (serial.skipped, serial.computed, serial.failed) == (0, 4, 0)
    for point in serial:
        record = json.loads((serial.cache_dir / f"{point.key}.json").read_text())
        assert record["key"] == point.key == spec_key(point.spec)
        assert record["metrics"] == point.metrics
        assert RunSpec(**record["spec"]) == point.spec
        assert record["wall_time"] > 0
    # the uncertainty changes the run
    assert len({point.metrics["iae"] for point in serial}) == 4
    assert not list(serial.cache_dir.glob(".*"))  # no temporary file left behind


def test_process_pool_gives_identical_results(grid, serial, tmp_path):
    points = run_sweep(grid, tmp_path, executor="process", workers=2)
    assert _metrics(points) == _metrics(serial)
    assert [p.key for p in points] == [p.key for p in serial]


def test_workers_alone_pick_the_process_pool(grid, serial, tmp_path, monkeypatch):
    created = []
    original = concurrent.futures.ProcessPoolExecutor

    def recording_pool(*args, **kwargs):
        created.append(kwargs)
        return original(*args, **kwargs)

    monkeypatch.setattr(concurrent.futures, "ProcessPoolExecutor", recording_pool)
    points = run_sweep(grid[:2], tmp_path, workers=2)
    assert [kwargs["max_workers"] for kwargs in created] == [2]
    assert _metrics(points) == _metrics(serial[:2])


def test_missing_dask_is_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # makes `import distributed` fail
    with pytest.raises(OptionalDependencyError, match=r"pip install 'delta-pin\[dask\]'"):
        run_sweep([BASE], tmp_path, executor="dask")


def test_a_killed_sweep_resumes_without_recomputing(grid, serial, tmp_path):
    run_sweep(grid[:2], tmp_path)  # the sweep "killed" after two points
    recorder = RecordingExecutor()
    points = run_sweep(grid, tmp_path, executor=recorder)
    assert [RunSpec(**spec) for spec in recorder.spec_dicts] == grid[2:]
    assert (points.skipped, points.computed) == (2, 2)
    assert [p.cached for p in points] == [True, True, False, False]
    assert _metrics(points) == _metrics(serial)

    # one cache file lost: only that point is recomputed; the others' files are not rewritten
    lost = points[1].key
    (tmp_path / f"{lost}.json").unlink()
    mtimes = {p.key: (tmp_path / f"{p.key}.json").stat().st_mtime_ns for p in points if p.key != lost}
    recorder = RecordingExecutor()
    again = run_sweep(grid, tmp_path, executor=recorder)
    assert [spec_key(RunSpec(**spec)) for spec in recorder.spec_dicts] == [lost]
    assert (again.skipped, again.computed) == (3, 1)
    assert {k: (tmp_path / f"{k}.json").stat().st_mtime_ns for k in mtimes} == mtimes
    assert _metrics(again) == _metrics(serial)


def test_duplicates_run_once_and_equal_keys_ignore_int_versus_float(tmp_path):
    recorder = RecordingExecutor()
    specs = [BASE, BASE.with_(delta_m=0), BASE]  # 0 and 0.3 differ; BASE twice
    points = run_sweep(specs, tmp_path, executor=recorder)
    assert len(recorder.spec_dicts) == 2
    assert points[0].metrics == points[2].metrics
    assert spec_key(BASE.with_(delta_m=0)) == spec_key(BASE.with_(delta_m=0.0))


def test_cached_metrics_equal_a_recomputation_from_the_saved_runs(grid, serial, tmp_path):
    points = run_sweep(grid, tmp_path, save_runs=True)
    for point in points:
        run = load_run(tmp_path / f"{point.key}.npz")
        cached = json.loads((tmp_path / f"{point.key}.json").read_text())["metrics"]
        assert compute_metrics(run).as_dict() == cached == point.metrics
        assert run.metadata["spec"] == point.spec.as_dict()
    assert _metrics(points) == _metrics(serial)


def test_save_runs_recomputes_points_cached_without_their_run(grid, tmp_path):
    run_sweep(grid[:1], tmp_path)
    points = run_sweep(grid[:1], tmp_path, save_runs=True)
    assert points.computed == 1
    assert (tmp_path / f"{points[0].key}.npz").is_file()
    assert run_sweep(grid[:1], tmp_path, save_runs=True).skipped == 1


def test_save_runs_can_name_the_runs_to_keep(grid, serial, tmp_path):
    """A predicate keeps the runs of the specs it accepts (reproduce keeps its main runs only);
    the other points keep their metrics, equal to the serial sweep's."""
    keep = grid[0]
    points = run_sweep(grid, tmp_path, save_runs=lambda spec: spec == keep)
    saved = {point.key for point in points if (tmp_path / f"{point.key}.npz").is_file()}
    assert saved == {points[0].key}
    assert compute_metrics(load_run(tmp_path / f"{points[0].key}.npz")).as_dict() == points[0].metrics
    assert _metrics(points) == _metrics(serial)
    again = run_sweep(grid, tmp_path, save_runs=lambda spec: spec == keep)
    assert again.skipped == len(grid) and again.computed == 0  # the runs not kept are not needed


def test_a_failing_point_is_recorded_cached_and_does_not_stop_the_others(tmp_path):
    specs = [BASE, DIVERGING, BASE.with_(delta_m=0.0)]
    points = run_sweep(specs, tmp_path, executor="process", workers=2)
    assert [p.ok for p in points] == [True, False, True]
    failed = points[1]
    assert failed.metrics is None
    assert failed.error_type == SimulationError.__name__
    assert "diverged" in failed.error
    assert points.failed == 1
    record = json.loads((tmp_path / f"{failed.key}.json").read_text())
    assert record["error"] == failed.error

    recorder = RecordingExecutor()
    resumed = run_sweep(specs, tmp_path, executor=recorder)  # a failure is final ...
    assert recorder.spec_dicts == []
    assert resumed[1].error == failed.error and resumed[1].cached
    recorder = RecordingExecutor()
    retried = run_sweep(specs, tmp_path, executor=recorder, retry_failed=True)  # ... unless asked
    assert [RunSpec(**spec) for spec in recorder.spec_dicts] == [DIVERGING]
    assert retried[1].error == failed.error


def test_an_unexpected_error_is_recorded_not_cached_and_warned(tmp_path, monkeypatch):
    import delta_pin.studies.sweep

    broken = BASE.with_(t_end=0.25)
    real = delta_pin.studies.sweep.run_spec

    def run_spec_with_a_bug(spec, robot=None):
        if spec == broken:
            raise ZeroDivisionError("a bug in no_such_code")
        return real(spec, robot)

    monkeypatch.setattr(delta_pin.studies.sweep, "run_spec", run_spec_with_a_bug)
    specs = [broken, BASE]
    with pytest.warns(RuntimeWarning, match="no_such_code"):
        points = run_sweep(specs, tmp_path, executor="serial")
    assert points[0].error_type == "ZeroDivisionError" and points[1].ok
    assert not (tmp_path / f"{points[0].key}.json").exists()  # a resume retries it
    assert (tmp_path / f"{points[1].key}.json").exists()


def test_bad_robot_arguments_fail_once_before_any_point(tmp_path):
    with pytest.raises(XacroArgumentError):
        run_sweep([BASE], tmp_path, robot_args={"no_such_argument": 1.0})
    assert not list(tmp_path.iterdir())


def test_robot_arguments_are_part_of_the_key(tmp_path):
    assert spec_key(BASE, {"m_o": 0.5}) != spec_key(BASE)
    assert spec_key(BASE, {}) == spec_key(BASE)
    default, heavy = (run_sweep([BASE], tmp_path, robot_args=args)[0] for args in (None, {"m_o": 0.5}))
    assert default.key != heavy.key and default.metrics["iae"] != heavy.metrics["iae"]


def test_spec_key_is_the_sha256_of_the_sorted_canonical_json():
    spec = RunSpec(delta_m=0.1, gains={"xi": 0.01})
    # fields added after caches were written are left out at their defaults (old keys stay valid)
    later = ("integrator", "encoder_bits", "velocity", "delay", "torque_limit")
    fields = {k: v for k, v in spec.as_dict().items() if k not in later}
    text = json.dumps(fields, sort_keys=True, separators=(",", ":"))
    assert spec_key(spec) == hashlib.sha256(text.encode()).hexdigest()
    assert spec_key(spec) != spec_key(spec.with_(integrator="bdf2"))
    assert spec_key(spec) != spec_key(spec.with_(mode="sampled", encoder_bits=17, delay=1))
    assert spec_key(spec) == spec_key(RunSpec(gains={"xi": 0.01}, delta_m=0.1))
    assert spec_key(spec) != spec_key(spec.with_(gains={"xi": 0.02}))
    assert spec_key(RunSpec(gains={"T_v": (9, 9, 9)})) == spec_key(RunSpec(gains={"T_v": [9.0, 9.0, 9.0]}))
    with pytest.raises(InvalidParameterError, match=r"spec\.gains"):
        spec_key(RunSpec(gains={"xi": object()}))


def test_evaluate_spec_is_picklable_and_returns_json(tmp_path):
    assert pickle.loads(pickle.dumps(evaluate_spec)) is evaluate_spec
    record = evaluate_spec(BASE.as_dict(), None)
    json.dumps(record)
    assert record["error"] is None and record["metrics"]["iae"] > 0
    assert set(record) == {"spec", "metrics", "wall_time", "error", "error_type"}
    assert evaluate_spec(DIVERGING.as_dict(), {})["error_type"] == "SimulationError"


def test_executor_options_are_checked(tmp_path):
    for kwargs, match in [
        ({"executor": "threads"}, "executor='threads'"),
        ({"executor": "serial", "workers": 2}, "workers=2"),
        ({"executor": "process", "scheduler": "local"}, "scheduler='local'"),
        ({"workers": 0}, "workers=0"),
        ({"executor": RecordingExecutor(), "workers": 2}, "executor instance"),
    ]:
        with pytest.raises(InvalidParameterError, match=match):
            run_sweep([BASE], tmp_path, **kwargs)
    with pytest.raises(InvalidParameterError, match=r"specs\[1\]"):
        run_sweep([BASE, BASE.as_dict()], tmp_path)


def test_progress_lines_only_when_asked_outside_a_terminal(grid, tmp_path, capsys):
    run_sweep(grid[:1], tmp_path / "quiet")
    assert capsys.readouterr().err == ""
    run_sweep(grid[:2], tmp_path / "loud", progress=True)
    err = capsys.readouterr().err
    assert "sweep: 2/2 pt (100%)" in err and "0 from the cache" in err
    run_sweep(grid[:2], tmp_path / "loud", progress=True)
    assert "2 from the cache (skipped)" in capsys.readouterr().err


class FakeTerminal:
    def __init__(self):
        self.text = ""

    def write(self, text):
        self.text += text

    def flush(self):
        pass

    def isatty(self):
        return True


def test_progress_on_a_terminal_is_tqdm_or_a_counter_without_it(grid, tmp_path, monkeypatch):
    has_tqdm = importlib.util.find_spec("tqdm") is not None
    terminal = FakeTerminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    monkeypatch.setitem(sys.modules, "tqdm", None)  # tqdm not installed: the built-in counter
    run_sweep(grid[:2], tmp_path / "counter")
    assert "\rsweep: 2/2 pt" in terminal.text
    if not has_tqdm:
        pytest.skip("tqdm is optional")
    monkeypatch.delitem(sys.modules, "tqdm")  # the real one
    terminal.text = ""
    run_sweep(grid[:2], tmp_path / "tqdm")
    assert "sweep: 100%" in terminal.text and "2/2" in terminal.text


def test_grid_specs_is_the_cartesian_product_with_gains():
    specs = grid_specs(
        BASE.with_(gains={"beta": 0.2}), {"delta_m": [0, 0.5], "xi": [1e-3, 1e-2], "seed": [1.0]}
    )
    assert len(specs) == 4
    assert [(s.delta_m, s.gains["xi"]) for s in specs] == [(0.0, 1e-3), (0.0, 1e-2), (0.5, 1e-3), (0.5, 1e-2)]
    assert all(s.gains["beta"] == 0.2 and s.seed == 1 and isinstance(s.seed, int) for s in specs)
    assert isinstance(specs[0].delta_m, float)
    assert grid_specs(BASE, {"controller": ["design1", "design2"]})[1].controller == "design2"
    assert grid_specs(BASE, {"friction": [0]})[0].friction is False


@pytest.mark.parametrize(
    "axes, match",
    [
        ({}, "at least one axis"),
        ({"delta_m": []}, "axis delta_m has no values"),
        ({"delta_m": 0.5}, "axis delta_m: expected a list"),
        ({"delta_m": ["abc"]}, "'abc' is not a valid delta_m"),
        ({"seed": [1.5]}, "1.5 is not a valid seed"),
        ({"controller": ["nope"]}, "controller='nope'"),
        ({"gains": [{"xi": 1.0}]}, "axis 'gains'"),
        ({"not an identifier": [1]}, "axis name"),
    ],
)
def test_grid_specs_errors(axes, match):
    with pytest.raises(InvalidParameterError, match=match):
        grid_specs(BASE, axes)


def test_parse_axis():
    assert parse_axis("delta_m=0:0.9:4") == ("delta_m", [0.0, 0.3, 0.6, 0.9])
    assert parse_axis(" delta_f = 0, 0.3,0.6 ") == ("delta_f", [0, 0.3, 0.6])
    assert parse_axis("controller=design1,design2") == ("controller", ["design1", "design2"])
    assert parse_axis("seed=none,1,2") == ("seed", [None, 1, 2])
    assert parse_axis("friction=true,false") == ("friction", [True, False])
    assert parse_axis("xi=1e-3:1e-3:1") == ("xi", [1e-3])
    axes = parse_axes(["delta_m=0:0.5:2", "xi=0.001,0.01"])
    assert len(grid_specs(BASE, axes)) == 4


@pytest.mark.parametrize(
    "text, match",
    [
        ("delta_m", "'delta_m': expected NAME=START:STOP:COUNT"),
        ("delta_m=", "'delta_m=': expected"),
        ("=1,2", "'=1,2': expected"),
        ("delta_m=0:1", "'delta_m=0:1': a range is START:STOP:COUNT"),
        ("delta_m=a:1:3", "'delta_m=a:1:3': START and STOP must be numbers"),
        ("delta_m=0:1:x", "COUNT must be an integer, got 'x'"),
        ("delta_m=0:1:0", "COUNT must be >= 1"),
        ("delta_m=0:1:1", "COUNT=1 needs START == STOP"),
        ("delta_m=0,,1", "empty value"),
        ("delta-m=0,1", "'delta-m' is not a field or gain name"),
    ],
)
def test_parse_axis_errors(text, match):
    with pytest.raises(InvalidParameterError, match=match):
        parse_axis(text)


def test_parse_axes_rejects_a_repeated_name():
    with pytest.raises(InvalidParameterError, match="axis delta_m given twice"):
        parse_axes(["delta_m=0,1", "delta_m=0.5"])


# dask last: its clusters leave threads in this process, and the process pools above fork it


def test_local_dask_cluster_gives_identical_results(grid, serial, tmp_path):
    pytest.importorskip("dask.distributed")
    points = run_sweep(grid, tmp_path, executor="dask", scheduler="local", workers=2)
    assert _metrics(points) == _metrics(serial)
    assert all(not point.cached for point in points)


def test_a_dask_scheduler_address_or_client_instance(grid, serial, tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    with (
        distributed.LocalCluster(
            n_workers=1, processes=False, threads_per_worker=1, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        by_address = run_sweep(grid[:2], tmp_path / "address", scheduler=cluster.scheduler_address)
        by_client = run_sweep(grid[2:], tmp_path / "client", executor=client)
        assert client.status == "running"  # a client given by the caller is left open
    assert _metrics(by_address) + _metrics(by_client) == _metrics(serial)


def test_sweep_batches_bdf2_points_and_matches_point_by_point(robot, tmp_path):
    """Points of one batch group go to one task (a compiled batch); a point that cannot be batched
    runs alone; every point's metrics are those of the point evaluated on its own."""
    from delta_pin.studies.experiments import RunSpec
    from delta_pin.studies.sweep import _chunks, evaluate_spec, spec_key

    base = RunSpec(controller="design1", plant="analytic", integrator="bdf2", t_end=0.3)
    specs = [base.with_(delta_m=m, delta_f=f) for m in (0.0, 0.6) for f in (0.0, 0.9)]
    specs.append(base.with_(controller="lqr", integrator="auto"))  # not batchable: runs alone
    unique = {spec_key(s): s for s in specs}
    tasks = _chunks(list(unique), unique, workers=1)
    assert sorted(len(t) for t in tasks) == [1, 2, 2]
    result = run_sweep(specs, tmp_path, executor="serial", progress=False)
    assert result.failed == 0
    for point, spec in zip(result, specs):
        alone = evaluate_spec(spec.as_dict())
        assert point.metrics["iae"] == pytest.approx(alone["metrics"]["iae"], rel=1e-12)


@pytest.mark.parametrize(
    ("param", "extra", "match"),
    [
        ("banana=0:1:3", [], "banana"),
        ("delta_m=2,5", [], "delta_m must be < 1"),
        ("delta_m=0,0.3", ["--metric", "bogus"], "metric='bogus' must be one of iae"),
    ],
)
def test_a_bad_sweep_is_refused_before_any_run(tmp_path, capsys, param, extra, match):
    """These used to run every point, print 'wrote results.csv' and exit 0 (issue 15)."""
    from delta_pin.cli import main

    out = tmp_path / "sweep"
    assert (
        main(["sweep", "--param", param, *extra, "--t-end", "0.1", "--workers", "1", "--out", str(out)]) == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and match in err[0]
    assert not out.exists()


def test_a_sweep_whose_runs_fail_says_so_and_exits_1(tmp_path, capsys):
    """The paper's gains sampled at 1 kHz diverge at 0.11 s: both points fail."""
    from delta_pin.cli import main

    command = ["sweep", "--mode", "sampled", "--t-end", "0.2", "--param", "xi=0.001,0.002", "--workers", "1"]
    assert main([*command, "--out", str(tmp_path / "a")]) == 1
    err = capsys.readouterr().err
    assert "2 of 2 runs failed; the first:" in err and "diverged" in err
    assert main([*command, "--allow-failures", "--out", str(tmp_path / "b")]) == 0


def test_single_runs_start_longest_first_and_batches_follow():
    """High-rate runs (continuous at 10 kHz on the Pinocchio plant, sampled at 10 kHz) are
    dispatched before short ones, so that two workers end together (reproduce --full left one
    worker alone on a 10 kHz run)."""
    from delta_pin.studies.sweep import _chunks, estimated_cost

    specs = {
        "sampled_1k": RunSpec(controller="tdc", mode="sampled", dt=1e-3),
        "continuous_10k": RunSpec(controller="pd", dt=1e-4),
        "sampled_10k": RunSpec(controller="tdc", mode="sampled", dt=1e-4),
        "radau": RunSpec(controller="design1", plant="analytic"),
        "bdf2_a": RunSpec(controller="design1", integrator="bdf2", plant="analytic", delta_m=0.1),
        "bdf2_b": RunSpec(controller="design1", integrator="bdf2", plant="analytic", delta_m=0.2),
    }
    assert (
        estimated_cost(specs["continuous_10k"])
        > estimated_cost(specs["sampled_10k"])
        > estimated_cost(specs["sampled_1k"])
        > estimated_cost(specs["radau"])
    )
    # on the Pinocchio plant a compiled continuous run (the LQR's too) costs more than a sampled
    # 1 kHz one, far less than a 10 kHz one
    lqr, design = RunSpec(controller="lqr"), RunSpec(controller="design1")
    assert estimated_cost(lqr) == estimated_cost(design) > estimated_cost(specs["sampled_1k"])
    assert estimated_cost(specs["sampled_10k"]) > estimated_cost(lqr)
    tasks = _chunks(list(specs), specs, workers=2)
    assert tasks[:4] == [["continuous_10k"], ["sampled_10k"], ["sampled_1k"], ["radau"]]
    assert sorted(key for task in tasks[4:] for key in task) == ["bdf2_a", "bdf2_b"]  # one batch group

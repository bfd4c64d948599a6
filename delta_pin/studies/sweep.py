"""Many runs at once: a grid of :class:`~delta_pin.studies.experiments.RunSpec` through an executor, with an
on-disk cache so that a killed sweep resumes where it stopped.

Every finished point is written at once, atomically (a temporary file, then a rename), to
``cache_dir/<key>.json`` -- the spec, its metrics and the wall time -- and, with ``save_runs=True``,
its :class:`~delta_pin.sim.runner.Run` to ``cache_dir/<key>.npz``. ``<key>`` is :func:`spec_key`, the
sha256 of the spec's canonical JSON. A point whose ``.json`` exists is read back, not recomputed,
once it holds up: its spec and robot arguments hash to its key, its metrics, wall time and error
are of their types, and its ``.npz`` (where the run is needed) loads and holds a spec of this key
(a file swapped with another point's is not trusted). One that does not is named in a warning line
and recomputed.

Executors: ``"serial"`` (a loop in this process), ``"process"`` (a
:class:`concurrent.futures.ProcessPoolExecutor`), ``"dask"`` (``dask.distributed``: a scheduler
address, or ``"local"`` for a :class:`~distributed.LocalCluster`; ``pip install 'delta-pin[dask]'``),
or any :class:`concurrent.futures.Executor` (or ``distributed.Client``) instance. Simulations are
deterministic, so the metrics do not depend on the executor.

A point that fails on purpose (a :class:`~delta_pin.errors.DeltaPinError`, e.g. a diverging run)
is recorded with its error and cached, and the sweep goes on. Any other exception (a bug, an
unknown gain name) is recorded but not cached, so that a resume retries it, and is reported by a
:class:`RuntimeWarning` at the end.

Examples:
    >>> base = RunSpec(controller="design1", path="I", t_end=5.0)
    >>> specs = grid_specs(base, dict([parse_axis("delta_m=0:0.9:4"), parse_axis("xi=0.001,0.01")]))
    >>> points = run_sweep(specs, "sweep-cache", workers=4)       # a process pool of 4
    >>> [p.metrics["iae"] for p in points]
"""

from __future__ import annotations

import concurrent.futures
import functools
import hashlib
import itertools
import json
import logging
import math
import os
import sys
import time
import traceback
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from delta_pin.control.registry import declaration
from delta_pin.errors import (
    DeltaPinError,
    InvalidParameterError,
    OptionalDependencyError,
    SchedulerUnreachableError,
)
from delta_pin.sim.run import load_run
from delta_pin.studies.experiments import RunSpec, batch_group, run_batch, run_spec
from delta_pin.studies.metrics import METRIC_NAMES, compute_metrics
from delta_pin.utils.atomic import write_text_atomically
from delta_pin.utils.interrupts import reraise_interrupt
from delta_pin.utils.progress import Progress

__all__ = [
    "EXECUTORS",
    "OptionalDependencyError",
    "SweepPoint",
    "SweepResult",
    "estimated_cost",
    "evaluate_batch",
    "evaluate_spec",
    "grid_specs",
    "parse_axes",
    "parse_axis",
    "run_sweep",
    "spec_key",
]

EXECUTORS = ("serial", "process", "dask")
BATCH_SIZE = 32  # points per compiled batch (one executor task)
SCHEDULER_TIMEOUT = 5.0  # [s] to connect to a Dask scheduler before giving up
RECORD_FORMAT = "delta-pin-sweep-point"
RECORD_VERSION = 1
NAMED_BAD_RECORDS = 5  # cache files that do not hold up named one by one; the rest are counted
_log = logging.getLogger(__name__)
_FIELD_TYPES = {f.name: str(f.type) for f in fields(RunSpec)}


# --------------------------------------------------------------------------------------------------
# keys and records


def _canonical(value, *, as_float: bool = False, where: str = "value"):
    """A JSON-ready copy of ``value``: tuples and arrays as lists, numpy scalars as Python ones,
    and (``as_float``) integers as floats, so that ``delta_m=0`` and ``delta_m=0.0`` give one key."""
    if value is None or isinstance(value, str | bool | np.bool_):
        return value if not isinstance(value, np.bool_) else bool(value)
    if isinstance(value, int | np.integer):
        return float(value) if as_float else int(value)
    if isinstance(value, float | np.floating):
        return float(value)
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, list | tuple):
        return [_canonical(v, as_float=as_float, where=where) for v in value]
    if isinstance(value, Mapping):
        return {str(k): _canonical(v, as_float=as_float, where=f"{where}[{k!r}]") for k, v in value.items()}
    raise InvalidParameterError(f"{where}={value!r} ({type(value).__name__}) is not JSON-serialisable")


_MISSING = object()
# fields added to RunSpec after caches were written, with the default that keeps their keys
_DEFAULTS_BEFORE_THE_FIELD = {
    "integrator": "auto",
    "encoder_bits": None,
    "velocity": "difference",
    "delay": 0,
    "torque_limit": None,
}


def _canonical_spec(spec: RunSpec) -> dict:
    out = {}
    for name, value in spec.as_dict().items():
        if _DEFAULTS_BEFORE_THE_FIELD.get(name, _MISSING) == value:
            continue  # at its default: keys of caches written before the field existed stay valid
        floaty = name == "gains" or "float" in _FIELD_TYPES.get(name, "")
        out[name] = _canonical(value, as_float=floaty, where=f"spec.{name}")
    return out


def _canonical_robot_args(robot_args: Mapping | None) -> dict:
    return _canonical(dict(robot_args or {}), as_float=True, where="robot_args")


def _dumps(payload) -> str:
    return json.dumps(payload, sort_keys=True, separators=(",", ":"))


def spec_key(spec: RunSpec, robot_args: Mapping | None = None) -> str:
    """The cache name of ``spec``: the sha256 (hex) of the canonical JSON of ``spec.as_dict()``
    (sorted keys; integers in float fields and gains as floats; tuples as lists).

    With non-empty ``robot_args`` (the :func:`~delta_pin.load_delta` arguments of the sweep) the hash
    covers ``{"spec": ..., "robot_args": ...}``, so that two robots never share a cache entry.
    """
    if not isinstance(spec, RunSpec):
        raise InvalidParameterError(f"spec_key expects a RunSpec, got {type(spec).__name__}: {spec!r}")
    payload = _canonical_spec(spec)
    args = _canonical_robot_args(robot_args)
    if args:
        payload = {"spec": payload, "robot_args": args}
    return hashlib.sha256(_dumps(payload).encode()).hexdigest()


@dataclass(frozen=True)
class SweepPoint:
    """One point of a sweep.

    Attributes:
        spec: the run.
        key: :func:`spec_key` (the cache file name without suffix).
        metrics: :meth:`~delta_pin.studies.metrics.RunMetrics.as_dict` of the run, ``None`` if it failed.
        wall_time: seconds the worker took (simulation and metrics) [s].
        error: the error message of a failed point, ``None`` otherwise.
        error_type: the exception's class name of a failed point.
        cached: read from the cache rather than computed by this call.
    """

    spec: RunSpec
    key: str
    metrics: dict | None
    wall_time: float | None
    error: str | None = None
    error_type: str | None = None
    cached: bool = False

    @property
    def ok(self) -> bool:
        return self.error is None

    def as_dict(self) -> dict:
        """The JSON record (the content of the cache file, without its format fields)."""
        return {
            "key": self.key,
            "spec": _canonical_spec(self.spec),
            "metrics": self.metrics,
            "wall_time": self.wall_time,
            "error": self.error,
            "error_type": self.error_type,
            "cached": self.cached,
        }

    def row(self) -> dict:
        """A flat row for a table (CSV, pandas): the spec's fields, its gains as ``gains.NAME``,
        the metrics (the simulation's own wall time as ``sim_wall_time``), ``wall_time``, ``error``."""
        spec = _canonical_spec(self.spec)
        gains = spec.pop("gains")
        row = {**spec, **{f"gains.{name}": value for name, value in sorted(gains.items())}}
        for name, value in (self.metrics or {}).items():
            row["sim_wall_time" if name == "wall_time" else name] = value
        row["wall_time"] = self.wall_time
        row["error"] = self.error
        return row


class SweepResult(list):
    """The points of a sweep, in the order of its specs (a ``list`` of :class:`SweepPoint`).

    Attributes:
        skipped: points read from the cache (not recomputed).
        computed: points simulated by this call (distinct keys).
        failed: points with an error (cached or new).
        wall_time: seconds the whole call took [s].
        cache_dir: the cache folder.
    """

    def __init__(self, points=(), *, skipped=0, computed=0, wall_time=0.0, cache_dir=None):
        super().__init__(points)
        self.skipped = skipped
        self.computed = computed
        self.wall_time = wall_time
        self.cache_dir = cache_dir

    @property
    def failed(self) -> int:
        return sum(not point.ok for point in self)

    def rows(self) -> list[dict]:
        return [point.row() for point in self]

    def summary(self) -> str:
        return (
            f"sweep: {len(self)} points, {self.skipped} from the cache (skipped), {self.computed} computed,"
            f" {self.failed} failed, {self.wall_time:.1f} s"
        )


# --------------------------------------------------------------------------------------------------
# the worker


def _freeze(value):
    if isinstance(value, Mapping):
        return tuple(sorted((str(k), _freeze(v)) for k, v in value.items()))
    if isinstance(value, list | tuple):
        return tuple(_freeze(v) for v in value)
    return value


@functools.lru_cache(maxsize=8)
def _cached_robot(frozen_args: tuple):
    """The robot of ``load_delta(**robot_args)``, built once per process."""
    from delta_pin.model.delta_robot import load_delta

    return load_delta(**dict(frozen_args))


def evaluate_spec(spec_dict: dict, robot_args: Mapping | None = None, return_run: bool = False) -> dict:
    """Simulate one point and compute its metrics (the function the executors run; picklable).

    Args:
        spec_dict: :meth:`RunSpec.as_dict` of the run.
        robot_args: keyword arguments of :func:`~delta_pin.load_delta` (``None``: Table 1); the
            robot is built once per process and reused.
        return_run: add the :class:`~delta_pin.sim.runner.Run` under ``"run"`` (to be saved by the caller).

    Returns:
        ``{"spec", "metrics", "wall_time", "error", "error_type"}`` (JSON-serialisable, apart from
        ``"run"``). A :class:`~delta_pin.errors.DeltaPinError` is returned as ``error`` and
        ``error_type``; any other exception also sets ``unexpected`` and ``traceback``.
    """
    start = time.perf_counter()
    record = {"spec": spec_dict, "metrics": None, "wall_time": None, "error": None, "error_type": None}
    try:
        spec = RunSpec(**spec_dict)
        robot = _cached_robot(_freeze(_canonical_robot_args(robot_args)))
        run = run_spec(spec, robot)
        record["metrics"] = _canonical(compute_metrics(run).as_dict(), where="metrics")
        if return_run:
            record["run"] = run
    except DeltaPinError as exc:
        record.update(error=str(exc), error_type=type(exc).__name__)
    except Exception as exc:
        reraise_interrupt(exc)  # Ctrl-C inside a compiled call: not a failed point
        record.update(
            error=f"{type(exc).__name__}: {exc}",
            error_type=type(exc).__name__,
            unexpected=True,
            traceback=traceback.format_exc(),
        )
    record["wall_time"] = time.perf_counter() - start
    return record


def evaluate_batch(
    spec_dicts: list[dict], robot_args: Mapping | None = None, return_run: bool = False
) -> list[dict]:
    """:func:`evaluate_spec` for several points that share a
    :func:`~delta_pin.studies.experiments.batch_group`:
    one compiled call simulates them all (each record's ``wall_time`` is its share). A batch that
    cannot be built (e.g. an unknown gain name) falls back to one point at a time, so the error
    lands on the point that caused it."""
    if len(spec_dicts) == 1:
        return [evaluate_spec(spec_dicts[0], robot_args, return_run)]
    start = time.perf_counter()
    try:
        specs = [RunSpec(**spec_dict) for spec_dict in spec_dicts]
        robot = _cached_robot(_freeze(_canonical_robot_args(robot_args)))
        results = run_batch(specs, robot)
    except Exception as exc:
        reraise_interrupt(exc)
        return [evaluate_spec(spec_dict, robot_args, return_run) for spec_dict in spec_dicts]
    share = (time.perf_counter() - start) / len(specs)
    records = []
    for spec_dict, result in zip(spec_dicts, results):
        record = {"spec": spec_dict, "metrics": None, "wall_time": share, "error": None, "error_type": None}
        if isinstance(result, DeltaPinError):
            record.update(error=str(result), error_type=type(result).__name__)
        else:
            record["metrics"] = _canonical(compute_metrics(result).as_dict(), where="metrics")
            if return_run:
                record["run"] = result
        records.append(record)
    return records


def estimated_cost(spec: RunSpec) -> float:
    """A run's cost in units of one compiled 1 ms sample, to start the longest runs first: the
    samples of a sampled run (one compiled step each); for the compiled continuous Radau IIA/BDF2
    (the laws declared compiled_continuous) 1.5 times that on the Pinocchio plant and a tenth of that on the
    analytic plant (in ``reproduce --full``, 15 s on the Pinocchio plant took 0.8-1.1 s for designs
    I/II, 1.2-1.4 s for the LQR, 0.6-0.7 s for a sampled 1 kHz run); fifteen times that for a
    Python law called back by the continuous loop."""
    samples = spec.duration / spec.dt
    if spec.mode == "sampled":
        return samples
    compiled_law = declaration(spec.controller).compiled_continuous
    compiled = compiled_law and spec.integrator in ("auto", "radau", "bdf2")
    if not compiled:
        return samples * 15.0
    return samples * (1.5 if spec.plant == "pinocchio" else 0.1)


def _chunks(todo: list[str], unique: Mapping[str, RunSpec], workers: int | None) -> list[list[str]]:
    """The todo keys in tasks: points of one batch group in chunks (at most BATCH_SIZE, and at
    least two chunks per worker when the group is large enough), every other point alone, the
    single points longest first (:func:`estimated_cost`) and the batch chunks after them, so that
    the workers end together rather than one of them finishing a long run alone."""
    groups: dict = {}
    tasks = []
    for key in todo:
        group = batch_group(unique[key])
        if group is None:
            tasks.append([key])
        else:
            groups.setdefault(group, []).append(key)
    tasks.sort(key=lambda task: -estimated_cost(unique[task[0]]))  # stable: equal costs keep their order
    lanes = 2 * (workers or os.cpu_count() or 1)
    for keys in groups.values():
        size = max(1, min(BATCH_SIZE, math.ceil(len(keys) / lanes)))
        tasks.extend(keys[i : i + size] for i in range(0, len(keys), size))
    return tasks


# --------------------------------------------------------------------------------------------------
# the cache


def _read_cached(
    cache_dir: Path, key: str, need_run: bool, retry_failed: bool, args: dict
) -> tuple[dict | None, str | None]:
    """``(record, None)``: the cache record of ``key`` (with its run, if ``need_run``);
    ``(None, None)``: none is cached (or a failure to retry); ``(None, why)``: a record or run that
    does not hold up (:func:`_record_problem`, :func:`_run_problem`), named in one line to be
    recomputed (never trusted, never a traceback)."""
    path = cache_dir / f"{key}.json"
    try:
        record = json.loads(path.read_text())
    except FileNotFoundError:
        return None, None
    except (OSError, ValueError) as exc:
        return None, f"unreadable cache file {path} ({exc}): recomputing it"
    if not isinstance(record, dict) or record.get("format") != RECORD_FORMAT or record.get("key") != key:
        return None, f"cache file {path} is not a delta-pin sweep point of key {key}: recomputing it"
    problem = _record_problem(record, key, args)
    if problem:
        return None, f"cache file {path} is not a valid sweep point ({problem}): recomputing it"
    if record["error"] is not None:
        return (None, None) if retry_failed else (record, None)
    if need_run:
        run_path = cache_dir / f"{key}.npz"
        if not run_path.is_file() and not run_path.is_symlink():
            return None, None  # stored without its run (save_runs was off): computed again, quietly
        problem = _run_problem(run_path, key, args)
        if problem:
            return None, problem
    return record, None


def _number_or_none(value) -> bool:
    return value is None or (isinstance(value, int | float) and not isinstance(value, bool))


def _record_problem(record: dict, key: str, args: dict) -> str | None:
    """What is wrong with a cache record of ``key`` (``None``: nothing): its spec and robot
    arguments must hash to its key, its metrics be every index as a number or null (or null with
    an error), its wall time and error fields of their types."""
    spec, robot_args = record.get("spec"), record.get("robot_args", {})
    if not isinstance(spec, dict):
        return f"spec is {json.dumps(spec)}, not an object"
    try:
        canonical_args = _canonical_robot_args(robot_args)
    except (InvalidParameterError, AttributeError, TypeError, ValueError):
        return f"robot_args is {json.dumps(robot_args)}, not an object"
    if canonical_args != args:
        return f"robot_args {json.dumps(canonical_args)}, not this sweep's {json.dumps(args)}"
    payload = {"spec": spec, "robot_args": canonical_args} if canonical_args else spec
    if hashlib.sha256(_dumps(payload).encode()).hexdigest() != key:
        return "its spec does not hash to its key"
    error, error_type = record.get("error"), record.get("error_type")
    if error is not None and not isinstance(error, str):
        return f"error is {json.dumps(error)}, not a string or null"
    if error_type is not None and not isinstance(error_type, str):
        return f"error_type is {json.dumps(error_type)}, not a string or null"
    if not _number_or_none(record.get("wall_time")):
        return f"wall_time is {json.dumps(record.get('wall_time'))}, not a number or null"
    metrics = record.get("metrics")
    if error is not None:
        return None if metrics is None or isinstance(metrics, dict) else f"metrics is {json.dumps(metrics)}"
    if not isinstance(metrics, dict):
        return f"metrics is {json.dumps(metrics)} without an error"
    missing = [name for name in METRIC_NAMES if name not in metrics]
    if missing:
        return f"metrics lack {', '.join(missing)}"
    bad = [name for name, value in metrics.items() if not _number_or_none(value)]
    if bad:
        return f"metrics.{bad[0]} is {json.dumps(metrics[bad[0]])}, not a number or null"
    return None


def _run_problem(path: Path, key: str, args: dict) -> str | None:
    """What is wrong with the cached run ``path`` of ``key`` (``None``: nothing): it must be a file
    that loads (a truncated one does not), and its metadata's spec must have this key (a run
    swapped with another point's is not this point's)."""
    if not path.is_file():
        return f"cached run {path} is not a file: recomputing it"
    try:
        run = load_run(path)
    except DeltaPinError as exc:
        return f"unreadable cached run {path} ({exc}): recomputing it"
    metadata = run.metadata if isinstance(run.metadata, dict) else {}
    spec = metadata.get("spec")
    if not isinstance(spec, dict):
        return f"cached run {path} holds no spec in its metadata: recomputing it"
    try:
        found = spec_key(RunSpec(**spec), args)
    except (DeltaPinError, TypeError, ValueError) as exc:
        return f"cached run {path} holds a spec that is not a RunSpec ({exc}): recomputing it"
    if found != key:
        return f"cached run {path} is the run of another point (key {found}): recomputing it"
    return None


def _store(cache_dir: Path, key: str, record: dict, robot_args: dict) -> None:
    """Write the run (if any) and then the record, each atomically: a ``.json`` implies its ``.npz``."""
    run = record.pop("run", None)
    if run is not None:
        run.save(cache_dir / f"{key}.npz")
    if record.get("unexpected"):
        return  # not cached: a resume retries it
    from delta_pin import __version__

    payload = {
        "format": RECORD_FORMAT,
        "version": RECORD_VERSION,
        "key": key,
        "spec": record["spec"],
        "robot_args": robot_args,
        "metrics": record["metrics"],
        "wall_time": record["wall_time"],
        "error": record["error"],
        "error_type": record["error_type"],
        "delta_pin": __version__,
    }
    write_text_atomically(cache_dir / f"{key}.json", json.dumps(payload, indent=1, sort_keys=True) + "\n")


# --------------------------------------------------------------------------------------------------
# executors: each backend maps a function over (key, args) items and yields (key, result) as they finish

_Submit = Callable[..., object]


def _import_distributed():
    try:
        import distributed
    except ImportError as exc:
        raise OptionalDependencyError(
            "executor='dask' needs dask.distributed, an optional extra: "
            "pip install 'delta-pin[dask]'  (or: pip install 'dask[distributed]')"
        ) from exc
    return distributed


def _is_dask_client(executor) -> bool:
    return type(executor).__module__.split(".")[0] == "distributed" and hasattr(executor, "submit")


def _run_futures(submit: _Submit, as_completed, cancel, fn, items) -> Iterator[tuple[str, dict]]:
    futures = {submit(fn, *args): key for key, args in items}
    try:
        for future in as_completed(futures):
            yield futures[future], future.result()
    finally:
        for future in futures:
            if not future.done():
                cancel(future)


@contextmanager
def _backend(executor, workers: int | None, scheduler: str | None):
    """A function ``(fn, items) -> iterator of (key, fn(*args))`` for the chosen executor."""
    if isinstance(executor, concurrent.futures.Executor):
        yield functools.partial(
            _run_futures, executor.submit, concurrent.futures.as_completed, lambda f: f.cancel()
        )
        return
    if _is_dask_client(executor):
        distributed = _import_distributed()
        submit = functools.partial(executor.submit, pure=False)
        yield functools.partial(_run_futures, submit, distributed.as_completed, lambda f: f.cancel())
        return
    if executor == "serial":
        yield lambda fn, items: ((key, fn(*args)) for key, args in items)
        return
    if executor == "process":
        # Ctrl-C reaches the whole process group: the workers leave it to this process, which
        # stops the pool (instead of each printing its own KeyboardInterrupt traceback)
        # (and a worker ends when this process dies, even by SIGKILL: _init_worker)
        pool = concurrent.futures.ProcessPoolExecutor(
            max_workers=workers, initializer=_init_worker, initargs=(os.getpid(),)
        )
        clean = False
        try:
            yield functools.partial(
                _run_futures, pool.submit, concurrent.futures.as_completed, lambda f: f.cancel()
            )
            clean = True
        finally:
            pool.shutdown(wait=clean, cancel_futures=True)
            if not clean:  # Ctrl-C or an error: the workers' running points are not waited for
                _terminate_workers(pool)
        return
    # dask
    distributed = _import_distributed()
    if scheduler in (None, "local"):
        cluster = distributed.LocalCluster(
            n_workers=workers, processes=True, threads_per_worker=1, dashboard_address=None
        )
        client = distributed.Client(cluster)
    else:
        cluster = None
        try:
            _probe_scheduler(scheduler, SCHEDULER_TIMEOUT)
            client = distributed.Client(scheduler, timeout=SCHEDULER_TIMEOUT)
        except (OSError, TimeoutError, ValueError, _NotASchedulerError) as exc:
            raise SchedulerUnreachableError(
                f"no Dask scheduler answers at --scheduler {scheduler} within {SCHEDULER_TIMEOUT:g} s "
                f"({exc if isinstance(exc, _NotASchedulerError) else type(exc).__name__}); "
                "start one (dask scheduler) or give its address, or 'local'"
            ) from None
    try:
        submit = functools.partial(client.submit, pure=False)
        yield functools.partial(_run_futures, submit, distributed.as_completed, lambda f: f.cancel())
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


class _NotASchedulerError(Exception):
    """The peer at a --scheduler address answered, but not as a Dask scheduler."""


def _probe_scheduler(address: str, timeout: float) -> None:
    """Ask the peer at ``address`` for its identity, all within ``timeout`` seconds, before a
    ``distributed.Client`` is made: the client's own ``timeout`` bounds the TCP connect only, so
    a peer that accepts and never answers held it 143 s and more, and one that sends 8 random
    bytes made it read a frame of exabytes. Runs in a thread of its own (its own event loop, so a
    caller's running loop is no obstacle); the thread ends with the deadline's cancellation.

    Raises:
        TimeoutError: no answer within ``timeout``.
        OSError: the connection broke.
        _NotASchedulerError: the peer answered, but not as a scheduler (or not in Dask's protocol).
    """
    import asyncio

    from distributed.comm import connect

    async def ask() -> object:
        comm = await connect(address, timeout=timeout)
        try:
            await comm.write({"op": "identity"})
            return await comm.read()
        finally:
            comm.abort()

    def run() -> object:
        return asyncio.run(asyncio.wait_for(ask(), timeout))

    with concurrent.futures.ThreadPoolExecutor(max_workers=1) as pool:
        try:
            reply = pool.submit(run).result(timeout=timeout + 1.0)  # the loop's own deadline first
        except (concurrent.futures.TimeoutError, asyncio.TimeoutError):
            raise TimeoutError(f"no answer within {timeout:g} s") from None
        except OSError:
            raise
        except Exception as exc:  # a reply that is not Dask's protocol: struct.error, ValueError, ...
            raise _NotASchedulerError(f"its reply broke Dask's protocol: {type(exc).__name__}") from None
    if not (isinstance(reply, dict) and reply.get("type") == "Scheduler"):
        raise _NotASchedulerError(f"it answered {str(reply)[:60]!r}")


def _terminate_workers(pool: concurrent.futures.ProcessPoolExecutor) -> None:
    """Stop the pool's worker processes now (they only compute: the cache is written here)."""
    terminate = getattr(pool, "terminate_workers", None)  # Python >= 3.14
    if terminate is not None:
        terminate()
        return
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.terminate()


_WORKER_BLAS_LIMIT = []  # the worker's one-thread BLAS limit, kept for its lifetime


def _init_worker(parent: int) -> None:
    """Initializer of the pool's workers: Ctrl-C is for the parent process to handle, a worker
    ends when the parent process ``parent`` dies (killed outright, its workers used to live on,
    blocked on their pipe, ~220 MB each), and its BLAS runs on one thread: the pool already has a
    process per core, and OpenBLAS's threads, which wait spinning after each call, took the other
    workers' cores (docs/measured/bench_sweep.md)."""
    import signal

    from threadpoolctl import threadpool_limits

    from delta_pin.utils.processes import die_with_parent

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the CLI's handler, inherited by the fork
    die_with_parent(parent)
    _WORKER_BLAS_LIMIT.append(threadpool_limits(limits=1, user_api="blas"))


def _resolve_executor(executor, workers, scheduler):
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise InvalidParameterError(f"workers={workers!r} must be an integer >= 1")
    if scheduler is not None and not isinstance(scheduler, str):
        raise InvalidParameterError(f"scheduler={scheduler!r} must be 'local' or a dask scheduler address")
    if isinstance(executor, concurrent.futures.Executor) or _is_dask_client(executor):
        if workers is not None or scheduler is not None:
            raise InvalidParameterError(
                "workers and scheduler apply to executor='process' or 'dask', not to an executor instance"
            )
        return executor
    if executor is None:
        executor = "dask" if scheduler is not None else ("process" if workers and workers > 1 else "serial")
    if executor not in EXECUTORS:
        raise InvalidParameterError(
            f"executor={executor!r} must be one of {', '.join(EXECUTORS)} or a concurrent.futures.Executor"
        )
    if scheduler is not None and executor != "dask":
        raise InvalidParameterError(f"scheduler={scheduler!r} applies to executor='dask', not {executor!r}")
    if executor == "serial" and workers not in (None, 1):
        raise InvalidParameterError(f"workers={workers} needs executor='process' or 'dask', not 'serial'")
    return executor


# --------------------------------------------------------------------------------------------------
# progress


# --------------------------------------------------------------------------------------------------
# the sweep


def run_sweep(
    specs: Iterable[RunSpec],
    cache_dir: str | Path,
    *,
    executor: str | concurrent.futures.Executor | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    save_runs: bool | Callable[[RunSpec], bool] = False,
    robot_args: Mapping | None = None,
    progress: bool | None = None,
    retry_failed: bool = False,
) -> SweepResult:
    """Simulate every spec (those not already in ``cache_dir``) and return their points in order.

    Args:
        specs: the runs (:func:`grid_specs` makes a grid). Duplicates are simulated once.
        cache_dir: folder of the cache (created if needed); ``<key>.json`` per finished point and,
            with ``save_runs``, ``<key>.npz``. Points already there are read back, not recomputed.
        executor: ``"serial"``, ``"process"`` (a process pool of ``workers``), ``"dask"`` (a
            ``dask.distributed`` client of ``scheduler``), a :class:`concurrent.futures.Executor`
            or a ``distributed.Client`` instance (left open). ``None``: ``"dask"`` if ``scheduler``
            is given, ``"process"`` if ``workers > 1``, else ``"serial"``.
        workers: processes of the pool, or workers of a local dask cluster (``None``: one per core).
        scheduler: ``"local"`` (a :class:`~distributed.LocalCluster` of ``workers`` processes, one
            thread each; the default with ``executor="dask"``) or a scheduler address
            (``"tcp://host:8786"``).
        save_runs: also store each run (``<key>.npz``, :func:`~delta_pin.load_run` reads it); a
            cached point without its ``.npz`` is recomputed. A function of the spec: store the runs
            of the specs it accepts only (compressing a run costs ~50 ms of the calling process:
            ``reproduce --full`` keeps the 10 runs it plots, not the 769 it only takes metrics of).
        robot_args: keyword arguments of :func:`~delta_pin.load_delta` (``None``: Table 1); part of
            the cache key when given.
        progress: ``None``: a progress bar on a terminal only; ``True``: also one line per 10% when
            stderr is not a terminal; ``False``: quiet.
        retry_failed: recompute cached points that failed (by default a failure is final).

    Returns:
        A :class:`SweepResult` (a list of :class:`SweepPoint`, in the order of ``specs``) with the
        counts ``skipped``, ``computed`` and ``failed``.

    Raises:
        InvalidParameterError: a spec that is not a RunSpec, bad executor options.
        OptionalDependencyError: ``executor="dask"`` without dask installed.
        DeltaPinError: ``robot_args`` that do not make a robot (checked once, before any run).
    """
    start = time.perf_counter()
    specs = _checked_specs(specs)
    executor = _resolve_executor(executor, workers, scheduler)
    args = _canonical_robot_args(robot_args)
    cache_dir = Path(cache_dir)
    cache_dir.mkdir(parents=True, exist_ok=True)

    keys = [spec_key(spec, args) for spec in specs]
    unique = {key: spec for key, spec in zip(keys, specs)}
    wanted = {
        key: bool(save_runs(spec) if callable(save_runs) else save_runs) for key, spec in unique.items()
    }
    records = _read_cache(cache_dir, unique, wanted, retry_failed, args)
    from_cache = set(records)
    todo = [key for key in unique if key not in records]
    skipped = sum(key in from_cache for key in keys)

    bar = Progress(len(todo), progress, label="sweep", unit="pt")
    if skipped:
        bar.note(f"sweep: {skipped} points from the cache, {len(todo)} to compute")
    try:
        unexpected = _compute(
            todo, unique, records, cache_dir, args, wanted, executor, workers, scheduler, bar
        )
    finally:
        bar.close()

    points = [
        SweepPoint(
            spec=spec,
            key=key,
            metrics=records[key]["metrics"],
            wall_time=records[key]["wall_time"],
            error=records[key]["error"],
            error_type=records[key]["error_type"],
            cached=key in from_cache,
        )
        for spec, key in zip(specs, keys)
    ]
    result = SweepResult(
        points,
        skipped=skipped,
        computed=len(todo),
        wall_time=time.perf_counter() - start,
        cache_dir=cache_dir,
    )
    _report(result, unexpected, bar.enabled)
    return result


def _checked_specs(specs: Iterable[RunSpec]) -> list[RunSpec]:
    """The specs as a list, each a :class:`RunSpec` (or an error naming the first that is not)."""
    specs = list(specs)
    for index, spec in enumerate(specs):
        if not isinstance(spec, RunSpec):
            raise InvalidParameterError(
                f"specs[{index}] must be a RunSpec, got {type(spec).__name__}: {spec!r}"
            )
    return specs


def _read_cache(
    cache_dir: Path, unique: dict, wanted: dict, retry_failed: bool, args: dict
) -> dict[str, dict]:
    """The records of the points already in the cache, by key (``wanted``: key -> whether its run
    must be there too); each one that does not hold up is named in a warning line (the first
    :data:`NAMED_BAD_RECORDS`, then one line counting the rest) and left to be recomputed."""
    records: dict[str, dict] = {}
    bad = []
    for key in unique:
        record, problem = _read_cached(cache_dir, key, wanted[key], retry_failed, args)
        if record is not None:
            records[key] = record
        elif problem:
            bad.append(problem)
    for problem in bad[:NAMED_BAD_RECORDS]:
        _log.warning("%s", problem)
    if len(bad) > NAMED_BAD_RECORDS:
        _log.warning(
            "%d more cache files of %s do not hold up either: recomputing them",
            len(bad) - NAMED_BAD_RECORDS,
            cache_dir,
        )
    return records


def _compute(todo, unique, records, cache_dir, args, wanted, executor, workers, scheduler, bar) -> list:
    """Simulate the points ``todo`` in batches on the executor, storing each record in the cache
    (and in ``records``) as it arrives, with its run where ``wanted[key]``; returns the (spec,
    record) of unexpected failures."""
    unexpected = []
    if not todo:
        return unexpected
    _cached_robot(_freeze(args))  # bad robot arguments fail here, once, not in every point
    items = [
        (tuple(chunk), ([_canonical_spec(unique[key]) for key in chunk], args, any(wanted[k] for k in chunk)))
        for chunk in _chunks(todo, unique, workers)
    ]
    with _backend(executor, workers, scheduler) as run_all:
        for chunk, chunk_records in run_all(evaluate_batch, items):
            for key, record in zip(chunk, chunk_records):
                if not wanted[key]:
                    record.pop("run", None)
                _store(cache_dir, key, record, args)
                records[key] = record
                if record.get("unexpected"):
                    unexpected.append((unique[key], record))
                    _log.error("sweep point %s (%s) failed:\n%s", key, unique[key], record["traceback"])
                bar.update(failed=record["error"] is not None)
    return unexpected


def _report(result: SweepResult, unexpected: list, to_stderr: bool) -> None:
    """Log the sweep's summary (and print it where a progress display was shown); warn about
    unexpected failures, which are not cached."""
    _log.info("%s (cache %s)", result.summary(), result.cache_dir)
    if to_stderr:
        print(result.summary(), file=sys.stderr, flush=True)
    if unexpected:
        spec, record = unexpected[0]
        warnings.warn(
            f"{len(unexpected)} sweep point(s) failed with an unexpected error (not cached, a resume"
            f" retries them); the first, {spec.label()}: {record['error']}",
            RuntimeWarning,
            stacklevel=3,
        )


# --------------------------------------------------------------------------------------------------
# grids


def _coerce(name: str, value):
    """``value`` as the type of RunSpec field ``name`` (ints as floats, 0/1 as bools ...)."""
    kind = _FIELD_TYPES[name]
    optional = "None" in kind
    if value is None:
        if optional:
            return None
        raise InvalidParameterError(f"axis {name}: None is not a valid {name} ({kind})")
    if isinstance(value, np.generic):
        value = value.item()
    bad = InvalidParameterError(f"axis {name}: {value!r} is not a valid {name} ({kind})")
    if kind.startswith("bool"):
        if isinstance(value, bool):
            return value
        if isinstance(value, int) and value in (0, 1):
            return bool(value)
        if isinstance(value, str) and value.lower() in ("true", "false"):
            return value.lower() == "true"
        raise bad
    if kind.startswith("float"):
        if isinstance(value, bool):
            raise bad
        if isinstance(value, int | float):
            return float(value)
        if isinstance(value, str):
            try:
                return float(value)
            except ValueError:
                raise bad from None
        raise bad
    if kind.startswith("int"):
        if isinstance(value, bool):
            raise bad
        if isinstance(value, int):
            return value
        if isinstance(value, float) and value.is_integer():
            return int(value)
        if isinstance(value, str):
            try:
                return int(value)
            except ValueError:
                raise bad from None
        raise bad
    if kind.startswith("str"):
        if isinstance(value, str):
            return value
        raise bad
    return value


def grid_specs(base: RunSpec, axes: Mapping[str, Iterable]) -> list[RunSpec]:
    """The Cartesian product of ``axes`` over ``base`` (the first axis varies slowest).

    Args:
        base: the spec every point starts from.
        axes: values by name. A :class:`RunSpec` field (``delta_m``, ``controller``, ``seed`` ...)
            replaces the field (values coerced to its type: ``0`` -> ``0.0`` for a float field);
            any other name is a gain and goes into ``spec.gains`` (over ``base.gains``). An unknown
            gain name fails when the point runs.

    Examples:
        >>> grid_specs(RunSpec(), {"delta_m": [0.0, 0.5], "xi": [1e-3, 1e-2]})   # 4 specs

    Raises:
        InvalidParameterError: no axes, an axis without values, a name that is not an identifier
            or is ``gains``, a value of the wrong type for its field.
    """
    if not isinstance(base, RunSpec):
        raise InvalidParameterError(f"grid_specs: base must be a RunSpec, got {type(base).__name__}")
    if not isinstance(axes, Mapping) or not axes:
        raise InvalidParameterError(
            f"grid_specs needs at least one axis, e.g. {{'delta_m': [0.0, 0.5]}}, got axes={axes!r}"
        )
    names, values = [], []
    for name, axis in axes.items():
        if not isinstance(name, str) or not name.isidentifier():
            raise InvalidParameterError(f"axis name {name!r} must be a RunSpec field or a gain name")
        if name == "gains":
            raise InvalidParameterError("axis 'gains': give each gain its own axis, e.g. {'xi': [...]}")
        if isinstance(axis, str | bytes | Mapping) or not isinstance(axis, Iterable):
            raise InvalidParameterError(f"axis {name}: expected a list of values, got {axis!r}")
        axis = list(axis)
        if not axis:
            raise InvalidParameterError(f"axis {name} has no values")
        if name in _FIELD_TYPES:
            axis = [_coerce(name, value) for value in axis]
        names.append(name)
        values.append(axis)
    specs = []
    for combo in itertools.product(*values):
        changes, gains = {}, dict(base.gains)
        for name, value in zip(names, combo):
            if name in _FIELD_TYPES:
                changes[name] = value
            else:
                gains[name] = value
        try:
            specs.append(base.with_(**changes, gains=gains))
        except InvalidParameterError as exc:  # name the point (dt=0, t_end=-1, velocity='bogus' ...)
            point = ", ".join(f"{name}={value!r}" for name, value in zip(names, combo))
            raise InvalidParameterError(f"the grid's point {point}: {exc}") from None
    return specs


_AXIS_SYNTAX = "NAME=START:STOP:COUNT (inclusive) or NAME=V1,V2,..."


def _parse_value(token: str):
    lower = token.lower()
    if lower in ("none", "null"):
        return None
    if lower in ("true", "false"):
        return lower == "true"
    try:
        return int(token)
    except ValueError:
        pass
    try:
        return float(token)
    except ValueError:
        return token


def parse_axis(text: str) -> tuple[str, list]:
    """A sweep axis from the command line.

    ``"delta_m=0:0.9:4"`` -> ``("delta_m", [0.0, 0.3, 0.6, 0.9])`` (START:STOP:COUNT, both ends
    included, values rounded to 12 significant digits); ``"delta_f=0,0.3,0.6"`` -> an explicit list
    (integers, floats, ``true``/``false``, ``none`` and words such as ``design1`` or ``II``).

    Raises:
        InvalidParameterError: naming the text that cannot be read.
    """
    if not isinstance(text, str):
        raise InvalidParameterError(f"axis {text!r} must be a string {_AXIS_SYNTAX}")
    name, sep, rest = text.partition("=")
    name, rest = name.strip(), rest.strip()
    if not sep or not name or not rest:
        raise InvalidParameterError(f"axis {text!r}: expected {_AXIS_SYNTAX}")
    if not name.isidentifier():
        raise InvalidParameterError(f"axis {text!r}: {name!r} is not a field or gain name")
    if ":" in rest:
        parts = [part.strip() for part in rest.split(":")]
        if len(parts) != 3:
            raise InvalidParameterError(f"axis {text!r}: a range is START:STOP:COUNT, got {rest!r}")
        try:
            start, stop = float(parts[0]), float(parts[1])
        except ValueError:
            raise InvalidParameterError(
                f"axis {text!r}: START and STOP must be numbers, got {rest!r}"
            ) from None
        if not (math.isfinite(start) and math.isfinite(stop)):
            raise InvalidParameterError(f"axis {text!r}: START and STOP must be finite")
        try:
            count = int(parts[2])
        except ValueError:
            raise InvalidParameterError(
                f"axis {text!r}: COUNT must be an integer, got {parts[2]!r}"
            ) from None
        if count < 1:
            raise InvalidParameterError(f"axis {text!r}: COUNT must be >= 1, got {count}")
        if count == 1 and start != stop:
            raise InvalidParameterError(f"axis {text!r}: COUNT=1 needs START == STOP")
        values = [float(f"{value:.12g}") for value in np.linspace(start, stop, count)]
        return name, values
    tokens = [token.strip() for token in rest.split(",")]
    if any(not token for token in tokens):
        raise InvalidParameterError(f"axis {text!r}: empty value in {rest!r}")
    return name, [_parse_value(token) for token in tokens]


def parse_axes(texts: Iterable[str]) -> dict[str, list]:
    """Several :func:`parse_axis` texts as the ``axes`` of :func:`grid_specs` (a name at most once)."""
    axes: dict[str, list] = {}
    for text in texts:
        name, values = parse_axis(text)
        if name in axes:
            raise InvalidParameterError(f"axis {name} given twice (in {text!r})")
        axes[name] = values
    return axes

"""A closed-loop run as data: :class:`Run` (arrays sampled at t_k = k dt and metadata), saved
atomically to ``.npz`` and read back by :func:`load_run`."""

from __future__ import annotations

import json
import platform
import sys
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from delta_pin.errors import DeltaPinError
from delta_pin.utils.atomic import atomic_open

if TYPE_CHECKING:
    from delta_pin.control.base import Controller
    from delta_pin.model.robot import Delta
    from delta_pin.sim.plants import Plant

__all__ = ["ARRAYS", "Run", "load_run", "run_metadata"]

ARRAYS = ("t", "alpha", "alpha_dot", "alpha_d", "alpha_dot_d", "xyz", "xyz_d", "tau", "closure_residual")
OPTIONAL_ARRAYS = ("q", "v")  # absent from runs of plants without a full state, and from older runs


@dataclass
class Run:
    """One closed-loop simulation, sampled at t_k = k dt.

    Attributes:
        t: sample times (N,) [s].
        alpha, alpha_dot: joint angles [rad] and velocities [rad/s] (N, 3).
        alpha_d, alpha_dot_d: reference angles and velocities (N, 3).
        xyz, xyz_d: actual and desired platform positions (N, 3) [m].
        tau: torques (N, 3) [N m] evaluated at each sample (held over the period in sampled mode).
        closure_residual: largest loop-closure gap (N,) [m] (zeros on the analytic plant).
        internals: controller quantities by name (e.g. ``rho_hat``), each (N, ...).
        metadata: every parameter of the run, seed and versions (JSON-serialisable).
        q, v: the plant's full configuration (N, nq) and velocity (N, nv) at every sample, where
            the plant has them (``None`` otherwise, and in runs saved before they were kept):
            idle motions and the assembly mode are in q, not in alpha.
    """

    t: np.ndarray
    alpha: np.ndarray
    alpha_dot: np.ndarray
    alpha_d: np.ndarray
    alpha_dot_d: np.ndarray
    xyz: np.ndarray
    xyz_d: np.ndarray
    tau: np.ndarray
    closure_residual: np.ndarray
    internals: dict[str, np.ndarray] = field(default_factory=dict)
    metadata: dict = field(default_factory=dict)
    q: np.ndarray | None = None
    v: np.ndarray | None = None

    @property
    def error(self) -> np.ndarray:
        """Joint tracking error r = alpha - alpha^d (eq. 14) (N, 3) [rad]."""
        return self.alpha - self.alpha_d

    @property
    def error_rate(self) -> np.ndarray:
        """r_dot = alpha_dot - alpha_dot^d (N, 3) [rad/s]."""
        return self.alpha_dot - self.alpha_dot_d

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        """A one-line summary (the arrays and the metadata, URDF included, are too long to print)."""
        controller = (self.metadata.get("controller") or {}).get("name", "?")
        plant, mode = self.metadata.get("plant", "?"), self.metadata.get("mode", "?")
        error = float(np.abs(self.error).max()) if len(self.t) else float("nan")
        return (
            f"Run({len(self.t)} samples, t = {self.t[0]:g}..{self.t[-1]:g} s, controller={controller!r}, "
            f"plant={plant!r}, mode={mode!r}, max |alpha - alpha_d| = {error:.3g} rad)"
        )

    def save(self, path: str | Path) -> Path:
        """Write the run to ``path`` (``.npz``) atomically: a temporary file, then a rename."""
        arrays = {name: getattr(self, name) for name in ARRAYS}
        arrays.update(
            {name: getattr(self, name) for name in OPTIONAL_ARRAYS if getattr(self, name) is not None}
        )
        arrays.update({f"internal__{name}": value for name, value in self.internals.items()})
        arrays["metadata_json"] = np.array(json.dumps(self.metadata, default=_json_default))
        with atomic_open(path, "wb") as handle:
            np.savez_compressed(handle, **arrays)
        return Path(path)


def _json_default(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{value!r} is not JSON-serialisable")


def load_run(path: str | Path) -> Run:
    """Read a :class:`Run` written by :meth:`Run.save`."""
    path = Path(path)
    if not path.is_file():
        raise DeltaPinError(f"run file {str(path)!r} does not exist")
    try:
        with np.load(path, allow_pickle=False) as data:
            try:
                arrays = {name: data[name] for name in ARRAYS}
            except KeyError as exc:
                raise DeltaPinError(f"{str(path)!r} is not a delta-pin run: missing {exc}") from None
            arrays.update({name: data[name] for name in OPTIONAL_ARRAYS if name in data.files})
            internals = {
                key.removeprefix("internal__"): data[key]
                for key in data.files
                if key.startswith("internal__")
            }
            metadata = json.loads(str(data["metadata_json"]))
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as exc:
        # a truncated or foreign file: numpy's own error would not name it
        raise DeltaPinError(
            f"{str(path)!r} is not a readable delta-pin run ({type(exc).__name__}: {exc}); "
            "give a run.npz written by delta-pin"
        ) from None
    problem = _layout_problem(arrays, internals, metadata)
    if problem is not None:  # a foreign or edited file: its arrays would fail later, unnamed
        raise DeltaPinError(
            f"{str(path)!r} is not a delta-pin run: {problem}; give a run.npz written by delta-pin"
        )
    return Run(**arrays, internals=internals, metadata=metadata)


def _layout_problem(arrays: dict, internals: dict, metadata) -> str | None:
    """What in a loaded run's arrays and metadata is not what :meth:`Run.save` writes (``None``:
    nothing): real numeric arrays, ``t`` (N,) finite and increasing, ``closure_residual`` (N,),
    ``alpha``, ``alpha_dot``, ``alpha_d``, ``alpha_dot_d``, ``tau`` (N, n) of one n, ``xyz`` and
    ``xyz_d`` (N, 3), ``q``/``v`` (N, k), each internal N samples long, and a metadata object."""
    if not isinstance(metadata, dict):
        return f"its metadata is a JSON {type(metadata).__name__}, expected an object"
    for key in ("robot", "controller", "trajectory", "plant_details", "uncertainty"):  # what viewers read
        if metadata.get(key) is not None and not isinstance(metadata[key], dict):
            return f"its metadata's {key!r} is a JSON {type(metadata[key]).__name__}, expected an object"
    every = {**arrays, **{f"internal {name!r}": value for name, value in internals.items()}}
    for name, value in every.items():
        if value.dtype.kind not in "fiu":
            return f"{name} holds {value.dtype} values, expected real numbers (float64)"
    t = arrays["t"]
    if t.ndim != 1:
        return f"t has shape {t.shape}, expected (N,): one time per sample"
    n = len(t)
    if not np.all(np.isfinite(t)):
        return f"t is not finite at sample {int(np.argmax(~np.isfinite(t)))}"
    if n > 1 and not np.all(np.diff(t) > 0.0):
        k = int(np.argmax(~(np.diff(t) > 0.0)))
        return f"t does not increase at sample {k + 1} (t={t[k + 1]:.6g} s after {t[k]:.6g} s)"
    alpha = arrays["alpha"]
    joints = alpha.shape[1] if alpha.ndim == 2 else 3
    expected = {"closure_residual": (n,), "xyz": (n, 3), "xyz_d": (n, 3)}
    expected.update({name: (n, joints) for name in ("alpha", "alpha_dot", "alpha_d", "alpha_dot_d", "tau")})
    for name, shape in expected.items():
        if arrays[name].shape != shape:
            return f"{name} has shape {arrays[name].shape}, expected {shape} ({n} samples as t)"
    for name in OPTIONAL_ARRAYS:
        if name in arrays and (arrays[name].ndim != 2 or len(arrays[name]) != n):
            return f"{name} has shape {arrays[name].shape}, expected ({n}, k) ({n} samples as t)"
    for name, value in internals.items():
        if value.ndim == 0 or len(value) != n:
            return f"internal {name!r} has shape {value.shape}, expected ({n}, ...) ({n} samples as t)"
    return None


def _versions() -> dict:
    import pinocchio

    from delta_pin import __version__

    return {
        "delta_pin": __version__,
        "pinocchio": pinocchio.__version__,
        "numpy": np.__version__,
        "python": sys.version.split()[0],
        "machine": platform.machine(),
    }


def run_metadata(robot: Delta, controller: Controller, trajectory, plant: Plant, **timing) -> dict:
    """The metadata of a :class:`Run`: robot, controller, trajectory, plant, then ``timing``
    (mode, dt, t_end, integrator, ...), then the package versions."""
    return {
        "robot": robot.metadata(),
        "urdf": robot.urdf,
        # where its relative mesh filenames point (a serial robot from example-robot-data has none)
        "urdf_dir": getattr(getattr(robot, "description", None), "base_dir", None)
        or getattr(robot, "base_dir", None),
        "controller": controller.metadata(),
        "trajectory": None if trajectory is None else trajectory.metadata(),
        **plant.metadata(),
        **timing,
        "versions": _versions(),
    }

"""The constrained tree dynamics as a small C++ library, for compiled simulation loops.

``pin.constraintDynamics`` costs ~7.6 us per call from Python, a third of it in the binding. The
compiled loops of :mod:`delta_pin.compiled.closed_loop` and :mod:`delta_pin.compiled.tree_loop`
call C++ directly instead, through ``tree_dynamics.cpp``, a C ABI with two evaluations of the
constrained tree (:data:`STAGES`): the same explicitly instantiated ``constraintDynamics`` of
``libpinocchio_default`` that the Python binding calls, so the accelerations agree bit for bit; and
``axis_tree.hpp``, delta-pin's own recursive algorithms for trees of 1-DOF axis joints, equal to it
to ~1e-13 relative at ~40 % of its cost, the default (tests/sim/test_native.py).

The library is built when the package is installed (``setup.py`` runs :func:`build_prebuilt`):
``prebuilt/tree_dynamics.so`` beside this file, with a stamp of the source, the flags and the
Pinocchio version it was compiled against. Where that stamp does not match the running Pinocchio
(another ``pin`` installed later, the source edited), it is built on first use (~45 s) with the
system's C++ compiler (``$CXX`` or ``c++``) against the headers and libraries of the installed
``pin`` wheel and Eigen's headers (the ``cmeel-eigen`` wheel), and cached in ``$DELTA_PIN_CACHE``
(default ``~/.cache/delta-pin``) under a name that hashes the same things; it is written
atomically, so parallel processes may build it at once. The library needs no run-time path to
Pinocchio's: ``import pinocchio`` has loaded ``libpinocchio_default`` into the process already.
Where it cannot be built (no compiler, no headers) or
``DELTA_PIN_NATIVE=0``, :func:`load` returns ``None`` after one warning and callers keep the
Python path (the same results, slower).

Example:
    >>> library = load()
    >>> tree = TreeDynamics(library, plant) if library is not None else None
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

from delta_pin.errors import NativeUnavailableError

__all__ = [
    "JOINT_TYPES",
    "STAGES",
    "NativeUnavailableError",
    "TreeDynamics",
    "build",
    "build_prebuilt",
    "load",
]

SOURCE = Path(__file__).with_name("tree_dynamics.cpp")
HEADERS = (Path(__file__).with_name("axis_tree.hpp"),)  # included by SOURCE: part of its stamp
PREBUILT = Path(__file__).with_name("prebuilt")  # the library built at install time, and its stamp
# what pinocchio's CMake targets define for their users (lib/cmake/pinocchio/pinocchioTargets.cmake)
DEFINES = (
    "PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION",
    "BOOST_MPL_LIMIT_LIST_SIZE=30",
    "BOOST_MPL_LIMIT_VECTOR_SIZE=30",
    "BOOST_MPL_CFG_NO_PREPROCESSED_HEADERS",
    "BOOST_FUSION_INVOKE_MAX_ARITY=12",
    "NDEBUG",
)
FLAGS = ("-O2", "-std=c++17", "-fPIC", "-shared", "-Wno-deprecated-declarations")
# the two evaluations of ddq a compiled loop can call: Pinocchio's constraintDynamics (the Python
# loop's arithmetic, bit for bit) and delta-pin's own recursive algorithms (axis_tree.hpp)
STAGES = ("constraint_dynamics", "axis_tree")
JOINT_TYPES = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelPX", "JointModelPY", "JointModelPZ")

_loaded: dict[str, object] = {}


def _prefix() -> Path:
    """The ``cmeel.prefix`` directory of the installed ``pin`` wheel (headers and libraries)."""
    import pinocchio

    for parent in Path(pinocchio.__file__).resolve().parents:
        if parent.name == "cmeel.prefix":
            return parent
    raise NativeUnavailableError(f"pinocchio at {pinocchio.__file__} is not a cmeel wheel: no headers found")


def _cache_dir() -> Path:
    root = os.environ.get("DELTA_PIN_CACHE")
    if root:
        return Path(root)
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "delta-pin"


def _command(prefix: Path, output: Path) -> list[str]:
    compiler = os.environ.get("CXX", "c++")
    if shutil.which(compiler) is None:
        raise NativeUnavailableError(f"no C++ compiler {compiler!r} on PATH (set CXX)")
    include = prefix / "include"
    if not (include / "eigen3" / "Eigen" / "Core").exists():
        raise NativeUnavailableError(f"Eigen's headers are missing under {include} (pip install cmeel-eigen)")
    if not (include / "pinocchio" / "algorithm" / "constrained-dynamics.hpp").exists():
        raise NativeUnavailableError(f"Pinocchio's headers are missing under {include}")
    lib = prefix / "lib"
    return [
        compiler,
        *FLAGS,
        *(f"-D{d}" for d in DEFINES),
        f"-I{include}",
        f"-I{include / 'eigen3'}",
        str(SOURCE),
        "-o",
        str(output),
        f"-L{lib}",
        "-lpinocchio_default",
        f"-Wl,-rpath,{lib}",
    ]


def _source_bytes() -> bytes:
    """The library's source and the headers it includes, as one byte string (what its stamp and
    cache name hash)."""
    return b"".join(path.read_bytes() for path in (SOURCE, *HEADERS))


def _library_path(prefix: Path) -> Path:
    import pinocchio

    key = hashlib.sha256(
        _source_bytes()
        + repr((FLAGS, DEFINES, pinocchio.__version__, str(prefix), os.environ.get("CXX", "c++"))).encode()
    ).hexdigest()[:16]
    return _cache_dir() / f"tree_dynamics-{key}.so"


def _stamp() -> str:
    """What a prebuilt library must have been compiled from: the source, the flags, the Pinocchio
    version (its C++ ABI)."""
    import pinocchio

    return hashlib.sha256(
        _source_bytes() + repr((FLAGS, DEFINES, pinocchio.__version__)).encode()
    ).hexdigest()


def _prebuilt() -> Path | None:
    """The library built at install time, where its stamp matches this Pinocchio and source."""
    library, stamp = PREBUILT / "tree_dynamics.so", PREBUILT / "stamp.txt"
    if library.exists() and stamp.exists() and stamp.read_text().strip() == _stamp():
        return library
    return None


def build_prebuilt(directory: Path = PREBUILT) -> Path:
    """Compile the library into ``directory`` with its stamp (what ``setup.py`` runs at install
    time; the build environment's ``pin`` must be the one installed with the package).

    Raises:
        NativeUnavailableError: no compiler or headers, or the compiler failed.
    """
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "tree_dynamics.so"
    command = [part for part in _command(_prefix(), path) if not part.startswith("-Wl,-rpath")]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise NativeUnavailableError(f"compiling {SOURCE.name} failed:\n{done.stderr[-4000:]}")
    (directory / "stamp.txt").write_text(_stamp() + "\n")
    return path


def build(verbose: bool = False) -> Path:
    """The prebuilt library where it matches, else build it into the cache (if not there yet); its
    path.

    Raises:
        NativeUnavailableError: no compiler or headers, or the compiler failed (its output included).
    """
    prebuilt = _prebuilt()
    if prebuilt is not None:
        return prebuilt
    prefix = _prefix()
    path = _library_path(prefix)
    if path.exists():
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, temporary = tempfile.mkstemp(suffix=".so", dir=path.parent)
    os.close(fd)
    try:
        command = _command(prefix, Path(temporary))
        print(
            f"delta-pin: building the native tree dynamics once (~45 s) into {path.parent}",
            file=sys.stderr,
        )
        if verbose:
            print(" ".join(command), file=sys.stderr)
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise NativeUnavailableError(f"compiling {SOURCE.name} failed:\n{done.stderr[-4000:]}")
        os.chmod(temporary, 0o755)  # mkstemp's 0600 would hide it from other users of the cache
        os.replace(temporary, path)  # atomic: a parallel build writes the same file
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)
    return path


def _declare(library: ctypes.CDLL) -> ctypes.CDLL:
    int_p, double_p, void_p = ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_double), ctypes.c_void_p
    library.dpn_create.restype = void_p
    library.dpn_create.argtypes = [
        ctypes.c_int, int_p, int_p, double_p, double_p, double_p,
        ctypes.c_int, int_p, double_p, ctypes.c_double, ctypes.c_double, ctypes.c_int,
        ctypes.c_char_p, ctypes.c_int,
    ]  # fmt: skip
    library.dpn_destroy.argtypes = [void_p]
    library.dpn_nv.argtypes = [void_p]
    library.dpn_dynamics.restype = ctypes.c_int
    library.dpn_dynamics.argtypes = [
        void_p,
        double_p,
        double_p,
        double_p,
        ctypes.c_double,
        double_p,
        double_p,
    ]
    library.dpn_dynamics_axis.restype = ctypes.c_int
    library.dpn_dynamics_axis.argtypes = library.dpn_dynamics.argtypes
    library.dpn_closure_gap.restype = ctypes.c_double
    library.dpn_closure_gap.argtypes = [void_p, double_p]
    library.dpn_set_active.restype = ctypes.c_int
    library.dpn_set_active.argtypes = [void_p, int_p, int_p, ctypes.c_double, ctypes.c_int, double_p]
    library.dpn_active_dynamics.restype = ctypes.c_int
    library.dpn_active_dynamics.argtypes = [void_p, double_p, double_p, double_p, ctypes.c_double] + [
        double_p
    ] * 4
    return library


def load(strict: bool = False) -> ctypes.CDLL | None:
    """The native library (built on first use), or ``None`` with one warning where it cannot be
    had; ``strict=True`` raises :class:`NativeUnavailableError` instead. ``DELTA_PIN_NATIVE=0`` turns it
    off."""
    if os.environ.get("DELTA_PIN_NATIVE", "1") == "0":
        if strict:
            raise NativeUnavailableError("turned off by DELTA_PIN_NATIVE=0")
        return None
    if "library" not in _loaded:
        try:
            _loaded["library"] = _declare(ctypes.CDLL(str(build())))
        except (NativeUnavailableError, OSError) as exc:
            _loaded["library"] = None
            _loaded["reason"] = str(exc)
            warnings.warn(
                f"delta-pin's native tree dynamics are unavailable, using the Python path: {exc}",
                RuntimeWarning,
                stacklevel=2,
            )
    if _loaded["library"] is None and strict:
        raise NativeUnavailableError(_loaded.get("reason", "unavailable"))
    return _loaded["library"]  # type: ignore[return-value]


def _pointer(array: np.ndarray, kind=ctypes.c_double):
    return array.ctypes.data_as(ctypes.POINTER(kind))


def _placement_numbers(placement) -> np.ndarray:
    return np.concatenate([placement.rotation.ravel(), placement.translation])


class TreeDynamics:
    """A plant's tree and closures in the native library (one ``pin.Data`` of its own).

    Args:
        library: :func:`load`'s library.
        model: the ``pin.Model`` (1-DOF axis joints only).
        constraint_models: its ``RigidConstraintModel`` point closures (CONTACT_3D, LOCAL).
        baumgarte: (Kp, Kd) of the closures' Baumgarte corrector.
        platform_joint: the joint whose body inertia :meth:`dynamics` rewrites with the mass.

    Attributes:
        handle: the address of the C++ tree (for compiled callers); ``address_dynamics``,
            ``address_gap`` and ``address_active``: those of ``dpn_dynamics``,
            ``dpn_closure_gap`` and ``dpn_active_dynamics`` (see
            :mod:`delta_pin.compiled.native.calls`); ``address_dynamics_axis``: that of
            ``dpn_dynamics_axis``, the same accelerations from delta-pin's own recursive
            algorithms for trees of axis joints (``axis_tree.hpp``: equal to
            ``constraintDynamics``' up to rounding, 2.5-3 times cheaper).
    """

    def __init__(self, library, model, constraint_models, baumgarte, platform_joint: int) -> None:
        joints = model.njoints - 1
        types = []
        for i in range(1, model.njoints):
            name = model.joints[i].shortname()
            if name not in JOINT_TYPES:
                raise NativeUnavailableError(
                    f"joint {model.names[i]!r} is a {name}: only {JOINT_TYPES} are native"
                )
            types.append(JOINT_TYPES.index(name))
        parents = np.array([model.parents[i] for i in range(1, model.njoints)], dtype=np.intc)
        placements = np.array([_placement_numbers(model.jointPlacements[i]) for i in range(1, model.njoints)])
        inertias = np.array(
            [
                [model.inertias[i].mass, *model.inertias[i].lever, *model.inertias[i].inertia.ravel()]
                for i in range(1, model.njoints)
            ]
        )
        closure_joints = np.array([[c.joint1_id, c.joint2_id] for c in constraint_models], dtype=np.intc)
        anchors = np.array(
            [
                [*_placement_numbers(c.joint1_placement), *_placement_numbers(c.joint2_placement)]
                for c in constraint_models
            ]
        )
        types_array = np.array(types, dtype=np.intc)
        gravity = np.array(model.gravity.linear, dtype=float)
        message = ctypes.create_string_buffer(512)
        handle = library.dpn_create(
            joints, _pointer(parents, ctypes.c_int), _pointer(types_array, ctypes.c_int),
            _pointer(placements), _pointer(inertias), _pointer(gravity),
            len(constraint_models), _pointer(closure_joints, ctypes.c_int), _pointer(anchors),
            float(baumgarte[0]), float(baumgarte[1]), int(platform_joint), message, len(message),
        )  # fmt: skip
        if not handle:
            raise NativeUnavailableError(f"the native tree could not be built: {message.value.decode()}")
        self._library = library
        self.handle = int(handle)
        self.nv = model.nv
        self.address_dynamics = ctypes.cast(library.dpn_dynamics, ctypes.c_void_p).value
        self.address_dynamics_axis = ctypes.cast(library.dpn_dynamics_axis, ctypes.c_void_p).value
        self.address_gap = ctypes.cast(library.dpn_closure_gap, ctypes.c_void_p).value
        self.address_active = ctypes.cast(library.dpn_active_dynamics, ctypes.c_void_p).value

    def set_active(self, active, platform, q0, tolerance: float = 1e-13, max_iterations: int = 30) -> None:
        """Set up the active coordinates: indices of alpha (3) and of the platform slides (3) in
        q, and restart the completions of q(alpha) from the closed configuration ``q0`` (the
        Newton tolerance [m] and iteration limit of ``DeltaPinocchioModel.configuration``)."""
        active = np.ascontiguousarray(active, dtype=np.intc)
        platform = np.ascontiguousarray(platform, dtype=np.intc)
        q0 = np.ascontiguousarray(q0, dtype=float)
        self._library.dpn_set_active(
            self.handle, _pointer(active, ctypes.c_int), _pointer(platform, ctypes.c_int),
            float(tolerance), int(max_iterations), _pointer(q0),
        )  # fmt: skip

    def active_dynamics(self, alpha, alpha_dot, torque, mass: float, rotational):
        """(alpha_ddot (3,), xyz (3,), closure gap [m]) in active coordinates (after
        :meth:`set_active`) under net active torques [N m] (from Python, for tests)."""
        alpha, alpha_dot, torque = (np.ascontiguousarray(a, dtype=float) for a in (alpha, alpha_dot, torque))
        rotational = np.ascontiguousarray(rotational, dtype=float)
        alpha_ddot, xyz, gap = np.empty(3), np.empty(3), np.empty(1)
        status = self._library.dpn_active_dynamics(
            self.handle, _pointer(alpha), _pointer(alpha_dot), _pointer(torque), float(mass),
            _pointer(rotational), _pointer(alpha_ddot), _pointer(xyz), _pointer(gap),
        )  # fmt: skip
        if status:
            raise RuntimeError(f"dpn_active_dynamics failed with status {status}")
        return alpha_ddot, xyz, float(gap[0])

    def dynamics(self, q, v, tau, mass: float, rotational, stage: str = "constraint_dynamics") -> np.ndarray:
        """ddq (nv,) at (q, v) under joint torques tau (nv,) with platform mass [kg] and
        rotational inertia about the COM (3, 3) [kg m^2] (from Python, for tests):
        with the stage ``stage`` (``"constraint_dynamics"`` or ``"axis_tree"``, see
        :data:`STAGES`)."""
        q, v, tau = (np.ascontiguousarray(a, dtype=float) for a in (q, v, tau))
        rotational = np.ascontiguousarray(rotational, dtype=float)
        ddq = np.empty(self.nv)
        if stage not in STAGES:
            raise ValueError(f"stage={stage!r} must be one of {', '.join(STAGES)}")
        function = self._library.dpn_dynamics_axis if stage == "axis_tree" else self._library.dpn_dynamics
        if function(
            self.handle,
            _pointer(q),
            _pointer(v),
            _pointer(tau),
            float(mass),
            _pointer(rotational),
            _pointer(ddq),
        ):
            raise RuntimeError(f"the native tree dynamics failed (stage {stage})")
        return ddq

    def closure_gap(self, q) -> float:
        """Largest closure gap [m] at q."""
        return self._library.dpn_closure_gap(self.handle, _pointer(np.ascontiguousarray(q, dtype=float)))

    def __del__(self) -> None:
        handle, self.handle = getattr(self, "handle", 0), 0
        if handle:
            self._library.dpn_destroy(handle)

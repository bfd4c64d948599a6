"""The constrained tree dynamics in the compiled core, for the compiled simulation loops.

``pin.constraintDynamics`` costs ~7.6 us per call from Python, a third of it in the binding. The
compiled loops of :mod:`delta_pin.compiled.closed_loop` (the Pinocchio plant in active
coordinates, continuous mode) call C++ directly instead, through the C entry points of
``delta_pin/core/tree_dynamics.cpp`` in the compiled core (:mod:`delta_pin.compiled.core`),
with two evaluations of the constrained tree (:data:`STAGES`): the same explicitly instantiated
``constraintDynamics`` of ``libpinocchio_default`` that the Python binding calls, so the
accelerations agree bit for bit; and ``axis_tree.hpp``, delta-pin's own recursive algorithms for
trees of 1-DOF axis joints, equal to it to ~1e-13 relative at ~40 % of its cost, the default
(tests/sim/test_native.py).

The core is compiled when the package is installed (scikit-build-core, ``CMakeLists.txt``);
nothing is compiled at run time. Where it cannot be imported (built against another Pinocchio, a
broken install) or ``DELTA_PIN_NATIVE=0``, :func:`load` returns ``None`` after one warning and
callers keep the Python path (the same results, slower).

Example:
    >>> library = load()
    >>> tree = TreeDynamics(library, model, constraint_models, (400.0, 40.0), 12) if library else None
"""

from __future__ import annotations

import ctypes
import os
import warnings
from types import SimpleNamespace

import numpy as np

from delta_pin.errors import NativeUnavailableError

__all__ = ["JOINT_TYPES", "STAGES", "NativeUnavailableError", "TreeDynamics", "load"]

# the two evaluations of ddq a compiled loop can call: Pinocchio's constraintDynamics (the Python
# loop's arithmetic, bit for bit) and delta-pin's own recursive algorithms (axis_tree.hpp)
STAGES = ("constraint_dynamics", "axis_tree")
JOINT_TYPES = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelPX", "JointModelPY", "JointModelPZ")

_loaded: dict[str, object] = {}


def _declare(addresses: dict[str, int]) -> SimpleNamespace:
    """ctypes functions at the core's C entry points (``_core.symbols()``), for calls from Python;
    ``addresses`` stay available to compiled callers."""
    int_p, double_p, void_p = ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_double), ctypes.c_void_p
    dynamics = [void_p, double_p, double_p, double_p, ctypes.c_double, double_p, double_p]
    prototypes = {
        "dpn_create": (void_p, [
            ctypes.c_int, int_p, int_p, double_p, double_p, double_p,
            ctypes.c_int, int_p, double_p, ctypes.c_double, ctypes.c_double, ctypes.c_int,
            ctypes.c_char_p, ctypes.c_int,
        ]),
        "dpn_destroy": (None, [void_p]),
        "dpn_nv": (ctypes.c_int, [void_p]),
        "dpn_dynamics": (ctypes.c_int, dynamics),
        "dpn_dynamics_axis": (ctypes.c_int, dynamics),
        "dpn_closure_gap": (ctypes.c_double, [void_p, double_p]),
        "dpn_set_active": (ctypes.c_int, [void_p, int_p, int_p, ctypes.c_double, ctypes.c_int, double_p]),
        "dpn_active_dynamics": (ctypes.c_int, [void_p, double_p, double_p, double_p, ctypes.c_double]
                                + [double_p] * 4),
    }  # fmt: skip
    functions = {
        name: ctypes.CFUNCTYPE(restype, *argtypes)(addresses[name])
        for name, (restype, argtypes) in prototypes.items()
    }
    return SimpleNamespace(addresses=dict(addresses), **functions)


def load(strict: bool = False) -> SimpleNamespace | None:
    """The core's tree dynamics (ctypes functions and their ``addresses``), or ``None`` with one
    warning where the core cannot be imported; ``strict=True`` raises
    :class:`NativeUnavailableError` instead. ``DELTA_PIN_NATIVE=0`` turns it off."""
    if os.environ.get("DELTA_PIN_NATIVE", "1") == "0":
        if strict:
            raise NativeUnavailableError("turned off by DELTA_PIN_NATIVE=0")
        return None
    if "library" not in _loaded:
        from delta_pin.compiled.core import core

        try:
            _loaded["library"] = _declare(core().symbols())
        except NativeUnavailableError as exc:
            _loaded["library"] = None
            _loaded["reason"] = str(exc)
            warnings.warn(
                f"delta-pin's compiled tree dynamics are unavailable, using the Python path: {exc}",
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
        self.address_dynamics = library.addresses["dpn_dynamics"]
        self.address_dynamics_axis = library.addresses["dpn_dynamics_axis"]
        self.address_gap = library.addresses["dpn_closure_gap"]
        self.address_active = library.addresses["dpn_active_dynamics"]

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

"""One declaration per built-in controller: what it is called, how it is built from a nominal model
and the run's options, and what it can do. The CLI, :class:`~delta_pin.studies.experiments.RunSpec`,
``run --robot``, the sweeps' cost estimate and the studies' labels read these declarations instead
of testing names; the names alone live in :data:`delta_pin.choices.CONTROLLERS` (so ``--help``
lists them without importing this), in the same order.

Adding a built-in law: its module in :mod:`delta_pin.control`, one :class:`ControllerDeclaration`
in :data:`CONTROLLERS` and its name in :data:`delta_pin.choices.CONTROLLERS`. A user's own
:class:`~delta_pin.control.base.Controller` needs none of this: :func:`delta_pin.simulate` takes it
as it is.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable, Mapping

import numpy as np

import delta_pin.control
from delta_pin.choices import CONTROLLERS as NAMES
from delta_pin.control.adaptive_robust import AdaptiveRobustController, design1, design2
from delta_pin.control.base import Controller
from delta_pin.control.baselines import LQR, ComputedTorque, PDGravity
from delta_pin.control.declaration import (
    FRICTION_COMPENSATION,
    SAMPLING_AWARE,
    ControllerDeclaration,
    LawOptions,
)
from delta_pin.control.digital import TimeDelayControl, tdc
from delta_pin.control.digital_robust import DigitalRobustController, digital_robust
from delta_pin.control.nominal import NominalModel
from delta_pin.errors import InvalidParameterError

__all__ = ["CONTROLLERS", "ControllerDeclaration", "LawOptions", "declaration", "label"]


def _design(make: Callable) -> Callable:
    def build(nominal: NominalModel, options: LawOptions, gains: Mapping) -> Controller:
        period = options.dt if options.sampling_aware else None
        return make(
            nominal, sampling_period=period, friction_compensation=options.friction_compensation, **gains
        )

    return build


def _with_friction(law: type[Controller]) -> Callable:
    def build(nominal: NominalModel, options: LawOptions, gains: Mapping) -> Controller:
        return law(nominal, friction_compensation=options.friction_compensation, **gains)

    return build


def _lqr(nominal: NominalModel, options: LawOptions, gains: Mapping) -> Controller:
    start = np.asarray(options.start, dtype=float)
    return LQR(nominal, start, friction_compensation=options.friction_compensation, **gains)


def _tdc(nominal: NominalModel, options: LawOptions, gains: Mapping) -> Controller:
    return tdc(nominal, options.dt, delay=options.delay, **gains)


def _digital_robust(nominal: NominalModel, options: LawOptions, gains: Mapping) -> Controller:
    return digital_robust(
        nominal, options.dt, delay=options.delay, torque_limit=options.torque_limit,
        friction_compensation=options.friction_compensation, **gains,
    )  # fmt: skip


_FC = frozenset({FRICTION_COMPENSATION})
_DECLARATIONS = (
    ControllerDeclaration(
        "design1", "design I", AdaptiveRobustController, _design(design1),
        options=_FC | {SAMPLING_AWARE}, compiled_continuous=True, batchable=True, run_name="designI",
    ),
    ControllerDeclaration(
        "design2", "design II", AdaptiveRobustController, _design(design2),
        options=_FC | {SAMPLING_AWARE}, compiled_continuous=True, batchable=True, run_name="designII",
    ),
    ControllerDeclaration("lqr", "LQR", LQR, _lqr, options=_FC, compiled_continuous=True, needs_start=True),
    ControllerDeclaration(
        "ctc", "CTC", ComputedTorque, _with_friction(ComputedTorque), options=_FC,
        compiled_continuous=True,
    ),
    ControllerDeclaration(
        "pd", "PD", PDGravity, _with_friction(PDGravity), options=_FC, compiled_continuous=True
    ),
    ControllerDeclaration("tdc", "TDC", TimeDelayControl, _tdc, discrete=True),
    ControllerDeclaration(
        "digital-robust", "digital robust", DigitalRobustController, _digital_robust, options=_FC,
        discrete=True,
    ),
)  # fmt: skip


def _declared_by_their_modules() -> tuple[ControllerDeclaration, ...]:
    """The declarations of the laws that declare themselves: a module of :mod:`delta_pin.control`
    with a module-level ``DECLARATION`` (adding a law needs no edit here)."""
    found = []
    for info in pkgutil.iter_modules(delta_pin.control.__path__):
        if info.name in ("registry", "declaration") or info.name.startswith("_"):
            continue
        found.append(getattr(importlib.import_module(f"delta_pin.control.{info.name}"), "DECLARATION", None))
    return tuple(d for d in found if isinstance(d, ControllerDeclaration))


_DECLARATIONS = _DECLARATIONS + _declared_by_their_modules()
CONTROLLERS: dict[str, ControllerDeclaration] = {
    d.name: d
    for d in sorted(_DECLARATIONS, key=lambda d: NAMES.index(d.name) if d.name in NAMES else len(NAMES))
}
if tuple(CONTROLLERS) != NAMES:  # one list of names: choices.CONTROLLERS, in this order
    raise ImportError(
        f"delta_pin.choices.CONTROLLERS {NAMES} and the declarations {tuple(CONTROLLERS)} differ"
    )


def declaration(name: str) -> ControllerDeclaration:
    """The declaration of the built-in controller ``name``.

    Raises:
        InvalidParameterError: an unknown name (the line lists the known ones).
    """
    try:
        return CONTROLLERS[name]
    except (KeyError, TypeError):
        raise InvalidParameterError(f"controller {name!r} must be one of {', '.join(NAMES)}") from None


_LABELS = {
    **{d.name: d.label for d in _DECLARATIONS},
    **{d.run_name: d.label for d in _DECLARATIONS if d.run_name},
}


def label(name: str | None) -> str:
    """The figures' name of a built-in controller, by its CLI name or the name its runs carry
    (``"design1"`` or ``"designI"``: ``"design I"``); any other name as it is."""
    return _LABELS.get(name, str(name) if name else "controller")

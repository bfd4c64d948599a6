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

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from delta_pin.choices import CONTROLLERS as NAMES
from delta_pin.control.adaptive_robust import AdaptiveRobustController, design1, design2
from delta_pin.control.base import Controller
from delta_pin.control.baselines import LQR, ComputedTorque, PDGravity
from delta_pin.control.digital import TimeDelayControl, tdc
from delta_pin.control.digital_robust import DigitalRobustController, digital_robust
from delta_pin.control.nominal import NominalModel
from delta_pin.errors import InvalidParameterError

__all__ = ["CONTROLLERS", "ControllerDeclaration", "LawOptions", "declaration", "label"]

FRICTION_COMPENSATION = "friction_compensation"
SAMPLING_AWARE = "sampling_aware"


@dataclass(frozen=True)
class LawOptions:
    """What a run tells the law it builds (SI units).

    Attributes:
        dt: the sample / control period [s].
        friction_compensation: add the nominal friction M̄_f (laws that have it).
        sampling_aware: cap the robust gain for a zero-order-hold loop of period dt (designs I/II).
        delay: samples of computation delay the drive adds (a digital law is told it).
        torque_limit: the drive's saturation [N m] (a digital law is told it); None: none.
        start: the actuated coordinates the LQR is linearised at [rad or m] (the path's start, or
            a closed chain's home).
    """

    dt: float = 1e-3
    friction_compensation: bool = True
    sampling_aware: bool = False
    delay: int = 0
    torque_limit: object = None
    start: np.ndarray | None = None


@dataclass(frozen=True)
class ControllerDeclaration:
    """A built-in controller as the run-time reads it.

    Attributes:
        name: the CLI's and :class:`~delta_pin.studies.experiments.RunSpec`'s name.
        label: its name in figures and tables (e.g. ``"design I"``).
        law: the class the factory returns (its constructor's keywords are the gains).
        build: ``build(nominal, options, gains) -> Controller``.
        options: which of :class:`LawOptions`' switches (``"friction_compensation"``,
            ``"sampling_aware"``) the law has; a command that runs this law alone refuses another
            (:meth:`check_options`) instead of ignoring it.
        discrete: a law of period dt (sampled mode only).
        compiled_continuous: the compiled core's continuous loop (Radau IIA, BDF2) runs its
            compiled law (otherwise a continuous run calls the Python law back).
        batchable: several runs of it share one batched simulation in sweeps (designs I/II).
        needs_start: its construction needs :attr:`LawOptions.start` (the LQR).
        run_name: the ``name`` its controllers carry in a run's metadata, where it differs from
            :attr:`name` (designs I/II: ``"designI"``).
    """

    name: str
    label: str
    law: type[Controller]
    build: Callable[[NominalModel, LawOptions, Mapping], Controller] = field(repr=False)
    options: frozenset[str] = frozenset()
    discrete: bool = False
    compiled_continuous: bool = False
    batchable: bool = False
    needs_start: bool = False
    run_name: str = ""

    def make(self, nominal: NominalModel, options: LawOptions | None = None, **gains) -> Controller:
        """The controller on ``nominal`` with ``options`` and gain overrides by name. A switch of
        ``options`` the law does not have is not applicable to it (a study of several laws sets it
        for those that have it); a command that runs one law refuses it (:meth:`check_options`).

        Raises:
            InvalidParameterError: no start for the LQR, or a gain the law refuses.
        """
        options = options or LawOptions()
        if self.needs_start and options.start is None:
            raise InvalidParameterError(f"controller {self.name!r} needs the start it is linearised at")
        return self.build(nominal, options, gains)

    def check_options(self, *, friction_compensation: bool = True, sampling_aware: bool = False) -> None:
        """Refuse a switch this law does not take (one line naming it and the laws that do).

        Raises:
            InvalidParameterError: ``friction_compensation=False`` or ``sampling_aware=True`` for a
                law without that switch.
        """
        asked = {FRICTION_COMPENSATION: not friction_compensation, SAMPLING_AWARE: sampling_aware}
        for option, set_ in asked.items():
            if set_ and option not in self.options:
                takers = ", ".join(d.name for d in CONTROLLERS.values() if option in d.options)
                value = "False" if option == FRICTION_COMPENSATION else "True"
                raise InvalidParameterError(
                    f"controller {self.name!r} has no {option} switch ({option}={value} would be "
                    f"ignored); the laws that have it: {takers}"
                )


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
CONTROLLERS: dict[str, ControllerDeclaration] = {d.name: d for d in _DECLARATIONS}
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

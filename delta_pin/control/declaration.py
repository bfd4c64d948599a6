"""What a controller declares about itself (:class:`ControllerDeclaration`) and the run's options
it is built with (:class:`LawOptions`): the vocabulary of :mod:`delta_pin.control.registry`, kept
apart so that a law's own module can declare itself (a module-level ``DECLARATION``) without
importing the registry that collects it."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from delta_pin.control.base import Controller
from delta_pin.control.nominal import NominalModel
from delta_pin.errors import InvalidParameterError

__all__ = ["FRICTION_COMPENSATION", "SAMPLING_AWARE", "ControllerDeclaration", "LawOptions"]

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

    def gain_names(self) -> list[str]:
        """The gains the law takes by name (``--param``, ``RunSpec.gains``): its constructor's
        keywords less the nominal model, the run's own options and the switches, with a gains
        dataclass (designs I/II's ``gains=``) expanded into its fields."""
        import dataclasses
        import inspect
        import typing

        taken = {"self", "nominal", "design", "dt", "delay", "torque_limit", "alpha_linearisation",
                 "sampling_period", FRICTION_COMPENSATION}  # fmt: skip
        names = []
        hints = typing.get_type_hints(self.law.__init__)
        for name in inspect.signature(self.law).parameters:
            if name in taken:
                continue
            kind = hints.get(name)
            for candidate in typing.get_args(kind) or (kind,):
                if dataclasses.is_dataclass(candidate):
                    names += [f.name for f in dataclasses.fields(candidate)]
                    break
            else:
                names.append(name)
        return names

    def check_options(self, *, friction_compensation: bool = True, sampling_aware: bool = False) -> None:
        """Refuse a switch this law does not take (one line naming it and the laws that do).

        Raises:
            InvalidParameterError: ``friction_compensation=False`` or ``sampling_aware=True`` for a
                law without that switch.
        """
        asked = {FRICTION_COMPENSATION: not friction_compensation, SAMPLING_AWARE: sampling_aware}
        for option, set_ in asked.items():
            if set_ and option not in self.options:
                value = "False" if option == FRICTION_COMPENSATION else "True"
                has = ", ".join(sorted(self.options)) or "none"
                raise InvalidParameterError(
                    f"controller {self.name!r} has no {option} switch ({option}={value} would be "
                    f"ignored); its switches: {has}"
                )

"""The controller interface every control law implements.

A controller maps (t [s], alpha [rad], alpha_dot [rad/s], reference, internal state) to joint
torques tau [N m] and to the evolution of its internal state. Two kinds of state:

* continuous-time (e.g. the bound estimate rho_hat of the adaptive law, eqs. 24-25): the
  controller returns its time derivative; the simulator integrates it with the plant in
  ``continuous`` mode and advances it once per period, z_{k+1} = z_k + T z_dot_k, in ``sampled``
  mode;
* discrete-time (a digital law with period :attr:`Controller.dt`): the controller returns the
  next state itself (:attr:`ControlOutput.next_state`), used once per sample.

Keeping the state explicit lets the same law run inside :func:`~delta_pin.sim.runner.simulate`
and sample by sample outside it (:meth:`Controller.step`), the way a drive calls a controller.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from delta_pin.errors import InvalidParameterError

__all__ = [
    "CallableController",
    "CompiledController",
    "ControlOutput",
    "Controller",
    "Reference",
    "as_controller",
    "check_delay",
    "check_period",
    "check_torque_limit",
]


def check_period(dt: float) -> float:
    """A sample period [s]: a finite number > 0."""
    number = isinstance(dt, int | float | np.floating) and not isinstance(dt, bool)
    if not (number and math.isfinite(dt) and dt > 0.0):
        raise InvalidParameterError(f"dt={dt!r} must be a positive sample period [s]")
    return float(dt)


def check_delay(delay: int) -> int:
    """Samples of computation delay: an integer >= 0."""
    if not (isinstance(delay, int | np.integer) and not isinstance(delay, bool) and delay >= 0):
        raise InvalidParameterError(f"delay={delay!r} must be an integer number of samples >= 0")
    return int(delay)


def check_torque_limit(torque_limit, dof: int) -> np.ndarray | None:
    """The drive's torque limit per joint (dof,) [N m] (positive), or ``None`` for none."""
    if torque_limit is None:
        return None
    limit = np.broadcast_to(np.asarray(torque_limit, dtype=float), (dof,)).copy()
    if not (np.all(np.isfinite(limit)) and np.all(limit > 0.0)):
        raise InvalidParameterError(
            f"torque_limit={torque_limit!r} must be positive [N m], one value or one per joint"
        )
    return limit


@dataclass(frozen=True)
class Reference:
    """Desired joint motion at one instant: alpha^d [rad], alpha_dot^d [rad/s], alpha_ddot^d [rad/s^2]."""

    alpha: np.ndarray
    alpha_dot: np.ndarray
    alpha_ddot: np.ndarray

    @classmethod
    def hold(cls, alpha: np.ndarray) -> Reference:
        """A set point: hold ``alpha`` with zero velocity and acceleration."""
        zero = np.zeros_like(np.asarray(alpha, dtype=float))
        return cls(np.asarray(alpha, dtype=float), zero, zero)


@dataclass
class ControlOutput:
    """What a controller returns at one instant.

    Attributes:
        tau: joint torques (n,) [N m].
        state_derivative: time derivative of a continuous-time internal state (empty for
            stateless laws).
        internals: named quantities to record (e.g. ``rho_hat``, ``Lambda``, ``phi``).
        next_state: the internal state at the next sample, for a discrete-time controller
            (``None`` for a continuous-time one).
    """

    tau: np.ndarray
    state_derivative: np.ndarray = field(default_factory=lambda: np.zeros(0))
    internals: dict[str, float | np.ndarray] = field(default_factory=dict)
    next_state: np.ndarray | None = None


class Controller(ABC):
    """Base of every control law. Subclasses implement :meth:`evaluate` (and, if they carry an
    internal state, :meth:`initial_state`).

    Attributes:
        dt: the sample period [s] of a discrete-time controller (``None``: a continuous-time law,
            which runs at any period).
        delay: samples of computation delay the law accounts for (its torque computed at sample k
            acts from sample k + delay); ``simulate`` checks that its own delay matches.
    """

    name: str = "controller"
    dt: float | None = None
    delay: int = 0

    def initial_state(self) -> np.ndarray:
        """Internal state at t = 0 (empty for stateless controllers)."""
        return np.zeros(0)

    @abstractmethod
    def evaluate(
        self,
        t: float,
        alpha: np.ndarray,
        alpha_dot: np.ndarray,
        reference: Reference,
        state: np.ndarray,
    ) -> ControlOutput:
        """Torque and state derivative at time ``t`` [s] for the given internal ``state``."""

    def reset(self) -> None:
        """Restore the internal state to :meth:`initial_state` (and forget the previous sample of
        :meth:`step`)."""
        self.state = self.initial_state()
        self._previous_sample: tuple[float, np.ndarray, ControlOutput] | None = None

    def sampled_core_law(self):
        """This law in the compiled core for the sampled loop (``delta_pin/core/run/controller.hpp``),
        or ``None`` (the default): the loop then calls :meth:`evaluate` back from the core once
        per sample."""
        return None

    def core_law_internals(self, law) -> dict[str, np.ndarray]:
        """The internals (N, ...) that :meth:`evaluate` would have recorded, read from the records
        of :meth:`sampled_core_law`'s law after a run: its ``records`` by name (the compiled law
        names them; none for a law without any)."""
        return {name: np.array(value) for name, value in getattr(law, "records", {}).items()}

    def advance(self, state: np.ndarray, output: ControlOutput, period: float) -> np.ndarray:
        """The internal state one sample of ``period`` [s] later: the discrete-time law's
        ``next_state``, or z + period z_dot for a continuous-time one (explicit Euler, as a drive
        that integrates once per sample)."""
        if output.next_state is not None:
            return np.asarray(output.next_state, dtype=float)
        if len(state) == 0:
            return state
        return state + period * np.asarray(output.state_derivative, dtype=float)

    def estimate_velocity(
        self, alpha_measured: np.ndarray, previous_measured: np.ndarray | None, period: float
    ) -> np.ndarray:
        """The joint velocity [rad/s] this controller uses when none is measured: the backward
        difference of the measured angles over ``period`` [s] (zero at the first sample).
        A controller with an observer overrides this."""
        if previous_measured is None or not period > 0.0:
            return np.zeros_like(alpha_measured)
        return (alpha_measured - previous_measured) / period

    def step(
        self,
        t: float,
        alpha_measured: np.ndarray,
        reference: Reference,
        alpha_dot_measured: np.ndarray | None = None,
    ) -> np.ndarray:
        """One sample of the controller, called the way a drive or another simulator calls it:
        :meth:`reset` once, then ``tau = ctrl.step(t, alpha_measured, reference)`` at every
        sample.

        Args:
            t: the sample's time [s].
            alpha_measured: the measured joint angles [rad] (e.g. encoder readings).
            reference: the desired motion at ``t`` (:class:`Reference`).
            alpha_dot_measured: measured joint velocities [rad/s], or ``None``: then the backward
                difference of the measured angles over the period (zero at the first sample).

        Returns:
            The torque [N m] to apply (from sample k + :attr:`delay` on a delayed drive).

        The internal state advances once per sample by :meth:`advance`, at the start of the next
        call: over :attr:`dt` or, for a continuous-time law, over the time since the previous call
        (z_k = z_{k-1} + T z_dot_{k-1}, as ``simulate``'s sampled loop). A built-in law evaluates
        its compiled copy, the one ``simulate`` runs (:class:`CompiledController`); a law of your
        own its :meth:`evaluate`.
        """
        if not hasattr(self, "state"):
            self.reset()
        alpha, alpha_dot_measured, reference = self._checked_sample(
            t, alpha_measured, alpha_dot_measured, reference
        )
        previous = self._previous_sample
        period = 0.0
        if previous is not None:
            previous_t, previous_alpha, previous_output = previous
            period = self.dt if self.dt is not None else t - previous_t
            # the state reaches this sample: z_k = z_{k-1} + T z_dot_{k-1}, or the law's next state
            self.state = self.advance(self.state, previous_output, period)
        if alpha_dot_measured is not None:
            alpha_dot = np.asarray(alpha_dot_measured, dtype=float)
        else:
            alpha_dot = self.estimate_velocity(alpha, None if previous is None else previous_alpha, period)
        output = self.evaluate(t, alpha, alpha_dot, reference, self.state)
        self._previous_sample = (t, alpha, output)
        return np.asarray(output.tau, dtype=float)

    @property
    def dof(self) -> int | None:
        """Joints the law drives: its nominal model's (``None`` for a law without one)."""
        nominal = getattr(self, "nominal", None)
        return None if nominal is None else int(nominal.dof)

    def _checked_sample(self, t, alpha, alpha_dot, reference) -> tuple:
        """The inputs of :meth:`step` as float arrays, each checked before it reaches compiled
        code: a finite time after the previous sample's, and finite vectors of one length each
        (the law's ``dof`` where it declares one).

        Raises:
            InvalidParameterError: naming the input and what would work.
        """
        try:
            time_now = float(t)
        except (TypeError, ValueError):
            raise InvalidParameterError(f"t={t!r} must be a time in seconds") from None
        previous = self._previous_sample
        if not math.isfinite(time_now) or (previous is not None and not time_now > previous[0]):
            after = "" if previous is None else f" after the previous sample's t={previous[0]:g}"
            raise InvalidParameterError(f"t={t!r} must be a finite time [s]{after}")
        n = self.dof
        if n is None:
            n = np.asarray(alpha).size

        def vector(value, name: str) -> np.ndarray:
            array = np.array(value, dtype=float)
            if array.shape != (n,) or not np.isfinite(array).all():
                raise InvalidParameterError(
                    f"{name}={np.asarray(value).tolist()!r} must be {n} finite numbers (one per joint of "
                    f"{self.name!r})"
                )
            return array

        if not isinstance(reference, Reference):
            raise InvalidParameterError(
                f"reference={reference!r} must be a delta_pin Reference(alpha, alpha_dot, alpha_ddot)"
            )
        checked = Reference(
            vector(reference.alpha, "reference.alpha"),
            vector(reference.alpha_dot, "reference.alpha_dot"),
            vector(reference.alpha_ddot, "reference.alpha_ddot"),
        )
        rate = None if alpha_dot is None else vector(alpha_dot, "alpha_dot_measured")
        return vector(alpha, "alpha_measured"), rate, checked

    def torque(self, t: float, alpha: np.ndarray, alpha_dot: np.ndarray, reference: Reference) -> np.ndarray:
        """Torque [N m] with the controller's current internal state (call :meth:`reset` first)."""
        if not hasattr(self, "state"):
            self.reset()
        return self.evaluate(t, alpha, alpha_dot, reference, self.state).tau

    def metadata(self) -> dict:
        """JSON-serialisable description (name and gains) stored with every run."""
        return {"name": self.name}


class CompiledController(Controller):
    """A built-in law: its arithmetic is the compiled core's (:meth:`sampled_core_law`, the law
    ``simulate`` runs, ``delta_pin/core/run/controller.hpp``), and :meth:`evaluate` is one
    evaluation of it -- no internals (a run records them: :meth:`core_law_internals`). The
    readable Python law it is tested against lives in ``tests/reference/laws.py``."""

    def evaluate(self, t, alpha, alpha_dot, reference, state) -> ControlOutput:
        """Torque [N m] and the state's derivative (or a discrete-time law's next state) at
        (alpha [rad], alpha_dot [rad/s]) along ``reference`` from ``state``, by the compiled law
        (built at the first call; its nominal model's assembly warm-started from the last)."""
        law = self.__dict__.get("_compiled")
        if law is None:
            law = self._compiled = self.sampled_core_law()
            if law is None:
                raise InvalidParameterError(
                    f"controller {self.name!r} has no compiled law (sampled_core_law() is None): a law of "
                    "your own subclasses Controller and defines evaluate()"
                )
        tau, rate = law.evaluate(
            np.asarray(alpha, dtype=float), np.asarray(alpha_dot, dtype=float),
            np.asarray(reference.alpha, dtype=float), np.asarray(reference.alpha_dot, dtype=float),
            np.asarray(reference.alpha_ddot, dtype=float), np.asarray(state, dtype=float),
        )  # fmt: skip
        if law.discrete:  # a discrete-time law returns its next state
            return ControlOutput(np.asarray(tau), next_state=np.asarray(rate))
        return ControlOutput(np.asarray(tau), state_derivative=np.asarray(rate))


class CallableController(Controller):
    """Wraps a plain function ``f(t, alpha, alpha_dot) -> tau`` as a stateless controller."""

    def __init__(self, function: Callable[[float, np.ndarray, np.ndarray], np.ndarray]) -> None:
        self.function = function
        self.name = getattr(function, "__name__", "callable")

    def evaluate(self, t, alpha, alpha_dot, reference, state) -> ControlOutput:
        return ControlOutput(np.asarray(self.function(t, alpha, alpha_dot), dtype=float))


class NoTorque(Controller):
    """Zero torque on every actuated joint: a free motion (a mechanism without motors, or a robot
    with its motors off). What :func:`~delta_pin.sim.runner.simulate` runs for ``controller=None``."""

    def __init__(self, dof: int) -> None:
        self._zeros = np.zeros(int(dof))
        self.name = "no torque"

    def evaluate(self, t, alpha, alpha_dot, reference, state) -> ControlOutput:
        return ControlOutput(self._zeros.copy())


def as_controller(controller: Controller | Callable) -> Controller:
    """Return ``controller`` itself, or a :class:`CallableController` around a function."""
    if isinstance(controller, Controller):
        return controller
    if callable(controller):
        return CallableController(controller)
    raise TypeError(
        f"controller must be a Controller or a callable f(t, alpha, alpha_dot), got {controller!r}"
    )

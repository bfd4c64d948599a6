"""The controller interface every control law implements.

A controller maps (t [s], alpha [rad], alpha_dot [rad/s], reference, internal state) to joint
torques tau [N m] and to the time derivative of its internal state (e.g. the bound estimate
rho_hat of the adaptive law, eqs. 24-25). Keeping the state explicit lets the simulator integrate
it with the plant in ``continuous`` mode and advance it once per period in ``sampled`` mode.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

__all__ = ["CallableController", "ControlOutput", "Controller", "Reference", "as_controller"]


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
        state_derivative: time derivative of the internal state (empty for stateless laws).
        internals: named quantities to record (e.g. ``rho_hat``, ``Lambda``, ``phi``).
    """

    tau: np.ndarray
    state_derivative: np.ndarray = field(default_factory=lambda: np.zeros(0))
    internals: dict[str, float | np.ndarray] = field(default_factory=dict)


class Controller(ABC):
    """Base of every control law. Subclasses implement :meth:`evaluate` (and, if they carry an
    internal state, :meth:`initial_state`)."""

    name: str = "controller"

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
        """Restore the internal state to :meth:`initial_state`."""
        self.state = self.initial_state()

    def torque(self, t: float, alpha: np.ndarray, alpha_dot: np.ndarray, reference: Reference) -> np.ndarray:
        """Torque [N m] with the controller's current internal state (call :meth:`reset` first)."""
        if not hasattr(self, "state"):
            self.reset()
        return self.evaluate(t, alpha, alpha_dot, reference, self.state).tau

    def metadata(self) -> dict:
        """JSON-serialisable description (name and gains) stored with every run."""
        return {"name": self.name}


class CallableController(Controller):
    """Wraps a plain function ``f(t, alpha, alpha_dot) -> tau`` as a stateless controller."""

    def __init__(self, function: Callable[[float, np.ndarray, np.ndarray], np.ndarray]) -> None:
        self.function = function
        self.name = getattr(function, "__name__", "callable")

    def evaluate(self, t, alpha, alpha_dot, reference, state) -> ControlOutput:
        return ControlOutput(np.asarray(self.function(t, alpha, alpha_dot), dtype=float))


def as_controller(controller: Controller | Callable) -> Controller:
    """Return ``controller`` itself, or a :class:`CallableController` around a function."""
    if isinstance(controller, Controller):
        return controller
    if callable(controller):
        return CallableController(controller)
    raise TypeError(
        f"controller must be a Controller or a callable f(t, alpha, alpha_dot), got {controller!r}"
    )

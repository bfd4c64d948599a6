"""What a digital drive adds to the sampled loop: an encoder, a computation delay, a torque limit.

docs/architecture.md section 6. In ``simulate(..., mode="sampled")`` the controller sees the
:class:`Encoder`'s reading at each sample t_k = k dt; the torque it computes at sample k acts on
the plant from sample k + ``delay`` (held, zero-order, until replaced); the drive saturates each
joint's torque at ``torque_limit``. The plant is integrated between samples as before.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from delta_pin.choices import VELOCITIES
from delta_pin.control.base import check_delay, check_torque_limit
from delta_pin.errors import InvalidParameterError

__all__ = ["VELOCITIES", "Drive", "Encoder", "check_delay", "check_torque_limit"]


@dataclass
class Encoder:
    """An absolute encoder on each active joint.

    Attributes:
        bits: counts per turn are 2^bits (8-32): the position reads round(alpha / q) q with
            q = 2 pi / 2^bits [rad] (17 bits: q = 4.8e-5 rad).
        velocity: what the controller gets as velocity: ``"difference"`` the backward difference
            of the readings over the sample period (zero at the first sample), ``"none"`` nothing
            (the controller estimates it: :meth:`Controller.step
            <delta_pin.control.base.Controller.step>` differences the readings itself), or
            ``"exact"`` the true velocity.
        noise: standard deviation [rad] of Gaussian noise added to the angle before it is
            quantised (0: none).
        seed: seed of the noise (``None``: fresh entropy; recorded in the run's metadata).
    """

    bits: int = 17
    velocity: str = "difference"
    noise: float = 0.0
    seed: int | None = None
    _rng: np.random.Generator = field(init=False, repr=False)
    _previous: np.ndarray | None = field(init=False, repr=False, default=None)

    def __post_init__(self) -> None:
        if not (isinstance(self.bits, int) and 8 <= self.bits <= 32):
            raise InvalidParameterError(f"Encoder bits={self.bits!r} must be an integer from 8 to 32")
        if self.velocity not in VELOCITIES:
            raise InvalidParameterError(
                f"Encoder velocity={self.velocity!r} must be one of {', '.join(VELOCITIES)}"
            )
        if not (math.isfinite(self.noise) and self.noise >= 0.0):
            raise InvalidParameterError(
                f"Encoder noise={self.noise!r} must be a finite standard deviation >= 0 [rad]"
            )
        if self.seed is None and self.noise > 0.0:
            self.seed = int(np.random.SeedSequence().entropy % 2**63)
        self.reset()

    @property
    def resolution(self) -> float:
        """One count [rad]."""
        return 2.0 * math.pi / 2**self.bits

    def reset(self) -> None:
        """Start again: no previous reading, the noise from its seed."""
        self._rng = np.random.default_rng(self.seed)
        self._previous = None

    def read(
        self, alpha: np.ndarray, alpha_dot: np.ndarray, dt: float
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """(measured angles [rad], velocity [rad/s] or ``None``) at one sample of period dt [s]."""
        angle = alpha + self._rng.normal(0.0, self.noise, alpha.shape) if self.noise > 0.0 else alpha
        measured = np.round(angle / self.resolution) * self.resolution
        if self.velocity == "exact":
            velocity = np.array(alpha_dot, dtype=float)
        elif self.velocity == "difference":
            velocity = np.zeros_like(measured) if self._previous is None else (measured - self._previous) / dt
        else:
            velocity = None
        self._previous = measured
        return measured, velocity

    def metadata(self) -> dict:
        return {"bits": self.bits, "velocity": self.velocity, "noise": self.noise, "seed": self.seed}


class Drive:
    """The torque path of a digital drive: computation delay, then saturation.

    :meth:`apply` takes the torque a controller computed at sample k and returns the torque that
    acts on the plant from sample k: the command of sample k - ``delay`` (zero before the first
    one arrives), clipped to +-``torque_limit``. ``hits`` counts the samples at which the limit
    bound on at least one joint.
    """

    def __init__(self, dof: int, delay: int = 0, torque_limit=None) -> None:
        self.delay = check_delay(delay)
        self.torque_limit = check_torque_limit(torque_limit, dof)
        self._pending = deque(np.zeros(dof) for _ in range(self.delay))
        self.hits = 0

    def apply(self, command: np.ndarray) -> np.ndarray:
        """The torque [N m] acting from this sample on."""
        self._pending.append(command)
        torque = self._pending.popleft()
        if self.torque_limit is not None:
            clipped = np.clip(torque, -self.torque_limit, self.torque_limit)
            if np.any(clipped != torque):
                self.hits += 1
            torque = clipped
        return torque

    def metadata(self) -> dict:
        return {
            "delay": self.delay,
            "torque_limit": None if self.torque_limit is None else self.torque_limit.tolist(),
            "torque_limit_hits": self.hits,
        }

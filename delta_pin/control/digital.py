"""Discrete-time laws for a digital drive: time-delay control (TDC), a baseline for issue 13.

Time-delay estimation (Youcef-Toumi & Ito 1990) writes the robot as M̄ alpha_ddot + N = tau,
where N lumps everything M̄ does not describe (Coriolis, gravity, friction, the disturbance and
the model error of M̄), and estimates N from the last sample, where the torque and the
acceleration are known:

    N̂_k = tau_{k-1} - M̄ alpha_ddot_{k-1},  alpha_ddot_{k-1} = (alpha_k - 2 alpha_{k-1} + alpha_{k-2}) / T^2,
    tau_k = M̄(alpha_k) (alpha_ddot^d_k - K_v r_dot_k - K_p r_k) + N̂_k,

with r = alpha - alpha^d, K_p = omega^2, K_v = 2 omega (critically damped error dynamics of
bandwidth omega [rad/s]). With a computation delay of d samples, the command of sample j acts
over [t_{j+d}, t_{j+d+1}). ``pairing`` says which torque goes with the second difference:

* ``"last"`` (the textbook law): the torque that acted over the last period, tau_{k-1-d};
* ``"mean"``: the mean of the two torques that acted over [t_{k-2}, t_k], the interval the
  second difference averages over, (tau_{k-2-d} + tau_{k-1-d}) / 2.

Measured (analytic plant, path I, the paper's uncertainty and friction, 1 kHz, omega = 80 rad/s;
max |r| over the last 5 s and the RMS torque increment ||tau_k - tau_{k-1}|| there):

==========================  ======================  ======================
                            ``"last"``              ``"mean"``
==========================  ======================  ======================
exact state, no delay       5.0e-4 rad, 0.017 N m   7.7e-4 rad, 0.015 N m
17-bit encoder, no delay    4.3e-4 rad, 1.15 N m    6.2e-4 rad, 1.59 N m
17-bit encoder, delay 1     8.6e-4 rad, 23-38 N m   1.1e-3 rad, 1.54 N m
==========================  ======================  ======================

The textbook pairing tracks best but, with one sample of delay, its estimate lags the torque by a
sample and the torque alternates from sample to sample (its RMS increment is not stable to rounding:
23 and 38 N m on the analytic plant, 45-49 N m on the Pinocchio plant, in the realisations
measured); the mean pairing stays smooth. Either way the estimate is only as good as the second
difference of the measured angles: quantisation enters it amplified by 4/T^2, hence the ~1 N m
increments with 17-bit encoders (docs/architecture.md section 6). M̄ is the nominal model's
inertia at the measured angles. Before three past samples exist, N̂ is the nominal model's C̄ alpha_dot + Ḡ + F̄.

The law's state is discrete (updated once per sample): [alpha_{k-1}, alpha_{k-2}, the last d + 2
commands, samples seen].
"""

from __future__ import annotations

import math

import numpy as np

from delta_pin.control.base import CompiledController, check_delay, check_period
from delta_pin.control.nominal import NominalModel, core_law_of
from delta_pin.errors import InvalidParameterError

__all__ = ["PAIRINGS", "TimeDelayControl", "tdc"]

PAIRINGS = ("last", "mean")


class TimeDelayControl(CompiledController):
    """Time-delay control at sample period ``dt`` (see the module docstring).

    Args:
        nominal: the nominal model (its M̄; C̄, Ḡ, F̄ for the first two samples).
        dt: the sample period [s] (the loop's ``dt`` must equal it).
        bandwidth: omega [rad/s] of the error dynamics r_ddot + 2 omega r_dot + omega^2 r = 0.
        delay: samples of computation delay of the drive it runs on (its torque at sample k acts
            from sample k + delay).
        pairing: ``"last"`` (textbook) or ``"mean"`` (see the module docstring).
    """

    name = "tdc"

    def __init__(
        self,
        nominal: NominalModel,
        dt: float = 1e-3,
        *,
        bandwidth: float = 80.0,
        delay: int = 0,
        pairing: str = "last",
    ):
        if not (math.isfinite(bandwidth) and bandwidth > 0.0):
            raise InvalidParameterError(
                f"bandwidth={bandwidth!r} must be a positive angular frequency [rad/s]"
            )
        if pairing not in PAIRINGS:
            raise InvalidParameterError(f"pairing={pairing!r} must be one of {', '.join(PAIRINGS)}")
        self.nominal = nominal
        self.pairing = pairing
        self.dt = check_period(dt)
        self.bandwidth = float(bandwidth)
        self.delay = check_delay(delay)
        self.K_p, self.K_v = bandwidth**2, 2.0 * bandwidth
        self.reset()

    def initial_state(self) -> np.ndarray:
        n = self.nominal.dof
        return np.zeros(2 * n + n * (self.delay + 2) + 1)

    def sampled_core_law(self):
        """The compiled core's time-delay control (``TimeDelayControl`` of
        ``delta_pin/core/run/controller.hpp``, the module docstring's arithmetic) on the nominal
        model (:meth:`NominalModel.core_law <delta_pin.control.nominal.NominalModel.core_law>`; a
        model written in Python is called back). Its first samples' N̂ is
        C̄ alpha_dot + Ḡ + F̄, without the nominal friction."""
        gains = {
            "period": self.dt, "K_p": self.K_p, "K_v": self.K_v, "delay": self.delay,
            "mean_pairing": self.pairing == "mean",
        }  # fmt: skip
        return core_law_of(self.nominal, "TimeDelayControl", self.name, gains, friction_compensation=False)

    def metadata(self) -> dict:
        return {
            "name": self.name,
            "dt": self.dt,
            "bandwidth": self.bandwidth,
            "delay": self.delay,
            "pairing": self.pairing,
            "nominal": self.nominal.metadata(),
        }


def tdc(nominal: NominalModel, dt: float = 1e-3, **options) -> TimeDelayControl:
    """Time-delay control (:class:`TimeDelayControl`) at sample period ``dt`` [s]."""
    return TimeDelayControl(nominal, dt, **options)

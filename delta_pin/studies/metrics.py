"""Performance indices of a run (Section V of the paper).

    IAE = int ||r|| dt,   ISE = int ||r||^2 dt       (Figs. 26-29; r = alpha - alpha^d [rad])
    S   = int ||tau|| dt                             (eq. 68) [N m s]
    S_sum = sum_k ||tau_k||                          the sample sum [N m]

The paper reports S = 62262 and 62197 for a 15 s run: values of the size of a sample sum at a
fine step, not of the integral (~100 N m s here) -- both are reported (docs/architecture.md
section 4, erratum 5).
Integrals use the trapezoidal rule on the run's samples. The "last 5 s" indices are NaN for a run
shorter than 5 s (they would otherwise describe the initial transient under the name of the
steady state; ``None``/``null`` in :meth:`RunMetrics.as_dict` and JSON); :func:`window_note` says so
in words.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from delta_pin.sim.run import Run

__all__ = ["METRIC_NAMES", "WINDOW", "RunMetrics", "compute_metrics", "window_note"]

WINDOW = 5.0  # [s] the final stretch of the "last 5 s" indices


@dataclass(frozen=True)
class RunMetrics:
    """Indices of one run (SI units; the task-space error in mm)."""

    iae: float
    ise: float
    control_effort: float
    control_effort_sum: float
    rho_hat_max: float | None
    rho_hat_final: float | None
    max_task_error_mm_last_5s: float
    max_joint_error_last_5s: float
    torque_increment_rms_last_5s: float
    torque_limit_hits: int | None
    wall_time: float | None

    def as_dict(self) -> dict:
        """The indices by name; a NaN index (a "last 5 s" one of a shorter run) is ``None``, so
        that records compare equal and JSON stays strict (``null``)."""
        return {k: None if isinstance(v, float) and math.isnan(v) else v for k, v in asdict(self).items()}


METRIC_NAMES = tuple(f.name for f in fields(RunMetrics))  # what --metric and the tables accept


def _trapezoid(values: np.ndarray, t: np.ndarray) -> float:
    return float(np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(t)))


def _increment_rms(tau: np.ndarray, window: np.ndarray) -> float:
    """RMS of ||tau_k - tau_{k-1}|| over the samples k in ``window`` (k >= 1) [N m]."""
    increments = np.linalg.norm(np.diff(tau, axis=0), axis=1)[window[1:]]
    return float(np.sqrt(np.mean(increments**2))) if len(increments) else 0.0


def _shorter_than(run: Run, window: float) -> bool:
    return run.t[-1] - run.t[0] < window - 1e-9


def window_note(run: Run, window: float = WINDOW) -> str | None:
    """A sentence for a run shorter than ``window`` [s] (its "last 5 s" indices are NaN), else None."""
    if not _shorter_than(run, window):
        return None
    return (
        f"the run lasts {run.t[-1] - run.t[0]:g} s, less than the {window:g} s of the 'last_5s' "
        "indices: they are NaN"
    )


def compute_metrics(run: Run, window: float = WINDOW) -> RunMetrics:
    """IAE, ISE, S (integral and sample sum), rho_hat max and final, the largest task-space error
    [mm] and joint error [rad] over the last ``window`` seconds of ``run``, the torque's roughness
    there (RMS over those samples of ||tau_k - tau_{k-1}|| [N m]) and how many samples the drive's
    torque limit bound at (``None`` without a limit). The three indices over the last ``window``
    seconds are NaN when the run is shorter than ``window``."""
    error = np.linalg.norm(run.error, axis=1)
    torque = np.linalg.norm(run.tau, axis=1)
    last = run.t >= run.t[-1] - window - 1e-12
    task_error = np.linalg.norm(run.xyz - run.xyz_d, axis=1)
    short = _shorter_than(run, window)
    rho = run.internals.get("rho_hat")
    rho_norm = None if rho is None else np.linalg.norm(np.reshape(rho, (len(run.t), -1)), axis=1)
    return RunMetrics(
        iae=_trapezoid(error, run.t),
        ise=_trapezoid(error**2, run.t),
        control_effort=_trapezoid(torque, run.t),
        control_effort_sum=float(torque.sum()),
        rho_hat_max=None if rho_norm is None else float(rho_norm.max()),
        rho_hat_final=None if rho_norm is None else float(rho_norm[-1]),
        max_task_error_mm_last_5s=math.nan if short else float(task_error[last].max() * 1e3),
        max_joint_error_last_5s=math.nan if short else float(error[last].max()),
        torque_increment_rms_last_5s=math.nan if short else _increment_rms(run.tau, last),
        torque_limit_hits=run.metadata.get("torque_limit_hits"),
        wall_time=run.metadata.get("wall_time"),
    )

"""Performance indices of a run (Section V of the paper).

    IAE = int ||r|| dt,   ISE = int ||r||^2 dt       (Figs. 26-29; r = alpha - alpha^d [rad])
    S   = int ||tau|| dt                             (eq. 68) [N m s]
    S_sum = sum_k ||tau_k||                          the sample sum [N m]

The paper reports S = 62262 and 62197 for a 15 s run: values of the size of a sample sum at a
fine step, not of the integral (~100 N m s here) -- both are reported (docs/architecture.md
section 4, erratum 5).
Integrals use the trapezoidal rule on the run's samples.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np

from delta_pin.sim.run import Run

__all__ = ["METRIC_NAMES", "RunMetrics", "compute_metrics"]


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
        return asdict(self)


METRIC_NAMES = tuple(f.name for f in fields(RunMetrics))  # what --metric and the tables accept


def _trapezoid(values: np.ndarray, t: np.ndarray) -> float:
    return float(np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(t)))


def _increment_rms(tau: np.ndarray, window: np.ndarray) -> float:
    """RMS of ||tau_k - tau_{k-1}|| over the samples k in ``window`` (k >= 1) [N m]."""
    increments = np.linalg.norm(np.diff(tau, axis=0), axis=1)[window[1:]]
    return float(np.sqrt(np.mean(increments**2))) if len(increments) else 0.0


def compute_metrics(run: Run, window: float = 5.0) -> RunMetrics:
    """IAE, ISE, S (integral and sample sum), rho_hat max and final, the largest task-space error
    [mm] and joint error [rad] over the last ``window`` seconds of ``run``, the torque's roughness
    there (RMS over those samples of ||tau_k - tau_{k-1}|| [N m]) and how many samples the drive's
    torque limit bound at (``None`` without a limit)."""
    error = np.linalg.norm(run.error, axis=1)
    torque = np.linalg.norm(run.tau, axis=1)
    last = run.t >= run.t[-1] - window - 1e-12
    task_error = np.linalg.norm(run.xyz - run.xyz_d, axis=1)
    rho = run.internals.get("rho_hat")
    rho_norm = None if rho is None else np.linalg.norm(np.reshape(rho, (len(run.t), -1)), axis=1)
    return RunMetrics(
        iae=_trapezoid(error, run.t),
        ise=_trapezoid(error**2, run.t),
        control_effort=_trapezoid(torque, run.t),
        control_effort_sum=float(torque.sum()),
        rho_hat_max=None if rho_norm is None else float(rho_norm.max()),
        rho_hat_final=None if rho_norm is None else float(rho_norm[-1]),
        max_task_error_mm_last_5s=float(task_error[last].max() * 1e3),
        max_joint_error_last_5s=float(error[last].max()),
        torque_increment_rms_last_5s=_increment_rms(run.tau, last),
        torque_limit_hits=run.metadata.get("torque_limit_hits"),
        wall_time=run.metadata.get("wall_time"),
    )

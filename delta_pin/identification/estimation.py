"""From a measured log to base parameters: filtering, differentiation, OLS and WLS with covariance.

* **States.** Encoder positions are quantised (17 bits: one count 4.8e-5 rad, a uniform error of
  standard deviation 1.4e-5 rad) and have no velocity or acceleration. They are low-passed by a
  zero-phase Butterworth filter (``scipy.signal.butter`` + ``filtfilt``, order 4, cut-off
  ``STATE_CUTOFF_RATIO`` = 2 x ``cutoff``, 40 Hz by default; its gain in the pass band below
  ``cutoff`` differs from 1 by less than 4e-3, at 5 Hz by 1e-7) and differentiated by second-order
  central differences (``np.gradient``; truncation (omega h)^2 / 6: 3e-6 at 2 Hz and 1 kHz).
  The velocities come from the positions by default, whether or not the log has ``qd`` columns:
  a drive's velocity is often a backward difference (half a sample late) or its own filter's
  output, and a lag there goes unseen into the friction and inertia estimates. A log's ``qd`` is
  used on request (``velocities="logged"``, filtered by the same filter), and its lag behind the
  derivative of the filtered positions is measured either way (:func:`velocity_lag`).
* **Parallel filtering** (Gautier 1997). The torques hold what the filtered states lack: the
  controller's reaction to the Coulomb torque's steps at a velocity reversal is fast. Since
  tau = Y theta holds sample by sample, it holds for any linear filter F applied to both sides:
  F(tau) = F(Y) theta. The torques and every regressor column are low-passed by the same
  zero-phase Butterworth at ``cutoff`` (order 4), which removes the band where Y of the filtered
  states and Y of the true states differ. For a zero-order-hold drive (the torque logged at t_k
  acts over [t_k, t_k + dt)) the torque paired with the central differences at t_k is the mean of
  tau_(k-1) and tau_k. ``trim`` seconds at each end are dropped (filtfilt's edge transients).
* **Velocity reversals.** Near alpha_dot_j = 0 the smooth Coulomb sign tanh(alpha_dot_j / eps)
  (eps = 0.01 rad/s) has a slope of F_c / eps (6 N m s/rad on the Table 1 robot): the joint
  dwells there with millisecond dynamics that no filtered velocity resolves, so joint j's
  equation is wrong near its reversals whatever the filter. Joint j's rows (its friction appears
  in no other joint's row) are dropped where |alpha_dot_j| < ``REVERSAL_SPEED`` = 0.1 rad/s
  (10 eps: tanh = 1 - 4e-9 beyond) within 1 / ``cutoff`` of the sample (:func:`reversal_mask`).
* **Ordinary least squares** on the base regressor W_b (n dof rows): beta = argmin |W_b beta - tau|,
  covariance sigma^2 (W_b^T W_b)^-1 with sigma^2 = |r|^2 / (n dof - r).
* **Weighted least squares**: each joint's rows weighted by 1 / sigma_j, sigma_j^2 its OLS
  residual variance (Gautier & Poignet 2001); covariance (W^T Sigma^-1 W)^-1.
* **Essential parameters** (Pham & Gautier 1991), optional: a base parameter whose WLS estimate is
  not significantly different from 0 (|beta_i| / sigma_i < ``t_min`` = 3) is set to 0 and the rest
  re-fitted, the least significant first, until every one left is significant. What is dropped is
  listed (its t value when dropped), never silent; a Delta's rods have zero products of inertia,
  and fitting them only adds variance to the rest.
* **Physical friction** (:func:`bounded_fit`): the WLS problem again with Coulomb ``fc`` >= 0,
  Stribeck excess ``fs`` >= 0 (static >= Coulomb), viscous ``fv`` >= 0 and rotor inertia ``Ia``
  >= 0, on those base parameters that are one such column alone (checked: its K row is zero and
  it lumps no other column; the others stay free), by ``scipy.optimize.lsq_linear`` (BVLS); the
  unconstrained WLS values are reported beside it.
* **Identifiability of the log.** Before the fit, W_b's columns are scaled to unit norm and
  factored by pivoted QR; a base parameter whose diagonal entry is below ``LOG_RANK_TOLERANCE``
  (1e-7) of the largest is not identifiable from this excitation, and the fit refuses, naming it
  (never a silently dropped parameter).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.signal

from delta_pin.errors import InvalidParameterError
from delta_pin.identification.base import BaseParameters
from delta_pin.identification.log import IdentificationLog
from delta_pin.identification.regressor import ClosedChainRegressor

__all__ = [
    "LOG_RANK_TOLERANCE",
    "Estimate",
    "FilteredStates",
    "bounded_fit",
    "check_cutoff",
    "check_identifiable",
    "check_velocity_source",
    "essential_fit",
    "expand",
    "filtered_states",
    "least_squares_fit",
    "log_regressor",
    "minimum_filtered_samples",
    "parallel_filter",
    "reversal_mask",
    "trimmed_samples",
    "velocity_lag",
]

LOG_RANK_TOLERANCE = 1e-7
REVERSAL_SPEED = 0.1  # [rad/s or m/s] joint rows this near a reversal are dropped
STATE_CUTOFF_RATIO = 2.0  # the states' filter cut-off over the parallel filter's
VELOCITY_SOURCES = ("positions", "logged")  # filtered_states' velocities: d/dt q, or the log's qd
# A logged qd lagging the derivative of q by more than this many samples is reported as a lag
# (a backward difference lags by 0.5); below it, the estimate's own spread on noisy logs
VELOCITY_LAG_SAMPLES = 0.1


@dataclass
class FilteredStates:
    """States rebuilt from a log (module docstring): t (N,) [s], alpha, alpha_dot, alpha_ddot,
    tau (N, dof) [SI]."""

    t: np.ndarray
    alpha: np.ndarray
    alpha_dot: np.ndarray
    alpha_ddot: np.ndarray
    tau: np.ndarray


def filtered_states(
    log: IdentificationLog,
    cutoff: float = 20.0,
    order: int = 4,
    trim: float = 0.05,
    velocities: str = "positions",
) -> FilteredStates:
    """Zero-phase low-passed positions and their derivatives (module docstring); ``tau`` is the
    log's, paired with the states for a zero-order-hold drive (header ``torque_hold: zoh``, the
    default) and not yet filtered (:func:`parallel_filter`).

    Args:
        cutoff: the parallel filter's cut-off [Hz]; the states' is ``STATE_CUTOFF_RATIO`` times it
            (below half the sample rate).
        order: the filter's order (the zero-phase response has twice it).
        trim: time dropped at each end [s].
        velocities: ``"positions"`` (the default): alpha_dot is the derivative of the filtered
            positions, a log's ``qd`` columns unused; ``"logged"``: the log's ``qd``, filtered.

    Raises:
        InvalidParameterError: another ``velocities``, or ``"logged"`` for a log without ``qd``.
    """
    check_velocity_source(velocities, log)
    if len(log) < 2:
        raise InvalidParameterError(f"{log.where} has {len(log)} samples; a fit needs a recorded run")
    rate = log.sample_rate
    check_cutoff(cutoff, rate)
    need = minimum_filtered_samples(rate, order, trim)
    if len(log) < need:
        raise InvalidParameterError(
            f"{log.where} has {len(log)} samples; filtering it needs at least {need} at its {rate:g} Hz "
            f"({trim:g} s trimmed at each end, and more than the 3 (order + 1) = {3 * (order + 1)} samples "
            "the zero-phase filter extends each end by); record a longer run"
        )
    dt = 1.0 / rate
    alpha = _state_filter(log.alpha, cutoff, rate, order)
    if velocities == "logged":
        alpha_dot = _state_filter(log.alpha_dot, cutoff, rate, order)
    else:
        alpha_dot = np.gradient(alpha, dt, axis=0)
    alpha_ddot = np.gradient(alpha_dot, dt, axis=0)
    keep = (log.t >= log.t[0] + trim) & (log.t <= log.t[-1] - trim)
    tau = log.tau
    if log.header.get("torque_hold", "zoh") == "zoh":
        tau = tau.copy()
        tau[1:] = 0.5 * (log.tau[1:] + log.tau[:-1])
    return FilteredStates(log.t[keep], alpha[keep], alpha_dot[keep], alpha_ddot[keep], tau[keep])


def _state_filter(signal: np.ndarray, cutoff: float, rate: float, order: int) -> np.ndarray:
    """The states' zero-phase low-pass (Butterworth of ``order`` at STATE_CUTOFF_RATIO x ``cutoff``
    [Hz], ``filtfilt`` along the samples of a log at ``rate`` [Hz]): the one filter that both
    :func:`filtered_states` and :func:`velocity_lag` apply."""
    b, a = scipy.signal.butter(order, STATE_CUTOFF_RATIO * cutoff / (0.5 * rate))
    return scipy.signal.filtfilt(b, a, signal, axis=0)


def check_velocity_source(velocities: str, log: IdentificationLog) -> None:
    """Refuse a ``velocities`` outside :data:`VELOCITY_SOURCES`, or ``"logged"`` for a log without
    ``qd`` columns, in one line."""
    if velocities not in VELOCITY_SOURCES:
        raise InvalidParameterError(
            f"velocities={velocities!r} must be 'positions' (the derivative of the filtered positions) or "
            "'logged' (the log's qd columns)"
        )
    if velocities == "logged" and log.alpha_dot is None:
        raise InvalidParameterError(
            f"{log.where} has no qd columns: its velocities can only come from the positions "
            "(velocities='positions', identify fit --velocities positions)"
        )


def velocity_lag(
    log: IdentificationLog, cutoff: float = 20.0, order: int = 4, trim: float = 0.05
) -> np.ndarray:
    """How late the log's ``qd`` is against the derivative of its filtered positions, per joint
    [s] (positive: ``qd`` lags); NaN per joint for a log without ``qd``.

    Both are low-passed by the states' zero-phase filter; with g the derivative of the positions,
    qd(t) = g(t - lag) ~ g(t) - lag g'(t) to first order in the lag, so lag is the least-squares
    solution <g - qd, g'> / <g', g'> over the trimmed samples. A backward difference
    (q_k - q_(k-1)) / dt lags by half a sample; a central difference by none."""
    dof = log.alpha.shape[1]
    if log.alpha_dot is None:
        return np.full(dof, np.nan)
    rate = log.sample_rate
    dt = 1.0 / rate
    g = np.gradient(_state_filter(log.alpha, cutoff, rate, order), dt, axis=0)
    qd = _state_filter(log.alpha_dot, cutoff, rate, order)
    g_dot = np.gradient(g, dt, axis=0)
    keep = (log.t >= log.t[0] + trim) & (log.t <= log.t[-1] - trim)
    g, qd, g_dot = g[keep], qd[keep], g_dot[keep]
    energy = (g_dot**2).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(energy > 0.0, ((g - qd) * g_dot).sum(axis=0) / energy, np.nan)


def check_cutoff(cutoff: float, rate: float) -> None:
    """Refuse a parallel filter's ``cutoff`` [Hz] outside (0, rate / 4): the states' filter
    (``STATE_CUTOFF_RATIO`` times it) must lie below the Nyquist frequency of ``rate`` [Hz]."""
    if not 0.0 < STATE_CUTOFF_RATIO * cutoff < 0.5 * rate:
        raise InvalidParameterError(
            f"cutoff {cutoff} Hz must lie between 0 and a quarter of the log's sample rate "
            f"({0.25 * rate:g} Hz)"
        )


def minimum_filtered_samples(rate: float, order: int = 4, trim: float = 0.05) -> int:
    """The fewest samples of a log at ``rate`` [Hz] that :func:`filtered_states` and
    :func:`parallel_filter` take: ``scipy.signal.filtfilt`` extends a signal by 3 (order + 1)
    samples at each end (15 at order 4) and needs more samples than that, after the ``trim`` [s]
    dropped at each end (ceil(trim rate) samples, one more for the rounding of the time column)."""
    return 3 * (order + 1) + 1 + trimmed_samples(rate, trim)


def trimmed_samples(rate: float, trim: float = 0.05) -> int:
    """At most how many samples of a log at ``rate`` [Hz] :func:`filtered_states` drops with
    ``trim`` [s] at each end: ceil(trim rate) at each, one more each for the time column's rounding."""
    return 2 * (math.ceil(trim * rate) + 1)


def parallel_filter(
    Y: np.ndarray, tau: np.ndarray, rate: float, cutoff: float = 20.0, order: int = 4
) -> tuple[np.ndarray, np.ndarray]:
    """(F(Y), F(tau)): the same zero-phase Butterworth low-pass (``cutoff`` [Hz], ``order``) along
    time applied to the regressor (N, dof, p) and the torques (N, dof) (module docstring)."""
    b, a = scipy.signal.butter(order, cutoff / (0.5 * rate))
    return scipy.signal.filtfilt(b, a, Y, axis=0), scipy.signal.filtfilt(b, a, tau, axis=0)


def log_regressor(regressor: ClosedChainRegressor, states: FilteredStates, stride: int = 1) -> np.ndarray:
    """Y (N, dof, p) along filtered states. With ``stride`` > 1 the tree's columns (smooth in
    time: the excitation's few hertz and their products) are evaluated at every ``stride``-th
    sample and interpolated by a cubic spline (``scipy.interpolate.CubicSpline``; error
    ~(omega h)^4 / 384: 2e-7 relative for a 10 Hz column at stride 5 and 1 kHz), the
    actuated-joint columns (the friction's sharp sign) at every sample."""
    from scipy.interpolate import CubicSpline

    t = states.t
    if stride <= 1 or len(t) < 4 * stride:
        return regressor.stack(states.alpha, states.alpha_dot, states.alpha_ddot, times=t)
    picks = np.unique(np.r_[np.arange(0, len(t), stride), len(t) - 1])
    Y_coarse = regressor.stack(
        states.alpha[picks], states.alpha_dot[picks], states.alpha_ddot[picks], times=t[picks]
    )
    n = regressor.inertial_count
    Y = np.empty((len(t), regressor.dof, regressor.size))
    Y[:, :, :n] = CubicSpline(t[picks], Y_coarse[:, :, :n], axis=0)(t)
    Y[:, :, n:] = regressor.columns.block(states.alpha_dot, states.alpha_ddot)
    return Y


def reversal_mask(
    alpha_dot: np.ndarray, rate: float, cutoff: float, speed: float = REVERSAL_SPEED
) -> np.ndarray:
    """(N, dof) bool: the rows to keep, False where |alpha_dot_j| < ``speed`` within 1 / ``cutoff``
    [s] of the sample (module docstring)."""
    from scipy.ndimage import minimum_filter1d

    width = 2 * int(np.ceil(rate / cutoff)) + 1
    return minimum_filter1d(np.abs(alpha_dot), size=width, axis=0, mode="nearest") >= speed


def check_identifiable(W_base: np.ndarray, names: list[str], rtol: float = LOG_RANK_TOLERANCE) -> None:
    """Raise unless every base parameter is identifiable from the stacked base regressor
    ``W_base`` (n, r) (module docstring).

    Raises:
        InvalidParameterError: how many base parameters are not identifiable and which.
    """
    if W_base.shape[0] < W_base.shape[1]:
        raise InvalidParameterError(
            f"rank-deficient excitation: {W_base.shape[0]} rows are left for {W_base.shape[1]} base "
            "parameters "
            "(joint rows near a velocity reversal are dropped: the joints barely move); excite every joint "
            "faster and longer (delta-pin identify excite)"
        )
    norms = np.linalg.norm(W_base, axis=0)
    zero = [names[k] for k in np.flatnonzero(norms == 0.0)]
    scaled = W_base / np.where(norms > 0.0, norms, 1.0)
    _, R, pivots = scipy.linalg.qr(scaled, mode="economic", pivoting=True)
    diagonal = np.abs(np.diag(R))
    weak = [names[k] for k, d in zip(pivots, diagonal / diagonal[0], strict=False) if d <= rtol]
    weak += [names[k] for k in pivots[len(diagonal) :]]
    bad = sorted(set(zero) | set(weak), key=names.index)
    if bad:
        raise InvalidParameterError(
            f"rank-deficient excitation: {len(bad)} of {len(names)} base parameters are not identifiable "
            f"from this log ({', '.join(bad)}); excite every joint over more of its range and speeds "
            "(delta-pin identify excite)"
        )


@dataclass
class Estimate:
    """A least-squares estimate of the base parameters.

    Attributes:
        beta: base parameters (r,) [SI].
        covariance: their covariance (r, r).
        sigma: residual standard deviation per joint (dof,) [N m or N].
        method: ``"ols"`` or ``"wls"``.
    """

    beta: np.ndarray
    covariance: np.ndarray
    sigma: np.ndarray
    method: str
    R: np.ndarray | None = None  # WLS: the R factor of the whitened regressor (information R^T R)
    weights: np.ndarray | None = None  # WLS: each joint's sigma_j its rows were divided by (dof,)

    @property
    def std(self) -> np.ndarray:
        """Standard deviation of each base parameter (r,)."""
        return np.sqrt(np.diag(self.covariance))

    def relative_std(self) -> np.ndarray:
        """std / |beta| (r,) (inf where beta is 0)."""
        with np.errstate(divide="ignore"):
            return self.std / np.abs(self.beta)


def least_squares_fit(
    Y_base: np.ndarray, tau: np.ndarray, mask: np.ndarray | None = None, weighted: bool = True
) -> tuple[Estimate, Estimate]:
    """(OLS, WLS) estimates from the base regressor ``Y_base`` (N, dof, r) and torques ``tau``
    (N, dof) [N m] on the rows ``mask`` (N, dof) keeps (all by default) (module docstring); WLS
    is OLS again when ``weighted`` is False."""
    count, dof, r = Y_base.shape
    mask = np.ones((count, dof), bool) if mask is None else mask
    keep = mask.ravel()
    joint = np.broadcast_to(np.arange(dof), (count, dof)).ravel()[keep]
    W = Y_base.reshape(-1, r)[keep]
    y = tau.reshape(-1)[keep]
    beta, *_ = scipy.linalg.lstsq(W, y, lapack_driver="gelsy")
    e = y - W @ beta
    rows = np.bincount(joint, minlength=dof)
    residual_sq = np.bincount(joint, weights=e**2, minlength=dof)
    sigma2 = float(e @ e) / max(len(y) - r, 1)
    # (W^T W)^-1 from the R factor of W: better conditioned than inverting the normal matrix
    R = scipy.linalg.qr(W, mode="r")[0][:r]
    R_inv = scipy.linalg.solve_triangular(R, np.eye(r))
    ols = Estimate(beta, sigma2 * R_inv @ R_inv.T, np.sqrt(residual_sq / np.maximum(rows, 1)), "ols")
    if not weighted:
        return ols, ols
    sigma_j = np.sqrt(residual_sq / np.maximum(rows - r / dof, 1.0))
    sigma_j = np.where(sigma_j > 0.0, sigma_j, 1.0)
    Ww = W / sigma_j[joint, None]
    yw = y / sigma_j[joint]
    beta_w, *_ = scipy.linalg.lstsq(Ww, yw, lapack_driver="gelsy")
    e_w = y - W @ beta_w
    Rw = scipy.linalg.qr(Ww, mode="r")[0][:r]
    Rw_inv = scipy.linalg.solve_triangular(Rw, np.eye(r))
    sigma_w = np.sqrt(np.bincount(joint, weights=e_w**2, minlength=dof) / np.maximum(rows, 1))
    wls = Estimate(beta_w, Rw_inv @ Rw_inv.T, sigma_w, "wls")
    wls.R = Rw
    wls.weights = sigma_j
    return ols, wls


def bounded_fit(
    Y_base: np.ndarray, tau: np.ndarray, mask: np.ndarray, weights: np.ndarray, lower: np.ndarray
) -> np.ndarray:
    """The WLS problem (rows divided by ``weights``, each joint's sigma_j) with ``beta >= lower``
    (r,) (``-inf``: free): ``scipy.optimize.lsq_linear`` (bounded-variable least squares); the
    physical friction of the module docstring."""
    from scipy.optimize import lsq_linear

    count, dof, r = Y_base.shape
    keep = mask.ravel()
    joint = np.broadcast_to(np.arange(dof), (count, dof)).ravel()[keep]
    W = Y_base.reshape(-1, r)[keep] / weights[joint, None]
    y = tau.reshape(-1)[keep] / weights[joint]
    if not np.any(np.isfinite(lower)):
        return scipy.linalg.lstsq(W, y, lapack_driver="gelsy")[0]
    found = lsq_linear(W, y, bounds=(lower, np.full(r, np.inf)), method="bvls", tol=1e-12)
    return np.maximum(found.x, lower)


def base_names(base: BaseParameters) -> list[str]:
    """Short names of the base parameters (:meth:`BaseParameters.short_names`)."""
    return base.short_names()


def essential_fit(
    Y_base: np.ndarray, tau: np.ndarray, mask: np.ndarray, t_min: float = 3.0
) -> tuple[np.ndarray, list[tuple[int, float]], Estimate, Estimate]:
    """The essential parameters (module docstring): (the kept base parameters' indices, [(dropped
    index, its |t| when dropped), ...] in dropping order, OLS and WLS on the kept ones)."""
    kept = np.arange(Y_base.shape[2])
    dropped: list[tuple[int, float]] = []
    while True:
        ols, wls = least_squares_fit(Y_base[:, :, kept], tau, mask)
        t = np.abs(wls.beta) / wls.std
        worst = int(np.argmin(t))
        if t[worst] >= t_min or len(kept) == 1:
            return kept, dropped, ols, wls
        dropped.append((int(kept[worst]), float(t[worst])))
        kept = np.delete(kept, worst)


def expand(estimate: Estimate, kept: np.ndarray, size: int) -> Estimate:
    """An estimate on the ``kept`` base parameters as one on all ``size`` of them (0, with zero
    variance, where dropped)."""
    beta = np.zeros(size)
    beta[kept] = estimate.beta
    covariance = np.zeros((size, size))
    covariance[np.ix_(kept, kept)] = estimate.covariance
    R = None
    if estimate.R is not None:
        R = np.zeros((len(kept), size))
        R[:, kept] = estimate.R
    return Estimate(beta, covariance, estimate.sigma, estimate.method, R, estimate.weights)

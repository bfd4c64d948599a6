"""A user's workflow: an excitation to run, a simulated log to try it on, the fit, its validation.

* :func:`simulate_log` -- run an excitation on the Pinocchio plant of a (true) robot under a
  computed-torque controller on the nominal (CAD) model, and log what a drive measures: 17-bit
  encoder positions and torques with Gaussian noise of 1 % of each joint's RMS torque;
* :func:`identify` (``dp.identify``) -- the fit of a log: base parameters, OLS and WLS with
  covariance, the physically consistent estimate, and for a Delta the paper's lumped terms and the
  xacro arguments of the identified robot (``load_delta(**result.xacro_arguments)``);
* :func:`validate` -- torque prediction on a log the fit never saw (RMS and max per joint, relative).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin
from threadpoolctl import threadpool_limits

from delta_pin.errors import InvalidParameterError
from delta_pin.identification.base import BaseParameters, base_parameters
from delta_pin.identification.consistent import ConsistentEstimate, consistent_estimate
from delta_pin.identification.estimation import (
    VELOCITY_LAG_SAMPLES,
    Estimate,
    bounded_fit,
    check_cutoff,
    check_identifiable,
    essential_fit,
    expand,
    filtered_states,
    least_squares_fit,
    log_regressor,
    minimum_filtered_samples,
    parallel_filter,
    reversal_mask,
    trimmed_samples,
    velocity_lag,
)
from delta_pin.identification.excitation import FourierExcitation
from delta_pin.identification.log import (
    IdentificationLog,
    check_log_robot,
    check_torques,
    count_samples,
    kinematics_digest,
    read_log,
)
from delta_pin.identification.regressor import ClosedChainRegressor, JointColumns

__all__ = [
    "FIT_BYTES_PER_ENTRY",
    "TORQUE_SCALE_LIMIT",
    "IdentificationResult",
    "check_fit_memory",
    "check_log_memory",
    "delta_lumped_map",
    "fit_memory",
    "friction_truth",
    "identified_robot",
    "identify",
    "minimum_samples",
    "perturbed_robot",
    "read_trajectory",
    "reversal_speed",
    "simulate_log",
    "torque_scale",
    "validate",
    "write_trajectory",
]


def friction_truth(robot, friction) -> dict:
    """The joint columns' true values {"fv", "fc", "fs"} [N m s/rad, N m, N m] of a plant's eq. 12
    friction (a :class:`~delta_pin.model.friction.Friction`): fv = mu_v r_a, fc = mu_d F_n r_a,
    fs = (mu_s - mu_d) F_n r_a."""
    if friction is None:
        return {}
    delta = getattr(robot, "delta", None)
    s = friction.stribeck_for(None if delta is None else delta.params.friction)
    n = friction.normal_force
    return {"fv": s.mu_v * s.r_a, "fc": s.mu_d * n * s.r_a, "fs": (s.mu_s - s.mu_d) * n * s.r_a}


def simulate_log(
    robot,
    trajectory: FourierExcitation,
    *,
    nominal=None,
    friction=True,
    payload_mass: float = 0.0,
    dt: float = 1e-3,
    encoder_bits: int = 17,
    torque_noise: float = 0.01,
    seed: int = 0,
):
    """Run ``trajectory`` on the Pinocchio plant of ``robot`` (the truth) and return
    (the log a drive would record, the :class:`~delta_pin.sim.run.Run`).

    Args:
        nominal: the robot whose projected model the computed-torque controller uses (default:
            ``robot``; pass the CAD robot to track with a wrong model, as on a real robot).
        friction: the plant's friction (:class:`~delta_pin.model.friction.Friction`, ``True`` for
            a Delta's Table 1 friction at F_n = 15 N, or ``None``).
        payload_mass: a point mass [kg] at the end effector.
        dt: sample period [s].
        encoder_bits: the positions are read by an encoder of 2^bits counts per turn.
        torque_noise: standard deviation of the torque noise, relative to each joint's RMS torque.
        seed: seed of the torque noise.
    """
    from delta_pin.control import ComputedTorque
    from delta_pin.control.nominal import ClosedChainNominalModel
    from delta_pin.model.friction import Friction
    from delta_pin.sim.closed_chain_plant import ClosedChainPlant
    from delta_pin.sim.drive import Encoder
    from delta_pin.sim.runner import simulate

    if friction is True:
        friction = Friction()
    model = ClosedChainNominalModel(robot if nominal is None else nominal)
    # gains scaled by the smallest inertia at the start, so that any robot's loop is stable at
    # 1 kHz (the damping's k T / m is 0.04 here, far below the sampled limit 2; docs/architecture.md
    # section 6): error dynamics of ~20 rad/s
    inertia = float(np.linalg.eigvalsh(model.terms(trajectory.alpha0, np.zeros(robot.dof))[0]).min())
    controller = ComputedTorque(model, D=20.0, T_p=400.0 * inertia, T_v=20.0 * inertia)
    plant = ClosedChainPlant(robot, friction=friction or None, payload_mass=payload_mass or None)
    run = simulate(robot, controller, trajectory, plant=plant, t_end=trajectory.duration, dt=dt,
                   alpha0=trajectory.alpha0, alpha_dot0=np.zeros(robot.dof))  # fmt: skip
    encoder = Encoder(bits=encoder_bits, velocity="none")
    alpha = np.array([encoder.read(a, None, dt)[0] for a in run.alpha])
    rng = np.random.default_rng(seed)
    rms = np.sqrt((run.tau**2).mean(axis=0))
    tau = run.tau + rng.normal(0.0, 1.0, run.tau.shape) * torque_noise * rms
    # whose log this is: the robot the user named (the CAD robot; the truth differs from it in its
    # inertias, or in what a study changes on purpose), checked by identify (log.check_log_robot)
    named = robot if nominal is None else nominal
    header = {
        "robot": named.name,
        "kinematics_sha256": kinematics_digest(named),
        "source": "delta-pin identify simulate",
        "encoder_bits": encoder_bits,
        "torque_noise_relative": torque_noise,
        "torque_hold": "zoh",
        "payload_mass_kg": payload_mass,
        "seed": seed,
    }
    log = IdentificationLog(run.t.copy(), alpha, tau, tuple(robot.actuated_joints), None, header)
    return log, run


def delta_lumped_map(regressor: ClosedChainRegressor, base: BaseParameters, states: int = 60, seed: int = 1):
    """The paper's lumped parameters of a Delta (eqs. 7-9) in terms of the base parameters.

    Eqs. 7-9 are linear in seven numbers: per arm the inertia about its hinge
    I_i = (m_a / 3 + m_b / 2) l_a^2 [kg m^2] and the gravity lever k_i = (m_a + m_b) l_a / 2 [kg m]
    (erratum 1's corrected G), and the platform-side mass m_eq = m_o + 3/2 m_b [kg]:
    tau = I alpha_ddot + J^T m_eq (J alpha_ddot + J_dot alpha_dot + g e_z) - g k cos(alpha). The
    paper's regressor Y_p (columns of these) lies in the span of the base regressor Y_b: Y_p = Y_b A,
    A (r, 7) by least squares over generic states (residual reported). Then a robot that follows the
    lumped model has beta = A theta_p, and theta_p = A^+ beta for an estimate.

    Returns:
        (names (7,), A (r, 7), the fit's largest residual relative to |Y_p|).
    """
    from delta_pin.identification.base import generic_states

    robot = regressor.robot
    delta = robot.delta
    if delta is None:
        raise InvalidParameterError(f"robot {robot.name!r} is not a recognised Delta: no lumped terms")
    p = delta.params
    alpha, alpha_dot, alpha_ddot = generic_states(robot, states, seed)
    Y = base.reduce(regressor.stack(alpha, alpha_dot, alpha_ddot)).reshape(-1, base.rank)
    regressor._last_q = robot.reference_configuration.copy()
    columns = []
    for a, ad, add in zip(alpha, alpha_dot, alpha_ddot, strict=True):
        J = delta.jacobian(a)
        drift = delta.jacobian_derivative_times_velocity(a, ad)
        block = np.zeros((3, 7))
        block[:, :3] = np.diag(add)
        block[:, 3:6] = np.diag(-p.g * np.cos(a))
        block[:, 6] = J.T @ (J @ add + drift + np.array([0.0, 0.0, p.g]))
        columns.append(block)
    Y_p = np.vstack(columns)
    A, *_ = np.linalg.lstsq(Y, Y_p, rcond=None)
    residual = float(np.abs(Y @ A - Y_p).max() / np.abs(Y_p).max())
    names = ["I_1", "I_2", "I_3", "k_1", "k_2", "k_3", "m_eq"]
    return names, A, residual


@dataclass
class IdentificationResult:
    """What :func:`identify` returns.

    Attributes:
        regressor, base: the regressor and its base parameters.
        names: the base parameters' short names (r,); ``expressions`` their combinations.
        ols, wls: the least-squares estimates; ``consistent`` the physically consistent one
            (``None`` where not asked for).
        theta_nominal: the nominal (CAD) standard parameters.
        residual_rms: RMS of tau - Y beta_wls per joint (dof,) [N m]; ``tau_rms`` of tau.
        condition: cond of the column-scaled base regressor of the log.
        timings: seconds per step.
        lumped: for a Delta, the paper's terms {name: value} from WLS; ``xacro_arguments`` the
            masses and friction of the identified Delta (``load_delta(**xacro_arguments)``).
        friction: per joint {"fv", "fc", ...} of the bounded fit (fc, fs, fv, Ia >= 0: physical by
            construction; ``bounded_beta`` its base parameters); ``friction_unconstrained`` the WLS
            values beside it.
        torque_scale: the log's torque against the CAD model's (:func:`torque_scale`).
        warnings: one line each, for stdout and report.md (a torque scale beyond
            :data:`TORQUE_SCALE_LIMIT`, a logged velocity that lags q's derivative).
        notes: one line each, after the warnings in stdout and report.md: each Stribeck term the
            fit kept, with the fit without it (:func:`_stribeck_notes`).
        velocities: where the velocities came from: ``"positions"`` or ``"logged"`` (the log's qd).
        velocity_lag: a log with qd: how late qd is against the derivative of the filtered
            positions, per joint [s] (:func:`~delta_pin.identification.estimation.velocity_lag`);
            ``None`` for a log without qd.
    """

    regressor: ClosedChainRegressor
    base: BaseParameters
    names: list[str]
    expressions: list[str]
    ols: Estimate
    wls: Estimate
    consistent: ConsistentEstimate | None
    theta_nominal: np.ndarray
    residual_rms: np.ndarray
    tau_rms: np.ndarray
    condition: float
    samples: int
    singular_values: np.ndarray | None = None
    cutoff: float = 20.0
    timings: dict = field(default_factory=dict)
    lumped: dict | None = None
    xacro_arguments: dict | None = None
    dropped: list = field(default_factory=list)
    friction: dict = field(default_factory=dict)
    friction_unconstrained: dict = field(default_factory=dict)
    bounded_beta: np.ndarray | None = None
    torque_scale: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    notes: list = field(default_factory=list)  # one line each, after the warnings: the kept Stribeck terms
    velocities: str = "positions"
    velocity_lag: np.ndarray | None = None

    @property
    def beta(self) -> np.ndarray:
        """The WLS base parameters (r,)."""
        return self.wls.beta

    def predict(
        self, log: IdentificationLog, estimate: str = "wls", **options
    ) -> tuple[np.ndarray, np.ndarray]:
        """(predicted, measured) torques (N, dof) along a log, from filtered states
        (:func:`~delta_pin.identification.estimation.filtered_states` with ``options``)."""
        predicted, measured, _ = self._predict_states(log, estimate, **options)
        return predicted, measured

    def _predict_states(self, log: IdentificationLog, estimate: str = "wls", **options):
        """:meth:`predict` and the filtered states' alpha_dot (N, dof) it was made along (the
        velocities from where the fit took them, unless ``options`` say otherwise)."""
        options.setdefault("velocities", self.velocities if log.alpha_dot is not None else "positions")
        states = filtered_states(log, cutoff=self.cutoff, **options)
        Y, tau = parallel_filter(log_regressor(self.regressor, states, _stride(log)), states.tau,
                                 log.sample_rate, self.cutoff)  # fmt: skip
        beta = (
            self.consistent.beta
            if estimate == "consistent" and self.consistent is not None
            else self.wls.beta
        )
        return self.base.reduce(Y) @ beta, tau, states.alpha_dot


# The log's torque may be this many times the CAD model's (or 1 / this many times) before the fit
# warns (a warning, not a refusal: a CAD file can be far off). Measured on simulated logs whose
# true masses are off the CAD file's by up to 30 % (Delta: Table 1 friction in the plant, the
# CAD model's too, or none; five-bar: no friction): ratios 0.83-1.18. A CAD model 10x off in its
# masses is hardly this robot's, while the mistakes this catches are 100x and more: torques in
# mN m (1000x) or N cm (100x), kN m (0.001x), or motor-side torques of a 10:1 to 100:1 gearbox.
TORQUE_SCALE_LIMIT = 10.0


def torque_scale(regressor, Y: np.ndarray, tau: np.ndarray, mask: np.ndarray, nominal) -> dict:
    """The log's torque RMS against the RMS of the torque the nominal (CAD) robot predicts along the
    logged motion (its inertias, and for a Delta its URDF's friction at F_n = 15 N: the
    :func:`friction_truth` of :class:`~delta_pin.model.friction.Friction`; other robots' friction
    counts 0), over the rows the fit used (the filtered Y (N, dof, p) and tau (N, dof), ``mask``).

    Returns:
        {"measured_rms", "nominal_rms" [N m or N], "ratio", and "warning" (one line) where the ratio
        is beyond :data:`TORQUE_SCALE_LIMIT` or below its inverse}; no ratio where the CAD model
        predicts no torque (a file without masses).
    """
    friction = None
    if getattr(nominal, "delta", None) is not None and nominal.delta.params.friction is not None:
        from delta_pin.model.friction import Friction

        friction = friction_truth(nominal, Friction())
    predicted = Y @ regressor.parameters(nominal, friction)
    measured_rms = float(np.sqrt(np.mean(tau[mask] ** 2)))
    nominal_rms = float(np.sqrt(np.mean(predicted[mask] ** 2)))
    out = {"measured_rms": measured_rms, "nominal_rms": nominal_rms}
    if not nominal_rms > 1e-12 * max(measured_rms, 1.0):
        return out
    ratio = measured_rms / nominal_rms
    out["ratio"] = ratio
    if not 1.0 / TORQUE_SCALE_LIMIT <= ratio <= TORQUE_SCALE_LIMIT:
        out["warning"] = (
            f"warning: torques in N m? the log's torques are {ratio:.3g}x the CAD model's (RMS "
            f"{measured_rms:.4g} vs {nominal_rms:.4g} along the logged motion; beyond a factor "
            f"{TORQUE_SCALE_LIMIT:g} either way): mN m would be 1000x, a motor-side torque the gear "
            "ratio; the identified parameters carry the same factor"
        )
    return out


DECIMATION_ROUNDING = 1e-6  # relative: a rate measured from rounded time stamps is still its own


def decimation(rate: float, cutoff: float) -> int:
    """Rows kept after the parallel filter: every rate / (2 cutoff)-th (the Nyquist interval of the
    filtered band), rounded down; a ratio within :data:`DECIMATION_ROUNDING` of a whole number is
    that number (a 1 kHz log whose time stamps measure 999.99999 Hz keeps every 25th row at 20 Hz,
    not every 24th)."""
    ratio = rate / (2.0 * cutoff)
    nearest = round(ratio)
    if abs(ratio - nearest) <= DECIMATION_ROUNDING * ratio:
        return max(1, int(nearest))
    return max(1, math.floor(ratio))


def minimum_samples(rate: float, cutoff: float, rank: int, dof: int, trim: float = 0.05) -> int:
    """The fewest samples of a log at ``rate`` [Hz] from which :func:`identify` can fit ``rank``
    base parameters of a robot of ``dof`` actuated joints at ``cutoff`` [Hz]; necessary, not
    sufficient (the rows near a velocity reversal are dropped too, which only the log's motion
    decides: ``check_identifiable`` names what is then not identifiable). What the fit does:

    * :func:`~delta_pin.identification.estimation.filtered_states` drops ``trim`` s at each end
      (the filters' edge transients), and the zero-phase filters need more samples than the 15
      they extend each end by (:func:`~delta_pin.identification.estimation.minimum_filtered_samples`);
    * the filtered rows are decimated to every :func:`decimation`-th sample (25 at 1 kHz and
      20 Hz), dof rows each;
    * least squares need more rows than base parameters (sigma^2 = |r|^2 / (rows - r)): rank // dof
      + 1 samples per joint after decimation, i.e. (rank // dof) x step + 1 after trimming.

    The packaged Delta (46 base parameters, 3 joints) at 1 kHz and 20 Hz: 15 x 25 + 1 = 376 after
    trimming, 478 in all (0.48 s)."""
    rows = (rank // dof) * decimation(rate, cutoff) + 1 + trimmed_samples(rate, trim)
    return max(minimum_filtered_samples(rate, trim=trim), rows)


# Peak memory of a fit per entry of the regressor it holds along the log (samples x actuated joints x
# regressor columns, float64): the regressor Y (N, dof, p), its cubic spline's output and the parallel
# filter's copies (filtfilt extends, filters forward and back) are alive at once. Measured on
# 2026-12-06 (the peak RSS, ru_maxrss, of `delta-pin identify fit` in a subprocess on synthetic logs,
# less the ~185 MiB its imports take; 2-core x86_64): the Delta (3 x 85) 228, 355, 673, 1169 MiB at
# 5k, 20k, 60k, 120k samples (8.7 kB a sample: 4.25 x 8 bytes an entry; an 80 MB log is ~590k samples,
# ~5 GB, as the issue saw), the five-bar (2 x 48) 4.46 x 8, the Stewart platform (6 x 214) 4.17 x 8;
# counted as 4.5 x 8 bytes. Reading the log (its text, rows of Python floats) takes ~0.7 kB a sample
# for a Delta's 7 columns, freed before the fit.
FIT_BYTES_PER_ENTRY = 36


def fit_memory(regressor: ClosedChainRegressor, samples: int) -> int:
    """About how many bytes :func:`identify` (or :func:`validate`) holds at its peak along a log of
    ``samples`` samples: :data:`FIT_BYTES_PER_ENTRY` per sample, joint and regressor column."""
    return int(samples * regressor.dof * regressor.size * FIT_BYTES_PER_ENTRY)


def check_fit_memory(regressor: ClosedChainRegressor, samples: int, where: str, exact: bool = True) -> None:
    """Refuse a log (``where``: ``log PATH``) whose fit would take more than half of this machine's
    memory (:func:`fit_memory`, :func:`delta_pin.utils.memory.memory_limit`), in one line saying how
    many samples it may have."""
    from delta_pin.utils import memory

    need, limit = fit_memory(regressor, samples), memory.memory_limit()
    if need <= limit:
        return
    per = regressor.dof * regressor.size * FIT_BYTES_PER_ENTRY
    raise InvalidParameterError(
        f"{where} has {'' if exact else 'about '}{samples:,} samples: a fit of robot "
        f"{regressor.robot.name!r} holds about {memory.format_size(need)} along them "
        f"({memory.format_size(per)} a sample: {regressor.dof} joints x {regressor.size} regressor columns "
        f"x {FIT_BYTES_PER_ENTRY} bytes), more than "
        f"{memory.format_size(limit)} (half of this machine's memory); shorten the log to at most "
        f"{limit // per:,} samples (cut it, or record a shorter excitation)"
    )


def check_log_memory(path: str | Path, robot) -> None:
    """:func:`check_fit_memory` for the log file at ``path`` before it is read: its sample lines
    counted (:func:`~delta_pin.identification.log.count_samples`, up to what the limit allows).
    ``robot``: a robot or its :class:`ClosedChainRegressor`. A missing file passes (``read_log``
    names it)."""
    from delta_pin.utils.memory import memory_limit

    regressor = robot if isinstance(robot, ClosedChainRegressor) else ClosedChainRegressor(robot)
    if not Path(path).is_file():
        return
    most = memory_limit() // (regressor.dof * regressor.size * FIT_BYTES_PER_ENTRY)
    samples, exact = count_samples(path, stop=most)
    check_fit_memory(regressor, samples, f"log {path}", exact)


def _stride(log: IdentificationLog) -> int:
    """Every stride-th sample is evaluated in full (the rest interpolated): a coarse rate >= 200 Hz."""
    return max(1, int(log.sample_rate // 200))


# The fit is hundreds of least-squares and QR calls on matrices of a few hundred columns: BLAS's
# threads cost more than they give there, and many times more when the cores are shared (a sweep, a
# CI job beside it); one thread is faster on an idle machine too (benchmarks/bench_identification_mujoco.py,
# docs/benchmarks.md)
ONE_BLAS_THREAD = threadpool_limits.wrap(limits=1, user_api="blas")


@ONE_BLAS_THREAD
def identify(
    robot,
    data: IdentificationLog | str | Path,
    *,
    columns: JointColumns | None = None,
    massless: str = "fixed",
    cutoff: float = 20.0,
    consistent: bool = True,
    prior_robot=None,
    refine_stribeck: bool = False,
    essential: bool = True,
    velocities: str = "positions",
) -> IdentificationResult:
    """Identify ``robot``'s base parameters from a log (docs/identification.md).

    Args:
        robot: the robot as loaded from its (CAD) file: its kinematics are taken as exact, its
            inertias only as the prior of the physically consistent estimate.
        data: an :class:`~delta_pin.identification.log.IdentificationLog` or the path of a CSV log.
        columns: the actuated-joint columns (default: :class:`ClosedChainRegressor`'s).
        massless: bodies without mass in the file: ``"fixed"`` or ``"free"``.
        cutoff: the position filter's cut-off [Hz].
        consistent: also compute the physically consistent estimate.
        prior_robot: the robot whose parameters are the prior (default ``robot``).
        refine_stribeck: refine the Stribeck velocity v_s by a 1-D search (variable projection).
        essential: set the base parameters not significantly different from 0 to 0 and re-fit the
            rest (:func:`~delta_pin.identification.estimation.essential_fit`; listed in
            ``result.dropped``); ``False`` fits every base parameter.
        velocities: ``"positions"`` (the default): the joint velocities are the derivative of the
            filtered positions, a log's ``qd`` columns unused; ``"logged"``: the log's ``qd``. A log
            with ``qd`` has its lag behind q's derivative measured either way
            (``result.velocity_lag``), and a lag beyond
            :data:`~delta_pin.identification.estimation.VELOCITY_LAG_SAMPLES` of a sample is a
            warning.

    Raises:
        InvalidParameterError: a bad log (one line: column, line), another robot's log (its
            joints, or its header's robot and kinematics_sha256:
            :func:`~delta_pin.identification.log.check_log_robot`), a constant torque column, a log
            shorter than :func:`minimum_samples` or whose fit would take more than half of this
            machine's memory (:func:`check_fit_memory`; a file's samples counted before it is read),
            an excitation that leaves base parameters unidentifiable (named). Torques far from the CAD
            model's (beyond :data:`TORQUE_SCALE_LIMIT`) are a warning in ``result.warnings``.
    """
    timings = {}
    start = time.perf_counter()
    regressor = ClosedChainRegressor(robot, columns, massless=massless)
    if not isinstance(data, IdentificationLog):
        check_log_memory(data, regressor)  # before reading it all
        data = read_log(data, robot.actuated_joints)
    check_log_robot(data, robot)  # its joints and its header's robot
    check_torques(data)
    check_fit_memory(regressor, len(data), data.where)
    base = base_parameters(regressor)
    timings["base_parameters"] = time.perf_counter() - start
    _check_log_length(data, cutoff, base.rank, regressor)
    t0 = time.perf_counter()
    states = filtered_states(data, cutoff=cutoff, velocities=velocities)
    lag = None if data.alpha_dot is None else velocity_lag(data, cutoff=cutoff)
    timings["filter"] = time.perf_counter() - t0
    if refine_stribeck and regressor.columns.stribeck_velocity is not None:
        regressor = _refine_stribeck(regressor, states, data, massless, cutoff)
    t0 = time.perf_counter()
    Y, tau = parallel_filter(
        log_regressor(regressor, states, _stride(data)), states.tau, data.sample_rate, cutoff
    )
    timings["regressor"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    names = base.short_names()
    # the filtered rows are band-limited to the cut-off: keep one per Nyquist interval, so that
    # their noise is (nearly) independent and the covariance formula holds (estimation docstring)
    step = decimation(data.sample_rate, cutoff)
    if regressor.columns.coulomb or regressor.columns.stribeck_velocity is not None:
        speed = reversal_speed(regressor)
        mask = reversal_mask(states.alpha_dot, data.sample_rate, cutoff, speed)[::step]
    else:  # no smooth sign: nothing to drop
        mask = np.ones(states.alpha_dot.shape, bool)[::step]
    Y, tau = Y[::step], tau[::step]
    Y_base = base.reduce(Y)
    # what the excitation cannot see at all, named; then what the rows kept cannot
    check_identifiable(Y_base.reshape(-1, base.rank), names)
    W = Y_base.reshape(-1, base.rank)[mask.ravel()]
    check_identifiable(W, names)
    dropped: list = []
    kept = np.arange(base.rank)
    ols_full, wls_full = least_squares_fit(Y_base, tau, mask)
    ols, wls = ols_full, wls_full
    if essential:
        kept, dropped, ols, wls = essential_fit(Y_base, tau, mask)
        ols, wls = expand(ols, kept, base.rank), expand(wls, kept, base.rank)
    kept_columns = kept
    # physical friction: the WLS problem with fc, fs, fv, Ia >= 0 where each is a base parameter alone
    lower = _friction_lower_bounds(regressor, base)
    bounded = np.zeros(base.rank)
    bounded[kept] = bounded_fit(Y_base[:, :, kept], tau, mask, wls.weights, lower[kept])
    norms = np.linalg.norm(W, axis=0)
    singular = np.linalg.svd(W / norms, compute_uv=False)
    timings["least_squares"] = time.perf_counter() - t0
    theta_nominal = regressor.parameters(prior_robot or robot)
    estimate = None
    if consistent:
        t0 = time.perf_counter()

        # on every base parameter's WLS estimate (the essential fit's zeros are a choice of model,
        # the consistent estimate's bodies make their own)
        estimate = consistent_estimate(regressor, base, wls_full.beta, wls_full.R, theta_nominal)
        timings["consistent"] = time.perf_counter() - t0
    residual = np.where(mask, tau - Y_base @ wls.beta, 0.0)
    kept = np.maximum(mask.sum(axis=0), 1)
    scale = torque_scale(regressor, Y, tau, mask, prior_robot or robot)
    result = IdentificationResult(
        regressor=regressor,
        base=base,
        names=names,
        expressions=base.expressions(),
        ols=ols,
        wls=wls,
        consistent=estimate,
        theta_nominal=theta_nominal,
        residual_rms=np.sqrt((residual**2).sum(axis=0) / kept),
        tau_rms=np.sqrt((np.where(mask, tau, 0.0) ** 2).sum(axis=0) / kept),
        condition=float(singular[0] / singular[-1]),
        samples=int(mask.sum(axis=0).min()),
        singular_values=singular / singular[0],
        cutoff=cutoff,
        timings=timings,
        dropped=[(names[k], t) for k, t in dropped],
        torque_scale=scale,
        warnings=[scale["warning"]] if scale.get("warning") else [],
        velocities=velocities,
        velocity_lag=lag,
    )
    if lag is not None:
        result.warnings.extend(_velocity_lag_lines(lag, data, velocities))
    result.notes.extend(_stribeck_notes(regressor, Y_base, tau, mask, kept_columns, names, wls))
    if estimate is not None and not estimate.success:
        result.warnings.append(
            f"warning: the physically consistent estimate did not converge ({estimate.message}): it is "
            "reported but not optimal, and no robot.urdf is written from it"
        )
    result.bounded_beta = bounded
    result.friction = _friction_estimates(regressor, base, bounded)
    result.friction_unconstrained = _friction_estimates(regressor, base, wls.beta)
    if getattr(robot, "delta", None) is not None:
        t0 = time.perf_counter()
        lumped_names, A, fit = delta_lumped_map(regressor, base)
        values = np.linalg.lstsq(A, wls.beta, rcond=None)[0]
        result.lumped = {"names": lumped_names, "values": values.tolist(), "span_residual": fit}
        result.xacro_arguments = _delta_xacro_arguments(robot, values, result.friction)
        timings["lumped"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - start
    return result


def _stribeck_notes(regressor, Y_base, tau, mask, kept, names, wls) -> list[str]:
    """One note per Stribeck column the fit kept (``fs[joint]``, |beta| / sigma >= 3): what the fit
    without that column gives -- the joint's torque residual and its Coulomb term -- so that a
    statistically significant but physically small term shows as what it is. On a robot whose dry
    friction is not tanh-shaped (MuJoCo's ``frictionloss``) the Stribeck column fits that difference
    and takes from the Coulomb term (docs/identification.md, "Friction")."""
    notes = []
    joints = list(regressor.robot.actuated_joints)
    for k in kept:
        name = names[k]
        if not name.startswith("fs[") or name[3:-1] not in joints:
            continue
        joint = name[3:-1]
        j = joints.index(joint)
        others = np.array([i for i in kept if i != k])
        _, without = least_squares_fit(Y_base[:, :, others], tau, mask)
        rows = mask[:, j]
        with_fs = float(np.sqrt(np.mean((tau[rows, j] - Y_base[rows, j, :] @ wls.beta) ** 2)))
        without_fs = float(np.sqrt(np.mean((tau[rows, j] - Y_base[rows, j][:, others] @ without.beta) ** 2)))
        coulomb = f"fc[{joint}]"
        change = ""
        if coulomb in names and names.index(coulomb) in others:
            c = names.index(coulomb)
            after = without.beta[list(others).index(c)]
            change = f", and {coulomb} from {wls.beta[c]:.4g} to {after:.4g}"
        t = abs(wls.beta[k]) / wls.std[k]
        notes.append(
            f"note: {name} = {wls.beta[k]:.4g} kept (|beta|/sigma = {t:.1f}); without it joint {joint}'s "
            f"torque residual changes by {100.0 * (without_fs / with_fs - 1.0):+.3g} %{change} "
            "(--friction-model coulomb fits without Stribeck terms)"
        )
    return notes


def _velocity_lag_lines(lag: np.ndarray, log: IdentificationLog, velocities: str) -> list[str]:
    """One line for the joints whose logged qd lags q's derivative by more than
    VELOCITY_LAG_SAMPLES of a sample: a warning where the fit used qd, a note where it did not."""
    samples = lag * log.sample_rate
    late = [
        f"{joint} {lag_j * 1e3:.3g} ms ({n:.2f} samples)"
        for joint, lag_j, n in zip(log.joints, lag, samples)
        if np.isfinite(n) and abs(n) > VELOCITY_LAG_SAMPLES
    ]
    if not late:
        return []
    what = "; ".join(late)
    if velocities == "logged":
        return [
            f"warning: the log's qd lags the derivative of q ({what}; a backward difference lags by 0.5 "
            "samples): the fit used qd (--velocities logged), whose lag biases friction and inertia; "
            "the default takes the velocities from the positions"
        ]
    return [
        f"note: the log's qd lags the derivative of q ({what}); unused: the velocities are the positions'"
    ]


def _check_log_length(log: IdentificationLog, cutoff: float, rank: int, regressor) -> None:
    """Refuse, before any filtering, a log shorter than :func:`minimum_samples` (before: a
    10-sample log ended in filtfilt's 'unexpected ValueError: ... padlen')."""
    if len(log) < 2:
        raise InvalidParameterError(f"{log.where} has {len(log)} samples; a fit needs a recorded run")
    rate = log.sample_rate
    check_cutoff(cutoff, rate)
    need = minimum_samples(rate, cutoff, rank, regressor.dof)
    if len(log) < need:
        raise InvalidParameterError(
            f"{log.where} has {len(log)} samples; fitting the {rank} base parameters of robot "
            f"{regressor.robot.name!r} at {rate:g} Hz needs at least {need} ({need / rate:.3g} s): more "
            f"rows than base parameters ({rank // regressor.dof + 1} per joint for {regressor.dof} joints), "
            f"one every {decimation(rate, cutoff)} samples (the Nyquist interval of the {cutoff:g} Hz "
            "filter), and 0.05 s trimmed at each end; record a longer excitation (identify excite "
            "--duration)"
        )


def _friction_lower_bounds(regressor, base) -> np.ndarray:
    """(r,): 0 for a base parameter that is one ``fv``, ``fc``, ``fs`` or ``Ia`` column alone (its
    K row zero, and no other base parameter lumps that column), ``-inf`` for the rest."""
    lower = np.full(base.rank, -np.inf)
    n = regressor.inertial_count
    lumped = set()
    for i in range(base.rank):
        lumped |= {int(base.dependent[j]) for j in np.flatnonzero(base.K[i])}
    for kind, (prefix, _) in enumerate(regressor.columns.kinds()):
        if prefix not in ("fv", "fc", "fs", "Ia"):
            continue
        for j in range(regressor.dof):
            column = n + kind * regressor.dof + j
            hits = np.flatnonzero(base.independent == column)
            if hits.size and not np.any(base.K[hits[0]]) and column not in lumped:
                lower[hits[0]] = 0.0
    return lower


def _friction_estimates(regressor, base, beta) -> dict:
    """{"fv": (dof,), ...}: the joint columns that are base parameters of their own, per joint
    (NaN where a joint column is lumped with others or absent)."""
    out = {}
    n = regressor.inertial_count
    index = {int(k): i for i, k in enumerate(base.independent)}
    for kind, (prefix, _) in enumerate(regressor.columns.kinds()):
        values = []
        for j in range(regressor.dof):
            column = n + kind * regressor.dof + j
            i = index.get(column)
            alone = i is not None and not np.any(base.K[i])
            values.append(float(beta[i]) if alone else math.nan)
        out[prefix] = values
    return out


def _delta_xacro_arguments(robot, lumped: np.ndarray, friction: dict) -> dict:
    """m_a, m_b, m_o [kg] (and the friction's mu_v, mu_d, mu_s at the URDF's r_a and F_n = 15 N) of
    the Delta whose eqs. 7-9 are the identified lumped terms (means over the arms):
    I = (m_a/3 + m_b/2) l_a^2, k = (m_a + m_b) l_a / 2, m_eq = m_o + 3/2 m_b."""
    p = robot.delta.params
    inertia, lever, m_eq = float(np.mean(lumped[:3])), float(np.mean(lumped[3:6])), float(lumped[6])
    m_a = 6.0 * (lever / p.l_a - inertia / p.l_a**2)
    m_b = 2.0 * lever / p.l_a - m_a
    m_o = m_eq - 1.5 * m_b
    args = {"m_a": m_a, "m_b": m_b, "m_o": m_o}
    stribeck = p.friction
    if stribeck is not None and friction:
        normal = 15.0  # the Friction default: eq. 12's coefficients are per newton of F_n
        r_a = stribeck.r_a

        def mean(values):  # NaN where every joint's is (lumped) or the column is absent: no warning
            values = np.asarray(values, dtype=float)
            return float(values[np.isfinite(values)].mean()) if np.isfinite(values).any() else math.nan

        fv, fc = mean(friction.get("fv", [math.nan])), mean(friction.get("fc", [math.nan]))
        fs = mean(friction.get("fs", [0.0]))
        if np.isfinite(fv) and np.isfinite(fc):
            args.update(
                mu_v=fv / r_a,
                mu_d=fc / (normal * r_a),
                mu_s=(fc + (fs if np.isfinite(fs) else 0.0)) / (normal * r_a),
            )
    return {k: float(v) for k, v in args.items()}


def _refine_stribeck(regressor, states, log, massless, cutoff):
    """The Stribeck velocity v_s [m/s] minimising the WLS residual (a bounded 1-D search over
    log v_s, the linear parameters re-fitted at each v_s: variable projection)."""
    from dataclasses import replace

    from scipy.optimize import minimize_scalar

    base = base_parameters(regressor)
    n = regressor.inertial_count
    Y_tree, tau = parallel_filter(log_regressor(regressor, states, _stride(log))[:, :, :n], states.tau,
                                  log.sample_rate, cutoff)  # fmt: skip

    def cost(log_vs):
        columns = replace(regressor.columns, stribeck_velocity=float(np.exp(log_vs)))
        joint = parallel_filter(
            columns.block(states.alpha_dot, states.alpha_ddot), tau, log.sample_rate, cutoff
        )[0]
        Y = np.concatenate([Y_tree, joint], axis=2)
        W = base.reduce(Y).reshape(-1, base.rank)
        beta, *_ = np.linalg.lstsq(W, tau.reshape(-1), rcond=None)
        return float(((W @ beta - tau.reshape(-1)) ** 2).sum())

    v0 = regressor.columns.stribeck_velocity
    found = minimize_scalar(cost, bounds=(np.log(v0 / 10), np.log(v0 * 10)), method="bounded",
                            options={"xatol": 1e-4})  # fmt: skip
    columns = replace(regressor.columns, stribeck_velocity=float(np.exp(found.x)))
    return ClosedChainRegressor(regressor.robot, columns, massless=massless)


def reversal_speed(regressor: ClosedChainRegressor) -> float:
    """The speed [rad/s or m/s] below which a joint's rows near a velocity reversal are dropped by
    the fit and split off by :func:`validate`: 10 x the smooth sign's velocity scale (tanh = 1 - 4e-9
    beyond; 0.1 rad/s by default), within 1 / cutoff of the sample
    (:func:`~delta_pin.identification.estimation.reversal_mask`)."""
    return 10.0 * regressor.columns.sign_velocity_scale


def _torque_error(error: np.ndarray, measured: np.ndarray, rows: np.ndarray) -> dict:
    """RMS and max of ``error`` per joint over ``rows`` (N, dof) bool, absolute and relative to the
    measured torque's RMS over the same rows (NaN for a joint with no row)."""
    count = rows.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        rms = np.sqrt(np.where(rows, error**2, 0.0).sum(axis=0) / count)
        rms_tau = np.sqrt(np.where(rows, measured**2, 0.0).sum(axis=0) / count)
        peak = np.where(count > 0, np.where(rows, np.abs(error), 0.0).max(axis=0), np.nan)
        total = float(np.sqrt(np.where(rows, error**2, 0.0).sum() / np.where(rows, measured**2, 0.0).sum()))
    return {
        "rms": rms.tolist(),
        "max": peak.tolist(),
        "rms_relative": (rms / rms_tau).tolist(),
        "max_relative": (peak / rms_tau).tolist(),
        "rms_relative_all": total,
        "rows": count.astype(int).tolist(),
    }


@ONE_BLAS_THREAD
def validate(
    result: IdentificationResult, log: IdentificationLog | str | Path, estimate: str = "wls"
) -> dict:
    """Torque prediction on a log the fit never saw: per joint the RMS and max of the error, and
    both relative to the measured torque's RMS, over every row and away from velocity reversals.

    Scored over every row, a good fit and a broken one hardly differ: a joint's rows near a velocity
    reversal (|alpha_dot_j| < :func:`reversal_speed`, 0.1 rad/s, within 1 / cutoff: the fit's own
    :func:`~delta_pin.identification.estimation.reversal_mask`) hold the smooth Coulomb sign's
    millisecond dynamics that no filtered velocity resolves, and their error swamps the rest.
    ``away_from_reversals`` scores the other rows only (each joint relative to its torque's RMS over
    those rows), whatever the fit's friction columns.

    Returns:
        {"rms": (dof,), "max": (dof,), "rms_relative": (dof,), "max_relative": (dof,),
        "rms_relative_all": the error's RMS over all joints / the torque's, "rows": (dof,),
        "away_from_reversals": the same keys over the rows away from reversals,
        "reversal_mask": {"speed", "window_s", "fraction_near": (dof,) the share of rows dropped}}.
    """
    robot = result.regressor.robot
    if not isinstance(log, IdentificationLog):
        check_log_memory(log, result.regressor)  # before reading it all
        log = read_log(log, robot.actuated_joints)
    check_log_robot(log, robot)
    check_torques(log)
    check_fit_memory(result.regressor, len(log), log.where)
    predicted, measured, alpha_dot = result._predict_states(log, estimate)
    error = predicted - measured
    speed = reversal_speed(result.regressor)
    away = reversal_mask(alpha_dot, log.sample_rate, result.cutoff, speed)
    out = _torque_error(error, measured, np.ones(away.shape, bool))
    out["away_from_reversals"] = _torque_error(error, measured, away)
    out["reversal_mask"] = {
        "speed": speed,
        "window_s": 1.0 / result.cutoff,
        "fraction_near": (1.0 - away.mean(axis=0)).tolist(),
    }
    return out


def identified_robot(result: IdentificationResult, estimate: str = "consistent"):
    """A :class:`~delta_pin.model.closed_chain.ClosedChainRobot` with the identified standard
    parameters (the physically consistent estimate; its bodies physical) and rotor inertias (in
    ``model.armature``: what ``robot.urdf`` carries as ``drake:rotor_inertia``), to build a controller's
    nominal model (:class:`~delta_pin.control.nominal.ClosedChainNominalModel`). For a Delta, prefer
    ``load_delta(**result.xacro_arguments)`` (the paper's analytic model at the identified masses)."""
    if result.consistent is None:
        raise InvalidParameterError(
            "the fit was made with consistent=False: no standard parameters to build a robot from"
        )
    regressor = result.regressor
    robot = regressor.robot.with_payload(0.0)
    theta = result.consistent.theta
    for i, k in enumerate(regressor.bodies):
        inertia = pin.Inertia.FromDynamicParameters(theta[10 * i : 10 * i + 10])
        robot.model.inertias[int(k) + 1] = inertia
        robot.tree.inertias[int(k) + 1] = inertia
    values = dict(zip(regressor.names, theta, strict=True))
    for joint, v in zip(robot.actuated_joints, robot.actuated_indices, strict=True):
        if f"Ia[{joint}]" in values:  # the rotor inertia: on M's diagonal (model.armature)
            robot.model.armature[v] = robot.tree.armature[v] = values[f"Ia[{joint}]"]
    robot.model_changed()  # a compiled model built before holds the old inertias
    return robot


def perturbed_robot(robot, spread: float = 0.3, seed: int = 0):
    """A copy of ``robot`` whose every body with mass has its inertia (mass, first moment, inertia:
    the COM kept) scaled by a seeded factor uniform in [1 - spread, 1 + spread]: a "true" robot
    the CAD file gets wrong. For a Delta prefer ``load_delta(m_a=..., m_b=..., m_o=...)``."""
    if not 0.0 <= spread < 1.0:
        raise InvalidParameterError(f"mass spread {spread} must lie in [0, 1)")
    rng = np.random.default_rng(seed)
    true = robot.with_payload(0.0)
    for j in range(1, true.model.njoints):
        inertia = true.model.inertias[j]
        if inertia.mass > 0.0:
            scaled = pin.Inertia.FromDynamicParameters(
                inertia.toDynamicParameters() * rng.uniform(1 - spread, 1 + spread)
            )
            true.model.inertias[j] = scaled
            true.tree.inertias[j] = scaled
    true.model_changed()  # a compiled model built before holds the old inertias
    return true


def write_trajectory(path: str | Path, trajectory: FourierExcitation, robot, rate: float = 1000.0) -> Path:
    """The excitation as a CSV a drive can play: ``t, q[J], qd[J], qdd[J]`` at ``rate`` [Hz], its
    Fourier coefficients in the header (``# fourier: {json}``, what :func:`read_trajectory` reads)."""
    import json

    from delta_pin.utils.atomic import atomic_open

    t = np.arange(0.0, trajectory.duration + 0.5 / rate, 1.0 / rate)
    alpha, alpha_dot, alpha_ddot = trajectory.evaluate(t)
    joints = robot.actuated_joints
    columns = [
        "t",
        *(f"q[{j}]" for j in joints),
        *(f"qd[{j}]" for j in joints),
        *(f"qdd[{j}]" for j in joints),
    ]
    with atomic_open(path, "w", newline="") as handle:
        handle.write("# delta-pin excitation trajectory\n")
        # whose excitation this is, checked by read_trajectory (as identify checks a log's)
        handle.write(f"# robot: {robot.name}\n# kinematics_sha256: {kinematics_digest(robot)}\n")
        handle.write(f"# sample_rate_hz: {rate:g}\n")
        handle.write(f"# fourier: {json.dumps(trajectory.metadata())}\n")
        handle.write(",".join(columns) + "\n")
        np.savetxt(handle, np.hstack([t[:, None], alpha, alpha_dot, alpha_ddot]), delimiter=",", fmt="%.12g")
    return Path(path)


def read_trajectory(path: str | Path, robot) -> FourierExcitation:
    """The excitation of a file written by :func:`write_trajectory` (``delta-pin identify excite``),
    for ``robot``: where its header names a robot (``# robot:``) it must be ``robot``'s name, and a
    ``# kinematics_sha256:`` must be ``robot``'s :func:`~delta_pin.identification.log.kinematics_digest`
    (an excitation keeps to one robot's workspace, limits and singularity margin); a header without
    them (a file of anyone's) is accepted. Then it must move ``robot``'s number of joints.

    Raises:
        InvalidParameterError: no such file, no ``# fourier:`` header, another robot's excitation, or
            joints that are not the robot's; one line.
    """
    import json

    path = Path(path)
    if not path.is_file():
        raise InvalidParameterError(f"trajectory {path}: no such file")
    try:
        lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    except UnicodeDecodeError:
        raise InvalidParameterError(f"trajectory {path} is not a text file") from None
    header: dict[str, str] = {}
    fourier = None
    for number, line in enumerate(lines, 1):
        if not line.startswith("#"):
            break
        key, colon, value = line[1:].partition(":")
        if colon:
            header.setdefault(key.strip(), value.strip())
        if line.startswith("# fourier:") and fourier is None:
            fourier = number, line.split(":", 1)[1]
    if fourier is None:
        raise InvalidParameterError(
            f"trajectory {path}: no '# fourier:' header line (write it with delta-pin identify excite)"
        )
    named = header.get("robot")
    if named is not None and named != robot.name:
        raise InvalidParameterError(
            f"trajectory {path} was excited for robot {named!r} (its header's '# robot: {named}'), not for "
            f"robot {robot.name!r}, the one given: simulate it with the robot it was made for "
            "(--robot/--urdf/--set as for identify excite), or excite this robot"
        )
    digest = header.get("kinematics_sha256")
    if named is not None and digest is not None and digest != kinematics_digest(robot):
        raise InvalidParameterError(
            f"trajectory {path} was excited for a robot {named!r} of other kinematics (its header's "
            f"kinematics_sha256: {digest}, the robot given: {kinematics_digest(robot)}): another --urdf, "
            "--set (R, r, l_a, l_b) or --robot file than the one identify excite had; give that one, or "
            "excite this robot"
        )
    number, text = fourier
    try:
        trajectory = FourierExcitation.from_metadata(json.loads(text))
    except (ValueError, KeyError, TypeError) as error:
        raise InvalidParameterError(
            f"trajectory {path}: line {number}: bad fourier header ({error})"
        ) from None
    if trajectory.alpha0.shape != (robot.dof,):
        raise InvalidParameterError(
            f"trajectory {path}: it moves {trajectory.alpha0.size} joints, "
            f"robot {robot.name!r} has {robot.dof}"
        )
    return trajectory

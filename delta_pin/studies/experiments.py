"""The paper's Section V scenario as data: a :class:`RunSpec` names a controller, a path and the
conditions; :func:`run_spec` builds everything from it and simulates. ``delta-pin run``,
``compare``, ``sweep`` and ``reproduce`` are all made of this one piece.

Section V defaults: Table 1 robot, Stribeck friction with F̄_n = 15 N, uncertainty magnitudes
Delta_m = Delta_fc = Delta_f = 0.3 (sinusoids of the paper, or seeded band-limited noise when a
seed is given), F̄ = [2, 4, 6] N m known to the controllers, alpha_0 = 0.3322 rad on every joint
(the paper's initial deviation: path I starts at 0.2492 rad, erratum 4), alpha_dot_0 = 0,
Pinocchio plant, continuous mode, 15 s for path I and 10 s for path II.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from delta_pin.choices import CONTROLLERS, PATHS, VELOCITIES
from delta_pin.control import Controller, DeltaNominalModel
from delta_pin.control.registry import LawOptions, declaration
from delta_pin.errors import InvalidParameterError
from delta_pin.model.delta_robot import load_delta
from delta_pin.model.friction import Friction
from delta_pin.model.robot import Delta
from delta_pin.model.trajectory import AdeptCycle, PathI, PathII, Trajectory
from delta_pin.sim.arguments import MODES
from delta_pin.sim.batch import simulate_batch
from delta_pin.sim.drive import Encoder, check_delay, check_torque_limit
from delta_pin.sim.integrators import INTEGRATORS
from delta_pin.sim.run import Run
from delta_pin.sim.runner import simulate
from delta_pin.sim.uncertainty import PAPER_NOMINAL_DISTURBANCE, PaperUncertainty, RandomUncertainty
from delta_pin.utils.memory import memory_limit  # re-exported: it lived here (cli imports it from here)

__all__ = [
    "CONTROLLERS",
    "PATHS",
    "RunSpec",
    "batch_group",
    "build_controller",
    "build_trajectory",
    "check_specs",
    "estimated_memory",
    "memory_limit",
    "run_batch",
    "run_spec",
]

DEFAULT_T_END = {"I": 15.0, "II": 10.0, "adept": 3.0}  # [s]
PAPER_ALPHA0 = 0.3322  # [rad] on every joint (Section V)


@dataclass(frozen=True)
class RunSpec:
    """One simulation of the Section V study (SI units).

    Attributes:
        controller: one of :data:`CONTROLLERS`.
        path: ``"I"`` (eq. 66), ``"II"`` (eq. 69) or ``"adept"`` (pick-and-place cycle).
        plant: ``"pinocchio"`` or ``"analytic"``.
        mode: ``"continuous"`` or ``"sampled"``.
        integrator: ``"auto"`` (RK4 sampled, the compiled Radau IIA continuous), ``"rk4"``
            (sampled), ``"radau"`` (continuous, error-controlled) or ``"bdf2"`` (continuous, fixed
            steps; batched by sweeps); every one the compiled core's.
        t_end: duration [s]; ``None`` for the path's default (15 s, 10 s, 3 s).
        dt: sample / control period [s].
        friction_compensation: include M̄_f in the controller.
        sampling_aware: cap the robust gain for a zero-order-hold loop of period dt.
        delta_m, delta_fc, delta_f: uncertainty magnitudes Delta_m, Delta_fc, Delta_f [-].
        seed: ``None`` for the paper's sinusoids, an integer for seeded band-limited noise.
        friction: Stribeck friction in the plant.
        alpha0: initial angle of every joint [rad]; ``None`` starts on the path.
        gains: gain overrides by name (e.g. ``{"xi": 0.01}``).
        encoder_bits: sampled mode: an encoder of 2^bits counts per turn on each joint
            (:class:`~delta_pin.sim.drive.Encoder`); ``None``: the controller sees the true state.
        velocity: with an encoder, the velocity the controller gets: ``"difference"``, ``"none"``
            (its own estimate) or ``"exact"``.
        delay: sampled mode: samples of computation delay (a digital law such as ``tdc`` is told
            the same delay).
        torque_limit: sampled mode: the drive's saturation [N m]; ``None``: none.
    """

    controller: str = "design1"
    path: str = "I"
    plant: str = "pinocchio"
    mode: str = "continuous"
    integrator: str = "auto"
    t_end: float | None = None
    dt: float = 1e-3
    friction_compensation: bool = True
    sampling_aware: bool = False
    delta_m: float = 0.3
    delta_fc: float = 0.3
    delta_f: float = 0.3
    seed: int | None = None
    friction: bool = True
    alpha0: float | None = PAPER_ALPHA0
    gains: dict = field(default_factory=dict)
    encoder_bits: int | None = None
    velocity: str = "difference"
    delay: int = 0
    torque_limit: float | None = None

    def __post_init__(self) -> None:
        if self.controller not in CONTROLLERS:
            raise InvalidParameterError(
                f"controller={self.controller!r} must be one of {', '.join(CONTROLLERS)}"
            )
        if self.path not in PATHS:
            raise InvalidParameterError(f"path={self.path!r} must be one of {', '.join(PATHS)}")
        if self.mode not in MODES:
            raise InvalidParameterError(f"mode={self.mode!r} must be one of {', '.join(MODES)}")
        if self.integrator not in ("auto", *INTEGRATORS):
            raise InvalidParameterError(
                f"integrator={self.integrator!r} must be one of auto, {', '.join(INTEGRATORS)}"
            )
        _check_seconds("dt", self.dt, "e.g. 0.001")
        if self.t_end is not None:
            _check_seconds("t_end", self.t_end, "or None for the path's default")
        if self.velocity not in VELOCITIES:  # checked with or without an encoder: never ignored
            raise InvalidParameterError(f"velocity={self.velocity!r} must be one of {', '.join(VELOCITIES)}")
        self.sensor()  # the encoder, delay and torque limit are checked here, before any run
        check_delay(self.delay)
        check_torque_limit(self.torque_limit, 3)
        samples = self.samples
        if self.delay >= samples:  # no command would ever reach the plant
            raise InvalidParameterError(
                f"delay={self.delay} samples is not shorter than the run, {samples} samples (t_end "
                f"{self.duration:g} s at dt {self.dt:g} s): give a delay below {samples}, or a longer t_end"
            )

    @property
    def samples(self) -> int:
        """The number of samples t_k = k dt of the run, t_0 = 0 and t_end included."""
        return round(min(self.duration / self.dt, 1e18)) + 1

    @property
    def drive_effects(self) -> bool:
        """Whether the run has an encoder, a delay or a torque limit (sampled mode only)."""
        return self.encoder_bits is not None or self.delay > 0 or self.torque_limit is not None

    def sensor(self) -> Encoder | None:
        """The spec's encoder (``None`` without ``encoder_bits``)."""
        if self.encoder_bits is None:
            return None
        return Encoder(bits=self.encoder_bits, velocity=self.velocity)

    @property
    def duration(self) -> float:
        """t_end [s], or the path's default."""
        return DEFAULT_T_END[self.path] if self.t_end is None else self.t_end

    def label(self) -> str:
        """A short, file-name-safe name, e.g. ``design1_I`` or ``design2_II_noFC``."""
        return f"{self.controller}_{self.path}" + ("" if self.friction_compensation else "_noFC")

    def with_(self, **changes) -> RunSpec:
        """A copy with some fields changed."""
        return replace(self, **changes)

    def as_dict(self) -> dict:
        return asdict(self)


def _check_seconds(name: str, value, hint: str) -> None:
    """A duration field of :class:`RunSpec`: a finite number of seconds > 0."""
    if (
        isinstance(value, bool)
        or not isinstance(value, numbers.Real)
        or not (math.isfinite(value) and value > 0)
    ):
        raise InvalidParameterError(f"{name}={value!r} must be a finite number of seconds > 0, {hint}")


# bytes per sample that a run holds at its peak, measured with the peak RSS of 10-30 s Adept runs
# on the analytic plant (2.4 kB continuous: the reference on a dt/4 grid, the loop's internals;
# 0.63 kB sampled; measured when the Python loop ran them), rounded up
BYTES_PER_SAMPLE = {"continuous": 2560, "sampled": 1024}


def estimated_memory(spec: RunSpec) -> int:
    """About how many bytes the arrays of a run of ``spec`` take at their peak (reference
    tables, truth tables, the recorded samples): :data:`BYTES_PER_SAMPLE` per sample."""
    samples = spec.duration / spec.dt + 1
    return int(min(samples, 1e30) * BYTES_PER_SAMPLE[spec.mode])


def build_trajectory(path: str) -> Trajectory:
    """Path I, path II or the Adept cycle by name."""
    return {"I": PathI, "II": PathII, "adept": AdeptCycle}[path]()


def build_uncertainty(spec: RunSpec):
    """The plant's time-varying truth of ``spec``. With every magnitude 0 the plant is the nominal
    one, the known disturbance F̄ included (the controllers compensate F̄, so the plant has it)."""
    if spec.seed is None:
        return PaperUncertainty(spec.delta_m, spec.delta_fc, spec.delta_f, PAPER_NOMINAL_DISTURBANCE)
    return RandomUncertainty(
        spec.delta_m,
        spec.delta_fc,
        spec.delta_f,
        seed=spec.seed,
        nominal_disturbance=PAPER_NOMINAL_DISTURBANCE,
    )


def build_controller(spec: RunSpec, robot: Delta, trajectory: Trajectory | None = None) -> Controller:
    """The controller of ``spec`` on the Delta's analytic nominal model (m̄_o from the URDF,
    F̄ = [2, 4, 6] N m, F̄_n = 15 N).

    Raises:
        InvalidParameterError: a gain name the controller does not have, or a value it cannot take.
    """
    names = declaration(spec.controller).gain_names()
    unknown = sorted(set(spec.gains) - set(names))
    if unknown:  # before the law is built: its own TypeError named one and none of the valid ones
        raise InvalidParameterError(
            f"controller {spec.controller!r} has no gain {', '.join(unknown)}; its gains: {', '.join(names)}"
        )
    try:
        return _build_controller(spec, robot, trajectory)
    except TypeError as exc:
        raise InvalidParameterError(
            f"controller {spec.controller!r} does not take gains {spec.gains}: {exc}"
        ) from None
    except ValueError as exc:
        if isinstance(exc, InvalidParameterError) or not spec.gains:
            raise
        # a gain of the wrong kind (xi='abc' from a sweep axis) that the law's own arrays refuse
        raise InvalidParameterError(
            f"controller {spec.controller!r}: gains {spec.gains} are not valid ({exc}); give numbers"
        ) from None


def _build_controller(spec: RunSpec, robot: Delta, trajectory: Trajectory | None) -> Controller:
    law = declaration(spec.controller)
    start = None
    if law.needs_start:  # the LQR: linearised at the path's start
        trajectory = trajectory or build_trajectory(spec.path)
        start = robot.inverse_kinematics(trajectory.position(0.0))
    options = LawOptions(
        dt=spec.dt, friction_compensation=spec.friction_compensation, sampling_aware=spec.sampling_aware,
        delay=spec.delay, torque_limit=spec.torque_limit, start=start,
    )  # fmt: skip
    nominal = DeltaNominalModel(robot, nominal_disturbance=PAPER_NOMINAL_DISTURBANCE)
    return law.make(nominal, options, **spec.gains)


def check_specs(specs: list[RunSpec], robot: Delta | None = None) -> None:
    """Build each distinct controller and uncertainty of ``specs`` once, so that an unknown gain
    name or an out-of-range magnitude fails here, in one line, before a study runs anything.

    Raises:
        InvalidParameterError: naming the spec's controller and the bad gain or magnitude.
    """
    robot = robot or load_delta()
    seen = set()
    for spec in specs:
        key = (
            spec.controller,
            spec.path,
            spec.dt,
            spec.sampling_aware,
            spec.delay,
            tuple(sorted(spec.gains.items())),
        )
        if key not in seen:
            seen.add(key)
            build_controller(spec, robot)
        build_uncertainty(spec)


def run_spec(spec: RunSpec, robot: Delta | None = None, progress: bool | None = False) -> Run:
    """Simulate ``spec`` (on the Table 1 robot unless ``robot`` is given); ``progress`` as in
    :func:`~delta_pin.sim.runner.simulate`."""
    robot = robot or load_delta()
    trajectory = build_trajectory(spec.path)
    controller = build_controller(spec, robot, trajectory)
    run = simulate(
        robot,
        controller,
        trajectory,
        plant=spec.plant,
        t_end=spec.duration,
        dt=spec.dt,
        mode=spec.mode,
        integrator=spec.integrator,
        alpha0=None if spec.alpha0 is None else np.full(3, spec.alpha0),
        friction=Friction() if spec.friction else None,
        uncertainty=build_uncertainty(spec),
        progress=progress,
        sensor=spec.sensor(),
        delay=spec.delay,
        torque_limit=spec.torque_limit,
    )
    run.metadata["spec"] = spec.as_dict()
    return run


def batch_group(spec: RunSpec) -> tuple | None:
    """What runs must share to be simulated in one batch (:func:`run_batch`, one task of a sweep's
    workers), or ``None`` when ``spec`` runs alone: designs I/II in continuous mode with
    ``integrator="bdf2"`` or in sampled mode (RK4) on the analytic plant, or in continuous mode,
    on the Pinocchio plant."""
    continuous = spec.mode == "continuous" and spec.integrator == "bdf2"
    sampled = spec.mode == "sampled" and spec.integrator in ("auto", "rk4")
    if not (declaration(spec.controller).batchable and (continuous or sampled)) or spec.drive_effects:
        return None  # designs I/II with a drive, and the digital laws, run one by one (compiled)
    if spec.plant == "pinocchio" and sampled:
        return None  # sampled on the Pinocchio plant: the compiled core, one run each
    vector_rho = bool(spec.gains.get("vector_rho"))
    return (spec.plant, spec.mode, spec.path, spec.duration, spec.dt, spec.alpha0, spec.friction, vector_rho)


def run_batch(specs: list[RunSpec], robot: Delta | None = None) -> list:
    """Simulate specs of one :func:`batch_group` together (:func:`delta_pin.sim.batch.simulate_batch`);
    each result is the :class:`Run` that :func:`run_spec` gives for its spec, or the
    :class:`~delta_pin.errors.SimulationError` of a run that failed.

    Raises:
        InvalidParameterError: specs from different groups, or a spec that cannot be batched.
    """
    groups = {batch_group(spec) for spec in specs}
    if None in groups or len(groups) != 1:
        raise InvalidParameterError(
            "run_batch needs specs of one batch group (designs I/II, continuous with bdf2 or sampled; "
            "same plant, path, duration, dt, alpha0, friction); got groups "
            f"{sorted(map(str, groups))}"
        )
    robot = robot or load_delta()
    first = specs[0]
    trajectory = build_trajectory(first.path)
    runs = simulate_batch(
        robot,
        [build_controller(spec, robot, trajectory) for spec in specs],
        trajectory,
        plant=first.plant,
        t_end=first.duration,
        dt=first.dt,
        mode=first.mode,
        alpha0=None if first.alpha0 is None else np.full(3, first.alpha0),
        friction=Friction() if first.friction else None,
        uncertainties=[build_uncertainty(spec) for spec in specs],
        errors="return",
    )
    for spec, run in zip(specs, runs):
        if isinstance(run, Run):
            run.metadata["spec"] = spec.as_dict()
    return runs

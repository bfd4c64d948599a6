"""The closed-loop runner: any controller, on either plant, along any path -> a :class:`Run`.

Two timings (DESIGN.md section 6):

* ``mode="sampled"`` -- a digital drive: tau_k is evaluated at t_k = k dt and held (zero-order
  hold) over [t_k, t_k + dt) while the plant integrates with ``substeps`` RK4 steps; the
  controller's internal state (rho_hat) advances once per period, z_{k+1} = z_k + dt z_dot_k;
* ``mode="continuous"`` -- the analysis of the paper: the controller is evaluated inside the
  integrator (RK4 on the plant and controller states together, step dt / substeps).

The reference alpha^d(t) is computed from the trajectory before the run starts (a path that
leaves the workspace fails at once with the time and the point).
"""

from __future__ import annotations

import json
import math
import platform
import sys
import time as _time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .atomic import atomic_open
from .control.base import Controller, Reference, as_controller
from .errors import DeltaPinError, InvalidParameterError, NonFiniteError, SimulationError
from .fast_model import njit
from .kinematics import as_vector3
from .plant import Plant, make_plant
from .progress import Progress
from .robot import Delta

__all__ = ["INTEGRATORS", "MODES", "Run", "load_run", "simulate"]

MODES = ("sampled", "continuous")
INTEGRATORS = ("rk4", "lsoda", "bdf2")
INTEGRATOR_CHOICES = ("auto", *INTEGRATORS)  # what RunSpec and the CLI accept
MAX_JOINT_SPEED = 1e3  # [rad/s] a state beyond this has diverged
_FAST_SAMPLED = True  # sampled mode: use a plant's held_rk4 fast path (False: the generic RK4 only)
_ARRAYS = ("t", "alpha", "alpha_dot", "alpha_d", "alpha_dot_d", "xyz", "xyz_d", "tau", "closure_residual")


@dataclass
class Run:
    """One closed-loop simulation, sampled at t_k = k dt.

    Attributes:
        t: sample times (N,) [s].
        alpha, alpha_dot: joint angles [rad] and velocities [rad/s] (N, 3).
        alpha_d, alpha_dot_d: reference angles and velocities (N, 3).
        xyz, xyz_d: actual and desired platform positions (N, 3) [m].
        tau: torques (N, 3) [N m] evaluated at each sample (held over the period in sampled mode).
        closure_residual: largest loop-closure gap (N,) [m] (zeros on the analytic plant).
        internals: controller quantities by name (e.g. ``rho_hat``), each (N, ...).
        metadata: every parameter of the run, seed and versions (JSON-serialisable).
    """

    t: np.ndarray
    alpha: np.ndarray
    alpha_dot: np.ndarray
    alpha_d: np.ndarray
    alpha_dot_d: np.ndarray
    xyz: np.ndarray
    xyz_d: np.ndarray
    tau: np.ndarray
    closure_residual: np.ndarray
    internals: dict[str, np.ndarray] = field(default_factory=dict)
    metadata: dict = field(default_factory=dict)

    @property
    def error(self) -> np.ndarray:
        """Joint tracking error r = alpha - alpha^d (eq. 14) (N, 3) [rad]."""
        return self.alpha - self.alpha_d

    @property
    def error_rate(self) -> np.ndarray:
        """r_dot = alpha_dot - alpha_dot^d (N, 3) [rad/s]."""
        return self.alpha_dot - self.alpha_dot_d

    def __len__(self) -> int:
        return len(self.t)

    def save(self, path: str | Path) -> Path:
        """Write the run to ``path`` (``.npz``) atomically: a temporary file, then a rename."""
        arrays = {name: getattr(self, name) for name in _ARRAYS}
        arrays.update({f"internal__{name}": value for name, value in self.internals.items()})
        arrays["metadata_json"] = np.array(json.dumps(self.metadata, default=_json_default))
        with atomic_open(path, "wb") as handle:
            np.savez_compressed(handle, **arrays)
        return Path(path)


def _json_default(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{value!r} is not JSON-serialisable")


def load_run(path: str | Path) -> Run:
    """Read a :class:`Run` written by :meth:`Run.save`."""
    path = Path(path)
    if not path.is_file():
        raise DeltaPinError(f"run file {str(path)!r} does not exist")
    with np.load(path, allow_pickle=False) as data:
        try:
            arrays = {name: data[name] for name in _ARRAYS}
        except KeyError as exc:
            raise DeltaPinError(f"{str(path)!r} is not a delta-pin run: missing {exc}") from None
        internals = {
            key.removeprefix("internal__"): data[key] for key in data.files if key.startswith("internal__")
        }
        metadata = json.loads(str(data["metadata_json"]))
    return Run(**arrays, internals=internals, metadata=metadata)


def _versions() -> dict:
    import pinocchio

    from . import __version__
    from .fast_model import FAST_BACKEND

    return {
        "delta_pin": __version__,
        "pinocchio": pinocchio.__version__,
        "numpy": np.__version__,
        "python": sys.version.split()[0],
        "machine": platform.machine(),
        "fast_backend": FAST_BACKEND,
    }


def _joint_vector(value, name: str, dof: int) -> np.ndarray:
    """``value`` as a finite (dof,) float array, or an error naming ``name``."""
    if dof == 3:
        return as_vector3(value, name)
    array = np.asarray(value, dtype=float)
    if array.shape != (dof,):
        raise InvalidParameterError(f"{name} must have shape ({dof},), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise NonFiniteError(f"{name}={array.tolist()} holds a non-finite number")
    return array


class _Loop:
    """Evaluates the controller with checks that name the time of a bad output."""

    def __init__(self, controller: Controller, plant: Plant) -> None:
        self.controller = controller
        self.plant = plant

    def control(self, t: float, x: np.ndarray, reference: Reference, z: np.ndarray, joints=None):
        """(tau, z_dot, output) at t; ``joints``: x's (alpha, alpha_dot) if already known."""
        alpha, alpha_dot = self.plant.joint_state(x) if joints is None else joints
        out = self.controller.evaluate(t, alpha, alpha_dot, reference, z)
        tau = np.asarray(out.tau, dtype=float)
        if tau.shape != (self.plant.dof,):
            raise SimulationError(
                f"controller {self.controller.name!r} returned a torque of shape {tau.shape}, "
                f"expected ({self.plant.dof},)",
                t,
            )
        if not _all_finite(tau):
            raise SimulationError(
                f"controller {self.controller.name!r} returned a non-finite torque {tau.tolist()}", t
            )
        return tau, np.asarray(out.state_derivative, dtype=float), out

    def check_state(self, t: float, x: np.ndarray, z: np.ndarray) -> None:
        alpha, alpha_dot = self.plant.joint_state(x)
        if not (np.isfinite(x).all() and np.isfinite(z).all()):
            raise SimulationError(f"the state became non-finite (alpha={alpha.tolist()})", t)
        speed = np.abs(alpha_dot).max()
        if speed > MAX_JOINT_SPEED:
            raise SimulationError(
                f"the run diverged: |alpha_dot| = {speed:.3g} rad/s > {MAX_JOINT_SPEED:g} rad/s", t
            )


@njit(cache=True)
def _all_finite(values):
    """``np.isfinite(values).all()`` for a 1-d array, without the temporaries."""
    for value in values:  # noqa: SIM110 - a plain loop for numba
        if not math.isfinite(value):
            return False
    return True


@njit(cache=True)
def _within_limits(x, z, alpha_dot, max_speed):
    """Whether :meth:`_Loop.check_state` passes: x and z finite, |alpha_dot| <= max_speed."""
    if not (_all_finite(x) and _all_finite(z)):
        return False
    for value in alpha_dot:  # noqa: SIM110 - a plain loop for numba
        if abs(value) > max_speed:
            return False
    return True


def _rk4(f, t: float, y: np.ndarray, h: float) -> np.ndarray:
    k1 = f(t, y)
    k2 = f(t + 0.5 * h, y + 0.5 * h * k1)
    k3 = f(t + 0.5 * h, y + 0.5 * h * k2)
    k4 = f(t + h, y + h * k3)
    return y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


class _ReferenceTable:
    """alpha^d, alpha_dot^d, alpha_ddot^d on a uniform grid, read at any time by cubic Hermite
    interpolation (exact at the grid points; O(h^4) between them, ~1e-15 rad for path I on a
    0.25 ms grid)."""

    def __init__(
        self,
        step: float,
        alpha: np.ndarray,
        alpha_dot: np.ndarray,
        alpha_ddot: np.ndarray,
        alpha_dddot: np.ndarray | None = None,
    ) -> None:
        self.step = step
        self.alpha, self.alpha_dot, self.alpha_ddot = alpha, alpha_dot, alpha_ddot
        # jerk for the Hermite interpolation of alpha_ddot, by central differences of the table
        self.alpha_dddot = np.gradient(alpha_ddot, step, axis=0) if alpha_dddot is None else alpha_dddot
        self.last = len(alpha) - 1

    def __call__(self, t: float) -> Reference:
        u = t / self.step
        k = min(max(int(u), 0), self.last)
        tau = u - k
        if tau <= 1e-9 or k == self.last:
            return Reference(self.alpha[k], self.alpha_dot[k], self.alpha_ddot[k])
        if tau >= 1.0 - 1e-9:
            return Reference(self.alpha[k + 1], self.alpha_dot[k + 1], self.alpha_ddot[k + 1])
        tau2, tau3 = tau * tau, tau * tau * tau
        h00, h10, h01, h11 = 2 * tau3 - 3 * tau2 + 1, tau3 - 2 * tau2 + tau, -2 * tau3 + 3 * tau2, tau3 - tau2
        h = self.step

        def hermite(y, dy):
            return h00 * y[k] + h10 * h * dy[k] + h01 * y[k + 1] + h11 * h * dy[k + 1]

        return Reference(
            hermite(self.alpha, self.alpha_dot),
            hermite(self.alpha_dot, self.alpha_ddot),
            hermite(self.alpha_ddot, self.alpha_dddot),
        )


def _reference(robot: Delta, trajectory, alpha0, dof: int, steps: int, dt: float, per_sample: int):
    """(reference table on the grid dt / per_sample, desired xyz at the samples, alpha0): the
    trajectory's, or a hold of ``alpha0`` when there is no trajectory."""
    grid = np.arange(steps * per_sample + 1) * (dt / per_sample)
    if trajectory is not None:
        ref = trajectory.joint_reference(robot, grid)
        table = _ReferenceTable(dt / per_sample, ref.alpha, ref.alpha_dot, ref.alpha_ddot)
        return table, ref.xyz[::per_sample], ref.alpha[0] if alpha0 is None else alpha0
    if alpha0 is None:
        raise InvalidParameterError("alpha0 is required when no trajectory is given")
    hold = _joint_vector(alpha0, "alpha0", dof)
    zeros = np.zeros((len(grid), dof))
    table = _ReferenceTable(dt / per_sample, np.broadcast_to(hold, (len(grid), dof)), zeros, zeros, zeros)
    return table, np.broadcast_to(robot.forward_kinematics(hold), (steps + 1, 3)), alpha0


def run_metadata(robot: Delta, controller: Controller, trajectory, plant: Plant, **timing) -> dict:
    """The metadata of a :class:`Run`: robot, controller, trajectory, plant, then ``timing``
    (mode, dt, t_end, integrator, ...), then the package versions."""
    return {
        "robot": robot.metadata(),
        "urdf": robot.urdf,
        "controller": controller.metadata(),
        "trajectory": None if trajectory is None else trajectory.metadata(),
        **plant.metadata(),
        **timing,
        "versions": _versions(),
    }


def simulate(
    robot: Delta,
    controller,
    trajectory=None,
    *,
    plant: str | Plant = "pinocchio",
    t_end: float,
    dt: float = 1e-3,
    mode: str = "sampled",
    alpha0=None,
    alpha_dot0=None,
    friction=None,
    uncertainty=None,
    substeps: int = 1,
    integrator: str = "auto",
    rtol: float = 1e-6,
    atol: float = 1e-8,
    progress: bool | None = False,
    compiled: bool | None = None,
) -> Run:
    """Simulate ``controller`` driving ``robot`` along ``trajectory``.

    Args:
        robot: the robot (:func:`delta_pin.load_delta`).
        controller: a :class:`~delta_pin.control.Controller` or any ``f(t, alpha, alpha_dot) -> tau``.
        trajectory: a task-space :class:`~delta_pin.trajectory.Trajectory`, or ``None`` to hold
            ``alpha0`` (then required).
        plant: ``"pinocchio"`` (constrained multibody, the default), ``"analytic"`` (reduced ODE) or
            a :class:`~delta_pin.plant.Plant`.
        t_end: duration [s] (> 0).
        dt: sample (and control) period [s] (> 0).
        mode: ``"sampled"`` (zero-order hold) or ``"continuous"`` (see the module docstring).
        alpha0, alpha_dot0: initial joint angles [rad] and velocities [rad/s]; ``alpha0`` defaults
            to the trajectory's start, ``alpha_dot0`` to zero.
        friction: :class:`~delta_pin.plant.Friction`, ``True`` for its defaults, or ``None``.
        uncertainty: an :class:`~delta_pin.uncertainty.Uncertainty` profile or ``None``.
        substeps: RK4 steps per period (>= 1) for the ``"rk4"`` integrator.
        integrator: ``"rk4"`` (fixed step dt / substeps), ``"lsoda"`` (scipy's adaptive
            stiff/non-stiff switching solver, continuous mode only) or ``"bdf2"`` (compiled implicit
            BDF2 with step dt / substeps, continuous mode, designs I/II on either plant -- the
            Pinocchio plant in active coordinates through :mod:`delta_pin.native` --:
            :func:`delta_pin.batch.simulate_batch`; 5-25x faster than LSODA, less accurate: ~3e-6
            rad from a tight reference after 0.1 s at 1 ms steps, up to 5e-4 rad in a reaching
            phase, against ~1e-8 rad for LSODA's defaults). ``"auto"`` takes RK4 in sampled mode
            and LSODA in continuous mode, where the robust term's boundary-layer gain makes the
            closed loop stiff (eigenvalues near -2e5 1/s with the paper's gains: RK4 would need ~80
            substeps per millisecond).
        rtol, atol: LSODA tolerances (relative; absolute in SI units of the state).
        progress: show the simulated time on stderr (``None``: only on a terminal).
        compiled: sampled mode only: run the whole loop compiled
            (:func:`delta_pin.batch.simulate_batch`, the same arithmetic, ~10x faster) where it
            applies -- designs I/II with their compiled step, on the analytic plant or on the
            Pinocchio plant in full coordinates with the native library of
            :mod:`delta_pin.native`. ``None`` (the default): where it applies; ``False``: never
            (the Python loop, the reference the compiled loops are tested against); ``True``:
            required (an error where it does not apply).

    Raises:
        InvalidParameterError: non-positive dt, t_end or substeps, unknown mode or plant.
        UnreachablePoseError: the trajectory leaves the workspace (before the run starts).
        SimulationError: a bad controller output, a diverging state or an exploding closure gap,
            with the time it happened.
    """
    if not (isinstance(dt, int | float) and dt > 0.0 and np.isfinite(dt)):
        raise InvalidParameterError(f"dt={dt!r} must be a positive number of seconds")
    if not (isinstance(t_end, int | float) and t_end > 0.0 and np.isfinite(t_end)):
        raise InvalidParameterError(f"t_end={t_end!r} must be a positive number of seconds")
    if mode not in MODES:
        raise InvalidParameterError(f"mode={mode!r} must be one of {', '.join(MODES)}")
    if not (isinstance(substeps, int) and substeps >= 1):
        raise InvalidParameterError(f"substeps={substeps!r} must be an integer >= 1")
    if integrator == "auto":
        integrator = "lsoda" if mode == "continuous" else "rk4"
    if integrator not in INTEGRATORS or (integrator != "rk4" and mode == "sampled"):
        raise InvalidParameterError(
            f"integrator={integrator!r} must be 'rk4' or, in continuous mode, 'lsoda' or 'bdf2'"
        )
    if integrator == "bdf2" or (mode == "sampled" and compiled is not False):
        from .batch import batchable, simulate_batch

        # bdf2 and compiled=True always go there: simulate_batch names what it cannot run
        if integrator == "bdf2" or compiled or batchable(controller, plant, mode):
            return simulate_batch(
                robot,
                [controller],
                trajectory,
                plant=plant,
                t_end=t_end,
                dt=dt,
                substeps=substeps,
                mode=mode,
                alpha0=alpha0,
                alpha_dot0=alpha_dot0,
                friction=friction,
                uncertainties=[uncertainty],
            )[0]
    # an adaptive integrator takes the Pinocchio plant in active coordinates (loops closed by
    # construction at every evaluation; a 7-dimensional state instead of 25)
    plant = make_plant(
        plant, robot, friction, uncertainty, **({"coordinates": "active"} if integrator == "lsoda" else {})
    )
    controller = as_controller(controller)
    steps = round(t_end / dt)
    if steps < 1:
        raise InvalidParameterError(f"t_end={t_end} s is shorter than one period dt={dt} s")
    h = dt / substeps

    dof = plant.dof
    # the reference on a grid fine enough for the integrator: the samples in sampled mode, the RK4
    # stage times (half steps) or dt/4 for LSODA in continuous mode
    per_sample = 1 if mode == "sampled" else (2 * substeps if integrator == "rk4" else 4)
    table, sample_xyz, alpha0 = _reference(robot, trajectory, alpha0, dof, steps, dt, per_sample)
    alpha0 = _joint_vector(alpha0, "alpha0", dof)
    alpha_dot0 = np.zeros(dof) if alpha_dot0 is None else _joint_vector(alpha_dot0, "alpha_dot0", dof)

    if integrator == "rk4":
        plant.precompute_truth(h / 2.0, 2 * steps * substeps + 1)
    controller.reset()
    loop = _Loop(controller, plant)
    x = plant.initial_state(alpha0, alpha_dot0)
    z = controller.initial_state().astype(float)
    nx = len(x)

    n = steps + 1
    t = np.arange(n) * dt
    record = {name: np.zeros((n, dof)) for name in ("alpha", "alpha_dot", "tau")}
    record["xyz"] = np.zeros((n, 3))
    residual = np.zeros(n)
    internals: dict[str, list] = {}

    record_alpha, record_alpha_dot, record_tau, record_xyz = (
        record[name] for name in ("alpha", "alpha_dot", "tau", "xyz")
    )

    # the reference at the samples: table rows k per_sample (what table(t[k]) returns there)
    reference_rows = (
        table.alpha[::per_sample],
        table.alpha_dot[::per_sample],
        table.alpha_ddot[::per_sample],
    )

    def sample(k: int, x: np.ndarray, z: np.ndarray, gap: float | None = None):
        """Control at t_k and record the sample; ``gap``: x's closure residual if known."""
        joints = plant.joint_state(x)
        record_alpha[k], record_alpha_dot[k] = joints
        reference = Reference(reference_rows[0][k], reference_rows[1][k], reference_rows[2][k])
        tau, z_dot, out = loop.control(t[k], x, reference, z, joints)
        record_tau[k] = tau
        record_xyz[k] = plant.platform_position(x)
        residual[k] = plant.closure_residual(x) if gap is None else gap
        for name, value in out.internals.items():
            values = internals.get(name)
            if values is None:
                values = internals[name] = []
            values.append(np.asarray(value, dtype=float))
        return tau, z_dot

    def closed_loop(t_now: float, y: np.ndarray) -> np.ndarray:
        xs, zs = y[:nx], y[nx:]
        tau, z_dot, _ = loop.control(t_now, xs, table(t_now), zs)
        return np.concatenate([plant.derivative(t_now, xs, tau), z_dot])

    wall = _time.perf_counter()
    bar = Progress(round(steps * dt, 9), progress, label="simulate", unit="s")
    stride = max(steps // 100, 1)
    gap = None  # the closure residual of x when the step computed it
    fast = mode == "sampled" and _FAST_SAMPLED
    if integrator == "lsoda":
        x, z = _integrate_lsoda(closed_loop, sample, loop, plant, x, z, t, rtol, atol, bar)
    else:
        for k in range(steps):
            if k % stride == 0 and k:
                bar.update(round(stride * dt, 9))
            tau, z_dot = sample(k, x, z, gap)
            if mode == "sampled":
                for j in range(substeps):
                    # the plant's own RK4 step under the held torque if it has one (truth read by
                    # stage index, same numbers), else the generic step on plant.derivative
                    x_next = plant.held_rk4(x, tau, 2 * (k * substeps + j), h) if fast else None
                    if x_next is None:
                        x = _rk4(lambda ts, xs: plant.derivative(ts, xs, tau), t[k] + j * h, x, h)  # noqa: B023
                        x, gap = plant.finish_step(x, t[k] + (j + 1) * h), None
                    else:
                        x, gap = plant.finish_step_residual(x_next, t[k] + (j + 1) * h)
                z = z + dt * z_dot
            else:
                y = np.concatenate([x, z])
                for j in range(substeps):
                    y = _rk4(closed_loop, t[k] + j * h, y, h)
                    y[:nx] = plant.finish_step(y[:nx], t[k] + (j + 1) * h)
                x, z = y[:nx], y[nx:]
            if not (fast and _within_limits(x, z, plant.joint_state(x)[1], MAX_JOINT_SPEED)):
                loop.check_state(t[k + 1], x, z)  # raises where the state is bad
    sample(steps, x, z, gap)
    bar.close()
    wall = _time.perf_counter() - wall

    metadata = run_metadata(
        robot,
        controller,
        trajectory,
        plant,
        mode=mode,
        dt=dt,
        t_end=steps * dt,
        substeps=substeps,
        integrator=integrator,
        **({"rtol": rtol, "atol": atol} if integrator == "lsoda" else {}),
        alpha0=alpha0.tolist(),
        alpha_dot0=alpha_dot0.tolist(),
        wall_time=wall,
    )
    if getattr(plant, "projections", 0):
        metadata["closure_projections"] = plant.projections
    try:
        internal_arrays = {name: np.array(values) for name, values in internals.items()}
    except ValueError:  # pragma: no cover - inconsistent shapes from a user controller
        raise NonFiniteError("controller internals changed shape during the run") from None
    return Run(
        t=t,
        alpha=record["alpha"],
        alpha_dot=record["alpha_dot"],
        alpha_d=np.array(table.alpha[::per_sample]),
        alpha_dot_d=np.array(table.alpha_dot[::per_sample]),
        xyz=record["xyz"],
        xyz_d=np.array(sample_xyz),
        tau=record["tau"],
        closure_residual=residual,
        internals=internal_arrays,
        metadata=metadata,
    )


LSODA_CHUNK = 1000  # samples per LSODA call (each restart costs a start-up; finish_step runs between)


def _integrate_lsoda(closed_loop, sample, loop, plant, x, z, t, rtol, atol, bar):
    """Continuous mode with scipy's LSODA, in chunks of LSODA_CHUNK samples (the plant's
    ``finish_step`` runs between chunks); every sample is recorded with ``sample``."""
    from scipy.integrate import solve_ivp

    nx = len(x)
    dt = t[1] - t[0]
    k = 0
    while k < len(t) - 1:
        stop = min(k + LSODA_CHUNK, len(t) - 1)
        sample(k, x, z)
        solution = solve_ivp(
            closed_loop,
            (t[k], t[stop]),
            np.concatenate([x, z]),
            method="LSODA",
            t_eval=t[k : stop + 1],
            rtol=rtol,
            atol=atol,
            max_step=dt,
        )
        if solution.status != 0:
            raise SimulationError(f"the integrator failed: {solution.message}", float(t[k]))
        for j in range(1, stop - k):
            xs, zs = solution.y[:nx, j], solution.y[nx:, j]
            loop.check_state(t[k + j], xs, zs)
            sample(k + j, xs, zs)
        x, z = solution.y[:nx, -1], solution.y[nx:, -1]
        loop.check_state(t[stop], x, z)
        x = plant.finish_step(x, t[stop])
        bar.update(round(t[stop] - t[k], 9))
        k = stop
    return x, z

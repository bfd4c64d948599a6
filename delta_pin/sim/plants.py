"""Plants: the simulated "true" robot, driven by torques on the three active joints.

Both plants integrate eq. 13 of the paper,

    M(alpha, m_o(t)) alpha_ddot + C alpha_dot + G + F(t) + M_f(alpha_dot, F_n(t)) = tau,

with the plant's truth (friction, time-varying platform mass m_o(t), normal force F_n(t) and
joint disturbance F(t)) kept apart from what a controller knows:

* :class:`PinocchioPlant` -- the full 12-joint tree with its three point closures, integrated
  with ``pin.constraintDynamics`` (exact KKT solve, mu = 0). Baumgarte stabilisation
  (omega = 20 rad/s, critically damped) damps closure drift; should the closure gap still exceed
  ``projection_tolerance`` after a step, the passive coordinates are projected back onto the
  constraint manifold (positions by Newton from the active angles, velocities through the null
  space), however large the gap: a rough torque (a digital law alternating by tens of N m per
  sample) drifts the loops by micrometres in one step, which a projection removes. Only loops
  that cannot be re-assembled (Newton fails) stop the run. The platform
  mass changes during the run by rewriting the platform body's inertia (its rotational inertia
  scales with the mass);
* :class:`AnalyticPlant` -- the paper's reduced ODE (eqs. 7-9, corrected G) through the fast
  kernels of :mod:`delta_pin.compiled.delta_kernels`.

A time-varying mass enters as in eq. 13: the instantaneous M(m_o(t)), no momentum flux term.

Friction: eq. 12 with sgn replaced by tanh(alpha_dot / sign_velocity_scale) -- 0.01 rad/s by
default -- so that the ODE right-hand side stays Lipschitz and RK4 at 1 kHz resolves it (the
friction slope near zero is then mu_d F_n r_a / 0.01 = 6 N m s/rad on the Table 1 robot).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import asdict

import numpy as np
import pinocchio as pin

from delta_pin.compiled.delta_kernels import delta_terms, friction_torque, solve3
from delta_pin.compiled.layouts import TRUTH, as_table, records
from delta_pin.compiled.tree_kernels import joint_torques, joint_torques_at, tree_combine, tree_stage
from delta_pin.errors import AssemblyError, ForwardKinematicsError, InvalidParameterError, SimulationError
from delta_pin.model.delta_robot import analytic_delta
from delta_pin.model.dynamics import kernel_geometry
from delta_pin.model.friction import Friction, kernel_friction
from delta_pin.model.kinematics import chain_trigonometry
from delta_pin.model.robot import Delta
from delta_pin.sim.uncertainty import NoUncertainty

__all__ = ["PLANTS", "AnalyticPlant", "DeltaPlant", "PinocchioPlant", "Plant", "make_plant", "truth_records"]

PLANTS = ("pinocchio", "analytic")


def truth_records(mass, normal_force, disturbance) -> np.ndarray:
    """A table of :data:`~delta_pin.compiled.layouts.TRUTH` records from the columns m_o (R,)
    [kg], F_n (R, 3) [N] and F (R, 3) [N m] (what :meth:`Plant.evaluate_truth` gives)."""
    mass = np.atleast_1d(np.asarray(mass, dtype=float))
    table = records(TRUTH, len(mass))
    table["platform_mass"] = mass
    table["normal_force"] = np.broadcast_to(normal_force, (len(mass), 3))
    table["disturbance"] = np.broadcast_to(disturbance, (len(mass), 3))
    return table


class Plant(ABC):
    """A simulated robot with state ``x``, driven by torques on its ``dof`` actuated joints: the
    interface every plant implements (the Delta's analytic and Pinocchio plants, any closed
    chain's, a serial robot's), with what a plant without closures or a time-varying truth needs
    by default.
    """

    name: str = "plant"
    dof: int = 3  # actuated joints: the robot's where it says

    def __init__(self, robot) -> None:
        self.robot = robot
        self.dof = int(getattr(robot, "dof", type(self).dof))

    def precompute_truth(self, step: float, count: int) -> None:  # noqa: B027 - an optional hook
        """Tabulate the time-varying truth at t = k step, k < count [s] for the integrator's stage
        times (nothing to tabulate by default)."""

    # ------------------------------------------------------------------ state interface
    @abstractmethod
    def initial_state(self, alpha: np.ndarray, alpha_dot: np.ndarray) -> np.ndarray:
        """Plant state for active angles [rad] and velocities [rad/s]."""

    @abstractmethod
    def derivative(self, t: float, x: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """dx/dt at time t [s] under active-joint torques tau [N m]."""

    @abstractmethod
    def joint_state(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(alpha [rad], alpha_dot [rad/s]) of a plant state."""

    @abstractmethod
    def platform_position(self, x: np.ndarray) -> np.ndarray:
        """Platform (end-effector) position xyz [m] of a plant state."""

    def configuration_state(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """The multibody's full (q (nq,), v (nv,)) at plant state x, where the plant has one
        (a run records it at every sample, so drawings and energies need no re-assembly)."""
        return None

    def closure_residual(self, x: np.ndarray) -> float:
        """Largest loop-closure gap [m] (0 for plants without closures)."""
        return 0.0

    def finish_step(self, x: np.ndarray, t: float) -> np.ndarray:
        """Correction applied after each integration step (none by default)."""
        return x

    def finish_step_residual(self, x: np.ndarray, t: float) -> tuple[np.ndarray, float]:
        """(:meth:`finish_step` of x, the :meth:`closure_residual` of that state)."""
        x = self.finish_step(x, t)
        return x, self.closure_residual(x)

    def held_rk4(self, x: np.ndarray, tau: np.ndarray, stage: int, h: float) -> np.ndarray | None:
        """A fast path for one RK4 step of length h [s] of :meth:`derivative` under a held torque
        from t = stage h / 2 (the sampled mode's inner step), equal to the generic step bit for
        bit; ``None`` (the default) where the plant has none: the caller then takes the generic
        step."""
        return None

    def sampled_core(self, step: float, count: int):
        """This plant in the compiled core for the sampled loop
        (:mod:`delta_pin.sim.compiled_plant`), with its time-varying truth tabulated at the RK4
        stage times t = i step / 2, i < count; ``None`` (the default) where it has none: the
        Python loop then steps :meth:`derivative`."""
        return None

    def metadata(self) -> dict:
        """JSON-serialisable description stored with every run (``"plant"``: its name)."""
        return {"plant": self.name}


class DeltaPlant(Plant):
    """A Delta plant: the paper's time-varying truth (eq. 13: platform mass m_o(t), normal force
    F_n(t), disturbance F(t)) and eq. 12's friction on the three active joints, shared by the
    analytic and the Pinocchio plant.

    Args:
        robot: the robot (its URDF sets every number; the robot of ``load_delta`` gives its
            analytic model).
        friction: joint friction, ``True`` for :class:`Friction` defaults, or ``None``.
        uncertainty: time-varying truth (:mod:`delta_pin.sim.uncertainty`), or ``None`` for nominal.
    """

    dof = 3  # actuated joints

    def __init__(self, robot: Delta, friction: Friction | bool | None = None, uncertainty=None) -> None:
        robot = analytic_delta(robot)  # the robot of load_delta carries the Delta's model
        super().__init__(robot)
        self.dof = 3
        if friction is True:
            friction = Friction()
        self.friction = friction or None
        self.stribeck = None
        self.friction_parameters = kernel_friction(None)  # the friction as the kernels read it
        if self.friction is not None:
            self.stribeck = self.friction.stribeck_for(robot.params.friction)
            self.friction_parameters = kernel_friction(self.stribeck, self.friction.sign_velocity_scale)
        self._friction_table = as_table(self.friction_parameters)  # what Python passes to kernels
        self.uncertainty = NoUncertainty() if uncertainty is None else uncertainty

    # ------------------------------------------------------------------ truth shared by both plants
    def _nominal_normal_force(self) -> float:
        return 0.0 if self.friction is None else self.friction.normal_force

    def evaluate_truth(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(m_o, F_n, F) at a time or an array of times, straight from the uncertainty profile."""
        nominal_mass = self.robot.params.m_o
        return (
            self.uncertainty.platform_mass(t, nominal_mass),
            self.uncertainty.normal_force(t, self._nominal_normal_force()),
            self.uncertainty.disturbance(t),
        )

    def precompute_truth(self, step: float, count: int) -> None:
        """Tabulate m_o, F_n, F at t = k step, k < count [s] (one vectorised call): the
        integrator's stage times then read the table instead of calling the profile."""
        self._table_step = step
        self._table = self.evaluate_truth(np.arange(count) * step)

    def truth(self, t: float) -> tuple[float, np.ndarray, np.ndarray]:
        """(m_o(t) [kg], F_n(t) (3,) [N], F(t) (3,) [N m]): the plant's time-varying truth."""
        table = getattr(self, "_table", None)
        if table is not None:
            k = round(t / self._table_step)
            if k < len(table[0]) and abs(k * self._table_step - t) <= 1e-9 * self._table_step:
                return table[0][k], table[1][k], table[2][k]
        return self.uncertainty.at(t, self.robot.params.m_o, np.full(3, self._nominal_normal_force()))

    def platform_mass(self, t: float) -> float:
        """m_o(t) [kg]."""
        return self.truth(t)[0]

    def passive_torque(self, t: float, alpha_dot: np.ndarray) -> np.ndarray:
        """F(t) + M_f(alpha_dot, F_n(t)) [N m]: what eq. 13 adds to the left-hand side."""
        return self.acceleration_terms(t, alpha_dot)[1]

    def acceleration_terms(self, t: float, alpha_dot: np.ndarray) -> tuple[float, np.ndarray]:
        """(m_o(t), F(t) + M_f(alpha_dot, F_n(t))) in one lookup of the truth."""
        mass, normal, disturbance = self.truth(t)
        if self.friction is None:
            return mass, disturbance
        return mass, disturbance + friction_torque(self._friction_table, alpha_dot, normal)

    def metadata(self) -> dict:
        return {
            "plant": self.name,
            "friction": None
            if self.friction is None
            else {**asdict(self.friction), "stribeck": asdict(self.stribeck)},
            "uncertainty": self.uncertainty.metadata(),
        }


class AnalyticPlant(DeltaPlant):
    """The paper's reduced model M alpha_ddot + C alpha_dot + G + F + M_f = tau; x = [alpha, alpha_dot]."""

    name = "analytic"

    def __init__(self, robot: Delta, friction=None, uncertainty=None) -> None:
        super().__init__(robot, friction, uncertainty)
        robot = self.robot
        self._geometry_table = as_table(kernel_geometry(robot.params))  # what Python passes to kernels
        self._cos, self._sin = chain_trigonometry()
        self._last_xyz = np.full(3, np.nan)

    def initial_state(self, alpha, alpha_dot):
        return np.concatenate([alpha, alpha_dot]).astype(float)

    def derivative(self, t, x, tau):
        alpha, alpha_dot = x[:3], x[3:]
        mass, passive = self.acceleration_terms(t, alpha_dot)
        m_eq = mass + 1.5 * self.robot.params.m_b
        ok, _, _, _, M, C, G = delta_terms(self._geometry_table, self._cos, self._sin, m_eq, alpha, alpha_dot)
        if not ok:
            raise SimulationError(f"alpha={alpha.tolist()} rad has no forward kinematics", t)
        rhs = tau - C @ alpha_dot - G - passive
        return np.concatenate([alpha_dot, solve3(M, rhs)])

    def joint_state(self, x):
        return x[:3], x[3:]

    def platform_position(self, x):
        ok, xyz, *_ = delta_terms(self._geometry_table, self._cos, self._sin, 1.0, x[:3], x[3:])
        return xyz if ok else self.robot.forward_kinematics(x[:3])  # the latter raises with alpha


class PinocchioPlant(DeltaPlant):
    """The full tree with point closures through ``pin.constraintDynamics``.

    Two state representations:

    * ``coordinates="full"`` -- x = [q, v] (nq + nv): the whole tree is integrated, Baumgarte
      stabilisation plus projection when the closure gap exceeds ``projection_tolerance``;
    * ``coordinates="active"`` -- x = [alpha, alpha_dot] (generalised coordinate partitioning):
      every evaluation completes q(alpha) by Newton (warm-started from the previous one) and
      v = S alpha_dot, then takes alpha_ddot from ``constraintDynamics``. The loops are closed to
      1e-13 m by construction; adaptive integrators (LSODA) need this small state.

    Args:
        coordinates: ``"full"`` or ``"active"``.
        baumgarte_frequency: omega [rad/s] of the Baumgarte corrector (Kp = omega^2, Kd = 2 omega).
        projection_tolerance: closure gap [m] above which a step is projected back.
        failure_tolerance: closure gap [m] that aborts the run without a projection (default:
            none; any finite gap is projected, and the run stops only where the loops cannot be
            re-assembled). The compiled loops hand every gap above ``projection_tolerance`` and
            up to this one to :meth:`finish_step_residual`.
    """

    name = "pinocchio"

    def __init__(
        self,
        robot: Delta,
        friction=None,
        uncertainty=None,
        *,
        coordinates: str = "full",
        baumgarte_frequency: float = 20.0,
        projection_tolerance: float = 1e-10,
        failure_tolerance: float = math.inf,
    ) -> None:
        super().__init__(robot, friction, uncertainty)
        robot = self.robot
        if coordinates not in ("full", "active"):
            raise InvalidParameterError(f"coordinates={coordinates!r} must be 'full' or 'active'")
        self.coordinates = coordinates
        source = robot.pinocchio
        self._source = source
        self.model = pin.Model(source.model)  # own copy: the platform inertia changes in time
        self.data = self.model.createData()
        self.constraint_models = pin.StdVec_RigidConstraintModel()
        self.constraint_datas = pin.StdVec_RigidConstraintData()
        self.baumgarte_gains = (baumgarte_frequency**2, 2.0 * baumgarte_frequency)  # (Kp, Kd)
        gains = pin.BaumgarteCorrectorParameters(*self.baumgarte_gains)
        for cm in source.constraint_models:
            copy = pin.RigidConstraintModel(cm)
            copy.setBaumgarteCorrectorParameters(gains)
            self.constraint_models.append(copy)
            self.constraint_datas.append(copy.createData())
        pin.initConstraintDynamics(self.model, self.data, self.constraint_models, self.constraint_datas)
        self.settings = pin.ProximalSettings(1e-12, 0.0, 1)  # mu = 0: exact KKT solve
        self.nq = self.model.nq
        self.active = source.active_indices
        self._joint_indices = np.concatenate([self.active, self.nq + self.active])
        self.projection_tolerance = projection_tolerance
        self.failure_tolerance = failure_tolerance
        self.projections = 0  # steps projected back onto the loops
        self.largest_projected_gap = 0.0  # [m] the largest gap a projection removed
        self._platform_joint = source.platform_joint
        nominal_inertia = pin.Inertia(self.model.inertias[self._platform_joint])
        self.nominal_platform_mass = nominal_inertia.mass  # [kg]
        self.nominal_platform_rotational = nominal_inertia.inertia  # (3, 3) about the COM [kg m^2]
        # the model's own platform inertia (a reference into model.inertias), rewritten in place
        self._platform_inertia = self.model.inertias[self._platform_joint]
        self._mass = self.nominal_platform_mass
        self._tau = np.zeros(self.model.nv)
        # k1, k2, k3, k4, then the stage points y2, y3, y4 of held_rk4 with their q and v views
        stages = np.empty((7, self.model.nq + self.model.nv))
        points = [(y, y[: self.model.nq], y[self.model.nq :]) for y in stages[4:]]
        self._stages = (*stages[:4], *(view for point in points for view in point))
        self._last_q: np.ndarray | None = None
        self._native_tree = None
        self.metadata_extra = {
            "coordinates": coordinates,
            "baumgarte_frequency": baumgarte_frequency,
            "projection_tolerance": projection_tolerance,
        }

    def rotational_inertia(self, mass):
        """The platform's rotational inertia about its COM [kg m^2] for a platform mass [kg] (or
        an array of masses (R, 1, 1)): the nominal one scaled with the mass."""
        return self.nominal_platform_rotational * (mass / self.nominal_platform_mass)

    def _set_platform_mass(self, mass: float, rotational: np.ndarray | None = None) -> None:
        """Rewrite the platform body's inertia in the model (in place) for a platform mass [kg]:
        the same COM, the rotational inertia ``rotational`` (by default
        :meth:`rotational_inertia` of the mass); nothing when the mass is unchanged."""
        if mass != self._mass:
            inertia = self._platform_inertia
            inertia.mass = mass
            inertia.inertia = self.rotational_inertia(mass) if rotational is None else rotational
            self._mass = mass

    def _accelerations(self, q, v, tau, mass, normal_force, disturbance) -> np.ndarray:
        """ddq of eq. 13 on the tree at (q, v) under active-joint torques tau [N m] for the
        truth (m_o, F_n, F)."""
        joint_torques(self._tau, self.active, tau, v, disturbance, normal_force, self._friction_table)
        return self._tree_dynamics(q, v, mass)

    def _tree_dynamics(self, q, v, mass, rotational=None) -> np.ndarray:
        """ddq of the constrained tree at (q, v) with platform mass m_o [kg] under the joint
        torques already in ``self._tau`` (:func:`~delta_pin.compiled.tree_kernels.joint_torques`).
        This, the joint torques
        and :meth:`_set_platform_mass` are the plant's physics, which :meth:`derivative` and
        the fast sampled step :meth:`held_rk4` share."""
        if mass != self._mass:
            self._set_platform_mass(mass, rotational)
        return pin.constraintDynamics(
            self.model,
            self.data,
            q,
            v,
            self._tau,
            self.constraint_models,
            self.constraint_datas,
            self.settings,
        )

    def precompute_truth(self, step: float, count: int) -> None:
        super().precompute_truth(step, count)
        # the platform's rotational inertia at each tabulated mass, for held_rk4
        self._rotational_table = self.rotational_inertia(np.asarray(self._table[0])[:, None, None])

    def _complete(self, alpha: np.ndarray, alpha_dot: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) on the constraint manifold for active coordinates (``coordinates="active"``)."""
        guess = None
        if self._last_q is not None:  # first-order predictor from the previous completion
            guess = self._last_q + self._last_S @ (alpha - self._last_q[self.active])
        try:
            q = self._source.configuration(alpha, initial_guess=guess)
        except AssemblyError as exc:
            raise SimulationError(f"cannot close the loops: {exc}", t) from None
        self._last_q, self._last_S = q, self._source.velocity_map(q)
        return q, self._last_S @ alpha_dot

    def initial_state(self, alpha, alpha_dot):
        if self.coordinates == "active":
            return np.concatenate([alpha, alpha_dot]).astype(float)
        q, v = self._source.state(alpha, alpha_dot)
        return np.concatenate([q, v])

    def derivative(self, t, x, tau):
        if self.coordinates == "active":
            q, v = self._complete(x[:3], x[3:], t)
        else:
            q, v = x[: self.nq], x[self.nq :]
        ddq = self._accelerations(q, v, tau, *self.truth(t))
        if self.coordinates == "active":
            return np.concatenate([x[3:], ddq[self.active]])
        return np.concatenate([v, ddq])

    def joint_state(self, x):
        if self.coordinates == "active":
            return x[:3], x[3:]
        joints = x[self._joint_indices]  # one gather: [alpha, alpha_dot]
        return joints[:3], joints[3:]

    def _configuration(self, x: np.ndarray) -> np.ndarray:
        if self.coordinates == "active":
            return self._complete(x[:3], x[3:], float("nan"))[0]
        return x[: self.nq]

    def platform_position(self, x):
        return self._source.platform_position(self._configuration(x))

    def closure_residual(self, x):
        return self._source.closure_gap(self._configuration(x))

    def finish_step(self, x, t):
        if self.coordinates == "active":
            return x
        return self.finish_step_residual(x, t)[0]

    def finish_step_residual(self, x: np.ndarray, t: float) -> tuple[np.ndarray, float]:
        """:meth:`finish_step` and the closure residual of the state it returns, computed once."""
        if self.coordinates == "active":
            return super().finish_step_residual(x, t)
        gap = self._source.closure_gap(x[: self.nq])  # closure_residual(x)
        if gap <= self.projection_tolerance:
            return x, gap
        if not math.isfinite(gap) or not np.isfinite(x).all():
            raise SimulationError(f"the loop-closure gap is {gap:.3e} m: the state is no longer finite", t)
        if gap > self.failure_tolerance:
            raise SimulationError(
                f"the loop-closure gap reached {gap:.3e} m, above failure_tolerance="
                f"{self.failure_tolerance:g} m (raise it, or shorten dt)",
                t,
            )
        alpha, alpha_dot = self.joint_state(x)
        try:
            x = self.initial_state(alpha, alpha_dot)
        except (AssemblyError, ForwardKinematicsError) as exc:
            raise SimulationError(
                f"the loops cannot be re-assembled after a closure gap of {gap:.3e} m: {exc}", t
            ) from None
        projected = self.closure_residual(x)
        if not projected <= self.projection_tolerance:  # pragma: no cover - Newton closes to 1e-13 m
            raise SimulationError(
                f"the loops cannot be re-assembled: the gap is {projected:.3e} m after projecting a "
                f"gap of {gap:.3e} m",
                t,
            )
        self.projections += 1
        self.largest_projected_gap = max(self.largest_projected_gap, gap)
        return x, projected

    def held_rk4(self, x: np.ndarray, tau: np.ndarray, stage: int, h: float) -> np.ndarray | None:
        """One RK4 step of length h [s] under the held torque tau from t = stage h / 2, reading the
        truth table of :meth:`precompute_truth` (step h / 2) by index: the result of
        :func:`~delta_pin.sim.integrators.rk4_step` on :meth:`derivative`, bit for bit, without its
        per-call overhead.
        ``None`` where this fast path does not apply (active coordinates, no table for h)."""
        table = getattr(self, "_table", None)
        if self.coordinates != "full" or table is None or self._table_step != 0.5 * h:
            return None
        masses, normals, disturbances = table
        if stage + 2 >= len(masses):
            return None
        # the stages of rk4_step at t, t + h/2, t + h/2, t + h: table rows i, i+1, i+1, i+2
        dynamics, rotational = self._tree_dynamics, self._rotational_table
        torques, active, friction = self._tau, self.active, self._friction_table
        k1, k2, k3, k4, y2, q2, v2, y3, q3, v3, y4, q4, v4 = self._stages
        q, v = x[: self.nq], x[self.nq :]
        i, half = stage, 0.5 * h
        joint_torques_at(torques, active, tau, v, disturbances, normals, i, friction)
        ddq = dynamics(q, v, masses[i], rotational[i])
        tree_stage(y2, x, k1, v, ddq, half, torques, active, tau, disturbances, normals, i + 1, friction)
        ddq = dynamics(q2, v2, masses[i + 1], rotational[i + 1])
        tree_stage(y3, x, k2, v2, ddq, half, torques, active, tau, disturbances, normals, i + 1, friction)
        ddq = dynamics(q3, v3, masses[i + 1], rotational[i + 1])
        tree_stage(y4, x, k3, v3, ddq, h, torques, active, tau, disturbances, normals, i + 2, friction)
        ddq = dynamics(q4, v4, masses[i + 2], rotational[i + 2])
        return tree_combine(x, k1, k2, k3, k4, v4, ddq, h / 6.0)

    def native_tree(self):
        """This plant's tree and closures in the native library
        (:class:`delta_pin.compiled.native.TreeDynamics`, built once), for compiled loops.

        Raises:
            NativeUnavailableError: the native library cannot be built here.
        """
        if self._native_tree is None:
            from delta_pin.compiled import native  # builds the library on first use

            self._native_tree = native.TreeDynamics(
                native.load(strict=True), self.model, self.constraint_models, self.baumgarte_gains,
                self._platform_joint,
            )  # fmt: skip
        return self._native_tree

    def metadata(self):
        return {
            **super().metadata(),
            **self.metadata_extra,
            "closure_projections": self.projections,
            "closure_gap_projected_max": self.largest_projected_gap,  # [m] before its projection
        }


def make_plant(plant: str | Plant, robot: Delta, friction=None, uncertainty=None, **options) -> Plant:
    """A plant by name (``"pinocchio"`` or ``"analytic"``), or the given :class:`Plant` itself;
    ``options`` go to :class:`PinocchioPlant` (e.g. ``coordinates="active"``)."""
    if isinstance(plant, Plant):
        return plant
    robot = analytic_delta(robot)
    if plant == "pinocchio":
        return PinocchioPlant(robot, friction, uncertainty, **options)
    if plant == "analytic":
        return AnalyticPlant(robot, friction, uncertainty)
    raise InvalidParameterError(f"plant={plant!r} must be one of {', '.join(PLANTS)} or a Plant")

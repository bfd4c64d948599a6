"""The Pinocchio plant of every closed-chain robot: ``pin.constraintDynamics`` on its tree.

One plant for every :class:`~delta_pin.model.closed_chain.ClosedChainRobot` from any file shape,
the paper's Delta included (``PinocchioPlant`` is its older name):

* ``coordinates="full"`` -- x = [q, v]: the whole tree is integrated with Baumgarte
  stabilisation (omega = 20 rad/s), and a step whose closure gap exceeds
  ``projection_tolerance`` is projected back onto the loops (Newton from the actuated
  coordinates, velocities through the null space). Ball, free and continuous joints integrate
  their configuration coefficients (``ClosedChainRobot.configuration_rate``), renormalised after
  every step; idle motions and passive joints need this representation;
* ``coordinates="active"`` -- x = [alpha, alpha_dot]: every evaluation assembles q(alpha)
  (warm-started) and v = S alpha_dot, then reads alpha_ddot from ``constraintDynamics``; the
  loops are closed by construction, and any joint type works (the core's continuous loop
  completes (q, v) this way too).

The truth is pluggable and kept apart from what a controller knows (eq. 13 of the paper,

    M(q, m_o(t)) ddq + ... = S_a^T (tau - F(t) - M_f(alpha_dot, F_n(t)))   on the closures,

docs/architecture.md section 10):

* an uncertainty profile (:mod:`delta_pin.sim.uncertainty`: the paper's Section V, seeded random
  or user functions) sets the mass m_o(t) of the body that carries the payload frame (its
  rotational inertia scaled with the mass, its COM kept), the normal forces F_n(t) of the
  actuated joints' friction and the joint disturbance F(t), for robots with three actuated joints
  (the profiles' shape);
* a payload m(t) [kg] rides as a point mass at a named frame (``payload_mass``);
* joint friction on the actuated joints: eq. 12's Stribeck form with sgn smoothed by tanh
  (:class:`~delta_pin.model.friction.Friction`), at the normal force F_n(t).

A time-varying mass enters as in eq. 13: the instantaneous M(m_o(t)), no momentum flux term.

Closures with redundant equations (a planar loop closed by a 3D point or a 6D weld) make the
KKT system singular; for them the proximal solver runs with mu = 1e-9 until the constraint
accelerations agree to 1e-13 (Pinocchio's ``ProximalSettings``), which converges to the exact
accelerations (tested against the projected dynamics).

Joint couplings (``robot.joint_couplings``, MuJoCo's ``<equality joint>``) are not constraints
Pinocchio's ``constraintDynamics`` knows; their multipliers lambda (one per coupling) are added
here. For a fixed state, ddq is affine in the joint torques, so with a(tau) from
``constraintDynamics`` on the frame closures and D = [a(tau + J_k^T) - a(tau)] (one more call per
coupling), ddq = a(tau) + D lambda with (J D) lambda = -(J a(tau) + J_dot v) - Kd J v - Kp r: the
coupling rows J (r their residual) held at the acceleration level with the same Baumgarte gains.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict

import numpy as np
import pinocchio as pin

from delta_pin.errors import (
    AssemblyError,
    InvalidParameterError,
    SimulationError,
)
from delta_pin.model.closed_chain import ClosedChainRobot, closure_rank
from delta_pin.model.delta_robot import as_closed_chain
from delta_pin.model.friction import Friction, stribeck_torque
from delta_pin.sim.plants import AnalyticPlant, Plant
from delta_pin.sim.truth import PlantTruth
from delta_pin.sim.uncertainty import Uncertainty

__all__ = ["PLANTS", "ClosedChainPlant", "PinocchioPlant", "closed_chain_plant", "make_plant"]

PLANTS = ("pinocchio", "analytic")


class ClosedChainPlant(Plant):
    """Constrained forward dynamics of a closed-chain robot (module docstring).

    Args:
        robot: the robot (an analytic :class:`~delta_pin.model.robot.Delta` stands for the
            closed-chain robot of its URDF).
        friction: joint friction on the actuated joints: a :class:`Friction` with its
            ``stribeck`` parameters (or, for a recognised Delta, the URDF's), ``True`` for a
            recognised Delta's defaults, or ``None``.
        uncertainty: the time-varying truth m_o(t), F_n(t), F(t) (:mod:`delta_pin.sim.uncertainty`,
            three actuated joints), or ``None`` for the nominal one.
        payload_mass: m(t) [kg] as a function of time, a constant, or ``None``.
        payload_frame: the frame the payload rides at and whose body's mass the uncertainty sets
            (default: the end effector).
        coordinates: ``"full"`` or ``"active"`` (default: full wherever every joint has a
            configuration rate, else active); the compiled core's plant steps either.
        baumgarte_frequency: omega [rad/s] of the Baumgarte corrector (Kp = omega^2, Kd = 2 omega).
        projection_tolerance: closure gap [m or rad] above which a full-coordinate step is projected.
        failure_tolerance: closure gap [m or rad] that stops the run instead of a projection
            (default: none; any finite gap is projected, and the run stops only where the loops
            cannot be re-assembled).
        joint_damping: apply the dampers of ``robot.joint_springs`` (``False``: springs only, a
            conservative plant, as the energy check of ``validate`` needs).
    """

    name = "pinocchio"

    def __init__(
        self,
        robot: ClosedChainRobot,
        friction: Friction | bool | None = None,
        uncertainty: Uncertainty | None = None,
        *,
        payload_mass: Callable[[float], float] | float | None = None,
        payload_frame: str | None = None,
        coordinates: str | None = None,
        baumgarte_frequency: float = 20.0,
        projection_tolerance: float = 1e-10,
        failure_tolerance: float = math.inf,
        joint_damping: bool = True,
    ) -> None:
        robot = as_closed_chain(robot)
        super().__init__(robot)
        if uncertainty is not None and self.dof != 3:
            raise InvalidParameterError(
                f"uncertainty profiles give m_o(t) and three joints' F_n(t) and F(t); {robot.name!r} has "
                f"{self.dof} actuated joint(s): give payload_mass=m(t) [kg] at payload_frame= instead"
            )
        full_possible = robot.model.nq == robot.model.nv
        if coordinates is None:  # full wherever it can: the core's compiled plant steps it
            coordinates = (
                "full" if full_possible or robot.has_unactuated_motion or _has_rates(robot) else "active"
            )
        if coordinates not in ("full", "active"):
            raise InvalidParameterError(f"coordinates={coordinates!r} must be 'full' or 'active'")
        carried = robot.has_unactuated_motion
        if coordinates == "active" and carried:
            raise InvalidParameterError(
                f"coordinates='active' carries only the actuated joints, and {robot.name!r} also moves "
                f"{robot.idle_dof} idle motion(s) and {len(robot.passive_joints)} passive joint(s) that no "
                "motor drives: use coordinates='full'"
            )
        if coordinates == "full" and not full_possible:
            robot.configuration_rate(robot.reference_configuration, np.zeros(robot.model.nv))  # a named error
        self.coordinates = coordinates
        self._set_friction(friction)
        self.model = robot.model
        self.baumgarte_gains = (baumgarte_frequency**2, 2.0 * baumgarte_frequency)
        gains = pin.BaumgarteCorrectorParameters(*self.baumgarte_gains)
        self.constraint_models = pin.StdVec_RigidConstraintModel()
        for cm in robot.constraint_models:
            copy = pin.RigidConstraintModel(cm)
            copy.setBaumgarteCorrectorParameters(gains)
            self.constraint_models.append(copy)
        redundant = closure_rank(robot, robot.reference_configuration) < robot.closure_size
        # mu = 0: the exact KKT solve; redundant equations need the proximal iterations
        self.settings = (
            pin.ProximalSettings(1e-13, 1e-9, 200) if redundant else pin.ProximalSettings(1e-12, 0.0, 1)
        )
        self.redundant = redundant
        self._gap_unit = " m" if all(c.kind == "3d" for c in robot.closures) else ""  # else m or rad
        self.payload_frame = robot.end_effector if payload_frame is None else robot.frame_id(payload_frame)
        frame = self.model.frames[self.payload_frame]
        self._payload_joint = frame.parentJoint
        self._payload_point = frame.placement.translation.copy()
        # the payload body's own inertia: the uncertainty's nominal mass m̄_o [kg] and the
        # rotational inertia about its COM [kg m^2] it scales
        nominal = pin.Inertia(self.model.inertias[self._payload_joint])
        self.nominal_platform_mass = nominal.mass
        self.nominal_platform_rotational = nominal.inertia
        if payload_mass is not None and not callable(payload_mass):
            constant = float(payload_mass)
            if not (math.isfinite(constant) and constant >= 0.0):
                raise InvalidParameterError(f"payload_mass={payload_mass!r} must be a finite mass >= 0 [kg]")

            def payload_mass(t, mass=constant):
                return mass

        self.payload_mass = payload_mass
        self.uncertainty = uncertainty
        self.nq = self.model.nq
        self.active = robot.actuated_indices
        self._active_v_rows = self.nq + np.asarray(self.active)  # alpha_dot's rows in a full state
        if not failure_tolerance > 0.0:
            raise InvalidParameterError(
                f"failure_tolerance={failure_tolerance!r} must be a closure gap > 0 [m or rad], or math.inf"
            )
        self.projection_tolerance = projection_tolerance
        self.failure_tolerance = failure_tolerance
        self.projections = 0  # steps projected back onto the loops
        self.largest_projected_gap = 0.0  # the largest gap a projection removed [m or rad]
        self._last_q = robot.reference_configuration.copy()
        # joint springs and dampers (robot.joint_springs), the dampers on or off
        self.joint_damping = bool(joint_damping)
        self._completed = None  # (active state, its (q, v)): what a sample's readings share
        self._truth = PlantTruth(uncertainty, self.nominal_platform_mass, self._normal_force)
        self.metadata_extra = {
            "coordinates": coordinates,
            "baumgarte_frequency": baumgarte_frequency,
            "projection_tolerance": projection_tolerance,
        }

    def _set_friction(self, friction) -> None:
        delta = getattr(self.robot, "delta", None)
        if friction is True:
            if delta is None:
                raise InvalidParameterError(
                    "friction=True takes a recognised Delta's Stribeck data; for this robot give "
                    "Friction(stribeck=StribeckParameters(...))"
                )
            friction = Friction()
        self.friction = friction or None
        self.stribeck = None
        if self.friction is not None:
            self.stribeck = self.friction.stribeck_for(None if delta is None else delta.params.friction)
        self._normal_force = np.full(self.dof, 0.0 if self.friction is None else self.friction.normal_force)

    # ------------------------------------------------------------------ truth
    def evaluate_truth(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(m_o [kg], F_n (dof,) [N], F (dof,) [N m]) at a time t [s], or (R,), (R, dof), (R, dof)
        at an array of times: the payload body's mass, the normal forces and the disturbance."""
        return self._truth.evaluate(t)

    def precompute_truth(self, step: float, count: int) -> None:
        """Tabulate the truth at t = k step, k < count [s] (one vectorised call): the stage times
        of the integrator then read the table instead of calling the profile."""
        self._truth.tabulate(step, count)

    def truth(self, t: float) -> tuple[float, np.ndarray, np.ndarray]:
        """(m_o(t) [kg], F_n(t) (dof,) [N], F(t) (dof,) [N m]): the plant's time-varying truth."""
        return self._truth.at(t)

    def platform_mass(self, t: float) -> float:
        """m_o(t) [kg]: the mass of the payload frame's body."""
        return self.truth(t)[0]

    def passive_torque(self, t: float, alpha_dot: np.ndarray) -> np.ndarray:
        """F(t) + M_f(alpha_dot, F_n(t)) [N m]: what eq. 13 adds to the left-hand side."""
        _, normal, disturbance = self.truth(t)
        return disturbance + self._friction(alpha_dot, normal)

    def _friction(self, alpha_dot: np.ndarray, normal_force: np.ndarray) -> np.ndarray:
        if self.friction is None:
            return np.zeros(self.dof)
        return stribeck_torque(self.stribeck, alpha_dot, normal_force, self.friction.sign_velocity_scale)

    def joint_friction(self, alpha_dot: np.ndarray) -> np.ndarray:
        """Friction torque M_f(alpha_dot) (dof,) [N m or N] on the actuated joints at the nominal
        normal force (0 without friction)."""
        return self._friction(alpha_dot, self._normal_force)

    def rotational_inertia(self, mass):
        """The payload body's rotational inertia about its COM [kg m^2] for a mass [kg] (or an
        array of masses (R, 1, 1)): the nominal one scaled with the mass."""
        return self.nominal_platform_rotational * (mass / self.nominal_platform_mass)

    # ------------------------------------------------------------------ state interface
    def complete(self, alpha: np.ndarray, alpha_dot: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) on the loops for actuated positions and velocities, warm-started from the last
        completion (the active-coordinate state's full configuration); t [s] only names a failure.

        The robot's (the compiled core's) Newton; where it does not close, the error names the
        worst closure."""
        try:
            q = self.robot.configuration(alpha, initial_guess=self._last_q)
        except AssemblyError as exc:
            raise SimulationError(f"cannot close the loops: {exc}", t) from None
        self._last_q = q
        return q, self.robot.velocity_map(q) @ alpha_dot

    def initial_state(self, alpha, alpha_dot):
        alpha = np.asarray(alpha, dtype=float)
        alpha_dot = np.asarray(alpha_dot, dtype=float)
        if self.coordinates == "active":
            return np.concatenate([alpha, alpha_dot])
        q, v = self.complete(alpha, alpha_dot, 0.0)
        return np.concatenate([q, v])

    def joint_state(self, x):
        if self.coordinates == "active":
            return x[: self.dof], x[self.dof :]
        return x[self.robot.actuated_q_indices], x[self._active_v_rows]

    def _completed_state(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) of an active-coordinate state, completed once: the position, the closure gap
        and the recorded configuration of one sample read the same state."""
        if self._completed is None or not np.array_equal(self._completed[0], x):
            self._completed = (np.array(x), *self.complete(x[: self.dof], x[self.dof :], math.nan))
        return self._completed[1], self._completed[2]

    def _configuration(self, x: np.ndarray) -> np.ndarray:
        if self.coordinates == "active":
            return self._completed_state(x)[0]
        return x[: self.nq]

    def configuration_state(self, x):
        if self.coordinates == "active":
            q, v = self._completed_state(x)
            return q.copy(), v.copy()
        return x[: self.nq].copy(), x[self.nq :].copy()

    def platform_position(self, x):
        """Position [m] of the robot's end-effector frame."""
        return self.robot.frame_placement(self._configuration(x)).translation.copy()

    def closure_residual(self, x):
        return self.robot.closure_gap(self._configuration(x))

    def build(self, step: float = 0.0, count: int = 0):
        """The compiled core's copy of this plant (:mod:`delta_pin.sim.compiled_plant`)."""
        from delta_pin.sim.compiled_plant import build_core_plant

        return self._built_in_core(build_core_plant, step, count)

    def sampled_core(self, step: float, count: int):
        """:meth:`build` for the sampled loop: its RK4 steps integrate the whole x = [q, v]
        (``coordinates="full"``) or the actuated (alpha, alpha_dot) with (q, v) completed at
        every stage (``"active"``); the run records the completed (q, v) either way."""
        compiled = super().sampled_core(step, count)
        compiled.integrates_active = self.coordinates == "active"
        return compiled

    def metadata(self):
        return {
            "plant": self.name,
            **self.metadata_extra,
            "friction": None
            if self.friction is None
            else {**asdict(self.friction), "stribeck": asdict(self.stribeck)},
            "uncertainty": None if self.uncertainty is None else self.uncertainty.metadata(),
            "payload_frame": self.model.frames[self.payload_frame].name,
            "payload": getattr(self.payload_mass, "__name__", None),
            "redundant_closure_equations": self.redundant,
            "joint_couplings": [c.name for c in self.robot.joint_couplings],
            "idle_dof": self.robot.idle_dof,
            "passive_joints": list(self.robot.passive_joints),
            "joint_springs": {name: list(values) for name, values in self.robot.joint_springs.items()},
            "closure_projections": self.projections,
            "closure_gap_projected_max": self.largest_projected_gap,  # before its projection
        }


PinocchioPlant = ClosedChainPlant  # the Delta's plant's older name: one plant for every robot


def closed_chain_plant(plant: str, robot, friction=None, uncertainty=None, **options) -> Plant:
    """A plant by name: ``"pinocchio"`` (:class:`ClosedChainPlant`) or, for a recognised Delta,
    ``"analytic"`` (the paper's reduced ODE)."""
    if plant == "pinocchio":
        return ClosedChainPlant(robot, friction, uncertainty, **options)
    if plant == "analytic":
        delta = getattr(robot, "delta", robot if hasattr(robot, "params") else None)
        if delta is None:
            raise InvalidParameterError(
                f"plant='analytic' is the Delta's reduced ODE and {robot.name!r} is not a recognised "
                "Delta: use plant='pinocchio'"
            )
        if options.get("coordinates") == "active":  # the reduced ODE's state is [alpha, alpha_dot]
            options.pop("coordinates")
        if options:
            raise InvalidParameterError(
                f"plant='analytic' takes no plant options; {sorted(options)} are the Pinocchio plant's"
            )
        return AnalyticPlant(delta, friction, uncertainty)
    raise InvalidParameterError(f"plant={plant!r} must be 'pinocchio' or 'analytic' (or a Plant)")


def _has_rates(robot: ClosedChainRobot) -> bool:
    """Whether every joint of ``robot`` has a configuration rate (axis, ball, free, continuous,
    planar), so its whole state x = [q, v] can be integrated."""
    try:
        robot.configuration_rate(robot.reference_configuration, np.zeros(robot.model.nv))
    except InvalidParameterError:
        return False
    return True


def make_plant(plant: str | Plant, robot, friction=None, uncertainty=None, **options) -> Plant:
    """A plant by name (``"pinocchio"``: :class:`ClosedChainPlant`, the one Pinocchio plant;
    ``"analytic"``: the Delta's reduced ODE), or the given :class:`~delta_pin.sim.plants.Plant`
    itself; ``options`` go to the Pinocchio plant (e.g. ``coordinates="active"``)."""
    if isinstance(plant, Plant):
        return plant
    if plant not in PLANTS:
        raise InvalidParameterError(f"plant={plant!r} must be one of {', '.join(PLANTS)} or a Plant")
    return closed_chain_plant(plant, robot, friction, uncertainty, **options)

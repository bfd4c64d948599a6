"""Nominal models: what a controller knows of the robot (M̄, C̄, Ḡ, F̄, M̄_f of eqs. 16-20).

* :class:`DeltaNominalModel` -- the Delta's analytic model (eqs. 7-9, corrected G) with the
  nominal platform mass m̄_o, the nominal disturbance F̄ and the nominal Stribeck friction
  (eq. 12 with F̄_n; sgn smoothed like the plant's, so that the compensation does not chatter);
* :class:`PinocchioNominalModel` -- any serial (tree) Pinocchio model: M̄ by CRBA, C̄ by
  ``computeCoriolisMatrix`` and Ḡ by ``computeGeneralizedGravity``, so the controllers run on
  robots from example-robot-data too;
* :class:`ClosedChainNominalModel` -- any closed-chain robot
  (:class:`~delta_pin.model.closed_chain.ClosedChainRobot`): M̄, C̄ (the matrix) and Ḡ of its
  actuated joints by projection of the tree's dynamics onto the closures' null space, with a
  nominal payload and nominal friction (docs/architecture.md section 10).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from delta_pin.errors import AssemblyError, ForwardKinematicsError, InvalidParameterError
from delta_pin.model.core_model import core_chain, core_friction
from delta_pin.model.delta_robot import analytic_delta
from delta_pin.model.dynamics import analytic_dynamics
from delta_pin.model.friction import Friction, stribeck_torque
from delta_pin.model.kinematics import chain_trigonometry

__all__ = [
    "ClosedChainNominalModel",
    "DeltaNominalModel",
    "NominalModel",
    "PinocchioNominalModel",
    "core_law_of",
    "python_core_law",
]


def core_law_of(nominal, kind: str, name: str, *gains, friction_compensation: bool = True):
    """The compiled law ``kind`` on ``nominal`` (:meth:`NominalModel.core_law`): any object with
    the :class:`NominalModel` methods serves a controller as its nominal model (a robot's own
    ``terms``, say); one without ``core_law`` is called back by the compiled law
    (:func:`python_core_law`)."""
    make = getattr(nominal, "core_law", None)
    if make is None:
        return python_core_law(nominal, kind, name, gains, friction_compensation)
    return make(kind, name, *gains, friction_compensation=friction_compensation)


def python_core_law(nominal, kind: str, name: str, gains, friction_compensation: bool = True):
    """The compiled law ``kind`` on a nominal model written in Python: its ``terms(alpha,
    alpha_dot)`` and ``compensation(alpha_dot, friction_compensation)`` (F̄ [+ M̄_f]; an object
    without it: its ``disturbance()`` [+ ``friction(alpha_dot)``]) called back at every
    evaluation (``PythonTerms`` of ``delta_pin/core/python/bind_laws.cpp``), the law's arithmetic
    compiled."""
    from delta_pin.compiled.core import core

    own = getattr(nominal, "compensation", None)  # looked up once, not at every evaluation

    def compensation(alpha_dot):
        if own is not None:
            return np.asarray(own(alpha_dot, friction_compensation), dtype=float)
        value = np.asarray(nominal.disturbance(), dtype=float)
        return (
            value + np.asarray(nominal.friction(alpha_dot), dtype=float) if friction_compensation else value
        )

    terms = core().PythonTerms(int(nominal.dof), nominal.terms, compensation)
    return _core_law(terms, kind, name, gains, np.zeros(int(nominal.dof)), None, None, None)


class NominalModel(ABC):
    """M̄(q) [kg m^2], C̄(q, q_dot) [kg m^2/s], Ḡ(q) [N m], F̄ [N m] and M̄_f(q_dot) [N m]."""

    dof: int

    @abstractmethod
    def terms(self, q: np.ndarray, q_dot: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(M̄, C̄, Ḡ) at a state: inertia (n, n), Coriolis MATRIX (n, n), gravity (n,)."""

    def disturbance(self) -> np.ndarray:
        """Nominal disturbance torque F̄ (n,) [N m] (zero by default)."""
        return np.zeros(self.dof)

    def friction(self, q_dot: np.ndarray) -> np.ndarray:
        """Nominal friction torque M̄_f (n,) [N m] (zero by default)."""
        return np.zeros(self.dof)

    def core_law(self, kind: str, name: str, *gains, friction_compensation: bool = True):
        """A law of the compiled core on this nominal model (``kind``: ``"AdaptiveRobust"``,
        ``"ComputedTorque"``, ``"PDGravity"``, ... of ``delta_pin/core/run/controller.hpp``, with
        its gains): by default the law calls :meth:`terms` and :meth:`compensation` back
        (:func:`python_core_law`); a model the core holds overrides this."""
        return python_core_law(self, kind, name, gains, friction_compensation)

    def compensation(self, q_dot: np.ndarray, friction: bool) -> np.ndarray:
        """F̄ [+ M̄_f(q_dot) when ``friction``] (n,) [N m]: what eq. 23 adds besides M̄, C̄, Ḡ."""
        if friction:
            return self.disturbance() + self.friction(q_dot)
        return self.disturbance()

    def metadata(self) -> dict:
        return {"kind": type(self).__name__}


class DeltaNominalModel(NominalModel):
    """The Delta's analytic model as a controller's nominal model.

    Args:
        robot: the robot (its URDF sets every number).
        platform_mass: m̄_o [kg]; the URDF's ``m_o`` by default (0.3 kg, the paper's m̄_o).
        nominal_disturbance: F̄ (3,) [N m] (the paper: [2, 4, 6]).
        friction: nominal friction (:class:`~delta_pin.model.friction.Friction`, its F̄_n = 15 N
            by default), ``True`` for the defaults, or ``None`` for none.

    Attributes:
        m_eq: m̄_o + 3/2 m_b [kg], the platform-side mass of eqs. 7-8.
        stribeck: the nominal Stribeck parameters in force (``None`` without friction).
        normal_force: nominal F̄_n per joint (3,) [N] (zeros without friction).
    """

    dof = 3

    def __init__(
        self,
        robot,
        platform_mass: float | None = None,
        nominal_disturbance=(0.0, 0.0, 0.0),
        friction: Friction | bool | None = True,
    ) -> None:
        robot = analytic_delta(robot)  # the robot of load_delta carries the Delta's model
        self.robot = robot
        m_o = robot.params.m_o if platform_mass is None else float(platform_mass)
        if not m_o > 0.0:
            raise InvalidParameterError(f"platform_mass={platform_mass} must be > 0")
        self.platform_mass = m_o
        self.m_eq = m_o + 1.5 * robot.params.m_b
        self._cos, self._sin = chain_trigonometry()  # the chain azimuths, for the core's model
        self._disturbance = np.asarray(nominal_disturbance, dtype=float).reshape(3)
        if friction is True:
            friction = Friction()
        self.friction_model = friction or None
        self.normal_force = np.zeros(3)
        self.stribeck = None
        if self.friction_model is not None:
            self.stribeck = self.friction_model.stribeck_for(robot.params.friction)
            self.normal_force = np.full(3, float(self.friction_model.normal_force))

    def terms(self, q, q_dot):
        """M̄ [kg m^2], C̄ [kg m^2/s], Ḡ [N m] of eqs. 7-9 at (alpha [rad], alpha_dot [rad/s]) with
        the nominal platform mass (:func:`~delta_pin.model.dynamics.analytic_dynamics`).

        Raises:
            InvalidParameterError: ``alpha`` has no forward kinematics (the message names it).
        """
        try:
            terms = analytic_dynamics(self.robot.params, q, q_dot, platform_mass=self.platform_mass)
        except ForwardKinematicsError:
            message = f"alpha={np.asarray(q).tolist()} rad has no forward kinematics"
            raise InvalidParameterError(message) from None
        return terms.M, terms.C, terms.G

    def core_law(self, kind: str, name: str, *gains, friction_compensation: bool = True):
        """The compiled law ``kind`` on this analytic model (eqs. 7-10 in the core,
        ``core/control/delta_analytic.hpp``; F̄ and, with ``friction_compensation``, the nominal
        friction): the core's ``DeltaTerms``, no closed chain assembled."""
        from delta_pin.compiled.core import core

        p = self.robot.params
        arm_gravity = 0.5 * (p.m_a + p.m_b) * p.g * p.l_a  # eq. 9 (corrected)
        terms = core().DeltaTerms(
            p.R,
            p.r,
            p.l_a,
            p.l_b,
            p.arm_equivalent_inertia,
            arm_gravity,
            p.g,
            self.m_eq,
            self._cos,
            self._sin,
        )
        stribeck = self.stribeck if friction_compensation else None
        return _core_law(
            terms, kind, name, gains, self._disturbance, stribeck, self.friction_model, self.normal_force
        )

    def disturbance(self):
        return self._disturbance

    def friction(self, q_dot):
        """M̄_f(alpha_dot) of eq. 12 with F̄_n, sgn smoothed like the plant's [N m]."""
        if self.friction_model is None:
            return np.zeros(3)
        return stribeck_torque(
            self.stribeck, q_dot, self.normal_force, self.friction_model.sign_velocity_scale
        )

    def metadata(self):
        return {
            "kind": "delta_analytic",
            "platform_mass": self.platform_mass,
            "nominal_disturbance": self._disturbance.tolist(),
            "nominal_normal_force": None if self.friction_model is None else self.friction_model.normal_force,
        }


class PinocchioNominalModel(NominalModel):
    """Nominal model of a serial Pinocchio model with 1-DOF joints (nq == nv).

    Args:
        model: a ``pin.Model`` (copied: later changes to the caller's model do not leak in).
        nominal_disturbance: F̄ (nv,) [N m], zero by default.
    """

    def __init__(self, model: pin.Model, nominal_disturbance=None) -> None:
        if model.nq != model.nv:
            raise InvalidParameterError(
                f"PinocchioNominalModel needs nq == nv (1-DOF joints), got nq={model.nq}, nv={model.nv}"
            )
        self.model = pin.Model(model)
        self.data = self.model.createData()
        self.dof = model.nv
        self._disturbance = (
            np.zeros(self.dof)
            if nominal_disturbance is None
            else np.asarray(nominal_disturbance, dtype=float).reshape(self.dof)
        )

    def terms(self, q, q_dot):
        M = pin.crba(self.model, self.data, q)
        M = np.triu(M) + np.triu(M, 1).T
        C = pin.computeCoriolisMatrix(self.model, self.data, q, q_dot).copy()
        G = pin.computeGeneralizedGravity(self.model, self.data, q).copy()
        return M, C, G

    def disturbance(self):
        return self._disturbance

    def metadata(self):
        return {"kind": "pinocchio_serial", "name": self.model.name, "nv": self.dof}


class ClosedChainNominalModel(NominalModel):
    """A closed-chain robot's projected dynamics as a controller's nominal model.

    Args:
        robot: the robot (:func:`~delta_pin.model.loaders.load_robot`).
        payload_mass: nominal payload m̄ [kg] at ``payload_frame`` (the end effector by default).
        payload_frame: where the payload rides.
        nominal_disturbance: F̄ (dof,) [N m], zero by default.
        friction: nominal friction on the actuated joints (a
            :class:`~delta_pin.model.friction.Friction` with its ``stribeck``; ``True`` takes a
            recognised Delta's), or ``None``.

    Attributes:
        stribeck: the Stribeck parameters in force (``None`` without friction).
        normal_force: nominal F̄_n per actuated joint (dof,) [N] (zeros without friction).
    """

    def __init__(
        self,
        robot,
        payload_mass: float = 0.0,
        payload_frame: str | None = None,
        nominal_disturbance=None,
        friction: Friction | bool | None = None,
    ) -> None:
        mass = float(payload_mass)
        if not (np.isfinite(mass) and mass >= 0.0):
            raise InvalidParameterError(f"payload_mass={payload_mass!r} must be a finite mass >= 0 [kg]")
        robot.require_full_actuation()  # an underactuated or free-base robot: one line, at once
        self.robot = robot.with_payload(mass, payload_frame) if mass > 0.0 else robot
        self.payload_mass = mass
        self.dof = robot.dof
        # the compiled projection (joint springs and dampers included), None where the core refuses the model
        self._core = self.robot.compiled_model
        self._last_q = self.robot.reference_configuration.copy()
        self._disturbance = (
            np.zeros(self.dof)
            if nominal_disturbance is None
            else np.asarray(nominal_disturbance, dtype=float).reshape(self.dof)
        )
        if friction is True:
            if robot.delta is None:
                raise InvalidParameterError(
                    "friction=True needs a recognised Delta; give a Friction with its stribeck"
                )
            friction = Friction()
        self.friction_model = friction or None
        self.normal_force = np.zeros(self.dof)
        self.stribeck = None  # the Stribeck parameters in force (None without friction)
        if self.friction_model is not None:
            self.stribeck = self.friction_model.stribeck_for(
                None if robot.delta is None else robot.delta.params.friction
            )
            self.normal_force = np.full(self.dof, float(self.friction_model.normal_force))

    def terms(self, q, q_dot):
        """M, C, G of the projected dynamics at the actuated coordinates (``robot.reduced_terms``,
        the compiled core's), assembled from this model's previous configuration, else from the
        robot's own warm start (which names what does not close)."""
        alpha = self.robot._joint_vector(q, "alpha")
        try:
            configuration = self.robot.configuration(alpha, initial_guess=self._last_q)
        except AssemblyError:
            configuration = self.robot.configuration(alpha)
        self._last_q = configuration
        M, C, G, _ = self.robot.reduced_terms(alpha, q_dot, configuration)
        return M, C, G

    def core_law(self, kind: str, name: str, *gains, friction_compensation: bool = True):
        """The compiled law ``kind`` on this projected model (its robot, F̄ and, with
        ``friction_compensation``, the nominal friction), where the core takes the robot."""
        from delta_pin.compiled.core import core

        if self._core is None:  # a model the core refuses: its terms called back
            return python_core_law(self, kind, name, gains, friction_compensation)
        terms = core().ProjectedTerms(core_chain(self.robot), self.robot.reference_configuration)
        stribeck = self.stribeck if friction_compensation else None
        return _core_law(
            terms, kind, name, gains, self._disturbance, stribeck, self.friction_model, self.normal_force
        )

    def disturbance(self):
        return self._disturbance

    def friction(self, q_dot):
        if self.friction_model is None:
            return np.zeros(self.dof)
        return stribeck_torque(
            self.stribeck, q_dot, self.normal_force, self.friction_model.sign_velocity_scale
        )

    def metadata(self):
        return {
            "kind": "closed_chain_projected",
            "robot": self.robot.name,
            "payload_mass": self.payload_mass,
            "nominal_disturbance": self._disturbance.tolist(),
            "nominal_normal_force": None if self.friction_model is None else self.friction_model.normal_force,
        }


def gains_fields(struct_type: type) -> set[str]:
    """The fields of a compiled gains struct (its bound read-write properties)."""
    return {name for name, value in vars(struct_type).items() if isinstance(value, property)}


def named_gains(module, kind: str, gains: Mapping):
    """The compiled law ``kind``'s gains struct (``<kind>Gains`` of the core) filled by name from
    ``gains``: every field of the struct must be given and no other (a default taken silently,
    or a name that does not exist, is how positional gains went wrong).

    Raises:
        ValueError: a missing or unknown field, naming it.
    """
    struct_type = getattr(module, f"{kind}Gains")
    fields = gains_fields(struct_type)
    missing, unknown = sorted(fields - set(gains)), sorted(set(gains) - fields)
    if missing or unknown:
        raise ValueError(f"{kind}Gains: missing {missing}, unknown {unknown}; its fields: {sorted(fields)}")
    struct = struct_type()
    for field, value in gains.items():
        setattr(struct, field, value)
    return struct


def _core_law(terms, kind: str, name: str, gains, disturbance, stribeck, friction, normal_force):
    """The compiled law ``kind`` of ``delta_pin/core/run/controller.hpp`` on the nominal model
    ``terms`` (a ``NominalTerms`` of the core; F̄ ``disturbance`` [N m]; the Stribeck friction it
    compensates, or ``None``).

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """
    from delta_pin.compiled.core import core

    module = core()
    if len(gains) == 1 and isinstance(gains[0], Mapping):  # gains by name: the law's gains struct
        gains = (named_gains(module, kind, gains[0]),)
    law = getattr(module, kind)(terms, np.asarray(disturbance, dtype=float), name, *gains)
    if stribeck is not None:
        law.set_friction(core_friction(stribeck, friction.sign_velocity_scale, normal_force))
    return law

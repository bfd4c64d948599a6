"""Plants: the simulated "true" robot, driven by torques on the three active joints.

The Delta's plants integrate eq. 13 of the paper,

    M(alpha, m_o(t)) alpha_ddot + C alpha_dot + G + F(t) + M_f(alpha_dot, F_n(t)) = tau,

with the plant's truth (friction, time-varying platform mass m_o(t), normal force F_n(t) and
joint disturbance F(t)) kept apart from what a controller knows:

* the Pinocchio plant, :class:`~delta_pin.sim.closed_chain_plant.ClosedChainPlant` (the one
  plant of every closed-chain robot, ``PinocchioPlant`` its older name) -- the full tree with
  its closures through ``pin.constraintDynamics``, Baumgarte stabilisation and a projection onto
  the loops where the gap exceeds a tolerance; the platform mass changes during the run by
  rewriting the platform body's inertia (its rotational inertia scales with the mass);
* :class:`AnalyticPlant` -- the paper's reduced ODE (eqs. 7-9, corrected G), stepped by the
  compiled core (``delta_pin/core/plant/analytic_plant.hpp``).

A built-in plant is a specification -- robot, friction, truth, settings -- that builds its
compiled copy (:meth:`Plant.build`), and every run steps that copy. Their readable Python
dynamics are the oracles of ``tests/reference/plants.py``. A plant a user writes in Python
defines :meth:`Plant.derivative` instead, and the core's sampled loop calls it back.

A time-varying mass enters as in eq. 13: the instantaneous M(m_o(t)), no momentum flux term.

Friction: eq. 12 with sgn replaced by tanh(alpha_dot / sign_velocity_scale) -- 0.01 rad/s by
default -- so that the ODE right-hand side stays Lipschitz and RK4 at 1 kHz resolves it (the
friction slope near zero is then mu_d F_n r_a / 0.01 = 6 N m s/rad on the Table 1 robot).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import asdict

import numpy as np

from delta_pin.model.delta_robot import analytic_delta
from delta_pin.model.friction import Friction, stribeck_torque
from delta_pin.model.kinematics import forward_kinematics_masked
from delta_pin.model.robot import Delta
from delta_pin.sim.truth import PlantTruth
from delta_pin.sim.uncertainty import NoUncertainty

__all__ = ["AnalyticPlant", "DeltaPlant", "Plant"]


class Plant(ABC):
    """A simulated robot with state ``x``, driven by torques on its ``dof`` actuated joints: the
    interface every plant implements (the Delta's analytic and Pinocchio plants, any closed
    chain's, a serial robot's), with what a plant without closures or a time-varying truth needs
    by default. A built-in plant builds its compiled copy (:meth:`build`); a plant written in
    Python defines :meth:`derivative` (and :meth:`finish_step` where it corrects its state).
    """

    name: str = "plant"
    dof: int = 3  # actuated joints: the robot's where it says
    stepped_in_core: bool = False  # whether build handed a loop a compiled copy

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

    def derivative(self, t: float, x: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """dx/dt at time t [s] under active-joint torques tau [N m]: what a plant written in Python
        defines (the core's sampled loop calls it back at every RK4 stage). A built-in plant has
        none: its dynamics are its compiled copy's (:meth:`build`); their readable twins are the
        oracles of tests/reference/plants.py."""
        raise NotImplementedError(
            f"plant {self.name!r} steps in the compiled core (build()); a plant written in Python "
            "defines derivative(t, x, tau)"
        )

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

    def truth_table(self, step: float, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(m_o (count,) [kg], F_n (count, dof) [N], F (count, dof) [N m]) at t = k step [s] of a
        plant with a time-varying truth (:class:`~delta_pin.sim.truth.PlantTruth`): the table of
        :meth:`precompute_truth` where it was made on that grid, else tabulated now."""
        truth = self._truth
        if truth.table is None or truth.step != step or len(truth.table[0]) < count:
            self.precompute_truth(step, count)
        return tuple(np.asarray(column)[:count] for column in truth.table)

    def build(self, step: float = 0.0, count: int = 0):
        """This plant's copy in the compiled core (:mod:`delta_pin.sim.compiled_plant`), its
        time-varying truth tabulated at t = i step, i < count [s] (``count=0``: not yet, the
        caller sets it); ``None`` (the default) where it has none."""
        return None

    def _built_in_core(self, build, step: float, count: int):
        """``build(self, step, count)`` (a builder of :mod:`delta_pin.sim.compiled_plant`); the
        plant handed out marks the run's metadata (``"core_plant"``).

        Raises:
            NativeUnavailableError: the core cannot be imported here.
        """
        compiled = build(self, step, count)
        self.stepped_in_core = True
        return compiled

    def sampled_core(self, step: float, count: int):
        """This plant in the compiled core for the sampled loop with RK4 steps of ``step`` [s],
        its truth tabulated at the stage times t = i step / 2, i < count; ``None`` where it has
        none: the core's loop then calls :meth:`derivative` back
        (:func:`~delta_pin.sim.compiled_plant.python_core_plant`)."""
        return self.build(step / 2.0, count)

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
        if self.friction is not None:
            self.stribeck = self.friction.stribeck_for(robot.params.friction)
        self.uncertainty = NoUncertainty() if uncertainty is None else uncertainty
        normal_force = 0.0 if self.friction is None else self.friction.normal_force
        self._truth = PlantTruth(self.uncertainty, robot.params.m_o, np.full(3, normal_force))

    # ------------------------------------------------------------------ truth
    def evaluate_truth(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(m_o, F_n, F) at a time or an array of times, straight from the uncertainty profile."""
        return self._truth.evaluate(t)

    def precompute_truth(self, step: float, count: int) -> None:
        """Tabulate m_o, F_n, F at t = k step, k < count [s] (one vectorised call): the
        integrator's stage times then read the table instead of calling the profile."""
        self._truth.tabulate(step, count)

    def truth(self, t: float) -> tuple[float, np.ndarray, np.ndarray]:
        """(m_o(t) [kg], F_n(t) (3,) [N], F(t) (3,) [N m]): the plant's time-varying truth."""
        return self._truth.at(t)

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
        friction = stribeck_torque(self.stribeck, alpha_dot, normal, self.friction.sign_velocity_scale)
        return mass, disturbance + friction

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

    def initial_state(self, alpha, alpha_dot):
        return np.concatenate([alpha, alpha_dot]).astype(float)

    def joint_state(self, x):
        return x[:3], x[3:]

    def build(self, step: float = 0.0, count: int = 0):
        """The compiled core's reduced Delta with this plant's friction and truth
        (:func:`~delta_pin.sim.compiled_plant.build_core_analytic_plant`)."""
        from delta_pin.sim.compiled_plant import build_core_analytic_plant

        return self._built_in_core(build_core_analytic_plant, step, count)

    def platform_position(self, x):
        xyz, valid = forward_kinematics_masked(self.robot.params, x[:3])
        return xyz if valid else self.robot.forward_kinematics(x[:3])  # the latter raises with alpha

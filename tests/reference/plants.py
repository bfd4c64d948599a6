"""The readable Python plants: the dynamics the compiled core's plants are tested against.

Each built-in plant of delta_pin is a specification -- its robot, friction, truth, payload and
settings -- that builds its compiled copy (:meth:`Plant.build <delta_pin.sim.plants.Plant.build>`),
which every run steps. The Python dynamics they had are kept here as the oracles, on the same
specifications (:func:`readable` makes the twin of a plant):

* :class:`ReadableClosedChainPlant` -- ``pin.constraintDynamics`` on the tree with Baumgarte
  stabilisation, the joint couplings' multipliers, springs and dampers, the payload body's
  time-varying inertia, and the projection onto the loops after a step (``finish_step``); in
  active coordinates the loops assembled at every evaluation (module docstring of
  :mod:`delta_pin.sim.closed_chain_plant`);
* :class:`ReadableAnalyticPlant` -- the paper's reduced ODE (eqs. 7-9, 13) by
  :func:`delta_pin.model.dynamics.analytic_dynamics`;
* :class:`ReadableSerialPlant` -- ``pin.aba`` with the payload a point mass at the end effector.

A readable plant has no compiled copy (``build`` returns ``None``): ``delta_pin.simulate`` then
calls its ``derivative`` back from the core's sampled loop, as it does a user's plant, and
tests/reference/python_loop.py integrates it in Python.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from delta_pin.errors import AssemblyError, ForwardKinematicsError, SimulationError
from delta_pin.model.dynamics import analytic_dynamics
from delta_pin.sim.closed_chain_plant import ClosedChainPlant
from delta_pin.sim.plants import AnalyticPlant, Plant
from delta_pin.sim.serial import SerialPlant

__all__ = ["ReadableAnalyticPlant", "ReadableClosedChainPlant", "ReadableSerialPlant", "readable"]


class _Readable:
    """What every readable twin shares: no compiled copy, so a run calls its dynamics back."""

    def build(self, step: float = 0.0, count: int = 0):
        return None

    def sampled_core(self, step: float, count: int):
        return None


class ReadableClosedChainPlant(_Readable, ClosedChainPlant):
    """:class:`~delta_pin.sim.closed_chain_plant.ClosedChainPlant` with its Python dynamics (the
    constructor's arguments are the plant's)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._prepare()

    def _prepare(self) -> None:
        """The Python dynamics' own model (the truth rewrites its inertias), data and scratch."""
        self.model = pin.Model(self.robot.model)
        self.data = self.model.createData()
        self.constraint_datas = pin.StdVec_RigidConstraintData()
        for cm in self.constraint_models:
            self.constraint_datas.append(cm.createData())
        pin.initConstraintDynamics(self.model, self.data, self.constraint_models, self.constraint_datas)
        # ball, free or continuous joints: their coefficients move at dq/dt = rate(q, v) and are
        # renormalised after every step (pin.normalize)
        self._coefficient_rates = self.model.nq != self.model.nv
        self._inertia = self.model.inertias[self._payload_joint]  # a reference, rewritten in place
        self._nominal_lever = self._inertia.lever.copy()
        self._mass = (self.nominal_platform_mass, 0.0)  # the (body mass, payload) the model holds
        self._tau = np.zeros(self.model.nv)
        # joint springs and dampers (robot.joint_springs): tau = -k (q - q_ref) - d v
        model, joint_damping = self.robot.model, self.joint_damping
        springs = [(model.getJointId(n), k, ref, d) for n, (k, ref, d) in self.robot.joint_springs.items()]
        one = [spring for spring in springs if model.nvs[spring[0]] == 1]
        self._spring_q = np.array([model.idx_qs[j] for j, *_ in one], dtype=int)
        self._spring_v = np.array([model.idx_vs[j] for j, *_ in one], dtype=int)
        self._spring_k = np.array([k for _, k, _, _ in one], dtype=float)
        self._spring_ref = np.array([r for _, _, r, _ in one], dtype=float)
        self._spring_d = np.array([d if joint_damping else 0.0 for *_, d in one], dtype=float)
        # dampers on joints of several degrees of freedom (ball joints): -d omega on each
        many = [(j, d) for j, _, _, d in springs if model.nvs[j] != 1]
        self._damper_v = np.array(
            [model.idx_vs[j] + k for j, _ in many for k in range(model.nvs[j])], dtype=int
        )
        self._damper_d = np.array(
            [d if joint_damping else 0.0 for j, d in many for _ in range(model.nvs[j])], dtype=float
        )

    def _set_mass(self, mass: float, payload: float, rotational: np.ndarray | None = None) -> None:
        """The payload body's inertia in the model for its mass [kg] (its COM kept, the rotational
        inertia ``rotational``, by default :meth:`rotational_inertia` of the mass) plus a point
        payload [kg] at the payload frame; nothing where both are unchanged."""
        if (mass, payload) == self._mass:
            return
        rotational = self.rotational_inertia(mass) if rotational is None else rotational
        if payload == 0.0 and self._mass[1] == 0.0:  # the body alone: rewritten in place
            self._inertia.mass = mass
            self._inertia.inertia = rotational
        else:
            inertia = pin.Inertia(mass, self._nominal_lever, rotational)
            if payload:
                inertia = inertia + pin.Inertia(payload, self._payload_point, np.zeros((3, 3)))
            self.model.inertias[self._payload_joint] = inertia
            self._inertia = self.model.inertias[self._payload_joint]
        self._mass = (mass, payload)

    def accelerations(self, t: float, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """ddq of the constrained tree at (q, v) under actuated torques tau (dof,) at time t [s]."""
        mass, normal, disturbance = self.truth(t)
        payload = 0.0 if self.payload_mass is None else float(self.payload_mass(t))
        if payload != self._mass[1] and not (math.isfinite(payload) and payload >= 0.0):
            raise SimulationError(f"payload_mass(t) returned {payload!r} kg", t)
        self._set_mass(mass, payload)
        self._tau[:] = 0.0
        self._tau[self.active] = tau - (disturbance + self._friction(v[self.active], normal))
        if self._spring_v.size:
            self._tau[self._spring_v] -= self._spring_k * (q[self._spring_q] - self._spring_ref) + (
                self._spring_d * v[self._spring_v]
            )
        if self._damper_v.size:
            self._tau[self._damper_v] -= self._damper_d * v[self._damper_v]
        if not self.robot.joint_couplings:
            return self._constrained(q, v, self._tau)
        return self._coupled(q, v)

    def _constrained(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """ddq by ``pin.constraintDynamics`` on the frame closures (a view into ``data``)."""
        return pin.constraintDynamics(
            self.model, self.data, q, v, tau, self.constraint_models, self.constraint_datas, self.settings
        )

    def _coupled(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """ddq with the joint couplings' multipliers added (module docstring)."""
        r, J, drift = self.robot.coupling_terms(q, v)
        free = self._constrained(q, v, self._tau).copy()
        D = np.empty((self.model.nv, len(r)))
        for k in range(len(r)):
            D[:, k] = self._constrained(q, v, self._tau + J[k]) - free
        kp, kd = self.baumgarte_gains
        target = -(J @ free + drift) - kd * (J @ v) - kp * r
        try:
            multipliers = np.linalg.solve(J @ D, target)
        except np.linalg.LinAlgError:  # a coupling the closures already imply: redundant rows
            multipliers = np.linalg.lstsq(J @ D, target, rcond=None)[0]
        return free + D @ multipliers

    def derivative(self, t, x, tau):
        if self.coordinates == "active":
            q, v = self.complete(x[: self.dof], x[self.dof :], t)
            return np.concatenate([x[self.dof :], self.accelerations(t, q, v, tau)[self.active]])
        q, v = x[: self.nq], x[self.nq :]
        rate = self.robot.configuration_rate(q, v) if self._coefficient_rates else v
        return np.concatenate([rate, self.accelerations(t, q, v, tau)])

    def finish_step(self, x, t):
        return self.finish_step_residual(x, t)[0]

    def finish_step_residual(self, x, t):
        """:meth:`finish_step` and the closure residual of the state it returns, computed once: a
        full-coordinate state whose gap exceeds ``projection_tolerance`` is projected back onto the
        loops (positions by Newton from the actuated joints, velocities through the null space;
        idle and passive coordinates kept where the robot has them)."""
        if self.coordinates == "active":
            return x, self.closure_residual(x)
        if self._coefficient_rates:
            x = np.concatenate([pin.normalize(self.model, x[: self.nq]), x[self.nq :]])
        gap = self.robot.closure_gap(x[: self.nq])
        if gap <= self.projection_tolerance:
            return x, gap
        if not (math.isfinite(gap) and np.isfinite(x).all()):
            raise SimulationError(
                f"the loop-closure gap is {gap:.3e}{self._gap_unit}: the state is no longer finite", t
            )
        if gap > self.failure_tolerance:
            raise SimulationError(
                f"the loop-closure gap reached {gap:.3e}{self._gap_unit}, above failure_tolerance="
                f"{self.failure_tolerance:g}{self._gap_unit} (raise it, or shorten dt)",
                t,
            )
        self._last_q = x[: self.nq].copy()
        try:
            if self.robot.has_unactuated_motion:  # idle and passive state of its own: keep it
                q, v = self.robot.project_state(x[: self.nq], x[self.nq :])
            else:
                alpha, alpha_dot = self.joint_state(x)
                q = self.robot.configuration(alpha, initial_guess=self._last_q)
                v = self.robot.velocity_map(q) @ alpha_dot
        except (AssemblyError, ForwardKinematicsError) as exc:
            raise SimulationError(
                f"the loops cannot be re-assembled after a closure gap of {gap:.3e}{self._gap_unit}: {exc}", t
            ) from None
        self._last_q = q
        x = np.concatenate([q, v])
        self.projections += 1
        self.largest_projected_gap = max(self.largest_projected_gap, gap)
        return x, self.closure_residual(x)


class ReadableAnalyticPlant(_Readable, AnalyticPlant):
    """:class:`~delta_pin.sim.plants.AnalyticPlant` with its Python dynamics."""

    def derivative(self, t, x, tau):
        """[alpha_dot, alpha_ddot] of eq. 13 at t [s], x = [alpha [rad], alpha_dot [rad/s]] under
        tau [N m]: M, C, G of :func:`~delta_pin.model.dynamics.analytic_dynamics` at m_o(t)."""
        alpha, alpha_dot = x[:3], x[3:]
        mass, passive = self.acceleration_terms(t, alpha_dot)
        try:
            terms = analytic_dynamics(self.robot.params, alpha, alpha_dot, platform_mass=mass)
        except ForwardKinematicsError:
            raise SimulationError(f"alpha={alpha.tolist()} rad has no forward kinematics", t) from None
        rhs = tau - terms.coriolis - terms.G - passive
        return np.concatenate([alpha_dot, np.linalg.solve(terms.M, rhs)])


class ReadableSerialPlant(_Readable, SerialPlant):
    """:class:`~delta_pin.sim.serial.SerialPlant` with its Python dynamics (``pin.aba``)."""

    def derivative(self, t, x, tau):
        self._set_payload(t)
        q, v = x[: self.dof], x[self.dof :]
        return np.concatenate([v, pin.aba(self.model, self.data, q, v, tau)])


READABLE = {
    ClosedChainPlant: ReadableClosedChainPlant,
    AnalyticPlant: ReadableAnalyticPlant,
    SerialPlant: ReadableSerialPlant,
}


def readable(plant: Plant) -> Plant:
    """The readable twin of a built-in plant: the same specification (a copy of its attributes),
    the Python dynamics of this module; a plant with none here (a user's, already written in
    Python, or a twin) is returned as it is."""
    twin_class = READABLE.get(type(plant))
    if twin_class is None:
        return plant
    twin = twin_class.__new__(twin_class)
    twin.__dict__.update(plant.__dict__)
    if isinstance(twin, ReadableClosedChainPlant):
        twin._prepare()
    return twin

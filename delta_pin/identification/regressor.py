"""The regressor of a closed-chain robot's actuated dynamics: tau_act = Y(alpha, alpha_dot, alpha_ddot) theta.

The tree's dynamics are linear in its inertial parameters, M(q) a + h(q, v) = Y_tree(q, v, a) theta
(``pin.computeJointTorqueRegressor``, 10 parameters per body in Pinocchio's order m, m c_x, m c_y,
m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz, the inertia about the joint frame's origin). On the
closures, M a + h = tau_tree + J_c^T lambda, and the closures' velocity map S (v = S alpha_dot,
its columns spanning the null space of J_c, so S^T J_c^T = 0; identity rows at the actuated
joints) removes the unknown multipliers:

    tau_act = S^T Y_tree(q(alpha), S alpha_dot, S alpha_ddot + S_dot alpha_dot) theta

the projection of docs/architecture.md sections 5 and 10 (M = S^T M S, G = S^T g, C alpha_dot =
S^T (nle - g) + S^T M S_dot alpha_dot), read the other way round: the same q(alpha), S and drift
S_dot alpha_dot the robot model computes (:meth:`ClosedChainRobot.configuration`,
:meth:`~ClosedChainRobot.velocity_map`, :meth:`~ClosedChainRobot.closure_drift`). On the Delta
it reproduces eqs. 7-9 (the corrected G, erratum 1) at the URDF's parameters.

Columns on the actuated joints are appended per joint (all linear in their parameter):

* ``Ia`` rotor inertia [kg m^2]: alpha_ddot_j;
* ``fv`` viscous friction [N m s/rad]: alpha_dot_j;
* ``fc`` Coulomb friction [N m]: tanh(alpha_dot_j / eps), the smooth sign of the plant
  (eps = ``sign_velocity_scale``, 0.01 rad/s as :class:`~delta_pin.model.friction.Friction`);
* ``fs`` Stribeck excess F_s - F_c [N m]: exp(-(alpha_dot_j r_a / v_s)^2) tanh(alpha_dot_j / eps)
  (eq. 12 at a given v_s [m/s] and r_a [m]; v_s itself by the nonlinear refinement of
  :func:`delta_pin.identification.estimation.refine_stribeck_velocity`);
* ``off`` torque offset [N m]: 1.

So with eq. 12's friction (plant truth: fc = mu_d F_n r_a, fs = (mu_s - mu_d) F_n r_a,
fv = mu_v r_a) the measured motor torque is exactly Y theta.

Robots with idle motions, passive joints, joint couplings or joint springs are refused: with
idle motions S depends on the inertias (the map of least kinetic energy), so the actuated torque
is not linear in them, and springs or couplings add torques that are not inertial parameters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from delta_pin.errors import AssemblyError, InvalidParameterError
from delta_pin.model.closed_chain import ClosedChainRobot, least_squares

__all__ = [
    "INERTIAL_NAMES",
    "ClosedChainRegressor",
    "JointColumns",
    "standard_parameters",
]

INERTIAL_NAMES = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")  # Pinocchio's order
INERTIAL_UNITS = ("kg", "kg m", "kg m", "kg m", "kg m^2", "kg m^2", "kg m^2", "kg m^2", "kg m^2", "kg m^2")


@dataclass(frozen=True)
class JointColumns:
    """Which actuated-joint columns the regressor carries (module docstring).

    Attributes:
        rotor_inertia: an ``Ia`` column per joint.
        viscous: an ``fv`` column per joint.
        coulomb: an ``fc`` column per joint.
        stribeck_velocity: v_s [m/s] of the ``fs`` column (``None``: no Stribeck column).
        friction_arm: r_a [m] of the Stribeck exponent.
        offset: an ``off`` column per joint.
        sign_velocity_scale: eps [rad/s] of the smooth sign tanh(alpha_dot / eps).
    """

    rotor_inertia: bool = True
    viscous: bool = True
    coulomb: bool = True
    stribeck_velocity: float | None = None
    friction_arm: float = 0.04
    offset: bool = True
    sign_velocity_scale: float = 0.01

    def __post_init__(self) -> None:
        if not self.sign_velocity_scale > 0.0:
            raise InvalidParameterError(f"sign_velocity_scale={self.sign_velocity_scale} must be > 0 [rad/s]")
        if self.stribeck_velocity is not None and not self.stribeck_velocity > 0.0:
            raise InvalidParameterError(f"stribeck_velocity={self.stribeck_velocity} must be > 0 [m/s]")
        if not self.friction_arm > 0.0:
            raise InvalidParameterError(f"friction_arm={self.friction_arm} must be > 0 [m]")

    def kinds(self) -> tuple[tuple[str, str], ...]:
        """(prefix, unit) of each kind of column present, in the regressor's order."""
        kinds = []
        if self.rotor_inertia:
            kinds.append(("Ia", "kg m^2"))
        if self.viscous:
            kinds.append(("fv", "N m s/rad"))
        if self.coulomb:
            kinds.append(("fc", "N m"))
        if self.stribeck_velocity is not None:
            kinds.append(("fs", "N m"))
        if self.offset:
            kinds.append(("off", "N m"))
        return tuple(kinds)

    def block(self, alpha_dot: np.ndarray, alpha_ddot: np.ndarray) -> np.ndarray:
        """The joint columns (N, dof, kinds x dof) at N samples: kind-major, joint-minor."""
        alpha_dot = np.atleast_2d(alpha_dot)
        alpha_ddot = np.atleast_2d(alpha_ddot)
        count, dof = alpha_dot.shape
        sign = np.tanh(alpha_dot / self.sign_velocity_scale)
        values = []
        for prefix, _ in self.kinds():
            if prefix == "Ia":
                values.append(alpha_ddot)
            elif prefix == "fv":
                values.append(alpha_dot)
            elif prefix == "fc":
                values.append(sign)
            elif prefix == "fs":
                values.append(np.exp(-((alpha_dot * self.friction_arm / self.stribeck_velocity) ** 2)) * sign)
            else:
                values.append(np.ones_like(alpha_dot))
        out = np.zeros((count, dof, len(values) * dof))
        joints = np.arange(dof)
        for k, value in enumerate(values):
            out[:, joints, k * dof + joints] = value
        return out


def _body_names(model: pin.Model) -> list[str]:
    """The link (body frame) carried by each joint 1..njoints-1 of the tree."""
    names = []
    for j in range(1, model.njoints):
        name = model.names[j]
        for frame in model.frames:
            if frame.type == pin.FrameType.BODY and frame.parentJoint == j:
                name = frame.name
                break
        names.append(name)
    return names


def standard_parameters(model: pin.Model) -> np.ndarray:
    """The tree's inertial parameters theta (10 (njoints - 1),) in the regressor's order
    (``Inertia.toDynamicParameters``: m [kg], m c [kg m], the inertia about the joint frame's
    origin [kg m^2])."""
    return np.concatenate([model.inertias[j].toDynamicParameters() for j in range(1, model.njoints)])


class ClosedChainRegressor:
    """Y(alpha, alpha_dot, alpha_ddot) of a closed-chain robot (module docstring).

    Args:
        robot: the robot (:func:`~delta_pin.load_delta`, :func:`~delta_pin.load_robot`).
        columns: the actuated-joint columns (:class:`JointColumns`; default: rotor inertia,
            viscous and Coulomb friction, offsets; a Stribeck column at the robot's v_s where it
            is a recognised Delta).
        massless: ``"fixed"`` (default): a body whose URDF gives it no mass and no inertia (a
            virtual link: the Delta's elbow links between the two revolutes of a universal joint,
            the platform's slides) keeps them, and has no columns; ``"free"``: every body has its
            10 columns.

    Attributes:
        names: one name per parameter: ``"m[upper_arm_1]"`` ... for the tree's bodies, then
            ``"fv[active_1]"`` ... for the joint columns.
        units: their SI units.
        inertial_count: how many of them are the tree's (10 per body).

    Raises:
        InvalidParameterError: a robot whose actuated torque is not linear in its parameters
            (idle motions, passive joints, joint couplings, joint springs), named.
    """

    def __init__(
        self, robot: ClosedChainRobot, columns: JointColumns | None = None, *, massless: str = "fixed"
    ) -> None:
        robot.require_full_actuation()
        why = []
        if robot.idle_dof:
            why.append(f"{robot.idle_dof} idle motion(s) (S then depends on the inertias)")
        if robot.joint_couplings:
            why.append("joint couplings")
        if robot.joint_springs:
            why.append(f"joint springs on {', '.join(robot.joint_springs)}")
        if why:
            raise InvalidParameterError(
                f"robot {robot.name!r} has {' and '.join(why)}: its actuated torque is not linear in the "
                "inertial parameters, so it has no regressor here"
            )
        if columns is None:
            delta = getattr(robot, "delta", None)
            friction = None if delta is None else delta.params.friction
            columns = (
                JointColumns()
                if friction is None
                else JointColumns(stribeck_velocity=friction.v_s, friction_arm=friction.r_a)
            )
        self.robot = robot
        self.columns = columns
        self.model = robot.model
        self.data = self.model.createData()
        self.dof = robot.dof
        if massless not in ("fixed", "free"):
            raise InvalidParameterError(f"massless={massless!r} must be 'fixed' or 'free'")
        names_all = _body_names(self.model)
        theta = standard_parameters(self.model).reshape(-1, 10)
        kept = [k for k in range(len(names_all)) if massless == "free" or np.any(theta[k] != 0.0)]
        self.bodies = np.array(kept, dtype=int)  # tree joint k + 1 carries body k
        self.tree_columns = (10 * self.bodies[:, None] + np.arange(10)[None, :]).ravel()
        bodies = [names_all[k] for k in kept]
        self.body_names = tuple(bodies)
        self.fixed_bodies = tuple(names_all[k] for k in range(len(names_all)) if k not in kept)
        self.inertial_count = 10 * len(bodies)
        names = [f"{p}[{b}]" for b in bodies for p in INERTIAL_NAMES]
        units = [u for _ in bodies for u in INERTIAL_UNITS]
        for prefix, unit in columns.kinds():
            names += [f"{prefix}[{j}]" for j in robot.actuated_joints]
            units += [unit] * self.dof
        self.names = tuple(names)
        self.units = tuple(units)
        self._last_q = robot.reference_configuration.copy()

    @property
    def size(self) -> int:
        """Number of parameters (columns)."""
        return len(self.names)

    def parameters(
        self, robot: ClosedChainRobot | None = None, joint_values: dict | None = None
    ) -> np.ndarray:
        """theta of a robot (this one by default) with the given joint-column values
        (``{"fv": [..], "fc": ..}``, dof values or one for all; 0 where absent)."""
        robot = self.robot if robot is None else robot
        theta = np.zeros(self.size)
        theta[: self.inertial_count] = standard_parameters(robot.model)[self.tree_columns]
        joint_values = joint_values or {}
        for k, (prefix, _) in enumerate(self.columns.kinds()):
            if prefix in joint_values:
                start = self.inertial_count + k * self.dof
                theta[start : start + self.dof] = np.broadcast_to(joint_values[prefix], (self.dof,))
        return theta

    def kinematics(
        self, alpha: np.ndarray, alpha_dot: np.ndarray, alpha_ddot: np.ndarray, q: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(q, v, a, S) of one state: the assembled configuration q(alpha) (``q`` where known, else
        warm-started from the previous call), v = S alpha_dot, a = S alpha_ddot + S_dot alpha_dot [SI]."""
        robot = self.robot
        if q is None:  # the core's Newton; where it does not close, the error names the worst closure
            q = robot.configuration(alpha, initial_guess=self._last_q)
        self._last_q = q
        S = robot.velocity_map(q)
        J = robot.closure_jacobian(q)
        v = S @ alpha_dot
        drift = np.zeros(
            self.model.nv
        )  # S_dot alpha_dot: the dependent joints' acceleration at alpha_ddot = 0
        drift[robot.dependent_indices] = -least_squares(
            J[:, robot.dependent_indices], robot.closure_drift(q, v)
        )
        return q, v, S @ alpha_ddot + drift, S

    def tree_rows(self, alpha, alpha_dot, alpha_ddot, q: np.ndarray | None = None) -> np.ndarray:
        """S^T Y_tree (dof, ``inertial_count``) at one state [rad, rad/s, rad/s^2] (``q``: its
        assembled configuration, where known)."""
        q, v, a, S = self.kinematics(
            np.asarray(alpha, float), np.asarray(alpha_dot, float), np.asarray(alpha_ddot, float), q
        )
        Y = pin.computeJointTorqueRegressor(self.model, self.data, q, v, a)
        return S.T @ Y[:, self.tree_columns]

    def rows(self, alpha, alpha_dot, alpha_ddot, q: np.ndarray | None = None) -> np.ndarray:
        """Y (dof, ``size``) at one state [rad, rad/s, rad/s^2]: tau_act = Y theta [N m]."""
        joint = self.columns.block(np.asarray(alpha_dot, float), np.asarray(alpha_ddot, float))[0]
        return np.hstack([self.tree_rows(alpha, alpha_dot, alpha_ddot, q), joint])

    def stack(
        self,
        alpha: np.ndarray,
        alpha_dot: np.ndarray,
        alpha_ddot: np.ndarray,
        *,
        times: np.ndarray | None = None,
    ) -> np.ndarray:
        """Y at N samples (N, dof, ``size``): alpha, alpha_dot, alpha_ddot (N, dof).

        Raises:
            AssemblyError: a sample whose loops do not close (named by its row, and its time
                where ``times`` is given).
        """
        alpha, alpha_dot, alpha_ddot = (
            np.atleast_2d(np.asarray(x, float)) for x in (alpha, alpha_dot, alpha_ddot)
        )
        out = np.empty((len(alpha), self.dof, self.size))
        out[:, :, self.inertial_count :] = self.columns.block(alpha_dot, alpha_ddot)
        for k in range(len(alpha)):
            try:
                out[k, :, : self.inertial_count] = self.tree_rows(alpha[k], alpha_dot[k], alpha_ddot[k])
            except AssemblyError as error:
                when = f" (t = {times[k]:.4f} s)" if times is not None else ""
                raise AssemblyError(f"sample {k}{when}: {error}") from None
        return out

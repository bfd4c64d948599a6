"""MuJoCo as the plant: the Delta's MJCF (:func:`~delta_pin.model.mjcf.delta_mjcf`) in
``mujoco.MjModel`` / ``MjData``, with maps between MuJoCo's and Pinocchio's coordinates.

MuJoCo is an optional extra (``pip install 'delta-pin[mujoco]'`` or ``pip install mujoco``); it is
imported only when a :class:`MujocoDelta` is made.
"""

from __future__ import annotations

import numpy as np

from delta_pin.errors import OptionalDependencyError
from delta_pin.model.delta_robot import analytic_delta
from delta_pin.model.mjcf import STIFF_CONNECT, delta_mjcf

__all__ = ["MujocoDelta"]


def _import_mujoco():
    try:
        import mujoco
    except ImportError as exc:
        raise OptionalDependencyError(
            "MujocoDelta needs MuJoCo, an optional extra: pip install 'delta-pin[mujoco]' "
            "(or: pip install mujoco)"
        ) from exc
    return mujoco


class MujocoDelta:
    """The Delta in MuJoCo (RK4 at ``timestep``), stepped by :meth:`step` with joint torques.

    Args:
        robot: the robot (:class:`~delta_pin.model.robot.Delta`).
        timestep: MuJoCo's step [s].
        solref, solimp: the loop closures' softness (stiff by default, :data:`STIFF_CONNECT`;
            ``None``: MuJoCo's defaults).

    Attributes:
        model, data: MuJoCo's ``MjModel`` and ``MjData``.
        qpos_index, dof_index: MuJoCo's position / velocity address of each Pinocchio joint, in
            Pinocchio's order.
        active_qpos, active_dof: the same for the three actuated shoulder joints.
    """

    def __init__(
        self,
        robot,
        timestep: float = 1e-3,
        solref: str | None = STIFF_CONNECT["solref"],
        solimp: str | None = STIFF_CONNECT["solimp"],
    ) -> None:
        mujoco = self._mujoco = _import_mujoco()
        robot = analytic_delta(robot)
        self.robot = robot
        self.model = mujoco.MjModel.from_xml_string(
            delta_mjcf(robot, timestep=timestep, solref=solref, solimp=solimp)
        )
        self.data = mujoco.MjData(self.model)
        closed = robot.pinocchio  # the closed-chain robot of the Delta's URDF
        pin_model = closed.model
        names = [pin_model.names[j] for j in range(1, pin_model.njoints)]
        ids = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, name) for name in names]
        self.qpos_index = np.array([self.model.jnt_qposadr[i] for i in ids])  # Pinocchio q order
        self.dof_index = np.array([self.model.jnt_dofadr[i] for i in ids])
        platform = [pin_model.idx_qs[pin_model.getJointId(n)] for n in robot.description.platform_joints]
        self.active_dof = self.dof_index[closed.actuated_indices]
        self.active_qpos = self.qpos_index[closed.actuated_q_indices]
        self.platform_qpos = self.qpos_index[platform]
        self.site_pairs = [
            (
                mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, f"{c.name}_parent"),
                mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, f"{c.name}_child"),
            )
            for c in closed.closures
        ]

    @property
    def timestep(self) -> float:
        """MuJoCo's step [s]."""
        return float(self.model.opt.timestep)

    def set_state(self, q: np.ndarray, v: np.ndarray) -> None:
        """Set the full state from Pinocchio's coordinates (q, v), e.g. an assembled start pose."""
        self._mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[self.qpos_index] = q
        self.data.qvel[self.dof_index] = v
        self._mujoco.mj_forward(self.model, self.data)

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """(alpha [rad], alpha_dot [rad/s]) of the actuated joints."""
        return self.data.qpos[self.active_qpos].copy(), self.data.qvel[self.active_dof].copy()

    def platform_position(self) -> np.ndarray:
        """The platform's position [m] (its three slides)."""
        return self.data.qpos[self.platform_qpos].copy()

    def step(self, tau: np.ndarray) -> None:
        """One MuJoCo step with the actuated joints' torques ``tau`` [N m] held over it."""
        self.data.qfrc_applied[self.active_dof] = tau
        self._mujoco.mj_step(self.model, self.data)

    def closure_gap(self) -> float:
        """Largest distance between the paired closure sites [m] (needs kinematics computed)."""
        xpos = self.data.site_xpos
        return max(float(np.linalg.norm(xpos[a] - xpos[b])) for a, b in self.site_pairs)

"""The controllers on serial robots: a robot from example-robot-data, a joint-space reference and
a Pinocchio forward-dynamics (ABA) plant with an uncertain payload.

Everything else -- :func:`~delta_pin.sim.runner.simulate`, the controllers, the nominal-model
adapter :class:`~delta_pin.control.nominal.PinocchioNominalModel` -- is shared with the Delta.
example-robot-data ships its URDFs as data (``pip install example-robot-data``, in the ``[test]``
and ``[serial]`` extras); the meshes are not needed.
"""

from __future__ import annotations

import math
import sysconfig
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin

from delta_pin.errors import DeltaPinError, InvalidParameterError
from delta_pin.model.trajectory import JointReference
from delta_pin.sim.plants import Plant

__all__ = [
    "EXAMPLE_ROBOTS",
    "JointSinusoid",
    "SerialPlant",
    "SerialRobot",
    "example_robot_urdf",
    "load_example_robot",
]

# name -> (URDF path inside example-robot-data's robots/ folder, end-effector frame)
EXAMPLE_ROBOTS = {
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "tool0"),
    "ur3": ("ur_description/urdf/ur3_robot.urdf", "tool0"),
    "ur10": ("ur_description/urdf/ur10_robot.urdf", "tool0"),
}


def example_robot_urdf(name: str) -> Path:
    """Path of an example-robot-data URDF (looked up in the installed cmeel prefix)."""
    if name not in EXAMPLE_ROBOTS:
        raise InvalidParameterError(f"robot {name!r} is not one of {', '.join(EXAMPLE_ROBOTS)}")
    relative = EXAMPLE_ROBOTS[name][0]
    for root in {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}:
        path = Path(root) / "cmeel.prefix" / "share" / "example-robot-data" / "robots" / relative
        if path.is_file():
            return path
    raise DeltaPinError(f"example-robot-data's {relative} is not installed: pip install example-robot-data")


class SerialRobot:
    """A serial (tree) robot with 1-DOF joints: its Pinocchio model and an end-effector frame."""

    def __init__(self, model: pin.Model, end_effector: str, urdf: str | None = None, name: str = "") -> None:
        if model.nq != model.nv:
            raise InvalidParameterError(f"SerialRobot needs 1-DOF joints (nq == nv), got nq={model.nq}")
        if not model.existFrame(end_effector):
            raise InvalidParameterError(f"the model has no frame {end_effector!r}")
        self.model = model
        self.data = model.createData()
        self.end_effector = model.getFrameId(end_effector)
        self.urdf = urdf
        self.name = name or model.name
        self.dof = model.nv

    def forward_kinematics(self, q: np.ndarray) -> np.ndarray:
        """End-effector position [m] (3,) for one configuration, or (N, 3) for (N, dof)."""
        q = np.asarray(q, dtype=float)
        if q.ndim == 2:
            return np.array([self.forward_kinematics(row) for row in q])
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[self.end_effector].translation.copy()

    def metadata(self) -> dict:
        return {"name": self.name, "dof": self.dof, "end_effector": self.model.frames[self.end_effector].name}


def load_example_robot(name: str = "ur5") -> SerialRobot:
    """A robot from example-robot-data (kinematics and inertias; gravity 9.81 m/s^2)."""
    path = example_robot_urdf(name)
    text = path.read_text()
    return SerialRobot(pin.buildModelFromXML(text), EXAMPLE_ROBOTS[name][1], urdf=text, name=name)


class JointSinusoid:
    """q^d(t) = center + amplitude sin(2 pi frequency t + phase), per joint (rad, Hz)."""

    name = "joint sinusoid"
    duration = None
    joint_space = True  # its joints by joint_values (delta_pin.sim.reference.tabulate_reference)

    def __init__(self, center, amplitude, frequency, phase=0.0) -> None:
        self.center = np.asarray(center, dtype=float)
        shape = self.center.shape
        self.amplitude = np.broadcast_to(np.asarray(amplitude, dtype=float), shape).copy()
        self.frequency = np.broadcast_to(np.asarray(frequency, dtype=float), shape).copy()
        self.phase = np.broadcast_to(np.asarray(phase, dtype=float), shape).copy()

    def joint_values(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Analytic (q^d [rad], q_dot^d [rad/s], q_ddot^d [rad/s^2]) (N, dof) at times ``t`` (N,) [s]
        (a joint-space trajectory: :func:`~delta_pin.sim.reference.tabulate_reference`)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))[:, None]
        omega = 2.0 * np.pi * self.frequency
        angle = omega * t + self.phase
        return (
            self.center + self.amplitude * np.sin(angle),
            self.amplitude * omega * np.cos(angle),
            -self.amplitude * omega**2 * np.sin(angle),
        )

    def joint_reference(self, robot: SerialRobot, t: np.ndarray) -> JointReference:
        """:meth:`joint_values` at times ``t`` (N,) [s]; xyz = end-effector FK."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        q, q_dot, q_ddot = self.joint_values(t)
        zeros = np.zeros((len(t), 3))
        return JointReference(
            t=t, xyz=robot.forward_kinematics(q), xyz_dot=zeros, xyz_ddot=zeros, alpha=q, alpha_dot=q_dot,
            alpha_ddot=q_ddot,
        )  # fmt: skip

    def metadata(self) -> dict:
        return {
            "name": self.name,
            "center": self.center.tolist(),
            "amplitude": self.amplitude.tolist(),
            "frequency": self.frequency.tolist(),
            "phase": self.phase.tolist(),
        }


class SerialPlant(Plant):
    """Forward dynamics (ABA) of a serial robot with a payload m(t) [kg] held at the end effector.

    Args:
        robot: the robot.
        payload_mass: m(t) [kg] as a function of time (a point mass at the end-effector frame).
    """

    name = "pinocchio_serial"

    def __init__(self, robot: SerialRobot, payload_mass: Callable[[float], float] | None = None) -> None:
        super().__init__(robot)
        self.friction = None
        self.uncertainty = None
        self.model = pin.Model(robot.model)
        self.data = self.model.createData()
        frame = self.model.frames[robot.end_effector]
        self._joint = frame.parentJoint
        self._base_inertia = pin.Inertia(self.model.inertias[self._joint])
        self._payload_placement = frame.placement
        self.payload_mass = payload_mass
        # where the core's plant carries the payload: a point mass at the end effector
        self._payload_joint, self._payload_point = int(self._joint), np.array(frame.placement.translation)

    def _set_payload(self, t: float) -> None:
        if self.payload_mass is None:
            return
        mass = float(self.payload_mass(t))
        payload = pin.Inertia(mass, self._payload_placement.translation, np.zeros((3, 3)))
        self.model.inertias[self._joint] = self._base_inertia + payload

    def initial_state(self, alpha, alpha_dot):
        return np.concatenate([alpha, alpha_dot]).astype(float)

    def joint_state(self, x):
        return x[: self.dof], x[self.dof :]

    def configuration_state(self, x):
        return x[: self.dof].copy(), x[self.dof :].copy()

    def platform_position(self, x):
        return self.robot.forward_kinematics(x[: self.dof])

    def build(self, step: float = 0.0, count: int = 0):
        """The compiled core's plant of this robot (a tree without closures: Pinocchio's forward
        dynamics, every joint actuated), the payload m(t) a point mass at the end effector
        tabulated at t = i step, i < count [s] (:func:`~delta_pin.sim.compiled_plant.set_core_truth`)."""
        return self._built_in_core(_build_core_serial_plant, step, count)

    def metadata(self):
        return {"plant": self.name, "payload": getattr(self.payload_mass, "__name__", None)}


def _build_core_serial_plant(plant: SerialPlant, step: float, count: int):
    """The core's ``ClosedChainPlant`` of a serial robot: its model, no closure, every joint
    actuated (nq == nv), the end effector its frame; the payload as :class:`SerialPlant` carries it.

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """
    from delta_pin.compiled.core import core
    from delta_pin.model.core_model import model_spec
    from delta_pin.sim.compiled_plant import set_core_truth

    module, model = core(), plant.robot.model
    joints = np.arange(model.nv, dtype=np.int32)
    chain = module.ChainDescription(
        model_spec(model), [], [], joints, joints, np.zeros(0, np.int32), 0, int(plant.robot.end_effector)
    )
    # no closure: the Baumgarte gains, the proximal settings and the projection act on nothing
    compiled = module.ClosedChainPlant(chain, [], 0.0, 0.0, 1e-12, 0.0, 1, math.inf)
    if count > 0:
        set_core_truth(compiled, plant, step, count)
    return compiled

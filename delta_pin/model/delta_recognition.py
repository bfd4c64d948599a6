"""Recognise a Delta in a closed-chain robot loaded from any file shape, so that it gets the
paper's analytic model (eqs. 5-12) besides the projected one.

The test is the dynamics, not the names: the robot's dimensions and masses are measured from
its tree at the reference configuration (R, l_a from the actuated joints and the next joint of
each chain, l_b and r from the closure anchors, the masses from the bodies), the packaged xacro is
compiled with them, and the robot is a Delta if the projected M, C alpha_dot and G of the two
agree to 1e-9 (relative) at a few states. A different inertia model, axis convention or any
other difference fails the test and leaves ``robot.delta`` as ``None``
(docs/architecture.md section 10).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from delta_pin.errors import DeltaPinError

__all__ = ["delta_platform_joint", "recognise_delta", "same_reduced_dynamics"]

_STATES = (  # (alpha [rad], alpha_dot [rad/s]) inside the Table 1 workspace
    (np.array([0.3, 0.45, 0.6]), np.array([0.7, -1.1, 0.4])),
    (np.array([0.1, -0.2, 0.35]), np.array([-0.5, 0.9, 1.3])),
    (np.array([0.55, 0.25, 0.05]), np.array([1.2, 0.3, -0.8])),
)
RELATIVE_TOLERANCE = 1e-9


def same_reduced_dynamics(robot, delta, tolerance: float = RELATIVE_TOLERANCE) -> float | None:
    """The largest relative difference between the robot's projected M, C alpha_dot, G and the
    Delta's analytic ones over a few states, or ``None`` where it exceeds ``tolerance`` or a
    state does not assemble."""
    largest = 0.0
    for alpha, alpha_dot in _STATES:
        try:
            M, _C, G, coriolis = robot.reduced_terms(alpha, alpha_dot)
            reference = delta.analytic_dynamics(alpha, alpha_dot)
        except DeltaPinError:
            return None
        for mine, theirs in ((M, reference.M), (G, reference.G), (coriolis, reference.coriolis)):
            scale = max(np.abs(theirs).max(), 1e-12)
            largest = max(largest, float(np.abs(mine - theirs).max() / scale))
    return largest if largest <= tolerance else None


def _subtree_joints(model: pin.Model, joint: int) -> list[int]:
    return [j for j in range(1, model.njoints) if joint in model.supports[j]]


def _measure(robot) -> dict | None:
    """R, r, l_a, l_b, m_a, m_b, m_o of a 3-actuator, 3-point-closure mechanism, or ``None``."""
    model = robot.model
    data = model.createData()
    q = robot.reference_configuration
    pin.framesForwardKinematics(model, data, q)
    actuated = [model.getJointId(name) for name in robot.actuated_joints]
    R, l_a, l_b, r, m_a, m_b, platform_joints = [], [], [], [], [], [], set()
    for joint in actuated:
        A = data.oMi[joint].translation
        children = [j for j in range(1, model.njoints) if model.parents[j] == joint]
        if len(children) != 1 or abs(A[2]) > 1e-9:
            return None
        elbow = children[0]
        chain = _subtree_joints(model, joint)
        anchors = []
        for f1, f2, _size in robot.closure_frames:
            for mine, other in ((f1, f2), (f2, f1)):
                if model.frames[mine].parentJoint in chain and model.frames[other].parentJoint not in chain:
                    anchors.append((mine, other))
        if len(anchors) != 1:
            return None
        mine, other = anchors[0]
        platform_joints.add(model.frames[other].parentJoint)
        R.append(np.hypot(A[0], A[1]))
        l_a.append(np.linalg.norm(data.oMi[elbow].translation - A))
        l_b.append(np.linalg.norm(data.oMf[mine].translation - data.oMi[elbow].translation))
        platform = data.oMi[model.frames[other].parentJoint]
        r.append(np.linalg.norm(data.oMf[other].translation - platform.translation))
        m_a.append(model.inertias[joint].mass)
        m_b.append(sum(model.inertias[j].mass for j in chain if j != joint))
    if len(platform_joints) != 1:
        return None
    total = sum(inertia.mass for inertia in model.inertias)
    values = {
        name: float(np.mean(v))
        for name, v in (("R", R), ("r", r), ("l_a", l_a), ("l_b", l_b), ("m_a", m_a), ("m_b", m_b))
    }
    values["platform_joint"] = platform_joints.pop()
    for v in (R, r, l_a, l_b, m_a, m_b):
        if np.ptp(v) > 1e-9 * max(abs(np.mean(v)), 1.0):
            return None  # the three chains differ: not the symmetric Delta of the paper
    values["m_o"] = float(total - 3.0 * values["m_a"] - 3.0 * values["m_b"])
    if min(v for k, v in values.items() if k != "platform_joint") <= 0.0:
        return None
    return values


def recognise_delta(robot):
    """The :class:`~delta_pin.model.robot.Delta` with the robot's dynamics, or ``None``.

    A URDF that follows the Delta convention (docs/architecture.md section 3) is read as such;
    any other 3-actuator robot with three point closures is measured and compared with the
    packaged xacro compiled at its dimensions (module docstring).
    """
    from delta_pin.model.robot import load_analytic_delta

    if robot.dof != 3 or len(robot.closures) != 3 or any(c.kind != "3d" for c in robot.closures):
        return None
    g = -float(robot.model.gravity.linear[2])
    if not g > 0.0 or np.abs(robot.model.gravity.linear[:2]).max() > 0.0:
        return None
    if robot.urdf and "<constraint" in robot.urdf:  # a URDF that follows the convention: read as such
        from delta_pin.model.description import read_description
        from delta_pin.model.robot import Delta

        try:
            delta = Delta(read_description(robot.urdf, g=g, base_dir=robot.base_dir))
        except DeltaPinError:
            delta = None
        if delta is not None and same_reduced_dynamics(robot, delta) is not None:
            return delta
    measured = _measure(robot)
    if measured is None:
        return None
    measured.pop("platform_joint")
    for forearm in ("lumped", "rod"):
        try:
            delta = load_analytic_delta(
                g=g, forearm_inertia=forearm, **{k: repr(v) for k, v in measured.items()}
            )
        except DeltaPinError:
            return None
        if same_reduced_dynamics(robot, delta) is not None:
            return delta
    return None


def delta_platform_joint(robot) -> str | None:
    """Name of the joint that carries a recognised Delta's platform (its frame is the platform
    position of the paper's kinematics), or ``None``."""
    if robot.delta is None:
        return None
    measured = _measure(robot)
    return None if measured is None else robot.model.names[measured["platform_joint"]]

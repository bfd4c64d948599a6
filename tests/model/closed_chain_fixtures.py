"""A planar five-bar linkage in the vertical xz plane, written as URDF text with a
``<constraint type="point">`` (the closed-chain tests' own robot, independent of the shipped files).

The joint frames are rotated so that the zero configuration is assembled with the tip at
``tip``: chain 1 from A1 = (-base/2, 0, 0), chain 2 from A2 = (base/2, 0, 0), elbows outward.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pinocchio as pin

PROXIMAL, DISTAL, BASE = 0.25, 0.3, 0.2  # [m]
MASSES = (0.3, 0.2)  # proximal, distal [kg]


def _pitch(v: np.ndarray) -> float:
    """Rotation about y that turns the x axis along v (in the xz plane)."""
    return math.atan2(-v[2], v[0])


def five_bar_urdf(tip=(0.0, 0.0, -0.4), closure_type: str = "point", transmissions: bool = True) -> str:
    tip = np.asarray(tip, dtype=float)
    chains = []
    for i, (x, side) in enumerate(((-BASE / 2, -1.0), (BASE / 2, 1.0)), 1):
        A = np.array([x, 0.0, 0.0])
        d = tip - A
        n = np.linalg.norm(d)
        u = d / n
        a = (PROXIMAL**2 - DISTAL**2 + n**2) / (2 * n)
        h = math.sqrt(PROXIMAL**2 - a**2)
        elbow = A + a * u + side * h * np.array([-u[2], 0.0, u[0]])
        first = _pitch(elbow - A)
        second = _pitch(tip - elbow) - first
        chains.append((i, x, first, second))
    links, joints = ['<link name="base"/>'], []
    for i, x, first, second in chains:
        for part, length, mass in (("proximal", PROXIMAL, MASSES[0]), ("distal", DISTAL, MASSES[1])):
            across = mass * length**2 / 12.0
            links.append(
                f'<link name="{part}_{i}"><inertial><origin xyz="{length / 2!r} 0 0"/>'
                f'<mass value="{mass!r}"/><inertia ixx="1e-6" iyy="{across!r}" izz="{across!r}" '
                'ixy="0" ixz="0" iyz="0"/></inertial></link>'
            )
        joints.append(
            f'<joint name="motor_{i}" type="revolute"><parent link="base"/><child link="proximal_{i}"/>'
            f'<origin xyz="{x!r} 0 0" rpy="0 {first!r} 0"/><axis xyz="0 1 0"/>'
            '<limit effort="50" lower="-6.3" upper="6.3" velocity="50"/></joint>'
        )
        joints.append(
            f'<joint name="elbow_{i}" type="revolute"><parent link="proximal_{i}"/><child link="distal_{i}"/>'
            f'<origin xyz="{PROXIMAL!r} 0 0" rpy="0 {second!r} 0"/><axis xyz="0 1 0"/>'
            '<limit effort="50" lower="-6.3" upper="6.3" velocity="50"/></joint>'
        )
    links.append('<link name="tip"/>')
    joints.append(
        f'<joint name="tip_joint" type="fixed"><parent link="distal_1"/><child link="tip"/>'
        f'<origin xyz="{DISTAL!r} 0 0"/></joint>'
    )
    constraint = (
        f'<constraint name="loop" type="{closure_type}"><parent link="distal_1"/>'
        f'<parent_origin xyz="{DISTAL!r} 0 0"/><child link="distal_2"/><child_origin xyz="{DISTAL!r} 0 0"/>'
        "</constraint>"
    )
    transmission = (
        "".join(f'<transmission name="t{i}"><joint name="motor_{i}"/></transmission>' for i in (1, 2))
        if transmissions
        else ""
    )
    return (
        '<?xml version="1.0"?>\n<robot name="five_bar">\n'
        + "\n".join(links + joints)
        + "\n"
        + constraint
        + "\n"
        + transmission
        + "\n</robot>\n"
    )


_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def assert_same_numbers(shipped: str, generated: str, name: str) -> None:
    """Two texts with the same words and numbers equal to 1e-12 relative (plus 1e-15 absolute):
    computed inertias and trigonometry differ in their last digits between numpy/BLAS/libm
    builds, so a generated file is compared after parsing, never byte for byte."""
    assert _NUMBER.sub("#", shipped) == _NUMBER.sub("#", generated), name
    mine = np.array([float(v) for v in _NUMBER.findall(shipped)])
    theirs = np.array([float(v) for v in _NUMBER.findall(generated)])
    np.testing.assert_allclose(mine, theirs, rtol=1e-12, atol=1e-15, err_msg=name)


def configuration_rate(model: pin.Model, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """dq/dt: 0.5 quat * (omega, 0) for ball and free joints (x, y, z, w), R v for a free joint's
    position, v for the rest (the tests' own)."""

    def quaternion_rate(quat, omega):
        u, w = quat[:3], quat[3]
        return 0.5 * np.r_[w * omega + np.cross(u, omega), -u @ omega]

    rate = np.empty(model.nq)
    for j in range(1, model.njoints):
        iq, iv, kind = model.idx_qs[j], model.idx_vs[j], model.joints[j].shortname()
        if kind == "JointModelFreeFlyer":
            rate[iq : iq + 3] = pin.Quaternion(q[iq + 3 : iq + 7]).matrix() @ v[iv : iv + 3]
            rate[iq + 3 : iq + 7] = quaternion_rate(q[iq + 3 : iq + 7], v[iv + 3 : iv + 6])
        elif kind == "JointModelSpherical":
            rate[iq : iq + 4] = quaternion_rate(q[iq : iq + 4], v[iv : iv + 3])
        else:
            rate[iq] = v[iv]
    return rate


def pinocchio_accelerations(robot, settings=None):
    """q_ddot = f(q, v, tau_full) by Pinocchio alone, the tests' reference for the plant:
    ``pin.constraintDynamics`` on the robot's tree and closure models, no Baumgarte correction.
    ``settings`` default to tight proximal iterations (accuracy 1e-14, mu 1e-10, 1000 iterations),
    which also converge where redundant closure equations make the KKT matrix singular; give
    ``pin.ProximalSettings(1e-14, 0.0, 1)`` for the exact solve of independent equations."""
    model, data = robot.model, robot.model.createData()
    datas = pin.StdVec_RigidConstraintData()
    for constraint in robot.constraint_models:
        datas.append(constraint.createData())
    pin.initConstraintDynamics(model, data, robot.constraint_models, datas)
    settings = pin.ProximalSettings(1e-14, 1e-10, 1000) if settings is None else settings

    def accelerations(q, v, tau_full):
        return pin.constraintDynamics(model, data, q, v, tau_full, robot.constraint_models, datas, settings)

    return accelerations


# a planar five-bar: one motor (with a rotor inertia), one sprung and damped base joint that no
# motor drives (so passive), a damped elbow; the loop closed at the tips by a connect
SPRUNG_FIVE_BAR = """<mujoco model="sprung_five_bar">
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="left" pos="-0.1 0 0">
      <joint name="motor_joint" type="hinge" axis="0 1 0" armature="0.002"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.01" mass="0.3"/>
      <body name="left_distal" pos="0 0 -0.2">
        <joint name="left_elbow" type="hinge" axis="0 1 0" damping="0.01"/>
        <geom type="capsule" fromto="0 0 0 0.1 0 -0.2" size="0.01" mass="0.2"/>
        <site name="tip" pos="0.1 0 -0.2"/>
      </body>
    </body>
    <body name="right" pos="0.1 0 0">
      <joint name="spring_joint" type="hinge" axis="0 1 0" stiffness="3" springref="0.2" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.01" mass="0.3"/>
      <body name="right_distal" pos="0 0 -0.2">
        <joint name="right_elbow" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 -0.1 0 -0.2" size="0.01" mass="0.2"/>
        <site name="right_tip" pos="-0.1 0 -0.2"/>
      </body>
    </body>
  </worldbody>
  <equality>
    <connect site1="tip" site2="right_tip"/>
  </equality>
  <actuator>
    <motor joint="motor_joint"/>
  </actuator>
</mujoco>
"""

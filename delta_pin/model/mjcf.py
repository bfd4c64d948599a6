"""The Delta as MuJoCo MJCF, built from its Pinocchio model: MuJoCo as a second plant.

Every joint placement, axis, mass and inertia and the closure points are read from the robot's
Pinocchio model (the :class:`~delta_pin.model.closed_chain.ClosedChainRobot` of its URDF), nothing is
written down twice. Two adaptations MuJoCo needs:

* massless links (the elbow cross, the platform slides) are merged into the next body as
  consecutive joints, since MuJoCo rejects moving bodies without mass;
* rod inertias that are singular in the URDF (no inertia about the rod's axis) get
  :data:`INERTIA_FLOOR` on the diagonal.

The three loops are closed by ``connect`` equality constraints between sites at the forearm tips
and the platform attachment points (the URDF's ``<constraint>`` frames); the platform moves on
three slides, as in the URDF. :data:`STIFF_CONNECT` makes the connects stiff enough that MuJoCo and
Pinocchio agree to ~1e-7 rad over 15 s (benchmarks/bench_mujoco.py); MuJoCo's default softness
leaves closure gaps near 0.5 mm.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = ["INERTIA_FLOOR", "STIFF_CONNECT", "delta_mjcf"]

INERTIA_FLOOR = 1e-9  # [kg m^2] added to every inertia (MuJoCo needs positive eigenvalues)
# connect softness: time constant 2 ms (the least MuJoCo advises at a 1 ms step), impedance near 1
STIFF_CONNECT = {"solref": "0.002 1", "solimp": "0.99 0.999 0.001"}

_JOINT_TYPES = {
    "RX": ("hinge", "1 0 0"),
    "RY": ("hinge", "0 1 0"),
    "RZ": ("hinge", "0 0 1"),
    "PX": ("slide", "1 0 0"),
    "PY": ("slide", "0 1 0"),
    "PZ": ("slide", "0 0 1"),
}


def _numbers(values) -> str:
    return " ".join(f"{float(v):.17g}" for v in np.ravel(values))


def delta_mjcf(
    robot,
    *,
    timestep: float = 1e-3,
    solref: str | None = None,
    solimp: str | None = None,
    inertia_floor: float = INERTIA_FLOOR,
) -> str:
    """MJCF text of ``robot`` (a :class:`~delta_pin.model.robot.Delta`).

    Args:
        robot: the robot.
        timestep: MuJoCo's step [s] (its RK4 integrator).
        solref, solimp: the connects' softness (``None``: MuJoCo's defaults; see
            :data:`STIFF_CONNECT`).
        inertia_floor: [kg m^2] added to every inertia's diagonal (MuJoCo accepted down to 1e-14;
            1e-12 keeps the file within 1e-12 of the Pinocchio model, as a reference file needs).

    Returns:
        The MJCF document; joints keep the URDF's names, the closure sites are
        ``<closure>_parent`` and ``<closure>_child``.
    """
    from delta_pin.model.delta_robot import analytic_delta

    source = analytic_delta(robot).pinocchio  # the closed-chain robot of the Delta's URDF
    model = source.model
    children: dict[int, list[int]] = {j: [] for j in range(model.njoints)}
    for j in range(1, model.njoints):
        children[model.parents[j]].append(j)
    sites: dict[int, list[tuple[str, np.ndarray]]] = {}
    closure_names = [c.name for c in source.closures]
    for name, (f1, f2, _) in zip(closure_names, source.closure_frames):
        for tag, f in (("parent", f1), ("child", f2)):
            frame = model.frames[f]
            sites.setdefault(frame.parentJoint, []).append((f"{name}_{tag}", frame.placement.translation))

    def body(j: int, indent: str) -> str:
        placement = model.jointPlacements[j]
        quat = pin.Quaternion(placement.rotation)
        text = (
            f'{indent}<body name="{model.names[j]}" pos="{_numbers(placement.translation)}" '
            f'quat="{_numbers([quat.w, quat.x, quat.y, quat.z])}">\n'
        )
        chain = [j]  # a massless link joined to its only child at the same frame: one body, two joints
        while (
            model.inertias[chain[-1]].mass == 0.0
            and chain[-1] not in sites
            and len(children[chain[-1]]) == 1
            and model.jointPlacements[children[chain[-1]][0]].isIdentity()
        ):
            chain.append(children[chain[-1]][0])
        for joint in chain:
            kind, axis = _JOINT_TYPES[model.joints[joint].shortname().removeprefix("JointModel")]
            text += f'{indent}  <joint name="{model.names[joint]}" type="{kind}" axis="{axis}"/>\n'
        last = chain[-1]
        inertia = model.inertias[last]
        if inertia.mass == 0.0:
            raise ValueError(f"link of joint {model.names[last]!r} is massless and cannot be merged")
        c = inertia.inertia + inertia_floor * np.eye(3)
        text += (
            f'{indent}  <inertial pos="{_numbers(inertia.lever)}" mass="{inertia.mass!r}" '
            f'fullinertia="{_numbers([c[0, 0], c[1, 1], c[2, 2], c[0, 1], c[0, 2], c[1, 2]])}"/>\n'
        )
        for name, position in sites.get(last, []):
            text += f'{indent}  <site name="{name}" pos="{_numbers(position)}"/>\n'
        for child in children[last]:
            text += body(child, indent + "  ")
        return text + f"{indent}</body>\n"

    soft = (f' solref="{solref}"' if solref else "") + (f' solimp="{solimp}"' if solimp else "")
    connects = "".join(
        f'    <connect name="{name}" site1="{name}_parent" site2="{name}_child"{soft}/>\n'
        for name in closure_names
    )
    bodies = "".join(body(j, "    ") for j in children[0])
    return (
        f'<mujoco model="{model.name or "delta"}">\n'
        f'  <option timestep="{timestep!r}" integrator="RK4" gravity="{_numbers(model.gravity.linear)}"/>\n'
        f"  <worldbody>\n{bodies}  </worldbody>\n"
        f"  <equality>\n{connects}  </equality>\n"
        "</mujoco>\n"
    )

"""A closed-chain robot from MJCF (MuJoCo's XML), compiled by MuJoCo itself.

MuJoCo compiles the file first (``mujoco.MjModel.from_xml_path``), so that defaults, classes,
``<include>``, inertias inferred from geoms, ``<compiler angle=... eulerseq=...>`` and the
reference-pose semantics of equality anchors mean exactly what they mean in MuJoCo. The compiled
``mjModel`` is then turned into a ``pin.Model`` (docs/architecture.md section 13):

* every MuJoCo body is placed by ``body_pos``/``body_quat`` (MuJoCo quaternions are w, x, y, z)
  in its parent body's frame; a body without joints is rigidly merged into its parent's joint
  (a BODY frame keeps its name);
* joints: ``hinge`` -> revolute (``RX``/``RY``/``RZ`` for a positive unit axis, else
  ``RevoluteUnaligned``), ``slide`` -> prismatic, ``ball`` -> spherical, ``free`` -> free-flyer
  (top-level bodies only). A joint rotates about its own anchor ``jnt_pos``: the Pinocchio joint
  frame sits at that anchor. Several joints in one body become consecutive Pinocchio joints
  (massless intermediate bodies), in MuJoCo's order;
* coordinates are MuJoCo's: q = qpos for hinge and slide joints (so alpha reads as MuJoCo's
  joint positions). The body pose in the file is the pose at ``qpos = qpos0`` (the joint's
  ``ref``), so a joint with a non-zero ``ref`` gets the placement rotated by -ref about its axis
  (moved by -ref along it for a slide), as Pinocchio's own MJCF parser does; ball and free
  quaternions are reordered to Pinocchio's (x, y, z, w);
* inertia: ``body_mass`` at ``body_ipos`` with principal moments ``body_inertia`` along the axes
  ``body_iquat`` [kg, m, kg m^2];
* sites become OP_FRAME frames (names kept), usable as end effectors;
* equalities: ``connect`` -> a ``"3d"`` closure, ``weld`` -> a ``"6d"`` closure, each with the
  anchors MuJoCo compiled (body semantics: ``eq_data``, the second anchor computed by MuJoCo at
  ``qpos0``; site semantics: the sites). A weld frame on body 1 is (``relpose`` position,
  ``relpose`` quaternion), the one on body 2 is (``anchor``, identity): MuJoCo's weld holds
  exactly these two frames together (its error is ``neg(q2) q1 relquat`` and
  ``x1 + R1 relpos - x2 - R2 anchor``). ``torquescale`` only weighs MuJoCo's soft constraint and
  does not change which poses satisfy it. An equality on the world body (``body2`` left out, or
  ``body1="world"``), or on a body without joints fixed to the world, holds the other body to the
  ground: that frame is on joint 0, placed in the world. A ``joint`` equality (joint1 - its qpos0
  = polycoef's polynomial of joint2 - its qpos0) is a
  :class:`~delta_pin.model.closed_chain.JointCoupling`, one closure equation of its own. Any other
  equality (``tendon``, ``flex``), a disabled one, or one between two parts of one rigid body is an
  error naming it and its line;
* actuators: ``motor`` (and ``general`` without dynamics or bias, i.e. a torque/force source) on a
  hinge or slide joint give the actuated joints, in actuator order (``gear`` only scales the
  control and is not part of the model). An actuator on a fixed tendon whose joints are one joint
  and joints linearly coupled to it (a gripper's two drivers) actuates that joint: its force F
  on the tendon and F m on that joint (m = gear x sum of coef x d q_joint / d q_that joint) move the
  mechanism alike, the difference being a force the coupling takes. A position or velocity servo
  (an affine bias: ``position``, ``velocity``, a ``general`` with ``biastype="affine"``) is read as a
  force source, and that is said (``robot.summary()``'s notes and a warning): the servo law, its
  gains and its force range are not applied, the controller's torques replace them. Activation
  dynamics, a non-fixed gain, a spatial tendon, a tendon over joints that move independently, or
  another transmission are errors naming the actuator and its line;
* gravity: ``opt.gravity`` (``g=`` overrides it with g along -z);
* reference configuration: the keyframe named ``home`` if there is one, else ``qpos0``;
* visuals: geoms of the primitive types (box, sphere, capsule, cylinder, ellipsoid) become a
  ``pin.GeometryModel`` (coal shapes) for drawing; mesh, plane, hfield and sdf geoms are not drawn.

Joint dynamics: armature (rotor inertia) goes into ``model.armature`` (hinge, slide and ball
joints); stiffness, ``springref`` and damping of hinge and slide joints, and the damping of ball
joints, become the robot's ``joint_springs`` (the plant applies -k (q - q_ref) - d v), and a
sprung joint that no motor drives and that the loops leave free is passive (an underactuated
mechanism, e.g. a gripper's spring links); one the loops determine is not. A spring on a ball
joint or anything on a free joint is refused; friction loss is
listed in a warning; joint limits and contacts are not modelled.

Units: SI (m, kg, s, rad), as MuJoCo's.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin

from delta_pin.errors import OptionalDependencyError, URDFConventionError
from delta_pin.model.closed_chain import (
    ClosedChainRobot,
    JointCoupling,
    assembled_pose,
    free_motions,
    independent_joints,
)
from delta_pin.model.closures import Closure
from delta_pin.model.inertials import check_compiled_inertials, check_mjcf_inertials

__all__ = ["mjcf_to_pinocchio", "read_mjcf"]

_UNIT_AXES = {
    (1.0, 0.0, 0.0): ("RX", "PX"),
    (0.0, 1.0, 0.0): ("RY", "PY"),
    (0.0, 0.0, 1.0): ("RZ", "PZ"),
}
_ACTUATOR_TAGS = ("motor", "general", "position", "velocity", "intvelocity", "damper", "cylinder",
                  "muscle", "adhesion", "plugin")  # fmt: skip


def _import_mujoco():
    try:
        import mujoco
    except ImportError as exc:  # pragma: no cover - mujoco is installed with [test]
        raise OptionalDependencyError(
            f"reading MJCF needs MuJoCo ({exc}): pip install mujoco (or pip install 'delta-pin[mjcf]')"
        ) from None
    return mujoco


def _quat_wxyz(q) -> pin.Quaternion:
    w, x, y, z = (float(v) for v in q)
    quat = pin.Quaternion(w, x, y, z)
    quat.normalize()
    return quat


def _se3(pos, quat_wxyz) -> pin.SE3:
    return pin.SE3(_quat_wxyz(quat_wxyz).matrix(), np.array(pos, dtype=float))


def _translation(pos) -> pin.SE3:
    return pin.SE3(np.eye(3), np.array(pos, dtype=float))


def _name(mujoco, m, kind, index: int, prefix: str) -> str:
    name = mujoco.mj_id2name(m, kind, index)
    return name if name else f"{prefix}_{index}"


def _joint_model(kind: str, axis: np.ndarray):
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    key = tuple(float(v) for v in np.round(axis, 15))
    if key in _UNIT_AXES:
        revolute, prismatic = _UNIT_AXES[key]
        return getattr(pin, f"JointModel{revolute if kind == 'hinge' else prismatic}")()
    if kind == "hinge":
        return pin.JointModelRevoluteUnaligned(*axis)
    return pin.JointModelPrismaticUnaligned(*axis)


def mjcf_to_pinocchio(m, *, source: str = "MJCF") -> tuple[pin.Model, dict[int, tuple[int, pin.SE3]], list]:
    """A ``pin.Model`` of a compiled ``mujoco.MjModel`` (module docstring).

    Returns:
        (model, bodies, q_maps): ``bodies[b]`` = (Pinocchio joint id, placement of MuJoCo body
        b's frame in that joint's frame); ``q_maps`` lists (kind, qpos address, q address) per
        MuJoCo joint, for :func:`_to_pinocchio_q`.

    Raises:
        URDFConventionError: a free joint below the top level, or a zero joint axis.
    """
    mujoco = _import_mujoco()
    model = pin.Model()
    model.name = "mjcf"
    bodies: dict[int, tuple[int, pin.SE3]] = {0: (0, pin.SE3.Identity())}
    q_maps = []
    for b in range(1, m.nbody):
        parent_joint, parent_placement = bodies[int(m.body_parentid[b])]
        body_name = _name(mujoco, m, mujoco.mjtObj.mjOBJ_BODY, b, "body")
        placement = parent_placement * _se3(m.body_pos[b], m.body_quat[b])  # body frame in parent joint frame
        joint = parent_joint
        for j in range(int(m.body_jntadr[b]), int(m.body_jntadr[b]) + int(m.body_jntnum[b])):
            kind = {0: "free", 1: "ball", 2: "slide", 3: "hinge"}[int(m.jnt_type[j])]
            joint_name = _name(mujoco, m, mujoco.mjtObj.mjOBJ_JOINT, j, "joint")
            anchor = np.array(m.jnt_pos[j], dtype=float)
            if kind == "free":
                if int(m.body_parentid[b]) != 0 or joint != 0:
                    raise URDFConventionError(
                        f"{source}: free joint {joint_name!r} of body {body_name!r} is not on a top-level "
                        "body"
                    )
                joint_model, joint_placement = pin.JointModelFreeFlyer(), pin.SE3.Identity()
                anchor = np.zeros(3)
            elif kind == "ball":
                joint_model, joint_placement = pin.JointModelSpherical(), placement * _translation(anchor)
            else:
                if np.linalg.norm(m.jnt_axis[j]) == 0.0:
                    raise URDFConventionError(f"{source}: joint {joint_name!r} has a zero axis")
                joint_model = _joint_model(kind, m.jnt_axis[j])
                axis = np.array(m.jnt_axis[j], dtype=float) / np.linalg.norm(m.jnt_axis[j])
                ref = float(m.qpos0[m.jnt_qposadr[j]])  # the file's pose is at qpos = ref
                offset = (
                    pin.SE3(pin.exp3(-ref * axis), np.zeros(3))
                    if kind == "hinge"
                    else _translation(-ref * axis)
                )
                joint_placement = placement * _translation(anchor) * offset
            if model.existJointName(joint_name):
                raise URDFConventionError(f"{source}: two joints are named {joint_name!r}")
            q_index = model.nq
            joint = model.addJoint(joint, joint_model, joint_placement, joint_name)
            q_maps.append((kind, int(m.jnt_qposadr[j]), q_index))
            placement = _translation(-anchor)  # the body frame in this joint's frame
        axes = _quat_wxyz(m.body_iquat[b]).matrix()  # principal axes in the body frame
        rotational = axes @ np.diag(m.body_inertia[b]) @ axes.T
        inertia = pin.Inertia(float(m.body_mass[b]), np.array(m.body_ipos[b], dtype=float), rotational)
        model.appendBodyToJoint(joint, inertia, placement)
        model.addFrame(pin.Frame(body_name, joint, 0, placement, pin.FrameType.BODY), False)
        bodies[b] = (joint, placement)
    for s in range(m.nsite):
        joint, placement = bodies[int(m.site_bodyid[s])]
        frame = placement * _se3(m.site_pos[s], m.site_quat[s])
        name = _name(mujoco, m, mujoco.mjtObj.mjOBJ_SITE, s, "site")
        model.addFrame(pin.Frame(name, joint, 0, frame, pin.FrameType.OP_FRAME), False)
    model.gravity.linear = np.array(m.opt.gravity, dtype=float)
    return model, bodies, q_maps


def _to_pinocchio_q(model: pin.Model, q_maps, qpos: np.ndarray) -> np.ndarray:
    """Pinocchio's q (nq,) for MuJoCo's qpos (module docstring): quaternions reordered."""
    q = pin.neutral(model)
    for kind, a, i in q_maps:
        if kind in ("hinge", "slide"):
            q[i] = qpos[a]
        elif kind == "ball":
            w, x, y, z = qpos[a : a + 4]
            q[i : i + 4] = np.array([x, y, z, w]) / np.linalg.norm([w, x, y, z])
        else:
            w, x, y, z = qpos[a + 3 : a + 7]
            q[i : i + 3] = qpos[a : a + 3]
            q[i + 3 : i + 7] = np.array([x, y, z, w]) / np.linalg.norm([w, x, y, z])
    return q


def _elements(path: Path, section: str, tags=None) -> list:
    """The child elements of every ``<section>`` of the file, in document order (their line
    numbers for messages); empty where the file cannot be parsed by lxml."""
    from lxml import etree

    try:
        root = etree.parse(str(path)).getroot()
    except (etree.XMLSyntaxError, OSError):
        return []
    found = []
    for block in root.iter(section):
        for child in block:
            if isinstance(child.tag, str) and (tags is None or child.tag in tags):
                found.append(child)
    return found


def _where(source: str, elements: list, index: int, name: str) -> str:
    element = None
    if name:
        element = next((e for e in elements if e.get("name") == name), None)
    if element is None and index < len(elements):
        element = elements[index]
    return f"{source} line {_opening_line(element)}" if element is not None else source


def _opening_line(element) -> int:
    """The line an element's start tag opens on: libxml2's ``sourceline`` is the line where a start
    tag written over several lines closes."""
    line = element.sourceline
    try:
        lines = Path(element.getroottree().docinfo.URL).read_text(encoding="utf-8").splitlines()
    except (OSError, TypeError, UnicodeDecodeError):
        return line
    opening = f"<{element.tag}"
    for number in range(min(line, len(lines)), 0, -1):
        if opening in lines[number - 1]:
            return number
    return line


def _closures(mujoco, m, bodies, path: Path, source: str) -> list[Closure]:
    elements = _elements(path, "equality")
    closures = []
    for e in range(m.neq):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e) or ""
        label = repr(name) if name else f"#{e} (unnamed)"
        where = _where(source, elements, e, name)
        kind = int(m.eq_type[e])
        if kind == int(mujoco.mjtEq.mjEQ_JOINT):
            continue  # a joint coupling (_joint_couplings)
        if kind not in (int(mujoco.mjtEq.mjEQ_CONNECT), int(mujoco.mjtEq.mjEQ_WELD)):
            type_name = mujoco.mjtEq(kind).name.removeprefix("mjEQ_").lower()
            raise URDFConventionError(
                f"equality {label} ({where}) is a {type_name!r} equality; a closed-chain robot is closed by "
                "'connect' (a point) and 'weld' (a rigid joint) equalities, and 'joint' equalities couple "
                "joints"
            )
        _require_active(m, e, label, where)
        data = np.array(m.eq_data[e], dtype=float)
        id1, id2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        if int(m.eq_objtype[e]) == int(mujoco.mjtObj.mjOBJ_SITE):
            (j1, b1), (j2, b2) = bodies[int(m.site_bodyid[id1])], bodies[int(m.site_bodyid[id2])]
            p1 = b1 * _se3(m.site_pos[id1], m.site_quat[id1])
            p2 = b2 * _se3(m.site_pos[id2], m.site_quat[id2])
        else:
            (j1, b1), (j2, b2) = bodies[id1], bodies[id2]
            if kind == int(mujoco.mjtEq.mjEQ_CONNECT):  # anchor in body 1, its image in body 2 at qpos0
                p1, p2 = b1 * _translation(data[0:3]), b2 * _translation(data[3:6])
            else:  # x1 + R1 relpos == x2 + R2 anchor and R1 relquat == R2
                p1, p2 = b1 * _se3(data[3:6], data[6:10]), b2 * _translation(data[0:3])
        # the world body and the bodies without joints above every joint ride on joint 0 (the
        # ground), placed in the world: such an equality holds a moving part to the ground
        if j1 == j2:
            site = int(m.eq_objtype[e]) == int(mujoco.mjtObj.mjOBJ_SITE)
            b1, b2 = (int(m.site_bodyid[i]) if site else i for i in (id1, id2))
            n1, n2 = (_name(mujoco, m, mujoco.mjtObj.mjOBJ_BODY, b, "body") for b in (b1, b2))
            how = "fixed to the world" if j1 == 0 else "moved by the same joint"
            raise URDFConventionError(
                f"equality {label} ({where}) joins bodies {n1!r} and {n2!r}, which are one rigid body (both "
                f"{how}): it closes no loop; join bodies that move relative to each other"
            )
        closure_name = name or f"equality_{e}"
        closure_kind = "3d" if kind == int(mujoco.mjtEq.mjEQ_CONNECT) else "6d"
        closures.append(Closure(closure_name, closure_kind, j1, p1, j2, p2, source=where))
    return closures


def _require_active(m, e: int, label: str, where: str) -> None:
    if not bool(m.eq_active0[e]):
        raise URDFConventionError(
            f'equality {label} ({where}) is disabled (active="false"); a loop closure must hold '
            "from the start: remove it or enable it"
        )


def _joint_couplings(mujoco, m, path: Path, source: str) -> list[JointCoupling]:
    """The file's ``<equality joint>`` elements as joint couplings (module docstring): joint1 -
    qpos0 = polycoef's polynomial of joint2 - qpos0 (joint1 held at qpos0 + polycoef[0] without
    joint2).

    Raises:
        URDFConventionError: a disabled one (named, with its line).
    """
    elements = _elements(path, "equality")
    couplings = []
    for e in range(m.neq):
        if int(m.eq_type[e]) != int(mujoco.mjtEq.mjEQ_JOINT):
            continue
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e) or ""
        label = repr(name) if name else f"#{e} (unnamed)"
        where = _where(source, elements, e, name)
        _require_active(m, e, label, where)
        id1, id2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        joint1 = _name(mujoco, m, mujoco.mjtObj.mjOBJ_JOINT, id1, "joint")
        joint2 = None if id2 < 0 else _name(mujoco, m, mujoco.mjtObj.mjOBJ_JOINT, id2, "joint")
        coefficients = tuple(float(c) for c in m.eq_data[e, :5])
        while len(coefficients) > 2 and coefficients[-1] == 0.0:
            coefficients = coefficients[:-1]
        references = [0.0 if joint < 0 else float(m.qpos0[m.jnt_qposadr[joint]]) for joint in (id1, id2)]
        coupling = JointCoupling(
            name or f"equality_{e}", joint1, joint2, coefficients, *references, source=where
        )
        couplings.append(coupling)
    return couplings


def _tendon_joint(mujoco, m, a: int, label: str, where: str, couplings: list[JointCoupling]) -> tuple:
    """(joint name, moment m) an actuator on a fixed tendon drives (module docstring): the one joint
    the tendon's joints are, or are linearly coupled to.

    Raises:
        URDFConventionError: a spatial tendon, or joints that move independently of each other.
    """
    tendon = int(m.actuator_trnid[a, 0])
    tendon_name = _name(mujoco, m, mujoco.mjtObj.mjOBJ_TENDON, tendon, "tendon")
    wraps = range(int(m.tendon_adr[tendon]), int(m.tendon_adr[tendon]) + int(m.tendon_num[tendon]))
    if any(int(m.wrap_type[w]) != int(mujoco.mjtWrap.mjWRAP_JOINT) for w in wraps):
        raise URDFConventionError(
            f"actuator {label} ({where}) pulls the spatial tendon {tendon_name!r}; delta-pin's actuators "
            'drive one hinge or slide joint (joint="...") or a fixed tendon over joints coupled to one'
        )
    # joint1 = c0 + c1 joint2 (relative to qpos0) makes d joint1 / d joint2 = c1: joint1 follows joint2
    follows = {
        c.joint1: (c.joint2, c.coefficients[1])
        for c in couplings
        if c.joint2 is not None and len(c.coefficients) == 2
    }
    gear = float(m.actuator_gear[a, 0])
    terms = []
    for w in wraps:
        joint = _name(mujoco, m, mujoco.mjtObj.mjOBJ_JOINT, int(m.wrap_objid[w]), "joint")
        leader, rate = follows.get(joint, (joint, 1.0))
        terms.append((joint, leader, gear * float(m.wrap_prm[w]) * rate))
    leaders = sorted({leader for _, leader, _ in terms})
    if len(leaders) != 1:
        raise URDFConventionError(
            f"actuator {label} ({where}) pulls tendon {tendon_name!r} over joints "
            f"{', '.join(joint for joint, _, _ in terms)}, which no linear <equality joint> ties to one "
            "of them: delta-pin's actuators drive one joint; give each joint its own <motor>, or couple "
            "them"
        )
    return leaders[0], sum(moment for _, _, moment in terms), tendon_name, [joint for joint, _, _ in terms]


def _actuated(mujoco, m, path: Path, source: str, couplings: list[JointCoupling]) -> tuple[list, list, list]:
    """(the actuated joints in actuator order, notes on how the actuators were read, the notes of
    those read as force sources although the file makes them servos)."""
    elements = _elements(path, "actuator", _ACTUATOR_TAGS)
    names, notes, servos = [], [], []
    for a in range(m.nu):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or ""
        label = repr(name) if name else f"#{a} (unnamed)"
        where = _where(source, elements, a, name)
        transmission = int(m.actuator_trntype[a])
        if transmission not in (int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_TENDON)):
            kind = mujoco.mjtTrn(transmission).name.removeprefix("mjTRN_").lower()
            raise URDFConventionError(
                f"actuator {label} ({where}) drives a {kind!r} transmission; delta-pin's actuators drive one "
                'hinge or slide joint (joint="...") or a fixed tendon over joints coupled to one'
            )
        if int(m.actuator_dyntype[a]) != int(mujoco.mjtDyn.mjDYN_NONE) or int(m.actuator_gaintype[a]) != int(
            mujoco.mjtGain.mjGAIN_FIXED
        ):
            raise URDFConventionError(
                f"actuator {label} ({where}) is not a force source (it has activation dynamics or a "
                'non-fixed gain: a filtered servo, a cylinder, a muscle?); use <motor joint="..."/>'
            )
        if transmission == int(mujoco.mjtTrn.mjTRN_TENDON):
            joint_name, moment, tendon, joints = _tendon_joint(mujoco, m, a, label, where, couplings)
            notes.append(
                f"actuator {label} ({where}) pulls tendon {tendon!r} ({' + '.join(joints)}): read as a "
                f"torque on {joint_name} = {moment:.6g} x its force"
            )
        else:
            joint = int(m.actuator_trnid[a, 0])
            joint_name = _name(mujoco, m, mujoco.mjtObj.mjOBJ_JOINT, joint, "joint")
            if int(m.jnt_type[joint]) not in (
                int(mujoco.mjtJoint.mjJNT_HINGE),
                int(mujoco.mjtJoint.mjJNT_SLIDE),
            ):
                raise URDFConventionError(
                    f"actuator {label} ({where}) drives joint {joint_name!r}, which is not a hinge or a slide"
                )
        if int(m.actuator_biastype[a]) != int(mujoco.mjtBias.mjBIAS_NONE):
            gain, (b0, kp, kv) = (
                float(m.actuator_gainprm[a, 0]),
                (float(x) for x in m.actuator_biasprm[a, :3]),
            )
            kind = "position" if kp != 0.0 else "velocity" if kv != 0.0 else "biased"
            law = f"{gain:.6g} ctrl" + "".join(
                f" {'-' if value < 0 else '+'} {abs(value):.6g}{term}"
                for value, term in ((b0, ""), (kp, " length"), (kv, " length rate"))
                if value != 0.0
            )
            limits = (
                f", within [{m.actuator_forcerange[a, 0]:g}, {m.actuator_forcerange[a, 1]:g}]"
                if bool(m.actuator_forcelimited[a])
                else ""
            )
            servo = (
                f"actuator {label} ({where}) is a {kind} servo in the file (force = {law}{limits}): read "
                f"as a force source on {joint_name}; its servo law, gains and force range are not applied "
                "(the controller's torques replace them)"
            )
            notes.append(servo)
            servos.append(servo)
        names.append(joint_name)
    return names, notes, servos


def _velocity_rows(model: pin.Model, joint: str) -> slice:
    jid = model.getJointId(joint)
    return slice(model.idx_vs[jid], model.idx_vs[jid] + model.nvs[jid])


def _joint_dynamics(mujoco, m, model: pin.Model, source: str) -> tuple[dict, list[str]]:
    """The joints' springs, dampers and rotor inertias as the model carries them: armature into
    ``model.armature``; (stiffness, spring reference, damping) per hinge or slide joint, and
    (0, 0, damping) per ball joint; and the hinge and slide joints with a spring (stiffness > 0),
    which are passive unless a motor drives them. Friction loss is listed in a warning (the
    plant has no dry friction on those joints).

    Raises:
        URDFConventionError: a spring on a ball joint, unequal dampers on one, or anything on a
            free joint (named).
    """
    springs, sprung = {}, []
    for j in range(m.njnt):
        kind = int(m.jnt_type[j])
        name = _name(mujoco, m, mujoco.mjtObj.mjOBJ_JOINT, j, "joint")
        dofs = slice(
            int(m.jnt_dofadr[j]), int(m.jnt_dofadr[j]) + (1 if kind in (2, 3) else 3 if kind == 1 else 6)
        )
        stiffness, damping = float(m.jnt_stiffness[j]), np.asarray(m.dof_damping[dofs], dtype=float)
        armature = np.asarray(m.dof_armature[dofs], dtype=float)
        if kind == 0 and (stiffness != 0.0 or np.any(damping != 0.0) or np.any(armature != 0.0)):
            raise URDFConventionError(
                f"{source}: free joint {name!r} has a stiffness, damping or armature; delta-pin carries none "
                "on a free joint: set them to 0 there"
            )
        if kind == 1:
            if stiffness != 0.0 or np.ptp(damping) != 0.0:
                raise URDFConventionError(
                    f"{source}: ball joint {name!r} has a stiffness or unequal dampers {damping.tolist()}; "
                    "delta-pin carries springs on hinge and slide joints and one damper per ball joint"
                )
            start = model.idx_vs[model.getJointId(name)]
            model.armature[start : start + 3] = armature
            if damping[0] != 0.0:
                springs[name] = (0.0, 0.0, float(damping[0]))
            continue
        if kind == 0:
            continue
        index = model.idx_vs[model.getJointId(name)]
        model.armature[index] = armature[0]
        if stiffness != 0.0 or damping[0] != 0.0:
            springs[name] = (stiffness, float(m.qpos_spring[m.jnt_qposadr[j]]), float(damping[0]))
        if stiffness > 0.0:
            sprung.append(name)
    if np.any(np.asarray(m.dof_frictionloss) != 0.0):
        warnings.warn(
            f"{source}: joint frictionloss (dry friction) is a MuJoCo option the plant does not apply; "
            "give the actuated joints' friction to the plant (friction=) instead",
            stacklevel=3,
        )
    return springs, sprung


def _visual_model(mujoco, m, bodies, model: pin.Model) -> pin.GeometryModel:
    import coal

    geometry = pin.GeometryModel()
    types = mujoco.mjtGeom
    for g in range(m.ngeom):
        kind, size = int(m.geom_type[g]), np.array(m.geom_size[g], dtype=float)
        if kind == int(types.mjGEOM_BOX):
            shape = coal.Box(*(2.0 * size))
        elif kind == int(types.mjGEOM_SPHERE):
            shape = coal.Sphere(size[0])
        elif kind == int(types.mjGEOM_CAPSULE):
            shape = coal.Capsule(size[0], 2.0 * size[1])
        elif kind == int(types.mjGEOM_CYLINDER):
            shape = coal.Cylinder(size[0], 2.0 * size[1])
        elif kind == int(types.mjGEOM_ELLIPSOID):
            shape = coal.Ellipsoid(*size)
        else:  # plane, mesh, hfield, sdf: not drawn
            continue
        joint, body = bodies[int(m.geom_bodyid[g])]
        name = _name(mujoco, m, mujoco.mjtObj.mjOBJ_GEOM, g, "geom")
        body_name = _name(mujoco, m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g]), "body")
        frame = model.getFrameId(body_name, pin.FrameType.BODY)  # a site may share the body's name
        placement = body * _se3(m.geom_pos[g], m.geom_quat[g])
        obj = pin.GeometryObject(f"{name}_{g}", joint, frame, placement, shape)
        obj.meshColor = np.array(m.geom_rgba[g], dtype=float)
        geometry.addGeometryObject(obj)
    return geometry


def read_mjcf(
    path: str | Path,
    *,
    actuated: list[str] | None = None,
    passive: list[str] | None = None,
    end_effector: str | None = None,
    g: float | None = None,
    **assembly,
) -> ClosedChainRobot:
    """A :class:`~delta_pin.model.closed_chain.ClosedChainRobot` from an MJCF file (module docstring).

    Args:
        path: the ``.xml`` file.
        actuated: the actuated joints in the order of alpha (default: the joints of the file's
            ``<motor>`` actuators, in actuator order).
        passive: the joints no motor drives that the closures leave free (default: the hinge
            and slide joints with a spring, ``stiffness`` > 0, that no motor drives and the loops
            leave free with the motors held, and the free
            joints whose motion the closures leave free (a floating base); for a file without motors,
            the joints that fix its configuration, chosen by
            :func:`~delta_pin.model.closed_chain.independent_joints`).
        end_effector: a frame (body, site or joint name) the runs record (default: the first
            closure's first frame).
        g: gravity [m/s^2] along -z (default: the file's ``<option gravity>``).
        **assembly: ``home=``, ``closure_tolerance=`` of
            :class:`~delta_pin.model.closed_chain.ClosedChainRobot`.

    Raises:
        OptionalDependencyError: MuJoCo is not installed.
        URDFConventionError: MuJoCo rejects the file (its message, with the line), the file
            holds an equality or actuator delta-pin does not support (named, with its line), or an
            impossible inertial (:mod:`delta_pin.model.inertials`: named, with its line).
        InvalidParameterError, AssemblyError: bad actuated joints, or loops that do not close.
    """
    mujoco = _import_mujoco()
    path = Path(path)
    source = path.name
    check_mjcf_inertials(path, source)  # before MuJoCo clamps a negative mass of a jointless body to 0
    try:
        m = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:  # MuJoCo's compiler: the message names the element and the line
        message = "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())  # one line
        raise URDFConventionError(f"{source}: MuJoCo cannot compile it: {message}") from None
    check_compiled_inertials(m, path, source)
    model, bodies, q_maps = mjcf_to_pinocchio(m, source=source)
    springs, sprung = _joint_dynamics(mujoco, m, model, source)
    couplings = _joint_couplings(mujoco, m, path, source)
    model.name = bytes(m.names).split(b"\0", 1)[0].decode() or path.stem  # <mujoco model="...">
    if g is not None:
        model.gravity.linear = np.array([0.0, 0.0, -float(g)])
    closures = _closures(mujoco, m, bodies, path, source)
    if not closures:
        raise URDFConventionError(
            f"{source} has no <equality> connect or weld: a closed-chain robot needs its loop closures "
            "(see docs/architecture.md section 13)"
        )
    motors, notes, servos = _actuated(mujoco, m, path, source, couplings)
    for t in range(m.ntendon):  # a tendon's range is a one-sided coupling delta-pin does not model
        if int(m.tendon_limited[t]):
            name = _name(mujoco, m, mujoco.mjtObj.mjOBJ_TENDON, t, "tendon")
            low, high = (float(x) for x in m.tendon_range[t])
            line = (
                f"the limit of tendon {name!r} (range {low:g} to {high:g}) is not modelled: delta-pin's "
                "plant lets the tendon's length leave it (joint limits and contacts are not modelled either)"
            )
            notes.append(line)
            servos.append(line)
    for servo in servos:  # a gain the file gives and the model leaves out: said, not dropped silently
        warnings.warn(servo, stacklevel=3)
    if actuated is None:
        actuated = motors
    keys = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_KEY, k) for k in range(m.nkey)]
    home = keys.index("home") if "home" in keys else None
    qpos = m.qpos0 if home is None else m.key_qpos[home]
    # the file's pose, closed (MuJoCo users leave the loops open for its soft constraints to shut):
    # the mechanism's motions below are read where it is assembled
    reference = assembled_pose(
        model, closures, _to_pinocchio_q(model, q_maps, np.array(qpos, dtype=float)), couplings, held=actuated
    )
    if passive is None:
        # the sprung joints no motor drives; a file without motors is a passive mechanism whose
        # independent joints are chosen (closed_chain.independent_joints)
        # a free joint whose motion the closures leave free (a floating base: no motor drives
        # it); one the closures fix (a Delta's platform written as a free body) is not passive
        motions = free_motions(model, closures, reference, held=actuated, couplings=couplings)
        free = []
        for j in range(m.njnt):
            name = _name(mujoco, m, mujoco.mjtObj.mjOBJ_JOINT, j, "joint")
            if (
                int(m.jnt_type[j]) == 0
                and np.abs(motions[_velocity_rows(model, name)]).max(initial=0.0) > 1e-9
            ):
                free.append(name)
        # a sprung joint is passive only where the loops leave it free with the motors (and the
        # passive joints chosen before it) held; one the loops determine is not, sprung or not
        passive = list(free)
        for name in sprung:
            if name in actuated:
                continue
            left = free_motions(model, closures, reference, held=[*actuated, *passive], couplings=couplings)
            if np.abs(left[_velocity_rows(model, name)]).max(initial=0.0) > 1e-9:
                passive.append(name)
        if not actuated:
            passive += independent_joints(model, closures, reference, exclude=passive, couplings=couplings)
    return ClosedChainRobot(
        model, closures, actuated, passive=passive, joint_springs=springs, name=model.name, source=source,
        base_dir=str(path.resolve().parent), end_effector=end_effector, reference_configuration=reference,
        visual_model=_visual_model(mujoco, m, bodies, model), joint_couplings=couplings, notes=notes,
        **assembly,
    )  # fmt: skip

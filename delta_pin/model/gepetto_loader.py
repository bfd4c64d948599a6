"""A closed-chain robot from a URDF and a Gepetto ``robot.yaml`` sidecar.

The convention of Gepetto's example-parallel-robots and toolbox-parallel-robots: the URDF is a
plain tree (no ``<constraint>``), and ``robot.yaml`` beside it names the loop closures and the
motors (docs/architecture.md section 13)::

    closed_loop: [['closedloop1_A', 'closedloop1_B'], ['closedloop2_A', 'closedloop2_B']]
    type: ['3D', '6D']              # per pair: 3D (the origins coincide) or 6D (the frames do)
    name_mot: ['mot1', 'mot2']      # the actuated joints, in the order of alpha
    joint_name: ['to_rotule_1']     # optional: joints to replace ...
    joint_type: ['SPHERICAL']       # ... by SPHERICAL, UJOINTXY (RX then RY; any two of XYZ),
                                    #     CARDAN (= UJOINTXY) or FIXED
    name_passive: ['spring_1']      # optional: joints no motor drives (an underactuated robot)

A frame name is any frame of the Pinocchio model built from the URDF: a link, or a fixed
joint's child link or the fixed joint itself (Gepetto's files add massless child links, e.g.
``closedloop1_A``, at the closure points). ``type`` defaults to 6D for every pair, as in
Gepetto's loader; ``3d``/``6d`` in lower case are accepted. A frame on the root link (or on a
link fixed to it) rides on joint 0: that closure holds a moving part to the ground. The joint
replacements follow Gepetto's ``completeRobotLoader``: SPHERICAL makes the joint a ball joint at
the same placement, ``UJOINT<a><b>`` a revolute about axis a (``<name>_<a>``) followed by one
about axis b (``<name>_<b>``, which carries the link; CARDAN is UJOINTXY), FIXED locks the joint
at its neutral value. Gepetto's loader takes ``freeflyer=True`` in Python, not in the file:
``load_robot(..., free_flyer=True)`` puts the tree on a free-flyer root the same way. Units: SI,
as the URDF's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from delta_pin.errors import OptionalDependencyError, URDFConventionError
from delta_pin.model.closed_chain import ClosedChainRobot
from delta_pin.model.closures import Closure
from delta_pin.model.urdf_tree import build_urdf_tree, with_free_base

__all__ = ["read_gepetto", "read_gepetto_yaml"]

_KINDS = {"3d": "3d", "6d": "6d"}
_KEYS = ("closed_loop", "type", "name_mot", "name_passive", "joint_name", "joint_type")
_REPLACEMENTS = ("SPHERICAL", "UJOINT<a><b> (a, b in X, Y, Z)", "CARDAN", "FIXED")
_AXES = {"X": pin.JointModelRX, "Y": pin.JointModelRY, "Z": pin.JointModelRZ}


def _universal_axes(kind: str) -> tuple[str, str] | None:
    """The two axes of a universal-joint replacement (``UJOINTXY``, ``CARDAN``), else ``None``."""
    if kind == "CARDAN":
        return ("X", "Y")
    if kind.startswith("UJOINT") and len(kind) >= 8 and kind[-2] in _AXES and kind[-1] in _AXES:
        return (kind[-2], kind[-1]) if kind[-2] != kind[-1] else None
    return None


def _known_replacement(kind: str) -> bool:
    return kind in ("SPHERICAL", "FIXED") or _universal_axes(kind) is not None


def _lines(text: str) -> dict:
    """Line numbers (1-based) of the top-level keys and of each item of their lists."""
    import yaml

    lines: dict = {}
    node = yaml.compose(text)
    if not isinstance(node, yaml.MappingNode):
        return lines
    for key, value in node.value:
        lines[key.value] = key.start_mark.line + 1
        if isinstance(value, yaml.SequenceNode):
            for i, item in enumerate(value.value):
                lines[(key.value, i)] = item.start_mark.line + 1
    return lines


def read_gepetto_yaml(yaml_path: str | Path) -> tuple[dict, dict]:
    """The contents of a Gepetto ``robot.yaml`` and the line of each key and list item.

    Raises:
        OptionalDependencyError: PyYAML is missing.
        URDFConventionError: not YAML (with the line), not a mapping, an unknown key, or a key
            whose value has the wrong shape (named, with its line).
    """
    try:
        import yaml
    except ImportError as exc:  # pragma: no cover - PyYAML is a dependency
        raise OptionalDependencyError(
            f"reading robot.yaml needs PyYAML ({exc}): pip install pyyaml"
        ) from None
    yaml_path = Path(yaml_path)
    source = yaml_path.name
    try:
        text = yaml_path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise URDFConventionError(
            f"{str(yaml_path)!r} is not text (a binary file?): give a robot.yaml of YAML text, or remove it"
        ) from None
    try:
        content = yaml.safe_load(text)
        lines = _lines(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise URDFConventionError(f"{source}{at}: not valid YAML: {problem}") from None
    if not isinstance(content, dict):
        raise URDFConventionError(
            f"{source}: expected a mapping with keys {', '.join(_KEYS)}; got {type(content).__name__}"
        )
    for key in content:
        if key not in _KEYS:
            raise URDFConventionError(
                f"{source} line {lines.get(key, '?')}: unknown key {key!r}; delta-pin reads "
                f"{', '.join(_KEYS)}"
            )
    if "closed_loop" not in content:
        raise URDFConventionError(
            f"{source}: key 'closed_loop' is missing (the pairs of frames the loops join)"
        )
    for key in _KEYS:
        if key in content and not isinstance(content[key], list):
            raise URDFConventionError(
                f"{source} line {lines.get(key, '?')}: {key!r} must be a list, got {content[key]!r}"
            )
    for i, pair in enumerate(content["closed_loop"]):
        if not (isinstance(pair, list) and len(pair) == 2 and all(isinstance(n, str) for n in pair)):
            raise URDFConventionError(
                f"{source} line {lines.get(('closed_loop', i), '?')}: closed_loop item {i} must be a pair "
                f"of frame names [frameA, frameB], got {pair!r}"
            )
    for short, long in (("type", "closed_loop"), ("joint_type", "joint_name")):
        if short in content and len(content[short]) != len(content.get(long, [])):
            raise URDFConventionError(
                f"{source} line {lines.get(short, '?')}: {short!r} has {len(content[short])} item(s) but "
                f"{long!r} has {len(content.get(long, []))}: give one per item"
            )
    if "joint_name" in content and "joint_type" not in content:
        raise URDFConventionError(f"{source} line {lines['joint_name']}: 'joint_name' without 'joint_type'")
    return content, lines


def _replace_joints(model: pin.Model, names: list, types: list, where) -> pin.Model:
    """Gepetto's joint replacements (module docstring) on a copy of ``model``."""
    new = pin.Model()
    new.name = model.name
    new.gravity = model.gravity
    kinds = dict(zip(names, types))
    # the joint that carries the link of a universal-joint replacement: the second axis's
    carrier = {n: f"{n}_{_universal_axes(k)[1]}" for n, k in kinds.items() if _universal_axes(k)}
    locked = []
    for j in range(1, model.njoints):
        name, placement = model.names[j], model.jointPlacements[j]
        parent_name = model.names[model.parents[j]]
        parent = new.getJointId(carrier.get(parent_name, parent_name)) if model.parents[j] else 0
        kind = kinds.get(name)
        joint = model.joints[j]
        if kind == "SPHERICAL":
            joint = pin.JointModelSpherical()
        elif name in carrier:
            first, second = _universal_axes(kind)
            parent = new.addJoint(parent, _AXES[first](), placement, f"{name}_{first}")
            new.addJointFrame(parent, -1)
            joint, placement, name = _AXES[second](), pin.SE3.Identity(), carrier[name]
        jid = new.addJoint(parent, joint, placement, name)
        new.addJointFrame(jid, -1)
        new.appendBodyToJoint(jid, model.inertias[j], pin.SE3.Identity())
        if kind == "FIXED":
            locked.append(jid)
    for frame in model.frames[1:]:
        if frame.type == pin.FrameType.JOINT:
            continue  # addJoint made them
        joint_name = model.names[frame.parentJoint]
        joint_name = carrier.get(joint_name, joint_name)
        parent = new.getJointId(joint_name) if frame.parentJoint else 0
        previous = model.frames[frame.parentFrame]
        previous_name = previous.name
        if previous.type == pin.FrameType.JOINT:
            previous_name = carrier.get(previous_name, previous_name)
        previous_id = new.getFrameId(previous_name) if new.existFrame(previous_name) else 0
        new.addFrame(pin.Frame(frame.name, parent, previous_id, frame.placement, frame.type), False)
    for name in names:
        if not model.existJointName(name):
            raise URDFConventionError(f"{where('joint_name')}: joint {name!r} is not in the URDF")
    if locked:
        new = pin.buildReducedModel(new, locked, pin.neutral(new))
    return new


def _frame(model: pin.Model, name: str) -> pin.Frame | None:
    for kind in (pin.FrameType.BODY, pin.FrameType.FIXED_JOINT, pin.FrameType.OP_FRAME, pin.FrameType.JOINT):
        if model.existFrame(name, kind):
            return model.frames[model.getFrameId(name, kind)]
    return None


def read_gepetto(
    urdf_path: str | Path,
    yaml_path: str | Path,
    *,
    urdf: str,
    actuated: list[str] | None = None,
    passive: list[str] | None = None,
    free_flyer: bool = False,
    end_effector: str | None = None,
    g: float | None = None,
    **assembly,
) -> ClosedChainRobot:
    """A :class:`~delta_pin.model.closed_chain.ClosedChainRobot` from a URDF and its Gepetto
    ``robot.yaml`` (module docstring).

    Args:
        urdf_path: the URDF file (for messages and relative mesh paths).
        yaml_path: the ``robot.yaml``.
        urdf: the URDF text (already read, xacro compiled).
        actuated: the actuated joints (default: ``name_mot``).
        passive: joints no motor drives (default: ``name_passive``, if given).
        free_flyer: a free-flyer root joint (``root_joint``, passive) under the tree.
        end_effector: the frame the runs record (default: the first closure's first frame).
        g: gravity [m/s^2] along -z (default: Pinocchio's 9.81; a URDF has none).
        **assembly: ``home=``, ``closure_tolerance=`` of
            :class:`~delta_pin.model.closed_chain.ClosedChainRobot`.

    Raises:
        URDFConventionError: bad YAML (with its line), a missing key, lists of different
            lengths, an unknown closure or joint type, or a frame or joint the URDF does not have.
        InvalidParameterError, AssemblyError: bad actuated joints, or loops that do not close.
    """
    urdf_path, yaml_path = Path(urdf_path), Path(yaml_path)
    content, lines = read_gepetto_yaml(yaml_path)
    source = yaml_path.name

    def where(key, index=None) -> str:
        line = lines.get(key if index is None else (key, index), lines.get(key))
        return f"{source} line {line}" if line else source

    model = build_urdf_tree(urdf, urdf_path.name, free_flyer)
    joint_names = [str(n) for n in content.get("joint_name", [])]
    joint_types = [str(t).upper() for t in content.get("joint_type", [])]
    for i, kind in enumerate(joint_types):
        if not _known_replacement(kind):
            raise URDFConventionError(
                f"{where('joint_type', i)}: joint_type {content['joint_type'][i]!r} (for joint "
                f"{joint_names[i]!r}) is not supported; use one of {', '.join(_REPLACEMENTS)}"
            )
    if joint_names:
        model = _replace_joints(model, joint_names, joint_types, where)
    if g is not None:
        model.gravity.linear = np.array([0.0, 0.0, -float(g)])
    kinds = content.get("type", ["6D"] * len(content["closed_loop"]))
    closures = []
    for i, ((name1, name2), kind_name) in enumerate(zip(content["closed_loop"], kinds)):
        kind = _KINDS.get(str(kind_name).lower())
        if kind is None:
            raise URDFConventionError(
                f"{where('type', i)}: type {kind_name!r} of closed_loop pair {i} ({name1}, {name2}) is not "
                "supported; use '3D' (the frames' origins coincide) or '6D' (the frames coincide)"
            )
        frames = []
        for name in (name1, name2):
            frame = _frame(model, name)
            if frame is None:
                raise URDFConventionError(
                    f"{where('closed_loop', i)}: closed_loop pair {i} names frame {name!r}, which "
                    f"{urdf_path.name} does not have (a link or a fixed joint)"
                )
            frames.append(frame)
        (f1, f2) = frames
        if f1.parentJoint == f2.parentJoint:
            joint = f1.parentJoint
            body = "the ground (the root link)" if joint == 0 else f"joint {model.names[joint]!r}"
            raise URDFConventionError(
                f"{where('closed_loop', i)}: frames {name1!r} and {name2!r} move together (one rigid body, "
                f"both on {body}), so closed_loop pair {i} closes no loop; pair frames of two different "
                "bodies"
            )
        closures.append(
            Closure(
                f"{name1}_{name2}", kind, f1.parentJoint, f1.placement, f2.parentJoint, f2.placement,
                source=where("closed_loop", i),
            )
        )  # fmt: skip
    if actuated is None:
        if "name_mot" not in content:
            raise URDFConventionError(
                f"{source}: key 'name_mot' is missing (the motor joints); or pass actuated="
            )
        actuated = [str(n) for n in content["name_mot"]]
        for i, name in enumerate(actuated):
            if not model.existJointName(name):
                raise URDFConventionError(
                    f"{where('name_mot', i)}: motor joint {name!r} is not in {urdf_path.name} (joints: "
                    f"{', '.join(model.names[1:])})"
                )
    if passive is None:
        passive = [str(n) for n in content.get("name_passive", [])]
        for i, name in enumerate(passive):
            if not model.existJointName(name):
                raise URDFConventionError(
                    f"{where('name_passive', i)}: passive joint {name!r} is not in {urdf_path.name} (joints: "
                    f"{', '.join(model.names[1:])})"
                )
    return ClosedChainRobot(
        model, closures, actuated, passive=with_free_base(passive, free_flyer), name=model.name,
        source=f"{urdf_path.name} + {source}", urdf=urdf, base_dir=str(urdf_path.resolve().parent),
        end_effector=end_effector, **assembly,
    )  # fmt: skip

"""``load_robot``: a closed-chain robot from any of the three file shapes people keep them in.

* ``.urdf`` / ``.urdf.xacro`` with ``<constraint>`` elements (delta-pin's shape, the one proposed
  to urdfdom)::

      <constraint name="loop" type="point">          <!-- or type="weld": the frames coincide -->
        <parent link="link_a"/> <parent_origin xyz="0 0 -0.4" rpy="0 0 0"/>
        <child link="link_b"/>  <child_origin xyz="0.07 0.04 0"/>
      </constraint>

  the actuated joints from ``actuated=``, else from the URDF's ``<transmission>`` elements;
* ``.urdf`` with a ``robot.yaml`` beside it (Gepetto's convention: ``closed_loop`` frame-name
  pairs, ``type`` ``3D``/``6D`` per pair, ``name_mot`` motor joints;
  :mod:`delta_pin.model.gepetto_loader`);
* ``.xml`` MJCF (``<equality>`` ``connect``/``weld``, ``<actuator>`` ``motor``; compiled by MuJoCo
  itself so that defaults, inferred inertias and reference-pose anchors mean what they mean in
  MuJoCo; :mod:`delta_pin.model.mjcf_loader`).

A Delta in any shape is recognised (:func:`delta_pin.model.delta_recognition.recognise_delta`)
and then also carries the paper's analytic model (``robot.delta``). Nothing is dropped
silently: an element the loader does not support is an error naming it (and its line).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from delta_pin.errors import DeltaPinError, InvalidParameterError, URDFConventionError
from delta_pin.model.closed_chain import CLOSURE_TOLERANCE, ClosedChainRobot
from delta_pin.model.closures import read_urdf_constraints
from delta_pin.model.description import expand_xacro
from delta_pin.model.urdf_tree import build_urdf_tree, with_free_base

__all__ = ["ROBOT_FILE_SHAPES", "SHIPPED_ROBOTS", "load_robot", "read_urdf_constraints", "shipped_robot"]

ROBOT_FILE_SHAPES = (
    ".urdf or .urdf.xacro with <constraint> elements, .urdf with a robot.yaml beside it, or .xml (MJCF)"
)
# name (delta_pin.choices.SHIPPED_ROBOT_NAMES) -> file in delta_pin/robots
# (scripts/make_example_robots.py writes them)
SHIPPED_ROBOTS = {
    "five_bar": "five_bar.urdf",  # planar five-bar, URDF with a <constraint type="point">
    "three_rrr": "three_rrr.urdf",  # planar 3-RRR, URDF with a point and a weld closure
    "three_rrr_mjcf": "three_rrr.xml",  # the same robot in MJCF (connect + weld)
    "delta_mjcf": "delta.xml",  # the Table 1 Delta in MJCF (connects, motors)
    "delta_gepetto": "delta_gepetto/robot.urdf",  # the Table 1 Delta as URDF + robot.yaml
    "stewart": "stewart.urdf",  # 6-UPS Stewart-Gough platform, URDF with five <constraint type="point">
    "stewart_mjcf": "stewart.xml",  # the same robot in MJCF (connect, ball, motors on the slides)
    "delta_ballrods": "delta_ballrods.xml",  # the Table 1 Delta in MJCF, ball-jointed parallelogram rods
}


def _urdf_transmissions(urdf: str) -> list[str]:
    root = etree.fromstring(urdf.encode())
    return [
        joint.get("name") for t in root.iter("transmission") for joint in t.iter("joint") if joint.get("name")
    ]


def _has_constraints(text: str, source: str) -> bool:
    """Whether URDF text holds a ``<constraint>`` element (not a comment that mentions one)."""
    try:
        return next(etree.fromstring(text.encode()).iter("constraint"), None) is not None
    except etree.XMLSyntaxError as exc:
        raise URDFConventionError(f"{source}: not valid XML: {exc}") from None


def _read_text(path: Path) -> str:
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise URDFConventionError(f"{str(path)!r} is not text (a binary file?)") from None
    if path.name.endswith(".xacro"):
        return expand_xacro(path)
    return text


def _load_urdf(
    path: Path,
    text: str,
    actuated,
    g: float | None,
    end_effector: str | None,
    passive,
    free_flyer: bool,
    assembly: dict,
) -> ClosedChainRobot:
    source = path.name
    try:
        etree.fromstring(text.encode())
    except etree.XMLSyntaxError as exc:
        raise URDFConventionError(f"{source}: not valid XML: {exc}") from None
    model = build_urdf_tree(text, source, free_flyer)
    if g is not None:
        model.gravity.linear = np.array([0.0, 0.0, -float(g)])
    closures = read_urdf_constraints(text, model, source)
    if not closures:
        raise URDFConventionError(
            f"{source} has no <constraint> element and no robot.yaml beside it: a closed-chain robot "
            "needs its loop "
            "closures (see docs/architecture.md section 10)"
        )
    reference = None
    if actuated is None:
        actuated = _urdf_transmissions(text)
    if not actuated:  # a URDF that follows the Delta convention names its actuators by it
        delta = _as_delta(text, model, path)
        if delta is not None:
            actuated = list(delta.description.active_joints)
            reference = delta.reference_configuration(model, closures)
    if not actuated:
        raise URDFConventionError(
            f"{source} names no actuated joint: pass actuated=[...] (CLI: --actuated a,b,c) or add "
            "<transmission> "
            "elements"
        )
    return ClosedChainRobot(
        model, closures, actuated, passive=with_free_base(passive, free_flyer), name=model.name,
        source=source, urdf=text, base_dir=str(path.resolve().parent), end_effector=end_effector,
        reference_configuration=reference, **assembly,
    )  # fmt: skip


def _as_delta(text: str, model: pin.Model, path: Path):
    """The :class:`~delta_pin.model.robot.Delta` of URDF text that follows the Delta convention
    (docs/architecture.md section 3), else ``None``."""
    from delta_pin.model.description import read_description
    from delta_pin.model.robot import Delta

    try:
        g = -float(model.gravity.linear[2])
        return Delta(read_description(text, g=g if g > 0 else 9.81, base_dir=path.resolve().parent))
    except DeltaPinError:  # not a Delta
        return None


def shipped_robot(name: str) -> Path:
    """Path of a robot file shipped with delta-pin (:data:`SHIPPED_ROBOTS`)."""
    if name not in SHIPPED_ROBOTS:
        raise URDFConventionError(f"no shipped robot {name!r}; shipped: {', '.join(SHIPPED_ROBOTS)}")
    from importlib import resources

    return Path(str(resources.files("delta_pin") / "robots" / SHIPPED_ROBOTS[name]))


def load_robot(
    path: str | Path,
    *,
    actuated: list[str] | None = None,
    passive: list[str] | None = None,
    free_flyer: bool = False,
    end_effector: str | None = None,
    g: float | None = None,
    recognise: bool = True,
    home: Sequence[float] | np.ndarray | None = None,
    closure_tolerance: float = CLOSURE_TOLERANCE,
    **xacro_args: float | str,
) -> ClosedChainRobot:
    """A closed-chain robot from a URDF (with ``<constraint>`` elements, or with a Gepetto
    ``robot.yaml`` beside it) or an MJCF file (module docstring).

    Args:
        path: the file (``.urdf``, ``.urdf.xacro``, ``.xacro`` or ``.xml``), or the name of a
            shipped robot (:data:`SHIPPED_ROBOTS`, e.g. ``"five_bar"``).
        actuated: the actuated joints, in the order of alpha (default: from the file: URDF
            ``<transmission>``, ``robot.yaml`` ``name_mot``, MJCF ``<motor>``).
        passive: joints no motor drives that the closures leave free (an underactuated
            mechanism; default: ``robot.yaml`` ``name_passive``, MJCF joints with a spring that no
            motor drives and free joints; a motorless MJCF file: chosen). The plant simulates
            them; controllers refuse the robot.
        free_flyer: URDF shapes: put the tree on a free-flyer root joint (``root_joint``, passive),
            as Gepetto's loader does with ``freeflyer=True``; MJCF has its own free joints.
        end_effector: the frame the runs record and task-space paths move (default: the first
            closure's first frame).
        g: gravity [m/s^2] along -z (default: the file's; URDF has none: 9.81).
        recognise: look for a Delta (then ``robot.delta`` is its analytic model).
        home: where to assemble the robot: its actuated coordinates alpha (``dof``,) [rad or m],
            or a whole configuration q (nq,) (default: the file's pose -- MJCF ``qpos0`` or the
            keyframe ``home``, URDF zero -- closed by a global solve, first at the file's
            actuated coordinates, then with every joint free; docs/architecture.md, "Assembly").
        closure_tolerance: the largest gap [m or rad] accepted in the file's loops (CAD
            rounding); such loops are re-anchored to close exactly at home (``summary()`` says so).
        **xacro_args: arguments of a ``.xacro`` file.

    Raises:
        URDFConventionError: the file is missing, unreadable, holds an element the loader
            does not support (named, with its line), or a mass or inertia that is unreadable or
            physically impossible: a mass not finite or < 0 [kg], an inertia [kg m^2] not positive
            semi-definite or breaking the triangle inequality of its principal moments (the link
            or body, its line; :mod:`delta_pin.model.inertials`).
        InvalidParameterError, AssemblyError: bad actuated joints, or loops that do not close.
    """
    if isinstance(path, str) and path in SHIPPED_ROBOTS:
        path = shipped_robot(path)
    path = Path(path)
    if not path.is_file():
        raise URDFConventionError(
            f"robot file {str(path)!r} does not exist; give {ROBOT_FILE_SHAPES}, "
            f"or a shipped robot's name ({', '.join(SHIPPED_ROBOTS)})"
        )
    if g is not None and not (math.isfinite(float(g)) and float(g) >= 0.0):
        raise InvalidParameterError(f"g={g!r} must be a finite number >= 0 [m/s^2]")
    name = path.name.lower()
    if xacro_args and not name.endswith(".xacro"):
        raise InvalidParameterError(
            f"xacro arguments {sorted(xacro_args)} apply to .xacro files only, not to {path.name}"
        )
    assembly = {"home": home, "closure_tolerance": closure_tolerance}
    if name.endswith(".xml") or name.endswith(".mjcf"):
        from delta_pin.model.mjcf_loader import read_mjcf

        if free_flyer:
            raise InvalidParameterError(
                f"free_flyer=True applies to URDF files; {path.name} is MJCF: give its base a <freejoint/>"
            )
        robot = read_mjcf(
            path, actuated=actuated, passive=passive, end_effector=end_effector, g=g, **assembly
        )
    elif name.endswith(".urdf") or name.endswith(".xacro"):
        if xacro_args:
            text = expand_xacro(path, {k: str(v) for k, v in xacro_args.items()})
        else:
            text = _read_text(path)
        sidecar = path.with_name("robot.yaml")
        if not _has_constraints(text, path.name) and sidecar.is_file():
            from delta_pin.model.gepetto_loader import read_gepetto

            robot = read_gepetto(
                path, sidecar, urdf=text, actuated=actuated, passive=passive, free_flyer=free_flyer,
                end_effector=end_effector, g=g, **assembly,
            )  # fmt: skip
        else:
            robot = _load_urdf(path, text, actuated, g, end_effector, passive, free_flyer, assembly)
    else:
        raise URDFConventionError(f"{path.name}: unknown robot file type; give {ROBOT_FILE_SHAPES}")
    if recognise and not robot.passive_joints:  # an underactuated robot has no reduced model to compare
        from delta_pin.model.delta_recognition import delta_platform_joint, recognise_delta

        robot.delta = recognise_delta(robot)
        if robot.delta is not None and end_effector is None:  # the paper's xyz: the platform's
            robot.set_end_effector(robot.joint_frame(delta_platform_joint(robot)))
    return robot

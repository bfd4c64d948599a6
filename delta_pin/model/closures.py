"""Loop closures of a closed-chain robot, as plain data shared by every file loader.

A closed-chain robot is a kinematic tree (a ``pin.Model``) plus closures: pairs of frames, each
rigidly attached to a joint of the tree, that the mechanism keeps together. Two kinds:

* ``"3d"`` -- a point (ball-joint) closure: the two frames' origins coincide (3 equations);
* ``"6d"`` -- a weld closure: the two frames coincide, origin and orientation (6 equations).

The three file shapes (URDF ``<constraint>``, URDF + Gepetto ``robot.yaml``, MJCF equalities)
each produce a list of :class:`Closure` (:mod:`delta_pin.model.loaders`); the URDF's
``<constraint>`` elements are read here (:func:`read_urdf_constraints`, the one parser, the
Delta's description included); the
:class:`~delta_pin.model.closed_chain.ClosedChainRobot` turns them into Pinocchio
``RigidConstraintModel`` objects for ``constraintDynamics`` and into its own residuals and
Jacobians (docs/architecture.md section 10).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from lxml import etree

from delta_pin.errors import InvalidParameterError, URDFConventionError

__all__ = ["CLOSURE_KINDS", "Closure", "read_urdf_constraints"]

CLOSURE_KINDS = {"3d": 3, "6d": 6}  # kind -> equations


@dataclass(frozen=True)
class Closure:
    """Two frames of the tree that the mechanism holds together.

    Attributes:
        name: the closure's name (from the file; used in every error about it).
        kind: ``"3d"`` (the frames' origins coincide) or ``"6d"`` (the frames coincide).
        joint1, joint2: the tree joints (ids in the ``pin.Model``) the two frames ride on.
        placement1, placement2: each frame's placement in its joint's frame.
        source: where the closure was read, for error messages (e.g. ``"robot.urdf line 114"``).
    """

    name: str
    kind: str
    joint1: int
    placement1: pin.SE3
    joint2: int
    placement2: pin.SE3
    source: str = ""

    def __post_init__(self) -> None:
        if self.kind not in CLOSURE_KINDS:
            raise InvalidParameterError(
                f"closure {self.name!r}{self.where}: kind {self.kind!r} is not supported; use '3d' (point) "
                "or '6d' (weld)"
            )
        if self.joint1 == self.joint2:
            raise InvalidParameterError(
                f"closure {self.name!r}{self.where}: both frames ride on the same joint, so it closes no loop"
            )

    @property
    def where(self) -> str:
        """`` (source)`` for messages, or nothing."""
        return f" ({self.source})" if self.source else ""

    @property
    def size(self) -> int:
        """Number of scalar equations (3 or 6)."""
        return CLOSURE_KINDS[self.kind]

    def constraint_model(self, model: pin.Model) -> pin.RigidConstraintModel:
        """This closure as Pinocchio's ``RigidConstraintModel`` (LOCAL frame), for
        ``pin.constraintDynamics``."""
        kind = pin.ContactType.CONTACT_3D if self.kind == "3d" else pin.ContactType.CONTACT_6D
        constraint = pin.RigidConstraintModel(
            kind, model, self.joint1, self.placement1, self.joint2, self.placement2, pin.ReferenceFrame.LOCAL
        )
        constraint.name = self.name
        return constraint


_POINT_TYPES = {"point": "3d", "3d": "3d"}
_WELD_TYPES = {"weld": "6d", "fixed": "6d", "6d": "6d"}


def _numbers(element, attribute: str, where: str, default: str = "0 0 0") -> np.ndarray:
    text = default if element is None else element.get(attribute, default)
    try:
        values = np.array([float(v) for v in text.split()])
    except ValueError:
        raise URDFConventionError(f"{where}: {attribute}={text!r} is not a list of numbers") from None
    if values.shape != (3,) or not np.isfinite(values).all():
        raise URDFConventionError(f"{where}: {attribute}={text!r} must be 3 finite numbers")
    return values


def _origin(element, where: str) -> pin.SE3:
    xyz = _numbers(element, "xyz", where)
    rpy = _numbers(element, "rpy", where)
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), xyz)


def read_urdf_constraints(urdf: str, model: pin.Model, source: str = "URDF") -> list[Closure]:
    """The ``<constraint>`` elements of URDF text as :class:`Closure` on ``model`` (built from
    the same text by Pinocchio).

    A link may be the URDF's root link (the ground) or a link fixed to it: that frame rides on
    joint 0 (the world), at the link's placement in the world.

    Raises:
        URDFConventionError: a constraint with an unsupported type, a missing link, bad
            numbers, or two links of one rigid body; the message names the constraint and its line.
    """
    root = etree.fromstring(urdf.encode())
    closures = []
    for number, element in enumerate(root.iter("constraint"), 1):
        name = element.get("name") or f"constraint_{number}"
        where = f"{source} line {element.sourceline}"
        kind_name = (element.get("type") or "").lower()
        kind = _POINT_TYPES.get(kind_name) or _WELD_TYPES.get(kind_name)
        if kind is None:
            raise URDFConventionError(
                f"constraint {name!r} ({where}) has type {element.get('type')!r}; "
                "supported: 'point' (3D, the "
                "frames' origins coincide) and 'weld' (6D, the frames coincide)"
            )
        anchors, links = [], []
        for tag in ("parent", "child"):
            link_element = element.find(tag)
            link = None if link_element is None else link_element.get("link")
            if link is None:
                raise URDFConventionError(f"constraint {name!r} ({where}) has no <{tag} link='...'/>")
            if not model.existFrame(link, pin.FrameType.BODY):
                raise URDFConventionError(
                    f"constraint {name!r} ({where}) names link {link!r}, which the URDF does not have"
                )
            # the root link and links fixed to it are on joint 0 (the ground), placed in the world
            body = model.frames[model.getFrameId(link, pin.FrameType.BODY)]
            anchors.append((body.parentJoint, body.placement * _origin(element.find(f"{tag}_origin"), where)))
            links.append(link)
        (j1, placement1), (j2, placement2) = anchors
        if j1 == j2:
            body = "the ground (the root link)" if j1 == 0 else f"joint {model.names[j1]!r}"
            raise URDFConventionError(
                f"constraint {name!r} ({where}) joins links {links[0]!r} and {links[1]!r}, which are one "
                f"rigid body (both on {body}): it closes no loop; join links of two different bodies"
            )
        closures.append(Closure(name, kind, j1, placement1, j2, placement2, source=where))
    return closures

"""Loop closures of a closed-chain robot, as plain data shared by every file loader.

A closed-chain robot is a kinematic tree (a ``pin.Model``) plus closures: pairs of frames, each
rigidly attached to a joint of the tree, that the mechanism keeps together. Two kinds:

* ``"3d"`` -- a point (ball-joint) closure: the two frames' origins coincide (3 equations);
* ``"6d"`` -- a weld closure: the two frames coincide, origin and orientation (6 equations).

The three file shapes (URDF ``<constraint>``, URDF + Gepetto ``robot.yaml``, MJCF equalities)
each produce a list of :class:`Closure` (:mod:`delta_pin.model.loaders`); the
:class:`~delta_pin.model.closed_chain.ClosedChainRobot` turns them into Pinocchio
``RigidConstraintModel`` objects for ``constraintDynamics`` and into its own residuals and
Jacobians (docs/architecture.md section 10).
"""

from __future__ import annotations

from dataclasses import dataclass

import pinocchio as pin

from delta_pin.errors import InvalidParameterError

__all__ = ["CLOSURE_KINDS", "Closure"]

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

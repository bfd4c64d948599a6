"""Pinocchio's tree of a URDF, fixed or on a free-flyer base: shared by the URDF loaders
(:mod:`delta_pin.model.loaders`, :mod:`delta_pin.model.gepetto_loader`)."""

from __future__ import annotations

from collections.abc import Sequence

import pinocchio as pin

from delta_pin.errors import URDFConventionError
from delta_pin.model.inertials import check_urdf_inertials

__all__ = ["FREE_FLYER_JOINT", "build_urdf_tree", "with_free_base"]

FREE_FLYER_JOINT = "root_joint"  # the name Pinocchio gives a root joint it adds


def build_urdf_tree(text: str, source: str, free_flyer: bool = False) -> pin.Model:
    """Pinocchio's tree of URDF text, on a free-flyer root joint (``root_joint``) if asked; every
    link's ``<inertial>`` checked first (:func:`~delta_pin.model.inertials.check_urdf_inertials`:
    urdfdom would drop one it cannot parse and accept a negative mass).

    Raises:
        URDFConventionError: an impossible or unreadable inertial (file, line, link), or Pinocchio
            cannot read it (its message, naming the file).
    """
    check_urdf_inertials(text, source)
    try:
        if free_flyer:
            return pin.buildModelFromXML(text, pin.JointModelFreeFlyer())
        return pin.buildModelFromXML(text)
    except (RuntimeError, ValueError) as exc:
        raise URDFConventionError(f"{source}: Pinocchio could not read the URDF: {exc}") from None


def with_free_base(passive: Sequence[str] | None, free_flyer: bool) -> list[str]:
    """The passive joints, with the free-flyer root where the base is free (a free base is
    driven by no motor: the plant simulates it, controllers refuse it)."""
    names = list(passive or [])
    return [*names, FREE_FLYER_JOINT] if free_flyer and FREE_FLYER_JOINT not in names else names

"""Pinocchio's tree of a URDF, fixed or on a free-flyer base: shared by the URDF loaders
(:mod:`delta_pin.model.loaders`, :mod:`delta_pin.model.gepetto_loader`).

Rotor inertia: URDF has no field for it; Drake's extension puts it on a transmission's actuator,
``<drake:rotor_inertia value="I"/>`` [kg m^2] with ``<drake:gear_ratio value="N"/>`` (default 1),
and reflects I N^2 onto the joint. The tree reads it the same way, into ``model.armature`` (what
Pinocchio's CRBA adds to M's diagonal, as the MJCF loader does with MuJoCo's ``armature``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import pinocchio as pin
from lxml import etree

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
            model = pin.buildModelFromXML(text, pin.JointModelFreeFlyer())
        else:
            model = pin.buildModelFromXML(text)
    except (RuntimeError, ValueError) as exc:
        raise URDFConventionError(f"{source}: Pinocchio could not read the URDF: {exc}") from None
    _add_rotor_inertias(model, text, source)
    return model


_DRAKE = "http://drake.mit.edu"


def _value(element, source: str, what: str, low: float) -> float:
    try:
        value = float(element.get("value", ""))
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= low):
        raise URDFConventionError(
            f"{source} line {element.sourceline}: {what} value={element.get('value')!r} must be a finite "
            f"number >= {low:g}"
        )
    return value


def _add_rotor_inertias(model: pin.Model, text: str, source: str) -> None:
    """``model.armature`` += I N^2 of each transmission actuator's Drake rotor inertia I and gear
    ratio N (module docstring) on its one 1-DOF joint.

    Raises:
        URDFConventionError: a value that is not a finite number >= 0 (N > 0), or a transmission
            with a rotor inertia that names no 1-DOF joint of the model (file, line).
    """
    if "rotor_inertia" not in text:
        return
    root = etree.fromstring(text.encode())  # check_urdf_inertials has parsed it already
    for transmission in root.iter("transmission"):
        joints = [j.get("name") for j in transmission.findall("joint")]
        for actuator in transmission.findall("actuator"):
            inertia = actuator.find(f"{{{_DRAKE}}}rotor_inertia")
            if inertia is None:
                continue
            where = f"{source} line {inertia.sourceline}"
            if len(joints) != 1 or not model.existJointName(joints[0]):
                raise URDFConventionError(
                    f"{where}: a drake:rotor_inertia's transmission names joints {joints}; expected one "
                    "joint of the model"
                )
            jid = model.getJointId(joints[0])
            if model.nvs[jid] != 1:
                raise URDFConventionError(
                    f"{where}: drake:rotor_inertia on joint {joints[0]!r} of {model.nvs[jid]} degrees of "
                    "freedom; a rotor drives a 1-DOF joint"
                )
            ratio = actuator.find(f"{{{_DRAKE}}}gear_ratio")
            n = 1.0 if ratio is None else _value(ratio, source, "drake:gear_ratio", 1e-300)
            model.armature[model.idx_vs[jid]] += _value(inertia, source, "drake:rotor_inertia", 0.0) * n * n


def with_free_base(passive: Sequence[str] | None, free_flyer: bool) -> list[str]:
    """The passive joints, with the free-flyer root where the base is free (a free base is
    driven by no motor: the plant simulates it, controllers refuse it)."""
    names = list(passive or [])
    return [*names, FREE_FLYER_JOINT] if free_flyer and FREE_FLYER_JOINT not in names else names

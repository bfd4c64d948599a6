"""Inertial checks at load: every mass and inertia a robot file gives is physically possible.

A body's inertial is possible when its mass m [kg] is finite and >= 0 (0 only with a zero
inertia: a massless body written out, as CAD exporters write intermediate links, the same as no
inertial at all) and its rotational inertia I [kg m^2] about the centre of mass is finite,
symmetric, positive semi-definite, and its principal moments I1, I2, I3 satisfy the triangle
inequality I1 + I2 >= I3 (for each permutation): with I_k = integral of rho (r^2 - x_k^2) dV and
a density rho >= 0, I1 + I2 - I3 = 2 integral of rho x_3^2 dV >= 0. The triangle inequality
implies the moments are >= 0 (add two of the three) and holds with equality for a flat plate; a
point mass (I = 0) and a thin rod (one zero moment) are possible, and the Delta's own URDF writes
its rods that way, so semi-definite, not definite, is the rule.

Tolerance (:data:`INERTIA_RTOL`): a moment may miss these inequalities by 1e-5 of the largest
principal moment. CAD exports and hand-written files round: a flat plate (I1 + I2 = I3 exactly)
printed with 6 significant digits (``%g``) misses by up to 5e-7 (I1 + I2 + I3) = 1e-6 I3, and
the eigenvalues of a rounded full tensor move by as much; 1e-5 is ten times that. A real error
(a moment in the wrong unit, a lost sign, a product of inertia that swamps the moments) misses
by orders of magnitude more, and a violation below 1e-5 changes no simulated number that
matters. (MuJoCo's compiler checks the same inequality to 1e-15 kg m^2 absolute.)

URDF: urdfdom silently drops an ``<inertial>`` whose mass or inertia it cannot parse (``heavy``,
``nan``, ``inf``, empty), leaving the link massless, and accepts a negative mass. So the text is
read here, with lxml (line numbers), before Pinocchio builds the tree
(:func:`delta_pin.model.urdf_tree.build_urdf_tree`, which every URDF path takes). A link without
an ``<inertial>`` is allowed: a massless link (a frame, a joint's intermediate body).

MJCF: MuJoCo refuses most impossible inertials of moving bodies itself (its message, one line
naming the file, body and line: :func:`delta_pin.model.mjcf_loader.read_mjcf`), but it silently
clamps a negative mass or moment of a body without joints to 0 and accepts an infinite mass.
:func:`check_mjcf_inertials` reads the file's ``<inertial>`` elements before MuJoCo compiles it,
:func:`check_compiled_inertials` every compiled body after (MuJoCo infers masses from geoms;
a body with neither geoms nor inertial carries no mass).

Errors are :class:`~delta_pin.errors.URDFConventionError`, one line naming the file, the line,
the link or body, the element and the value, and what would work.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from delta_pin.errors import URDFConventionError

__all__ = [
    "INERTIA_RTOL",
    "MASSLESS_RATIO",
    "check_compiled_inertials",
    "check_mjcf_inertials",
    "check_urdf_inertials",
    "inertial_problem",
    "massless_bodies",
]

INERTIA_RTOL = 1e-5  # of the largest principal moment: 10 x 6-digit rounding (module docstring)
MASSLESS_RATIO = 1e-6  # a moving body lighter than this fraction of the robot's mass is "massless"

_URDF_MOMENTS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
_MASS_RULE = "a mass must be a finite number >= 0 [kg]"
_URDF_MASSLESS = "leave out the link's <inertial> for a massless link"


def inertial_problem(mass: float, inertia: np.ndarray) -> str | None:
    """What makes an inertial physically impossible (module docstring), else ``None``.

    Args:
        mass: the body's mass [kg].
        inertia: its rotational inertia (3, 3) about the centre of mass [kg m^2].

    Returns:
        the reason, a clause that starts with what is wrong and says what would work.
    """
    if not (math.isfinite(mass) and mass >= 0.0):
        return f"mass {mass:g} [kg]: {_MASS_RULE}"
    inertia = np.asarray(inertia, dtype=float)
    if not np.all(np.isfinite(inertia)):
        return "the inertia is not finite: each moment must be a finite number [kg m^2]"
    if mass == 0.0 and np.any(inertia != 0.0):
        return "a body of mass 0 has no inertia: give its mass, or zero moments (a massless body)"
    scale = float(np.abs(inertia).max())
    tolerance = INERTIA_RTOL * scale
    if float(np.abs(inertia - inertia.T).max()) > tolerance:
        return "the inertia matrix is not symmetric"
    moments = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))  # ascending principal moments
    listed = ", ".join(f"{value:.6g}" for value in moments)
    if moments[0] < -tolerance:
        return (
            f"the inertia matrix is not positive semi-definite (principal moments {listed} [kg m^2]): "
            "a body's principal moments are >= 0; check the moments' signs and the products of inertia"
        )
    small, middle, large = moments
    if small + middle < large - tolerance:
        return (
            f"its principal moments {listed} [kg m^2] break the triangle inequality "
            f"({small:.6g} + {middle:.6g} < {large:.6g}): no mass distribution has them; each principal "
            f"moment must be <= the sum of the other two (to {INERTIA_RTOL:g} of the largest)"
        )
    return None


def _where(source: str, element: etree._Element) -> str:
    expanded = " (expanded)" if source.endswith(".xacro") else ""
    return f"{source}{expanded} line {element.sourceline}"


def _attributes(element: etree._Element, names: tuple[str, ...] | None = None) -> str:
    shown = names if names is not None else tuple(element.keys())
    return "".join(f' {name}="{element.get(name)}"' for name in shown if element.get(name) is not None)


def _number(text: str | None) -> float | None:
    """A finite float of an attribute's text, else ``None`` (``heavy``, ``nan``, ``inf``, empty)."""
    try:
        value = float((text or "").strip())
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def check_urdf_inertials(text: str, source: str) -> None:
    """Check every link's ``<inertial>`` of URDF text (module docstring).

    Args:
        text: the URDF (xacro expanded); text lxml cannot parse is left to the caller's error.
        source: the file's name, for messages.

    Raises:
        URDFConventionError: a mass or moment that is missing, not a finite number, or
            physically impossible (one line: file, line, link, element, what would work).
    """
    try:
        root = etree.fromstring(text.encode())
    except etree.XMLSyntaxError:
        return
    for link in root.iter("link"):
        name = link.get("name")
        for inertial in link.findall("inertial"):
            mass_element = inertial.find("mass")
            if mass_element is None:
                raise URDFConventionError(
                    f"{_where(source, inertial)}: link {name!r} <inertial> has no <mass value=...>: give "
                    f"one ({_MASS_RULE}), or {_URDF_MASSLESS}"
                )
            mass = _number(mass_element.get("value"))
            if mass is None or mass < 0.0:
                dropped = (
                    " (urdfdom would drop this <inertial>: the link would weigh nothing)"
                    if mass is None
                    else ""
                )
                raise URDFConventionError(
                    f"{_where(source, mass_element)}: link {name!r} <mass{_attributes(mass_element)}>"
                    f"{dropped}: {_MASS_RULE}; or {_URDF_MASSLESS}"
                )
            inertia_element = inertial.find("inertia")
            if inertia_element is None:
                raise URDFConventionError(
                    f"{_where(source, inertial)}: link {name!r} <inertial> has no <inertia>: give "
                    f"<inertia {' '.join(f'{m}=...' for m in _URDF_MOMENTS)}/> [kg m^2] about the centre "
                    "of mass"
                )
            values = {}
            for moment in _URDF_MOMENTS:
                values[moment] = _number(inertia_element.get(moment))
                if values[moment] is None:
                    raise URDFConventionError(
                        f"{_where(source, inertia_element)}: link {name!r} <inertia "
                        f'{moment}="{inertia_element.get(moment, "")}">: {moment} must be a finite number '
                        f"[kg m^2] (urdfdom needs all six of {', '.join(_URDF_MOMENTS)})"
                    )
            xx, xy, xz, yy, yz, zz = (values[moment] for moment in _URDF_MOMENTS)
            problem = inertial_problem(mass, np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]))
            if problem is not None:
                raise URDFConventionError(
                    f"{_where(source, inertia_element)}: link {name!r} "
                    f"<inertia{_attributes(inertia_element, _URDF_MOMENTS)}>: {problem}"
                )


def _mjcf_root(path: Path) -> etree._Element | None:
    try:
        return etree.parse(str(path)).getroot()
    except (etree.XMLSyntaxError, OSError):
        return None


def _compiler_flag(root: etree._Element, name: str) -> bool:
    return any(compiler.get(name, "").strip().lower() == "true" for compiler in root.iter("compiler"))


def _mjcf_inertia(inertial: etree._Element) -> tuple[np.ndarray | None, str]:
    """(the (3, 3) inertia [kg m^2] of an MJCF ``<inertial>``, or ``None`` if a number does not
    parse; the attribute it came from)."""
    for attribute, count in (("fullinertia", 6), ("diaginertia", 3)):
        text = inertial.get(attribute)
        if text is None:
            continue
        numbers = [_number(word) for word in text.split()]
        if len(numbers) != count or any(value is None for value in numbers):
            return None, attribute
        if count == 3:
            return np.diag(numbers), attribute
        xx, yy, zz, xy, xz, yz = numbers  # MuJoCo's order: M(1,1), M(2,2), M(3,3), M(1,2), M(1,3), M(2,3)
        return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]), attribute
    return np.zeros((3, 3)), ""  # MuJoCo's own error names the missing inertia


def check_mjcf_inertials(path: str | Path, source: str) -> None:
    """Check every ``<inertial>`` element of an MJCF file, before MuJoCo compiles it (module
    docstring). Files under ``<include>`` are covered by :func:`check_compiled_inertials`. With
    ``<compiler inertiafromgeom="true">`` the elements are ignored (MuJoCo ignores them); with
    ``balanceinertia="true"`` the triangle inequality is left to MuJoCo, which balances it.

    Args:
        path: the ``.xml`` file; a file lxml cannot parse is left to MuJoCo's error.
        source: its name, for messages.

    Raises:
        URDFConventionError: a mass or inertia that is not a finite number or is physically
            impossible (one line: file, line, body, element, what would work).
    """
    root = _mjcf_root(Path(path))
    if root is None or _compiler_flag(root, "inertiafromgeom"):
        return
    balanced = _compiler_flag(root, "balanceinertia")
    for inertial in root.iter("inertial"):
        body = inertial.getparent()
        label = f"body {body.get('name')!r}" if body.get("name") else f"an unnamed <{body.tag}>"
        where = f"{_where(source, inertial)}: {label} <inertial"
        mass = _number(inertial.get("mass"))
        if mass is None or mass < 0.0:
            raise URDFConventionError(
                f'{where} mass="{inertial.get("mass", "")}">: {_MASS_RULE}; or leave out the <inertial> '
                "(MuJoCo then infers the mass from the body's geoms)"
            )
        inertia, attribute = _mjcf_inertia(inertial)
        if inertia is None:
            raise URDFConventionError(
                f'{where} {attribute}="{inertial.get(attribute)}">: {attribute} must be '
                f"{6 if attribute == 'fullinertia' else 3} finite numbers [kg m^2]"
            )
        problem = inertial_problem(mass, inertia)
        if problem is not None and (not balanced or "triangle" not in problem):
            raise URDFConventionError(f'{where} {attribute}="{inertial.get(attribute)}">: {problem}')


def check_compiled_inertials(m, path: str | Path, source: str) -> None:
    """Check every body of a compiled ``mujoco.MjModel`` (module docstring): mass finite and
    >= 0 [kg], principal moments ``body_inertia`` finite and possible [kg m^2].

    Args:
        m: the compiled model.
        path: its file (to give the body's line).
        source: the file's name, for messages.

    Raises:
        URDFConventionError: an impossible compiled inertial (one line naming the body).
    """
    import mujoco

    root = _mjcf_root(Path(path))
    for b in range(1, m.nbody):
        problem = inertial_problem(float(m.body_mass[b]), np.diag(np.asarray(m.body_inertia[b], dtype=float)))
        if problem is None:
            continue
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or ""
        element = None
        if root is not None and name:
            element = next((e for e in root.iter("body") if e.get("name") == name), None)
        where = _where(source, element) if element is not None else source
        raise URDFConventionError(
            f"{where}: body {name or f'#{b}'!r} as MuJoCo compiled it (from its <inertial> or geoms): "
            f"{problem}"
        )


def massless_bodies(model: pin.Model, ratio: float = MASSLESS_RATIO) -> list[tuple[str, float]]:
    """The moving bodies that carry no mass: (label, mass [kg]) of each joint's body (its link and
    the links fixed to it) whose mass is 0 or below ``ratio`` of the robot's moving mass [kg].

    A body is labelled by its first BODY frame, quoted (the URDF link, the MJCF body), else by its
    joint.
    """
    total = sum(float(model.inertias[j].mass) for j in range(1, model.njoints))
    found = []
    for j in range(1, model.njoints):
        mass = float(model.inertias[j].mass)
        if mass <= ratio * total:
            frame = next(
                (f.name for f in model.frames if f.parentJoint == j and f.type == pin.FrameType.BODY), None
            )
            found.append((repr(frame) if frame else f"the body of joint {model.names[j]!r}", mass))
    return found

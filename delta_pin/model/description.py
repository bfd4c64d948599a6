"""The robot description: compile the parametric xacro, read the Delta's numbers FROM the URDF.

One source of truth: geometry and inertia live in ``urdf/delta.urdf.xacro``. This module
compiles it with xacrodoc (no ROS) and reads the parameters back from the compiled URDF -- joint
placements and link inertials through Pinocchio's own URDF parser, the ``<constraint>`` loop
closures and the ``<delta_pin_friction>`` element with lxml (every URDF parser ignores them) --
so that a hand-written URDF that follows the convention of docs/architecture.md section 3 works too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from delta_pin.errors import (
    InvalidParameterError,
    NonFiniteError,
    URDFConventionError,
    XacroArgumentError,
)
from delta_pin.model.closures import Closure, read_urdf_constraints
from delta_pin.model.inertials import check_urdf_inertials

__all__ = [
    "GRAVITY",
    "DeltaDescription",
    "DeltaParameters",
    "StribeckParameters",
    "chain_azimuths",
    "compile_urdf",
    "default_xacro_path",
    "read_description",
    "xacro_arguments",
]

GRAVITY = 9.8  # [m/s^2] the paper's value (Table 1); Pinocchio's default is 9.81
N_CHAINS = 3
FOREARM_INERTIA_MODELS = ("lumped", "rod")
VISUAL_STYLES = ("primitive", "mesh")  # xacro argument visuals: URDF shapes or the packaged meshes
# xacro arguments that are physical quantities and must be strictly positive
_POSITIVE_ARGUMENTS = ("R", "r", "l_a", "l_b", "m_a", "m_b", "m_o", "r_a", "v_s")
# friction coefficients may be zero (no friction of that kind) but not negative
_NON_NEGATIVE_ARGUMENTS = ("mu_s", "mu_d", "mu_v")
_CONVENTION_TOL = 1e-9  # [m] or [rad]: how far a hand-written URDF may stray from the convention


def chain_azimuths() -> np.ndarray:
    """Azimuths phi_i = (2i/3 - 1/2) pi of chains i = 1, 2, 3 [rad] (eq. 2, Fig. 3)."""
    return np.array([(2.0 * i / 3.0 - 0.5) * math.pi for i in range(1, N_CHAINS + 1)])


@dataclass(frozen=True)
class StribeckParameters:
    """Stribeck friction of the active joints (eqs. 11-12, Table 1).

    Attributes:
        r_a: friction arm of the active joints [m].
        v_s: Stribeck velocity, read as the sliding speed at the friction arm [m/s]: the
            exponent of eq. 12 is (alpha_dot r_a / v_s)^2 (docs/architecture.md section 4, erratum 6).
        mu_s: coefficient of static friction [-] (F_s = mu_s F_n).
        mu_d: coefficient of Coulomb friction [-] (F_c = mu_d F_n).
        mu_v: coefficient of viscous friction [N s/m] (torque mu_v alpha_dot r_a).
    """

    r_a: float
    v_s: float
    mu_s: float
    mu_d: float
    mu_v: float


@dataclass(frozen=True)
class DeltaParameters:
    """The Delta's numbers, as read from the URDF (Table 1 for the default robot). SI units.

    Attributes:
        R: radius of the fixed platform (base joints A_i) [m].
        r: radius of the moving platform (attachment points C_i) [m].
        l_a: upper (active) arm length [m].
        l_b: forearm (passive arm) length [m].
        m_a: upper arm mass [kg].
        m_b: forearm mass [kg].
        m_o: platform mass [kg].
        g: gravity acceleration [m/s^2].
        forearm_inertia: ``"lumped"`` (two point masses, the paper's model is exact), ``"rod"``
            (uniform rod) or ``"custom"`` (anything else found in the URDF).
        upper_arm_inertia: upper arm inertia about its hinge [kg m^2] (m_a l_a^2 / 3 for a
            uniform rod, which the analytic model assumes).
        friction: Stribeck parameters, or ``None`` when the URDF carries none.
    """

    R: float
    r: float
    l_a: float
    l_b: float
    m_a: float
    m_b: float
    m_o: float
    g: float = GRAVITY
    forearm_inertia: str = "lumped"
    upper_arm_inertia: float | None = None
    friction: StribeckParameters | None = None

    @property
    def platform_equivalent_mass(self) -> float:
        """m_o + 3/2 m_b [kg]: the mass that moves with the platform (eqs. 7-9)."""
        return self.m_o + 1.5 * self.m_b

    @property
    def arm_equivalent_inertia(self) -> float:
        """(1/3 m_a + 1/2 m_b) l_a^2 [kg m^2]: per-joint inertia of eq. 7."""
        return (self.m_a / 3.0 + self.m_b / 2.0) * self.l_a**2


@dataclass(frozen=True)
class DeltaDescription:
    """A compiled Delta URDF together with what was read from it."""

    urdf: str
    params: DeltaParameters
    closures: tuple[Closure, ...]  # on the joints of Pinocchio's model of ``urdf``
    active_joints: tuple[str, ...] = ("active_1", "active_2", "active_3")
    platform_joints: tuple[str, ...] = ("platform_x", "platform_y", "platform_z")
    platform_link: str = "platform"
    base_dir: str | None = None  # the URDF's folder: relative mesh filenames are resolved from it


def default_xacro_path() -> Path:
    """Path of the packaged ``delta.urdf.xacro``."""
    return Path(str(resources.files("delta_pin") / "urdf" / "delta.urdf.xacro"))


@cache
def _xacro_text() -> str:
    return default_xacro_path().read_text()


@cache
def xacro_arguments() -> dict[str, str]:
    """The xacro arguments of the packaged Delta and their default values (as strings)."""
    root = etree.fromstring(_xacro_text().encode())
    ns = {"xacro": "http://www.ros.org/wiki/xacro"}
    return {el.get("name"): el.get("default") for el in root.findall("xacro:arg", ns)}


def _check_xacro_arguments(args: dict[str, object]) -> dict[str, str]:
    known = xacro_arguments()
    checked: dict[str, str] = {}
    for name, value in args.items():
        if name not in known:
            raise XacroArgumentError(
                f"unknown xacro argument {name!r}={value!r}; known arguments: {', '.join(known)}"
            )
        if name == "forearm_inertia":
            if value not in FOREARM_INERTIA_MODELS:
                raise XacroArgumentError(
                    f"xacro argument forearm_inertia={value!r} must be one of "
                    f"{', '.join(FOREARM_INERTIA_MODELS)}"
                )
            checked[name] = str(value)
            continue
        if name == "visuals":
            if value not in VISUAL_STYLES:
                raise XacroArgumentError(
                    f"xacro argument visuals={value!r} must be one of {', '.join(VISUAL_STYLES)}"
                )
            checked[name] = str(value)
            continue
        if name == "mesh_uri":
            text = str(value)
            if not text or any(c.isspace() or c in "<>&\"'" for c in text):
                raise XacroArgumentError(
                    f"xacro argument mesh_uri={value!r} must be a folder or package:// URI "
                    "without spaces or XML characters, e.g. package://delta_pin/urdf/meshes"
                )
            checked[name] = text.rstrip("/")
            continue
        try:
            number = float(value)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            raise XacroArgumentError(f"xacro argument {name}={value!r} is not a number") from None
        if not math.isfinite(number):
            raise XacroArgumentError(f"xacro argument {name}={value!r} is not finite")
        if name in _POSITIVE_ARGUMENTS and number <= 0.0:
            raise XacroArgumentError(f"xacro argument {name}={value!r} must be > 0")
        if name in _NON_NEGATIVE_ARGUMENTS and number < 0.0:
            raise XacroArgumentError(f"xacro argument {name}={value!r} must be >= 0")
        checked[name] = repr(number)
    return checked


@cache
def _compile_cached(items: tuple[tuple[str, str], ...]) -> str:
    from xacrodoc import XacroDoc  # imported lazily: only needed to compile

    doc = XacroDoc.from_string(_xacro_text(), subargs=dict(items), resolve_packages=False)
    return doc.to_urdf_string()


def expand_xacro(path: str | Path, subargs: dict[str, str] | None = None) -> str:
    """The URDF text of a user's ``.xacro`` file (with ``subargs``, its xacro arguments).

    Raises:
        URDFConventionError: xacro cannot expand the file (not XML, an undefined property or
            macro parameter, a missing include ...): the message names the file and xacro's reason.
    """
    from xacrodoc import XacroDoc  # imported lazily: only needed to compile

    try:
        return XacroDoc.from_file(str(path), subargs=subargs).to_urdf_string()
    except Exception as exc:  # xacro's own XacroException, expat's ExpatError, a NameError ...
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise URDFConventionError(
            f"xacro file {str(path)!r} does not expand ({type(exc).__name__}: {reason}); fix the file"
        ) from None


def compile_urdf(**xacro_args: float | str) -> str:
    """Compile the packaged Delta xacro with the given arguments and return the URDF text.

    Args:
        **xacro_args: any of :func:`xacro_arguments` (SI units), e.g. ``l_a=0.25``,
            ``forearm_inertia="rod"``.

    Raises:
        XacroArgumentError: an unknown argument, or a value that is not a finite number of the
            right sign (named in the message).
    """
    checked = _check_xacro_arguments(xacro_args)
    return _compile_cached(tuple(sorted(checked.items())))


def _floats(text: str | None, what: str, count: int = 3) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in (text or "").split())
    except ValueError:
        raise URDFConventionError(f"{what}: {text!r} is not a list of numbers") from None
    if len(values) != count:
        raise URDFConventionError(f"{what}: expected {count} numbers, got {text!r}")
    if not all(math.isfinite(v) for v in values):
        raise NonFiniteError(f"{what}: {text!r} holds a non-finite number")
    return values


def _parse_friction(root: etree._Element) -> StribeckParameters | None:
    el = root.find("delta_pin_friction")
    if el is None:
        return None
    values = {}
    for name in ("r_a", "v_s", "mu_s", "mu_d", "mu_v"):
        (values[name],) = _floats(el.get(name), f"<delta_pin_friction> attribute {name}", 1)
    return StribeckParameters(**values)


def _require_positive(name: str, value: float) -> float:
    if not math.isfinite(value):
        raise NonFiniteError(f"{name}={value!r} is not finite")
    if value <= 0.0:
        raise InvalidParameterError(f"{name}={value!r} must be > 0")
    return value


def _same_for_all_chains(name: str, values: list[float]) -> float:
    if max(values) - min(values) > _CONVENTION_TOL * max(1.0, abs(values[0])):
        raise URDFConventionError(
            f"{name} differs between the three chains ({values}); delta-pin models a symmetric Delta"
        )
    return values[0]


def read_description(urdf: str, g: float = GRAVITY, base_dir: str | Path | None = None) -> DeltaDescription:
    """Read a Delta's parameters and loop closures from URDF text.

    Geometry comes from joint placements (A_i from ``active_i``, l_a from ``elbow_i_pitch``),
    masses and inertias from link inertials, l_b and r from the ``<constraint>`` origins.

    Args:
        urdf: URDF text following docs/architecture.md section 3.
        g: gravity acceleration [m/s^2] (the URDF does not carry it).
        base_dir: the URDF's folder, from which relative mesh filenames are resolved (drawing only).

    Raises:
        URDFConventionError: a missing joint or link, a closure naming a missing link, a
            geometry that does not follow the convention (named in the message), or an impossible
            inertial (:mod:`delta_pin.model.inertials`).
        InvalidParameterError: a non-positive length or mass.
    """
    _require_positive("g", g)
    try:
        root = etree.fromstring(urdf.encode())
    except etree.XMLSyntaxError as exc:
        raise URDFConventionError(f"the URDF is not valid XML: {exc}") from None
    check_urdf_inertials(urdf, "the URDF")  # before urdfdom drops an unreadable one
    try:
        model = pin.buildModelFromXML(urdf)
    except (RuntimeError, ValueError) as exc:
        raise URDFConventionError(f"Pinocchio could not parse the URDF: {exc}") from None
    closures = tuple(read_urdf_constraints(urdf, model))

    def joint(name: str) -> int:
        if not model.existJointName(name):
            raise URDFConventionError(f"the URDF has no joint {name!r} (docs/architecture.md section 3)")
        return model.getJointId(name)

    R_values, l_a_values, l_b_values, r_values = [], [], [], []
    m_a_values, m_b_values, arm_inertia, forearm_across = [], [], [], []
    phis = chain_azimuths()
    for i, phi in zip(range(1, N_CHAINS + 1), phis):
        placement = model.jointPlacements[joint(f"active_{i}")]
        A = placement.translation
        expected_rotation = pin.rpy.rpyToMatrix(0.0, 0.0, phi)
        if (
            abs(A[2]) > _CONVENTION_TOL
            or abs(math.atan2(A[1], A[0]) - math.atan2(math.sin(phi), math.cos(phi))) > 1e-6
            or np.abs(placement.rotation - expected_rotation).max() > 1e-6
        ):
            raise URDFConventionError(
                f"joint active_{i} is not at azimuth phi_{i} = {phi:.6f} rad in the base plane "
                f"with its frame yawed by phi_{i} (found origin {A.round(6).tolist()})"
            )
        R_values.append(float(np.hypot(A[0], A[1])))
        l_a_values.append(float(np.linalg.norm(model.jointPlacements[joint(f"elbow_{i}_pitch")].translation)))
        joint(f"elbow_{i}_roll")
        arm = model.inertias[joint(f"active_{i}")]
        m_a_values.append(float(arm.mass))
        arm_inertia.append(float(arm.inertia[1, 1] + arm.mass * (arm.lever[0] ** 2 + arm.lever[2] ** 2)))
        forearm = model.inertias[joint(f"elbow_{i}_roll")]
        m_b_values.append(float(forearm.mass))
        forearm_across.append(float(forearm.inertia[0, 0]))
        # the forearm's tip and the platform's anchor C_i, each in its body's (joint's) frame
        forearm_joint, platform_joint = joint(f"elbow_{i}_roll"), joint("platform_z")
        ends = None
        for c in closures:
            if c.kind == "3d" and {c.joint1, c.joint2} == {forearm_joint, platform_joint}:
                ends = (
                    (c.placement1, c.placement2)
                    if c.joint1 == forearm_joint
                    else (c.placement2, c.placement1)
                )
        if ends is None:
            raise URDFConventionError(f"no <constraint type='point'> joins forearm_{i} to the platform")
        l_b_values.append(float(np.linalg.norm(ends[0].translation)))
        r_values.append(float(np.linalg.norm(ends[1].translation)))
    for name in ("platform_x", "platform_y", "platform_z"):
        joint(name)
    platform = model.inertias[joint("platform_z")]

    R = _require_positive("R", _same_for_all_chains("R", R_values))
    r = _require_positive("r", _same_for_all_chains("r", r_values))
    l_a = _require_positive("l_a", _same_for_all_chains("l_a", l_a_values))
    l_b = _require_positive("l_b", _same_for_all_chains("l_b", l_b_values))
    m_a = _require_positive("m_a", _same_for_all_chains("m_a", m_a_values))
    m_b = _require_positive("m_b", _same_for_all_chains("m_b", m_b_values))
    m_o = _require_positive("m_o", float(platform.mass))
    across = _same_for_all_chains("forearm inertia", forearm_across)
    if math.isclose(across, m_b * l_b**2 / 4.0, rel_tol=1e-9):
        forearm_model = "lumped"
    elif math.isclose(across, m_b * l_b**2 / 12.0, rel_tol=1e-9):
        forearm_model = "rod"
    else:
        forearm_model = "custom"
    params = DeltaParameters(
        R=R,
        r=r,
        l_a=l_a,
        l_b=l_b,
        m_a=m_a,
        m_b=m_b,
        m_o=m_o,
        g=float(g),
        forearm_inertia=forearm_model,
        upper_arm_inertia=_same_for_all_chains("upper arm inertia", arm_inertia),
        friction=_parse_friction(root),
    )
    return DeltaDescription(
        urdf=urdf, params=params, closures=closures, base_dir=None if base_dir is None else str(base_dir)
    )

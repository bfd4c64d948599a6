"""Write the example closed-chain robots shipped in delta_pin/robots/ (docs/architecture.md section 13).

* ``five_bar.urdf``   a planar five-bar linkage, URDF with a ``<constraint type="point">``;
* ``three_rrr.urdf``  a 3-RRR planar parallel robot closed by one point and one weld
  ``<constraint>``, and ``three_rrr.xml``, the same robot as MJCF (``connect`` + ``weld``);
* ``delta.xml``       the Table-1 Delta as MJCF (:func:`delta_pin.model.mjcf.delta_mjcf`) with
  three ``<motor>`` actuators;
* ``delta_gepetto/robot.urdf`` + ``robot.yaml``: the Table-1 Delta in Gepetto's convention (the
  xacro's URDF without ``<constraint>``, the closure points as fixed-joint child links, the
  pairs and the motors in ``robot.yaml``);
* ``stewart.urdf``    a 6-UPS Stewart-Gough platform (six prismatic actuators), URDF with five
  ``<constraint type="point">``, and ``stewart.xml``, the same robot as MJCF (``connect``,
  ``ball``, ``motor`` on the slide joints);
* ``delta_ballrods.xml`` the Table-1 Delta as MJCF the common way: each forearm a parallelogram of
  two rods between ball joints, the platform on one rod's ball joint, five ``connect`` and six
  idle rod spins (:func:`delta_ballrods_xml`); checked number by number, like the Stewart
  platform's (:func:`delta_ballrods_files`, tests/model/test_delta_ballrods.py).

Every number is written with 17 significant digits, so each file is the robot exactly; the tests
check that this script reproduces the shipped files: byte for byte for those of :func:`files`,
number by number (to 1e-12) for the Stewart platform's (:func:`stewart_files`), whose numbers
come from sin and cos.

Run from the repository root: ``python scripts/make_example_robots.py [OUT_DIR]``.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

ROBOTS_DIR = Path(__file__).resolve().parents[1] / "delta_pin" / "robots"

# the MJCF Delta's inertia floor [kg m^2]: MuJoCo needs positive principal moments, the xacro's
# rods have none about their axis; 1e-12 keeps the reduced M within ~2e-12 of the xacro's (the
# package default, 1e-9, would not meet the 1e-10 check)
DELTA_INERTIA_FLOOR = 1e-12


def _n(values) -> str:
    return " ".join(f"{float(v):.17g}" for v in np.ravel(values))


def _rod_inertia(mass: float, vector: np.ndarray, radius: float) -> np.ndarray:
    """Inertia [kg m^2] about the centre of a uniform rod of the given mass and radius along ``vector``."""
    length = float(np.linalg.norm(vector))
    u = np.asarray(vector, float) / length
    across = mass * (3.0 * radius**2 + length**2) / 12.0
    along = mass * radius**2 / 2.0
    return across * (np.eye(3) - np.outer(u, u)) + along * np.outer(u, u)


def _urdf_inertial(mass: float, com, inertia: np.ndarray, indent: str = "    ") -> str:
    i = inertia
    return (
        f"{indent}<inertial>\n"
        f'{indent}  <origin xyz="{_n(com)}"/>\n'
        f'{indent}  <mass value="{mass:.17g}"/>\n'
        f'{indent}  <inertia ixx="{i[0, 0]:.17g}" ixy="{i[0, 1]:.17g}" ixz="{i[0, 2]:.17g}" '
        f'iyy="{i[1, 1]:.17g}" iyz="{i[1, 2]:.17g}" izz="{i[2, 2]:.17g}"/>\n'
        f"{indent}</inertial>\n"
    )


def _urdf_joint(name: str, parent: str, child: str, xyz, kind: str = "revolute") -> str:
    limit = (
        '\n    <limit effort="100" lower="-3.1415926535897931" upper="3.1415926535897931" velocity="100"/>'
    )
    return (
        f'  <joint name="{name}" type="{kind}">\n'
        f'    <parent link="{parent}"/>\n    <child link="{child}"/>\n'
        f'    <origin xyz="{_n(xyz)}"/>' + ('\n    <axis xyz="0 1 0"/>' + limit if kind == "revolute" else "")
        + "\n  </joint>\n"
    )  # fmt: skip


def _transmission(joint: str) -> str:
    return (
        f'  <transmission name="{joint}_transmission">\n'
        "    <type>transmission_interface/SimpleTransmission</type>\n"
        f'    <joint name="{joint}"><hardwareInterface>hardware_interface/EffortJointInterface'
        "</hardwareInterface></joint>\n"
        f'    <actuator name="{joint}_motor"><mechanicalReduction>1</mechanicalReduction></actuator>\n'
        "  </transmission>\n"
    )


# ---------------------------------------------------------------------------------------- five-bar
FIVE_BAR = {"base": 0.2, "proximal": 0.25, "distal": 0.3, "m_proximal": 0.2, "m_distal": 0.15, "radius": 0.01}


def five_bar_urdf() -> str:
    """The planar five-bar linkage (module docstring): motion in the x-z plane, joint axes along
    y, gravity -z (in the plane; Pinocchio's default 9.81 m/s^2 where no g is given)."""
    p = FIVE_BAR
    text = (
        '<?xml version="1.0"?>\n'
        "<!--\n"
        "  Planar five-bar linkage (delta-pin example, written by scripts/make_example_robots.py).\n"
        f"  Two actuated revolute joints active_1, active_2 on the base, {p['base']} m apart on x; proximal\n"
        f"  links {p['proximal']} m ({p['m_proximal']} kg), distal links {p['distal']} m "
        f"({p['m_distal']} kg), uniform rods of radius {p['radius']} m.\n"
        "  Motion in the x-z plane (every axis along y), gravity along -z, i.e. in the plane.\n"
        "  At zero angles every link hangs along -z; the point constraint 'distal_tips' closes the\n"
        "  loop at the distal tips (the passive joints then bend the distal links inwards), and the\n"
        "  frame 'tip' (a fixed joint on distal_1) marks the end effector. Units: SI.\n"
        "-->\n"
        '<robot name="five_bar">\n  <link name="base"/>\n'
    )
    down = np.array([0.0, 0.0, -1.0])
    for i, side in ((1, -1.0), (2, 1.0)):
        for link, length, mass, parent, xyz, joint in (
            (
                f"proximal_{i}",
                p["proximal"],
                p["m_proximal"],
                "base",
                [side * p["base"] / 2, 0, 0],
                f"active_{i}",
            ),
            (
                f"distal_{i}",
                p["distal"],
                p["m_distal"],
                f"proximal_{i}",
                [0, 0, -p["proximal"]],
                f"passive_{i}",
            ),
        ):
            text += _urdf_joint(joint, parent, link, xyz)
            inertia = _rod_inertia(mass, down * length, p["radius"])
            text += f'  <link name="{link}">\n' + _urdf_inertial(mass, down * length / 2, inertia)
            text += (
                f'    <visual>\n      <origin xyz="{_n(down * length / 2)}"/>\n'
                f'      <geometry><cylinder radius="{p["radius"]}" length="{length}"/></geometry>\n'
                "    </visual>\n  </link>\n"
            )
    text += _urdf_joint("tip_joint", "distal_1", "tip", [0, 0, -p["distal"]], kind="fixed")
    text += '  <link name="tip"/>\n'
    text += (
        '  <constraint name="distal_tips" type="point">\n'
        f'    <parent link="distal_1"/>\n    <parent_origin xyz="0 0 {-p["distal"]}"/>\n'
        f'    <child link="distal_2"/>\n    <child_origin xyz="0 0 {-p["distal"]}"/>\n'
        "  </constraint>\n"
    )
    text += _transmission("active_1") + _transmission("active_2")
    return text + "</robot>\n"


# ---------------------------------------------------------------------------------------- 3-RRR
THREE_RRR = {
    "base_radius": 0.3, "platform_radius": 0.08, "proximal": 0.15, "distal": 0.15,
    "m_proximal": 0.2, "m_distal": 0.15, "m_platform": 0.3, "m_collar": 0.02, "radius": 0.01,
}  # fmt: skip


def three_rrr_geometry() -> dict:
    """World points of the 3-RRR at its zero configuration [m] (x-z plane): base joints B_i,
    elbows E_i, platform vertices P_i (the platform centred at the origin, unrotated)."""
    p = THREE_RRR
    points = {}
    for i in range(3):
        phi = math.pi / 2 + 2 * math.pi * i / 3
        d = np.array([math.cos(phi), 0.0, math.sin(phi)])
        B, P = p["base_radius"] * d, p["platform_radius"] * d
        half = (p["base_radius"] - p["platform_radius"]) / 2
        h = math.sqrt(p["proximal"] ** 2 - half**2)  # L1 = L2: the elbow over the midpoint
        normal = np.array([-d[2], 0.0, d[0]])  # d turned +90 degrees in the plane
        points[i + 1] = (B, (B + P) / 2 + h * normal, P)
    return points


def _platform_inertia() -> np.ndarray:
    m, r = THREE_RRR["m_platform"], THREE_RRR["platform_radius"]
    return np.diag([m * r**2 / 4, m * r**2 / 2, m * r**2 / 4])  # a disc in the x-z plane


def three_rrr_urdf() -> str:
    """The 3-RRR planar robot as URDF: chain 1 carries the platform (joint wrist_1); chain 2's
    distal tip is held to platform vertex 2 by a point constraint (a revolute in the plane);
    chain 3 ends in joint wrist_3 and a collar welded to the platform at vertex 3."""
    p, pts = THREE_RRR, three_rrr_geometry()
    text = (
        '<?xml version="1.0"?>\n'
        "<!--\n"
        "  3-RRR planar parallel robot (delta-pin example, written by scripts/make_example_robots.py),\n"
        "  the same robot as three_rrr.xml. Motion in the x-z plane, axes along y, gravity -z.\n"
        f"  Base joints active_i on a circle of radius {p['base_radius']} m, links {p['proximal']} m and"
        f" {p['distal']} m, platform radius {p['platform_radius']} m.\n"
        "  Closures: 'vertex_2' (point: chain 2's distal tip on the platform) and 'vertex_3' (weld: the\n"
        "  collar after chain 3's wrist joint fixed to the platform). Every frame is world-aligned at\n"
        "  zero angles, which is an assembled configuration. Units: SI.\n"
        "-->\n"
        '<robot name="three_rrr">\n  <link name="base"/>\n'
    )
    for i in (1, 2, 3):
        B, E, P = pts[i]
        for link, joint, parent, xyz, vector, mass in (
            (f"proximal_{i}", f"active_{i}", "base", B, E - B, p["m_proximal"]),
            (f"distal_{i}", f"elbow_{i}", f"proximal_{i}", E - B, P - E, p["m_distal"]),
        ):
            text += _urdf_joint(joint, parent, link, xyz)
            text += f'  <link name="{link}">\n' + _urdf_inertial(
                mass, vector / 2, _rod_inertia(mass, vector, p["radius"])
            )
            text += "  </link>\n"
    _B1, E1, P1 = pts[1]
    text += _urdf_joint("wrist_1", "distal_1", "platform", P1 - E1)
    text += (
        '  <link name="platform">\n'
        + _urdf_inertial(p["m_platform"], -P1, _platform_inertia())
        + "  </link>\n"
    )
    _B3, E3, P3 = pts[3]
    text += _urdf_joint("wrist_3", "distal_3", "collar_3", P3 - E3)
    collar = np.eye(3) * 1e-6
    text += '  <link name="collar_3">\n' + _urdf_inertial(p["m_collar"], [0, 0, 0], collar) + "  </link>\n"
    _B2, E2, P2 = pts[2]
    text += (
        '  <constraint name="vertex_2" type="point">\n'
        f'    <parent link="distal_2"/>\n    <parent_origin xyz="{_n(P2 - E2)}"/>\n'
        f'    <child link="platform"/>\n    <child_origin xyz="{_n(P2 - P1)}"/>\n'
        "  </constraint>\n"
        '  <constraint name="vertex_3" type="weld">\n'
        '    <parent link="collar_3"/>\n    <parent_origin xyz="0 0 0"/>\n'
        f'    <child link="platform"/>\n    <child_origin xyz="{_n(P3 - P1)}"/>\n'
        "  </constraint>\n"
    )
    text += "".join(_transmission(f"active_{i}") for i in (1, 2, 3))
    return text + "</robot>\n"


def _mjcf_inertial(mass: float, com, inertia: np.ndarray, indent: str) -> str:
    i = inertia
    return (
        f'{indent}<inertial pos="{_n(com)}" mass="{mass:.17g}" '
        f'fullinertia="{_n([i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]])}"/>\n'
    )


def three_rrr_mjcf() -> str:
    """The 3-RRR as MJCF: the same tree; ``connect`` with body semantics (anchor on body 1) and
    ``weld`` with body semantics (anchor on body 2, relpose computed by MuJoCo at qpos0)."""
    p, pts = THREE_RRR, three_rrr_geometry()
    text = (
        '<mujoco model="three_rrr">\n'
        "  <!-- 3-RRR planar parallel robot, the same robot as three_rrr.urdf (written by\n"
        "       scripts/make_example_robots.py). Motion in the x-z plane, gravity -z. -->\n"
        '  <option timestep="0.001" integrator="RK4" gravity="0 0 -9.8100000000000005"/>\n'
        "  <worldbody>\n"
    )
    for i in (1, 2, 3):
        B, E, P = pts[i]
        ind = "    "
        text += f'{ind}<body name="proximal_{i}" pos="{_n(B)}">\n'
        text += f'{ind}  <joint name="active_{i}" type="hinge" axis="0 1 0"/>\n'
        text += _mjcf_inertial(
            p["m_proximal"], (E - B) / 2, _rod_inertia(p["m_proximal"], E - B, p["radius"]), ind + "  "
        )
        text += f'{ind}  <body name="distal_{i}" pos="{_n(E - B)}">\n'
        text += f'{ind}    <joint name="elbow_{i}" type="hinge" axis="0 1 0"/>\n'
        text += _mjcf_inertial(
            p["m_distal"], (P - E) / 2, _rod_inertia(p["m_distal"], P - E, p["radius"]), ind + "    "
        )
        if i == 1:
            text += f'{ind}    <body name="platform" pos="{_n(P - E)}">\n'
            text += f'{ind}      <joint name="wrist_1" type="hinge" axis="0 1 0"/>\n'
            text += _mjcf_inertial(p["m_platform"], -P, _platform_inertia(), ind + "      ")
            text += f'{ind}      <site name="centre" pos="{_n(-P)}"/>\n'
            text += f"{ind}    </body>\n"
        if i == 3:
            text += f'{ind}    <body name="collar_3" pos="{_n(P - E)}">\n'
            text += f'{ind}      <joint name="wrist_3" type="hinge" axis="0 1 0"/>\n'
            text += _mjcf_inertial(p["m_collar"], [0, 0, 0], np.eye(3) * 1e-6, ind + "      ")
            text += f"{ind}    </body>\n"
        text += f"{ind}  </body>\n{ind}</body>\n"
    _B1, _E1, P1 = pts[1]
    _B2, E2, P2 = pts[2]
    _B3, _E3, P3 = pts[3]
    text += (
        "  </worldbody>\n  <equality>\n"
        f'    <connect name="vertex_2" body1="distal_2" body2="platform" anchor="{_n(P2 - E2)}"/>\n'
        f'    <weld name="vertex_3" body1="collar_3" body2="platform" anchor="{_n(P3 - P1)}"/>\n'
        "  </equality>\n  <actuator>\n"
        + "".join(f'    <motor name="motor_{i}" joint="active_{i}"/>\n' for i in (1, 2, 3))
        + "  </actuator>\n</mujoco>\n"
    )
    return text


# ---------------------------------------------------------------------------------------- Delta
def delta_xml() -> str:
    """The Table-1 Delta (``dp.load_delta()``) as MJCF with three motors on the active joints."""
    import delta_pin as dp
    from delta_pin.model import mjcf

    text = mjcf.delta_mjcf(dp.load_delta(), inertia_floor=DELTA_INERTIA_FLOOR)
    motors = "".join(f'    <motor name="motor_{i}" joint="active_{i}"/>\n' for i in (1, 2, 3))
    header = (
        "<!-- The Table-1 Delta (dp.load_delta()) as MJCF, written by scripts/make_example_robots.py with\n"
        f"     delta_pin.model.mjcf.delta_mjcf (inertia floor {DELTA_INERTIA_FLOOR:g} kg m^2) and three "
        "motors. -->\n"
    )
    return header + text.replace("</mujoco>\n", f"  <actuator>\n{motors}  </actuator>\n</mujoco>\n")


def delta_gepetto() -> tuple[str, str]:
    """The Table-1 Delta in Gepetto's convention: (robot.urdf, robot.yaml)."""
    from lxml import etree

    import delta_pin as dp

    delta = dp.load_delta()
    root = etree.fromstring(delta.urdf.encode())
    for comment in root.xpath("//comment()"):  # the xacro's own, which describe <constraint> elements
        if comment.getparent() is not None:
            comment.getparent().remove(comment)
    pairs = []
    for element in root.findall("constraint"):
        name = element.get("name")
        for tag, suffix in (("parent", "A"), ("child", "B")):
            link = f"{name}_{suffix}"
            joint = etree.SubElement(root, "joint", name=f"{link}_joint", type="fixed")
            etree.SubElement(joint, "parent", link=element.find(tag).get("link"))
            etree.SubElement(joint, "child", link=link)
            etree.SubElement(joint, "origin", xyz=element.find(f"{tag}_origin").get("xyz"), rpy="0 0 0")
            etree.SubElement(root, "link", name=link)
        pairs.append((f"{name}_A", f"{name}_B"))
        root.remove(element)
    etree.indent(root, space="  ")
    urdf = (
        '<?xml version="1.0"?>\n'
        "<!-- The Table-1 Delta (dp.load_delta()) in Gepetto's convention, written by\n"
        "     scripts/make_example_robots.py: the xacro's URDF without its loop-closure elements, the\n"
        "     closure points as massless links on fixed joints (closure_i_A on forearm_i, closure_i_B on\n"
        "     the platform), the pairs and the motors in robot.yaml. -->\n"
        + etree.tostring(root, encoding="unicode")
        + "\n"
    )
    yaml = (
        "# The Table-1 Delta's loop closures and motors (Gepetto's robot.yaml convention)\n"
        f"closed_loop: [{', '.join(f'[{a!r}, {b!r}]' for a, b in pairs)}]\n"
        f"type: [{', '.join(repr('3D') for _ in pairs)}]\n"
        f"name_mot: [{', '.join(repr(n) for n in delta.description.active_joints)}]\n"
    )
    return urdf, yaml


# ---------------------------------------------------------------------------------------- Stewart
# 6-UPS Stewart-Gough platform [m, kg, degrees]: base anchors B_i on a circle of radius
# base_radius at azimuth 120 k -/+ base_half_angle (k = 0, 1, 2: the three base pairs), platform
# anchors P_i on a circle of radius platform_radius at azimuth 120 k -/+ (60 - platform_half_angle):
# each base pair's two legs go to two different platform pairs (the classic crossed layout).
STEWART = {
    "base_radius": 0.5, "platform_radius": 0.3, "base_half_angle": 15.0, "platform_half_angle": 10.0,
    "height": 0.6, "stroke": 0.15,
    "m_cross": 0.1, "i_cross": 5e-5,
    "m_lower": 2.0, "lower_length": 0.4, "lower_radius": 0.04,
    "m_upper": 1.0, "upper_length": 0.4, "upper_radius": 0.02,
    "m_platform": 6.0, "platform_thickness": 0.03,
}  # fmt: skip


def stewart_geometry() -> dict:
    """The Stewart platform's home pose (platform level, its centre ``height`` above the base
    centre): ``{"centre": C, "legs": {i: (B_i, P_i, u_i, L_i)}}`` with B_i, P_i the world base
    and platform anchors [m], u_i the unit leg direction and L_i = |P_i - B_i| the home leg length."""
    p = STEWART
    centre = np.array([0.0, 0.0, p["height"]])
    legs = {}
    for i in range(1, 7):
        k, sign = (i - 1) // 2, (-1.0 if i % 2 else 1.0)
        base = math.radians(120.0 * k + sign * p["base_half_angle"])
        platform = math.radians(120.0 * k + sign * (60.0 - p["platform_half_angle"]))
        B = p["base_radius"] * np.array([math.cos(base), math.sin(base), 0.0])
        P = centre + p["platform_radius"] * np.array([math.cos(platform), math.sin(platform), 0.0])
        length = float(np.linalg.norm(P - B))
        legs[i] = (B, P, (P - B) / length, length)
    return {"centre": centre, "legs": legs}


def _cylinder_inertia(mass: float, axis, length: float, radius: float) -> np.ndarray:
    return _rod_inertia(mass, np.asarray(axis, float) * length, radius)


def _platform_disc_inertia() -> np.ndarray:
    m, r, h = STEWART["m_platform"], STEWART["platform_radius"], STEWART["platform_thickness"]
    across = m * (3.0 * r**2 + h**2) / 12.0
    return np.diag([across, across, m * r**2 / 2.0])


def _rpy_z_to(u: np.ndarray) -> np.ndarray:
    """URDF rpy of a rotation taking the z axis to the unit vector u (for visual cylinders)."""
    axis = np.cross([0.0, 0.0, 1.0], u)
    s, c = float(np.linalg.norm(axis)), float(u[2])
    if s < 1e-15:
        return np.zeros(3)
    k = axis / s
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    R = np.eye(3) + s * K + (1.0 - c) * K @ K
    return np.array([math.atan2(R[2, 1], R[2, 2]), -math.asin(R[2, 0]), math.atan2(R[1, 0], R[0, 0])])


def _stewart_joint(name: str, kind: str, parent: str, child: str, xyz, axis=None, limit=None) -> str:
    text = (
        f'  <joint name="{name}" type="{kind}">\n'
        f'    <parent link="{parent}"/>\n    <child link="{child}"/>\n'
        f'    <origin xyz="{_n(xyz)}"/>\n'
    )
    if axis is not None:
        text += f'    <axis xyz="{_n(axis)}"/>\n'
    if limit is not None:
        effort, lower, upper = limit
        text += f'    <limit effort="{effort:g}" lower="{lower:.17g}" upper="{upper:.17g}" velocity="10"/>\n'
    return text + "  </joint>\n"


def _stewart_visual(xyz, rpy, geometry: str) -> str:
    return (
        f'    <visual>\n      <origin xyz="{_n(xyz)}" rpy="{_n(rpy)}"/>\n'
        f"      <geometry>{geometry}</geometry>\n    </visual>\n"
    )


def _stewart_comment(shape: str, other: str) -> str:
    p = STEWART
    return (
        f"  6-UPS Stewart-Gough platform ({shape}; delta-pin example, written by\n"
        f"  scripts/make_example_robots.py), the same robot as {other}.\n"
        f"  Base anchors B_i on a circle of radius {p['base_radius']} m at azimuth 120k -/+ "
        f"{p['base_half_angle']:g} deg, platform anchors\n"
        f"  P_i on a circle of radius {p['platform_radius']} m at azimuth 120k -/+ "
        f"{60 - p['platform_half_angle']:g} deg (k = 0, 1, 2; legs 1..6 in\n"
        "  that order). Each leg: a universal joint at B_i (ux_i about world x, then uy_i about y; a\n"
        f"  {p['m_cross']} kg cross), a {p['m_lower']} kg lower body (cylinder {p['lower_length']} m, "
        f"radius {p['lower_radius']} m), the actuated prismatic\n"
        f"  joint leg_i along the leg, a {p['m_upper']} kg upper body (rod {p['upper_length']} m, "
        f"radius {p['upper_radius']} m) ending at the\n"
        f"  spherical joint at P_i. The {p['m_platform']} kg platform (a disc of radius "
        f"{p['platform_radius']} m, {p['platform_thickness']} m thick) is the child\n"
        "  of leg 1's spherical joint; legs 2..6 close on it by point closures sphere_i at P_i.\n"
        "  21 joint velocities, 15 closure equations: 6 degrees of freedom, the six leg_i.\n"
        f"  At q = 0 (leg_i = 0: every leg at its home length) the platform is level, its centre\n"
        f"  {p['height']} m above the base centre; leg_i is the extension from the home length\n"
        f"  (stroke -/+ {p['stroke']} m). Every frame is world-aligned at q = 0. Gravity -z. Units: SI.\n"
    )


def stewart_urdf() -> str:
    """The Stewart platform as URDF (module docstring): the spherical joint of leg 1 is three
    revolutes about world x, y, z on massless links (what a ball joint is, as long as the middle
    angle stays away from +/- 90 deg), the platform on a fixed joint at its centre."""
    p, geometry = STEWART, stewart_geometry()
    C, legs = geometry["centre"], geometry["legs"]
    text = (
        '<?xml version="1.0"?>\n<!--\n'
        + _stewart_comment('URDF with <constraint type="point">', "stewart.xml (MJCF)")
        + "-->\n"
        '<robot name="stewart">\n  <link name="base">\n'
        + _stewart_visual(
            [0, 0, -0.01], [0, 0, 0], f'<cylinder radius="{p["base_radius"] + 0.05:g}" length="0.02"/>'
        )
        + "  </link>\n"
    )
    cross = np.eye(3) * p["i_cross"]
    turn = np.pi
    for i, (B, P, u, _length) in legs.items():
        rpy = _rpy_z_to(u)
        text += _stewart_joint(f"ux_{i}", "revolute", "base", f"cross_{i}", B, [1, 0, 0], (100, -turn, turn))
        text += (
            f'  <link name="cross_{i}">\n' + _urdf_inertial(p["m_cross"], [0, 0, 0], cross) + "  </link>\n"
        )
        text += _stewart_joint(f"uy_{i}", "revolute", f"cross_{i}", f"lower_{i}", [0, 0, 0], [0, 1, 0],
                               (100, -turn, turn))  # fmt: skip
        lower = _cylinder_inertia(p["m_lower"], u, p["lower_length"], p["lower_radius"])
        text += (
            f'  <link name="lower_{i}">\n'
            + _urdf_inertial(p["m_lower"], u * p["lower_length"] / 2, lower)
            + _stewart_visual(
                u * p["lower_length"] / 2, rpy,
                f'<cylinder radius="{p["lower_radius"]}" length="{p["lower_length"]}"/>',
            )
            + "  </link>\n"
        )  # fmt: skip
        text += _stewart_joint(f"leg_{i}", "prismatic", f"lower_{i}", f"upper_{i}", P - B, u,
                               (2000, -p["stroke"], p["stroke"]))  # fmt: skip
        upper = _cylinder_inertia(p["m_upper"], u, p["upper_length"], p["upper_radius"])
        text += (
            f'  <link name="upper_{i}">\n'
            + _urdf_inertial(p["m_upper"], -u * p["upper_length"] / 2, upper)
            + _stewart_visual(
                -u * p["upper_length"] / 2, rpy,
                f'<cylinder radius="{p["upper_radius"]}" length="{p["upper_length"]}"/>',
            )
            + "  </link>\n"
        )  # fmt: skip
    _B1, P1, _u1, _L1 = legs[1]
    for axis, name, parent, child in (
        ([1, 0, 0], "sx_1", "upper_1", "wrist_x_1"),
        ([0, 1, 0], "sy_1", "wrist_x_1", "wrist_y_1"),
        ([0, 0, 1], "sz_1", "wrist_y_1", "wrist_z_1"),
    ):
        text += _stewart_joint(name, "revolute", parent, child, [0, 0, 0], axis, (100, -turn, turn))
        text += f'  <link name="{child}"/>\n'  # massless: the three revolutes are one ball joint
    text += _stewart_joint("platform_mount", "fixed", "wrist_z_1", "platform", C - P1)
    text += (
        '  <link name="platform">\n'
        + _urdf_inertial(p["m_platform"], [0, 0, 0], _platform_disc_inertia())
        + _stewart_visual(
            [0, 0, 0], [0, 0, 0],
            f'<cylinder radius="{p["platform_radius"]}" length="{p["platform_thickness"]}"/>',
        )
        + "  </link>\n"
    )  # fmt: skip
    for i in range(2, 7):
        text += (
            f'  <constraint name="sphere_{i}" type="point">\n'
            f'    <parent link="platform"/>\n    <parent_origin xyz="{_n(legs[i][1] - C)}"/>\n'
            f'    <child link="upper_{i}"/>\n    <child_origin xyz="0 0 0"/>\n'
            "  </constraint>\n"
        )
    text += "".join(_transmission(f"leg_{i}") for i in range(1, 7))
    return text + "</robot>\n"


def stewart_mjcf() -> str:
    """The Stewart platform as MJCF: the same bodies; leg 1's spherical joint a ``ball`` joint at
    P_1 in the platform body (its frame at the platform centre); ``connect`` equalities with body
    semantics (anchor on the platform); ``motor`` actuators on the slide joints. The geoms only
    draw (no contacts, no inertia: every body has an ``<inertial>``)."""
    p, geometry = STEWART, stewart_geometry()
    C, legs = geometry["centre"], geometry["legs"]
    text = (
        '<mujoco model="stewart">\n  <!--\n' + _stewart_comment("MJCF", "stewart.urdf") + "  -->\n"
        '  <option timestep="0.001" integrator="RK4" gravity="0 0 -9.8100000000000005"/>\n'
        '  <default>\n    <geom contype="0" conaffinity="0" rgba="0.6 0.6 0.7 1"/>\n  </default>\n'
        "  <worldbody>\n"
    )
    cross = np.eye(3) * p["i_cross"]
    _B1, P1, _u1, _L1 = legs[1]
    for i, (B, P, u, _length) in legs.items():
        a = "    "
        text += f'{a}<body name="cross_{i}" pos="{_n(B)}">\n'
        text += f'{a}  <joint name="ux_{i}" type="hinge" axis="1 0 0"/>\n'
        text += _mjcf_inertial(p["m_cross"], [0, 0, 0], cross, a + "  ")
        text += f'{a}  <body name="lower_{i}">\n'
        text += f'{a}    <joint name="uy_{i}" type="hinge" axis="0 1 0"/>\n'
        lower = _cylinder_inertia(p["m_lower"], u, p["lower_length"], p["lower_radius"])
        text += _mjcf_inertial(p["m_lower"], u * p["lower_length"] / 2, lower, a + "    ")
        text += (
            f'{a}    <geom name="lower_{i}" type="cylinder" size="{p["lower_radius"]}" '
            f'fromto="0 0 0 {_n(u * p["lower_length"])}"/>\n'
        )
        text += f'{a}    <body name="upper_{i}" pos="{_n(P - B)}">\n'
        text += (
            f'{a}      <joint name="leg_{i}" type="slide" axis="{_n(u)}" limited="true" '
            f'range="{-p["stroke"]:.17g} {p["stroke"]:.17g}"/>\n'
        )
        upper = _cylinder_inertia(p["m_upper"], u, p["upper_length"], p["upper_radius"])
        text += _mjcf_inertial(p["m_upper"], -u * p["upper_length"] / 2, upper, a + "      ")
        text += (
            f'{a}      <geom name="upper_{i}" type="cylinder" size="{p["upper_radius"]}" '
            f'fromto="{_n(-u * p["upper_length"])} 0 0 0"/>\n'
        )
        if i == 1:
            b = a + "      "
            text += f'{b}<body name="platform" pos="{_n(C - P1)}">\n'
            text += f'{b}  <joint name="sphere_1" type="ball" pos="{_n(P1 - C)}"/>\n'
            text += _mjcf_inertial(p["m_platform"], [0, 0, 0], _platform_disc_inertia(), b + "  ")
            text += (
                f'{b}  <geom name="platform" type="cylinder" '
                f'size="{p["platform_radius"]} {p["platform_thickness"] / 2:.17g}"/>\n'
            )
            text += f'{b}  <site name="platform_centre"/>\n'
            text += f"{b}</body>\n"
        text += f"{a}    </body>\n{a}  </body>\n{a}</body>\n"
    text += "  </worldbody>\n  <equality>\n"
    for i in range(2, 7):
        text += (
            f'    <connect name="sphere_{i}" body1="platform" body2="upper_{i}" '
            f'anchor="{_n(legs[i][1] - C)}"/>\n'
        )
    text += "  </equality>\n  <actuator>\n"
    text += "".join(f'    <motor name="motor_{i}" joint="leg_{i}"/>\n' for i in range(1, 7))
    return text + "  </actuator>\n</mujoco>\n"


def stewart_files() -> dict[str, str]:
    """The Stewart platform's files (path relative to delta_pin/robots/ -> text). Their numbers
    come from sin and cos, whose last bit may differ between math libraries, so the tests compare
    them with the script's output number by number (to 1e-12), not byte for byte."""
    return {"stewart.urdf": stewart_urdf(), "stewart.xml": stewart_mjcf()}


# ---------------------------------------------------------------------------------------- Delta, ball rods
# The Table-1 Delta with each forearm a parallelogram of two rods between ball joints (the way an
# MJCF Delta is commonly written): numbers that Table 1 does not give [m, kg m^2]. The width of
# the parallelograms and the spin inertias change neither the kinematics nor the motion of the
# arms and the platform (delta_ballrods_xml's docstring); the radii only draw.
DELTA_BALLRODS = {
    "width": 0.06,  # distance between a parallelogram's two rods (along the arm's hinge axis)
    "rod_spin_inertia": 1e-6,  # each rod's moment about its own axis (MuJoCo needs it > 0)
    "arm_axial_inertia": 1e-6,  # each arm's moment about its own axis (the arm turns about its hinge only)
    "rod_radius": 0.004, "arm_radius": 0.01, "platform_thickness": 0.01,
}  # fmt: skip


def _quaternion_product(a, b) -> np.ndarray:
    """a b for quaternions (w, x, y, z)."""
    (w1, x1, y1, z1), (w2, x2, y2, z2) = a, b
    return np.array([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ])  # fmt: skip


def _quaternion_matrix(q) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip


def delta_ballrods_geometry() -> dict:
    """The ball-rod Delta's home pose (every hinge at 0: the arms horizontal, the platform level
    below the base centre), from ``dp.load_delta().params`` and :data:`DELTA_BALLRODS` [m, rad]:
    ``params`` (Table 1), the chain azimuths ``phi``, the platform centre ``centre`` =
    (0, 0, -sqrt(l_b^2 - (R + l_a - r)^2)), and per rod ``"i_a"``/``"i_b"`` (i = 1, 2, 3) its
    elbow ``E`` and platform attachment ``P`` in the world (``P - E`` = the paper's forearm, the
    same for both rods of a chain) and the local one ``P_local`` in the platform's frame (the
    centre, world-aligned); ``arm_quat[i]`` (about z by phi_i) and ``rod_quat`` (about the arm's y
    axis: the rod body's z along the rod, elbow to platform) as MuJoCo quaternions (w, x, y, z)."""
    import delta_pin as dp
    from delta_pin.model.description import chain_azimuths

    p = dp.load_delta().params
    reach = p.R + p.l_a - p.r  # radial distance elbow -> platform attachment at alpha = 0
    height = math.sqrt(p.l_b**2 - reach**2)
    theta = math.atan2(-reach, -height)  # about y: z -> (sin theta, 0, cos theta) = the rod
    centre = np.array([0.0, 0.0, -height])
    phi = chain_azimuths()
    w = DELTA_BALLRODS["width"]
    rods, arm_quat = {}, {}
    for i, angle in enumerate(phi, 1):
        radial = np.array([math.cos(angle), math.sin(angle), 0.0])
        hinge = np.array([-math.sin(angle), math.cos(angle), 0.0])  # the arm's y axis in the world
        arm_quat[i] = np.array([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)])
        for side, sign in (("a", 1.0), ("b", -1.0)):
            P_local = p.r * radial + sign * w / 2 * hinge
            E = (p.R + p.l_a) * radial + sign * w / 2 * hinge
            rods[f"{i}_{side}"] = {"E": E, "P": centre + P_local, "P_local": P_local}
    rod_quat = np.array([math.cos(theta / 2.0), 0.0, math.sin(theta / 2.0), 0.0])
    return {
        "params": p,
        "phi": phi,
        "centre": centre,
        "rods": rods,
        "arm_quat": arm_quat,
        "rod_quat": rod_quat,
    }


def delta_ballrods_xml() -> str:
    """The Table-1 Delta in MJCF with ball-jointed parallelogram forearms (the comment it writes
    states the topology and the mass mapping). The platform hangs from rod 1a by a ball joint
    (MJCF bodies form a tree; a free joint would make the platform a floating base); the other
    five rods close on it by ``connect`` equalities. Each rod spins freely between its two balls:
    six idle motions. The rods carry the inertia of two point masses m_b/4 at their ends (plus a
    small spin inertia about their axis), so half of each forearm's mass moves with the elbow and
    half with the platform, as in the paper's lumped forearm: with the rods' absolute spin at
    zero (the least-kinetic-energy motion, which an axisymmetric rod keeps), the arms and the
    platform move exactly as eqs. 7-9 say."""
    geometry = delta_ballrods_geometry()
    p, b, rods = geometry["params"], DELTA_BALLRODS, geometry["rods"]
    centre, rod_quat = geometry["centre"], geometry["rod_quat"]
    w = b["width"]
    m_rod = p.m_b / 2.0
    rod_across = m_rod * p.l_b**2 / 4.0  # two point masses m_rod / 2 at +/- l_b / 2 from the centre
    arm_across = p.m_a * p.l_a**2 / 12.0  # a uniform rod: m_a l_a^2 / 3 about the hinge
    platform = [p.m_o * p.r**2 / 4.0, p.m_o * p.r**2 / 4.0, p.m_o * p.r**2 / 2.0]  # a disc
    text = (
        '<mujoco model="delta_ballrods">\n'
        "  <!--\n"
        "  The Table-1 Delta (dp.load_delta().params) with ball-jointed parallelogram forearms, the\n"
        "  way an MJCF Delta is commonly written (delta-pin example, written by\n"
        "  scripts/make_example_robots.py). Arms arm_i on hinges active_i (axis: the body's y;\n"
        f"  alpha_i > 0 swings the arm down) at radius R = {p.R:g} m, azimuth phi_i = 30, 150, 270 deg,\n"
        f"  length l_a = {p.l_a:g} m. Each forearm is two parallel rods rod_i_a, rod_i_b of length\n"
        f"  l_b = {p.l_b:g} m, {w:g} m apart along the hinge axis, each on a ball joint elbow_i_a /\n"
        "  elbow_i_b at the arm's tip; the rods end on the platform at r = "
        f"{p.r:g} m from its centre,\n"
        f"  -/+ {w / 2:g} m along the same axis. The platform hangs from rod 1a by the ball joint\n"
        "  platform_ball (MJCF bodies form a tree; a free joint would make it a floating base); the\n"
        "  five other rods hold it by connect equalities (ball joints).\n"
        "  Topology: 3 hinges + 7 balls x 3 = 24 joint velocities; 5 connects = 15 closure equations,\n"
        "  all independent: mobility 9 = 3 actuated + 6 idle (each rod spinning about its own axis,\n"
        "  which moves nothing else; rod 1a's spin turns platform_ball the other way). The\n"
        "  parallelograms keep the platform level, so the kinematics are the paper's whatever the width.\n"
        "  Masses (Table 1 -> bodies):\n"
        f"    arm: m_a = {p.m_a:g} kg, a uniform rod: centre at l_a / 2, moments m_a l_a^2 / 12\n"
        f"      across (m_a l_a^2 / 3 about the hinge, the paper's) and {b['arm_axial_inertia']:g} kg m^2\n"
        "      about its own axis (no effect: an arm turns about its hinge only);\n"
        f"    forearm: m_b = {p.m_b:g} kg split over its two rods, m_b / 2 each, with the inertia of\n"
        "      two point masses m_b / 4 at the rod's ends (m_b l_b^2 / 8 across, about its centre)\n"
        f"      plus a spin moment {b['rod_spin_inertia']:g} kg m^2 about its axis (MuJoCo needs one > 0;\n"
        "      a symmetric rod's spin is decoupled and stays at zero): half the forearm mass rides\n"
        "      at the elbow, half on the platform, the paper's lumped forearm (m_eq = m_o + 3/2 m_b\n"
        "      and (m_a / 3 + m_b / 2) l_a^2 of eqs. 7-9 hold exactly);\n"
        f"    platform: m_o = {p.m_o:g} kg, a disc of radius r (it never turns: its inertia does not\n"
        "      enter).\n"
        f"  Home (qpos0, assembled): every alpha_i = 0, the platform centre {-centre[2]:.6g} m below the\n"
        "  base centre, every ball at its identity; each rod body's z axis runs along its rod, elbow to\n"
        "  platform, and the platform's frame is its centre, world-aligned. The connects are stiff\n"
        "  (solref 0.002 s, as delta_pin.model.mjcf.STIFF_CONNECT); geoms only draw (no contacts).\n"
        f"  Gravity {p.g:g} m/s^2 along -z. Units: SI.\n"
        "  -->\n"
        f'  <option timestep="0.001" integrator="RK4" gravity="0 0 {-p.g:.17g}"/>\n'
        "  <default>\n"
        '    <geom contype="0" conaffinity="0" rgba="0.6 0.6 0.7 1"/>\n'
        '    <equality solref="0.002 1" solimp="0.99 0.999 0.001"/>\n'
        "  </default>\n"
        "  <worldbody>\n"
    )
    for i, phi in enumerate(geometry["phi"], 1):
        a = "    "
        base = p.R * np.array([math.cos(phi), math.sin(phi), 0.0])
        text += f'{a}<body name="arm_{i}" pos="{_n(base)}" quat="{_n(geometry["arm_quat"][i])}">\n'
        text += f'{a}  <joint name="active_{i}" type="hinge" axis="0 1 0"/>\n'
        text += (
            f'{a}  <inertial pos="{_n([p.l_a / 2, 0, 0])}" mass="{p.m_a:.17g}" '
            f'diaginertia="{_n([b["arm_axial_inertia"], arm_across, arm_across])}"/>\n'
        )
        text += (
            f'{a}  <geom name="arm_{i}" type="capsule" size="{b["arm_radius"]:g}" '
            f'fromto="0 0 0 {_n([p.l_a, 0, 0])}"/>\n'
        )
        for side, sign in (("a", 1.0), ("b", -1.0)):
            rod = f"rod_{i}_{side}"
            text += f'{a}  <body name="{rod}" pos="{_n([p.l_a, sign * w / 2, 0])}" quat="{_n(rod_quat)}">\n'
            text += f'{a}    <joint name="elbow_{i}_{side}" type="ball"/>\n'
            text += (
                f'{a}    <inertial pos="{_n([0, 0, p.l_b / 2])}" mass="{m_rod:.17g}" '
                f'diaginertia="{_n([rod_across, rod_across, b["rod_spin_inertia"]])}"/>\n'
            )
            text += (
                f'{a}    <geom name="{rod}" type="capsule" size="{b["rod_radius"]:g}" '
                f'fromto="0 0 0 {_n([0, 0, p.l_b])}"/>\n'
            )
            text += f'{a}    <site name="{rod}_tip" pos="{_n([0, 0, p.l_b])}"/>\n'
            if (i, side) == (1, "a"):  # the platform, its frame at its centre and world-aligned
                rod_world = _quaternion_product(geometry["arm_quat"][1], rod_quat)
                inverse = rod_world * np.array([1.0, -1.0, -1.0, -1.0])
                position = _quaternion_matrix(rod_world).T @ (centre - rods["1_a"]["E"])
                c = a + "    "
                text += f'{c}<body name="platform" pos="{_n(position)}" quat="{_n(inverse)}">\n'
                text += f'{c}  <joint name="platform_ball" type="ball" pos="{_n(rods["1_a"]["P_local"])}"/>\n'
                text += f'{c}  <inertial pos="0 0 0" mass="{p.m_o:.17g}" diaginertia="{_n(platform)}"/>\n'
                text += (
                    f'{c}  <geom name="platform" type="cylinder" '
                    f'size="{p.r:g} {b["platform_thickness"] / 2:.17g}"/>\n'
                )
                for name, values in rods.items():
                    if name != "1_a":
                        text += f'{c}  <site name="platform_{name}" pos="{_n(values["P_local"])}"/>\n'
                text += f"{c}</body>\n"
            text += f"{a}  </body>\n"
        text += f"{a}</body>\n"
    text += "  </worldbody>\n  <equality>\n"
    for name in rods:
        if name != "1_a":
            text += f'    <connect name="rod_{name}" site1="platform_{name}" site2="rod_{name}_tip"/>\n'
    text += "  </equality>\n  <actuator>\n"
    text += "".join(f'    <motor name="motor_{i}" joint="active_{i}"/>\n' for i in (1, 2, 3))
    return text + "  </actuator>\n</mujoco>\n"


def delta_ballrods_files() -> dict[str, str]:
    """The ball-rod Delta's file (path relative to delta_pin/robots/ -> text). Its numbers come
    from sin, cos and atan2, so the tests compare it with the script's output number by number
    (to 1e-12), not byte for byte (tests/model/test_delta_ballrods.py)."""
    return {"delta_ballrods.xml": delta_ballrods_xml()}


def files() -> dict[str, str]:
    """Every shipped robot file checked byte for byte: path relative to delta_pin/robots/ -> text
    (the Stewart platform's are :func:`stewart_files`)."""
    urdf, yaml = delta_gepetto()
    return {
        "five_bar.urdf": five_bar_urdf(),
        "three_rrr.urdf": three_rrr_urdf(),
        "three_rrr.xml": three_rrr_mjcf(),
        "delta.xml": delta_xml(),
        "delta_gepetto/robot.urdf": urdf,
        "delta_gepetto/robot.yaml": yaml,
    }


def all_files() -> dict[str, str]:
    """Every shipped robot file this script writes, by its path under delta_pin/robots."""
    return {**files(), **stewart_files(), **delta_ballrods_files()}


def main(out_dir: Path = ROBOTS_DIR) -> None:
    for name, text in all_files().items():
        path = Path(out_dir) / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
        print(f"wrote {path}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROBOTS_DIR)

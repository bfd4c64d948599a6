"""Write the example closed-chain robots shipped in delta_pin/robots/ (docs/architecture.md section 13).

* ``five_bar.urdf``   a planar five-bar linkage, URDF with a ``<constraint type="point">``;
* ``three_rrr.urdf``  a 3-RRR planar parallel robot closed by one point and one weld
  ``<constraint>``, and ``three_rrr.xml``, the same robot as MJCF (``connect`` + ``weld``);
* ``delta.xml``       the Table-1 Delta as MJCF (:func:`delta_pin.model.mjcf.delta_mjcf`) with
  three ``<motor>`` actuators;
* ``delta_gepetto/robot.urdf`` + ``robot.yaml``: the Table-1 Delta in Gepetto's convention (the
  xacro's URDF without ``<constraint>``, the closure points as fixed-joint child links, the
  pairs and the motors in ``robot.yaml``).

Every number is written with 17 significant digits, so each file is the robot exactly; the tests
check that this script reproduces the shipped files byte for byte.

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


def files() -> dict[str, str]:
    """Every shipped robot file: path relative to delta_pin/robots/ -> text."""
    urdf, yaml = delta_gepetto()
    return {
        "five_bar.urdf": five_bar_urdf(),
        "three_rrr.urdf": three_rrr_urdf(),
        "three_rrr.xml": three_rrr_mjcf(),
        "delta.xml": delta_xml(),
        "delta_gepetto/robot.urdf": urdf,
        "delta_gepetto/robot.yaml": yaml,
    }


def main(out_dir: Path = ROBOTS_DIR) -> None:
    for name, text in files().items():
        path = Path(out_dir) / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
        print(f"wrote {path}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROBOTS_DIR)

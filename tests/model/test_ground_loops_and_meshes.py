"""Loops closed on the ground, in the three file shapes, and Gepetto's ``package:///`` meshes.

The robot: a planar four-bar (crank 0.1 m, coupler 0.3 m, rocker 0.25 m, ground 0.3 m; a
crank-rocker, so every crank angle assembles), revolutes about y, gravity along -z. Its tree is
crank -> coupler -> rocker; the loop closes where the rocker's tip meets the ground pivot D, a
frame on the root link (URDF), on a link fixed to it (URDF, Gepetto), on the world body or on a
jointless body fixed to the world (MJCF): a closure with one frame on joint 0. The files place
every joint so that q = 0 is assembled (crank at 1 rad). Each shape also has a weld variant: a
small pin link (hinge about y at the rocker's tip) welded to the ground, which holds the tip at D
like the point does (its extra rows are redundant in the plane) and carries its mass at D.

Tolerances, and why:

* closure gap, and the rocker's tip at D, 1e-12 m: the assembly's own Newton tolerance
  (``configuration(tol=1e-12)``);
* the same pose in every shape 1e-9 rad (assembled to 1e-12 m by each robot's own Newton);
* gravity torque G across the shapes and variants 1e-12 N m (|G| 0.19-0.93 N m at the crank
  angles tested; measured 8e-15): the same tree, the same numbers (URDF rpy and MJCF quaternions
  written to 17 digits, inertias on the principal axes) and configurations assembled to round-off
  (tol 1e-15 m), so only round-off differs; the pin's weight acts at the fixed point D and adds
  nothing. A ground anchor misplaced by 1 um changes G by 0.5-2e-6 N m (measured), far above;
* G against the potential energy V(alpha) (``pin.computePotentialEnergy`` at the assembled q):
  a 4th-order central difference with h = 1e-3 rad, truncation ~h^4 |V^(5)| / 30 and assembly
  round-off ~1e-16 J / h, measured 9e-13 N m: 1e-10 N m leaves a hundredfold margin;
* accelerations from Pinocchio's constraintDynamics: see that test.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import delta_pin as dp
from delta_pin.errors import MeshFileError, URDFConventionError
from delta_pin.model.gepetto_loader import read_gepetto_yaml
from delta_pin.model.loaders import read_urdf_constraints
from delta_pin.model.visuals import check_mesh_files, resolve_mesh_path

DATA = Path(__file__).resolve().parents[1] / "data"
FIVE_BAR = DATA / "gepetto" / "5bar_linkage"
GEPETTO_DELTA = DATA / "gepetto" / "robot_delta"
MUJOCO_CONNECT = DATA / "mujoco" / "jdotv_connect_2d.xml"

CRANK, COUPLER, ROCKER, GROUND = 0.1, 0.3, 0.25, 0.3  # link lengths [m]
MASSES = {"crank": 0.5, "coupler": 0.8, "rocker": 0.6}  # [kg]
PIN_MASS = 0.05  # [kg], the weld variant's pin link (at D)
CRANK_ANGLE = 1.0  # [rad], the crank's direction at q = 0 (about y, from +x towards -z)


def _direction(angle: float) -> np.ndarray:
    return np.array([math.cos(angle), 0.0, -math.sin(angle)])  # R_y(angle) e_x


def _angles() -> tuple[float, float, float]:
    """Absolute angles (about y) of crank, coupler and rocker with the loop closed at D."""
    A, D = np.zeros(3), np.array([GROUND, 0.0, 0.0])
    B = A + CRANK * _direction(CRANK_ANGLE)
    # C: where the circles (B, coupler) and (D, rocker) meet, in the x-z plane (the upper branch)
    P, Q = np.array([B[0], -B[2]]), np.array([D[0], -D[2]])
    distance = float(np.linalg.norm(Q - P))
    along = (COUPLER**2 - ROCKER**2 + distance**2) / (2 * distance)
    e = (Q - P) / distance
    C2 = P + along * e + math.sqrt(COUPLER**2 - along**2) * np.array([-e[1], e[0]])
    C = np.array([C2[0], 0.0, -C2[1]])
    angle = lambda v: math.atan2(-v[2], v[0])  # noqa: E731
    return CRANK_ANGLE, angle(C - B), angle(D - C)


PHI = _angles()
# the joints' rotations about y at q = 0 (each relative to its parent link), and their offsets
ROTATIONS = {"crank": PHI[0], "coupler": PHI[1] - PHI[0], "rocker": PHI[2] - PHI[1], "pin_joint": -PHI[2]}
OFFSETS = {"crank": (0.0, 0.0, 0.0), "coupler": (CRANK, 0.0, 0.0), "rocker": (COUPLER, 0.0, 0.0),
           "pin_joint": (ROCKER, 0.0, 0.0)}  # fmt: skip
PARENTS = {"crank": "base", "coupler": "crank_link", "rocker": "coupler_link", "pin_joint": "rocker_link"}
LENGTHS = {"crank": CRANK, "coupler": COUPLER, "rocker": ROCKER}


def _xyz(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def _inertia(joint: str) -> tuple[float, tuple, tuple]:
    """(mass [kg], centre of mass in the link [m], principal moments [kg m^2]) of a link."""
    if joint == "pin_joint":
        return PIN_MASS, (0.0, 0.0, 0.0), (1e-5, 1e-5, 1e-5)
    m, length = MASSES[joint], LENGTHS[joint]
    return m, (length / 2, 0.0, 0.01), (1e-4, m * length**2 / 12 + 1e-4, m * length**2 / 12)


# ------------------------------------------------------------------------------ URDF, Gepetto


def _urdf(constraint: str = "", weld: bool = False, extra_links: str = "") -> str:
    joints = ["crank", "coupler", "rocker", *(["pin_joint"] if weld else [])]
    parts = ['<robot name="four_bar">', '  <link name="base"/>']
    for joint in joints:
        child = "pin_link" if joint == "pin_joint" else f"{joint}_link"
        mass, com, moments = _inertia(joint)
        parts += [
            f'  <joint name="{joint}" type="revolute">',
            f'    <parent link="{PARENTS[joint]}"/><child link="{child}"/>',
            f'    <origin xyz="{_xyz(OFFSETS[joint])}" rpy="0 {ROTATIONS[joint]!r} 0"/>',
            '    <axis xyz="0 1 0"/><limit lower="-6.3" upper="6.3" effort="100" velocity="100"/>',
            "  </joint>",
            f'  <link name="{child}"><inertial><origin xyz="{_xyz(com)}"/><mass value="{mass!r}"/>',
            f'    <inertia ixx="{moments[0]!r}" iyy="{moments[1]!r}" izz="{moments[2]!r}" ixy="0" ixz="0" '
            'iyz="0"/></inertial></link>',
        ]
    parts += [
        # the ground pivot D on a link fixed to the root, and the rocker's tip (Gepetto's frames)
        '  <joint name="ground_pin_joint" type="fixed"><parent link="base"/><child link="ground_pin"/>',
        f'    <origin xyz="{GROUND!r} 0 0" rpy="0.3 0 0"/></joint>',
        '  <link name="ground_pin"/>',
        '  <joint name="rocker_tip_joint" type="fixed"><parent link="rocker_link"/>',
        f'    <child link="rocker_tip"/><origin xyz="{ROCKER!r} 0 0"/></joint>',
        '  <link name="rocker_tip"/>',
        extra_links,
        constraint,
        "</robot>",
    ]
    return "\n".join(parts) + "\n"


TIP = f'<parent link="rocker_link"/><parent_origin xyz="{ROCKER!r} 0 0"/>'
D_ON_BASE = f'<child link="base"/><child_origin xyz="{GROUND!r} 0 0"/>'
URDF_VARIANTS = {
    # rocker tip -> the root link itself, at D
    "point_on_root": (False, f'<constraint name="pivot_d" type="point">{TIP}{D_ON_BASE}</constraint>'),
    # the same, the ground frame first (joint1 = 0)
    "point_on_root_first": (
        False,
        f'<constraint name="pivot_d" type="point"><parent link="base"/><parent_origin xyz="{GROUND!r} 0 0"/>'
        f'<child link="rocker_link"/><child_origin xyz="{ROCKER!r} 0 0"/></constraint>',
    ),
    # to a link fixed to the root (joint 0, placed at D with a rotation)
    "point_on_fixed_link": (
        False,
        f'<constraint name="pivot_d" type="point">{TIP}<child link="ground_pin"/></constraint>',
    ),
    # the pin link welded to the root link at D
    "weld_on_root": (
        True,
        f'<constraint name="pivot_d" type="weld"><parent link="pin_link"/>{D_ON_BASE}</constraint>',
    ),
}
GEPETTO_VARIANTS = {
    "point_on_fixed_link": (False, "closed_loop: [['rocker_tip', 'ground_pin']]\ntype: ['3D']\n"),
    "point_on_fixed_link_first": (False, "closed_loop: [['ground_pin', 'rocker_tip']]\ntype: ['3D']\n"),
    "weld_on_fixed_link": (
        True,
        "closed_loop: [['pin_link', 'ground_pin_2']]\ntype: ['6D']\n",
    ),
}
# the weld variant's ground frame: fixed to the root at D without rotation (the pin link's pose at q = 0)
GROUND_PIN_2 = (
    '  <joint name="ground_pin_2_joint" type="fixed"><parent link="base"/><child link="ground_pin_2"/>\n'
    f'    <origin xyz="{GROUND!r} 0 0"/></joint>\n  <link name="ground_pin_2"/>'
)


def _write_urdf(tmp_path: Path, variant: str) -> Path:
    weld, constraint = URDF_VARIANTS[variant]
    path = tmp_path / f"{variant}.urdf"
    path.write_text(_urdf(constraint, weld))
    return path


def _write_gepetto(tmp_path: Path, variant: str) -> Path:
    weld, yaml = GEPETTO_VARIANTS[variant]
    folder = tmp_path / f"gepetto_{variant}"
    folder.mkdir()
    (folder / "robot.urdf").write_text(_urdf(weld=weld, extra_links=GROUND_PIN_2))
    (folder / "robot.yaml").write_text(yaml + "name_mot: ['crank']\n")
    return folder / "robot.urdf"


# ------------------------------------------------------------------------------ MJCF


def _quat_y(angle: float) -> str:
    return f"{math.cos(angle / 2)!r} 0 {math.sin(angle / 2)!r} 0"


def _mjcf(equality: str, weld: bool = False) -> str:
    def body(joint: str, inner: str = "") -> str:
        name = "pin_link" if joint == "pin_joint" else f"{joint}_link"
        mass, com, moments = _inertia(joint)
        site = f'<site name="rocker_tip" pos="{ROCKER!r} 0 0"/>' if joint == "rocker" else ""
        return (
            f'<body name="{name}" pos="{_xyz(OFFSETS[joint])}" quat="{_quat_y(ROTATIONS[joint])}">'
            f'<joint name="{joint}" type="hinge" axis="0 1 0"/>'
            f'<inertial pos="{_xyz(com)}" mass="{mass!r}" diaginertia="{_xyz(moments)}"/>{site}{inner}</body>'
        )

    tree = body("crank", body("coupler", body("rocker", body("pin_joint") if weld else "")))
    return f"""<mujoco model="four_bar">
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <site name="ground_site" pos="{GROUND!r} 0 0"/>
    <body name="ground" pos="{GROUND!r} 0 0.02" quat="{_quat_y(0.4)}"/>
    {tree}
  </worldbody>
  <equality>
    {equality}
  </equality>
  <actuator><motor name="crank_motor" joint="crank"/></actuator>
</mujoco>
"""


MJCF_VARIANTS = {
    # body2 left out: the world body
    "connect_to_world": (False, f'<connect name="pivot_d" body1="rocker_link" anchor="{ROCKER!r} 0 0"/>'),
    # the world body first (joint1 = 0), its anchor in world coordinates
    "connect_world_first": (
        False,
        f'<connect name="pivot_d" body1="world" body2="rocker_link" anchor="{GROUND!r} 0 0"/>',
    ),
    # to a body without joints fixed to the world (placed off D, rotated)
    "connect_to_fixed_body": (
        False,
        f'<connect name="pivot_d" body1="rocker_link" body2="ground" anchor="{ROCKER!r} 0 0"/>',
    ),
    # a site on the world body
    "connect_to_world_site": (False, '<connect name="pivot_d" site1="rocker_tip" site2="ground_site"/>'),
    # the pin welded to the world, and to the fixed body (relpose from the pose at qpos0)
    "weld_to_world": (True, '<weld name="pivot_d" body1="pin_link"/>'),
    "weld_to_fixed_body": (True, '<weld name="pivot_d" body1="ground" body2="pin_link"/>'),
}


def _write_mjcf(tmp_path: Path, variant: str) -> Path:
    weld, equality = MJCF_VARIANTS[variant]
    path = tmp_path / f"{variant}.xml"
    path.write_text(_mjcf(equality, weld))
    return path


def _all_variants(tmp_path: Path) -> dict:
    robots = {}
    for variant in URDF_VARIANTS:
        robots[f"urdf:{variant}"] = dp.load_robot(_write_urdf(tmp_path, variant), actuated=["crank"])
    for variant in GEPETTO_VARIANTS:
        robots[f"gepetto:{variant}"] = dp.load_robot(_write_gepetto(tmp_path, variant))
    for variant in MJCF_VARIANTS:
        robots[f"mjcf:{variant}"] = dp.load_robot(_write_mjcf(tmp_path, variant))
    return robots


@pytest.fixture(scope="module")
def four_bars(tmp_path_factory) -> dict:
    pytest.importorskip("mujoco")
    return _all_variants(tmp_path_factory.mktemp("four_bars"))


def _assemble(robot, alpha: float, tol: float = 1e-15) -> np.ndarray:
    """The assembled q at crank angle ``alpha``, on the branch of the file's pose (q = 0): followed
    from there in steps of at most 0.1 rad (a far jump may land on the other branch)."""
    q = robot.reference_configuration
    for value in np.linspace(0.0, alpha, math.ceil(abs(alpha) / 0.1) + 1)[1:]:
        q = robot.configuration(np.array([value]), initial_guess=q, tol=tol)
    return q


def _potential(robot, q: np.ndarray, alpha: float) -> float:
    """V [J] at crank angle ``alpha`` near the assembled ``q``."""
    q = robot.configuration(np.array([alpha]), initial_guess=q, tol=1e-15)
    return float(pin.computePotentialEnergy(robot.model, robot.data, q))


ALPHAS = (0.0, 0.7, -1.2, 2.5)  # [rad] crank angles from the file's pose (a full turn assembles)


def test_ground_closures_load_on_joint_0_and_assemble(four_bars):
    assert len(four_bars) == 13
    for label, robot in four_bars.items():
        assert robot.actuated_joints == ("crank",), label
        assert robot.dof == 1 and robot.idle_dof == 0, label
        (closure,) = robot.closures
        assert 0 in (closure.joint1, closure.joint2), label
        assert robot.closure_gap(robot.reference_configuration) < 1e-12, label
        np.testing.assert_array_equal(robot.home, [0.0])
        for alpha in ALPHAS:
            q = _assemble(robot, alpha, tol=1e-12)
            assert robot.closure_gap(q) < 1e-12, (label, alpha)
            # the rocker's tip is at D, whichever ground frame holds it; the same pose in every shape
            pin.framesForwardKinematics(robot.model, robot.data, q)
            tip = robot.data.oMi[robot.model.getJointId("rocker")].act(np.array([ROCKER, 0.0, 0.0]))
            np.testing.assert_allclose(tip, [GROUND, 0.0, 0.0], rtol=0, atol=1e-12)
            reference = four_bars["urdf:point_on_root"]
            np.testing.assert_allclose(q[:3], _assemble(reference, alpha)[:3], rtol=0, atol=1e-9)


def test_urdf_root_link_anchor_is_on_joint_0_at_its_placement():
    for variant, first in (("point_on_root", False), ("point_on_root_first", True), ("weld_on_root", False)):
        weld, constraint = URDF_VARIANTS[variant]
        text = _urdf(constraint, weld)
        (closure,) = read_urdf_constraints(text, pin.buildModelFromXML(text), "four_bar.urdf")
        joint, placement = (
            (closure.joint1, closure.placement1) if first else (closure.joint2, closure.placement2)
        )
        assert joint == 0, variant
        np.testing.assert_array_equal(placement.translation, [GROUND, 0.0, 0.0])
        np.testing.assert_array_equal(placement.rotation, np.eye(3))


def test_gravity_torque_agrees_across_shapes_and_with_the_potential(four_bars):
    reference = four_bars["urdf:point_on_root"]
    measured = {"shapes": 0.0, "potential": 0.0}
    h = 1e-3
    for alpha in ALPHAS:
        a = np.array([alpha])
        expected = reference.reduced_terms(a, np.zeros(1), q=_assemble(reference, alpha))[2]
        assert 0.1 < abs(expected[0]) < 10.0  # a gravity torque worth comparing [N m]
        for label, robot in four_bars.items():
            q = _assemble(robot, alpha)
            G = robot.reduced_terms(a, np.zeros(1), q=q)[2]
            np.testing.assert_allclose(G, expected, rtol=0, atol=1e-12, err_msg=label)
            measured["shapes"] = max(measured["shapes"], float(np.abs(G - expected).max()))
            V = [_potential(robot, q, alpha + k * h) for k in (-2, -1, 1, 2)]
            dV = (V[0] - 8 * V[1] + 8 * V[2] - V[3]) / (12 * h)
            assert G[0] == pytest.approx(dV, abs=1e-10), label
            measured["potential"] = max(measured["potential"], abs(G[0] - dV))
    print(f"max |G - G_urdf| = {measured['shapes']:.1e} N m, max |G - dV/dalpha| = ", end="")
    print(f"{measured['potential']:.1e} N m")


def test_constraint_dynamics_with_a_ground_frame_matches_the_reduced_model(four_bars):
    """Pinocchio's constraintDynamics on the robot's RigidConstraintModel (a ground frame as
    joint1 or joint2) gives the crank acceleration of the reduced model M alpha_ddot = tau - C
    alpha_dot - G. Tolerance 1e-9 rad/s^2 on ~18 rad/s^2: the proximal solver (mu = 1e-9, the
    plant's setting for redundant closure rows: a planar loop) converges to the exact KKT solution
    to ~1e-12 relative (measured at most 2e-11 rad/s^2, the MJCF weld); the reduced model is exact."""
    alpha, alpha_dot, tau = 0.7, np.array([1.3]), np.array([0.4])
    for label, robot in four_bars.items():
        q = _assemble(robot, alpha)
        M, _C, G, coriolis = robot.reduced_terms(np.array([alpha]), alpha_dot, q=q)
        expected = np.linalg.solve(M, tau - coriolis - G)
        v = robot.velocity_map(q) @ alpha_dot
        torques = np.zeros(robot.model.nv)
        torques[robot.actuated_indices] = tau
        data, datas = robot.model.createData(), pin.StdVec_RigidConstraintData()
        for constraint in robot.constraint_models:
            datas.append(constraint.createData())
        pin.initConstraintDynamics(robot.model, data, robot.constraint_models, datas)
        settings = pin.ProximalSettings(1e-13, 1e-9, 200)
        a = pin.constraintDynamics(robot.model, data, q, v, torques, robot.constraint_models, datas, settings)
        np.testing.assert_allclose(a[robot.actuated_indices], expected, rtol=0, atol=1e-9, err_msg=label)


# ------------------------------------------------------------------------------ refusals


def test_closure_within_one_rigid_body_is_refused_in_one_line(tmp_path):
    cases = []
    # URDF: the root link and a link fixed to it (both joint 0); the rocker and its fixed tip
    for name, parent, child in (
        ("on_ground", "base", "ground_pin"),
        ("on_rocker", "rocker_link", "rocker_tip"),
    ):
        path = tmp_path / f"{name}.urdf"
        path.write_text(
            _urdf(f'<constraint name="{name}" type="point"><parent link="{parent}"/><child link="{child}"/>'
                  "</constraint>")
        )  # fmt: skip
        line = next(n for n, text in enumerate(path.read_text().splitlines(), 1) if "<constraint" in text)
        cases.append((path, ["crank"], rf"constraint '{name}' \({name}.urdf line {line}\) joins links "
                      rf"'{parent}' and '{child}', which are one rigid body"))  # fmt: skip
    # Gepetto: the root link and a link fixed to it
    folder = tmp_path / "gepetto"
    folder.mkdir()
    (folder / "robot.urdf").write_text(_urdf())
    (folder / "robot.yaml").write_text("name_mot: ['crank']\nclosed_loop: [['base', 'ground_pin']]\n")
    cases.append(
        (folder / "robot.urdf", None, r"robot.yaml line 2: frames 'base' and 'ground_pin' move together "
         r"\(one rigid body, both on the ground")
    )  # fmt: skip
    # MJCF: a jointless body fixed to the world, held to the world
    pytest.importorskip("mujoco")
    path = tmp_path / "on_ground.xml"
    path.write_text(_mjcf('<connect name="on_ground" body1="ground" anchor="0 0 0"/>'))
    line = next(n for n, text in enumerate(path.read_text().splitlines(), 1) if "<connect" in text)
    cases.append((path, None, rf"equality 'on_ground' \(on_ground.xml line {line}\) joins bodies 'ground' "
                  r"and 'world', which are one rigid body \(both fixed to the world\)"))  # fmt: skip
    for path, actuated, message in cases:
        with pytest.raises(URDFConventionError, match=message) as error:
            dp.load_robot(path, actuated=actuated)
        assert "\n" not in str(error.value)


# ------------------------------------------------------------------------------ Gepetto's files


def test_package_with_no_name_is_relative_to_the_robots_folder():
    assert resolve_mesh_path("package:///rod.stl", FIVE_BAR) == FIVE_BAR / "rod.stl"
    assert (FIVE_BAR / "rod.stl").is_file()
    with pytest.raises(
        MeshFileError, match=r"mesh 'package:///rod.stl' \(a visual\) is relative to the URDF's"
    ):
        resolve_mesh_path("package:///rod.stl", None)
    with pytest.raises(MeshFileError, match=r"mesh 'package:///nothing.stl' .* does not exist"):
        resolve_mesh_path("package:///nothing.stl", FIVE_BAR)


@pytest.mark.parametrize("folder", [FIVE_BAR, GEPETTO_DELTA], ids=["5bar_linkage", "robot_delta"])
def test_shipped_gepetto_models_parse_and_their_meshes_resolve(folder):
    urdf = (folder / "robot.urdf").read_text()
    assert "package:///" in urdf
    check_mesh_files(urdf, folder)  # every visual <mesh> is a file there (the collisions name the same)
    check_mesh_files(urdf, None)  # relative to an unknown folder: not checked
    # robot.yaml: its frames and motors are in the URDF (loading waits for idle motions)
    content, _lines = read_gepetto_yaml(folder / "robot.yaml")
    model = pin.buildModelFromXML(urdf)
    for pair in content["closed_loop"]:
        assert all(model.existFrame(name) for name in pair), pair
    assert all(model.existJointName(name) for name in content["name_mot"])


def test_gepetto_five_bar_meshes_are_drawn():
    pytest.importorskip("trimesh")
    pytest.importorskip("yourdfpy")
    from delta_pin.viz.meshcat_export import _urdf_geometry

    urdf = (FIVE_BAR / "robot.urdf").read_text()
    geometry, meshes = _urdf_geometry(pin.buildModelFromXML(urdf), urdf, FIVE_BAR)
    assert geometry.ngeoms == 5 and len(meshes) == 5  # the five visuals, each an STL read by trimesh
    assert {mesh.path.name for mesh in meshes.values()} == {"built.stl", "rod.stl", "end_rod.stl"}
    assert all(len(mesh.faces) > 0 for mesh in meshes.values())


def test_mujocos_connect_model_loads_with_its_actuators_named():
    # a pendulum's tip held to a planar free body (no ground in the loop); no <actuator>: name two
    pytest.importorskip("mujoco")
    robot = dp.load_robot(MUJOCO_CONNECT, actuated=["hinge1", "joint_3"])
    assert robot.dof == 2 and robot.idle_dof == 0
    (closure,) = robot.closures
    assert closure.kind == "3d" and 0 not in (closure.joint1, closure.joint2)
    for alpha in ([0.0, 0.0], [0.2, -0.3]):
        assert robot.closure_gap(robot.configuration(np.array(alpha))) < 1e-12

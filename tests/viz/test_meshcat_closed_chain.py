"""Meshcat export of a closed-chain robot's run (delta_pin.viz.meshcat_export on a ClosedChainRobot).

The robot is the closed-chain tests' planar five-bar (tests/model/closed_chain_fixtures.py), with
visuals added here. The reference every drawn placement is compared with is independent of the
module and of ``ClosedChainRobot.configuration``: the five-bar's closed-form assembly (the elbows
from the motor angles, the tip where the two distal circles meet), then Pinocchio's own
``updateGeometryPlacements`` (or ``forwardKinematics``) at that configuration.
"""

import itertools
import math
import os
import re
import shutil
import uuid
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from lxml import etree

import delta_pin as dp
from delta_pin.control.nominal import ClosedChainNominalModel
from delta_pin.model.frame_path import Circle, FramePath
from delta_pin.model.loaders import load_robot
from delta_pin.sim.closed_chain_plant import ClosedChainPlant
from delta_pin.sim.run import Run
from delta_pin.viz.meshcat_export import (
    RobotMismatchError,
    VisualizationError,
    export_html,
    read_scene_commands,
)
from tests.model.closed_chain_fixtures import BASE, DISTAL, PROXIMAL, five_bar_urdf
from tests.viz.browser import run_browser
from tests.viz.test_meshcat_export import live_scene_commands, scene_key

meshcat = pytest.importorskip("meshcat")

FPS = 30.0  # [frames/s]
T_END = 0.3  # [s]
PLACEMENT_TOL = 1e-6  # [m] and [-] (quaternion components): the page stores float32
CHROMIUM = shutil.which("chromium")
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="chromium is not installed (Debian: apt-get install -y chromium)"
)
WINDOW = (800, 600)  # [px]

# (link, geometry tag, geometry attributes, origin xyz, origin rpy, rgba) of the visuals added
VISUALS = [
    ("base", "box", {"size": f"{BASE + 0.04} 0.03 0.03"}, "0 0 0", "0 0 0", "0.5 0.5 0.5 1"),
    ("proximal_1", "cylinder", {"radius": "0.01", "length": repr(PROXIMAL)}, f"{PROXIMAL / 2} 0 0",
     f"0 {math.pi / 2} 0", "0.85 0.1 0.1 1"),
    ("proximal_2", "cylinder", {"radius": "0.01", "length": repr(PROXIMAL)}, f"{PROXIMAL / 2} 0 0",
     f"0 {math.pi / 2} 0", "0.85 0.1 0.1 1"),
    ("distal_1", "box", {"size": f"{DISTAL} 0.015 0.015"}, f"{DISTAL / 2} 0 0", "0 0 0", "0.1 0.7 0.2 1"),
    ("distal_1", "sphere", {"radius": "0.014"}, "0 0 0", "0 0 0", "0.5 0.5 0.5 1"),
    ("distal_2", "box", {"size": f"{DISTAL} 0.015 0.015"}, f"{DISTAL / 2} 0 0", "0 0 0", "0.1 0.7 0.2 1"),
    ("tip", "sphere", {"radius": "0.018"}, "0 0 0", "0 0 0", "0.93 0.5 0.13 1"),
]  # fmt: skip


def five_bar_with_visuals(distal_mesh: str | None = None) -> str:
    """The five-bar with VISUALS; ``distal_mesh``: the first distal box becomes that mesh file."""
    root = etree.fromstring(five_bar_urdf().encode())
    links = {link.get("name"): link for link in root.findall("link")}
    for number, (link, tag, attributes, xyz, rpy, rgba) in enumerate(VISUALS):
        if distal_mesh and link == "distal_1" and tag == "box":
            tag, attributes = "mesh", {"filename": distal_mesh}
        visual = etree.SubElement(links[link], "visual")
        etree.SubElement(visual, "origin", xyz=xyz, rpy=rpy)
        etree.SubElement(etree.SubElement(visual, "geometry"), tag, **attributes)
        etree.SubElement(etree.SubElement(visual, "material", name=f"m{number}"), "color", rgba=rgba)
    return etree.tostring(root, encoding="unicode")


def write_robot(folder: Path, text: str, name: str = "five_bar.urdf", **options):
    path = folder / name
    path.write_text(text)
    return load_robot(path, end_effector="tip", **options)


def simulate_circle(robot) -> Run:
    """0.3 s of a 3 cm circle in the xz plane under PD + gravity (the tip moves ~2 cm)."""
    path = FramePath(Circle(center=[0.0, 0.0, -0.38], radius=0.03, period=2.0, plane="xz"))
    nominal = ClosedChainNominalModel(robot)
    return dp.simulate(
        robot, dp.PDGravity(nominal), path, plant=ClosedChainPlant(robot), t_end=T_END, dt=1e-3,
        alpha0=robot.home,
    )  # fmt: skip


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("closed_chain_viz")


@pytest.fixture(scope="module")
def robot(folder):
    return write_robot(folder, five_bar_with_visuals())


@pytest.fixture(scope="module")
def bare_robot(folder):
    """The five-bar as the fixture writes it: no <visual> at all."""
    return write_robot(folder, five_bar_urdf(), name="bare.urdf")


@pytest.fixture(scope="module")
def run(robot) -> Run:
    return simulate_circle(robot)


@pytest.fixture(scope="module")
def bare_run(bare_robot) -> Run:
    return simulate_circle(bare_robot)


@pytest.fixture(scope="module")
def page(run, folder) -> Path:
    return export_html(run, folder / "five_bar.html", fps=FPS)  # robot=None: rebuilt from the run


@pytest.fixture(scope="module")
def bare_page(bare_run, folder) -> Path:
    return export_html(bare_run, folder / "bare.html", fps=FPS)


# ----------------------------------------------------------------------- independent reference
def closed_form_configuration(robot, alpha: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The five-bar's configuration q for motor angles alpha, in closed form (the elbows from
    the motor angles, the tip where the distal circles meet, the lower of the two points: the
    fixture's assembly mode), and the world points A_i, E_i (elbows) and T (tip)."""
    model = robot.model
    q = np.zeros(model.nq)
    pitch = {}  # the joint frames' rotations about y [rad] (R[0, 2] = sin, R[0, 0] = cos)
    for name in ("motor_1", "motor_2", "elbow_1", "elbow_2"):
        rotation = model.jointPlacements[model.getJointId(name)].rotation
        pitch[name] = math.atan2(rotation[0, 2], rotation[0, 0])
    points = {}
    for i in (1, 2):
        anchor = np.array([(-1.0 if i == 1 else 1.0) * BASE / 2, 0.0, 0.0])
        angle = pitch[f"motor_{i}"] + alpha[i - 1]  # about y: x turns to (cos, 0, -sin)
        points[f"A{i}"] = anchor
        points[f"E{i}"] = anchor + PROXIMAL * np.array([math.cos(angle), 0.0, -math.sin(angle)])
    E1, E2 = points["E1"], points["E2"]
    half = 0.5 * np.linalg.norm(E2 - E1)
    middle = 0.5 * (E1 + E2)
    across = (E2 - E1) / (2.0 * half)
    normal = np.array([-across[2], 0.0, across[0]])  # across turned by 90 deg in the xz plane
    height = math.sqrt(DISTAL**2 - half**2)
    candidates = [middle + height * normal, middle - height * normal]
    points["T"] = min(candidates, key=lambda point: point[2])
    for i in (1, 2):
        motor = pitch[f"motor_{i}"] + alpha[i - 1]
        d = points["T"] - points[f"E{i}"]
        distal = math.atan2(-d[2], d[0])
        q[model.idx_qs[model.getJointId(f"motor_{i}")]] = alpha[i - 1]
        q[model.idx_qs[model.getJointId(f"elbow_{i}")]] = distal - motor - pitch[f"elbow_{i}"]
    return q, points


def frame_alphas(run: Run, count: int) -> np.ndarray:
    times = run.t[0] + np.arange(count) / FPS
    times[-1] = min(times[-1], run.t[-1])
    return np.column_stack([np.interp(times, run.t, run.alpha[:, j]) for j in range(run.alpha.shape[1])])


def commands_of(page: Path) -> list[dict]:
    return read_scene_commands(page.read_text(encoding="utf-8"))


def robot_objects(commands: list[dict]) -> dict[str, dict]:
    """Drawn shapes by visual name."""
    return {
        c["path"].split("/")[-2]: c["object"]
        for c in commands
        if c["type"] == "set_object" and "/delta_pin/robot/" in c["path"]
    }


def drawn_poses(commands: list[dict], names: list[str], count: int) -> np.ndarray:
    """(F, V, 7) placements of the drawn visuals: the animation's keys, or the node's transform."""
    transforms = {c["path"]: c["matrix"] for c in commands if c["type"] == "set_transform"}
    (animation,) = [c for c in commands if c["type"] == "set_animation"]
    clips = {item["path"]: item["clip"] for item in animation["animations"]}
    poses = np.empty((count, len(names), 7))
    for j, name in enumerate(names):
        path = f"/meshcat/delta_pin/robot/{name}"
        clip = clips.get(path)
        if clip is None:  # a visual on the base: one transform
            matrix = np.asarray(transforms[path], dtype=float).reshape(4, 4).T
            poses[:, j] = pin.SE3ToXYZQUAT(pin.SE3(matrix[:3, :3], matrix[:3, 3]))
            continue
        tracks = {track["name"]: np.asarray(track["values"], dtype=float) for track in clip["tracks"]}
        times = {track["name"]: np.asarray(track["times"], dtype=float) for track in clip["tracks"]}
        np.testing.assert_array_equal(times[".position"], np.arange(count))
        poses[:, j, :3] = tracks[".position"].reshape(-1, 3)
        poses[:, j, 3:] = tracks[".quaternion"].reshape(-1, 4)
    return poses


def assert_same_poses(drawn: np.ndarray, expected: np.ndarray) -> None:
    np.testing.assert_allclose(drawn[..., :3], expected[..., :3], atol=PLACEMENT_TOL, rtol=0)
    # q and -q are the same rotation
    sign = np.where(np.einsum("...i,...i", drawn[..., 3:], expected[..., 3:]) < 0.0, -1.0, 1.0)
    np.testing.assert_allclose(
        drawn[..., 3:], sign[..., None] * expected[..., 3:], atol=PLACEMENT_TOL, rtol=0
    )


def frame_count(commands: list[dict]) -> int:
    (animation,) = [c for c in commands if c["type"] == "set_animation"]
    return len(animation["animations"][0]["clip"]["tracks"][0]["times"])


# ---------------------------------------------------------------------------- URDF visuals
def test_reference_assembly_closes_the_loop(robot, run):
    """The closed-form reference itself: the loop closes and the tip is where the plant put it."""
    for k in (0, len(run.t) // 2, len(run.t) - 1):
        q, points = closed_form_configuration(robot, run.alpha[k])
        assert robot.closure_gap(q) < 1e-12
        np.testing.assert_allclose(points["T"], run.xyz[k], atol=1e-9)


def test_page_holds_one_node_per_urdf_visual(page, robot):
    objects = robot_objects(commands_of(page))
    reference = pin.buildGeomFromUrdfString(robot.model, robot.urdf, pin.GeometryType.VISUAL)
    assert reference.ngeoms == len(VISUALS) == 7
    assert sorted(objects) == sorted(g.name for g in reference.geometryObjects)
    kinds = {"box": "BoxGeometry", "cylinder": "CylinderGeometry", "sphere": "SphereGeometry"}
    rank: dict[str, int] = {}
    for link, tag, *_rest in VISUALS:  # Pinocchio names a link's visuals <link>_<rank>
        rank[link] = rank.get(link, -1) + 1
        geometry = objects[f"{link}_{rank[link]}"]["geometries"][0]
        assert geometry["type"] == kinds[tag], (link, tag)
        if tag == "cylinder":
            assert geometry["height"] == pytest.approx(PROXIMAL, rel=1e-6)
            assert geometry["radiusTop"] == pytest.approx(0.01, rel=1e-6)
    color = objects["proximal_2_0"]["materials"][0]["color"]
    assert color == round(0.85 * 255) << 16 | round(0.1 * 255) << 8 | round(0.1 * 255)


def test_drawn_placements_equal_pinocchio_at_the_assembled_configuration(page, robot, run):
    commands = commands_of(page)
    count = frame_count(commands)
    assert count == math.floor(T_END * FPS + 1e-9) + 1  # 10 frames
    reference = pin.buildGeomFromUrdfString(robot.model, robot.urdf, pin.GeometryType.VISUAL)
    names = [g.name for g in reference.geometryObjects]
    data, geometry_data = robot.model.createData(), pin.GeometryData(reference)
    expected = np.empty((count, len(names), 7))
    tips, elbows = [], []
    for k, alpha in enumerate(frame_alphas(run, count)):
        q, points = closed_form_configuration(robot, alpha)
        pin.updateGeometryPlacements(robot.model, data, reference, geometry_data, q)
        expected[k] = [pin.SE3ToXYZQUAT(placement) for placement in geometry_data.oMg]
        tips.append(points["T"])
        elbows.append(points["E1"])
    drawn = drawn_poses(commands, names, count)
    assert_same_poses(drawn, expected)
    # and, without Pinocchio: the tip sphere is at the closed-form tip, the first distal box's
    # centre half-way from its elbow to the tip, the base box does not move
    np.testing.assert_allclose(drawn[:, names.index("tip_0"), :3], tips, atol=PLACEMENT_TOL)
    middle = 0.5 * (np.array(elbows) + np.array(tips))
    np.testing.assert_allclose(drawn[:, names.index("distal_1_0"), :3], middle, atol=PLACEMENT_TOL)
    np.testing.assert_allclose(drawn[:, names.index("base_0"), :3], 0.0, atol=PLACEMENT_TOL)
    # the motion is real: the tip moves ~2 cm over the 10 frames
    assert np.linalg.norm(tips[-1] - tips[0]) > 0.01


def test_rebuilt_robot_draws_the_same_page_as_the_robot_given(page, run, robot, folder):
    given = export_html(run, folder / "given.html", robot=robot, fps=FPS)
    assert given.read_text(encoding="utf-8") == page.read_text(encoding="utf-8")
    # and from the saved run file (its metadata carries the URDF and the actuated joints)
    saved = export_html(run.save(folder / "run.npz"), folder / "saved.html", fps=FPS)
    assert saved.read_text(encoding="utf-8") == page.read_text(encoding="utf-8")


def test_desired_ghost_follows_the_reference(run, robot, folder):
    commands = commands_of(export_html(run, folder / "ghost.html", show_desired_ghost=True, fps=FPS))
    count = frame_count(commands)
    (animation,) = [c for c in commands if c["type"] == "set_animation"]
    clip = {item["path"]: item["clip"] for item in animation["animations"]}[
        "/meshcat/delta_pin/desired_pose/tip_0"
    ]
    positions = np.asarray(clip["tracks"][0]["values"], dtype=float).reshape(-1, 3)
    times = run.t[0] + np.arange(count) / FPS
    alpha_d = np.column_stack([np.interp(times, run.t, run.alpha_d[:, j]) for j in range(2)])
    expected = [closed_form_configuration(robot, a)[1]["T"] for a in alpha_d]
    np.testing.assert_allclose(positions, expected, atol=PLACEMENT_TOL)


# ------------------------------------------------------------------------ no visual: skeleton
def test_robot_without_visuals_draws_its_skeleton(bare_page, bare_robot, bare_run):
    commands = commands_of(bare_page)
    objects = robot_objects(commands)
    # a cylinder per joint-to-child segment (the base's two halves, the proximal links) and per
    # joint-to-closure-frame segment (the distal links; the tip frame is loop_1's point), a
    # sphere per closure frame
    segments = {
        "skeleton_universe-motor_1": BASE / 2, "skeleton_universe-motor_2": BASE / 2,
        "skeleton_motor_1-elbow_1": PROXIMAL, "skeleton_motor_2-elbow_2": PROXIMAL,
        "skeleton_elbow_1-loop_1": DISTAL, "skeleton_elbow_2-loop_2": DISTAL,
    }  # fmt: skip
    spheres = ["closure_loop_1", "closure_loop_2"]
    assert sorted(objects) == sorted([*segments, *spheres])
    radius = 0.02 * DISTAL  # 2 % of the longest segment
    for name, length in segments.items():
        geometry = objects[name]["geometries"][0]
        assert geometry["type"] == "CylinderGeometry"
        assert geometry["height"] == pytest.approx(length, rel=1e-6)
        assert geometry["radiusTop"] == pytest.approx(radius, rel=1e-6)
    for name in spheres:
        assert objects[name]["geometries"][0]["radius"] == pytest.approx(2 * radius, rel=1e-6)

    # placements from the closed-form five-bar: each segment's centre half-way between its ends,
    # its axis along them; both closure spheres at the tip
    count = frame_count(commands)
    names = [*segments, *spheres]
    drawn = drawn_poses(commands, names, count)
    for k, alpha in enumerate(frame_alphas(bare_run, count)):
        _q, p = closed_form_configuration(bare_robot, alpha)
        ends = {
            "skeleton_universe-motor_1": (np.zeros(3), p["A1"]),
            "skeleton_universe-motor_2": (np.zeros(3), p["A2"]),
            "skeleton_motor_1-elbow_1": (p["A1"], p["E1"]), "skeleton_motor_2-elbow_2": (p["A2"], p["E2"]),
            "skeleton_elbow_1-loop_1": (p["E1"], p["T"]), "skeleton_elbow_2-loop_2": (p["E2"], p["T"]),
            "closure_loop_1": (p["T"], p["T"]), "closure_loop_2": (p["T"], p["T"]),
        }  # fmt: skip
        for j, name in enumerate(names):
            start, end = ends[name]
            placement = pin.XYZQUATToSE3(drawn[k, j])
            np.testing.assert_allclose(placement.translation, 0.5 * (start + end), atol=PLACEMENT_TOL)
            if name in segments:  # the cylinder's z axis along the segment
                axis = (end - start) / np.linalg.norm(end - start)
                np.testing.assert_allclose(placement.rotation[:, 2], axis, atol=PLACEMENT_TOL)


def test_mesh_visual_is_read_from_the_robots_folder(tmp_path):
    """A mesh visual at a path relative to the URDF: drawn from robot.base_dir with trimesh, placed
    where Pinocchio (which reads the same file itself) places it; a run alone cannot locate it."""
    import trimesh

    (tmp_path / "meshes").mkdir()
    trimesh.creation.box(extents=[DISTAL, 0.02, 0.02]).export(tmp_path / "meshes" / "distal.stl")
    robot = write_robot(tmp_path, five_bar_with_visuals(distal_mesh="meshes/distal.stl"))
    run = simulate_circle(robot)
    # the run records the URDF's folder, so the relative mesh resolves without robot= too
    rebuilt = export_html(run, tmp_path / "x.html", fps=FPS).read_bytes()
    given = export_html(run, tmp_path / "mesh.html", robot=robot, fps=FPS)
    assert rebuilt == given.read_bytes()
    commands = commands_of(given)
    geometry = robot_objects(commands)["distal_1_0"]["geometries"][0]
    assert geometry["type"] == "BufferGeometry"
    mesh = trimesh.load(tmp_path / "meshes" / "distal.stl", force="mesh")
    positions = np.asarray(geometry["data"]["attributes"]["position"]["array"]).reshape(-1, 3)
    np.testing.assert_allclose(positions, mesh.vertices[mesh.faces].reshape(-1, 3), atol=1e-7)

    reference = pin.buildGeomFromUrdfString(
        robot.model, robot.urdf, pin.GeometryType.VISUAL, package_dirs=[str(tmp_path)]
    )
    names = [g.name for g in reference.geometryObjects]
    assert type(reference.geometryObjects[names.index("distal_1_0")].geometry).__name__ == "BVHModelOBBRSS"
    count = frame_count(commands)
    data, geometry_data = robot.model.createData(), pin.GeometryData(reference)
    expected = np.empty((count, len(names), 7))
    for k, alpha in enumerate(frame_alphas(run, count)):
        pin.updateGeometryPlacements(
            robot.model, data, reference, geometry_data, closed_form_configuration(robot, alpha)[0]
        )
        expected[k] = [pin.SE3ToXYZQUAT(placement) for placement in geometry_data.oMg]
    assert_same_poses(drawn_poses(commands, names, count), expected)


# ----------------------------------------------------------------------- a robot's visual_model
def test_visual_model_is_drawn_instead_of_the_urdf_visuals(robot, run, folder):
    """A robot carrying a pin.GeometryModel (as an MJCF robot may): its capsule, triangle mesh
    and convex are drawn, placed where Pinocchio places them; the URDF's visuals are not."""
    import coal

    other = write_robot(folder, five_bar_with_visuals(), name="with_visual_model.urdf")
    model = other.model
    visual_model = pin.GeometryModel()
    capsule = pin.GeometryObject(
        "arm", model.getJointId("motor_1"), model.getFrameId("proximal_1"),
        pin.SE3(pin.utils.rotate("y", math.pi / 2), np.array([PROXIMAL / 2, 0.0, 0.0])),
        coal.Capsule(0.012, PROXIMAL),  # radius, full length
    )  # fmt: skip
    capsule.meshColor = np.array([0.2, 0.3, 0.9, 1.0])
    tetra = coal.BVHModelOBBRSS()
    vertices = 0.05 * np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    tetra.beginModel(4, 4)
    tetra.addVertices(vertices)
    tetra.addTriangles(faces)
    tetra.endModel()
    mesh = pin.GeometryObject(
        "", model.getJointId("elbow_2"), model.getFrameId("distal_2"),
        pin.SE3(np.eye(3), np.array([DISTAL, 0.0, 0.0])), tetra,
    )  # fmt: skip
    corners = 0.01 * np.array(list(itertools.product([-1.0, 1.0], repeat=3)))
    points = coal.StdVec_Vec3s()
    for corner in corners:
        points.append(corner)
    cube = pin.GeometryObject(
        "cube", model.getJointId("elbow_1"), model.getFrameId("distal_1"),
        pin.SE3(np.eye(3), np.array([DISTAL / 2, 0.0, 0.0])), coal.ConvexBase.convexHull(points, False, ""),
    )  # fmt: skip
    visual_model.addGeometryObject(capsule)
    visual_model.addGeometryObject(mesh)
    visual_model.addGeometryObject(cube)
    other.visual_model = visual_model

    commands = commands_of(export_html(run, folder / "visual_model.html", robot=other, fps=FPS))
    objects = robot_objects(commands)
    names = ["arm", "visual_1", "cube"]  # an unnamed object gets its index
    assert sorted(objects) == sorted(names)
    arm = objects["arm"]["geometries"][0]
    assert arm["type"] == "BufferGeometry"
    points = np.asarray(arm["data"]["attributes"]["position"]["array"]).reshape(-1, 3)
    np.testing.assert_allclose(points[:, 2].max(), PROXIMAL / 2 + 0.012, atol=1e-6)
    np.testing.assert_allclose(points[:, 2].min(), -PROXIMAL / 2 - 0.012, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(points[:, :2], axis=1).max(), 0.012, atol=1e-6)
    # every (non-degenerate) triangle faces away from the capsule's axis segment
    triangles = points.reshape(-1, 3, 3).astype(float)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    centres = triangles.mean(axis=1)
    axis_points = np.column_stack([0 * centres[:, :2], np.clip(centres[:, 2], -PROXIMAL / 2, PROXIMAL / 2)])
    area = np.linalg.norm(normals, axis=1) > 1e-12
    assert (np.einsum("ij,ij->i", normals, centres - axis_points)[area] > 0.0).all()
    assert objects["arm"]["materials"][0]["color"] == round(0.2 * 255) << 16 | round(0.3 * 255) << 8 | round(
        0.9 * 255
    )
    mesh_points = np.asarray(objects["visual_1"]["geometries"][0]["data"]["attributes"]["position"]["array"])
    np.testing.assert_allclose(mesh_points.reshape(-1, 3), vertices[faces].reshape(-1, 3), atol=1e-7)

    # the convex cube: its hull's 12 triangles on its 8 corners, each turned outwards
    cube_points = np.asarray(objects["cube"]["geometries"][0]["data"]["attributes"]["position"]["array"])
    triangles = cube_points.reshape(-1, 3, 3)
    assert len(triangles) == 12
    np.testing.assert_allclose(
        np.unique(triangles.reshape(-1, 3), axis=0), np.unique(corners, axis=0), atol=1e-7
    )
    outward = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    assert (np.einsum("ij,ij->i", outward, triangles.mean(axis=1)) > 0.0).all()

    count = frame_count(commands)
    data, geometry_data = model.createData(), pin.GeometryData(visual_model)
    expected = np.empty((count, 3, 7))
    for k, alpha in enumerate(frame_alphas(run, count)):
        q, _points = closed_form_configuration(other, alpha)
        pin.updateGeometryPlacements(model, data, visual_model, geometry_data, q)
        expected[k] = [pin.SE3ToXYZQUAT(placement) for placement in geometry_data.oMg]
    assert_same_poses(drawn_poses(commands, names, count), expected)


# ---------------------------------------------------------------------------------- bad input
def with_metadata(run: Run, **changes) -> Run:
    return Run(**{**run.__dict__, "metadata": {**run.metadata, **changes}})


@pytest.mark.parametrize(
    "urdf, reason",
    [
        (None, "it carries no URDF"),
        ("strip", r"its URDF has no <constraint> and the run records no closure frames"),
    ],
    ids=["mjcf_like", "older_gepetto_like"],
)
def test_run_that_cannot_rebuild_its_robot_needs_robot(run, robot, tmp_path, urdf, reason):
    changes = {}
    if urdf == "strip":  # loops from another file, in a run saved before closure frames were kept
        urdf = re.sub(r"<constraint .*?</constraint>", "", robot.urdf, flags=re.S)
        meta = run.metadata["robot"]
        changes["robot"] = {
            **meta,
            "closures": [{"name": c["name"], "kind": c["kind"]} for c in meta["closures"]],
        }
    bare = with_metadata(run, urdf=urdf, **changes)
    target = tmp_path / "needs_robot.html"
    with pytest.raises(VisualizationError) as info:
        export_html(bare, target)
    message = str(info.value)
    assert "\n" not in message
    assert re.fullmatch(
        rf"the run's closed-chain robot 'five_bar' \(from five_bar\.urdf\) cannot be rebuilt from the "
        rf"run: {reason}.*; pass robot=load_robot\(path\) with the file it was loaded from",
        message,
    ), message
    assert not isinstance(info.value, RobotMismatchError) and not target.exists()
    if urdf is None:  # with the robot given, it draws (no URDF to compare)
        assert export_html(bare, target, robot=robot).is_file()


def test_run_whose_loops_came_from_another_file_rebuilds_from_its_closure_frames(run, robot, tmp_path):
    """A URDF without <constraint> (a Gepetto robot.yaml closed the loops): the run's recorded
    closure frames rebuild it, and the page equals the one drawn with the robot given."""
    stripped = re.sub(r"<constraint .*?</constraint>", "", robot.urdf, flags=re.S)
    bare = with_metadata(run, urdf=stripped)
    page = export_html(bare, tmp_path / "rebuilt.html", fps=FPS)
    given = export_html(run, tmp_path / "given.html", robot=robot, fps=FPS)
    assert drawn_poses(commands_of(page), ["tip_0"], frame_count(commands_of(page))) == pytest.approx(
        drawn_poses(commands_of(given), ["tip_0"], frame_count(commands_of(given))), abs=PLACEMENT_TOL
    )


def test_robot_with_other_actuated_joints_is_refused(run, folder):
    swapped = write_robot(
        folder, five_bar_with_visuals(), name="swapped.urdf", actuated=["motor_2", "motor_1"]
    )
    with pytest.raises(RobotMismatchError, match=r"actuated joints \['motor_1', 'motor_2'\] \(run\) vs"):
        export_html(run, folder / "x.html", robot=swapped)


def test_robot_that_does_not_reproduce_the_run_is_refused(run, folder):
    """No URDF to compare (an MJCF-like run): the robot given is assembled at alpha[0] and its
    tip is 5 cm from where the run recorded it."""
    other = write_robot(folder, five_bar_urdf(tip=(0.05, 0.0, -0.4)), name="other.urdf")
    with pytest.raises(RobotMismatchError, match=r"frame 'tip' 50 mm from the run's xyz\[0\]"):
        export_html(with_metadata(run, urdf=None), folder / "x.html", robot=other)


def test_run_with_the_wrong_number_of_joint_angles_is_refused(run, robot, folder):
    three = Run(**{**run.__dict__, "alpha": np.column_stack([run.alpha, run.alpha[:, :1]])})
    with pytest.raises(RobotMismatchError, match=r"3 joint angle\(s\) per sample and the robot 2"):
        export_html(three, folder / "x.html", robot=robot)


# -------------------------------------------------------------------------------- live viewer
def test_live_viewer_smoke(run, folder):
    """view_live draws, through a real local meshcat server, the same scene the export records."""
    if os.environ.get("DELTA_PIN_SKIP_LIVE_VIEWER"):
        pytest.skip("DELTA_PIN_SKIP_LIVE_VIEWER is set")
    live = live_scene_commands(run)
    recorded = commands_of(export_html(run, folder / "live_reference.html"))
    assert sorted(map(scene_key, live)) == sorted(map(scene_key, recorded))
    assert len(robot_objects(live)) == len(VISUALS)


# ----------------------------------------------------------------------------- real browser
def screenshot(tmp_path: Path, page: Path, budget_ms: int) -> np.ndarray:
    from PIL import Image

    png = tmp_path / f"shot-{uuid.uuid4().hex[:8]}.png"
    command = [
        CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
        "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run",
        f"--user-data-dir={tmp_path / ('profile-' + png.stem)}", f"--window-size={WINDOW[0]},{WINDOW[1]}",
        f"--virtual-time-budget={budget_ms}", f"--screenshot={png}", page.as_uri(),
    ]  # fmt: skip
    result = run_browser(command, 120)
    assert result.returncode == 0, result.stderr[-2000:]
    return np.asarray(Image.open(png).convert("RGB")).astype(int)


def colour_counts(rgb: np.ndarray) -> dict[str, float]:
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return {
        "sky": float(((b - r) < 40)[40:120, 0:150].mean()),  # meshcat's blue background drawn
        "red": int(((r > 140) & (g < 90) & (b < 90)).sum()),  # the proximal cylinders
        "green": int(((g > 110) & (g > r + 40) & (g > b + 10)).sum()),  # the distal boxes
        "orange": int(((r > 180) & (g > 80) & (g < 180) & (b < 100)).sum()),  # tip / closure spheres
        "grey": int(((np.abs(r - g) < 12) & (np.abs(g - b) < 12) & (r > 60)).sum()),  # base, skeleton
    }


@needs_chromium
def test_browser_renders_the_five_bar(page, bare_page, tmp_path):
    stats = colour_counts(screenshot(tmp_path, page, 1000))
    # measured: sky 0.0, red 10582 px, green 10827 px, orange 417 px, grey 17332 px
    assert stats["sky"] < 0.02, stats  # the background is drawn: WebGL works
    assert stats["red"] > 3000 and stats["green"] > 3000 and stats["orange"] > 100, stats
    # the skeleton: grey cylinders, orange closure spheres, nothing red or green
    # measured: sky 0.0, grey 24354 px, orange 195 px, red 56 px, green 21 px
    stats = colour_counts(screenshot(tmp_path, bare_page, 1000))
    assert stats["sky"] < 0.02, stats
    assert stats["grey"] > 8000 and stats["orange"] > 80, stats
    assert stats["red"] < 1000 and stats["green"] < 1000, stats

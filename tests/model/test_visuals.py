"""Mesh visuals (delta_pin.model.visuals): the mesh Delta, its physics, paths, errors, yourdfpy."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

import delta_pin as dp
from delta_pin.cli import main
from delta_pin.errors import MeshFileError, URDFConventionError
from delta_pin.model.description import compile_urdf, default_xacro_path
from delta_pin.model.visuals import load_visual_meshes, resolve_mesh_path
from tests.model.closed_chain_fixtures import assert_same_numbers

URDF_DIR = default_xacro_path().parent
MESH_URDF = URDF_DIR / "delta_mesh.urdf"  # relative filenames: meshes/base.stl ...
MESH_FILES = ("base.stl", "forearm.stl", "platform.dae", "upper_arm.obj")


def test_packaged_meshes_are_small_and_the_script_rebuilds_them(tmp_path):
    """The script writes the shipped meshes and delta_mesh.urdf again (into tmp_path, the package
    untouched): the same faces and vertices to 1e-12 (trimesh's trigonometry may differ in its
    last digits between libm/numpy builds, so the files are compared after parsing, never byte
    for byte) and the URDF's words and numbers (assert_same_numbers, 1e-12 relative)."""
    sizes = {name: (URDF_DIR / "meshes" / name).stat().st_size for name in MESH_FILES}
    assert all(0 < size < 8_000 for size in sizes.values()), sizes  # measured 389-4884 bytes
    script = Path(__file__).resolve().parents[2] / "scripts" / "make_delta_meshes.py"
    if not script.is_file():
        pytest.skip("scripts/ is not shipped with an installed package")
    subprocess.run([sys.executable, str(script), "--out", str(tmp_path)], check=True, capture_output=True)
    for name in MESH_FILES:
        shipped, rebuilt = (
            trimesh.load(folder / "meshes" / name, force="mesh") for folder in (URDF_DIR, tmp_path)
        )
        np.testing.assert_array_equal(rebuilt.faces, shipped.faces, err_msg=name)
        np.testing.assert_allclose(rebuilt.vertices, shipped.vertices, rtol=0, atol=1e-12, err_msg=name)
    assert_same_numbers(
        MESH_URDF.read_text(encoding="utf-8"), (tmp_path / "delta_mesh.urdf").read_text(encoding="utf-8"),
        "delta_mesh.urdf",
    )  # fmt: skip


@pytest.mark.parametrize("source", ["relative", "package"])
def test_mesh_delta_has_the_same_physics(robot, source, rng):
    mesh = dp.load_delta(MESH_URDF) if source == "relative" else dp.load_delta(visuals="mesh")
    assert "<mesh" in mesh.urdf and "<mesh" not in robot.urdf
    assert mesh.params == robot.params
    a, b = robot.pinocchio.model, mesh.pinocchio.model
    assert (a.nq, a.nv, list(a.names)) == (b.nq, b.nv, list(b.names))
    for i in range(a.njoints):
        np.testing.assert_array_equal(
            a.inertias[i].toDynamicParameters(), b.inertias[i].toDynamicParameters()
        )
        np.testing.assert_array_equal(a.jointPlacements[i].homogeneous, b.jointPlacements[i].homogeneous)
    for _ in range(5):
        alpha = rng.uniform(-0.3, 0.6, 3)
        alpha_dot = rng.uniform(-2.0, 2.0, 3)
        expected = robot.pinocchio_dynamics(alpha, alpha_dot)
        got = mesh.pinocchio_dynamics(alpha, alpha_dot)
        for name in ("M", "coriolis", "G"):
            np.testing.assert_allclose(getattr(got, name), getattr(expected, name), rtol=0, atol=1e-12)


def test_loading_a_mesh_delta_imports_neither_yourdfpy_nor_trimesh():
    code = (
        "import sys, delta_pin as dp; dp.load_delta(sys.argv[1]); dp.load_delta(visuals='mesh');"
        "print(sorted(m for m in ('yourdfpy', 'trimesh', 'collada') if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, str(MESH_URDF)], capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "[]"


def test_meshes_read_with_yourdfpy_and_trimesh(robot):
    mesh = dp.load_delta(MESH_URDF)
    meshes = load_visual_meshes(mesh.urdf, mesh.description.base_dir)
    # base, platform, and one upper arm and one forearm per chain
    assert sorted({m.path.name for m in meshes.values()}) == sorted(MESH_FILES)
    assert len(meshes) == 8
    forearm = meshes[("forearm_1", 0)]
    np.testing.assert_allclose(forearm.scale, [0.02 * 0.4, 0.02 * 0.4, 0.4], rtol=1e-12)
    # unit cylinder: radius 1 and height 1 before scale (12 sides: 48 triangles)
    np.testing.assert_allclose(
        np.ptp(forearm.vertices, axis=0), [2.0, 2.0 * np.sin(np.pi / 2), 1.0], atol=1e-9
    )
    assert forearm.faces.shape == (48, 3)
    assert meshes[("platform", 0)].faces.shape == (24, 3)  # the DAE's hexagonal prism
    assert load_visual_meshes(robot.urdf, None) == {}


def test_mesh_uri_moves_the_meshes(tmp_path):
    (tmp_path / "cad").mkdir()
    for name in MESH_FILES:
        (tmp_path / "cad" / name).write_bytes((URDF_DIR / "meshes" / name).read_bytes())
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(compile_urdf(visuals="mesh", mesh_uri=str(tmp_path / "cad")))
    loaded = dp.load_delta(urdf)
    paths = {m.path for m in load_visual_meshes(loaded.urdf, loaded.description.base_dir).values()}
    assert paths == {tmp_path / "cad" / name for name in MESH_FILES}


@pytest.mark.parametrize(
    ("filename", "message"),
    [
        (
            "meshes/missing.stl",
            r"mesh 'meshes/missing\.stl' \(visual 0 of link 'base_link'\): "
            r"file '.*missing\.stl' does not exist",
        ),
        ("package://no_such_pkg/m.stl", r"no Python package .* named 'no_such_pkg'; use a path relative"),
        ("meshes/base.step", r"\.step files are not read; give an STL, OBJ or DAE file"),
    ],
)
def test_bad_mesh_paths_name_the_file(tmp_path, filename, message):
    text = MESH_URDF.read_text().replace("meshes/base.stl", filename, 1)
    urdf = tmp_path / "bad.urdf"
    urdf.write_text(text)
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "base.step").write_text("not a mesh")
    with pytest.raises(MeshFileError, match=message) as info:
        dp.load_delta(urdf)
    assert isinstance(info.value, URDFConventionError)
    assert "\n" not in str(info.value)


def test_unreadable_mesh_names_the_file(tmp_path):
    (tmp_path / "meshes").mkdir()
    for name in MESH_FILES:
        (tmp_path / "meshes" / name).write_bytes((URDF_DIR / "meshes" / name).read_bytes())
    (tmp_path / "meshes" / "forearm.stl").write_bytes(b"solid broken\nnot an stl\n")
    (tmp_path / "robot.urdf").write_text(MESH_URDF.read_text())
    loaded = dp.load_delta(tmp_path / "robot.urdf")  # the file exists: loading does not read it
    with pytest.raises(
        MeshFileError, match=r"mesh 'meshes/forearm\.stl' \(visual 0 of link 'forearm_1'\)"
    ) as info:
        load_visual_meshes(loaded.urdf, loaded.description.base_dir)
    assert "\n" not in str(info.value)


def test_relative_mesh_without_a_folder_says_what_works():
    with pytest.raises(
        MeshFileError, match=r"relative but the URDF's folder is unknown.*load the robot from its file"
    ):
        resolve_mesh_path("meshes/base.stl", None)


@pytest.mark.parametrize(
    "settings", [[], ["--set", "forearm_inertia=rod", "--set", "l_a=0.25"], ["--set", "visuals=mesh"]]
)
def test_every_urdf_delta_pin_writes_loads_in_yourdfpy(tmp_path, settings, capsys):
    yourdfpy = pytest.importorskip("yourdfpy")
    out = tmp_path / "delta.urdf"
    assert main(["urdf", *settings, "-o", str(out)]) == 0
    capsys.readouterr()
    loaded = yourdfpy.URDF.load(str(out), build_scene_graph=True, load_meshes=False)
    assert loaded.validate()
    assert len(loaded.robot.joints) == 3 * 3 + 3 and loaded.base_link == "base_link"
    actuated = [j for j in loaded.robot.joints if j.type != "fixed"]
    assert len(actuated) == 12
    meshes = [
        v.geometry.mesh.filename for link in loaded.robot.links for v in link.visuals if v.geometry.mesh
    ]
    assert len(meshes) == (8 if settings == ["--set", "visuals=mesh"] else 0)
    # and with the meshes loaded through our resolver, as a scene (yourdfpy's forward kinematics)
    if meshes:
        scene = yourdfpy.URDF.load(
            str(out), load_meshes=True, filename_handler=lambda fname: str(resolve_mesh_path(fname, tmp_path))
        ).scene
        assert len(scene.geometry) >= 4


def test_bad_visuals_argument():
    with pytest.raises(dp.XacroArgumentError, match="visuals='cad' must be one of primitive, mesh"):
        compile_urdf(visuals="cad")
    with pytest.raises(dp.XacroArgumentError, match="mesh_uri"):
        compile_urdf(visuals="mesh", mesh_uri="a b")

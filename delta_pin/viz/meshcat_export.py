"""Headless meshcat export of a :class:`~delta_pin.sim.runner.Run` to ONE standalone HTML file.

The robot is drawn from the visual geometry of the URDF the run came from, read by Pinocchio's
geometry model (``pin.buildGeomFromUrdfString(..., pin.GeometryType.VISUAL)``); mesh visuals (STL,
OBJ, DAE) are read with yourdfpy and trimesh (:mod:`delta_pin.model.visuals`, imported only when the
URDF has one) and drawn as triangle meshes where Pinocchio places a stand-in. It is posed at every
animation frame by the closure-consistent configuration q(alpha)
(:meth:`~delta_pin.model.pinocchio_model.DeltaPinocchioModel.configuration`). The desired (``xyz_d``)
and actual (``xyz``) platform paths are drawn as two lines of different colours; a translucent
ghost of the desired pose q(alpha_d) is optional.

No meshcat server is started (docs/architecture.md section 7): :class:`RecordingWindow` stands in for
meshcat's ``ViewerWindow`` and keeps the msgpack-packed commands in the scene tree that meshcat's
zmq server would keep; :func:`scene_html` then writes the page ``Visualizer.static_html()``
returns (meshcat's JS bundle inlined, about 0.85 MB, so the page works offline), except that the
commands are decoded and applied synchronously, in order, instead of through one
``fetch("data:...")`` promise each.

Real-time playback: frame k shows the run at ``t[0] + k / fps`` (joint angles interpolated
linearly between samples), its key time is k frames, and the animation clip's ``fps`` is that
same ``fps`` (three.js scales key times by 1 / fps): one second of run lasts one second on screen.
"""

from __future__ import annotations

import base64
import html
import itertools
import json
import math
import os
import uuid
import zipfile
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from delta_pin.errors import DeltaPinError, InvalidParameterError, NonFiniteError
from delta_pin.sim.run import Run, load_run
from delta_pin.utils.atomic import write_text_atomically

__all__ = [
    "DEFAULT_FPS",
    "DEFAULT_PATH_COLORS",
    "EmptyRunError",
    "RecordingWindow",
    "RobotMismatchError",
    "RunFileNotFoundError",
    "VisualizationError",
    "close_live",
    "export_html",
    "read_scene_commands",
    "scene_html",
    "view_live",
]

DEFAULT_FPS = 30.0  # [frames/s]
DEFAULT_PATH_COLORS = (0x2CA02C, 0xD62728)  # (desired, actual): green, red
GHOST_OPACITY = 0.35
MAX_PATH_POINTS = 4000  # points per path line (the run's samples, strided)
ROOT = "delta_pin"  # scene path under meshcat's /meshcat
# from the scene's centre towards the camera: azimuth 70 deg, elevation 25 deg
CAMERA_DIRECTION = np.array([0.31, 0.85, 0.42])
CAMERA_FOV = 75.0  # [deg] vertical field of view of meshcat's default camera
_FLOAT32_EXT = 0x17  # msgpack ext code meshcat's JS (msgpack-lite) decodes as a Float32Array
_UUID_NAMESPACE = uuid.UUID("6f9d3c52-1f0e-4b3a-9a51-0d5e7a1c2b40")
_SCENE_SCRIPT_ID = "delta-pin-scene"
_RING = np.linspace(0.0, 2.0 * math.pi, 12, endpoint=False)
_AXES = np.vstack([np.eye(3), -np.eye(3)])


class VisualizationError(DeltaPinError):
    """A run that cannot be drawn (missing data, unsupported geometry, missing meshcat)."""


class RunFileNotFoundError(VisualizationError, FileNotFoundError):
    """The run file given by path does not exist."""


class RobotMismatchError(VisualizationError, ValueError):
    """The robot given is not the robot the run was simulated on (their URDFs differ)."""


class EmptyRunError(VisualizationError, ValueError):
    """A run with no samples: nothing to draw."""


# --------------------------------------------------------------------------------------- meshcat
def _meshcat():
    try:
        import meshcat
        import meshcat.commands
        import meshcat.geometry
        import meshcat.servers.tree
    except ImportError as exc:  # pragma: no cover - meshcat is installed with delta-pin's viz extra
        raise VisualizationError(f"meshcat is needed to draw runs ({exc}): pip install meshcat") from exc
    return meshcat


class RecordingWindow:
    """A stand-in for meshcat's ``ViewerWindow`` that records commands instead of sending them.

    ``meshcat.Visualizer(window=RecordingWindow())`` draws without a server: each command is
    packed with msgpack and kept in the same scene tree meshcat's zmq server keeps (a later
    ``set_object`` on a path replaces the earlier one, ``delete`` drops a subtree), so
    :meth:`commands` lists what ``static_html()`` would embed.

    Args:
        float_precision: ``"single"`` (default: half the bytes, ample for drawing) or ``"double"``.
    """

    def __init__(self, float_precision: str = "single") -> None:
        if float_precision not in ("single", "double"):
            raise InvalidParameterError(f"float_precision={float_precision!r} must be 'single' or 'double'")
        self.float_precision = float_precision
        self.tree = _meshcat().servers.tree.SceneTree()
        self.animations: list[bytes] = []
        self.web_url = None

    def send(self, command) -> None:
        import umsgpack
        from meshcat.servers.tree import find_node

        data = command.lower()
        packed = umsgpack.packb(data, force_float_precision=self.float_precision)
        kind = data["type"]
        path = [entry for entry in data.get("path", "").split("/") if entry]
        if kind == "set_object":
            node = find_node(self.tree, path)
            node.object, node.properties = packed, []
        elif kind == "set_transform":
            find_node(self.tree, path).transform = packed
        elif kind == "set_property":
            find_node(self.tree, path).properties.append(packed)
        elif kind == "set_animation":
            self.animations = [packed]  # meshcat's viewer keeps one animation at a time
        elif kind == "delete":
            if path:
                find_node(self.tree, path[:-1]).pop(path[-1], None)
            else:
                self.tree = _meshcat().servers.tree.SceneTree()
        else:
            raise VisualizationError(f"a recorded scene cannot hold a {kind!r} command")

    def commands(self) -> list[bytes]:
        """The packed commands in the server's order (tree walk), the animation last."""
        from meshcat.servers.tree import walk

        packed = []
        for node in walk(self.tree):
            if node.object is not None:
                packed.append(node.object)
            packed.extend(node.properties)
            if node.transform is not None:
                packed.append(node.transform)
        return packed + self.animations

    def open(self):
        raise VisualizationError("a RecordingWindow has no server to open: write scene_html() to a file")

    def close(self) -> None:
        pass


_PAGE = """<!DOCTYPE html>
<html>
    <head> <meta charset=utf-8> <title>{title}</title> </head>
    <body>
        <div id="meshcat-pane">
        </div>
        <script>
            {bundle}
        </script>
        <script id="{scene_id}" type="application/json">{commands}</script>
        <script>
            var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
            (function (commands) {{
                for (var i = 0; i < commands.length; i++) {{
                    var raw = atob(commands[i]);
                    var bytes = new Uint8Array(raw.length);
                    for (var j = 0; j < raw.length; j++) {{
                        bytes[j] = raw.charCodeAt(j);
                    }}
                    viewer.handle_command_bytearray(bytes);
                }}
            }})(JSON.parse(document.getElementById("{scene_id}").textContent));
        </script>
        <style>
            body {{margin: 0; }}
            #meshcat-pane {{
                width: 100vw;
                height: 100vh;
                overflow: hidden;
            }}
        </style>
        <script id="embedded-json"></script>
    </body>
</html>
"""


def scene_html(window: RecordingWindow, title: str = "MeshCat") -> str:
    """The standalone page of a recorded scene: meshcat's JS bundle inlined, then the commands.

    The same page as meshcat's ``Visualizer.static_html()`` (same bundle, viewer and commands),
    with the commands kept base64-encoded in a JSON ``<script>`` and applied synchronously in
    order (no ``fetch``), so the scene is complete before the first frame is drawn.
    """
    bundle_path = Path(_meshcat().viewer_assets_path()) / "dist" / "main.min.js"
    if not bundle_path.is_file():  # pragma: no cover - a broken meshcat installation
        raise VisualizationError(f"meshcat's JS bundle {str(bundle_path)!r} is missing")
    commands = json.dumps([base64.b64encode(packed).decode("ascii") for packed in window.commands()])
    return _PAGE.format(
        title=html.escape(title),
        bundle=bundle_path.read_text(encoding="utf-8"),
        scene_id=_SCENE_SCRIPT_ID,
        commands=commands,
    )


def read_scene_commands(page: str) -> list[dict]:
    """Decode the meshcat commands embedded in a page written by :func:`scene_html`.

    Float32 arrays (msgpack ext 0x17) come back as ``numpy`` arrays.

    Raises:
        VisualizationError: the page holds no delta-pin scene.
    """
    import re

    import umsgpack

    match = re.search(
        rf'<script id="{_SCENE_SCRIPT_ID}" type="application/json">(.*?)</script>', page, flags=re.S
    )
    if match is None:
        raise VisualizationError("the page holds no delta-pin scene (not written by scene_html?)")

    handlers = {_FLOAT32_EXT: lambda ext: np.frombuffer(ext.data, dtype="<f4")}
    return [
        umsgpack.unpackb(base64.b64decode(item), ext_handlers=handlers) for item in json.loads(match.group(1))
    ]


# ------------------------------------------------------------------------------------ the scene
def _float32_array(values: np.ndarray):
    import umsgpack

    return umsgpack.Ext(_FLOAT32_EXT, np.ascontiguousarray(values, dtype="<f4").tobytes())


class _Animation:
    """A meshcat animation whose tracks carry float32 arrays (three.js ``times``/``values``).

    meshcat-python's ``Animation`` writes one ``{"time", "value"}`` map per key; three.js's
    ``AnimationClip.parse`` accepts the flat ``times``/``values`` arrays as well, which are about
    four times smaller.
    """

    def __init__(self, fps: float) -> None:
        self.fps = fps
        self.clips: list[tuple[str, np.ndarray, np.ndarray]] = []

    def add(self, path: str, key_frames: np.ndarray, xyzquat: np.ndarray) -> None:
        """Animate the node at ``path``: keys at ``key_frames`` [frames], poses (F, 7) xyz + quat xyzw."""
        self.clips.append((path, key_frames, xyzquat))

    def lower(self) -> list[dict]:
        return [
            {
                "path": path,
                "clip": {
                    "fps": self.fps,
                    "name": "default",
                    "tracks": [
                        {
                            "name": ".position",
                            "type": "vector3",
                            "times": _float32_array(keys),
                            "values": _float32_array(poses[:, :3]),
                        },
                        {
                            "name": ".quaternion",
                            "type": "quaternion",
                            "times": _float32_array(keys),
                            "values": _float32_array(poses[:, 3:]),
                        },
                    ],
                },
            }
            for path, keys, poses in self.clips
        ]


@dataclass
class _Visual:
    name: str
    geometry: Any  # a meshcat geometry
    correction: np.ndarray  # (4, 4) from the node's frame to meshcat's shape frame
    color: int
    opacity: float
    moving: bool
    outline: np.ndarray  # (n, 3) [m] points of the shape's hull in the visual's frame (camera framing)


@dataclass
class _Scene:
    visuals: list[_Visual]
    key_frames: np.ndarray  # (F,) [frames]
    poses: np.ndarray  # (F, V, 7) placements of the visuals along the run
    ghost_poses: np.ndarray | None  # (F, V, 7) along the reference, or None
    xyz: np.ndarray  # (P, 3) [m]
    xyz_d: np.ndarray  # (P, 3) [m]


def _as_run(run: Run | str | os.PathLike) -> Run:
    if isinstance(run, str | os.PathLike):
        path = Path(run)
        if not path.is_file():
            raise RunFileNotFoundError(f"run file {str(path)!r} does not exist")
        try:
            run = load_run(path)
        except (OSError, ValueError, zipfile.BadZipFile, DeltaPinError) as exc:
            raise VisualizationError(f"{str(path)!r} is not a run file saved by Run.save: {exc}") from None
    elif not isinstance(run, Run):
        raise InvalidParameterError(
            f"expected a Run or the path of a run .npz file, got {type(run).__name__}"
        )
    if len(run.t) == 0:
        raise EmptyRunError("the run has no samples (len(run.t) == 0): nothing to draw")
    return run


def _describe_difference(run_urdf: str, robot_urdf: str) -> str:
    from delta_pin.model.description import read_description

    try:
        run_params = asdict(read_description(run_urdf).params)
        robot_params = asdict(read_description(robot_urdf).params)
    except DeltaPinError:
        run_params = robot_params = {}
    differences = [
        f"{name} = {run_params[name]!r} (run) vs {robot_params[name]!r} (robot)"
        for name in run_params
        if run_params[name] != robot_params.get(name)
    ]
    if differences:
        return "; ".join(differences)
    for number, (a, b) in enumerate(itertools.zip_longest(run_urdf.splitlines(), robot_urdf.splitlines()), 1):
        if a != b:
            return f"the URDFs first differ at line {number}: run {str(a)[:80]!r} vs robot {str(b)[:80]!r}"
    return "the URDF texts differ"  # pragma: no cover - only line endings differ


def _resolve_robot(run: Run, robot):
    from delta_pin.model.description import read_description
    from delta_pin.model.robot import Delta

    run_urdf = run.metadata.get("urdf")
    if robot is None:
        if not run_urdf:
            raise VisualizationError("the run carries no URDF (metadata['urdf']): pass robot= to draw it")
        return Delta(read_description(run_urdf, base_dir=run.metadata.get("urdf_dir")))
    if run_urdf and robot.urdf != run_urdf:
        raise RobotMismatchError(
            "the run was simulated on another robot than the one given ("
            + _describe_difference(run_urdf, robot.urdf)
            + "); pass robot=None to draw the run's own robot"
        )
    return robot


def _color(value, what: str) -> int:
    if isinstance(value, str) and len(value) == 7 and value.startswith("#"):
        try:
            return int(value[1:], 16)
        except ValueError:
            pass
    elif isinstance(value, int | np.integer) and 0 <= value <= 0xFFFFFF:
        return int(value)
    raise InvalidParameterError(f"{what}={value!r} must be a colour 0xRRGGBB or '#rrggbb'")


def _rgba_color(rgba) -> tuple[int, float]:
    r, g, b, a = (float(np.clip(c, 0.0, 1.0)) for c in rgba)
    return (round(r * 255) << 16) | (round(g * 255) << 8) | round(b * 255), a


class _TriangleMesh:
    """A meshcat geometry: triangles with flat normals (meshcat's ``TriangularMeshGeometry`` has no
    normals, so three.js's Phong shading would draw it black). Not indexed: each triangle has its
    own three vertices, hence a sharp edge between faces."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self.uuid = str(uuid.uuid1())
        corners = vertices[faces]  # (m, 3, 3)
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        lengths = np.linalg.norm(normals, axis=1, keepdims=True)
        normals = np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0.0)
        self.positions = corners.reshape(-1, 3).astype(np.float32)
        self.normals = np.repeat(normals, 3, axis=0).astype(np.float32)

    # the duck-typed part of meshcat's Geometry (meshcat is imported lazily, so no subclass)
    field = "geometries"

    def intrinsic_transform(self) -> np.ndarray:
        return np.eye(4)

    def lower_in_object(self, object_data: dict) -> str:
        object_data.setdefault(self.field, []).append(self.lower(object_data))
        return self.uuid

    def lower(self, object_data) -> dict:
        pack = _meshcat().geometry.pack_numpy_array
        return {
            "uuid": self.uuid,
            "type": "BufferGeometry",
            "data": {"attributes": {"position": pack(self.positions.T), "normal": pack(self.normals.T)}},
        }


def _visuals(robot) -> tuple[pin.GeometryModel, list[_Visual]]:
    from delta_pin.model.visuals import has_mesh_visuals, load_visual_meshes, primitive_stand_in

    mg = _meshcat().geometry
    model = robot.pinocchio.model
    urdf = robot.urdf
    meshes = {}
    if has_mesh_visuals(urdf):  # Pinocchio places a small sphere for each; the meshes come from trimesh
        meshes = load_visual_meshes(urdf, robot.description.base_dir)
        urdf = primitive_stand_in(urdf)
    try:
        geometry_model = pin.buildGeomFromUrdfString(model, urdf, pin.GeometryType.VISUAL)
    except (RuntimeError, ValueError) as exc:
        raise VisualizationError(f"Pinocchio could not read the URDF's visual geometry: {exc}") from None
    visuals = []
    rank: dict[str, int] = {}  # visuals seen so far per link: (link, rank) names a mesh visual
    for obj in geometry_model.geometryObjects:
        shape = obj.geometry
        kind = type(shape).__name__
        correction = np.eye(4)
        link = model.frames[obj.parentFrame].name
        index = rank[link] = rank.get(link, -1) + 1
        mesh = meshes.get((link, index))
        if mesh is not None:
            geometry = _TriangleMesh(mesh.vertices, mesh.faces)
            correction[:3, :3] = np.diag(mesh.scale)
            step = max(1, len(mesh.vertices) // 200)  # at most ~200 hull points for the camera framing
            outline = mesh.vertices[::step] * mesh.scale
        elif kind == "Cylinder":  # URDF cylinders lie along z, three.js ones along y
            geometry = mg.Cylinder(2.0 * shape.halfLength, shape.radius)
            correction[:3, :3] = pin.utils.rotate("x", math.pi / 2)
            ring = shape.radius * np.column_stack([np.cos(_RING), np.sin(_RING), np.zeros_like(_RING)])
            cap = np.array([0.0, 0.0, shape.halfLength])
            outline = np.vstack([ring + cap, ring - cap])
        elif kind == "Sphere":
            geometry, outline = mg.Sphere(shape.radius), shape.radius * _AXES
        elif kind == "Box":
            geometry = mg.Box((2.0 * shape.halfSide).tolist())
            outline = np.array(list(itertools.product([-1.0, 1.0], repeat=3))) * shape.halfSide
        elif kind == "Ellipsoid":
            geometry, outline = mg.Ellipsoid(np.asarray(shape.radii)), _AXES * np.asarray(shape.radii)
        else:
            raise VisualizationError(
                f"visual {obj.name!r}: geometry {kind} is not supported "
                "(cylinder, sphere, box, ellipsoid, STL/OBJ/DAE mesh)"
            )
        color, opacity = _rgba_color(obj.meshColor)
        visuals.append(_Visual(obj.name, geometry, correction, color, opacity, obj.parentJoint != 0, outline))
    return geometry_model, visuals


def _check_finite(name: str, t: np.ndarray, values: np.ndarray) -> None:
    bad = ~np.all(np.isfinite(values), axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise NonFiniteError(f"run.{name} is not finite at t={t[k]:.6g} s (sample {k}): cannot draw it")


def _frame_times(t: np.ndarray, fps: float) -> np.ndarray:
    """Frame times from the run's start [s]: k / fps, plus the run's end when it falls between frames."""
    duration = float(t[-1] - t[0])
    times = np.arange(math.floor(duration * fps + 1e-9) + 1) / fps
    if duration - times[-1] > 1e-9:
        times = np.append(times, duration)
    return times


def _resample(t: np.ndarray, values: np.ndarray, times: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(t[0] + times, t, values[:, j]) for j in range(values.shape[1])])


def _placements(robot, geometry_model: pin.GeometryModel, alphas: np.ndarray) -> np.ndarray:
    """(F, V, 7) world placements (xyz, quaternion xyzw) of every visual at q(alpha) per frame."""
    pinocchio_model = robot.pinocchio
    model = pinocchio_model.model
    data = model.createData()
    geometry_data = pin.GeometryData(geometry_model)
    poses = np.empty((len(alphas), geometry_model.ngeoms, 7))
    for k, alpha in enumerate(alphas):
        q = pinocchio_model.configuration(alpha)
        pin.updateGeometryPlacements(model, data, geometry_model, geometry_data, q)
        for j in range(geometry_model.ngeoms):
            poses[k, j] = pin.SE3ToXYZQUAT(geometry_data.oMg[j])
    # one sign per quaternion path (q and -q are one rotation): no flips between frames
    for k in range(1, len(poses)):
        flip = np.einsum("ij,ij->i", poses[k, :, 3:], poses[k - 1, :, 3:]) < 0.0
        poses[k, flip, 3:] *= -1.0
    return poses


def _strided(points: np.ndarray, limit: int = MAX_PATH_POINTS) -> np.ndarray:
    if len(points) <= limit:
        return points
    index = np.unique(np.append(np.linspace(0, len(points) - 1, limit).round().astype(int), len(points) - 1))
    return points[index]


def _check_fps(fps) -> float:
    if isinstance(fps, bool) or not isinstance(fps, int | float) or not (math.isfinite(fps) and fps > 0.0):
        raise InvalidParameterError(f"fps={fps!r} must be a positive number of frames per second")
    return float(fps)


def _build_scene(run: Run, robot, fps: float, show_desired_ghost: bool) -> _Scene:
    t = np.asarray(run.t, dtype=float)
    alpha = np.asarray(run.alpha, dtype=float).reshape(len(t), 3)
    _check_finite("alpha", t, alpha)
    times = _frame_times(t, fps)
    geometry_model, visuals = _visuals(robot)
    poses = _placements(robot, geometry_model, _resample(t, alpha, times))
    ghost = None
    if show_desired_ghost:
        alpha_d = np.asarray(run.alpha_d, dtype=float).reshape(len(t), 3)
        _check_finite("alpha_d", t, alpha_d)
        ghost = _placements(robot, geometry_model, _resample(t, alpha_d, times))
    xyz = np.asarray(run.xyz, dtype=float).reshape(len(t), 3)
    xyz_d = np.asarray(run.xyz_d, dtype=float).reshape(len(t), 3)
    _check_finite("xyz", t, xyz)
    _check_finite("xyz_d", t, xyz_d)
    return _Scene(visuals, times * fps, poses, ghost, _strided(xyz), _strided(xyz_d))


def _transform(xyzquat: np.ndarray) -> np.ndarray:
    return pin.XYZQUATToSE3(np.asarray(xyzquat, dtype=float)).homogeneous


def _translation(xyz) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, 3] = xyz
    return matrix


def _stable_uuids(obj, path: str):
    """Replace meshcat's time-based uuids by ones derived from the path (reproducible files)."""
    obj.uuid = str(uuid.uuid5(_UUID_NAMESPACE, path))
    obj.geometry.uuid = str(uuid.uuid5(_UUID_NAMESPACE, path + "#geometry"))
    obj.material.uuid = str(uuid.uuid5(_UUID_NAMESPACE, path + "#material"))
    return obj


def _framing(scene: _Scene, max_frames: int = 60) -> np.ndarray:
    """World points [m] (n, 3) outlining the robot over the run (each visual's hull points) and both paths."""
    points = [scene.xyz, scene.xyz_d]
    frames = np.unique(np.linspace(0, len(scene.key_frames) - 1, max_frames).round().astype(int))
    for poses in (scene.poses, scene.ghost_poses):
        if poses is None:
            continue
        for j, visual in enumerate(scene.visuals):
            for pose in poses[frames, j]:
                placement = pin.XYZQUATToSE3(pose)
                points.append(visual.outline @ placement.rotation.T + placement.translation)
    return np.vstack(points)


def _camera(
    points: np.ndarray, aspect: float = 4.0 / 3.0, margin: float = 1.15
) -> tuple[np.ndarray, np.ndarray]:
    """Orbit centre and camera position [m] that keep ``points`` in view from CAMERA_DIRECTION.

    The camera sits on the ray from the points' bounding-box centre along CAMERA_DIRECTION, at
    the smallest distance at which every point lies inside the field of view of a window of
    width / height ``aspect`` or wider (meshcat keeps the vertical field of view fixed).
    """
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    back = CAMERA_DIRECTION / np.linalg.norm(CAMERA_DIRECTION)  # from the centre to the camera
    right = np.cross(np.array([0.0, 0.0, 1.0]), back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    relative = points - centre
    depth = relative @ back  # towards the camera
    tangent = math.tan(math.radians(CAMERA_FOV) / 2.0)
    lateral = np.maximum(np.abs(relative @ right) / aspect, np.abs(relative @ up))
    distance = max(float(np.max(depth + margin * lateral / tangent)), 0.05)
    return centre, centre + distance * back


def _draw(vis, scene: _Scene, fps: float, path_colors: tuple[int, int], repetitions: int) -> None:
    """Send the whole scene to a meshcat ``Visualizer`` (recording or live)."""
    mc = _meshcat()
    mg = mc.geometry
    root = vis[ROOT]
    animation = _Animation(fps)

    def add(node, visual: _Visual, material, pose: np.ndarray, poses: np.ndarray | None) -> None:
        shape = node["shape"]
        path = shape.path.lower()
        shape.set_object(_stable_uuids(mg.Mesh(visual.geometry, material), path))
        shape.set_transform(visual.correction)
        node.set_transform(_transform(pose))
        if poses is not None:
            animation.add(node.path.lower(), scene.key_frames, poses)

    for j, visual in enumerate(scene.visuals):
        material = mg.MeshPhongMaterial(
            color=visual.color, opacity=visual.opacity, transparent=visual.opacity < 1.0
        )
        moving = scene.poses[:, j] if visual.moving and len(scene.key_frames) > 1 else None
        add(root["robot"][visual.name], visual, material, scene.poses[0, j], moving)
    if scene.ghost_poses is not None:
        for j, visual in enumerate(scene.visuals):
            if not visual.moving:  # the base is shared by both poses
                continue
            material = mg.MeshPhongMaterial(color=path_colors[0], opacity=GHOST_OPACITY, transparent=True)
            moving = scene.ghost_poses[:, j] if len(scene.key_frames) > 1 else None
            add(root["desired_pose"][visual.name], visual, material, scene.ghost_poses[0, j], moving)

    # the desired path first, the actual one over it: where they coincide the actual one shows
    paths = (("desired", scene.xyz_d, path_colors[0]), ("actual", scene.xyz, path_colors[1]))
    for name, points, color in paths:
        node = root["paths"][name]
        # drawn after the solids and without depth test: the path stays visible through the platform
        material = mg.LineBasicMaterial(color=color, transparent=True, depthTest=False, depthWrite=False)
        line = mg.Line(mg.PointsGeometry(points.T.astype(np.float32)), material)
        node.set_object(_stable_uuids(line, node.path.lower()))

    # meshcat 0.3.2's camera always looks at the world origin (its orbit target cannot be set by a
    # command): move the scene so that the centre of the robot's box is there instead
    points = _framing(scene)
    centre, camera = _camera(points)
    root.set_transform(_translation(-centre))
    # the camera's parent "rotated" turns three.js's y-up into z-up: world (x, y, z) = local (x, -z, y)
    offset = camera - centre
    vis["/Cameras/default/rotated/<object>"].set_property("position", [offset[0], offset[2], -offset[1]])
    # meshcat's default scene: hide the 0.5 m axes, put the grid under the robot as a floor
    vis["/Axes"].set_property("visible", False)
    vis["/Grid"].set_transform(_translation([0.0, 0.0, points[:, 2].min() - centre[2] - 0.02]))

    if animation.clips:
        vis.set_animation(animation, play=True, repetitions=repetitions)


def _title(run: Run) -> str:
    controller = run.metadata.get("controller")
    name = controller.get("name") if isinstance(controller, dict) else None
    duration = float(run.t[-1] - run.t[0])
    return f"delta-pin run: {name or 'controller'} ({duration:g} s)"


def _prepare(run, robot, fps, show_desired_ghost, path_colors) -> tuple[Run, _Scene, float, tuple[int, int]]:
    fps = _check_fps(fps)
    try:
        desired_color, actual_color = path_colors
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"path_colors={path_colors!r} must be a pair (desired, actual) of colours"
        ) from None
    colors = (_color(desired_color, "path_colors[0]"), _color(actual_color, "path_colors[1]"))
    run = _as_run(run)
    robot = _resolve_robot(run, robot)
    return run, _build_scene(run, robot, fps, bool(show_desired_ghost)), fps, colors


# ----------------------------------------------------------------------------------- public API
def export_html(
    run: Run | str | os.PathLike,
    path: str | os.PathLike,
    robot=None,
    *,
    fps: float = DEFAULT_FPS,
    show_desired_ghost: bool = False,
    path_colors: tuple[int | str, int | str] = DEFAULT_PATH_COLORS,
    repetitions: int = 1,
) -> Path:
    """Write a run as ONE standalone HTML page that replays it in 3D at real-time speed.

    No meshcat server is started; the page inlines meshcat's viewer (about 0.85 MB of JS) and
    fetches nothing, so it opens offline. Its size grows with the number of frames: about
    1.3 MB for a 15 s run at 30 frames/s (0.85 MB of it the viewer).

    Args:
        run: a :class:`~delta_pin.sim.runner.Run`, or the path of one saved with ``Run.save``.
        path: the HTML file to write (its folder is created; written atomically).
        robot: the :class:`~delta_pin.model.robot.Delta` the run was simulated on; ``None`` rebuilds it
            from the URDF stored with the run (``run.metadata["urdf"]``).
        fps: animation frames per second [1/s]; joint angles are interpolated at k / fps.
        show_desired_ghost: also draw a translucent robot in the desired pose q(alpha_d).
        path_colors: colours (desired, actual) of the two platform paths, ``0xRRGGBB`` or
            ``"#rrggbb"`` (default green, red).
        repetitions: how many times the animation plays on opening.

    Returns:
        The path written.

    Raises:
        RunFileNotFoundError: ``run`` is a path that does not exist.
        EmptyRunError: the run has no samples.
        RobotMismatchError: ``robot`` is not the robot the run came from (the message names
            the parameters, or the URDF line, that differ).
        VisualizationError: ``run`` is a file that is not a saved run, the run carries no URDF
            and no robot is given, or the URDF has an unsupported visual geometry.
        NonFiniteError: NaN or infinite angles or positions (the message gives the time).
        InvalidParameterError: a bad ``fps``, ``path_colors`` or ``repetitions``.
    """
    if isinstance(repetitions, bool) or not isinstance(repetitions, int) or repetitions < 1:
        raise InvalidParameterError(f"repetitions={repetitions!r} must be an integer >= 1")
    run, scene, fps, colors = _prepare(run, robot, fps, show_desired_ghost, path_colors)
    window = RecordingWindow()
    vis = _meshcat().Visualizer(window=window)
    _draw(vis, scene, fps, colors, repetitions)
    path = Path(path)
    write_text_atomically(path, scene_html(window, title=_title(run)))
    return path


def view_live(
    run: Run | str | os.PathLike,
    robot=None,
    open_browser: bool = False,
    *,
    fps: float = DEFAULT_FPS,
    show_desired_ghost: bool = False,
    path_colors: tuple[int | str, int | str] = DEFAULT_PATH_COLORS,
    zmq_url: str | None = None,
):
    """Replay a run in a live meshcat viewer (a local server, started unless ``zmq_url`` is given).

    Draws the same scene as :func:`export_html` and plays the animation once; press "play" in
    the viewer's Animations panel to replay it. The server is a child process of this Python
    process and stops with it.

    Args:
        run, robot, fps, show_desired_ghost, path_colors: as for :func:`export_html`.
        open_browser: open the viewer's URL in the default web browser.
        zmq_url: connect to a running meshcat server (``meshcat-server``) instead of starting one.

    Returns:
        The ``meshcat.Visualizer``; its ``url()`` is the page to open.
    """
    run, scene, fps, colors = _prepare(run, robot, fps, show_desired_ghost, path_colors)
    vis = _meshcat().Visualizer(zmq_url=zmq_url)
    if open_browser:
        vis.open()
    _draw(vis, scene, fps, colors, repetitions=1)
    return vis


def close_live(vis) -> None:
    """Stop the meshcat server that :func:`view_live` started (nothing for one it connected to):
    meshcat stops it only at a normal interpreter exit, not on SIGTERM."""
    server = getattr(getattr(vis, "window", None), "server_proc", None)
    if server is not None and server.poll() is None:
        server.terminate()
        try:
            server.wait(timeout=5.0)
        except Exception:  # pragma: no cover - a server that ignores SIGTERM
            server.kill()
            server.wait()

"""Headless meshcat export of a :class:`~delta_pin.sim.runner.Run` to ONE standalone HTML file.

The robot is drawn from the visual geometry of the URDF the run came from, read by Pinocchio's
geometry model (``pin.buildGeomFromUrdfString(..., pin.GeometryType.VISUAL)``); mesh visuals (STL,
OBJ, DAE) are read with yourdfpy and trimesh (:mod:`delta_pin.model.visuals`, imported only when the
URDF has one) and drawn as triangle meshes where Pinocchio places a stand-in. It is posed at every
animation frame by the closure-consistent configuration q(alpha)
(:meth:`~delta_pin.model.pinocchio_model.DeltaPinocchioModel.configuration`). The desired (``xyz_d``)
and actual (``xyz``) platform paths are drawn as two lines of different colours; a translucent
ghost of the desired pose q(alpha_d) is optional.

Any closed-chain robot (:class:`~delta_pin.model.closed_chain.ClosedChainRobot`) is drawn the same
way: from its ``visual_model`` where it carries one (an MJCF robot's; meshes Pinocchio read are
drawn from its triangles, capsules as triangle meshes), else from its URDF's visuals (mesh files
relative to ``robot.base_dir``), else, for a robot with no visual at all, from a skeleton of its
kinematics (a cylinder per joint-to-child-joint segment and per joint-to-closure-frame segment, a
sphere at each closure frame). Each frame is assembled by Newton (``robot.configuration``), the
first one from the robot's reference configuration and each next one from the one before. The
robot of a closed-chain run is rebuilt from the run's URDF when it has ``<constraint>`` elements;
otherwise (MJCF, Gepetto ``robot.yaml``) ``robot=`` must be given.

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
import contextlib
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
from delta_pin.model.closed_chain import ClosedChainRobot
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
# [m] largest distance between a closed-chain run's xyz[0] and the end-effector frame of the robot
# drawn, assembled at alpha[0]; another assembly mode or another robot is centimetres off
ASSEMBLY_TOLERANCE = 1e-4
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


def _rebuild_closed_chain(run: Run) -> ClosedChainRobot:
    """The closed-chain robot of a run, rebuilt from its URDF text (``run.metadata["urdf"]``),
    actuated joints and end effector (``run.metadata["robot"]``).

    Raises:
        VisualizationError: the run's metadata cannot rebuild it: no URDF (an MJCF robot), a URDF
            without ``<constraint>`` (closures from a Gepetto ``robot.yaml``), or mesh visuals at
            paths relative to a folder the run does not record.
    """
    import tempfile

    from lxml import etree

    from delta_pin.errors import MeshFileError
    from delta_pin.model.loaders import load_robot
    from delta_pin.model.visuals import resolve_mesh_path

    meta = run.metadata.get("robot") or {}
    urdf = run.metadata.get("urdf")
    base_dir = run.metadata.get("urdf_dir")
    label = "the run's closed-chain robot" + (f" {meta['name']!r}" if meta.get("name") else "")
    label += f" (from {meta['source']})" if meta.get("source") else ""
    hint = "pass robot=load_robot(path) with the file it was loaded from"
    if not urdf:
        raise VisualizationError(f"{label} cannot be rebuilt from the run: it carries no URDF; {hint}")
    if "<constraint" not in urdf:
        return _rebuild_from_recorded_closures(run, urdf, base_dir, label, hint)
    # the run records no folder for a closed-chain robot's URDF: relative mesh filenames need robot=
    try:
        for link in etree.fromstring(urdf.encode()).findall("link"):
            for index, visual in enumerate(link.findall("visual")):
                for mesh in visual.iter("mesh"):
                    where = f"visual {index} of link {link.get('name')!r}"
                    resolve_mesh_path(mesh.get("filename", ""), base_dir, where)
    except MeshFileError as exc:
        raise VisualizationError(f"{label} cannot be drawn from the run: {exc}; {hint}") from None
    actuated = list(meta.get("actuated_joints") or [])
    end_effector = meta.get("end_effector")
    with tempfile.TemporaryDirectory(prefix="delta_pin_viz_") as folder:
        path = Path(folder) / "robot.urdf"
        path.write_text(urdf, encoding="utf-8")
        robot = None
        # as it was loaded (transmissions, the Delta convention's reference pose), if that fits
        with contextlib.suppress(DeltaPinError):
            robot = load_robot(path, end_effector=end_effector, recognise=False)
        if robot is None or (actuated and list(robot.actuated_joints) != actuated):
            try:
                robot = load_robot(
                    path, actuated=actuated or None, end_effector=end_effector, recognise=False
                )
            except DeltaPinError as exc:
                raise VisualizationError(f"{label} cannot be rebuilt from the run ({exc}); {hint}") from None
    robot.base_dir = base_dir  # relative mesh filenames: the run's folder, not the temporary one
    return robot


def _rebuild_from_recorded_closures(run: Run, urdf: str, base_dir, label: str, hint: str) -> ClosedChainRobot:
    """A run whose loops came from another file than its URDF (a Gepetto ``robot.yaml``): the
    tree from the URDF text (on a free-flyer root where the run's robot had one), the closures,
    passive joints and springs from the run's robot metadata, assembled at the run's first q."""
    from delta_pin.model.closures import Closure
    from delta_pin.model.urdf_tree import FREE_FLYER_JOINT, build_urdf_tree

    meta = run.metadata.get("robot") or {}
    recorded = meta.get("closures") or []
    if not recorded or any("joint1" not in c for c in recorded):
        raise VisualizationError(
            f"{label} cannot be rebuilt from the run: its URDF has no <constraint> and the run records "
            f"no closure frames (saved before they were kept); {hint}"
        )
    passive = list(meta.get("passive_joints") or [])
    try:
        model = build_urdf_tree(urdf, "the run's URDF", free_flyer=FREE_FLYER_JOINT in passive)
        ids = {
            name: model.getJointId(name) if name != "universe" else 0
            for c in recorded
            for name in (c["joint1"], c["joint2"])
        }
        if any(i >= model.njoints for i in ids.values()):
            raise DeltaPinError(f"a closure joint of {sorted(ids)} is not in the URDF")
        closures = [
            Closure(
                c["name"],
                c["kind"],
                ids[c["joint1"]],
                pin.SE3(np.array(c["placement1"])),
                ids[c["joint2"]],
                pin.SE3(np.array(c["placement2"])),
                source=c.get("source", ""),
            )
            for c in recorded
        ]
        q = getattr(run, "q", None)
        robot = ClosedChainRobot(
            model, closures, list(meta.get("actuated_joints") or []), passive=passive,
            joint_springs={k: tuple(v) for k, v in (meta.get("joint_springs") or {}).items()},
            name=meta.get("name", ""), source=meta.get("source", ""), urdf=urdf, base_dir=base_dir,
            end_effector=meta.get("end_effector"),
            reference_configuration=None if q is None else np.asarray(q[0], dtype=float),
        )  # fmt: skip
    except DeltaPinError as exc:
        raise VisualizationError(f"{label} cannot be rebuilt from the run ({exc}); {hint}") from None
    return robot


def _describe_robot_difference(run: Run, robot) -> str | None:
    """Why a closed-chain run cannot be the given robot's (actuated joints), or ``None``."""
    meta = run.metadata.get("robot") or {}
    actuated = meta.get("actuated_joints")
    if not actuated or not _is_closed_chain(robot) or list(robot.actuated_joints) == list(actuated):
        return None
    return f"actuated joints {list(actuated)} (run) vs {list(robot.actuated_joints)} (robot)"


def _resolve_robot(run: Run, robot):
    from delta_pin.model.delta_robot import analytic_delta
    from delta_pin.model.description import read_description
    from delta_pin.model.robot import Delta

    run_urdf = run.metadata.get("urdf")
    closed_chain = (run.metadata.get("robot") or {}).get("kind") == "closed_chain"
    if robot is None:
        if closed_chain:
            return _rebuild_closed_chain(run)
        if not run_urdf:
            raise VisualizationError("the run carries no URDF (metadata['urdf']): pass robot= to draw it")
        return Delta(read_description(run_urdf, base_dir=run.metadata.get("urdf_dir")))
    if not closed_chain:  # a Delta's run: drawn by the analytic model the robot of load_delta carries
        robot = analytic_delta(robot)
    if run_urdf and robot.urdf != run_urdf:
        difference = (
            "the run's robot has a URDF, the robot given has none"
            if not robot.urdf
            else _describe_difference(run_urdf, robot.urdf)
        )
        raise RobotMismatchError(
            "the run was simulated on another robot than the one given ("
            + difference
            + "); pass robot=None to draw the run's own robot"
        )
    difference = _describe_robot_difference(run, robot) if closed_chain else None
    if difference:
        raise RobotMismatchError(
            f"the run was simulated on another robot than the one given ({difference}); "
            "pass robot= the robot the run was simulated on"
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


def _is_closed_chain(robot) -> bool:
    return isinstance(robot, ClosedChainRobot)


def _robot_model(robot) -> pin.Model:
    return robot.model if _is_closed_chain(robot) else robot.pinocchio.model


def _urdf_geometry(model: pin.Model, urdf: str, base_dir) -> tuple[pin.GeometryModel, dict]:
    """The URDF's visuals on ``model`` read by Pinocchio, and its mesh visuals read by trimesh."""
    from delta_pin.model.visuals import has_mesh_visuals, load_visual_meshes, primitive_stand_in

    meshes = {}
    if has_mesh_visuals(urdf):  # Pinocchio places a small sphere for each; the meshes come from trimesh
        meshes = load_visual_meshes(urdf, base_dir)
        urdf = primitive_stand_in(urdf)
    try:
        geometry_model = pin.buildGeomFromUrdfString(model, urdf, pin.GeometryType.VISUAL)
    except (RuntimeError, ValueError) as exc:
        raise VisualizationError(f"Pinocchio could not read the URDF's visual geometry: {exc}") from None
    return geometry_model, meshes


def _skeleton(robot) -> pin.GeometryModel:
    """Stand-in visuals of a closed-chain robot that has none, from its kinematics alone.

    A cylinder per segment of the tree: from each joint (the universe's origin for a root joint)
    to each of its child joints, and from a joint to each closure frame and to the end-effector
    frame it carries (the links that end at a loop or a tool, which have no child joint); a
    sphere at each closure frame (both frames of a closure: they coincide once assembled).
    Radii scale with the longest segment (2 % of it, spheres 4 %).
    """
    import coal

    model = robot.model
    ends = []  # (joint, end point in the joint's frame, name)
    for joint in range(1, model.njoints):
        parent = model.parents[joint]
        ends.append(
            (parent, model.jointPlacements[joint].translation, f"{model.names[parent]}-{model.names[joint]}")
        )
    closure_frames = [fid for f1, f2, _size in robot.closure_frames for fid in (f1, f2)]
    for fid in [*closure_frames, robot.end_effector]:
        frame = model.frames[fid]
        ends.append(
            (frame.parentJoint, frame.placement.translation, f"{model.names[frame.parentJoint]}-{frame.name}")
        )
    segments, seen = [], set()
    for joint, end, name in ends:
        key = (joint, *np.round(end, 9))
        if np.linalg.norm(end) > 1e-9 and key not in seen:
            seen.add(key)
            segments.append((joint, np.array(end, dtype=float), name))
    longest = max((float(np.linalg.norm(end)) for _j, end, _n in segments), default=0.1)
    radius = max(0.02 * longest, 1e-3)
    geometry_model = pin.GeometryModel()
    z = np.array([0.0, 0.0, 1.0])
    for joint, end, name in segments:
        length = float(np.linalg.norm(end))
        rotation = pin.Quaternion.FromTwoVectors(z, end / length).matrix()
        frame = model.getFrameId(model.names[joint], pin.FrameType.JOINT) if joint else 0
        obj = pin.GeometryObject(
            f"skeleton_{name}", joint, frame, pin.SE3(rotation, 0.5 * end), coal.Cylinder(radius, length)
        )
        obj.meshColor = np.array([0.6, 0.6, 0.6, 1.0])
        geometry_model.addGeometryObject(obj)
    for fid in closure_frames:
        frame = model.frames[fid]
        obj = pin.GeometryObject(
            f"closure_{frame.name}", frame.parentJoint, fid, pin.SE3(np.eye(3), frame.placement.translation),
            coal.Sphere(2.0 * radius),
        )  # fmt: skip
        obj.meshColor = np.array([0.93, 0.50, 0.13, 1.0])
        geometry_model.addGeometryObject(obj)
    return geometry_model


def _robot_geometry(robot) -> tuple[pin.Model, pin.GeometryModel, dict]:
    """The model, its visual geometry and the URDF's mesh visuals (by (link, rank)) of a robot.

    A Delta: its URDF's visuals. A closed-chain robot: its ``visual_model`` where it has one,
    else its URDF's visuals, else (no visual at all) the :func:`_skeleton` of its kinematics.
    """
    if not _is_closed_chain(robot):
        model = robot.pinocchio.model
        return (model, *_urdf_geometry(model, robot.urdf, robot.description.base_dir))
    model = robot.model
    if robot.visual_model is not None:
        geometry_model, meshes = pin.GeometryModel(robot.visual_model), {}
    elif robot.urdf:
        geometry_model, meshes = _urdf_geometry(model, robot.urdf, robot.base_dir)
    else:
        geometry_model, meshes = pin.GeometryModel(), {}
    if geometry_model.ngeoms == 0:
        geometry_model = _skeleton(robot)
    return model, geometry_model, meshes


def _capsule_mesh(radius: float, half_length: float, segments: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of a capsule along z (a cylinder with two hemispherical caps)."""
    # (z, ring radius) from the top pole down: the top cap around +half_length, the bottom one around -
    quarter = np.linspace(0.0, math.pi / 2, segments // 4 + 1)
    rings = [(half_length + radius * math.cos(phi), radius * math.sin(phi)) for phi in quarter]
    rings += [(-half_length - radius * math.sin(phi), radius * math.cos(phi)) for phi in quarter]
    azimuth = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    vertices = np.array([[r * math.cos(a), r * math.sin(a), z] for z, r in rings for a in azimuth])
    faces = []
    for i in range(len(rings) - 1):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            c, d = a + segments, b + segments
            faces += [(a, c, b), (b, c, d)]
    return vertices, np.array(faces)


def _collision_mesh(shape) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices (already scaled by Pinocchio) and triangles of a mesh shape of a geometry model."""
    import coal

    if isinstance(shape, coal.BVHModelBase) and shape.num_tris > 0:
        vertices = np.array(shape.vertices(), dtype=float).reshape(-1, 3)
        faces = np.array([[t[0], t[1], t[2]] for t in (shape.tri_indices(i) for i in range(shape.num_tris))])
        return vertices, faces
    if isinstance(shape, coal.ConvexBase) and shape.num_points >= 4:
        from scipy.spatial import ConvexHull

        vertices = np.array(shape.points(), dtype=float).reshape(-1, 3)
        faces = ConvexHull(vertices).simplices.copy()
        corners = vertices[faces]  # qhull's triangles are not oriented: turn each one outwards
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        inward = np.einsum("ij,ij->i", normals, corners.mean(axis=1) - vertices.mean(axis=0)) < 0.0
        faces[inward] = faces[inward][:, ::-1]
        return vertices, faces
    return None


def _unique_names(names: list[str]) -> list[str]:
    """Scene-path-safe names, a suffix added to repeats (an MJCF model may leave geoms unnamed)."""
    result, seen = [], set()
    for index, name in enumerate(names):
        name = (name or f"visual_{index}").replace("/", "_")
        candidate, number = name, 1
        while candidate in seen:
            candidate, number = f"{name}_{number}", number + 1
        seen.add(candidate)
        result.append(candidate)
    return result


def _visuals(robot) -> tuple[pin.GeometryModel, list[_Visual]]:
    mg = _meshcat().geometry
    model, geometry_model, meshes = _robot_geometry(robot)
    visuals = []
    rank: dict[str, int] = {}  # visuals seen so far per link: (link, rank) names a mesh visual
    names = _unique_names([obj.name for obj in geometry_model.geometryObjects])
    for obj, name in zip(geometry_model.geometryObjects, names, strict=True):
        shape = obj.geometry
        kind = type(shape).__name__
        correction = np.eye(4)
        link = (
            model.frames[obj.parentFrame].name
            if obj.parentFrame < len(model.frames)
            else model.names[obj.parentJoint]
        )
        index = rank[link] = rank.get(link, -1) + 1
        mesh = meshes.get((link, index))
        triangles = _collision_mesh(shape) if mesh is None else None
        if mesh is not None:
            geometry = _TriangleMesh(mesh.vertices, mesh.faces)
            correction[:3, :3] = np.diag(mesh.scale)
            step = max(1, len(mesh.vertices) // 200)  # at most ~200 hull points for the camera framing
            outline = mesh.vertices[::step] * mesh.scale
        elif triangles is not None:  # a mesh Pinocchio read itself (a visual_model's)
            vertices, faces = triangles
            geometry = _TriangleMesh(vertices, faces)
            outline = vertices[:: max(1, len(vertices) // 200)]
        elif kind == "Cylinder":  # URDF cylinders lie along z, three.js ones along y
            geometry = mg.Cylinder(2.0 * shape.halfLength, shape.radius)
            correction[:3, :3] = pin.utils.rotate("x", math.pi / 2)
            ring = shape.radius * np.column_stack([np.cos(_RING), np.sin(_RING), np.zeros_like(_RING)])
            cap = np.array([0.0, 0.0, shape.halfLength])
            outline = np.vstack([ring + cap, ring - cap])
        elif kind == "Capsule":
            vertices, faces = _capsule_mesh(shape.radius, shape.halfLength)
            geometry, outline = _TriangleMesh(vertices, faces), vertices
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
                "(cylinder, capsule, sphere, box, ellipsoid, STL/OBJ/DAE mesh)"
            )
        color, opacity = _rgba_color(obj.meshColor)
        visuals.append(_Visual(name, geometry, correction, color, opacity, obj.parentJoint != 0, outline))
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


def _configurations(robot, alphas: np.ndarray) -> list[np.ndarray]:
    """The closure-consistent configuration q(alpha) (nq,) of each row of ``alphas``.

    A Delta: that of its closed-chain robot (``robot.pinocchio``). A closed-chain robot: Newton
    assembly started at the first frame from the robot's reference configuration (its assembly
    mode), then each frame warm-started from the one before.
    """
    if not _is_closed_chain(robot):
        return [robot.pinocchio.configuration(alpha) for alpha in alphas]
    q = robot.reference_configuration
    configurations = []
    for alpha in alphas:
        q = robot.configuration(alpha, initial_guess=q)
        configurations.append(q)
    return configurations


def _placements(
    robot, geometry_model: pin.GeometryModel, alphas: np.ndarray, configurations: list | None = None
) -> np.ndarray:
    """(F, V, 7) world placements (xyz, quaternion xyzw) of every visual at q(alpha) per frame
    (or at the given ``configurations``, one per frame: a run's recorded q)."""
    model = _robot_model(robot)
    data = model.createData()
    geometry_data = pin.GeometryData(geometry_model)
    if configurations is None:
        configurations = _configurations(robot, alphas)
    poses = np.empty((len(configurations), geometry_model.ngeoms, 7))
    for k, q in enumerate(configurations):
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


def _check_assembly(run: Run, robot, alpha0: np.ndarray) -> None:
    """The closed-chain robot drawn puts the run's end-effector frame where the run recorded it
    at t[0] (to ASSEMBLY_TOLERANCE): the same robot, assembled in the same mode."""
    frame = (run.metadata.get("robot") or {}).get("end_effector") or robot.end_effector_name
    if not robot.model.existFrame(frame):
        return  # another robot: the dof check has passed, nothing to compare with
    q = robot.configuration(alpha0, initial_guess=robot.reference_configuration)
    gap = float(np.linalg.norm(robot.frame_placement(q, frame).translation - np.asarray(run.xyz[0], float)))
    if gap > ASSEMBLY_TOLERANCE:
        raise RobotMismatchError(
            f"assembled at the run's first joint angles, robot {robot.name!r} puts frame {frame!r} "
            f"{gap * 1e3:.3g} mm from the run's xyz[0] (another robot, or another assembly mode): "
            "pass robot= the robot the run was simulated on"
        )


def _recorded_configurations(run: Run, robot, times: np.ndarray) -> list[np.ndarray] | None:
    """The run's recorded configurations q at the frame times (from the run's start),
    interpolated on the configuration manifold between the two samples around each
    (``pin.interpolate``), where the run has them for this robot's model; ``None`` otherwise
    (then q(alpha) is assembled frame by frame, which cannot tell idle motions apart and may
    change assembly mode)."""
    q = getattr(run, "q", None)
    model = _robot_model(robot)
    if q is None or not _is_closed_chain(robot) or np.ndim(q) != 2 or np.shape(q)[1] != model.nq:
        return None
    q = np.asarray(q, dtype=float)
    t = np.asarray(run.t, dtype=float)
    _check_finite("q", t, q)
    at = np.clip(t[0] + times, t[0], t[-1])
    after = np.clip(np.searchsorted(t, at, side="right"), 1, len(t) - 1)
    before = after - 1
    span = t[after] - t[before]
    weight = np.where(span > 0, (at - t[before]) / np.where(span > 0, span, 1.0), 0.0)
    return [pin.interpolate(model, q[i], q[j], float(u)) for i, j, u in zip(before, after, weight)]


def _build_scene(run: Run, robot, fps: float, show_desired_ghost: bool) -> _Scene:
    t = np.asarray(run.t, dtype=float)
    dof = robot.dof if _is_closed_chain(robot) else 3
    alpha = np.asarray(run.alpha, dtype=float).reshape(len(t), -1)
    if alpha.shape[1] != dof:
        raise RobotMismatchError(
            f"the run has {alpha.shape[1]} joint angle(s) per sample and the robot {dof} actuated "
            "joint(s): pass robot= the robot the run was simulated on"
        )
    _check_finite("alpha", t, alpha)
    if _is_closed_chain(robot):
        _check_assembly(run, robot, alpha[0])
    times = _frame_times(t, fps)
    geometry_model, visuals = _visuals(robot)
    poses = _placements(
        robot, geometry_model, _resample(t, alpha, times), _recorded_configurations(run, robot, times)
    )
    ghost = None
    if show_desired_ghost:
        alpha_d = np.asarray(run.alpha_d, dtype=float).reshape(len(t), dof)
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
        robot: the robot the run was simulated on: a :class:`~delta_pin.model.robot.Delta` or a
            :class:`~delta_pin.model.closed_chain.ClosedChainRobot`; ``None`` rebuilds it from the
            URDF stored with the run (``run.metadata["urdf"]``; for a closed-chain run, only a URDF
            with ``<constraint>`` elements: pass ``robot=load_robot(path)`` for an MJCF robot).
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
            the parameters, or the URDF line, that differ; for a closed-chain robot, also other
            actuated joints, or an end effector assembled away from the run's ``xyz[0]``).
        VisualizationError: ``run`` is a file that is not a saved run, the run carries no URDF
            (or, closed-chain, no URDF with ``<constraint>``) and no robot is given, or the URDF
            has an unsupported visual geometry.
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
    the viewer's Animations panel to replay it. The server
    (:mod:`delta_pin.viz.meshcat_server`) is a child process of this Python process that listens
    on 127.0.0.1 only and stops with it, however it ends (SIGKILL included).

    Args:
        run, robot, fps, show_desired_ghost, path_colors: as for :func:`export_html`.
        open_browser: open the viewer's URL in the default web browser.
        zmq_url: connect to a running meshcat server (``meshcat-server``) instead of starting one.

    Returns:
        The ``meshcat.Visualizer``; its ``url()`` is the page to open.
    """
    run, scene, fps, colors = _prepare(run, robot, fps, show_desired_ghost, path_colors)
    meshcat = _meshcat()
    if zmq_url is not None:
        vis = meshcat.Visualizer(zmq_url=zmq_url)
    else:  # delta-pin's server: on 127.0.0.1 only, and it ends with this process, even killed
        from delta_pin.viz.meshcat_server import start_server

        server, url, _ = start_server()
        try:
            vis = meshcat.Visualizer(zmq_url=url)
        except BaseException:
            _stop_server(server)
            raise
        vis.window.server_proc = server
    try:
        if open_browser:
            vis.open()
        _draw(vis, scene, fps, colors, repetitions=1)
    except BaseException:
        close_live(vis)
        raise
    return vis


def close_live(vis) -> None:
    """Stop the meshcat server that :func:`view_live` started (nothing for one it connected to):
    meshcat stops it only at a normal interpreter exit, not on SIGTERM."""
    server = getattr(getattr(vis, "window", None), "server_proc", None)
    if server is not None:
        _stop_server(server)


def _stop_server(server) -> None:
    if server.poll() is None:
        server.terminate()
        try:
            server.wait(timeout=5.0)
        except Exception:  # pragma: no cover - a server that ignores SIGTERM
            server.kill()
            server.wait()
    if server.stdin is not None:
        server.stdin.close()

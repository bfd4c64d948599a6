"""Mesh visuals of a URDF: find the files, read them with yourdfpy and trimesh.

Pinocchio's URDF parser ignores visuals when it builds the kinematic model, so a Delta whose
visuals are meshes (every robot from CAD) loads and simulates without this module; only drawing
needs the meshes. yourdfpy and trimesh (the ``viz`` extra) are imported lazily, and only when the
URDF has a ``<mesh>`` visual: loading the robot never pays for them, and the lxml check
:func:`check_mesh_files` names a missing file at load time.

A mesh filename may be

* ``package://<package>/<path>``: ``<package>`` is an importable Python package (so
  ``package://delta_pin/urdf/meshes/forearm.stl`` is the installed copy) or a folder of that name
  above the URDF's folder (the ROS layout ``<package>/urdf/robot.urdf``);
* ``package:///<path>`` (three slashes: an empty package name, as Onshape exports write and
  Gepetto's example-parallel-robots ship): relative to the URDF's folder, as Gepetto's loader
  reads them (Pinocchio given the robot's folder as its package directory);
* ``file://<absolute path>`` or an absolute path;
* a path relative to the folder of the URDF (``DeltaDescription.base_dir``), with or without
  ``file://`` (xacrodoc writes relative filenames as ``file://<relative path>``).

STL, OBJ and DAE (COLLADA, read through pycollada) files are read.
"""

from __future__ import annotations

import importlib.util
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from lxml import etree

from delta_pin.errors import MeshFileError, URDFConventionError

__all__ = [
    "MESH_SUFFIXES",
    "VisualMesh",
    "check_mesh_files",
    "has_mesh_visuals",
    "load_visual_meshes",
    "primitive_stand_in",
    "resolve_mesh_path",
]

MESH_SUFFIXES = (".stl", ".obj", ".dae")
_FORMS = (
    "a path relative to the URDF's folder (or package:///<path>), an absolute path, or "
    "package://<python package>/<path>"
)
_EMPTY_PACKAGE = "package:///"  # Gepetto's (Onshape's) meshes: relative to the URDF's folder


@dataclass(frozen=True)
class VisualMesh:
    """One mesh visual, read from its file.

    Attributes:
        link: the link the visual belongs to.
        index: its rank among that link's visuals (0-based, the URDF's order).
        filename: the filename as written in the URDF.
        path: the file it resolved to.
        scale: (3,) the URDF's ``scale`` of the mesh [-].
        vertices: (n, 3) [mesh units, before ``scale``] vertex positions.
        faces: (m, 3) vertex indices of the triangles.
    """

    link: str
    index: int
    filename: str
    path: Path
    scale: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray


def _parse(urdf: str) -> etree._Element:
    try:
        return etree.fromstring(urdf.encode())
    except etree.XMLSyntaxError as exc:
        raise URDFConventionError(f"the URDF is not valid XML: {exc}") from None


def _mesh_elements(root: etree._Element):
    """(link name, visual index, <mesh> element) of every mesh visual, in the URDF's order."""
    for link in root.findall("link"):
        for index, visual in enumerate(link.findall("visual")):
            mesh = visual.find("geometry/mesh")
            if mesh is not None:
                yield link.get("name"), index, mesh


def has_mesh_visuals(urdf: str) -> bool:
    """Whether any ``<visual>`` of the URDF is a ``<mesh>``."""
    return next(_mesh_elements(_parse(urdf)), None) is not None


def _where(link: str, index: int) -> str:
    return f"visual {index} of link {link!r}"


def resolve_mesh_path(filename: str, base_dir: str | Path | None, where: str = "a visual") -> Path:
    """The file a URDF mesh ``filename`` names (see the module's docstring for the forms).

    Raises:
        MeshFileError: the file does not exist, cannot be located, or is not STL/OBJ/DAE; the one-line
            message names the filename and the forms that work.
    """
    base = None if base_dir is None else Path(base_dir)
    if filename.startswith(_EMPTY_PACKAGE):
        if base is None:
            raise MeshFileError(
                f"mesh {filename!r} ({where}) is relative to the URDF's folder (package:/// names no "
                f"package) but that folder is unknown (URDF given as text); load the robot from its file, "
                f"or use {_FORMS}"
            )
        path = base / filename[len(_EMPTY_PACKAGE) :]
    elif filename.startswith("package://"):
        package, _, rest = filename[len("package://") :].partition("/")
        candidates = []
        spec = importlib.util.find_spec(package) if package.isidentifier() else None
        if spec is not None and spec.submodule_search_locations:
            candidates += [Path(location) / rest for location in spec.submodule_search_locations]
        if base is not None:
            candidates += [parent / rest for parent in (base, *base.parents) if parent.name == package]
        if not candidates:
            raise MeshFileError(
                f"mesh {filename!r} ({where}): no Python package and no folder above the URDF is "
                f"named {package!r}; use {_FORMS}"
            )
        path = next((c for c in candidates if c.is_file()), candidates[0])
    elif Path(filename.removeprefix("file://")).is_absolute():
        path = Path(filename.removeprefix("file://"))
    elif base is None:
        raise MeshFileError(
            f"mesh {filename!r} ({where}) is relative but the URDF's folder is unknown (URDF given as text); "
            f"load the robot from its file, or use {_FORMS}"
        )
    else:  # xacrodoc writes a relative filename as file://<relative path>
        path = base / filename.removeprefix("file://")
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise MeshFileError(
            f"mesh {filename!r} ({where}): {path.suffix or 'no suffix'} files are not read; "
            "give an STL, OBJ or DAE file"
        )
    if not path.is_file():
        raise MeshFileError(f"mesh {filename!r} ({where}): file {str(path)!r} does not exist; use {_FORMS}")
    return path


def check_mesh_files(urdf: str, base_dir: str | Path | None) -> None:
    """Check that every mesh visual's file exists (lxml only: neither yourdfpy nor trimesh is imported).

    Relative filenames (``package:///<path>`` included) are checked only when ``base_dir`` is known.

    Raises:
        MeshFileError: the first mesh visual whose file is missing (named in the message).
    """
    for link, index, mesh in _mesh_elements(_parse(urdf)):
        filename = mesh.get("filename", "")
        relative = filename.startswith(_EMPTY_PACKAGE) or (
            not filename.startswith("package://") and not Path(filename.removeprefix("file://")).is_absolute()
        )
        if relative and base_dir is None:
            continue
        resolve_mesh_path(filename, base_dir, _where(link, index))


def primitive_stand_in(urdf: str) -> str:
    """The URDF with every mesh visual replaced by a tiny sphere (same link, order, origin, material).

    Pinocchio's geometry parser then places the visuals without looking for the mesh files.
    """
    root = _parse(urdf)
    for _link, _index, mesh in _mesh_elements(root):
        geometry = mesh.getparent()
        geometry.remove(mesh)
        etree.SubElement(geometry, "sphere", radius="0.001")
    return etree.tostring(root, encoding="unicode")


def _import_mesh_readers():
    try:
        import trimesh
        import yourdfpy
    except ImportError as exc:
        raise MeshFileError(
            f"drawing mesh visuals needs yourdfpy and trimesh ({exc}): pip install 'delta-pin[viz]'"
        ) from None
    return yourdfpy, trimesh


def load_visual_meshes(urdf: str, base_dir: str | Path | None) -> dict[tuple[str, int], VisualMesh]:
    """Read every mesh visual of the URDF with yourdfpy (the URDF) and trimesh (the files).

    Returns:
        The meshes by (link, visual index); empty, without importing yourdfpy or trimesh, when the
        URDF has no mesh visual.

    Raises:
        MeshFileError: a mesh file is missing or unreadable (named in the message).
    """
    if not has_mesh_visuals(urdf):
        return {}
    yourdfpy, trimesh = _import_mesh_readers()
    parsed = yourdfpy.URDF.load(io.StringIO(urdf), build_scene_graph=False, load_meshes=False)
    meshes = {}
    for link in parsed.robot.links:
        for index, visual in enumerate(link.visuals):
            mesh = visual.geometry.mesh if visual.geometry is not None else None
            if mesh is None:
                continue
            where = _where(link.name, index)
            path = resolve_mesh_path(mesh.filename, base_dir, where)
            try:
                loaded = trimesh.load(str(path), force="mesh")
            except Exception as exc:  # trimesh raises many kinds (ValueError, KeyError, ImportError ...)
                raise MeshFileError(
                    f"mesh {mesh.filename!r} ({where}): trimesh could not read {str(path)!r}: "
                    f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
                ) from None
            vertices = np.asarray(getattr(loaded, "vertices", ()), dtype=float).reshape(-1, 3)
            faces = np.asarray(getattr(loaded, "faces", ()), dtype=np.int64).reshape(-1, 3)
            if len(faces) == 0:
                raise MeshFileError(
                    f"mesh {mesh.filename!r} ({where}): {str(path)!r} holds no triangles; "
                    "give an STL, OBJ or DAE file with a surface"
                )
            scale = np.ones(3) if mesh.scale is None else np.broadcast_to(mesh.scale, 3).astype(float)
            meshes[(link.name, index)] = VisualMesh(
                link.name, index, mesh.filename, path, scale, vertices, faces
            )
    return meshes

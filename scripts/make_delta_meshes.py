"""Write the packaged Delta's mesh visuals (delta_pin/urdf/meshes/) and delta_mesh.urdf.

The meshes are unit shapes made with trimesh's primitives; the xacro's ``<mesh scale=...>`` sizes
them from the robot's dimensions, so one set serves every geometry:

* ``base.stl``       a 24-sided cylinder, radius 1, height 1, along z, centred (binary STL);
* ``upper_arm.obj``  a unit cube, centred (OBJ);
* ``forearm.stl``    a 12-sided cylinder, radius 1, height 1, along z, centred (binary STL);
* ``platform.dae``   a hexagonal prism, radius 1, height 1, along z, centred (COLLADA, needs pycollada).

``delta_mesh.urdf`` is the Table 1 robot with these meshes named by paths relative to its folder
(``meshes/base.stl``); ``load_delta(visuals="mesh")`` compiles the same robot with
``package://delta_pin/urdf/meshes/...`` paths instead.

Run from the repository root: ``python scripts/make_delta_meshes.py`` (``--out FOLDER`` writes
``FOLDER/meshes/*`` and ``FOLDER/delta_mesh.urdf`` there instead, to compare with the shipped ones).
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import trimesh

URDF_DIR = Path(__file__).resolve().parents[1] / "delta_pin" / "urdf"


def _number_ids(data: bytes) -> bytes:
    """trimesh's COLLADA ids are random uuids: number them in order of appearance."""
    ids: dict[bytes, bytes] = {}
    return re.sub(rb"\b[0-9a-f]{32}\b", lambda m: ids.setdefault(m[0], b"id%d" % len(ids)), data)


def main(out: Path = URDF_DIR) -> None:
    meshes = out / "meshes"
    meshes.mkdir(parents=True, exist_ok=True)
    shapes = {
        "base.stl": trimesh.creation.cylinder(radius=1.0, height=1.0, sections=24),
        "upper_arm.obj": trimesh.creation.box(extents=(1.0, 1.0, 1.0)),
        "forearm.stl": trimesh.creation.cylinder(radius=1.0, height=1.0, sections=12),
        "platform.dae": trimesh.creation.cylinder(radius=1.0, height=1.0, sections=6),
    }
    for name, mesh in shapes.items():
        path = meshes / name
        if path.suffix == ".obj":
            data = trimesh.exchange.obj.export_obj(mesh, include_normals=False, header=None)
        else:
            data = mesh.export(file_type=path.suffix[1:])
        if path.suffix == ".dae":  # a fixed date and numbered ids (trimesh's are random): same bytes each run
            data = re.sub(rb"<(created|modified)>[^<]*<", rb"<\1>2000-01-01T00:00:00<", data)
            data = _number_ids(data)
        path.write_bytes(data if isinstance(data, bytes) else data.encode())
        print(f"wrote {path}: {path.stat().st_size} bytes, {len(mesh.faces)} faces")

    from delta_pin.model.description import compile_urdf

    urdf = out / "delta_mesh.urdf"
    # xacrodoc writes a relative filename as file://meshes/...: keep the plain relative form
    text = compile_urdf(visuals="mesh", mesh_uri="meshes").replace('"file://meshes/', '"meshes/')
    urdf.write_text(text, encoding="utf-8")
    print(f"wrote {urdf}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=URDF_DIR, help="folder (default: delta_pin/urdf)")
    main(parser.parse_args().out)

"""Low-polygon copies of the scene's visual meshes, made once and cached, for the cameras.

Software rendering costs what it draws: robosuite's Panda visual meshes and mount pedestals hold ~360,000
faces, which a 128 x 128 camera cannot resolve. Every mesh a visual geom draws with more than ``MAX_FACES``
faces is decimated (quadric error metric, ``fast_simplification``) to that many faces, written once under the
cache folder keyed by the source file's content, and given to the visual geoms as a mesh asset of its own.
Collision geometry, masses and inertias are untouched (robosuite computes inertia from the collision group only),
so physics does not change.
"""

from __future__ import annotations

import hashlib
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from bimanualshift.utils.io import atomic_writer

MAX_FACES = 400  # per mesh: a Panda link part at 128 px covers a few hundred pixels
CACHE_VERSION = 2  # bump when the decimation changes, so cached meshes are remade


def cache_dir() -> Path:
    root = os.environ.get("BIMANUALSHIFT_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "bimanualshift")
    return Path(root) / "camera_meshes"


def _is_visual(geom: ET.Element) -> bool:
    """A geom that never collides and is drawn (robosuite's visual geoms: group 1, no contact bits)."""
    return geom.get("contype") == "0" and geom.get("conaffinity") == "0" and geom.get("group", "0") != "0"


def _write_stl(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    """Binary STL: an 80-byte header, the triangle count, then per triangle a normal, 3 vertices, 2 bytes."""
    tri = vertices[faces].astype(np.float32)
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    record = np.zeros(len(faces), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    record["n"], record["v"] = normals, tri
    with atomic_writer(path) as tmp, open(tmp, "wb") as f:
        f.write(b"bimanualshift camera mesh".ljust(80, b" "))
        f.write(np.uint32(len(faces)).tobytes())
        f.write(record.tobytes())


# source file's (path, size, mtime) and max_faces -> its copy: every environment built in a process reads the same
# ~70 mesh files, and hashing them again cost ~0.4 s per environment.
_KNOWN: dict[tuple[str, int, int, int], Path | None] = {}


def decimated_copy(source: Path, max_faces: int = MAX_FACES) -> Path | None:
    """The cached low-polygon copy of ``source`` (made on first use), or None when it is small already."""
    stat = source.stat()
    key = (str(source), stat.st_size, stat.st_mtime_ns, max_faces)
    if key in _KNOWN and (_KNOWN[key] is None or _KNOWN[key].is_file()):
        return _KNOWN[key]
    _KNOWN[key] = _decimated_copy(source, max_faces)
    return _KNOWN[key]


def _decimated_copy(source: Path, max_faces: int) -> Path | None:
    import fast_simplification
    import trimesh

    digest = hashlib.sha1(source.read_bytes() + f"{max_faces}/{CACHE_VERSION}".encode()).hexdigest()[:16]
    target = cache_dir() / f"{source.stem}-{digest}.stl"
    if target.is_file():
        return target
    mesh = trimesh.load(source, force="mesh", process=False)
    mesh.merge_vertices()  # OBJ files repeat a vertex per face corner: decimation needs the connectivity
    faces = np.asarray(mesh.faces)
    if len(faces) <= max_faces:
        return None
    vertices, faces = fast_simplification.simplify(np.asarray(mesh.vertices, np.float32), faces.astype(np.int32),
                                                   target_reduction=1.0 - max_faces / len(faces))
    _write_stl(target, vertices, faces)
    return target


def lighten_visual_meshes(root: ET.Element, max_faces: int = MAX_FACES) -> int:
    """Point every visual geom whose mesh is large at a decimated copy of it (its own mesh asset, so collision
    geoms that share the original keep it); returns how many mesh assets were added."""
    assets = {m.get("name"): m for m in root.iter("mesh") if m.get("name")}
    parents = {child: parent for parent in root.iter() for child in parent}
    copies: dict[str, str | None] = {}  # original mesh name -> its camera copy's name (None: small already)
    for geom in root.iter("geom"):
        name = geom.get("mesh")
        if name is None or name not in assets or not _is_visual(geom):
            continue
        if name not in copies:
            source = assets[name]
            file = source.get("file")
            copy = decimated_copy(Path(file), max_faces) if file and file.lower().endswith((".obj", ".stl")) else None
            copies[name] = None
            if copy is not None:
                light = ET.Element("mesh", {k: v for k, v in source.attrib.items() if k != "file"})
                light.set("name", f"{name}_camera")
                light.set("file", str(copy))
                parents[source].append(light)
                copies[name] = light.get("name")
        if copies[name] is not None:
            geom.set("mesh", copies[name])
    return sum(v is not None for v in copies.values())

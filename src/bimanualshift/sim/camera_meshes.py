"""Low-polygon copies of the scene's visual meshes, made once and cached, for the cameras.

Software rendering costs what it draws: robosuite's Panda visual meshes and mount pedestals hold ~360,000
faces, which a 128 x 128 camera cannot resolve. Each visual-only mesh (a mesh no collision geom uses) with more
than ``MAX_FACES`` faces is decimated (quadric error metric, ``fast_simplification``) to that many faces and
written once under the cache folder, keyed by the source file's content. Collision geometry, masses and
inertias are untouched: robosuite computes inertia from the collision group only, so physics does not change.
"""

from __future__ import annotations

import hashlib
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from bimanualshift.utils.io import atomic_writer

MAX_FACES = 1500  # per mesh: a Panda link at 128 px covers a few hundred pixels
CACHE_VERSION = 2  # bump when the decimation changes, so cached meshes are remade


def cache_dir() -> Path:
    root = os.environ.get("BIMANUALSHIFT_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "bimanualshift")
    return Path(root) / "camera_meshes"


def _visual_only_meshes(root: ET.Element) -> set[str]:
    """Names of meshes drawn by visual geoms only (no geom that collides uses them)."""
    visual, colliding = set(), set()
    for geom in root.iter("geom"):
        mesh = geom.get("mesh")
        if mesh is None:
            continue
        no_contact = geom.get("contype") == "0" and geom.get("conaffinity") == "0"
        (visual if no_contact and geom.get("group", "0") != "0" else colliding).add(mesh)
    return visual - colliding


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


def decimated_copy(source: Path, max_faces: int = MAX_FACES) -> Path | None:
    """The cached low-polygon copy of ``source`` (made on first use), or None when it is small already."""
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
    """Point every large visual-only mesh of an MJCF tree at its decimated copy; returns how many changed."""
    visual = _visual_only_meshes(root)
    changed = 0
    for mesh in root.iter("mesh"):
        file = mesh.get("file")
        if mesh.get("name") not in visual or file is None or not file.lower().endswith((".obj", ".stl")):
            continue
        copy = decimated_copy(Path(file), max_faces)
        if copy is not None:
            mesh.set("file", str(copy))
            changed += 1
    return changed

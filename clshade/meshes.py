"""Scene objects → one world-space triangle soup with per-vertex normals and
per-face material ids, ready for the rasterizer."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import ClshadeError, located
from .scene import Scene, SceneObject

MESH_SUFFIXES = (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")


@dataclass(frozen=True)
class Geometry:
    vertices: np.ndarray       # (V, 3) float64 world space
    normals: np.ndarray        # (V, 3) float32 world space, unit
    faces: np.ndarray          # (F, 3) int64
    face_material: np.ndarray  # (F,) int32 index into Scene.material_names
    face_object: np.ndarray    # (F,) int32 index into Scene.objects
    cull: np.ndarray           # (F,) bool: back faces culled (False for double-sided materials)

    @property
    def triangle_count(self) -> int:
        return len(self.faces)


# Faces meeting at a vertex at more than this angle keep separate normals, so
# box edges and cylinder caps shade flat while curved sides stay smooth.
SHARP_EDGE_DEGREES = 30.0


def split_sharp_edges(vertices: np.ndarray, faces: np.ndarray, degrees: float = SHARP_EDGE_DEGREES):
    """Per-corner normals: each corner averages (area-weighted) the normals of the
    faces around its vertex that lie within `degrees` of its own face. Returns
    unshared vertices (3 per face), faces and normals. Vectorised over corner pairs."""
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])      # length = 2·area
    length = np.linalg.norm(cross, axis=1, keepdims=True)
    unit = np.divide(cross, length, out=np.zeros_like(cross), where=length > 0)
    vid = faces.reshape(-1)
    fid = np.repeat(np.arange(len(faces)), 3)
    order = np.argsort(vid, kind="stable")
    sorted_vid = vid[order]
    starts = np.flatnonzero(np.r_[True, sorted_vid[1:] != sorted_vid[:-1]])
    sizes = np.diff(np.r_[starts, len(vid)])
    # All (a, b) corner pairs sharing a vertex: group sizes are small (valence).
    group_of = np.repeat(np.arange(len(starts)), sizes)
    pair_counts = sizes[group_of]
    a = np.repeat(order, pair_counts)
    first = np.repeat(starts[group_of], pair_counts)
    within = np.arange(len(a)) - np.repeat(np.cumsum(pair_counts) - pair_counts, pair_counts)
    b = order[first + within]
    keep = np.einsum("ij,ij->i", unit[fid[a]], unit[fid[b]]) >= np.cos(np.radians(degrees))
    normals = np.zeros((len(vid), 3))
    np.add.at(normals, a[keep], cross[fid[b[keep]]])
    n = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, n, out=np.repeat(unit, 3, axis=0), where=n > 0)
    return vertices[vid], np.arange(len(vid)).reshape(-1, 3), normals


def _primitive(obj: SceneObject):
    import trimesh
    p = obj.params
    kind = obj.primitive
    if kind == "sphere":
        mesh = trimesh.creation.icosphere(subdivisions=p["subdivisions"], radius=p["radius"])
        return mesh.vertices, mesh.faces, mesh.vertices / np.linalg.norm(mesh.vertices, axis=1, keepdims=True)
    if kind == "plane":
        s = p["size"] / 2
        v = np.array([[-s, 0, -s], [s, 0, -s], [s, 0, s], [-s, 0, s]], float)
        f = np.array([[0, 2, 1], [0, 3, 2]])
        return v, f, np.tile([0.0, 1.0, 0.0], (4, 1))
    if kind == "box":
        mesh = trimesh.creation.box(extents=p["size"])
    elif kind == "cylinder":
        mesh = trimesh.creation.cylinder(radius=p["radius"], height=p["height"], sections=p["sections"])
    elif kind == "cone":
        mesh = trimesh.creation.cone(radius=p["radius"], height=p["height"], sections=p["sections"])
    elif kind == "capsule":
        mesh = trimesh.creation.capsule(radius=p["radius"], height=p["height"], count=[p["sections"], p["sections"]])
    elif kind == "torus":
        mesh = trimesh.creation.torus(major_radius=p["major_radius"], minor_radius=p["minor_radius"],
                                      major_sections=p["sections"], minor_sections=max(p["sections"] // 2, 3))
    else:  # pragma: no cover - validated in scene.py
        raise ClshadeError(f"unknown primitive {kind!r}")
    return split_sharp_edges(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64))


def load_mesh(path: Path, scene_file: Path | None = None, key: str = "mesh"):
    """Vertices, faces and vertex normals of a mesh file (all geometry of a multi-mesh file, flattened)."""
    import trimesh
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise located(f"unsupported mesh format {path.suffix or '(none)'}; use one of {', '.join(MESH_SUFFIXES)}",
                      scene_file, key, str(path), has_value=True)
    try:
        loaded = trimesh.load(path, process=False)
    except Exception as exc:  # trimesh raises many kinds
        raise located(f"cannot load mesh ({type(exc).__name__}: {exc})", scene_file, key, str(path), has_value=True) from exc
    if isinstance(loaded, trimesh.Scene):
        loaded = loaded.to_mesh() if hasattr(loaded, "to_mesh") else loaded.dump(concatenate=True)
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise located("mesh has no triangles", scene_file, key, str(path), has_value=True)
    return np.asarray(loaded.vertices, float), np.asarray(loaded.faces, np.int64), np.asarray(loaded.vertex_normals, float)


def build_geometry(scene: Scene) -> Geometry:
    """Transform every object into world space and concatenate."""
    names = scene.material_names
    verts, norms, faces, fmat, fobj, cull = [], [], [], [], [], []
    offset = 0
    for index, obj in enumerate(scene.objects):
        if obj.primitive:
            v, f, n = _primitive(obj)
        else:
            v, f, n = load_mesh(obj.mesh, scene.path, f"objects[{index}].mesh")
        m = obj.matrix()
        v = np.asarray(v, float) @ m[:3, :3].T + m[:3, 3]
        # Normals transform by the inverse transpose.
        n = np.asarray(n, float) @ np.linalg.inv(m[:3, :3])
        length = np.linalg.norm(n, axis=1, keepdims=True)
        n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
        if np.linalg.det(m[:3, :3]) < 0:     # a mirroring transform flips the winding
            f = f[:, ::-1]
        material = scene.materials[obj.material]
        verts.append(v)
        norms.append(n)
        faces.append(np.asarray(f, np.int64) + offset)
        fmat.append(np.full(len(f), names.index(obj.material), np.int32))
        fobj.append(np.full(len(f), index, np.int32))
        cull.append(np.full(len(f), not material.double_sided))
        offset += len(v)
    if not verts:
        return Geometry(np.zeros((0, 3)), np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int64),
                        np.zeros(0, np.int32), np.zeros(0, np.int32), np.zeros(0, bool))
    return Geometry(np.concatenate(verts), np.concatenate(norms).astype(np.float32), np.concatenate(faces),
                    np.concatenate(fmat), np.concatenate(fobj), np.concatenate(cull))

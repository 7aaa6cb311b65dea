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
    # Split vertices along sharp edges so boxes and cylinder caps shade flat.
    mesh = mesh.smooth_shaded
    return mesh.vertices, mesh.faces, mesh.vertex_normals


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

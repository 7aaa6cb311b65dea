"""Regenerate the small mesh files of scenes/meshes/ (one per format clshade loads):

- crate.obj    a box, no normals, and a Latin-1 byte in a comment (not UTF-8);
- tube.stl     a cylinder as binary STL (a triangle soup: no shared vertices, no normals);
- cube.ply     an 8-vertex cube (ASCII PLY, shared vertices, no normals);
- spheres.gltf a row of spheres, one glTF primitive each with its own
               metallic-roughness factors (and one emissive), NORMAL but no UVs
               (like Khronos' MetalRoughSpheresNoTextures).

`python scenes/make_meshes.py` writes them; tests call the functions with a tmp folder.
"""
from __future__ import annotations

import base64
import json
import struct
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

# (baseColorFactor RGBA, metallicFactor, roughnessFactor, emissiveFactor) per sphere of spheres.gltf.
SPHERE_MATERIALS = (
    ((0.9, 0.1, 0.1, 1.0), 0.0, 0.2, (0.0, 0.0, 0.0)),
    ((0.1, 0.8, 0.2, 1.0), 1.0, 0.3, (0.0, 0.0, 0.0)),
    ((0.2, 0.3, 0.9, 1.0), 0.0, 0.9, (0.0, 0.0, 0.0)),
    ((0.9, 0.8, 0.3, 1.0), 1.0, 0.7, (0.0, 0.0, 0.0)),
    ((0.05, 0.05, 0.05, 1.0), 0.0, 0.5, (1.0, 0.5, 0.1)),
)


def box_mesh(size: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """An 8-vertex cube centred at the origin, counter-clockwise outward faces."""
    s = size / 2
    v = np.array([[x, y, z] for x in (-s, s) for y in (-s, s) for z in (-s, s)], float)
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return v, f


def write_obj(path: Path) -> Path:
    v, f = box_mesh()
    lines = ["# crate: caf\xe9 cr\xe8me (this comment is Latin-1, not UTF-8)"]
    lines += [f"v {x:g} {y:g} {z:g}" for x, y, z in v]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f]
    path.write_bytes(("\n".join(lines) + "\n").encode("latin-1"))
    return path


def write_ply(path: Path) -> Path:
    v, f = box_mesh()
    head = ["ply", "format ascii 1.0", f"element vertex {len(v)}", "property float x", "property float y",
            "property float z", f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    body = [f"{x:g} {y:g} {z:g}" for x, y, z in v] + [f"3 {a} {b} {c}" for a, b, c in f]
    path.write_text("\n".join(head + body) + "\n", encoding="ascii")
    return path


def cylinder_soup(radius: float = 0.5, height: float = 1.0, sections: int = 32) -> np.ndarray:
    """(F, 3, 3) triangles of a capped cylinder along +Y, outward counter-clockwise."""
    a = np.linspace(0, 2 * np.pi, sections + 1)[:-1]
    b = np.roll(a, -1)
    ring = lambda t, y: np.stack([radius * np.cos(t), np.full_like(t, y), -radius * np.sin(t)], 1)  # noqa: E731
    lo0, lo1, hi0, hi1 = ring(a, -height / 2), ring(b, -height / 2), ring(a, height / 2), ring(b, height / 2)
    top, bottom = np.tile([0, height / 2, 0], (sections, 1)), np.tile([0, -height / 2, 0], (sections, 1))
    tris = [np.stack(t, 1) for t in ((lo0, lo1, hi1), (lo0, hi1, hi0), (top, hi0, hi1), (bottom, lo1, lo0))]
    return np.concatenate(tris)


def write_stl(path: Path) -> Path:
    tris = cylinder_soup()
    out = bytearray(b"clshade tube".ljust(80, b" ") + struct.pack("<I", len(tris)))
    for t in tris:
        n = np.cross(t[1] - t[0], t[2] - t[0])
        n /= np.linalg.norm(n)
        out += struct.pack("<12fH", *n, *t.ravel(), 0)
    path.write_bytes(bytes(out))
    return path


def uv_sphere(radius: float = 0.4, rings: int = 16, segments: int = 32) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices, exact normals and counter-clockwise faces of a latitude-longitude sphere."""
    theta = np.linspace(0, np.pi, rings + 1)
    phi = np.linspace(0, 2 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    n = np.stack([np.sin(t) * np.cos(p), np.cos(t), -np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    idx = np.arange((rings + 1) * (segments + 1)).reshape(rings + 1, segments + 1)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    f = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    f = f[np.linalg.norm(np.cross(n[f[:, 1]] - n[f[:, 0]], n[f[:, 2]] - n[f[:, 0]]), axis=1) > 1e-12]
    return radius * n, n, f


def write_gltf(path: Path, materials=SPHERE_MATERIALS, spacing: float = 1.0) -> Path:
    """One mesh per sphere (one primitive each, its own material), placed by node translations; the
    buffer is embedded as a data URI. No TEXCOORD_0: factors only."""
    v, n, f = uv_sphere()
    v, n, f = v.astype("<f4"), n.astype("<f4"), f.astype("<u4")
    blob = v.tobytes() + n.tobytes() + f.tobytes()
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": v.nbytes, "target": 34962},
             {"buffer": 0, "byteOffset": v.nbytes, "byteLength": n.nbytes, "target": 34962},
             {"buffer": 0, "byteOffset": v.nbytes + n.nbytes, "byteLength": f.nbytes, "target": 34963}]
    accessors = [{"bufferView": 0, "componentType": 5126, "count": len(v), "type": "VEC3",
                  "min": v.min(0).tolist(), "max": v.max(0).tolist()},
                 {"bufferView": 1, "componentType": 5126, "count": len(n), "type": "VEC3"},
                 {"bufferView": 2, "componentType": 5125, "count": f.size, "type": "SCALAR"}]
    mats, meshes, nodes = [], [], []
    x0 = -spacing * (len(materials) - 1) / 2
    for i, (base, metal, rough, emissive) in enumerate(materials):
        m = {"name": f"sphere{i}", "pbrMetallicRoughness": {"baseColorFactor": list(base), "metallicFactor": metal,
                                                            "roughnessFactor": rough}}
        if any(emissive):
            m["emissiveFactor"] = list(emissive)
        mats.append(m)
        meshes.append({"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": i}]})
        nodes.append({"mesh": i, "translation": [x0 + i * spacing, 0.0, 0.0], "name": f"sphere{i}"})
    doc = {"asset": {"version": "2.0", "generator": "clshade scenes/make_meshes.py"},
           "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes, "meshes": meshes,
           "materials": mats, "accessors": accessors, "bufferViews": views,
           "buffers": [{"byteLength": len(blob),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}]}
    path.write_text(json.dumps(doc, indent=1), encoding="utf-8")
    return path


def write_all(folder: Path) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    return [write_obj(folder / "crate.obj"), write_stl(folder / "tube.stl"), write_ply(folder / "cube.ply"),
            write_gltf(folder / "spheres.gltf")]


if __name__ == "__main__":
    for p in write_all(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "meshes"):
        print(f"wrote {p}")

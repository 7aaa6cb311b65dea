"""Procedural primitives tessellated in NumPy (no trimesh: importing it, with scipy
present, costs about a second, more than the rest of a small render).

Every generator returns (vertices (V, 3) float64, faces (F, 3) int64), closed where
the shape is, counter-clockwise seen from outside. Conventions follow the ones the
scene format documents (and trimesh's, which clshade used before): cylinder, cone,
capsule and torus have their axis along Z; the cylinder and capsule are centred at
the origin, the cone has its base at z = 0 and its apex at z = height; the capsule's
`height` is the length of its straight part (hemispheres add `radius` at each end).
"""
from __future__ import annotations

import numpy as np

# The regular icosahedron (vertices on a sphere after normalising), outward faces.
_T = (1.0 + 5.0 ** 0.5) / 2.0
_ICO_V = np.array([[-1, _T, 0], [1, _T, 0], [-1, -_T, 0], [1, -_T, 0], [0, -1, _T], [0, 1, _T],
                   [0, -1, -_T], [0, 1, -_T], [_T, 0, -1], [_T, 0, 1], [-_T, 0, -1], [-_T, 0, 1]], float)
_ICO_F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                   [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                   [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], np.int64)


def icosphere(subdivisions: int, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """An icosahedron split `subdivisions` times (each triangle into four at its edge
    midpoints, pushed onto the sphere): 10·4ⁿ + 2 vertices, 20·4ⁿ faces."""
    v = _ICO_V / np.linalg.norm(_ICO_V, axis=1, keepdims=True)
    f = _ICO_F
    for _ in range(subdivisions):
        edges = np.sort(f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        keys, inverse = np.unique(edges[:, 0] * len(v) + edges[:, 1], return_inverse=True)  # 1-D: fast
        unique = np.stack(np.divmod(keys, len(v)), axis=1)
        mid = v[unique].sum(axis=1)
        v = np.concatenate([v, mid / np.linalg.norm(mid, axis=1, keepdims=True)])
        ab, bc, ca = (len(v) - len(unique) + inverse.reshape(-1, 3)).T
        a, b, c = f.T
        f = np.concatenate([np.stack(t, axis=1) for t in ((a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca))])
    return v * radius, f


def revolve(profile: np.ndarray, sections: int) -> tuple[np.ndarray, np.ndarray]:
    """Rotate a profile of (r, z) points about Z. The profile runs from bottom to top along
    the surface; points with r = 0 become single pole vertices, the others rings of
    `sections` vertices. Faces are outward when the profile keeps the inside on its left."""
    theta = np.linspace(0.0, 2.0 * np.pi, sections, endpoint=False)
    cos, sin = np.cos(theta), np.sin(theta)
    verts, rings, offset = [], [], 0
    for r, z in profile:
        if r == 0:
            verts.append(np.array([[0.0, 0.0, z]]))
            rings.append(np.full(sections, offset))
            offset += 1
        else:
            verts.append(np.stack([r * cos, r * sin, np.full(sections, z)], axis=1))
            rings.append(offset + np.arange(sections))
            offset += sections
    faces = []
    for lo, hi in zip(rings[:-1], rings[1:]):
        a, b, c, d = lo, np.roll(lo, -1), np.roll(hi, -1), hi
        if lo[0] != lo[-1]:          # a ring below: the (a, b, c) half of the quad
            faces.append(np.stack([a, b, c], axis=1))
        if hi[0] != hi[-1]:          # a ring above: the (a, c, d) half
            faces.append(np.stack([a, c, d], axis=1))
    return np.concatenate(verts), np.concatenate(faces).astype(np.int64)


def cylinder(radius: float, height: float, sections: int) -> tuple[np.ndarray, np.ndarray]:
    h = height / 2
    return revolve(np.array([[0.0, -h], [radius, -h], [radius, h], [0.0, h]]), sections)


def cone(radius: float, height: float, sections: int) -> tuple[np.ndarray, np.ndarray]:
    return revolve(np.array([[0.0, 0.0], [radius, 0.0], [0.0, height]]), sections)


def capsule(radius: float, height: float, sections: int) -> tuple[np.ndarray, np.ndarray]:
    """Two hemispheres of max(2, sections // 4) latitude steps joined by a straight part."""
    steps = max(2, sections // 4)
    phi = np.linspace(-np.pi / 2, 0.0, steps + 1)             # bottom pole → equator
    lower = np.stack([radius * np.cos(phi), radius * np.sin(phi) - height / 2], axis=1)
    upper = np.stack([radius * np.cos(-phi[::-1]), radius * np.sin(-phi[::-1]) + height / 2], axis=1)
    profile = np.concatenate([lower, upper] if height > 0 else [lower, upper[1:]])
    profile[[0, -1], 0] = 0.0                                 # exact poles
    return revolve(profile, sections)


def torus(major_radius: float, minor_radius: float, major_sections: int,
          minor_sections: int) -> tuple[np.ndarray, np.ndarray]:
    u = np.linspace(0.0, 2.0 * np.pi, major_sections, endpoint=False)[:, None]
    v = np.linspace(0.0, 2.0 * np.pi, minor_sections, endpoint=False)[None, :]
    ring = major_radius + minor_radius * np.cos(v)
    verts = np.stack(np.broadcast_arrays(ring * np.cos(u), ring * np.sin(u), minor_radius * np.sin(v)), axis=-1)
    idx = np.arange(major_sections * minor_sections).reshape(major_sections, minor_sections)
    a, b = idx, np.roll(idx, -1, axis=0)                     # b: next along the major circle
    c, d = np.roll(b, -1, axis=1), np.roll(a, -1, axis=1)    # next along the minor circle
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return verts.reshape(-1, 3), faces.astype(np.int64)


def box(size: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """An 8-vertex box centred at the origin with the given extents."""
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]], np.int64)
    return corners * np.asarray(size, float), faces

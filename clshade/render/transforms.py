"""4×4 camera matrices in the OpenGL convention (column vectors, camera looks
down −Z, NDC z in [−1, 1]), shared by the scene camera, the shadow-map lights
and the benchmarks."""
from __future__ import annotations

import math

import numpy as np


def unit(v) -> np.ndarray | None:
    """`v` scaled to length 1, or None when it has none (zero or non-finite components).
    Divided by its largest component first, so that squaring cannot overflow (1e200) or
    underflow (1e-300, subnormal 1e-320): the direction of any finite non-zero vector survives."""
    v = np.asarray(v, np.float64)
    largest = float(np.max(np.abs(v))) if v.size else 0.0
    if not (np.isfinite(largest) and largest > 0.0):
        return None
    w = v / largest
    return w / math.sqrt(float(np.dot(w, w)))


def look_along(eye, forward, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """World → view for a camera at `eye` looking along `forward`. When `up` is
    (nearly) parallel to `forward`, +X serves as the up hint instead."""
    eye, f, up = (np.asarray(a, dtype=np.float64) for a in (eye, forward, up))
    f, up_dir = unit(f), unit(up)
    if f is None or up_dir is None:
        raise ValueError(f"look_along: forward {forward!r} and up {up!r} need a finite non-zero length")
    if abs(np.dot(f, up_dir)) > 0.99:
        up = np.array([1.0, 0.0, 0.0])
    right = np.cross(f, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = right, true_up, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """World → view for a camera at `eye` looking at `target`."""
    return look_along(eye, np.asarray(target, np.float64) - np.asarray(eye, np.float64), up)


def perspective(fov_y_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    """gluPerspective: vertical field of view in degrees."""
    f = 1.0 / math.tan(math.radians(fov_y_deg) / 2)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = f / aspect, f
    m[2, 2], m[2, 3] = (far + near) / (near - far), 2 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def orthographic(left: float, right: float, bottom: float, top: float, near: float, far: float) -> np.ndarray:
    """glOrtho."""
    m = np.zeros((4, 4))
    m[0, 0], m[0, 3] = 2 / (right - left), -(right + left) / (right - left)
    m[1, 1], m[1, 3] = 2 / (top - bottom), -(top + bottom) / (top - bottom)
    m[2, 2], m[2, 3] = -2 / (far - near), -(far + near) / (far - near)
    m[3, 3] = 1.0
    return m


def pixel_rays(view: np.ndarray, proj: np.ndarray, width: int, height: int,
               index: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """World-space rays through the pixel centres (row 0 at the top; pixel (i, j) at
    (j + 0.5, i + 0.5)), by inverting proj @ view: origins on the near plane and unit
    directions, each (H·W, 3), or (K, 3) for the flat pixel indices `index`. The one
    camera-ray function: the rasterizer's oracle (an independent ray caster), the
    frame oracle (clshade.verify.reference) and the raster benchmark use it."""
    inv = np.linalg.inv(proj @ view)
    flat = np.arange(width * height) if index is None else np.asarray(index)
    i, j = np.divmod(flat, width)
    x = (j + 0.5) * (2.0 / width) - 1.0
    y = 1.0 - (i + 0.5) * (2.0 / height)
    # inv · (x, y, ±1, 1) as outer products with its columns (cheaper than a (K, 4) matmul)
    xy = x[:, None] * inv[:, 0] + y[:, None] * inv[:, 1] + inv[:, 3]
    near, far = xy - inv[:, 2], xy + inv[:, 2]
    ends = [p[:, :3] / p[:, 3:] for p in (near, far)]
    d = ends[1] - ends[0]
    return ends[0], d / np.sqrt(np.einsum("ij,ij->i", d, d))[:, None]

"""Small equirectangular skies the environment tests make (clshade/render/environment.py is the convention,
restated here from the issue's words so that the tests do not read it from the code under test):
u = atan2(d.x, −d.z)/2π wrapped to [0, 1), v = acos(d.y)/π, row 0 at the zenith.

    from sky_maps import directions, write_map
    write_map(tmp_path / "sky.exr", sky_of(lambda d: 1.0 + d[..., 1], 32, 16))
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def directions(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unit directions at map coordinates (u, v): the inverse of the convention above."""
    phi, theta = np.broadcast_arrays(2.0 * np.pi * np.asarray(u, np.float64), np.pi * np.asarray(v, np.float64))
    return np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], axis=-1)


def coordinates(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) of unit directions: the convention above."""
    d = np.asarray(d, np.float64)
    u = np.mod(np.arctan2(d[..., 0], -d[..., 2]) / (2.0 * np.pi), 1.0)
    return u, np.arccos(np.clip(d[..., 1], -1.0, 1.0)) / np.pi


def texel_centres(width: int, height: int) -> np.ndarray:
    """(H, W, 3) the direction at each texel's centre in (u, v)."""
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    return directions(u[None, :], v[:, None])


def sky_of(fn, width: int, height: int) -> np.ndarray:
    """(H, W, 3) float32 map of radiance fn(direction) (a number or RGB per direction) at texel centres."""
    value = np.asarray(fn(texel_centres(width, height)), np.float64)
    if value.ndim == 2:
        value = np.repeat(value[..., None], 3, axis=2)
    return value.astype(np.float32)


def rotate_y(d: np.ndarray, degrees: float) -> np.ndarray:
    """R_y(θ)·d, right-handed about +y (x turns towards −z)."""
    t = math.radians(degrees)
    c, s = math.cos(t), math.sin(t)
    d = np.asarray(d, np.float64)
    return np.stack([c * d[..., 0] + s * d[..., 2], d[..., 1], -s * d[..., 0] + c * d[..., 2]], axis=-1)


def write_map(path: Path, pixels: np.ndarray) -> Path:
    """Float32 EXR of (H, W, C) pixels (exact values), via OpenImageIO."""
    import OpenImageIO as oiio
    pixels = np.ascontiguousarray(pixels, np.float32)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], oiio.FLOAT))
    assert out.write_image(pixels)
    out.close()
    return path

"""Fragments + scene → the G-buffer: named per-pixel channels, one flat array each.

A channel exists only when the scene and model need it (see variants.py for
which ones a kernel variant reads). Non-finite inputs are replaced here,
before upload, and counted so the CLI can warn: the kernels then see only
finite values, and a bad pixel cannot affect any other.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .meshes import Geometry
from .raster import Fragments
from .scene import Scene
from .variants import material_row

# The channels the rasterizer pass can write, with their element type and
# components per pixel (struct of arrays, row-major, row 0 at the top).
CHANNELS: dict[str, tuple[type, int]] = {
    "depth": (np.float32, 1), "normal": (np.float32, 3), "base": (np.float32, 3),
    "roughness": (np.float32, 1), "metallic": (np.float32, 1), "material": (np.uint8, 1),
}


@dataclass
class GBuffer:
    width: int
    height: int
    channels: dict[str, np.ndarray]          # name → (H·W·components,) array
    materials: np.ndarray                    # (M, 4, 4) float32 material table
    coverage: np.ndarray                     # (H, W) bool
    nonfinite_pixels: int = 0                # pixels whose inputs were not finite (replaced)
    stats: dict[str, float] = field(default_factory=dict)

    @property
    def pixels(self) -> int:
        return self.width * self.height

    def bytes_per_pixel(self, names: tuple[str, ...] | list[str], half: bool = False) -> int:
        """Bytes a pass reads per pixel for these channels (3-component channels as half when `half`)."""
        total = 0
        for name in names:
            dtype, comps = CHANNELS[name]
            size = 2 if half and comps == 3 else np.dtype(dtype).itemsize
            total += size * comps
        return total

    def channel(self, name: str, half: bool = False) -> np.ndarray:
        data = self.channels[name]
        if half and CHANNELS[name][1] == 3:
            return data.astype(np.float16)
        return data


def material_table(scene: Scene) -> np.ndarray:
    """(M, 4, 4) float32: every material's constants in the layout of surface.h."""
    rows = [material_row(m.constants()) for m in scene.materials.values()]
    return np.stack(rows) if rows else np.zeros((0, 4, 4), np.float32)


def build_gbuffer(scene: Scene, geometry: Geometry, fragments: Fragments) -> GBuffer:
    """Interpolate normals and look up material values for every covered pixel."""
    h, w = fragments.tri_id.shape
    n = h * w
    cov = fragments.coverage.reshape(-1)
    tri = fragments.tri_id.reshape(-1)[cov]
    bary = fragments.bary.reshape(-1, 3)[cov].astype(np.float32)

    mats = list(scene.materials.values())
    base_of = np.array([m.base_color for m in mats], np.float32).reshape(-1, 3)
    rough_of = np.array([m.roughness for m in mats], np.float32)
    metal_of = np.array([m.metallic for m in mats], np.float32)

    depth = np.zeros(n, np.float32)
    depth[cov] = fragments.depth.reshape(-1)[cov]
    normal = np.zeros((n, 3), np.float32)
    base = np.zeros((n, 3), np.float32)
    rough = np.zeros(n, np.float32)
    metal = np.zeros(n, np.float32)
    matid = np.zeros(n, np.uint8)
    if len(tri):
        corners = geometry.faces[tri]                       # (K, 3) vertex ids
        nrm = np.einsum("kc,kcd->kd", bary, geometry.normals[corners])
        length = np.linalg.norm(nrm, axis=1, keepdims=True)
        normal[cov] = np.divide(nrm, length, out=np.zeros_like(nrm), where=length > 0)
        mid = geometry.face_material[tri]
        base[cov] = base_of[mid]
        rough[cov] = rough_of[mid]
        metal[cov] = metal_of[mid]
        matid[cov] = mid.astype(np.uint8)

    # Replace non-finite inputs (from NaN vertices, bad normals in a mesh file):
    # the pixel shades as empty/neutral and is counted; no other pixel is touched.
    bad = ~(np.isfinite(depth) & np.isfinite(normal).all(1) & np.isfinite(base).all(1))
    nonfinite = int(np.count_nonzero(bad & cov))
    if nonfinite:
        depth[bad] = 0.0
        normal[bad] = 0.0
        base[bad] = 0.0
        cov = cov & ~bad

    channels = {"depth": depth, "normal": normal.reshape(-1), "base": base.reshape(-1),
                "roughness": rough, "metallic": metal, "material": matid}
    return GBuffer(w, h, channels, material_table(scene), cov.reshape(h, w), nonfinite)

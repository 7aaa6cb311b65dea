"""Shadow maps: the scene's depth seen from each shadow-casting light, rasterised
with clshade.render.raster.rasterize, for the lookup in the shading kernel (kernels/shadow.h).

Directional lights get an orthographic map fitted to the scene's bounding box
(seen along the light), spot lights a perspective map covering their outer
cone. Point lights would need cube maps: scene.py rejects `shadows = true` on
them. A map stores the light-view depth −z_view of the nearest surface (front
and back faces both: back faces culled would leak light through single-sided
planes), SHADOW_EMPTY_DEPTH where nothing was hit.

Per shadow map the kernel receives SHADOW_ROWS float4 (see shadow.h):
  rows 0–3  the light's proj · view (clip = M · (P, 1))
  row  4    the depth row: light-view depth = dot(row.xyz, P) + row.w
  row  5    (texel, perspective, 0, 0): the world size of one texel, at unit
            depth when perspective = 1 (spot), everywhere when 0 (directional)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from clshade.render.meshes import Geometry
from clshade.render.raster import rasterize
from clshade.render.scene import Light, Scene
from clshade.render.transforms import look_along, orthographic, perspective
from clshade.resources import constant

SHADOW_ROWS = 6
# Depth written where a map sees no surface: any receiver is nearer, so lit.
SHADOW_EMPTY_DEPTH = 3.0e38
# Relative margin added around the fitted depth range and footprint, so the
# bounding box's own corners are not clipped by round-off.
FIT_MARGIN = 1e-3
# A spot map covers the outer cone plus this many degrees; the field of view is
# capped at MAX_SPOT_FOV (a perspective map cannot cover a hemisphere: receivers
# beyond it are treated as lit). Spots with outer_angle ≤ 80° are fully covered.
SPOT_FOV_MARGIN_DEG = 2.0
MAX_SPOT_FOV_DEG = 164.0
# Near plane of a spot map as a fraction of its far plane: the rasterizer's
# depth keys have ~2⁴⁰ levels, so the usual precision worry does not apply;
# surfaces nearer than far/10⁴ to the light do not cast shadows.
SPOT_NEAR_RATIO = 1e-4


@dataclass(frozen=True)
class ShadowMaps:
    """All shadow maps of a frame, stacked, with the per-map parameters."""
    size: int
    pcf: int                        # odd PCF kernel width (1 = one tap)
    maps: np.ndarray                # (count, size, size) float32 light-view depth
    params: np.ndarray              # (count, SHADOW_ROWS, 4) float32
    light_slot: tuple[int, ...]     # per scene light: its map index, −1 = no shadows

    @property
    def count(self) -> int:
        return int(self.maps.shape[0])


def light_projection(light: Light, lo: np.ndarray, hi: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray, float, bool]:
    """(view, proj, texel, perspective) of a light's shadow map over the box [lo, hi]."""
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    extent = max(float(np.linalg.norm(hi - lo)), 1e-6)
    if light.kind == "directional":
        centre = 0.5 * (lo + hi)
        view = look_along(centre - light.direction * extent, light.direction)
        p = corners @ view[:3, :3].T + view[:3, 3]
        pad = FIT_MARGIN * extent
        x0, x1 = p[:, 0].min() - pad, p[:, 0].max() + pad
        y0, y1 = p[:, 1].min() - pad, p[:, 1].max() + pad
        near, far = max(-p[:, 2].max() - pad, pad), -p[:, 2].min() + pad
        proj = orthographic(x0, x1, y0, y1, near, far)
        return view, proj, max(x1 - x0, y1 - y0) / size, False
    view = look_along(light.position, light.direction)
    far = float(np.linalg.norm(corners - light.position, axis=1).max()) * (1 + FIT_MARGIN) + 1e-6
    fov = min(2.0 * light.outer_angle + SPOT_FOV_MARGIN_DEG, MAX_SPOT_FOV_DEG)
    proj = perspective(fov, 1.0, far * SPOT_NEAR_RATIO, far)
    return view, proj, 2.0 * math.tan(math.radians(fov) / 2) / size, True


def build_shadow_maps(scene: Scene, geometry: Geometry) -> ShadowMaps | None:
    """Rasterise one depth map per shadow-casting light; None when no light casts shadows."""
    casters = scene.shadow_lights
    if not casters:
        return None
    size = scene.shadow_map_size
    slots = [-1] * len(scene.lights)
    if geometry.triangle_count:
        lo, hi = geometry.vertices.min(axis=0), geometry.vertices.max(axis=0)
    else:
        lo, hi = -np.ones(3), np.ones(3)
    maps = np.full((len(casters), size, size), SHADOW_EMPTY_DEPTH, np.float32)
    params = np.zeros((len(casters), SHADOW_ROWS, 4), np.float32)
    for slot, index in enumerate(casters):
        light = scene.lights[index]
        view, proj, texel, perspective = light_projection(light, lo, hi, size)
        if geometry.triangle_count:
            frags = rasterize(geometry.vertices, geometry.faces, view, proj, size, size, cull_backfaces=False)
            maps[slot][frags.coverage] = frags.depth[frags.coverage]
        params[slot, :4] = proj @ view
        params[slot, 4] = -view[2]
        params[slot, 5] = [texel, float(perspective), 0.0, 0.0]
        slots[index] = slot
    return ShadowMaps(size, scene.shadow_pcf, maps, params, tuple(slots))


def shadow_visibility(shadows: ShadowMaps, points: np.ndarray, normals: np.ndarray, *,
                      offset: tuple[float, float] = (0.0, 0.0), normal_offset: float | None = None,
                      bias: float | None = None) -> np.ndarray:
    """(num_lights, K) fraction of PCF taps that see each light from the points (K, 3)
    with unit shading normals (K, 3), in float64, as the lookup of kernels/shadow.h is
    documented: the point moves texel · (radius + SHADOW_NORMAL_OFFSET_TEXELS) along its
    normal, its light-view depth less texel · SHADOW_BIAS_TEXELS is compared with each
    of the (2·radius + 1)² map texels around its projection; taps outside the map, and
    points behind a spot's projection centre, are lit. Lights without a map: 1.
    `offset` moves the projection by that many texels (x right, y down). `normal_offset` and
    `bias` (texels) default to shadow.h's; the float64 oracle passes its own (verify.reference)."""
    radius = shadows.pcf // 2
    normal_offset = constant("SHADOW_NORMAL_OFFSET_TEXELS") if normal_offset is None else normal_offset
    bias = constant("SHADOW_BIAS_TEXELS") if bias is None else bias
    size = shadows.size
    P = np.asarray(points, np.float64)
    n = np.asarray(normals, np.float64)
    out = np.ones((len(shadows.light_slot), len(P)))
    for light, slot in enumerate(shadows.light_slot):
        if slot < 0:
            continue
        m = shadows.params[slot].astype(np.float64)
        # row · (q, 1), element-wise (no BLAS call: the NumPy baseline stays on one thread)
        row = lambda k, q: q[:, 0] * m[k, 0] + q[:, 1] * m[k, 1] + q[:, 2] * m[k, 2] + m[k, 3]  # noqa: E731
        texel = m[5, 0] * row(4, P) if m[5, 1] > 0.5 else np.full(len(P), m[5, 0])
        q = P + n * (texel * (radius + normal_offset))[:, None]
        clip = np.stack([row(k, q) for k in range(4)], axis=1)
        front = clip[:, 3] > 0
        w = np.where(front, clip[:, 3], 1.0)
        fx = (clip[:, 0] / w * 0.5 + 0.5) * size + offset[0]
        fy = (0.5 - clip[:, 1] / w * 0.5) * size + offset[1]
        ref = row(4, q) - texel * bias
        ix = np.floor(np.clip(fx, -radius - 1, size + radius)).astype(np.int64)
        iy = np.floor(np.clip(fy, -radius - 1, size + radius)).astype(np.int64)
        lit = np.zeros(len(P))
        for dy in range(-radius, radius + 1):
            for dx in range(-radius, radius + 1):
                x, y = ix + dx, iy + dy
                inside = (x >= 0) & (y >= 0) & (x < size) & (y < size)
                stored = shadows.maps[slot][np.where(inside, y, 0), np.where(inside, x, 0)]
                lit += ~inside | (ref <= stored)
        out[light] = np.where(front, lit / (2 * radius + 1) ** 2, 1.0)
    return out

"""The truth under an environment: f·(n·l)·L integrated over the sphere in float64, for a documented
subset of a frame's covered pixels, and each rung's error against it.

The sky is piecewise constant over its texels (clshade/render/environment.py), so the integral is a
sum over texels of L_texel · ∫_texel f·(n·l)⁺ dω. Each texel's integral is taken by the midpoint rule
on `subdivisions`² cells of equal θ and φ extent, each weighted by its exact solid angle: exact where
f·(n·l) is constant over a cell, and it converges as `subdivisions` grows
(tests/verify/test_environment_oracle.py). The BRDF is clshade.verify.reference.brdf (the float64 formulas written from the
papers), or a user's lobe's double-precision device build (reference.device_f64).

The pixels: `count` covered pixels evenly strided in raster order (the k-th of K covered pixels
taken at k = round(i·(K − 1)/(count − 1))), so the set is fixed by the frame and the count alone.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from clshade.models.model import Model
from clshade.render.environment import Environment, rotation_matrix
from clshade.render.gbuffer import GBuffer
from clshade.render.scene import Camera, Scene
from clshade.render.shadows import ShadowMaps
from clshade.verify import reference as R
from clshade.verify.reference.vectors import _ERR

#: Pixels the oracle integrates by default: 256 pixels × a 128×64 map × 2² cells is 8.4 M BRDF
#: evaluations, about 10 s of NumPy.
DEFAULT_PIXELS = 256
#: Cells per texel side by default. Measured on scenes/environment.toml at 128×128 (GGX, gold at roughness
#: 0.2, 96 pixels): 2² against 4² cells differ by 0.6 % relative RMSE overall but 2–5 % where n·v ≤ 0.25 (a
#: sharp lobe at a grazing view is the midpoint rule's hard case); 1² → 2² shrinks the gap 8×. truth(check=True)
#: measures a frame's own gap.
DEFAULT_SUBDIVISIONS = 2
#: BRDF evaluations per NumPy batch (pixels × directions): bounds the oracle's memory (~0.5 GB).
BATCH = 1 << 20
#: A relative error below REL_ERROR_FLOOR × the peak radiance counts as absolute (as `clshade bench`).
REL_ERROR_FLOOR = 1e-3
#: The n·v bins the error is split by: grazing views first, where the split sum's n = v = r fails.
NV_BINS = (0.0, 0.1, 0.25, 0.5, 1.0)


def sky_cells(width: int, height: int, subdivisions: int, rotation: float = 0.0
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The integration cells of a W×H map: (world directions (M, 3), solid angles (M,), texel
    index (M,)), M = W·H·subdivisions². Each texel is cut into subdivisions² cells of equal θ and φ
    extent, whose solid angle is exact, Δφ·(cos θ_top − cos θ_bottom); a cell's direction is at its
    centre in (θ, φ). Cells of equal angles stay small at the poles (a 2×1 map's one row included)."""
    s = subdivisions
    edges = np.pi * np.arange(height * s + 1) / (height * s)                             # θ, row by row
    cos_edges = np.cos(edges)
    cos_edges[0], cos_edges[-1] = 1.0, -1.0
    theta = 0.5 * (edges[:-1] + edges[1:])                                               # (H·s,)
    phi = (2.0 * np.pi / width) * (np.arange(width)[:, None] + (np.arange(s) + 0.5) / s).reshape(-1)
    omega = (2.0 * np.pi / (width * s)) * (cos_edges[:-1] - cos_edges[1:])               # per θ row
    sin_t = np.sin(theta)
    d = np.stack([sin_t[:, None] * np.sin(phi)[None, :], np.broadcast_to(np.cos(theta)[:, None], (len(theta), len(phi))),
                  -sin_t[:, None] * np.cos(phi)[None, :]], axis=-1).reshape(-1, 3)
    world = d @ rotation_matrix(rotation).T
    rows = np.repeat(np.arange(height), s)
    cols = np.repeat(np.arange(width), s)
    texel = (rows[:, None] * width + cols[None, :]).reshape(-1)
    return world, np.broadcast_to(omega[:, None], (len(theta), len(phi))).reshape(-1).copy(), texel


def oracle_pixels(gbuffer: GBuffer, camera: Camera, count: int = DEFAULT_PIXELS) -> R.Pixels:
    """The covered pixels the oracle integrates (module docstring): `count` evenly strided ones, or
    all of them when there are fewer."""
    px = R.pixels(gbuffer, camera)
    k = len(px.index)
    keep = np.unique(np.round(np.linspace(0, k - 1, count)).astype(np.intp)) if k > count else np.arange(k)
    return R.Pixels(*(None if a is None else a[keep] for a in (px.index, px.P, px.n, px.v, px.base, px.roughness,
                                                               px.metallic, px.material, px.tangent)))


def sky_integral(model: Model, px: R.Pixels, env: Environment, subdivisions: int = DEFAULT_SUBDIVISIONS,
                 alpha_floor: float = R.MIN_ALPHA) -> np.ndarray:
    """(K, 3) float64: Σ over cells of f(n, l, v)·max(n·l, 0)·L·ω at each pixel (module docstring)."""
    w, h = env.size
    dirs, omega, texel = sky_cells(w, h, subdivisions, env.rotation)
    radiance = env.radiance.reshape(-1, 3).astype(np.float64)[texel] * omega[:, None]    # L·ω per cell
    lit = radiance.max(axis=1) > 0.0
    dirs, radiance = dirs[lit], radiance[lit]
    args = R.surface_args(model, px.base, px.roughness, px.metallic, px.material, alpha_floor)
    k = len(px.index)
    per_pixel = {name: a[:, None] if a.ndim == 1 else a[:, None, :]
                 for name, a in args.items() if isinstance(a, np.ndarray) and a.ndim and len(a) == k}
    out = np.zeros((k, 3))
    step = max(1, BATCH // max(k, 1))
    for start in range(0, len(dirs), step):
        l = dirs[start:start + step]
        nl = px.n @ l.T                                                                  # (K, m)
        with np.errstate(**_ERR):
            f = _brdf(model, px, l, {**args, **per_pixel})
            out += np.einsum("km,kmc,mc->kc", np.maximum(nl, 0.0), np.nan_to_num(f * (nl > 0)[..., None]),
                             radiance[start:start + step])
    return out


def _brdf(model: Model, px: R.Pixels, l: np.ndarray, args: dict) -> np.ndarray:
    """(K, m, 3) f at every pixel × direction."""
    k, m = len(px.index), len(l)
    n, v = px.n[:, None, :], px.v[:, None, :]
    if model.is_users:
        rep = lambda a: np.repeat(a, m, axis=0)  # noqa: E731
        f = R.device_f64(model, rep(px.n), np.tile(l, (k, 1)), rep(px.v), rep(px.base), rep(px.roughness),
                         rep(px.metallic), rep(px.material), None if px.tangent is None else rep(px.tangent))
        return f.reshape(k, m, 3)
    return R.brdf(model.diffuse, model.specular, np.broadcast_to(n, (k, m, 3)), np.broadcast_to(l[None], (k, m, 3)),
                  np.broadcast_to(v, (k, m, 3)), **args)


@dataclass(frozen=True)
class Truth:
    """The oracle's radiance at a set of pixels (flat index into the frame), with their n·v."""
    index: np.ndarray        # (K,) flat pixel index, raster order
    nv: np.ndarray           # (K,)
    radiance: np.ndarray     # (K, 3) float64
    subdivisions: int
    # (K, 3) |truth − the truth at twice the subdivisions|: the oracle's own error, estimated (check=True)
    uncertainty: np.ndarray | None = None


def truth(gbuffer: GBuffer, scene: Scene, model: Model, env: Environment, *, camera: Camera | None = None,
          shadows: ShadowMaps | None = None, count: int = DEFAULT_PIXELS,
          subdivisions: int = DEFAULT_SUBDIVISIONS, check: bool = False) -> Truth:
    """The radiance the shading pass should write at oracle_pixels: the frame oracle's lights, ambient
    and emission (reference.radiance) plus the sky's integral (times the occlusion channel where the
    G-buffer has one: the sky is unoccluded but for ambient occlusion). `check` also integrates with
    twice the subdivisions (4× the time) and keeps the difference as the truth's `uncertainty`."""
    camera = scene.camera if camera is None else camera
    px = oracle_pixels(gbuffer, camera, count)
    occlusion = np.ones(len(px.index))
    if "occlusion" in gbuffer.channels:
        occlusion = np.clip(gbuffer.channels["occlusion"][px.index].astype(np.float64), 0.0, 1.0)
    sky = sky_integral(model, px, env, subdivisions) * occlusion[:, None]
    gap = None
    if check:
        gap = np.abs(sky_integral(model, px, env, 2 * subdivisions) * occlusion[:, None] - sky)
    rest = R.radiance(gbuffer, scene, model, camera=camera, shadows=shadows).reshape(-1, 3)[px.index]
    return Truth(px.index, np.sum(px.n * px.v, axis=1), rest + sky, subdivisions, gap)


def errors(image: np.ndarray, t: Truth, bins: tuple[float, ...] = NV_BINS) -> dict[str, object]:
    """An image's error against the truth on its pixels: relative RMSE (√(Σ|L − T|²/Σ|T|²) over pixels and
    channels), the largest per-pixel relative error (max over RGB of |L − T| / max(|T|, REL_ERROR_FLOOR ·
    peak)), the truth's own relative RMSE where it was checked (Truth.uncertainty), and all per n·v bin
    (`bins` edges; a bin's row counts its pixels)."""
    got = np.asarray(image, np.float64)[..., :3].reshape(-1, 3)[t.index]
    peak = max(float(np.abs(t.radiance).max()), 1e-30)
    rel = (np.abs(got - t.radiance) / np.maximum(np.abs(t.radiance), REL_ERROR_FLOOR * peak)).max(axis=1)

    def summary(mask: np.ndarray) -> dict[str, object]:
        if not mask.any():
            return dict(pixels=0, rel_rmse=None, max_rel=None, oracle_rel_rmse=None)
        den = np.sum(t.radiance[mask] ** 2)
        rmse = lambda d: float(np.sqrt(np.sum(d ** 2) / den)) if den > 0 else None  # noqa: E731
        return dict(pixels=int(mask.sum()), rel_rmse=rmse(got[mask] - t.radiance[mask]), max_rel=float(rel[mask].max()),
                    oracle_rel_rmse=None if t.uncertainty is None else rmse(t.uncertainty[mask]))

    by_nv = [dict(nv=(lo, hi), **summary((t.nv > lo) & (t.nv <= hi))) for lo, hi in zip(bins[:-1], bins[1:])]
    return dict(**summary(np.ones(len(t.index), bool)), by_nv=by_nv)

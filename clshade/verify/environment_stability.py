"""The hard cases of environment light, for `clshade check stability` (docs/stability.md, *Environment*).

A hand-made G-buffer — roughness 0, MIN_PERCEPTUAL_ROUGHNESS, 0.5 and 1, base 0 and 1, metallic 0 and 1,
normals at ENV_AZIMUTHS azimuths × ENV_COSINES values of n·v down to grazing, 0 and back-facing — is shaded
under a sun sky in every rung of the ladder (clshade.verify.environment_rungs.ladder_rungs; the sampled rungs at
ENV_SAMPLES). The sun sky is synthetic (one texel SUN_RATIO × the mean of the rest of a soft gradient, so the
check runs without the assets) and, when present, the real map SUN_MAP (its sun ~3.1e4 × the mean).

Counted on the raw radiance (no MAX_RADIANCE clamp), per rung: NaN, ±Inf and negative pixels — each must be
zero (Report.failures) — and, reported and not failed:
* fireflies, in the rungs whose diffuse is sampled (a constant or SH9 diffuse beside a sampled specular is
  biased, not noisy: its error is the ladder's), under the synthetic sky. A firefly is a covered pixel whose
  luminance exceeds FIREFLY_FACTOR × the float64 truth's luminance at that pixel (environment_oracle; the
  truth floored at environment_oracle.REL_ERROR_FLOOR × its peak), counted where the roughness is at least
  FIREFLY_MIN_ROUGHNESS and n·v > 0;
* pixels above the sky's peak: luminance above the brightest texel's, every rung and roughness. A lobe
  whose directional albedo is ≤ 1 cannot reflect more than the brightest direction it sees, so such a pixel
  is a sampling spike (or a lobe that is not energy-conserving: the empirical ones without normalisation).
"""
from __future__ import annotations

import dataclasses
import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from clshade.device.runtime import Runtime
from clshade.models.model import Model
from clshade.render import environment as E
from clshade.verify.environment_rungs import ladder_rungs, model_rungs

#: Sample counts of the sampled rungs here: one sample (the noisiest image) and the default.
ENV_SAMPLES = (1, E.DEFAULT_SAMPLES)
#: n·v of the grid's normals (v = +z): head-on, oblique, grazing, the horizon and back-facing.
ENV_COSINES = (1.0, 0.5, 0.1, 1e-2, 1e-3, 0.0, -0.2)
#: Azimuths of the tilted normals: 8 turns, so that some mirror directions meet the sun.
ENV_AZIMUTHS = 8
#: Perceptual roughness of the grid: a mirror, the kernels' floor (MIN_PERCEPTUAL_ROUGHNESS), mid, fully rough.
ENV_ROUGHNESS = (0.0, 0.045, 0.5, 1.0)
#: The sun of the synthetic sky: its texel's radiance over the mean of the rest of the sky (sun_sky), as the
#: sunny CC0 maps' sun texels are over their mean.
SUN_RATIO = 3.5e4
#: The synthetic sky's size (2:1): small, so that the truth is cheap.
SUN_SKY = (64, 32)
#: The models of the environment cases by default (`clshade check stability` without --model): one per
#: strategy the sampled rung draws from (LOBE_SAMPLING: GGX, Beckmann, Phong, Blinn–Phong) and Lambert.
ENV_MODELS = ("lambert", "ggx_correlated", "cook_torrance", "phong", "blinn_phong")
#: The real sunny map, used when the shared assets are present (counts only: its truth costs minutes).
SUN_MAP = Path(__file__).resolve().parents[3] / "shared" / "assets" / "hdri" / "city.exr"
#: A firefly is brighter than FIREFLY_FACTOR × the truth at its pixel: 10× is far beyond the sampled rung's
#: noise at N = 64 on a soft sky (a few % RMSE) and what a viewer sees as a speck.
FIREFLY_FACTOR = 10.0
#: Below this roughness a lobe is narrower than the truth's cells (environment_oracle: the midpoint rule's
#: hard case), so the truth cannot say whether a bright pixel is right: fireflies are not counted there.
FIREFLY_MIN_ROUGHNESS = 0.25


def sun_sky(width: int = SUN_SKY[0], height: int = SUN_SKY[1], ratio: float = SUN_RATIO) -> np.ndarray:
    """(H, W, 3) float32: a soft sky (1 + the height, ≥ 0.2) with one sun texel at elevation ~34° (row H/5)
    `ratio` × the mean radiance of the rest of the sky. The rest, not the whole map: a texel of a small map
    is too large to be 3.5e4 × a mean it is part of (it would hold more than all the energy)."""
    v = (np.arange(height) + 0.5) / height
    sky = np.repeat(np.maximum(1.0 + np.cos(np.pi * v), 0.2)[:, None], width, axis=1)
    omega = E.texel_solid_angles(width, height)
    i, j = height // 5, width // 3
    rest = (np.sum(sky * omega[:, None]) - sky[i, j] * omega[i]) / (4.0 * np.pi - omega[i])
    sky[i, j] = ratio * rest
    return np.repeat(sky[..., None], 3, axis=2).astype(np.float32)


def fireflies(luminance: np.ndarray, truth: np.ndarray, factor: float = FIREFLY_FACTOR,
              floor: float | None = None) -> int:
    """Pixels whose luminance exceeds `factor` × the truth's (the truth floored at `floor`, default
    environment_oracle.REL_ERROR_FLOOR × its peak)."""
    from clshade.verify.environment_oracle import REL_ERROR_FLOOR
    truth = np.asarray(truth, np.float64)
    if floor is None:
        floor = REL_ERROR_FLOOR * max(float(np.abs(truth).max(initial=0.0)), 1e-30)
    return int(np.sum(np.asarray(luminance, np.float64) > factor * np.maximum(truth, floor)))


def bad_pixels(raw: np.ndarray) -> dict[str, int]:
    """NaN, ±Inf (not NaN) and negative (a channel < 0) pixels of an (…, 3) raw radiance."""
    raw = np.asarray(raw, np.float64).reshape(-1, raw.shape[-1])
    nan = np.isnan(raw).any(axis=1)
    return dict(nan=int(nan.sum()), inf=int((np.isinf(raw).any(axis=1) & ~nan).sum()),
                negative=int((raw < 0).any(axis=1).sum()))


@dataclass
class EnvironmentResult:
    """One model × sky × rung (× N) of the environment cases."""
    model: str
    sky: str
    rung: str
    samples: int | None
    pixels: int = 0
    nan: int = 0
    inf: int = 0
    negative: int = 0
    clamped_nonfinite: int = 0             # the shipped (clamped) build's NaN/Inf pixels
    max_radiance: float = 0.0              # largest finite raw radiance
    fireflies: int | None = None           # diffuse-sampled rungs, synthetic sky (None: not counted)
    above_peak: int = 0                    # pixels brighter than the sky's brightest texel (luminance)
    firefly_pixels: int = 0                # pixels where fireflies are counted

    @property
    def nonfinite(self) -> int:
        return self.nan + self.inf


def grid(model: Model) -> tuple[dict[str, np.ndarray], int, int, np.ndarray]:
    """The hand-made G-buffer's channels, width, height and per-pixel roughness (module docstring)."""
    normals = []
    for c in ENV_COSINES:
        s = math.sqrt(max(0.0, 1.0 - c * c))
        for k in range(ENV_AZIMUTHS):
            a = 2.0 * math.pi * (k + 0.5) / ENV_AZIMUTHS
            normals.append((s * math.cos(a), s * math.sin(a), c))
    normals = np.array(normals)
    params = [(r, b, m) for r in ENV_ROUGHNESS for b in (0.0, 1.0) for m in (0.0, 1.0)]
    width, height = len(normals), len(params)
    rough, base_value, metal = (np.repeat([p[i] for p in params], width) for i in range(3))
    npix = width * height
    channels = {"depth": np.full(npix, 10.0, np.float32), "normal": np.tile(normals, (height, 1)).astype(np.float32).reshape(-1),
                "base": np.repeat(base_value[:, None], 3, 1).astype(np.float32).reshape(-1),
                "roughness": rough.astype(np.float32), "metallic": metal.astype(np.float32),
                "material": np.zeros(npix, np.uint8)}
    return channels, width, height, rough


def run_environment(model: Model, rt: Runtime, skies: list[tuple[str, Path]] | None = None) -> list[EnvironmentResult]:
    """Every rung of the ladder on the grid under each sky (default: the synthetic sun sky and SUN_MAP when
    present), precise build, raw radiance counted; fireflies against the truth under the synthetic sky."""
    from clshade.device.shade import Shader, scene_features
    from clshade.device.variants import EnvironmentFeatures
    from clshade.render.gbuffer import GBuffer, material_table
    from clshade.render.scene import Camera, Material, Scene
    from clshade.verify import environment_oracle as O

    channels, width, height, rough = grid(model)
    camera = Camera(position=np.array([0.0, 0.0, 10.0]), target=np.zeros(3), up=np.array([0.0, 1.0, 0.0]),
                    fov=1e-3, width=width, height=height)
    out: list[EnvironmentResult] = []
    with tempfile.TemporaryDirectory(prefix="clshade-env-") as tmp:
        if skies is None:
            skies = [("synthetic sun", _write_exr(Path(tmp) / "sun.exr", sun_sky()))]
            if SUN_MAP.is_file():
                skies.append((SUN_MAP.name, SUN_MAP))
        for sky_name, path in skies:
            spec = E.EnvironmentSpec(map=path)
            scene = Scene(path=None, camera=camera, lights=(), materials={"m": Material("m")}, objects=(),
                          environment=spec)
            gb = GBuffer(width, height, channels, material_table(scene), np.ones((height, width), bool))
            truth, keep = None, None
            if sky_name == "synthetic sun":
                env = E.prepare_spec(spec)
                truth = O.truth(gb, scene, model, env, camera=camera, count=width * height, subdivisions=1)
                keep = (rough[truth.index] >= FIREFLY_MIN_ROUGHNESS) & (truth.nv > 0)
            base = scene_features(scene)
            peak = float((E.sky_radiance(spec).astype(np.float64) @ np.array(E.LUMINANCE)).max())
            shaders: dict[int | None, Shader] = {}
            for r in model_rungs(model, ladder_rungs(ENV_SAMPLES)):
                sc = scene if r.samples is None else dataclasses.replace(
                    scene, environment=dataclasses.replace(spec, samples=r.samples))
                shader = shaders.setdefault(r.samples, Shader(rt, gb, sc, camera))
                features = dataclasses.replace(base, environment=EnvironmentFeatures(
                    r.diffuse, r.specular, base.environment.map_sampling, False))
                raw = shader.render(model, dataclasses.replace(features, raw_radiance=True))[..., :3]
                shipped = shader.render(model, features)[..., :3]
                res = EnvironmentResult(model.id, sky_name, f"{r.diffuse}/{r.specular}", r.samples, pixels=width * height,
                                        clamped_nonfinite=int((~np.isfinite(shipped).all(-1)).sum()), **bad_pixels(raw))
                finite = raw[np.isfinite(raw)]
                res.max_radiance = float(finite.max()) if finite.size else 0.0
                lum_all = raw.reshape(-1, 3).astype(np.float64) @ np.array(E.LUMINANCE)
                res.above_peak = int(np.sum(lum_all > peak))
                if truth is not None and r.diffuse == "sampled":
                    lum = raw.reshape(-1, 3).astype(np.float64)[truth.index] @ np.array(E.LUMINANCE)
                    ref = truth.radiance @ np.array(E.LUMINANCE)
                    res.fireflies = fireflies(lum[keep], ref[keep])
                    res.firefly_pixels = int(keep.sum())
                out.append(res)
    return out


def _write_exr(path: Path, pixels: np.ndarray) -> Path:
    """Float32 EXR of (H, W, 3) pixels via OpenImageIO (the reader every map goes through)."""
    import OpenImageIO as oiio
    pixels = np.ascontiguousarray(pixels, np.float32)
    out = oiio.ImageOutput.create(str(path))
    if out is None or not out.open(str(path), oiio.ImageSpec(pixels.shape[1], pixels.shape[0], 3, oiio.FLOAT)):
        raise OSError(f"{path}: OpenImageIO cannot write it")
    out.write_image(pixels)
    out.close()
    return path


def summary(results: list[EnvironmentResult]) -> dict[str, object]:
    """Totals: pixels, NaN, Inf, negative, shipped-build NaN/Inf and fireflies (and the pixels they are
    counted on), with the firefly definition."""
    counted = [r for r in results if r.fireflies is not None]
    return dict(pixels=sum(r.pixels for r in results), nan=sum(r.nan for r in results),
                above_peak=sum(r.above_peak for r in results),
                inf=sum(r.inf for r in results), negative=sum(r.negative for r in results),
                clamped_nonfinite=sum(r.clamped_nonfinite for r in results),
                fireflies=sum(r.fireflies for r in counted), firefly_pixels=sum(r.firefly_pixels for r in counted),
                firefly_definition=f"luminance > {FIREFLY_FACTOR:g} × the float64 truth's at the pixel, where "
                                   f"roughness ≥ {FIREFLY_MIN_ROUGHNESS:g} and n·v > 0, diffuse-sampled rungs, synthetic "
                                   f"sun sky ({SUN_RATIO:g} × the mean of the rest)",
                sun_ratio=SUN_RATIO, samples=list(ENV_SAMPLES), cosines=list(ENV_COSINES), roughness=list(ENV_ROUGHNESS))

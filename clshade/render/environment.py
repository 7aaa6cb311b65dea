"""Environments: light from the whole sky, an equirectangular radiance map (scenes/README.md, [environment]).

Orientation (Mitsuba 3's `envmap`, stated once): +y is up; a unit direction d looks up the map at
u = atan2(d.x, −d.z) / 2π wrapped to [0, 1) (the left edge looks along −z, u = ¼ along +x, the
centre along +z) and v = acos(d.y) / π (row 0 is the zenith, the last row the nadir). Texel (row i,
column j) covers φ = 2πu in [2πj/W, 2π(j + 1)/W) and cos θ = d.y in [cos(π(i + 1)/H), cos(πi/H)], so
its solid angle is exactly (2π/W)·(cos(πi/H) − cos(π(i + 1)/H)). `rotation = θ` turns the sky by θ
about +y (right-handed): the map is looked up at R_y(−θ)·d.

The map is piecewise constant over its texels (the kernels look it up at the nearest texel; only the
background is filtered, bilinearly, for display). Everything derived from it here is exact for that
piecewise-constant sky: the mean radiance, the 9 spherical-harmonic coefficients (texel integrals of
the basis in closed form) and the luminance distribution the sampled rung draws from.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path

import numpy as np

from clshade import budget
from clshade.diagnostics import stderr_captured
from clshade.errors import ClshadeError, located
from clshade.render.textures import _read_pixels, _to_rgb

# The rungs of the ladder (scenes/README.md), cheapest first: the one list of what exists.
DIFFUSE_RUNGS = ("constant", "sh9", "sampled")
SPECULAR_RUNGS = ("none", "split_sum", "split_sum_ms", "sampled")
# The rungs that prefilter the map per specular lobe family (clshade/render/prefilter.py).
SPLIT_SUM_RUNGS = ("split_sum", "split_sum_ms")
DEFAULT_DIFFUSE = "sh9"
DEFAULT_SPECULAR = "sampled"
# Samples per pixel of the sampled rungs: 64 brings a rough GGX robot under a soft sky to ~1 %
# RMSE; 1024 is the top of the ladder the issue asks for (cost is linear in N).
DEFAULT_SAMPLES = 64
MAX_SAMPLES = 1024
# Rec. 709 luminance weights: the map's luminance is what the sampled rung draws directions from.
LUMINANCE = (0.2126, 0.7152, 0.0722)
# Lossy EXR compression (DWA) rings below 0 around bright edges: Poly Haven's 1k maps reach
# −0.18 % of their mean luminance. Texels down to −NEGATIVE_TEXEL_TOLERANCE × the mean read as 0;
# a more negative texel is a broken map and is refused.
NEGATIVE_TEXEL_TOLERANCE = 1e-2

# The real spherical harmonics of bands 0–2, with +y as the polar axis, in the order
# 1, y, z, x, xy, yz, 3y² − 1, xz, x² − z² (orthonormal on the sphere). kernels/environment.h holds the
# same constants; the clamped-cosine convolution weights Â_l are π, 2π/3, π/4 (Ramamoorthi &
# Hanrahan 2001, "An Efficient Representation for Irradiance Environment Maps", eq. 8).
SH_C0 = 0.5 / math.sqrt(math.pi)                 # 0.282095
SH_C1 = math.sqrt(3.0 / (4.0 * math.pi))         # 0.488603
SH_C2 = math.sqrt(15.0 / (4.0 * math.pi))        # 1.092548 (xy, yz, xz)
SH_C3 = math.sqrt(5.0 / (16.0 * math.pi))        # 0.315392 (3y² − 1)
SH_C4 = math.sqrt(15.0 / (16.0 * math.pi))       # 0.546274 (x² − z²)
SH_BAND = (0, 1, 1, 1, 2, 2, 2, 2, 2)
SH_CONVOLUTION = (math.pi, 2.0 * math.pi / 3.0, math.pi / 4.0)

# The specular lobes the sampled rung importance-samples, by built-in lobe id: the distribution
# kernels/environment.h draws from (GGX or Beckmann normals, the Phong lobe about the mirror
# direction, the Blinn–Phong normal distribution). A lobe not listed (a user's) has none: the rung
# then draws from the cosine and the map only.
LOBE_SAMPLING = {"ggx_correlated": "ggx", "walter_ggx": "ggx", "ggx_smith_schlick": "ggx",
                 "cook_torrance": "beckmann", "phong": "phong", "phong_normalized": "phong",
                 "blinn_phong": "blinn_phong", "blinn_phong_normalized": "blinn_phong"}


@dataclass(frozen=True)
class EnvironmentSpec:
    """A scene's [environment] table, checked (scenes/README.md): exactly one of `map` (a file)
    and `uniform` (a constant RGB sky)."""
    map: Path | None = None
    uniform: tuple[float, float, float] | None = None
    intensity: float = 1.0
    rotation: float = 0.0          # degrees about +y
    diffuse: str = DEFAULT_DIFFUSE
    specular: str = DEFAULT_SPECULAR
    samples: int = DEFAULT_SAMPLES

    @property
    def sampled(self) -> bool:
        """Some rung samples (the kernel then takes the sample count at run time)."""
        return self.diffuse == "sampled" or self.specular == "sampled"

    def describe(self) -> str:
        sky = f"map {self.map.name}" if self.map is not None else "uniform " + ", ".join(f"{c:g}" for c in self.uniform)
        n = f", {self.samples} samples" if self.sampled else ""
        return (f"{sky} × {self.intensity:g}, rotation {self.rotation:g}°; diffuse {self.diffuse}, "
                f"specular {self.specular}{n}")


def check_rungs(diffuse: str, specular: str, samples: int) -> str | None:
    """Why a rung combination is refused (None when it is fine)."""
    if diffuse not in DIFFUSE_RUNGS:
        return f"diffuse must be one of {', '.join(DIFFUSE_RUNGS)}"
    if specular not in SPECULAR_RUNGS:
        return f"specular must be one of {', '.join(SPECULAR_RUNGS)}"
    if not 1 <= samples <= MAX_SAMPLES:
        return f"samples must be within [1, {MAX_SAMPLES}]"
    return None


def with_overrides(spec: EnvironmentSpec | None, diffuse: str | None = None, specular: str | None = None,
                   samples: int | None = None) -> EnvironmentSpec | None:
    """The scene's [environment] with the command line's --environment-diffuse, --environment-specular and
    --environment-samples (None keeps the scene's); refused in one line naming the flag."""
    given = [(flag, value) for flag, value in (("--environment-diffuse", diffuse), ("--environment-specular", specular),
                                                ("--environment-samples", samples)) if value is not None]
    if not given:
        return spec
    if spec is None:
        raise ClshadeError(f"{given[0][0]}: the scene has no [environment] table to change (scenes/README.md)")
    if specular is not None and check_rungs(DEFAULT_DIFFUSE, specular, 1):
        raise ClshadeError(f"--environment-specular {specular}: {check_rungs(DEFAULT_DIFFUSE, specular, 1)}")
    if diffuse is not None and check_rungs(diffuse, "none", 1):
        raise ClshadeError(f"--environment-diffuse {diffuse}: {check_rungs(diffuse, 'none', 1)}")
    if samples is not None and check_rungs(DEFAULT_DIFFUSE, "none", samples):
        raise ClshadeError(f"--environment-samples {samples}: {check_rungs(DEFAULT_DIFFUSE, 'none', samples)}")
    return replace(spec, diffuse=diffuse or spec.diffuse, specular=specular or spec.specular,
                   samples=spec.samples if samples is None else samples)


# ---------------------------------------------------------------- geometry of the map


def row_cosines(height: int) -> np.ndarray:
    """(H + 1,) cos θ at the row edges, top (1) to bottom (−1), float64."""
    c = np.cos(np.pi * np.arange(height + 1) / height)
    c[0], c[-1] = 1.0, -1.0
    return c


def texel_solid_angles(width: int, height: int) -> np.ndarray:
    """(H,) the solid angle of a texel of each row: (2π/W)·(cos θ_top − cos θ_bottom); the
    W·H texels cover the sphere, 4π."""
    c = row_cosines(height)
    return (2.0 * np.pi / width) * (c[:-1] - c[1:])


def rotation_matrix(degrees: float) -> np.ndarray:
    """R_y(θ): the right-handed rotation by θ about +y (x → −z at 90°)."""
    t = math.radians(degrees)
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def map_directions(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unit directions in the map's frame at map coordinates (u, v) (module docstring)."""
    phi, theta = 2.0 * np.pi * np.asarray(u, np.float64), np.pi * np.asarray(v, np.float64)
    s = np.sin(theta)
    return np.stack([s * np.sin(phi), np.cos(theta), -s * np.cos(phi)], axis=-1)


def map_coordinates(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) of unit directions in the map's frame: u in [0, 1), v in [0, 1]."""
    d = np.asarray(d, np.float64)
    u = np.arctan2(d[..., 0], -d[..., 2]) / (2.0 * np.pi)
    u = np.where(u < 0.0, u + 1.0, u)
    return np.where(u >= 1.0, 0.0, u), np.arccos(np.clip(d[..., 1], -1.0, 1.0)) / np.pi


# ---------------------------------------------------------------- spherical harmonics


def sh9_basis(d: np.ndarray) -> np.ndarray:
    """(..., 9) the basis at unit directions d (..., 3)."""
    x, y, z = (np.asarray(d, np.float64)[..., k] for k in range(3))
    return np.stack([np.full_like(x, SH_C0), SH_C1 * y, SH_C1 * z, SH_C1 * x, SH_C2 * x * y, SH_C2 * y * z,
                     SH_C3 * (3.0 * y * y - 1.0), SH_C2 * x * z, SH_C4 * (x * x - z * z)], axis=-1)


def _sh9_texel_integrals(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(rows (9, H), columns (9, W)): ∫ Y_k over texel (i, j) = rows[k, i] · columns[k, j], in closed
    form. With μ = cos θ, s = sin θ: x = s sin φ, y = μ, z = −s cos φ and dω = dφ dμ."""
    c = row_cosines(height)
    top, bottom = c[:-1], c[1:]
    s = lambda m: np.sqrt(np.maximum(1.0 - m * m, 0.0))  # noqa: E731
    a0 = top - bottom                                                     # ∫ dμ
    a_s = 0.5 * ((top * s(top) + np.arcsin(top)) - (bottom * s(bottom) + np.arcsin(bottom)))  # ∫ s dμ
    a_mu = 0.5 * (top ** 2 - bottom ** 2)                                 # ∫ μ dμ
    a_mus = (s(bottom) ** 3 - s(top) ** 3) / 3.0                          # ∫ μ s dμ
    a_mu2 = (top ** 3 - bottom ** 3) / 3.0                                # ∫ μ² dμ
    a_s2 = a0 - a_mu2                                                     # ∫ s² dμ
    phi = 2.0 * np.pi * np.arange(width + 1) / width
    p0, p1 = phi[:-1], phi[1:]
    b0 = p1 - p0                                                          # ∫ dφ
    b_sin = np.cos(p0) - np.cos(p1)                                       # ∫ sin φ
    b_cos = np.sin(p1) - np.sin(p0)                                       # ∫ cos φ
    b_sc = 0.5 * (np.sin(p1) ** 2 - np.sin(p0) ** 2)                      # ∫ sin φ cos φ
    b_s2c2 = -0.5 * (np.sin(2.0 * p1) - np.sin(2.0 * p0))                 # ∫ sin² φ − cos² φ
    rows = np.stack([SH_C0 * a0, SH_C1 * a_mu, -SH_C1 * a_s, SH_C1 * a_s, SH_C2 * a_mus, -SH_C2 * a_mus,
                     SH_C3 * (3.0 * a_mu2 - a0), -SH_C2 * a_s2, SH_C4 * a_s2])
    columns = np.stack([b0, b0, b_cos, b_sin, b_sin, b_cos, b0, b_sc, b_s2c2])
    return rows, columns


def sh9_project(radiance: np.ndarray) -> np.ndarray:
    """(9, C) coefficients L_k = ∫ L Y_k dω of a piecewise-constant (H, W, C) map, exact."""
    radiance = np.asarray(radiance, np.float64)
    rows, columns = _sh9_texel_integrals(radiance.shape[1], radiance.shape[0])
    return np.einsum("ijc,ki,kj->kc", radiance, rows, columns)


def sh9_irradiance(coefficients: np.ndarray, n: np.ndarray) -> np.ndarray:
    """(..., C) irradiance E(n) = Σ Â_l L_k Y_k(n) at unit normals n (..., 3) in the map's frame."""
    weights = np.array([SH_CONVOLUTION[b] for b in SH_BAND])
    return sh9_basis(n) @ (weights[:, None] * np.asarray(coefficients, np.float64))


# ---------------------------------------------------------------- reading a map


def _stamp(path: Path) -> tuple[int, int] | None:
    """A map file's modification time and size (None where it cannot be read: read_map says why)."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_mtime_ns, st.st_size


def read_map(path: Path, scene_file: Path | str | None = None, key: str = "environment.map") -> np.ndarray:
    """The (H, W, 3) float32 linear radiance of an equirectangular map (read-only; cached by path,
    modification time and size). Refused in one line naming the scene file, the key, the map and the
    reason: not a regular file, unreadable, over the texture budget, not 2:1, NaN/Inf texels, or
    texels below −NEGATIVE_TEXEL_TOLERANCE × the mean luminance (those above read as 0)."""
    def refuse(message: str) -> ClshadeError:
        return located(message, scene_file, key, str(path), has_value=True)

    try:
        budget.regular_file(path, "environment map")
    except ClshadeError as exc:
        raise refuse(str(exc).removeprefix(f"{path}: ")) from None
    return _read_map(Path(path), _stamp(path), str(scene_file), key)


@lru_cache(maxsize=8)
def _read_map(path: Path, stamp: tuple[int, int], scene_file: str, key: str) -> np.ndarray:
    def refuse(message: str) -> ClshadeError:
        return located(message, scene_file, key, str(path), has_value=True)

    def two_to_one(width: int, height: int, channels: int) -> None:
        if width != 2 * height:
            raise refuse(f"an equirectangular map is 2:1, this one is {width}x{height}")

    with stderr_captured(f"OpenImageIO reading {path.name}"):
        pixels, _ = _read_pixels(path, refuse, "environment map", two_to_one)
    rgb = np.array(_to_rgb(pixels), np.float32)
    bad = ~np.isfinite(rgb)
    if bad.any():
        i, j, _ = np.argwhere(bad)[0]
        raise refuse(f"{int(bad.any(axis=2).sum())} NaN or Inf texel(s), the first at row {i}, column {j}")
    mean = float(np.mean(rgb @ np.array(LUMINANCE, np.float32)))
    low = rgb < -NEGATIVE_TEXEL_TOLERANCE * max(mean, 0.0)
    if low.any():
        i, j, _ = np.argwhere(low)[0]
        raise refuse(f"{int(low.any(axis=2).sum())} negative texel(s), the first at row {i}, column {j}: "
                     f"{float(rgb[i, j].min()):g} (radiance is ≥ 0)")
    np.maximum(rgb, 0.0, out=rgb)
    rgb.setflags(write=False)
    return rgb


def sky_radiance(spec: EnvironmentSpec, scene_file: Path | str | None = None) -> np.ndarray:
    """The (H, W, 3) float32 radiance the kernels and the oracle see: the map (or a 2×1 map of the
    uniform colour) times the intensity."""
    if spec.map is not None:
        base = read_map(spec.map, scene_file)
    else:
        base = np.broadcast_to(np.asarray(spec.uniform, np.float32), (1, 2, 3))
    return (base * np.float32(spec.intensity)).astype(np.float32)


# ---------------------------------------------------------------- what the kernels read


@dataclass(frozen=True)
class Environment:
    """A sky prepared for the kernels: the radiance (float32, × intensity), its mean, its SH9
    coefficients, and the luminance distribution of the sampled rung (texel pdf per steradian and
    the float32 CDFs it is drawn with)."""
    radiance: np.ndarray         # (H, W, 3) float32
    rotation: float              # degrees about +y
    mean: np.ndarray             # (3,) float64: ∫ L dω / 4π
    sh9: np.ndarray              # (9, 3) float64: L_k = ∫ L Y_k dω
    pdf: np.ndarray              # (H, W) float64: the density of a direction the map strategy draws, per sr
    marginal: np.ndarray         # (H + 1,) float32 CDF over rows
    conditional: np.ndarray      # (H, W + 1) float32 CDF over the columns of each row
    constant: bool               # every texel the same: no map strategy (the BRDF's is then better)

    @property
    def size(self) -> tuple[int, int]:
        return int(self.radiance.shape[1]), int(self.radiance.shape[0])

    def params(self) -> np.ndarray:
        """The kernels' env_params (kernels/environment.h): (cos θ, sin θ, W, H), the mean
        radiance, then the 9 SH coefficients times Â_l / π (the diffuse radiance of a white
        Lambertian surface), float4 rows."""
        t = math.radians(self.rotation)
        rows = np.zeros((11, 4), np.float64)
        rows[0] = (math.cos(t), math.sin(t), *self.size)
        rows[1, :3] = self.mean
        weights = np.array([SH_CONVOLUTION[b] for b in SH_BAND]) / math.pi
        rows[2:, :3] = weights[:, None] * self.sh9
        return rows.astype(np.float32)

    def texels(self) -> np.ndarray:
        """(H·W, 4) float32: radiance RGB and the map strategy's pdf."""
        return np.concatenate([self.radiance.reshape(-1, 3), self.pdf.reshape(-1, 1)], axis=1).astype(np.float32)

    def cdf(self) -> np.ndarray:
        """The marginal CDF (H + 1) followed by each row's conditional CDF (W + 1), float32."""
        return np.concatenate([self.marginal, self.conditional.reshape(-1)]).astype(np.float32)


def _cdf(weights: np.ndarray) -> np.ndarray:
    """Float32 CDFs along the last axis (a leading 0, a last 1); a row of zero weight is uniform."""
    total = weights.sum(axis=-1, keepdims=True)
    even = np.ones_like(weights) / weights.shape[-1]
    p = np.divide(weights, total, out=even, where=total > 0)
    c = np.concatenate([np.zeros(p.shape[:-1] + (1,)), np.cumsum(p, axis=-1)], axis=-1)
    c = np.minimum(c / c[..., -1:], 1.0).astype(np.float32)
    c[..., -1] = 1.0
    return np.maximum.accumulate(c, axis=-1)


def prepare(radiance: np.ndarray, rotation: float = 0.0) -> Environment:
    """The Environment of an (H, W, 3) radiance map. The map strategy draws texel (i, j) with
    probability ∝ luminance × solid angle (uniform by solid angle for an all-black map), then a
    direction uniform in the texel's solid angle; its pdf is computed from the float32 CDFs the
    kernel draws with, so that the density the kernel weights by is the one it samples."""
    radiance = np.asarray(radiance, np.float32)
    h, w = radiance.shape[:2]
    omega = texel_solid_angles(w, h)
    lum = radiance.astype(np.float64) @ np.array(LUMINANCE)
    weights = lum * omega[:, None]
    if not weights.sum() > 0.0:
        weights = np.broadcast_to(omega[:, None], (h, w)).copy()
    marginal = _cdf(weights.sum(axis=1))
    conditional = _cdf(weights)
    p_row = np.diff(marginal.astype(np.float64))
    p_col = np.diff(conditional.astype(np.float64), axis=1)
    pdf = p_row[:, None] * p_col / omega[:, None]
    mean = (radiance.astype(np.float64) * omega[:, None, None]).sum(axis=(0, 1)) / (4.0 * np.pi)
    constant = bool(np.all(radiance == radiance[:1, :1]))
    return Environment(radiance, rotation, mean, sh9_project(radiance), pdf, marginal, conditional, constant)


def data_key(spec: EnvironmentSpec) -> tuple:
    """What a sky's prepared data depends on: the map (and its file's modification time and size), the
    uniform colour and the intensity. Not the rotation: the kernels apply it (env_to_map)."""
    return spec.map, spec.uniform, spec.intensity, _stamp(spec.map) if spec.map is not None else None


def prepare_spec(spec: EnvironmentSpec, scene_file: Path | str | None = None) -> Environment:
    """The Environment of a scene's [environment] (cached by data_key), turned by its rotation: a
    turned sky shares the prepared data, so the live viewer's rotation slider prepares nothing."""
    env = _prepare_cached(*data_key(spec), str(scene_file))
    return env if env.rotation == spec.rotation else replace(env, rotation=spec.rotation)


@lru_cache(maxsize=4)
def _prepare_cached(map_path, uniform, intensity, stamp, scene_file) -> Environment:
    spec = EnvironmentSpec(map=map_path, uniform=uniform, intensity=intensity)
    return prepare(sky_radiance(spec, scene_file))

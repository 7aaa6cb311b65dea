"""The split-sum rungs' tables (Karis 2013, "Real Shading in Unreal Engine 4"; Filament's `cmgen`):
a prefiltered radiance mip chain per specular lobe family and a DFG table per specular lobe.

Split sum: ∫ f·(n·l)·L dω ≈ [∫ w(l; r)·L dω / ∫ w dω] · ∫ f·(n·l) dω, the first factor taken with
n = v = r (r the mirror direction of v), so that it depends on r and the lobe's width only.

The lookup coordinate t in [0, 1] of every family: the perceptual roughness r (α = r²) for the
microfacet families (GGX, Beckmann); for Phong and Blinn–Phong the exponent e maps to
t = (2/(e + 2))^¼, the roughness of the Beckmann lobe of the same width (α² = 2/(e + 2), Walter et al.
2007, §5.2), so e = ∞ (a mirror) is t = 0 and e = 0 is t = 1. Level k of LEVELS is prefiltered at
t_k = k/(LEVELS − 1): level 0 is the map itself (a mirror), the kernel interpolates linearly in t.

Prefilter weights, with c = r·l and n = v = r: GGX and Beckmann D(r·h)·c (the distribution of the
normals the mirror l was drawn from, weighted by n·l as Karis does), Blinn–Phong (r·h)ᵉ·c, Phong cᵉ·c;
h = (l + r)/|l + r|, so r·h = √((1 + c)/2). The weights are normalised by their own discrete sum, so
a constant sky stays exactly constant (the furnace).

DFG: for each specular lobe, over (n·v, t), A = ∫ (f/F)·(1 − (1 − v·h)⁵)·(n·l) dω and
B = ∫ (f/F)·(1 − v·h)⁵·(n·l) dω, so that the Schlick lobe's albedo is F0·A + f90·B; the empirical
lobes (no Fresnel) store their normalised lobe's albedo in A (B = 0), the kernel multiplies back
the normalisation. Energy compensation (Fdez-Agüera 2019; Filament): × 1 + F0·(1/E − 1), E = A + B.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from clshade.render.environment import LOBE_SAMPLING, texel_solid_angles

#: Mip levels (level 0: the map): t steps of 0.2, so that the chain's linear interpolation in t
#: stays within a fifth of the roughness range of a prefiltered level.
LEVELS = 6
#: The width of level 1 (and each next level half of it, down to LOWEST_WIDTH), never above the map's:
#: the map is box-filtered (by solid angle) to a level's size and then convolved at that size.
#: Level 1's lobe (t = 0.2, α = 0.04) spans ~4.6° in l, 3 texels of 1.4°: downsampling first keeps
#: the error small there and makes a 1024×512 map's chain take ~0.2 s instead of ~20 s.
FIRST_WIDTH = 256
LOWEST_WIDTH = 32
#: Nodes of the DFG table on each axis (n·v and t, both in [0, 1], node i at i/(DFG_SIZE − 1)).
DFG_SIZE = 32
#: Gauss–Legendre nodes over the distribution's CDF and midpoint nodes over the half azimuth (the
#: integrand is symmetric about the plane of n and v) of the DFG integral: within 3e-3 of a graded
#: float64 quadrature (tests/render/test_prefilter.py); the largest gap, 2.3e-3, at grazing n·v where
#: the horizon cuts the lobe (a kink the rule converges on slowly: 96 nodes still leave 6e-4).
DFG_RADIAL = 48
DFG_AZIMUTH = 24
#: The smallest α (kernels/brdf.h MIN_ALPHA) and n·v (MIN_N_DOT_V) the kernels use: the table's
#: t = 0 and n·v = 0 nodes are integrated there.
MIN_ALPHA = 1e-4
MIN_N_DOT_V = 1e-4
#: Phong/Blinn–Phong exponent at t = 0 (a mirror): large enough that the lobe is a delta at float32.
MAX_EXPONENT = 1e6

#: The lobe family of each specular lobe with one (environment.LOBE_SAMPLING's distributions).
FAMILIES = ("ggx", "beckmann", "phong", "blinn_phong")
#: Lobes whose f carries Schlick's (or the exact) Fresnel: DFG's scale and bias apply.
FRESNEL_LOBES = frozenset({"ggx_correlated", "walter_ggx", "ggx_smith_schlick", "cook_torrance"})
#: The empirical lobes' normalisation: f = NORMALISATION(e) × the normalised lobe (1: already normalised).
NORMALISED = {"phong": "phong_normalized", "blinn_phong": "blinn_phong_normalized"}


def family(lobe_id: str | None) -> str | None:
    """The prefilter family of a built-in specular lobe (None: a user's lobe, or none)."""
    return LOBE_SAMPLING.get(lobe_id) if lobe_id is not None else None


def exponent(t: np.ndarray) -> np.ndarray:
    """The Phong/Blinn–Phong exponent at lookup coordinate t (module docstring): 2/t⁴ − 2."""
    t = np.asarray(t, np.float64)
    with np.errstate(divide="ignore"):
        return np.minimum(np.where(t > 0.0, 2.0 / np.maximum(t, 1e-300) ** 4 - 2.0, np.inf), MAX_EXPONENT)


def level_t(levels: int = LEVELS) -> np.ndarray:
    """t of each level."""
    return np.arange(levels) / (levels - 1)


# ---------------------------------------------------------------- the prefiltered mip chain


def _weight(fam: str, c: np.ndarray, t: float) -> np.ndarray:
    """The prefilter weight of a direction at cosine c from r (module docstring), unnormalised. `c` is
    overwritten (a level's c is tens of MB: the GGX weight is formed in place, in the same order of
    operations, so that a cold call pays for two arrays' pages instead of six)."""
    c = np.clip(c, -1.0, 1.0, out=c)
    lit = np.maximum(c, 0.0)
    if fam == "ggx":
        a2 = max(t * t, MIN_ALPHA) ** 2
        d = np.add(1.0, c, out=c)
        d *= 0.5                           # (r·h)²
        d *= a2 - 1.0
        d += 1.0
        np.square(d, out=d)
        np.divide(a2, d, out=d)
        d *= lit
        return d
    nh2 = 0.5 * (1.0 + c)                  # (r·h)²
    if fam == "beckmann":
        a2 = max(t * t, MIN_ALPHA) ** 2
        with np.errstate(divide="ignore", invalid="ignore", under="ignore"):
            d = np.where(nh2 > 0.0, np.exp(-(1.0 - nh2) / np.maximum(nh2 * a2, 1e-300)) / np.maximum(nh2, 1e-300) ** 2, 0.0)
        return d * lit
    e = float(exponent(t))
    with np.errstate(under="ignore"):
        if fam == "blinn_phong":
            return nh2 ** (0.5 * e) * lit
        return lit ** (e + 1.0)


def _downsample(radiance: np.ndarray, factor: int) -> np.ndarray:
    """The map averaged over factor × factor texel blocks, each texel weighted by its solid angle
    (the exact mean radiance of each block)."""
    h, w, _ = radiance.shape
    omega = texel_solid_angles(w, h)
    weighted = radiance.astype(np.float64) * omega[:, None, None]
    sums = weighted.reshape(h // factor, factor, w // factor, factor, 3).sum(axis=(1, 3))
    area = omega.reshape(h // factor, factor).sum(axis=1) * factor
    return sums / area[:, None, None]


def _level_factor(source: np.ndarray, k: int) -> int:
    """The box filter's factor from the previous level's source to level k ≥ 1: the largest one that
    keeps the level at least its target width (FIRST_WIDTH halved per level, at least LOWEST_WIDTH)
    and takes whole blocks of the source's rows and columns (so each level's width stays twice its
    height, hence even)."""
    h, w = source.shape[:2]
    target = min(w, max(FIRST_WIDTH >> (k - 1), LOWEST_WIDTH))
    factor = max(1, w // target)
    while w % factor or h % factor:
        factor -= 1
    return factor


def _convolve(source: np.ndarray, fam: str, t: float) -> np.ndarray:
    """(H, W, 3) the normalised prefilter of a (H, W, 3) map at every texel centre: the weight
    depends on the rows and the column difference only, so the sum over columns is a circular
    convolution, taken by FFT along each row. The weight is even in the column difference Δφ: it is
    evaluated for Δφ in [0, π] only and mirrored, half the work."""
    h, w, _ = source.shape
    theta = np.pi * (np.arange(h) + 0.5) / h
    omega = texel_solid_angles(w, h)
    dphi = 2.0 * np.pi * np.arange(w // 2 + 1) / w
    c = (np.cos(theta)[:, None, None] * np.cos(theta)[None, :, None]
         + np.sin(theta)[:, None, None] * np.sin(theta)[None, :, None] * np.cos(dphi)[None, None, :])
    half = _weight(fam, c, t)                                  # (out row, source row, Δφ in [0, π])
    half *= omega[None, :, None]
    k = np.concatenate([half, half[:, :, (w - 1) // 2:0:-1]], axis=2)   # any parity of W
    norm = k.sum(axis=(1, 2))
    kf = np.fft.rfft(k, axis=2)                                # real and even in Δφ: a convolution
    sf = np.fft.rfft(source, axis=1)                           # (source row, frequency, channel)
    out = np.fft.irfft(np.matmul(kf.transpose(2, 0, 1), sf.transpose(1, 0, 2)).transpose(1, 0, 2), n=w, axis=1)
    return np.maximum(out / norm[:, None, None], 0.0)


# ---------------------------------------------------------------- the chain on the device: RGB9E5

#: The device holds the chain's texels as RGB9E5 (the shared-exponent format of OpenGL's
#: EXT_texture_shared_exponent and Direct3D's R9G9B9E5_SHAREDEXP): three 9-bit mantissas and one 5-bit
#: exponent in 32 bits, value = m·2^(e − RGB9E5_BIAS − RGB9E5_MANTISSA). One gather per texel instead of
#: three: the split sum's trilinear lookup reads eight texels per pixel, and on a CPU its time is the
#: gathers' (docs/bench-notes.md). Rounding to nearest, each channel is within 1/511.5 (≈ 2⁻⁹) of the texel's
#: largest channel (≥ 2⁻¹⁶; below it, within 2⁻²⁴ absolute); Filament ships its prefiltered specular
#: in R11G11B10F (6 and 5 mantissa bits: within 2⁻⁷ and 2⁻⁶ of each channel).
RGB9E5_MANTISSA = 9
RGB9E5_BIAS = 15
RGB9E5_MAX_EXPONENT = 31
#: The largest value RGB9E5 holds: (2⁹ − 1)/2⁹ · 2^(31 − 15) = 65408.
RGB9E5_MAX = (1.0 - 2.0 ** -RGB9E5_MANTISSA) * 2.0 ** (RGB9E5_MAX_EXPONENT - RGB9E5_BIAS)


def rgb9e5_scale_exponent(rgb: np.ndarray) -> int:
    """The power of two s ≥ 0 such that rgb·2⁻ˢ fits RGB9E5 (a sun may be brighter than 65408)."""
    top = float(np.max(rgb, initial=0.0))
    return max(0, math.ceil(math.log2(top / RGB9E5_MAX))) if top > RGB9E5_MAX else 0


def pack_rgb9e5(rgb: np.ndarray, scale_exponent: int = 0) -> np.ndarray:
    """(N,) uint32 RGB9E5 words of (N, 3) non-negative finite values × 2^−scale_exponent, each channel
    rounded to the nearest step of the texel's shared exponent (EXT_texture_shared_exponent, §2.16.1:
    the exponent of the largest channel, one up where its mantissa rounds to 2⁹)."""
    x = np.clip(np.asarray(rgb, np.float64) * 2.0 ** -scale_exponent, 0.0, RGB9E5_MAX)
    top = x.max(axis=1)
    _, p = np.frexp(top)                                     # top = f·2^p, f in [0.5, 1): ⌊log2 top⌋ = p − 1
    e = np.maximum(p - 1, -RGB9E5_BIAS - 1) + 1 + RGB9E5_BIAS
    e = np.where(top > 0.0, e, 0)
    step = np.ldexp(1.0, e - RGB9E5_BIAS - RGB9E5_MANTISSA)
    e = np.where(np.floor(top / step + 0.5) >= 2 ** RGB9E5_MANTISSA, e + 1, e)
    step = np.ldexp(1.0, e - RGB9E5_BIAS - RGB9E5_MANTISSA)
    m = np.floor(x / step[:, None] + 0.5).astype(np.uint32)
    return m[:, 0] | (m[:, 1] << 9) | (m[:, 2] << 18) | (e.astype(np.uint32) << 27)


def unpack_rgb9e5(words: np.ndarray, scale_exponent: int = 0) -> np.ndarray:
    """(N, 3) float64 values of RGB9E5 words (the kernels' env_rgb9e5 in float64)."""
    w = np.asarray(words, np.uint32)
    step = np.ldexp(1.0, (w >> 27).astype(np.int64) - RGB9E5_BIAS - RGB9E5_MANTISSA + scale_exponent)
    return np.stack([(w >> s) & 0x1FF for s in (0, 9, 18)], axis=1) * step[:, None]


@dataclass(frozen=True)
class MipChain:
    """The prefiltered levels of one map and family, float32, level 0 the map itself."""
    family: str
    levels: tuple[np.ndarray, ...]         # (H_k, W_k, 3) each

    @property
    def scale_exponent(self) -> int:
        """The device texels' power-of-two scale (rgb9e5_scale_exponent of the whole chain)."""
        return max(rgb9e5_scale_exponent(lv) for lv in self.levels)

    def texels(self) -> np.ndarray:
        """Every level's texels as RGB9E5 words (pack_rgb9e5), level after level."""
        return pack_rgb9e5(np.concatenate([lv.reshape(-1, 3) for lv in self.levels]), self.scale_exponent)

    def table(self) -> np.ndarray:
        """(LEVELS, 4) float32 rows (first texel, W, H, exponent bias) of each level (kernels/environment.h):
        the bias turns a texel's shared exponent into its float32 scale's exponent field,
        127 − RGB9E5_BIAS − RGB9E5_MANTISSA + the scale exponent."""
        bias = 127 - RGB9E5_BIAS - RGB9E5_MANTISSA + self.scale_exponent
        rows, offset = [], 0
        for lv in self.levels:
            rows.append((offset, lv.shape[1], lv.shape[0], bias))
            offset += lv.shape[0] * lv.shape[1]
        return np.array(rows, np.float32)

    @property
    def nbytes(self) -> int:
        return int(self.texels().nbytes)


def mip_chain(radiance: np.ndarray, fam: str) -> MipChain:
    """The prefiltered mip chain of an (H, W, 3) radiance map for a lobe family (cached in memory by
    the map's content and the family)."""
    radiance = np.ascontiguousarray(radiance, np.float32)
    digest = hashlib.blake2b(radiance.tobytes(), digest_size=16).hexdigest()
    return _mip_chain(digest, radiance.shape, fam, LEVELS, FIRST_WIDTH, _Held(radiance))


class _Held:
    """The map, passed to the cached function without taking part in its key (the digest does)."""
    def __init__(self, value: np.ndarray) -> None:
        self.value = value

    def __hash__(self) -> int:
        return 0

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _Held)


@lru_cache(maxsize=8)
def _mip_chain(digest: str, shape: tuple, fam: str, levels: int, first_width: int, held: _Held) -> MipChain:
    if fam not in FAMILIES:
        raise ValueError(f"no prefilter for lobe family {fam!r}")
    radiance = held.value
    out = [radiance]
    source = radiance.astype(np.float64)       # each level's box filter starts from the previous one's
    for k, t in enumerate(level_t(levels)[1:], start=1):
        factor = _level_factor(source, k)
        if factor > 1:
            source = _downsample(source, factor)
        out.append(_convolve(source, fam, float(t)).astype(np.float32))
    return MipChain(fam, tuple(out))


# ---------------------------------------------------------------- the DFG table


def _lobe_over_fresnel(lobe: str, nl: np.ndarray, nv: np.ndarray, nh: np.ndarray, vh: np.ndarray,
                       alpha: np.ndarray) -> np.ndarray:
    """f/F · (n·l) divided by the density the sample was drawn with, for the microfacet lobes:
    f = D·V·F, the sample's density over l is D·(n·h)/(4 v·h), so the quotient is V·(n·l)·4(v·h)/(n·h)."""
    a2 = alpha * alpha
    if lobe == "ggx_correlated":
        v = 0.5 / (nl * np.sqrt(nv * nv * (1.0 - a2) + a2) + nv * np.sqrt(nl * nl * (1.0 - a2) + a2))
    elif lobe == "walter_ggx":
        v = 1.0 / ((nl + np.sqrt(a2 + (1.0 - a2) * nl * nl)) * (nv + np.sqrt(a2 + (1.0 - a2) * nv * nv)))
    elif lobe == "ggx_smith_schlick":
        k = 0.5 * alpha
        v = 0.25 / ((nl * (1.0 - k) + k) * (nv * (1.0 - k) + k))
    elif lobe == "cook_torrance":
        v = np.minimum(2.0 * nh * np.minimum(nv, nl), vh) / (4.0 * nl * nv * vh)
    else:
        raise ValueError(lobe)
    return v * nl * 4.0 * vh / nh


def dfg_table(lobe: str, size: int = DFG_SIZE) -> np.ndarray:
    """(size (n·v), size (t), 2) float32: (A, B) of the module docstring at the nodes; cached."""
    return _dfg_table(lobe, size)


def dfg_words(lobe: str, size: int = DFG_SIZE) -> np.ndarray:
    """(size², ) uint32: the device's DFG table, a node a word, A the low half-float and B the high one
    (kernels/environment.h, env_half_lo/hi): one gather a node instead of two. Half-floats keep 11
    significant bits (rounding within 2⁻¹¹ relative), far below the table's own rule error (DFG_RADIAL)."""
    halves = np.ascontiguousarray(dfg_table(lobe, size), np.float16).view(np.uint16).astype(np.uint32)
    return (halves[..., 0] | (halves[..., 1] << 16)).reshape(-1)


@lru_cache(maxsize=16)
def _dfg_table(lobe: str, size: int) -> np.ndarray:
    fam = family(lobe)
    if fam is None:
        raise ValueError(f"no DFG table for specular lobe {lobe!r}")
    mu = np.maximum(np.linspace(0.0, 1.0, size), MIN_N_DOT_V)[:, None, None, None]      # n·v
    t = np.linspace(0.0, 1.0, size)[None, :, None, None]
    x, wx = np.polynomial.legendre.leggauss(DFG_RADIAL)
    u = (0.5 * (x + 1.0))[None, None, :, None]
    wu = (0.5 * wx)[None, None, :, None]
    phi = (np.pi * (np.arange(DFG_AZIMUTH) + 0.5) / DFG_AZIMUTH)[None, None, None, :]
    wphi = 1.0 / DFG_AZIMUTH                   # the mean over φ (uniform, 1/2π, and symmetric)
    sv = np.sqrt(1.0 - mu * mu)
    v = (sv, 0.0, mu)                          # n = +z, v in the xz plane
    with np.errstate(divide="ignore", invalid="ignore", over="ignore", under="ignore"):
        if fam == "phong":
            # l about the mirror r = (−sv, 0, μ) with density (e + 1)/2π (r·l)ᵉ.
            e = exponent(t)
            c = u ** (1.0 / (e + 1.0))
            s = np.sqrt(np.maximum(1.0 - c * c, 0.0))
            rx, rz = -sv, mu                   # r and its frame (b1 = (rz, 0, −rx) ⟂ r in the xz plane)
            nl = c * rz + s * np.cos(phi) * (-rx)
            # the normalised lobe (e + 2)/2π cᵉ over the density (e + 1)/2π cᵉ
            q = np.where(nl > 0.0, (e + 2.0) / (e + 1.0) * nl, 0.0)
            a = (q * wu).sum(axis=(2, 3)) * wphi
            # e = 0 is Lambert's 1/π over the whole hemisphere (the kernels' 0⁰ = 1, brdf.h Fs_Phong),
            # not only where r·l > 0: its albedo is 1.
            a = np.where(e[..., 0, 0] == 0.0, 1.0, a)
            return np.stack([a, np.zeros_like(a)], axis=-1).astype(np.float32)
        alpha = np.maximum(t * t, MIN_ALPHA)
        if fam == "ggx":
            cos_h = 1.0 / np.sqrt(1.0 + alpha * alpha * u / (1.0 - u))
        elif fam == "beckmann":
            cos_h = 1.0 / np.sqrt(1.0 - alpha * alpha * np.log(1.0 - u))
        else:                                  # Blinn–Phong normals, density (e + 1)/2π (n·h)ᵉ
            e = exponent(t)
            cos_h = u ** (1.0 / (e + 1.0))
        sin_h = np.sqrt(np.maximum(1.0 - cos_h * cos_h, 0.0))
        h = (sin_h * np.cos(phi), sin_h * np.sin(phi), cos_h)
        vh = v[0] * h[0] + v[2] * h[2]
        nl = 2.0 * vh * h[2] - v[2]
        ok = (nl > 0.0) & (vh > 0.0)
        nl_, vh_ = np.where(ok, nl, 1.0), np.where(ok, vh, 1.0)
        if fam == "blinn_phong":
            # the normalised lobe (e + 8)/8π (n·h)ᵉ over the density (e + 1)/2π (n·h)ᵉ/(4 v·h)
            q = (e + 8.0) / (e + 1.0) * nl_ * vh_
        else:
            q = _lobe_over_fresnel(lobe, nl_, mu, cos_h, vh_, alpha)
        q = np.where(ok, q, 0.0)
        w5 = (1.0 - vh_) ** 5
    a = (q * (1.0 - w5) * wu).sum(axis=(2, 3)) * wphi
    b = (q * w5 * wu).sum(axis=(2, 3)) * wphi
    if fam == "blinn_phong":
        a, b = a + b, np.zeros_like(b)
    return np.stack([a, b], axis=-1).astype(np.float32)

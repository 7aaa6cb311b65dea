"""The split-sum rungs' tables (clshade/render/prefilter.py): level 0 is the map, every level of a constant
sky is that constant, a level of a sky with a bright source equals a float64 integral of the lobe's weight
written here from its definition, and the DFG table's scale and bias agree with the float64 reference's
directional albedo (clshade.verify.reference, an independent implementation of the lobes)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from clshade.render import prefilter as P
from clshade.render.environment import map_directions, texel_solid_angles
from clshade.verify.reference import albedo, compose

from sky_maps import sky_of


def hot_sky(d: np.ndarray) -> np.ndarray:
    """A soft sky with a bright source (40× the rest) up and towards +x."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    spot = 40.0 * np.exp(-((x - 0.6) ** 2 + (y - 0.75) ** 2 + (z + 0.2) ** 2) / 0.05)
    return np.stack([0.4 + 0.2 * y + spot, 0.45 + 0.2 * y + 0.8 * spot, 0.5 + 0.3 * y + 0.6 * spot], axis=-1)


@pytest.mark.parametrize("fam", P.FAMILIES)
def test_level_zero_is_the_map_and_a_constant_sky_stays_constant(fam):
    sky = sky_of(hot_sky, 64, 32).astype(np.float32)
    assert np.array_equal(P.mip_chain(sky, fam).levels[0], sky)
    flat = P.mip_chain(np.full((16, 32, 3), 0.7, np.float32), fam)
    for level in flat.levels:
        assert np.abs(level - 0.7).max() < 1e-6


def test_rgb9e5_keeps_exact_values_and_rounds_within_its_step():
    """pack_rgb9e5 against values the format holds exactly (0, 1, halvings, its largest value, a channel
    order that a swap would show) and, over random colours spanning 33 octaves, within 1/511.5 of the
    texel's largest channel (≥ 2⁻¹⁶) or 2⁻²⁴ absolute below it."""
    exact = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.5, 0.25, 0.125], [P.RGB9E5_MAX, 0.0, 0.0],
                      [3.0, 5.0, 7.0], [2.0 ** -20, 0.0, 2.0 ** -21]])
    assert np.array_equal(P.unpack_rgb9e5(P.pack_rgb9e5(exact)), exact)
    rng = np.random.default_rng(3)
    x = rng.random((20000, 3)) * 2.0 ** rng.uniform(-17.0, 16.0, (20000, 1))
    err = np.abs(P.unpack_rgb9e5(P.pack_rgb9e5(x)) - x).max(axis=1)
    top = x.max(axis=1)
    big = top >= 2.0 ** -16
    assert big.any() and (~big).any()
    assert (err[big] <= top[big] / 511.5).all()
    assert (err[~big] <= 2.0 ** -24).all()
    assert (err[big] / top[big]).max() > 1.8e-3          # rounding at the step, not finer


def test_a_chain_brighter_than_rgb9e5_is_scaled_by_a_power_of_two():
    """A sun of 2·10⁵ (above RGB9E5's 65408): the device texels are the levels × 2⁻ˢ, s the smallest that
    fits, the level table's bias carries s, and the texels read back within the format's step."""
    sky = sky_of(hot_sky, 64, 32).astype(np.float32)
    sky[3, 10] = [2.0e5, 1.0e5, 3.0]
    chain = P.mip_chain(sky, "ggx")
    assert chain.scale_exponent == 2                       # 2·10⁵/4 = 50000 ≤ 65408 < 2·10⁵/2
    assert P.mip_chain(sky_of(hot_sky, 64, 32).astype(np.float32), "ggx").scale_exponent == 0
    bias = chain.table()[:, 3]
    assert np.array_equal(bias, np.full(P.LEVELS, 127 - 15 - 9 + 2, np.float32))
    back = P.unpack_rgb9e5(chain.texels(), chain.scale_exponent)
    flat = np.concatenate([lv.reshape(-1, 3) for lv in chain.levels]).astype(np.float64)
    assert np.all(np.abs(back - flat).max(axis=1) <= flat.max(axis=1) / 511.5 + 2.0 ** -22)
    first = chain.table()[:, 0].astype(int)
    assert np.allclose(back[first[0] + 3 * 64 + 10], [2.0e5, 1.0e5, 0.0], rtol=2e-3, atol=2e5 / 511)


@pytest.mark.parametrize("lobe", ["ggx_correlated", "blinn_phong_normalized"])
def test_dfg_words_hold_the_scale_low_and_the_bias_high_as_halves(lobe):
    """The device's DFG table: a node a word, A in the low half-float and B in the high one, each within a
    half's rounding (2⁻¹¹ relative) of the float32 table."""
    table = P.dfg_table(lobe)
    words = P.dfg_words(lobe)
    assert words.dtype == np.uint32 and words.shape == (P.DFG_SIZE ** 2,)
    a = (words & 0xFFFF).astype(np.uint16).view(np.float16).astype(np.float64)
    b = (words >> 16).astype(np.uint16).view(np.float16).astype(np.float64)
    for got, want in ((a, table[..., 0].reshape(-1)), (b, table[..., 1].reshape(-1))):
        assert np.all(np.abs(got - want) <= 2.0 ** -11 * want + 2.0 ** -25)
    assert a.max() > 0.9 and (lobe == "blinn_phong_normalized" or b.max() > 0.5)


@pytest.mark.parametrize("width", [180, 360])
def test_any_two_to_one_map_gets_a_chain_of_whole_blocks(width):
    """Each level is a whole-block box filter of the previous one (widths that divide, twice the height):
    a 180×90 map once asked level 4 to take 2×2 blocks of 45 rows."""
    sky = sky_of(hot_sky, width, width // 2).astype(np.float32)
    chain = P.mip_chain(sky, "ggx")
    for before, level in zip(chain.levels, chain.levels[1:]):
        assert level.shape[1] == 2 * level.shape[0]
        assert before.shape[1] % level.shape[1] == 0
    assert np.isfinite(np.concatenate([lv.reshape(-1) for lv in chain.levels])).all()


@pytest.mark.parametrize("fam", P.FAMILIES)
@pytest.mark.parametrize("width", [8, 9])
def test_the_row_convolution_is_the_direct_sum(fam, width):
    """_convolve (a weight on Δφ in [0, π] mirrored, then an FFT along rows) against the sum over every
    texel pair, for an even and an odd width."""
    h = 5
    rng = np.random.default_rng(7)
    source = rng.uniform(0.1, 2.0, (h, width, 3))
    theta = np.pi * (np.arange(h) + 0.5) / h
    phi = 2 * np.pi * np.arange(width) / width
    d = np.stack(np.broadcast_arrays(np.sin(theta)[:, None] * np.sin(phi), np.cos(theta)[:, None],
                                     -np.sin(theta)[:, None] * np.cos(phi)), axis=-1).reshape(-1, 3)
    omega = np.repeat(texel_solid_angles(width, h), width)
    w = P._weight(fam, d @ d.T, 0.6) * omega[None, :]
    direct = (w @ source.reshape(-1, 3)) / w.sum(axis=1)[:, None]
    assert np.allclose(P._convolve(source, fam, 0.6).reshape(-1, 3), direct, rtol=1e-9, atol=1e-12)


def direct_prefilter(fam: str, t: float, r: np.ndarray, cells: int = 512) -> np.ndarray:
    """∫ w(l) L(l) dω / ∫ w dω at unit directions r (K, 3), by the midpoint rule on a cells × cells/2 grid
    of the sphere, with w from its definition: n = v = r, h = (l + r)/|l + r|, GGX and Beckmann
    D(h)·(r·l) (α = t²), Blinn–Phong (r·h)ᵉ·(r·l), Phong (r·l)ᵉ·(r·l) (e = 2/t⁴ − 2)."""
    theta = np.pi * (np.arange(cells // 2) + 0.5) / (cells // 2)
    phi = 2 * np.pi * (np.arange(cells) + 0.5) / cells
    d = np.stack(np.broadcast_arrays(np.sin(theta)[:, None] * np.sin(phi), np.cos(theta)[:, None],
                                     -np.sin(theta)[:, None] * np.cos(phi)), axis=-1).reshape(-1, 3)
    dw = (np.sin(theta)[:, None] * np.ones(cells)).reshape(-1) * (np.pi / (cells // 2)) * (2 * np.pi / cells)
    L = hot_sky(d)
    c = r @ d.T
    h = d[None] + r[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        nh = np.nan_to_num(np.einsum("kmi,ki->km", h, r) / np.linalg.norm(h, axis=2))   # l = −r: h undefined, c < 0
    a2, e = t ** 4, 2 / t ** 4 - 2
    if fam == "ggx":
        w = a2 / (math.pi * (nh * nh * (a2 - 1) + 1) ** 2) * np.maximum(c, 0)
    elif fam == "beckmann":
        with np.errstate(divide="ignore", under="ignore"):
            w = np.where(nh > 0, np.exp(-(1 - nh * nh) / np.maximum(nh * nh * a2, 1e-300))
                         / (math.pi * a2 * np.maximum(nh, 1e-300) ** 4), 0.0) * np.maximum(c, 0)
    elif fam == "blinn_phong":
        w = np.maximum(nh, 0) ** e * np.maximum(c, 0)
    else:
        w = np.maximum(c, 0) ** (e + 1)
    w = w * dw
    return (w @ L) / w.sum(axis=1)[:, None]


@pytest.mark.parametrize("fam, level", [("ggx", 2), ("ggx", 4), ("beckmann", 2), ("beckmann", 4), ("blinn_phong", 3),
                                        ("phong", 3)])
def test_a_level_is_the_lobes_weighted_mean_of_the_sky(fam, level):
    """Level k at its texel centres against the float64 integral of the sky under the lobe at t_k, near the
    bright source and away from it: within 3 % (the level is convolved at its own, coarser size, from a
    box-filtered map; a weight without its cosine or at the wrong t is off by more)."""
    chain = P.mip_chain(sky_of(hot_sky, 256, 128).astype(np.float32), fam)
    lv = chain.levels[level]
    h, w = lv.shape[:2]
    rows, cols = np.array([h // 4, h // 3, h // 2, 2 * h // 3]), np.array([w // 8, w // 3, w // 2, 5 * w // 6])
    r = map_directions((cols + 0.5) / w, (rows + 0.5) / h)
    truth = direct_prefilter(fam, float(P.level_t()[level]), r)
    got = lv[rows, cols].astype(np.float64)
    assert np.abs(got / truth - 1).max() < 0.03, (got, truth)


def reference_dfg(lobe: str, mu: float, t: float) -> tuple[float, float]:
    """(A, B) by the reference's graded Gauss–Legendre directional albedo of the lobe with F = 1 − (1 − v·h)⁵
    and F = (1 − v·h)⁵."""
    fn = compose._MICROFACET_FN[lobe]
    v = (math.sqrt(1 - mu * mu), 0.0, mu)

    def part(weight):
        def f(n, l, vv):
            g_nl, g_nv = l[:, 2], vv[:, 2]
            h = l + vv
            h = h / np.linalg.norm(h, axis=1, keepdims=True)
            vh = np.sum(vv * h, axis=1)
            return np.asarray(fn(g_nl, g_nv, h[:, 2], vh, max(t * t, 1e-4))).reshape(len(l), -1)[:, 0] * weight(vh)
        return float(albedo.directional_albedo(f, 16, v=v))
    return part(lambda vh: 1 - (1 - vh) ** 5), part(lambda vh: (1 - vh) ** 5)


# The table's rule against the reference: 2.3e-3 measured at grazing n·v (prefilter.DFG_RADIAL says why).
DFG_TOLERANCE = 3e-3


@pytest.mark.parametrize("lobe", ["ggx_correlated", "cook_torrance"])
def test_dfg_table_agrees_with_the_reference_albedo(lobe):
    """Scale A and bias B at nodes across n·v and t: within DFG_TOLERANCE of the reference (A + B is E(μ))."""
    table = P.dfg_table(lobe)
    n = P.DFG_SIZE - 1
    for i, j in [(n, 3), (n // 2, n // 4), (5, n // 2), (n // 3, n), (2, 8)]:
        a, b = reference_dfg(lobe, i / n, j / n)
        assert table[i, j] == pytest.approx((a, b), abs=DFG_TOLERANCE), (i, j, table[i, j], a, b)


def test_phong_table_is_the_normalised_lobes_albedo():
    """Phong's A at (n·v, t): the albedo of (e + 2)/2π (r·l)ᵉ, e = 2/t⁴ − 2, by the reference."""
    table = P.dfg_table("phong")
    n = P.DFG_SIZE - 1
    for i, j in [(n, n // 2), (n // 2, n // 3), (6, n)]:
        e = float(P.exponent(j / n))
        mu = i / n

        def f(nn, l, v):
            r = 2 * v[:, 2:3] * nn - v
            return (e + 2) / (2 * math.pi) * np.maximum(np.sum(r * l, axis=1), 0.0) ** e
        want = float(albedo.directional_albedo(f, 16, v=(math.sqrt(1 - mu * mu), 0.0, mu)))
        assert table[i, j, 0] == pytest.approx(want, abs=DFG_TOLERANCE) and table[i, j, 1] == 0.0

"""Closed-form / golden checks of the float64 BRDF reference (clshade.verify.reference)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

import clshade.verify.reference as R

ALBEDO_TOL = 1e-4  # required accuracy of the golden albedo values
Z = (0.0, 0.0, 1.0)


def _model(diffuse: str, specular: str, **kw):
    return lambda n, l, v: R.brdf(diffuse, specular, n, l, v, **kw)[..., 0]


def _wf(specular: str) -> str:
    return "kdks" if specular in R.EMPIRICAL_MODELS else "metallic"


def _random_dirs(rng: np.random.Generator, size: int, *, upper: bool) -> np.ndarray:
    d = rng.normal(size=(size, 3))
    if upper:
        d[:, 2] = np.abs(d[:, 2]) + 1e-3
    return d * rng.uniform(0.1, 10.0, size=(size, 1))  # not normalised on purpose


# ---------------------------------------------------------------- albedo


@pytest.mark.parametrize(
    "name, fn, expected",
    [
        ("ggx_correlated a=1 F=1", _model("none", "ggx_correlated", base_color=1.0, roughness=1.0, f0=1.0),
         1.0 - math.log(2.0)),
        ("burley r=0", _model("burley", "none", base_color=1.0, roughness=0.0), 1.0 - 1.0 / 42.0),
        ("lambert", _model("lambert", "none", base_color=1.0, roughness=0.5), 1.0),
        *[(f"phong_normalized n={s}",
           _model("none", "phong_normalized", base_color=1.0, roughness=0.0, workflow="kdks",
                  kd=0.0, ks=1.0, shininess=s), 1.0) for s in (0.0, 1.0, 10.0, 100.0, 1e4)],
        *[(f"oren_nayar sigma={s}", _model("oren_nayar", "none", base_color=1.0, roughness=s),
           1.0 - 0.5 * s * s / (s * s + 0.33)) for s in (0.1, 0.5, 1.0)],
    ],
)
def test_albedo_golden(name: str, fn, expected: float) -> None:
    value, err = R.directional_albedo(fn, return_error=True)
    assert abs(value - expected) < ALBEDO_TOL, name
    assert abs(value - expected) < 1e-9, name  # the quadrature is far better than required
    assert err < 1e-9


def test_albedo_burley_rough_exceeds_one() -> None:
    value = R.directional_albedo(_model("burley", "none", base_color=1.0, roughness=1.0))
    assert value > 1.0


def test_albedo_rgb_and_error_estimate() -> None:
    fn = lambda n, l, v: R.brdf("lambert", "none", n, l, v, base_color=[1.0, 0.5, 0.25], roughness=1.0)
    value, err = R.directional_albedo(fn, return_error=True)
    np.testing.assert_allclose(value, [1.0, 0.5, 0.25], atol=1e-12)
    assert err < 1e-12


@pytest.mark.parametrize("shininess", [1e2, 1e4, 1e6])
def test_albedo_narrow_off_axis_lobe(shininess: float) -> None:
    """A normalised cosine lobe about the mirror direction, v at ~57 deg: integral 1."""

    def fn(n, l, v):
        r = R.reflect(v, n)
        c = np.clip(np.sum(r * l, axis=-1), 0.0, 1.0)
        return (shininess + 1.0) / (2.0 * math.pi) * c**shininess / np.sum(n * l, axis=-1)

    value, err = R.directional_albedo(fn, v=(math.sin(1.0), 0.0, math.cos(1.0)), return_error=True)
    assert abs(value - 1.0) < 1e-6
    assert err < 1e-6


# ---------------------------------------------------------------- D


@pytest.mark.parametrize("alpha", [0.02, 0.1, 0.5, 1.0])
@pytest.mark.parametrize("d", [R.d_ggx, R.d_beckmann])
def test_ndf_normalisation(d, alpha: float) -> None:
    """int D(h) (n.h) dw_h = 1 (scipy adaptive quadrature in theta_h)."""
    g = lambda th: 2.0 * math.pi * float(d(math.cos(th), alpha)) * math.cos(th) * math.sin(th)
    pts = [p for p in (alpha, 3 * alpha, 10 * alpha) if p < math.pi / 2]
    val, _ = integrate.quad(g, 0.0, math.pi / 2, points=pts, limit=400, epsabs=1e-12, epsrel=1e-12)
    assert abs(val - 1.0) < 1e-7


def test_ndf_delta_at_alpha_zero() -> None:
    for d in (R.d_ggx, R.d_beckmann):
        assert d(1.0, 0.0) == np.inf
        assert d(0.999, 0.0) == 0.0
        assert d(0.0, 0.5) == 0.0 and d(-0.3, 0.5) == 0.0
    np.testing.assert_allclose(R.d_ggx(1.0, 0.3), 1.0 / (math.pi * 0.09), rtol=1e-15)
    np.testing.assert_allclose(R.d_beckmann(1.0, 0.3), 1.0 / (math.pi * 0.09), rtol=1e-15)


# ---------------------------------------------------------------- G


def test_masking_ranges_and_limits() -> None:
    rng = np.random.default_rng(1)
    c = np.concatenate([[0.0, 1e-300, 1e-9, 1.0], rng.uniform(0, 1, 500)])
    c2 = rng.permutation(c)
    for a in (0.0, 1e-4, 0.1, 0.5, 1.0):
        g1 = R.g1_smith_ggx(c, a)
        assert np.all((g1 >= 0) & (g1 <= 1 + 1e-15))
        assert R.g1_smith_ggx(1.0, a) == pytest.approx(1.0, abs=1e-15)
        # Walter's closed form equals 1 / (1 + Lambda) (Heitz 2014): independent forms agree
        with np.errstate(divide="ignore"):
            np.testing.assert_allclose(g1, 1.0 / (1.0 + R.lambda_ggx(c, a)), atol=1e-14)
        gc = R.g_smith_ggx_correlated(c, c2, a)
        gs = R.g_smith_ggx_separable(c, c2, a)
        gk = R.g_smith_schlick(c, c2, a)
        for g in (gc, gs, gk):
            assert np.all((g >= 0) & (g <= 1 + 1e-15)) and not np.any(np.isnan(g))
        assert np.all(gc >= gs - 1e-15)  # 1 + La + Lb <= (1 + La)(1 + Lb)
        assert R.g_smith_ggx_correlated(1.0, 1.0, a) == pytest.approx(1.0)
        assert R.g_smith_schlick(1.0, 1.0, a) == pytest.approx(1.0)
    assert R.g1_smith_ggx(-0.5, 0.5) == 0.0
    gct = R.g_cook_torrance(c, c2, rng.permutation(c), rng.uniform(0.01, 1, c.size))
    assert np.all((gct >= 0) & (gct <= 1))
    assert R.g_cook_torrance(1.0, 1.0, 1.0, 1.0) == 1.0


def test_correlated_lambda_formula() -> None:
    """alpha = 1, v = n: G2 = 1 / (1 + Lambda(l)) with Lambda = (1/cos - 1)/2."""
    c = np.linspace(0.05, 1.0, 20)
    np.testing.assert_allclose(R.g_smith_ggx_correlated(c, 1.0, 1.0), 2 * c / (1 + c), rtol=1e-14)


# ---------------------------------------------------------------- Fresnel


ETAS = [0.5, 0.9, 1.2, 1.33, 1.5, 2.5]


@pytest.mark.parametrize("eta", ETAS)
def test_fresnel_dielectric(eta: float) -> None:
    assert R.f_dielectric(1.0, eta) == pytest.approx(((eta - 1) / (eta + 1)) ** 2, abs=1e-15)
    assert R.f_dielectric(0.0, eta) == 1.0
    assert R.f_dielectric(1e-9, eta) == pytest.approx(1.0, abs=1e-7)
    c = np.linspace(0.0, 1.0, 201)
    f = R.f_dielectric(c, eta)
    assert np.all((f >= 0) & (f <= 1))
    # conductor with k = 0 is the dielectric
    np.testing.assert_allclose(R.f_conductor(c, [eta] * 3, [0.0] * 3), np.stack([f] * 3, -1), atol=1e-14)
    if eta > 1.0:  # Walter 2007 eq. 22 (Cook-Torrance g-form), independent of the s/p form
        g = np.sqrt(eta**2 - 1 + c**2)
        with np.errstate(divide="ignore", invalid="ignore"):
            w = 0.5 * (g - c) ** 2 / (g + c) ** 2 * (1 + ((c * (g + c) - 1) / (c * (g - c) + 1)) ** 2)
        np.testing.assert_allclose(f, w, atol=1e-14)
    else:  # total internal reflection beyond the critical angle
        crit = math.sqrt(1 - eta**2)
        assert np.all(f[c < crit - 1e-9] == 1.0)


def test_fresnel_conductor_normal_incidence() -> None:
    eta, k = np.array([0.2, 0.9, 1.1]), np.array([3.0, 2.0, 2.5])
    expected = ((eta - 1) ** 2 + k**2) / ((eta + 1) ** 2 + k**2)
    np.testing.assert_allclose(R.f_conductor(1.0, eta, k), expected, rtol=1e-14)
    c = np.linspace(0, 1, 101)
    f = R.f_conductor(c, eta, k)
    assert f.shape == (101, 3) and np.all((f >= 0) & (f <= 1))
    np.testing.assert_allclose(f[0], 1.0, atol=1e-15)


def test_fresnel_schlick() -> None:
    f0 = np.array([0.04, 0.5, 0.9])
    np.testing.assert_allclose(R.f_schlick(1.0, f0), f0)
    np.testing.assert_allclose(R.f_schlick(0.0, f0), 1.0)
    np.testing.assert_allclose(R.f_schlick(0.0, f0, 0.5), 0.5)
    assert R.f_schlick(np.full((4, 5), 0.3), f0).shape == (4, 5, 3)
    assert R.f_schlick(np.full((4, 5), 0.3), 0.04).shape == (4, 5)
    assert R.f_schlick(0.5, 0.04) == pytest.approx(0.04 + 0.96 * 0.5**5)


# ---------------------------------------------------------------- diffuse / lobes


def test_oren_nayar_matches_trig_free_rewrite() -> None:
    """Explicit-angle reference vs the usual projection (no-trig) rewrite."""
    rng = np.random.default_rng(2)
    n = rng.normal(size=(400, 3))
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    l, v = rng.normal(size=(2, 400, 3))
    l += n * (np.abs(np.sum(l * n, -1)) - np.sum(l * n, -1) + 0.01)[:, None]  # flip to upper side
    v += n * (np.abs(np.sum(v * n, -1)) - np.sum(v * n, -1) + 0.01)[:, None]
    lu = l / np.linalg.norm(l, axis=-1, keepdims=True)
    vu = v / np.linalg.norm(v, axis=-1, keepdims=True)
    ci, co = np.sum(n * lu, -1), np.sum(n * vu, -1)
    lt, vt = lu - ci[:, None] * n, vu - co[:, None] * n
    cos_dphi = np.sum(lt * vt, -1) / (np.linalg.norm(lt, axis=-1) * np.linalg.norm(vt, axis=-1))
    cmin, cmax = np.minimum(ci, co), np.maximum(ci, co)  # larger angle <-> smaller cosine
    sin_a, tan_b = np.sqrt(1 - cmin**2), np.sqrt(1 - cmax**2) / cmax
    for sigma in (0.0, 0.3, 1.0):
        s2 = sigma**2
        a, b = 1 - 0.5 * s2 / (s2 + 0.33), 0.45 * s2 / (s2 + 0.09)
        expected = (a + b * np.maximum(0, cos_dphi) * sin_a * tan_b) / math.pi
        np.testing.assert_allclose(R.fd_oren_nayar(n, l, v, sigma), expected, rtol=1e-10)
    # sigma = 0 is Lambert; a direction along n drops the B term
    assert R.fd_oren_nayar(Z, (1, 0, 1), (0, 1, 1), 0.0) == pytest.approx(1 / math.pi)
    assert R.fd_oren_nayar(Z, Z, (1, 0, 1), 1.0) == pytest.approx((1 - 0.5 / 1.33) / math.pi)


def test_burley_closed_form() -> None:
    assert R.fd_burley(1.0, 1.0, 1.0, 0.25) == pytest.approx(1 / math.pi)
    f90 = 0.5 + 2 * 0.5 * 0.8**2
    expected = (1 + (f90 - 1) * 0.7**5) * (1 + (f90 - 1) * 0.4**5) / math.pi
    assert R.fd_burley(0.3, 0.6, 0.8, 0.5) == pytest.approx(expected, rel=1e-15)
    assert R.fd_burley(-0.1, 0.6, 0.8, 0.5) == 0.0
    assert R.fd_lambert() == pytest.approx(1 / math.pi)


def test_empirical_lobes() -> None:
    assert R.phong(0.0, 0.0) == 1.0 and R.blinn_phong(0.0, 0.0) == 1.0  # 0**0 = 1
    assert R.phong(-0.5, 3.0) == 0.0
    assert R.phong(0.5, 3.0) == 0.125 and R.blinn_phong(0.5, 3.0) == 0.125
    assert R.phong_normalized(1.0, 10.0) == pytest.approx(12 / (2 * math.pi))
    assert R.blinn_phong_normalized(1.0, 10.0) == pytest.approx(18 / (8 * math.pi))
    assert R.phong(0.999, 1e6) == pytest.approx(0.0, abs=1e-300)
    np.testing.assert_allclose(R.reflect([1.0, 0.0, 1.0], Z), [-1.0, 0.0, 1.0])


# ---------------------------------------------------------------- composition


def test_brdf_composition() -> None:
    l, v = (0.3, 0.1, 1.0), (-0.2, 0.4, 1.0)
    g = R.geometry(Z, l, v)
    base = np.array([0.8, 0.5, 0.2])
    # metallic workflow with Schlick F0 = mix(0.04, base, metallic)
    m, r = 0.3, 0.6
    a = r * r
    f0 = 0.04 * (1 - m) + base * m
    spec = R.ggx_correlated(g.nl, g.nv, g.nh, g.vh, a, R.f_schlick(g.vh, f0))
    # the diffuse lobe is weighted by (1 − F(n·l))(1 − F(n·v)) (Shirley et al. 1997)
    kd = (1 - R.f_schlick(g.nl, f0)) * (1 - R.f_schlick(g.nv, f0))
    expected = kd * base * (1 - m) * R.fd_burley(g.nl, g.nv, g.vh, a) + spec
    got = R.brdf("burley", "ggx_correlated", Z, l, v, base_color=base, roughness=r, metallic=m)
    np.testing.assert_allclose(got, expected, rtol=1e-14)
    # explicit f0, dielectric and conductor Fresnel
    got = R.brdf("none", "walter_ggx", Z, l, v, base_color=base, roughness=r, f0=0.5)
    np.testing.assert_allclose(got, R.walter_ggx(g.nl, g.nv, g.nh, g.vh, a, R.f_schlick(g.vh, 0.5)) * np.ones(3))
    got = R.brdf("none", "cook_torrance", Z, l, v, base_color=base, roughness=r, fresnel="dielectric", ior=1.7)
    np.testing.assert_allclose(got, R.cook_torrance(g.nl, g.nv, g.nh, g.vh, a, R.f_dielectric(g.vh, 1.7)) * np.ones(3))
    eta, k = [0.2, 0.9, 1.1], [3.0, 2.0, 2.5]
    got = R.brdf("none", "ggx_smith_schlick", Z, l, v, base_color=base, roughness=r, fresnel="conductor", eta=eta, k=k)
    np.testing.assert_allclose(got, R.ggx_smith_schlick(g.nl, g.nv, g.nh, g.vh, a, R.f_conductor(g.vh, eta, k)))
    # metallic = 1 removes the diffuse
    assert np.all(R.brdf("lambert", "none", Z, l, v, base_color=base, roughness=r, metallic=1.0) == 0)
    # kdks: f = kd base fd + ks lobe (white)
    rv = float(np.dot(R.reflect(g.l, g.n), g.v))
    got = R.brdf("lambert", "phong", Z, l, v, base_color=base, roughness=r, workflow="kdks", kd=0.7, ks=0.3, shininess=20)
    np.testing.assert_allclose(got, 0.7 * base / math.pi + 0.3 * rv**20, rtol=1e-14)
    got = R.brdf("oren_nayar", "blinn_phong_normalized", Z, l, v, base_color=base, roughness=r, workflow="kdks",
                 kd=0.6, ks=0.4, shininess=50)
    exp = 0.6 * base * R.fd_oren_nayar(Z, l, v, r) + 0.4 * R.blinn_phong_normalized(g.nh, 50)
    np.testing.assert_allclose(got, exp, rtol=1e-14)
    # below the horizon -> 0
    assert np.all(R.brdf("lambert", "ggx_correlated", Z, (1, 0, -0.1), v, base_color=1, roughness=0.5) == 0)
    # alpha_floor is applied as max(r^2, floor)
    assert R.alpha_from_roughness(0.0, 1e-3) == 1e-3 and R.alpha_from_roughness(0.5, 1e-3) == 0.25
    f = R.brdf("none", "ggx_correlated", Z, Z, Z, base_color=1, roughness=0.0, alpha_floor=1e-3)
    np.testing.assert_allclose(f, 0.04 / (math.pi * 1e-6 * 4))


def test_brdf_shapes_and_errors() -> None:
    rng = np.random.default_rng(3)
    n, l, v = (_random_dirs(rng, 50, upper=True) for _ in range(3))
    out = R.brdf("burley", "walter_ggx", n, l, v, base_color=rng.random((50, 3)), roughness=rng.random(50),
                 metallic=rng.random(50))
    assert out.shape == (50, 3)
    out = R.brdf("lambert", "none", Z, l.reshape(5, 10, 3), Z, base_color=0.5, roughness=0.5)
    assert out.shape == (5, 10, 3)
    with pytest.raises(ValueError):
        R.brdf("lambert", "phong", Z, Z, Z, base_color=1, roughness=0.5)  # empirical lobe needs kdks
    with pytest.raises(ValueError):
        R.brdf("foo", "none", Z, Z, Z, base_color=1, roughness=0.5)
    with pytest.raises(ValueError):
        R.brdf("none", "ggx_correlated", Z, Z, Z, base_color=1, roughness=0.5, fresnel="conductor")


RECIPROCAL = [(d, s) for d in ("lambert", "burley", "oren_nayar", "none") for s in R.SPECULAR_MODELS
              if (d, s) != ("none", "none")]


@pytest.mark.parametrize("diffuse, specular", RECIPROCAL)
def test_reciprocity(diffuse: str, specular: str) -> None:
    rng = np.random.default_rng(4)
    n, l, v = (_random_dirs(rng, 300, upper=True) for _ in range(3))
    n[:, :2] *= 0.3  # keep most l, v above the tilted normals
    kw = dict(base_color=rng.random((300, 3)), roughness=rng.uniform(0.05, 1, 300), metallic=rng.random(300),
              workflow=_wf(specular), kd=0.5, ks=0.5, shininess=30.0)
    a = R.brdf(diffuse, specular, n, l, v, **kw)
    b = R.brdf(diffuse, specular, n, v, l, **kw)
    assert np.count_nonzero(a[:, 0]) > 100
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=0)


ZERO = (0.0, 0.0, 0.0)
DEGENERATE = [
    (ZERO, Z, Z), (Z, ZERO, Z), (Z, Z, ZERO),                 # zero-length vectors
    (Z, (1.0, 0.0, 1.0), (-1.0, 0.0, -1.0)),                  # l = -v
    (Z, (0.6, 0.0, 0.8), (-0.6, 0.0, 0.8)),                   # exact mirror
    (Z, Z, Z),                                                # l = v = n
    (Z, (1.0, 0.0, 1e-17), Z), (Z, (1.0, 0.0, 1e-17), (0.0, 1.0, 1e-17)),  # grazing
    (Z, (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0)),                   # both on the horizon, l = -v
    ((1e-200, 0.0, 1e-200), Z, Z),                            # tiny normal
]


@pytest.mark.parametrize("diffuse", R.DIFFUSE_MODELS)
@pytest.mark.parametrize("specular", R.SPECULAR_MODELS)
def test_no_nan(diffuse: str, specular: str) -> None:
    n, l, v = (np.array([g[i] for g in DEGENERATE]) for i in range(3))
    for roughness in (0.0, 1e-8, 1.0):
        for shininess in (0.0, 1e6):
            for ks in (0.0, 0.5):
                out = R.brdf(diffuse, specular, n, l, v, base_color=1.0, roughness=roughness,
                             workflow=_wf(specular), ks=ks, shininess=shininess)
                assert not np.any(np.isnan(out)), (roughness, shininess, ks)
                assert np.all(out >= 0)
                assert np.all(out[:4] == 0)  # zero vectors and l = -v give 0
                if roughness > 0:
                    assert np.all(np.isfinite(out))


def test_alpha_zero_is_delta() -> None:
    """alpha = 0: 0 off the mirror direction, +inf exactly on it; 0 * inf -> 0."""
    l, v = (0.6, 0.0, 0.8), (-0.6, 0.0, 0.8)
    for s in R.MICROFACET_MODELS:
        off = R.brdf("none", s, Z, l, (-0.6, 0.01, 0.8), base_color=1, roughness=0.0)
        on = R.brdf("none", s, Z, l, v, base_color=1, roughness=0.0)
        assert np.all(off == 0) and np.all(on == np.inf)
        zero = R.brdf("lambert", s, Z, l, v, base_color=1, roughness=0.0, workflow="kdks", kd=1.0, ks=0.0)
        np.testing.assert_allclose(zero, 1 / math.pi)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    vecs=st.lists(st.floats(-10, 10, allow_nan=False), min_size=9, max_size=9),
    roughness=st.floats(0, 1),
    metallic=st.floats(0, 1),
    shininess=st.floats(0, 1e6),
)
def test_property_finite_nonnegative(vecs, roughness, metallic, shininess) -> None:
    n, l, v = np.array(vecs).reshape(3, 3)
    for d in R.DIFFUSE_MODELS:
        for s in R.SPECULAR_MODELS:
            out = R.brdf(d, s, n, l, v, base_color=[0.9, 0.5, 0.1], roughness=roughness, metallic=metallic,
                         workflow=_wf(s), kd=0.5, ks=0.5, shininess=shininess, alpha_floor=1e-3)
            assert out.shape == (3,)
            assert np.all(np.isfinite(out)) and np.all(out >= 0)

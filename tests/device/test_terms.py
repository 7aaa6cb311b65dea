"""Every term function of kernels/brdf.h on its own (kernels/terms.cl), against its
float64 reference term in clshade.verify.reference: ≥ 1e5 random inputs each, max relative
error ≤ 1e-4 (metric and limits: clshade/verify/accuracy.py)."""
from __future__ import annotations

import numpy as np
import pytest

from clshade.verify import accuracy as A


def test_every_term_has_a_kernel_and_a_reference() -> None:
    declared = A.brdf_term_functions()
    assert declared, "no term functions found in kernels/brdf.h"
    source = A.term_source()
    for name in declared:
        assert f"TERM_KERNEL({name}," in source, f"{name}: no kernel in kernels/terms.cl"
        assert name in A.TERMS, f"{name}: no reference case in clshade/verify/accuracy.py"


@pytest.mark.parametrize("name", list(A.TERMS))
def test_term_accuracy(name: str, runtime) -> None:
    result = A.term_accuracy(name, runtime=runtime)
    print(f"\n{name:22s} max rel err {result.max_rel_err:.2e} over {result.samples} samples")
    assert result.samples >= A.SAMPLES
    assert result.ok, f"{name}: {result.max_rel_err:.3g} > {A.TARGET:g} at {result.worst_input}"


def test_conductor_nearly_lossless_below_one() -> None:
    """η < 1, k → 0 (the regime where the difference form of a² cancelled): 4.5e-4 before the fix."""
    c = np.linspace(0.0, 1.0, 4001)
    eta = np.tile([[0.126, 0.5, 0.9]], (len(c), 1))
    k = np.tile([[7e-4, 1e-4, 1e-3]], (len(c), 1))
    x = np.zeros((len(c), 4), np.float32)
    x[:, 0] = c
    y = np.zeros_like(x); y[:, :3] = eta
    z = np.zeros_like(x); z[:, :3] = k
    from clshade.verify import reference as R
    g = R.f_conductor(A.f32(c), A.f32(eta), A.f32(k))
    f = A.eval_term("F_Conductor", x, y, z)[:, :3]
    assert np.max(np.abs(f - g) / np.maximum(g, A.FLOOR_REL)) <= A.TARGET


def test_dielectric_from_the_dense_side_total_internal_reflection() -> None:
    """η < 1 (light inside the denser medium): F = 1 beyond the critical angle (c < √(1 − η²)), the exact
    reflectance inside it. The accuracy grid draws η ≥ 1 only, where total internal reflection cannot occur."""
    from clshade.verify import reference as R
    c = np.linspace(0.0, 1.0, 2001)
    eta = np.full_like(c, 1.0 / 1.5)
    x = np.zeros((len(c), 4), np.float32)
    x[:, 0], x[:, 1] = c, eta
    f = A.eval_term("F_Dielectric", x, np.zeros_like(x), np.zeros_like(x))[:, 0]
    g = R.f_dielectric(A.f32(c), A.f32(eta)[:, None])[:, 0]
    critical = np.sqrt(1.0 - A.f32(eta) ** 2)
    assert np.all(f[c < critical - 1e-3] == 1.0)
    away = np.abs(c - critical) > 1e-3      # the critical angle itself: √ of a cancelling difference
    assert np.max(np.abs(f - g)[away] / np.maximum(g[away], A.FLOOR_REL)) <= A.TARGET


def test_phong_lobe_at_or_behind_the_mirror_horizon_is_zero_to_the_n() -> None:
    """Where r·v ≤ 0 the lobe is 0ⁿ exactly: 0 for every n > 0, small exponents included
    (MIN_POW_BASEⁿ would be 1e-3 at n = 0.1), and 1 for n = 0; a positive r·v, its power."""
    rv = np.array([-0.5, 0.0, -1e-7, 0.0, -0.5, 0.3, 0.3], np.float32)
    n = np.array([0.1, 0.1, 0.5, 0.0, 0.0, 0.1, 0.0], np.float32)
    x = np.zeros((len(rv), 4), np.float32)
    x[:, 0], x[:, 1] = rv, n
    f = A.eval_term("Fs_Phong", x, np.zeros_like(x), np.zeros_like(x))[:, 0]
    np.testing.assert_array_equal(f[:5], [0.0, 0.0, 0.0, 1.0, 1.0])
    np.testing.assert_allclose(f[5:], np.float64(0.3) ** np.float64(n[5:]), rtol=1e-5)


def test_phong_power_below_flt_min_is_zero() -> None:
    """(r·v)ⁿ below 2⁻¹²⁶ is exactly 0 (kernels/brdf.h exp2_lanes, MIN_EXP2_ARG), never a
    clamped FLT_MIN or garbage exponent bits; just above it, the float64 value."""
    rv = np.array([0.5, 0.5, 0.25, 1e-3, 0.0, 0.5, 0.5], np.float32)
    n = np.array([127.0, 200.0, 1e4, 1e6, 3.0, 120.0, 125.5], np.float32)
    x = np.zeros((len(rv), 4), np.float32)
    x[:, 0], x[:, 1] = rv, n
    f = A.eval_term("Fs_Phong", x, np.zeros_like(x), np.zeros_like(x))[:, 0]
    assert np.all(f[:5] == 0.0)
    want = np.float64(rv[5:]) ** np.float64(n[5:])
    np.testing.assert_allclose(f[5:], want, rtol=1e-4)


@pytest.mark.parametrize("model_id", ["phong", "phong_normalized", "blinn_phong", "blinn_phong_normalized"])
def test_power_lobes_skip_only_what_underflows(model_id: str, runtime) -> None:
    """The Phong lobes skip their power where it underflows (kernels/brdf.h,
    power_underflows): every lobe value from 1 down to just above FLT_MIN is still
    computed, equal to float64's; where it is below 2⁻¹²⁶ the lobe is 0, as the power
    itself returns it. Through the model as it renders (eval.cl), n = v = +z, so r·v = n·l."""
    from clshade.device.evaluate import Samples, constant_materials, eval_brdf
    from clshade.models.registry import Registry
    from clshade.verify import reference as R
    resolve = Registry().resolve          # the built-in lobes
    rng = np.random.default_rng(7)
    k = 4000
    cos = rng.uniform(0.05, 0.95, k)                    # r·v (Phong) or n·h (Blinn–Phong)
    target = 10.0 ** rng.uniform(-45.0, 0.0, k)          # the power's value, FLT_MIN ≈ 1.2e-38 inside
    blinn = model_id.startswith("blinn")
    theta = 2.0 * np.arccos(cos) if blinn else np.arccos(cos)     # n·h = cos(θ/2) with v = n
    keep = theta < np.pi / 2 - 1e-3                      # the light above the horizon
    cos, target, theta = cos[keep], target[keep], theta[keep]
    shininess = (np.log(target) / np.log(cos)).astype(np.float32)
    k = len(cos)
    z = np.tile([0.0, 0.0, 1.0], (k, 1))
    l = np.stack([np.sin(theta), np.zeros(k), np.cos(theta)], axis=1).astype(np.float32)
    samples = Samples(z, l, z, np.zeros((k, 3)), np.full(k, 0.5), np.zeros(k),
                      constant_materials(k, kd=0.0, ks=1.0, shininess=shininess))
    f = eval_brdf(resolve(model_id), samples, runtime=runtime)[:, 0].astype(np.float64)
    l64 = l.astype(np.float64) / np.linalg.norm(l.astype(np.float64), axis=1, keepdims=True)
    if blinn:
        h = l64 + z
        x = (h / np.linalg.norm(h, axis=1, keepdims=True))[:, 2]
    else:
        x = 2.0 * l64[:, 2] * 1.0 - l64[:, 2]            # r·v = 2(n·l)(n·v) − l·v with v = n
    n64 = shininess.astype(np.float64)
    want = getattr(R, model_id)(x, n64)
    power = (R.blinn_phong if blinn else R.phong)(x, n64)          # without the normalisation factor
    normal = power > 2.0 * np.finfo(np.float32).tiny    # representable, with a margin for float32 inputs
    assert normal.sum() > k // 2 and (~normal).sum() > k // 10
    np.testing.assert_allclose(f[normal], want[normal], rtol=2e-3)
    assert np.all(f[power < 0.5 * np.finfo(np.float32).tiny] == 0.0)


def test_power_underflow_claims_only_exact_zeros(runtime) -> None:
    """power_underflows (kernels/brdf.h) claims a lane only where pow_runtime returns
    exactly 0, bit for bit, with x up to 1 − 1e-7 (where ln x ≤ x − 1 is tight) and
    n·log2 x from −160 to −110 around the underflow; and it does claim the lanes well
    below it where the bound is tight (x ≥ 0.9, n·log2 x ≤ −140)."""
    rng = np.random.default_rng(5)
    k = 1 << 20
    x = np.concatenate([1 - 10.0 ** rng.uniform(-7, 0, k // 2), 10.0 ** rng.uniform(-30, 0, k // 2)]).astype(np.float32)
    exponent = rng.uniform(-160.0, -110.0, k)
    n = (exponent / np.log2(x.astype(np.float64))).astype(np.float32)
    args = np.zeros((k, 4), np.float32)
    args[:, 0], args[:, 1] = x, n
    out = A.eval_term("power_underflows", args, np.zeros_like(args), np.zeros_like(args), runtime)
    power, claimed = out[:, 0], out[:, 1] != 0
    assert claimed.sum() > k // 10 and (power[~claimed] != 0).sum() > k // 10
    wrong = claimed & (power != 0)
    assert not wrong.any(), f"claimed but nonzero: x = {x[wrong][:3]}, n = {n[wrong][:3]}, power = {power[wrong][:3]}"
    true_exp = n.astype(np.float64) * np.log2(x.astype(np.float64))
    must = (x >= 0.9) & (true_exp <= -140.0)
    assert must.sum() > 1000 and claimed[must].all()

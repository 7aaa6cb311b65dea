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

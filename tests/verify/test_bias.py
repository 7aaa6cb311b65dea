"""Clamps that only clamp: the irradiance uses the true cosine, floors act only inside the lobes, and the one
floor-bias measurement (clshade.verify.bias) runs through the shade kernel."""
from __future__ import annotations

import math

import numpy as np
import pytest

from clshade.models.registry import Registry
from clshade.verify import bias

resolve = Registry().resolve          # the built-in lobes


@pytest.mark.parametrize("nl", [1e-5, 1e-7, 5e-5])
def test_lambert_plane_at_grazing_light_gets_true_cosine(runtime, nl):
    """A Lambert plane lit at n·l = 1e-5 renders f·(n·l)·E (not f·1e-4·E, the old floored irradiance)."""
    E = 2.5
    got, _ = bias.shade_flat(resolve("lambert"), bias.direction(nl, 0.0), bias.direction(1.0, 0.0),
                             np.array([0.5]), np.array([0.0]), irradiance=E, runtime=runtime)
    want = np.array(bias.BASE) / math.pi * nl * E
    assert np.allclose(got[0], want, rtol=1e-3, atol=0.0), (got[0], want)


def test_phong_never_exceeds_its_peak(runtime):
    """r·v of unit vectors rounds above 1 in float32; capped, the Phong lobe at the mirror is exactly k_s·1 + diffuse
    (no n·1e-6 excess at a large exponent)."""
    from clshade.render.scene import Material
    model = resolve("phong")
    material = Material("bias", base_color=(0.0, 0.0, 0.0), shininess=1e5, ks=1.0, kd=0.0)
    worst = 0.0
    for c in np.linspace(0.05, 1.0, 40):
        got, s = bias.shade_flat(model, bias.direction(c, 0.0), bias.direction(c, math.pi), np.array([0.5]),
                                 np.array([0.0]), base=(0.0, 0.0, 0.0), material=material, runtime=runtime)
        nl = float(s.l[0, 2].astype(np.float32))
        worst = max(worst, float(got[0, 0]) / nl)
    assert worst <= 1.0 + 1e-6, worst


def test_floor_bias_through_the_shade_path(runtime):
    rows = bias.as_dict(bias.floor_bias(runtime))
    assert set(rows) >= {"MIN_ALPHA", "MIN_N_DOT_L", "MIN_N_DOT_V", "MIN_HALF_LEN2", "MIN_N_DOT_H_BECKMANN",
                         "MIN_POW_BASE"}
    # The n·l floor no longer touches the irradiance: its bias is float32 rounding of the lobes only
    # (it was 2.35e-5 per unit irradiance with E·max(n·l, 1e-4)).
    assert rows["MIN_N_DOT_L"]["bias"] < 1e-6
    assert all(np.isfinite(r["bias"]) and r["cases"] > 0 for r in rows.values())

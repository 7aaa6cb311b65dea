"""The .brdf translator against a real GLSL compiler (clshade.verify.glsl_oracle): Mesa's GLSL 4.30 and
clshade's translation evaluate the project's own .brdf files and BRDF Explorer's collection (when
../shared/assets/brdf-explorer is there) at 10⁴ directions with the hard cases (grazing, L = V, the
mirror direction, L below the horizon), apart only by float32 conditioning, with points where GLSL leaves a built-in
undefined left out; skipped with the reason where moderngl or Mesa's EGL is absent."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from conftest import ROOT, SCENES

glsl_oracle = pytest.importorskip("clshade.verify.glsl_oracle")

LOBES = sorted((SCENES / "lobes").glob("*.brdf"))
COLLECTION = ROOT.parent / "shared" / "assets" / "brdf-explorer"
SHARED = sorted(COLLECTION.glob("*.brdf"))


@pytest.fixture(scope="module")
def mesa():
    why = glsl_oracle.unavailable()
    if why:
        pytest.skip(f"no GLSL oracle here: {why}")


@pytest.fixture(scope="module")
def points():
    return glsl_oracle.directions(10_000)


def test_hard_cases_are_in_the_directions(points):
    nl, nv = (np.sum(points.n * d, axis=1) for d in (points.l, points.v))
    assert (nl < 0).any() and (np.abs(nl - 1e-3) < 1e-5).any() and (np.abs(nv - 1e-3) < 1e-5).any()
    assert (np.abs(points.l - points.v).max(axis=1) == 0).any()
    mirror = 2 * nl[:, None] * points.n - points.l
    assert (np.abs(mirror - points.v).max(axis=1) < 1e-5).sum() >= len(points) // 20


SETS = ("defaults", "quarter", "three_quarters")      # glsl_oracle.parameter_sets, in order


@pytest.mark.parametrize("which", range(len(SETS)), ids=SETS)
@pytest.mark.parametrize("path", LOBES, ids=[p.stem for p in LOBES])
def test_translation_agrees_with_mesa(path, which, mesa, points, runtime):
    values = glsl_oracle.parameter_sets(path)[which]
    c = glsl_oracle.compare(path, values, points=points, runtime=runtime)
    assert c.finite_mismatch == 0 and c.both_finite == c.compared and c.undefined == 0, c
    assert c.agrees and c.median_rel <= 1e-6, c
    assert c.below >= len(points) // 20, c


@pytest.mark.skipif(not SHARED, reason=f"BRDF Explorer's collection is not at {COLLECTION}")
@pytest.mark.parametrize("which", range(len(SETS)), ids=SETS)
@pytest.mark.parametrize("path", SHARED, ids=[p.stem for p in SHARED])
def test_collection_agrees_with_mesa(path, which, mesa, points, runtime):
    values = glsl_oracle.parameter_sets(path)[which]
    c = glsl_oracle.compare(path, values, points=points, runtime=runtime)
    assert c.agrees and c.finite_mismatch == 0, c
    assert c.compared >= 0.3 * 3 * 9_000, c        # what GLSL leaves undefined is a minority of points


def test_undefined_calls_are_left_out_and_a_wrong_value_is_not(tmp_path, mesa, points, runtime, monkeypatch):
    """pow of a negative base is left out (GLSL leaves it undefined); a translation that differs
    where GLSL is defined is caught, however small the value (MIN_POW_BASE^y for 0^y)."""
    from lobe_helpers import write_brdf
    path = Path(write_brdf(tmp_path, "undefined", """
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{
    float c = dot(L, V);
    float u = 0.0;
    if (c > 0.5)
        u = pow(c - 1.0, 2.5);          // a negative base: undefined
    return vec3(u, pow(max(c, 0.0), 1.0), 1.0);
}"""))
    c = glsl_oracle.compare(path, points=points, runtime=runtime)
    assert c.undefined_by.get("pow", 0) > 0 and c.agrees, c
    exact = glsl_oracle.clshade_values

    def floored(*args, **kwargs):
        f = exact(*args, **kwargs)
        return np.where(f == 0, np.float32(1e-30), f)

    monkeypatch.setattr(glsl_oracle, "clshade_values", floored)
    c = glsl_oracle.compare(path, points=points, runtime=runtime)
    assert not c.agrees and c.max_excess > 1e-5, c

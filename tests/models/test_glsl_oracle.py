"""The .brdf translator against a real GLSL compiler (clshade.verify.glsl_oracle): Mesa's GLSL 4.30 and
clshade's translation evaluate the project's own .brdf files at 10⁴ directions with the hard cases
(grazing, L = V, the mirror direction); skipped with the reason where moderngl or Mesa's EGL is absent."""
from __future__ import annotations

import pytest

from conftest import SCENES

glsl_oracle = pytest.importorskip("clshade.verify.glsl_oracle")

LOBES = sorted((SCENES / "lobes").glob("*.brdf"))


@pytest.fixture(scope="module")
def mesa():
    why = glsl_oracle.unavailable()
    if why:
        pytest.skip(f"no GLSL oracle here: {why}")


@pytest.fixture(scope="module")
def points():
    return glsl_oracle.directions(10_000)


def test_hard_cases_are_in_the_directions(points):
    import numpy as np
    nl, nv = (np.sum(points.n * d, axis=1) for d in (points.l, points.v))
    assert (nl < 0).any() and (np.abs(nl - 1e-3) < 1e-5).any() and (np.abs(nv - 1e-3) < 1e-5).any()
    assert (np.abs(points.l - points.v).max(axis=1) == 0).any()
    mirror = 2 * nl[:, None] * points.n - points.l
    assert (np.abs(mirror - points.v).max(axis=1) < 1e-5).sum() >= len(points) // 20


@pytest.mark.parametrize("path", LOBES, ids=[p.stem for p in LOBES])
def test_translation_agrees_with_mesa(path, mesa, points, runtime):
    c = glsl_oracle.compare(path, points=points, runtime=runtime)
    assert c.finite_mismatch == 0 and c.both_finite == c.compared, c
    assert c.median_rel <= 1e-6 and c.max_rel <= 1e-4, c

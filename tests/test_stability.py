"""A reduced torture grid (clshade.verify.stability): finite, non-negative, close to the reference."""
from __future__ import annotations

from clshade.verify import stability
from clshade.models import resolve

# docs/stability.md: "where no clamp is active the precise build stays within 3e-4 of the float64 reference".
DOCUMENTED_PRECISE_DEVIATION = 3e-4


def test_grid_finite_non_negative_and_accurate() -> None:
    models = [resolve("ggx_correlated@conductor"), resolve("ggx_correlated@dielectric"), resolve("phong")]
    rep = stability.run(models, extras=False)
    assert rep.ok, stability.format_report(rep)
    assert rep.results and all(r.cases > 0 for r in rep.results)
    precise = [r for r in rep.results if not r.fast_math]
    assert all(r.max_deviation_unclamped < DOCUMENTED_PRECISE_DEVIATION for r in precise), stability.format_report(rep)

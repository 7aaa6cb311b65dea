"""A reduced torture grid (clshade.verify.stability): finite, non-negative, close to the reference."""
from __future__ import annotations

from clshade.verify import stability
from clshade.models import resolve


def test_grid_finite_non_negative_and_accurate() -> None:
    models = [resolve("ggx_correlated@conductor"), resolve("ggx_correlated@dielectric"), resolve("phong")]
    rep = stability.run(models, extras=False)
    assert rep.ok, stability.format_report(rep)
    precise = [r for r in rep.results if not r.fast_math]
    assert all(r.max_deviation_unclamped < stability.PRECISE_TOLERANCE for r in precise), stability.format_report(rep)

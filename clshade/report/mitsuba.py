"""clshade's truth under a sky against Mitsuba 3's envmap emitter (benchmarks/measure/mitsuba_envmap.py:
mitsuba_envmap.json): benchmarks/results/mitsuba_envmap.md."""
from __future__ import annotations

from clshade.report.tables import markdown


def mitsuba_envmap_markdown(doc: dict) -> str:
    """benchmarks/results/mitsuba_envmap.md: one row per sky."""
    rows = [[r["sky"], f"{r['size'][0]}×{r['size'][1]}", f"{r['peak_over_mean']:.3g}",
             ", ".join(f"{k}°: {v:.1e}" for k, v in r["orientation_max_rel"].items()),
             str(r["normals"]), f"{r['samples']:,}", f"{r['rel_rmse']:.2e}", f"{r['max_rel']:.2e}",
             f"{r['median_rel_se']:.2e}", f"{r['max_z']:.2f}"] for r in doc["rows"]]
    table = markdown(["sky", "map", "peak ÷ mean luminance", "orientation: max rel diff per rotation", "normals",
                      "Mitsuba samples per normal", "E(n) rel RMSE", "E(n) max rel diff",
                      "Mitsuba's median rel std error", "max |diff| ÷ std error"], rows)
    commit = (doc["provenance"].get("commit") or "unknown")[:10]
    skipped = f" Skipped: {doc['skipped']}." if doc.get("skipped") else ""
    return "\n".join([
        "# The truth under a sky against Mitsuba 3", "",
        f"Rendered by `python -m benchmarks.publish` from benchmarks/results/mitsuba_envmap.json; how it is "
        f"measured: the docstring of benchmarks/measure/mitsuba_envmap.py. Orientation: Mitsuba's `envmap` "
        f"evaluated along the direction clshade gives each texel centre (turned by `to_world`). Integral: "
        f"irradiance E(n) at the normals of {doc['scene']}'s oracle pixels, by clshade's oracle cells "
        f"({doc['subdivisions']}² per texel) and by Mitsuba's own emitter sampling; where the two agree, the "
        f"differences are Mitsuba's noise (max |diff| ÷ std error of a few).{skipped}", "",
        table, "",
        f"*Mitsuba {doc['mitsuba']} ({doc['variant']}); machine {doc['machine'].get('cpu', '')}; commit {commit}; "
        f"measured {doc['created']} by `{doc['command']}` ({doc['seconds']:.0f} s).*", ""])

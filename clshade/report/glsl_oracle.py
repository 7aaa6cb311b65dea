"""The .brdf translator against Mesa's GLSL (benchmarks/measure/glsl_oracle.py: glsl_oracle.json):
benchmarks/results/glsl_oracle.md."""
from __future__ import annotations

from clshade.report.tables import markdown


def glsl_oracle_markdown(doc: dict) -> str:
    """benchmarks/results/glsl_oracle.md: one row per file and parameter set."""
    rows = [[f"`{r['file']}`", r["origin"], r["set"], "yes" if r["agrees"] else "**no**", f"{r['max_excess']:.1e}",
             f"{r['max_rel']:.1e} / {r['median_rel']:.1e}", str(r["conditioned"]), str(r["compared"]),
             str(r["below"]),
             ", ".join(f"{k} {v}" for k, v in r["undefined_by"].items()) or "0", str(r["singular"]),
             str(r["finite_mismatch"])] for r in doc["rows"]]
    table = markdown(["file", "origin", "parameters", "agrees", "max excess", "max / median rel err",
                      "conditioned values", "values compared", "of them below the horizon (points)", "points left out: undefined in GLSL",
                      "singular points", "finite on one side"], rows)
    agree = sum(r["agrees"] for r in doc["rows"])
    return "\n".join([
        "# .brdf files: clshade's translation against Mesa's GLSL", "",
        f"Rendered by `python -m benchmarks.publish` from benchmarks/results/glsl_oracle.json; what the columns "
        f"mean: docs/user-lobes.md (*Checked against a real GLSL compiler*). {agree} of {len(doc['rows'])} "
        f"file × parameter-set rows agree.", "",
        table, "",
        f"*{doc['points']} directions per row (grazing, L = V, mirror, n·l < 0 among them), 3 values each where "
        f"n·l > 0; parameters: the file's defaults, every float at a quarter of its range with every bool "
        f"flipped, every float at three quarters. Agreement: no value finite on one side only, and every "
        f"difference within {doc['conditioning_factor']:g}× the float32 conditioning ({doc['jitters']} draws) "
        f"plus {doc['tolerance']:.0e} relative. Mesa: {doc['mesa']}; clshade on {doc['device']}; commit "
        f"{(doc['provenance']['commit'] or 'unknown')[:10]}; measured {doc['created']} by `{doc['command']}` "
        f"({doc['seconds']:.0f} s).*", ""])

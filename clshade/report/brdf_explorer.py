"""BRDF Explorer's collection through clshade's commands (benchmarks/measure/brdf_explorer.py:
brdf_explorer.json): benchmarks/results/brdf_explorer.md."""
from __future__ import annotations

from clshade.report.tables import cell, markdown


def _render(r: dict) -> str:
    return "yes" if r["render"]["exit"] == 0 else f"**exit {r['render']['exit']}**: {r['render']['message']}"


def _stability(s: dict) -> str:
    if "ok" not in s:
        return f"**exit {s['exit']}**: {s['message']}"
    shipped = "finite" if s["shipped_nonfinite"] == 0 else f"**{s['shipped_nonfinite']} NaN/Inf**"
    counts = f"NaN/Inf {s['nonfinite']}, negative {s['negative']} of {s['cases']}; shipped image {shipped}"
    return f"stable: {counts}" if s["ok"] else f"**not stable** ({s['failures'][0]}): {counts}"


def _oracle(rows: list[dict]) -> str:
    if not rows:
        return "not measured"
    agree = sum(r["agrees"] for r in rows)
    return f"{agree} of {len(rows)} agree (beyond float32 conditioning ≤ {max(r['max_excess'] for r in rows):.1e})"


def brdf_explorer_markdown(doc: dict) -> str:
    """benchmarks/results/brdf_explorer.md: one row per file."""
    rows = [[f"`{r['file']}`", f"`{r['id']}`" if r["id"] else "**not listed**", _render(r),
             cell(r["mean_ms"], ".3f"), cell(r["lambert_ratio"], ".2f"), cell(r["copy_ratio"], ".2f"),
             f"{cell(r['max_rel_error'], '.1e')} / {cell(r['mean_rel_error'], '.1e')}",
             _stability(r["stability"]), _oracle(r["oracle"])] for r in doc["rows"]]
    rendered = sum(r["render"]["exit"] == 0 for r in doc["rows"])
    timed = sum(r["mean_ms"] is not None for r in doc["rows"])
    stable = sum(bool(r["stability"].get("ok")) for r in doc["rows"])
    listed = sum(r["id"] is not None for r in doc["rows"])
    commit = (doc["provenance"]["commit"] or "unknown")[:10]
    return "\n".join([
        "# BRDF Explorer's collection in clshade", "",
        f"Rendered by `python -m benchmarks.publish` from benchmarks/results/brdf_explorer.json. Every `.brdf` "
        f"file of BRDF Explorer's collection as a user brings it, with the commands a user runs: "
        f"{listed} of {len(doc['rows'])} listed by `clshade models --lobes`, {rendered} rendered by `clshade render -m "
        f"FILE`, {timed} timed by one `clshade bench` run, {stable} stable by `clshade check stability --model FILE` "
        f"(a file that divides by zero at some input of the torture grid is reported, not fixed: the file is the "
        f"user's).", "",
        f"![the collection on the white sphere]({doc['sheet'].rsplit('/', 1)[-1]})", "",
        markdown(["file", "id", "render", "ms/frame", "× Lambert", "× copy", "frame max / mean rel err vs float64",
                  "stability (torture grid, both builds)", "GLSL oracle (parameter sets)"], rows), "",
        f"*`{doc['scene']}` at {doc['width']}×{doc['height']}, {doc['frames']} frames per model in interleaved rounds "
        f"(Lambert {doc['lambert_ms']:.3f} ms in the same run); default parameters; the contact sheet at "
        f"{doc['sheet_tile']} px per tile by `clshade compare`. GLSL oracle: benchmarks/results/glsl_oracle.md "
        f"(measured on {(doc['oracle_measured'] or 'unknown')[:10]}). Device {doc['device']}; commit {commit}; "
        f"measured {doc['created']} by `{doc['command']}` ({doc['seconds']:.0f} s).*", ""])

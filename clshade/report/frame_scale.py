"""Whole frames against resolution and triangles (benchmarks/measure/frame_scale.py: frame_scale.json):
benchmarks/results/frame_scale.md."""
from __future__ import annotations

from clshade.report.tables import markdown


def _row(label: str, r: dict, target: float) -> list[str]:
    st = r["stage_ms"]
    stages = ", ".join(f"{k} {v:.1f}" for k, v in st.items() if v >= 0.05)
    return [label, f"{r['width']}×{r['height']}", f"{r['triangles']:,}", r["gbuffer"]["path"], f"{r['frame_ms']:.1f}", f"{1000.0 / r['frame_ms']:.1f}",
            f"{r['low1_fps']:.1f}", "yes" if r["frame_ms"] <= target else "no", stages]


def frame_scale_markdown(doc: dict) -> str:
    """The two tables (resolution, triangles) and the plot."""
    head = ["what", "size", "triangles", "g-buffer path", "median frame ms", "FPS (median)", "1 % low FPS",
            "≤ 33.3 ms", "stage medians, ms"]
    t = doc["target_ms"]
    res = markdown(head, [_row("robot.toml", r, t) for r in doc["resolution"]])
    tri = markdown(head, [_row(r["name"], r, t) for r in sorted(doc["triangles"], key=lambda r: r["triangles"])])
    skipped = "".join(f"\n- skipped {s['mesh']}: {s['reason']}" for s in doc.get("skipped", []))
    commit = (doc["provenance"].get("commit") or "unknown")[:10]
    return "\n".join([
        "# Where 30 FPS ends: whole frames against resolution and triangles", "",
        f"Rendered by `python -m benchmarks.publish` from benchmarks/results/frame_scale.json; how it is measured: "
        f"the docstring of benchmarks/measure/frame_scale.py. {doc['model']}, {doc['frames']} orbit frames per "
        f"point through the one frame path, on {doc['device']}.", "",
        "![whole frame against resolution and triangles](frame_scale.png)", "",
        "## Resolution", "", res, "", f"## Triangles ({doc['width']}×{doc['height']})", "", tri, skipped, "",
        f"*Commit {commit}; machine {doc['machine'].get('cpu', '')}, {doc['machine'].get('cores')} cores; measured "
        f"{doc['created']} by `{doc['command']}`; load average {doc['load_average']}.*", ""])

"""docs/accuracy.md from benchmarks/results/accuracy.json (benchmarks/measure/accuracy_table.py)."""
from __future__ import annotations

from clshade.report.tables import MISSING, markdown


def accuracy_markdown(doc: dict) -> str:
    """Every term and model against the float64 reference, with the metric and its limits."""
    terms = markdown(["term (brdf.h)", "samples", "max rel err", "median"],
                     [[t["name"], t["samples"], f"{t['max_rel_err']:.2e}", f"{t['median_rel_err']:.1e}"]
                      for t in doc["terms"]])
    hard = lambda m: (MISSING if m["hard_max_rel_err"] is None  # noqa: E731
                      else f"{m['hard_samples']}, {m['hard_max_rel_err']:.2e}")
    models = markdown(["model", "samples", "max rel err", "median", "outside the limits: samples, max rel err"],
                      [[m["model"], m["samples"], f"{m['max_rel_err']:.2e}", f"{m['median_rel_err']:.1e}", hard(m)]
                       for m in doc["models"]])
    lines = ["# Accuracy of the kernels against the float64 reference", "",
             f"Rendered by `python -m benchmarks.publish` from benchmarks/results/accuracy.json (measured "
             f"{doc['created']} by `{doc['command']}`); checked by tests/device/test_terms.py and tests/verify/test_accuracy.py.",
             "", f"Device: {doc['device']}. Precise math (no -cl-fast-relaxed-math). Target: max relative error ≤ "
             f"{doc['target']:g}.", "",
             f"Metric: |f − g| / max(|g|, {doc['floor_rel']:g} · peak), g the float64 reference on float32-rounded "
             f"inputs, max over samples and RGB. Limits: n·l, n·v ≥ {doc['min_cosine']}; microfacet r ≥ "
             f"{doc['min_roughness']} and α·min(n·l, n·v) ≥ {doc['min_alpha_cosine']:g} (the float32 half vector's "
             f"conditioning; samples outside are reported in the last column); Phong/Blinn–Phong n ≤ "
             f"{doc['max_shininess']:g}.", "", terms, "", models]
    return "\n".join(lines) + "\n"

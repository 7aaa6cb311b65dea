"""The user lobes beside built-in models (benchmarks/measure/user_lobes.py: user_lobes.json):
benchmarks/results/user_lobes.md and the regions of docs/user-lobes.md."""
from __future__ import annotations

from clshade.report.tables import cell, markdown


def _commit(doc: dict) -> str:
    return (doc["provenance"]["commit"] or "unknown")[:10]


def user_lobes_table(doc: dict) -> str:
    """Every column a built-in gets, one row per model, and the footnote."""
    rows = [[r["model"], r["origin"] if r["file"] is None else f"{r['origin']}: `{r['file']}`", f"{r['mean_ms']:.3f}",
             f"{r['copy_ratio']:.2f}", f"{r['lambert_ratio']:.2f}",
             f"{cell(r['frame_max_rel_error'], '.1e')} / {cell(r['frame_mean_rel_error'], '.1e')}",
             f"{cell(r['f32_max_rel_err'], '.1e')} / {cell(r['f32_median_rel_err'], '.1e')} ({r['reference']})",
             cell(r["fp64_vs_oracle"], ".1e"), f"{r['min_f']:.3g}", cell(r["reciprocity"], ".1e"),
             f"{r['max_albedo']:.3f}", "yes" if r["physically_based"] else "no",
             f"{r['grid_nonfinite']}, {r['grid_negative']} ({r['grid_cases']})"] for r in doc["rows"]]
    table = markdown(["model", "origin", "ms/frame", "× copy", "× Lambert", "frame max / mean rel err vs float64",
                      "f32 vs float64 max / median (reference)", "float64 build vs oracle", "min f", "reciprocity err",
                      "max albedo", "physically based", "grid NaN/Inf, negative (of evaluations)"], rows)
    return "\n".join([table, "", f"*{doc['scene']} at {doc['width']}×{doc['height']}, {doc['frames']} frames per model "
                                 f"in interleaved rounds; {doc['accuracy_samples']} hemisphere samples per model; device "
                                 f"{doc['device']}; commit {_commit(doc)}; measured {doc['created']} by "
                                 f"`{doc['command']}` ({doc['seconds']:.0f} s). Reference `oracle`: "
                                 "clshade.verify.reference (Python, float64); `fp64`: the lobe's own double-precision "
                                 "device build.*"])


def user_lobes_markdown(doc: dict) -> str:
    """benchmarks/results/user_lobes.md."""
    return ("# User lobes beside built-in models\n\nRendered by `python -m benchmarks.publish` from "
            "benchmarks/results/user_lobes.json; what the columns mean: docs/user-lobes.md.\n\n"
            + user_lobes_table(doc) + "\n")


def user_lobes_example(doc: dict) -> str:
    """docs/user-lobes.md's worked example: the Ward file's row and its built-in neighbours."""
    rows = {r["model"]: r for r in doc["rows"]}
    ward, lam = rows["ward"], rows["lambert"]
    return (f"On {doc['device']} ({doc['scene']}, {doc['width']}×{doc['height']}, commit "
            f"{_commit(doc)}), `ward.brdf` shades a frame in {ward['mean_ms']:.3f} ms: "
            f"{ward['lambert_ratio']:.2f}× Lambert ({lam['mean_ms']:.3f} ms) and {ward['copy_ratio']:.2f}× the copy "
            f"kernel that only moves the G-buffer. Its float32 build is within {ward['f32_max_rel_err']:.1e} "
            f"(max; median {ward['f32_median_rel_err']:.1e}) of its float64 build over "
            f"{ward['f32_samples']} hemisphere samples, and the rendered frame within "
            f"{ward['frame_max_rel_error']:.1e} of the float64 frame. It never goes negative (min f = "
            f"{ward['min_f']:.3g}), is reciprocal to {ward['reciprocity']:.1e}, reflects at most "
            f"{ward['max_albedo']:.3f} of the light, and gives {ward['grid_nonfinite']} NaN/Inf in "
            f"{ward['grid_cases']} torture-grid evaluations. For the built-in models the double build agrees with "
            f"the Python oracle to {max(r['fp64_vs_oracle'] for r in doc['rows'] if r['fp64_vs_oracle'] is not None):.1e}.")

"""Formatting for every command: measured data (dicts and dataclasses from
clshade.bench and clshade.verify) → Markdown tables, CSV and plots. Nothing here
measures; clshade.cli prints what these functions return."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from clshade.errors import ClshadeError
from clshade.outputs import write_atomic
from clshade.report.tables import MISSING, cell, markdown, write_csv

# ---------------------------------------------------------------- bench

BENCH_CSV_FIRST = ("model", "name", "mean_ms", "avg_fps", "low1_fps", "low01_fps", "median_ms", "p99_ms",
                   "host_overhead_ms", "mpixel_per_s", "bytes_per_pixel", "mean_bytes_per_pixel", "lambert_ratio",
                   "copy_ratio", "copy_mean_ms", "wall_median_ms", "numpy_ms", "numpy_ratio", "numpy_frames",
                   "reference_ms", "reference_ratio",
                   "max_rel_error", "mean_rel_error", "frames")


LOW01_MIN_FRAMES = 1000   # a 0.1 % low needs at least 1000 frames (one frame in a thousand)


def low01_fps(row: dict) -> float | None:
    """A row's 0.1 % low, or None below LOW01_MIN_FRAMES frames (there it is only the slowest frame again)."""
    return row["low01_fps"] if row["frames"] >= LOW01_MIN_FRAMES else None


def numpy_header(doc: dict | None = None) -> str:
    """The × NumPy column's header: the clock and the thread count of each side, and the
    straw-man guard's verdict when it marks the column suspect."""
    if doc is None:
        return "× NumPy (wall time)"
    cu = doc.get("device", {}).get("compute_units")
    guard = doc.get("numpy_guard") or {}
    flag = "; SUSPECT, see below" if guard.get("suspect") else ""
    return f"× NumPy (wall time; OpenCL {cu} CU, NumPy {doc.get('numpy_threads', 1)} thread{flag})"


NUMPY_BASELINE_CODE = "clshade/bench/numpy_baseline.py"


def numpy_guard_line(doc: dict, code: str = NUMPY_BASELINE_CODE) -> str:
    """One sentence: what the NumPy baseline is (`code`: how to name its file) and the straw-man
    guard's measurement."""
    what = (f"× NumPy = the NumPy baseline's wall time ({code}: vectorised float32 NumPy "
            "specialised to the scene, checked against the kernel's image first) / the kernel's wall time")
    guard = doc.get("numpy_guard")
    if not guard or guard.get("ratio") is None:
        return what + "; no straw-man guard in this run (the baseline has no Lambert for the scene)."
    verdict = ("SUSPECT: the baseline may be a straw man" if guard["suspect"] else "not suspect")
    return (what + f"; its Lambert takes {guard['ratio']:.2f}× a minimal NumPy Lambert (median of "
            f"{guard['frames']} pairs in the same rounds; limit {guard['limit']:g}): {verdict}.")


def bench_table(rows: list[dict], ladder: bool = False, doc: dict | None = None) -> str:
    """A Markdown table of bench rows (model rows, or ladder rungs with `ladder`); `doc`
    (the whole JSON document) names the thread counts in the NumPy column's header."""
    if ladder:
        return markdown(
            ["ladder", "rung", "model", "mean ms", "copy ×", "max rel err", "mean rel err", "error vs", "Pareto"],
            [[r["group"], r["label"], r["model"], cell(r["mean_ms"], ".2f"), cell(r["copy_ratio"], ".2f"),
              cell(r["max_rel_error"], ".2e"), cell(r["mean_rel_error"], ".2e"), r.get("error_target", ""),
              "●" if r.get("pareto") else ""] for r in rows])
    return markdown(
        ["model", "mean ms", "avg FPS", "1 % low", "0.1 % low", "median ms", "p99 ms", "host ms", "Mpix/s", "B/px",
         "mean B/px", "× Lambert", "× copy", "NumPy ms", numpy_header(doc), "× general ref. (f32)", "max rel err",
         "mean rel err"],
        [[r["label"], cell(r["mean_ms"], ".2f"), cell(r["avg_fps"], ".1f"), cell(r["low1_fps"], ".1f"),
          cell(low01_fps(r), ".1f"), cell(r["median_ms"], ".2f"), cell(r["p99_ms"], ".2f"),
          cell(r["host_overhead_ms"], ".3f"), cell(r["mpixel_per_s"], ".1f"), cell(r["bytes_per_pixel"]),
          cell(r["mean_bytes_per_pixel"], ".1f"), cell(r["lambert_ratio"], ".2f"), cell(r["copy_ratio"], ".2f"),
          cell(r["numpy_ms"], ".1f"), cell(r["numpy_ratio"], ".1f"), cell(r.get("reference_ratio"), ".1f"),
          cell(r["max_rel_error"], ".2e"),
          cell(r["mean_rel_error"], ".2e")] for r in rows])


def bench_csv(rows: list[dict], path: Path | str) -> None:
    """The per-model rows as CSV."""
    write_csv(rows, path, BENCH_CSV_FIRST)


def pyplot():
    """matplotlib's pyplot on the Agg backend (files only, no display); ClshadeError where
    matplotlib is missing, so that commands can check for it before a long run."""
    try:
        import matplotlib
    except ImportError as exc:
        raise ClshadeError("--plot needs matplotlib, a dependency of clshade missing from this environment: "
                           "pip install matplotlib") from exc
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _finish(plt, fig, ax, path: Path, title: str, legend_size: int) -> None:
    """Title, legend, tight layout; write the PNG and close the figure."""
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=legend_size)
    fig.tight_layout()
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=120))
    plt.close(fig)


def plot_fps(rows: list[dict], path: Path, title: str) -> None:
    """Bar chart: average FPS with the 1 % low and, from LOW01_MIN_FRAMES frames on, the 0.1 % low per model."""
    plt = pyplot()
    x = np.arange(len(rows))
    fig, ax = plt.subplots(figsize=(max(6, 0.9 * len(rows) + 2), 4.5))
    w = 0.27
    series = [(-w, "average", [r["avg_fps"] for r in rows]), (0, "1 % low", [r["low1_fps"] for r in rows])]
    if all(low01_fps(r) is not None for r in rows):      # else the 0.1 % low repeats the slowest frame
        series.append((w, "0.1 % low", [low01_fps(r) for r in rows]))
    for off, name, values in series:
        bars = ax.bar(x + off, values, w, label=name)
        ax.bar_label(bars, fmt="%.1f", fontsize=6, rotation=90, padding=2)
    ax.set_xticks(x, [r["label"] for r in rows], rotation=35, ha="right", fontsize=8)
    ax.set_ylabel("frames per second")
    _finish(plt, fig, ax, path, title, legend_size=8)


def _label_points(ax, points: list[tuple[float, float, str]], fontsize: float = 6) -> None:
    """Annotate (x, y, label) points without overlapping labels: each label goes up-right of its
    point unless its (measured) box overlaps one already placed, then to the first free slot
    stacked below or above, with a leader line back to the point. Call after the axes' scales
    and limits are set."""
    from matplotlib.text import Text

    fig = ax.figure
    fig.canvas.draw()                                   # the final transforms (scales, limits)
    renderer = fig.canvas.get_renderer()
    placed = []
    order = sorted(points, key=lambda p: -ax.transData.transform((p[0], p[1]))[1])
    for x, y, label in order:
        note = ax.annotate(label, (x, y), fontsize=fontsize, xytext=(3, 3), textcoords="offset points")
        for k in range(40):
            note.xyann = (3, 3.0 + (-1) ** k * ((k + 1) // 2) * (fontsize + 2))   # 3, -5, 11, -13, … points
            note.update_positions(renderer)
            box = Text.get_window_extent(note, renderer)                       # the text alone
            if not any(box.overlaps(other) for other in placed):
                break
        if k:                                           # moved off its point: a leader line back to it
            offset = note.xyann
            note.remove()
            ax.annotate(label, (x, y), fontsize=fontsize, xytext=offset, textcoords="offset points",
                        arrowprops=dict(arrowstyle="-", lw=0.4, color="0.5", shrinkA=0, shrinkB=2))
        placed.append(box)


def plot_ladder(rows: list[dict], path: Path, title: str) -> None:
    """Time vs error (log error axis), Pareto front of each ladder marked with a ring."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for group in dict.fromkeys(r["group"] for r in rows):
        pts = [r for r in rows if r["group"] == group]
        errs = [max(r["mean_rel_error"], 1e-9) for r in pts]
        sc = ax.scatter([r["mean_ms"] for r in pts], errs, label=group)
        for r, e in zip(pts, errs):
            if r.get("pareto"):
                ax.scatter([r["mean_ms"]], [e], s=160, facecolors="none", edgecolors=sc.get_facecolor()[0])
    ax.set_yscale("log")
    _label_points(ax, [(r["mean_ms"], max(r["mean_rel_error"], 1e-9), r["label"]) for r in rows])
    ax.set_xlabel("mean frame time (ms)")
    ax.set_ylabel("mean relative error vs the ladder's exact model (float64)")
    _finish(plt, fig, ax, path, title, legend_size=7)


def bench_text(doc: dict) -> str:
    """What `clshade bench` prints: a header line, the model table, the ladder table."""
    scene = Path(doc["scene"]).name if doc.get("scene") else "scene"
    n = doc.get("samples", 1)
    aa = f" ({n}x{n} samples per pixel, resolved on the device)" if n > 1 else ""
    aa += " (specular AA)" if doc.get("specular_aa") else ""
    lines = [f"{scene} {doc['width']}x{doc['height']}{aa}, {doc['frames']} frames after {doc['warmup']} warm-up, "
             f"{doc['features']['num_dir'] + doc['features']['num_point'] + doc['features']['num_spot']} lights, "
             f"device {doc['device']['name']} [{doc['device']['platform_version']}]",
             bench_table(doc["models"], doc=doc), numpy_guard_line(doc)]
    lines += [f"No NumPy time for {r['label']}: {r['numpy_note']}" for r in doc["models"] if r.get("numpy_note")]
    if doc["ladder"]:
        lines += ["", bench_table(doc["ladder"], ladder=True)]
    return "\n".join(lines)


def bench_plots(doc: dict, path: Path) -> None:
    """The FPS bar chart at `path` and, with ladders, the ladder plot beside it."""
    title = f"{Path(doc['scene']).stem if doc.get('scene') else 'scene'} {doc['width']}x{doc['height']}, " \
            f"{doc['device']['name']}"
    plot_fps(doc["models"], path, title)
    if doc["ladder"]:
        plot_ladder(doc["ladder"], path.with_name(path.stem + "_ladder" + path.suffix), title)


# ---------------------------------------------------------------- check stability


def stability_text(rep) -> str:
    """What `clshade check stability` prints for a clshade.verify.stability.Report."""
    from clshade.verify.stability import DEVIATION_COSINE, DEVIATION_FLOOR
    d = rep.as_dict()
    raw = d["raw_radiance"]
    per_build = ", ".join(f"{k} {v}" for k, v in d["distinct_inputs"].items())
    lines = [f"device: {rep.device}",
             f"evaluations: {rep.cases} over {len(d['builds'])} builds ({', '.join(d['builds'])}); "
             f"distinct inputs per build: {per_build}",
             f"BRDF NaN/Inf: {sum(r.nonfinite for r in rep.results)}, negative: {sum(r.negative for r in rep.results)} "
             "(must be 0)",
             f"shaded pixels, raw radiance (no MAX_RADIANCE clamp): NaN {raw['nan']}, Inf {raw['inf']}, "
             f"negative {raw['negative']}; saturated (≥ MAX_RADIANCE {raw['max_radiance_clamp']:.3g}) "
             f"{raw['saturated_pixels']}; largest finite {raw['max_radiance']:.3g}; shipped build NaN/Inf "
             f"{raw['clamped_build_nonfinite']}", "",
             f"largest deviation from the float64 reference, |f32 − f64| / max(|f64|, {DEVIATION_FLOOR:g}):"]
    rows = []
    for r in rep.results:
        at = r.max_deviation_at
        where = ", ".join(f"{k}={at[k]}" for k in ("n.l", "n.v", "azimuth", "normal", "roughness_label", "base",
                                                    "metallic", "f90", "ior", "eta_label", "shininess") if k in at)
        rows.append([r.model, "fast" if r.fast_math else "precise", r.cases, r.distinct_inputs,
                     f"{r.max_deviation:.2e}", f"{r.max_deviation_unclamped:.2e}", where])
    lines.append(markdown(["model", "build", "cases", "distinct", "all", "cos ≥ 1e-4", "where (all)"], rows))
    bad = [f"  BAD {r.model} ({'fast' if r.fast_math else 'precise'}): {r.first_bad}" for r in rep.results if r.first_bad]
    lines += bad
    if rep.shading:
        lines += ["", "shading pass, raw radiance (lights 0, 1e-30, 1e30: 4 directional, a point light on the "
                  f"surface, a point, a spot; ambient); deviation vs the frame oracle at unit lights, "
                  f"n·l and n·v ≥ {DEVIATION_COSINE:g}:",
                  markdown(["model", "build", "pixels", "distinct", "NaN", "Inf", "negative", "saturated",
                            "shipped NaN/Inf", "max radiance", "vs oracle", "compared"],
                           [[s.model, "fast" if s.fast_math else "precise", s.pixels, s.distinct_inputs, s.nan, s.inf,
                             s.negative, s.saturated, s.clamped_nonfinite, f"{s.max_radiance:.3g}",
                             f"{s.max_deviation:.2e}", s.deviation_pixels] for s in rep.shading])]
    if rep.clamps:
        lines += ["", "clamp bias (precise build, against the unclamped float64 reference):",
                  markdown(["clamp", "value", "active when", "bias", "measure", "worst"],
                           [[c["clamp"], f"{c['value']:g}", c["active"], f"{c['bias']:.3g}", c["measure"], c["worst"]]
                            for c in rep.clamps])]
    if rep.continuity:
        lines += ["", "continuity near the limits:",
                  markdown(["model", "check", "max relative step", "where"],
                           [[c["model"], c["check"], f"{c['max_relative_step']:.3g}", c["where"]]
                            for c in rep.continuity])]
    terms = rep.terms()
    if terms:
        lines += ["", "raw terms in the counting build (kernels/count.h), before any clamp; every model and build:",
                  markdown(["term", *next(iter(terms.values()))], [[t, *c.values()] for t, c in terms.items()])]
    failures = rep.failures()
    lines += [""] + [f"  FAIL {f}" for f in failures]
    lines += [f"{'OK' if not failures else 'FAILED'} in {rep.seconds:.1f} s"]
    return "\n".join(lines)


# ---------------------------------------------------------------- anti-aliasing (clshade aa)

AA_ERRORS = (("frame_rel_error", "whole frame"), ("silhouette_rel_error", "silhouette pixels"),
             ("highlight_rel_error", "highlight pixels"))


def aa_markdown(doc: dict) -> str:
    """`clshade aa` results: the ladder, the convergence of the truth, temporal stability."""
    d = doc["definitions"]
    out = [f"# Anti-aliasing ladder — {doc['scene']} {doc['width']}x{doc['height']}", "",
           f"Generated {doc['date']} by `{doc.get('command', 'clshade aa')}`; device {doc['device']['name']} "
           f"[{doc['device']['platform_version']}] on {doc['machine']['processor']} "
           f"({doc['machine']['cpu_count']} CPUs, shared). Frame time: {d['frame_time']}. Error: {d['error']}. "
           f"Silhouette: {d['silhouette']}; highlight: {d['highlight']}. ● = on the Pareto front of its model "
           "(frame time vs whole-frame error).", "",
           markdown(["model", "rung", "samples/px", "mean ms", "raster ms", "frame err", "silhouette err",
                     "highlight err", "Pareto"],
                    [[r["group"], r["label"],
                      f"{r['samples'] ** 2} coverage, 1 shaded" if r.get("msaa") else r["samples"] ** 2,
                      cell(r["mean_ms"], ".3f"), cell(r["raster_ms"], ".0f"),
                      cell(r["frame_rel_error"], ".4f"), cell(r["silhouette_rel_error"], ".3f"),
                      cell(r["highlight_rel_error"], ".3f"), "●" if r.get("pareto") else ""] for r in doc["ladder"]])]
    if doc["convergence"]:
        out += ["", "## Is the truth converged?", "",
                "The same errors of the truth against a denser one (both float64, ordered grids):", "",
                markdown(["model", "truth", "against", "frame err", "silhouette err", "highlight err"],
                         [[c["group"], f"{c['truth_samples']}x{c['truth_samples']}",
                           f"{c['check_samples']}x{c['check_samples']}", cell(c["frame_rel_error"], ".5f"),
                           cell(c["silhouette_rel_error"], ".4f"), cell(c["highlight_rel_error"], ".4f")]
                          for c in doc["convergence"]])]
    if doc["temporal"]:
        spheres = doc["temporal"][0]["spheres"]
        out += ["", "## Temporal stability", "", d["temporal"] + ".", "",
                markdown(["model", "rung", *(f"r {s['roughness']:g}" for s in spheres), "mean"],
                         [[r["group"], r["label"], *(f"{s['energy_change']:.1e}" for s in r["spheres"]),
                           f"{r['mean_energy_change']:.1e}"] for r in doc["temporal"]])]
    truth = "; ".join(f"{t['model']} {t['samples']}x{t['samples']} in {t['seconds']:.0f} s" for t in doc["truth"])
    return "\n".join(out + ["", f"Truth frames: {truth}.", ""])


def plot_aa(doc: dict, path: Path) -> None:
    """Frame time (log) vs each error (log), one panel per pixel set; the Pareto front of
    each model in that panel's error ringed."""
    from clshade.bench.run import pareto
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.3))
    rows = doc["ladder"]
    for ax, (key, name) in zip(axes, AA_ERRORS):
        ax.set_title(name, fontsize=9)
        if all(r[key] is None for r in rows):
            ax.text(0.5, 0.5, f"no {name} in this frame", ha="center", transform=ax.transAxes)
            continue
        for group in dict.fromkeys(r["group"] for r in rows):
            pts = [r for r in rows if r["group"] == group and r[key] is not None]
            errs = [max(r[key], 1e-9) for r in pts]
            sc = ax.scatter([r["mean_ms"] for r in pts], errs, label=group)
            front = pareto([(r["mean_ms"], e) for r, e in zip(pts, errs)])
            for r, e, f in zip(pts, errs, front):
                if f:
                    ax.scatter([r["mean_ms"]], [e], s=160, facecolors="none", edgecolors=sc.get_facecolor()[0])
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(plt.NullFormatter())   # minor log labels overlap over one decade
        _label_points(ax, [(r["mean_ms"], max(r[key], 1e-9), r["label"]) for r in rows if r[key] is not None])
        ax.set_xlabel("mean device frame time (ms)")
        ax.set_ylabel(f"mean relative error, {name}")
    axes[0].legend(fontsize=7)
    t = doc["truth"][0]["samples"] if doc["truth"] else "?"
    fig.suptitle(f"anti-aliasing ladder vs the pixel integral ({t}x{t} float64), {doc['scene']} "
                 f"{doc['width']}x{doc['height']}, {doc['device']['name']}", fontsize=10)
    fig.tight_layout()
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=120))
    plt.close(fig)


# ---------------------------------------------------------------- performance (clshade.bench.perf)

PERF_RUNTIME_HEADER = ("runtime", "build", "SIMD", "model", "ms", "copy ms", "× copy", "in cache ms",
                       "copy in cache ms", "GB/s", "copy GB/s", "× STREAM bound", "copy × STREAM bound",
                       "max rel diff vs first column")


def perf_markdown(doc: dict) -> str:
    """The performance document of clshade.bench.perf (`python -m clshade.bench.perf`, `clshade bench
    --peers`) as Markdown, from the JSON document only."""
    from clshade.bench.perf import CACHE_BAND_PIXELS, short
    s = doc["stream"]
    L = ["# Performance on the runtimes users get (issue 15)", "",
         f"Generated {doc['created']} by `{doc.get('command', '')}` "
         f"on {doc['machine']['processor']} ({doc['machine']['cpu_count']} cores, {doc['machine']['os']}); "
         f"{doc['scene']} {doc['width']}×{doc['height']}, {doc['rounds']} interleaved rounds"
         + (f" ({doc['timed_run']})" if doc.get("timed_run") else "") + ", medians. "
         f"Versions: " + ", ".join(f"{k} {v}" for k, v in doc["versions"].items()) + ".", "",
         "Times are of the shading dispatch alone (OpenCL profiling); the whole-frame figure is below. "
         "Builds: `default` = what clshade builds (kernels/simd.h's inline builtins only where PoCL's AVX-512 "
         "builtin library meets a compiler target without AVX-512), `library` = the OpenCL library's "
         "builtins everywhere (the kernels before issue 15; CLSHADE_LIBRARY_MATH=1), `inline` = inline "
         "builtins everywhere (CLSHADE_INLINE_MATH=1), `plain stores` = `default` with the image rows written "
         "by plain stores instead of streaming ones (CLSHADE_CACHED_STORES=1; kernels/simd.h, STORE_ROW8), "
         "`no prefetch` = `default` without the software prefetch of the G-buffer ahead (CLSHADE_NO_PREFETCH=1; "
         "kernels/gbuffer.h, PREFETCH_AHEAD). "
         "Targets are judged on `default`.", "",
         f"**STREAM anchor** ({s['before']['method']}, {s['before']['array_mib']} MiB arrays, best of "
         f"{s['before']['repeats']}): copy {s['before']['copy_best_gbs']:.1f} / {s['after']['copy_best_gbs']:.1f} GB/s, "
         f"triad {s['before']['triad_best_gbs']:.1f} / {s['after']['triad_best_gbs']:.1f} GB/s (before / after the "
         f"rounds)"
         + "".join(f"; OpenCL STREAM kernels on {short(d)}: " + ", ".join(
                       f"{loop} {v['before'][key + '_best_gbs']:.1f} / {v['after'][key + '_best_gbs']:.1f}"
                       for loop, key in _opencl_stream_keys(v["before"])) + " GB/s"
                   for d, v in s.get("opencl", {}).items())
         + f"; the fastest {s.get('best_anchor_gbs', s['anchor_gbs']):.1f} GB/s."
         + ("" if "in_rounds" not in s else
            f" In the rounds (STREAM triads over three {s['round_array_mib']} MiB arrays, interleaved with the "
            "kernels, medians): " + ", ".join(f"{k} {v['median_gbs']:.1f} GB/s (best {v['best_gbs']:.1f})"
                                              for k, v in s["in_rounds"].items()))
         + f". **Anchor** of the × STREAM columns and targets: {s['anchor_gbs']:.1f} GB/s"
         + (" (the fastest in-round median)." if "in_rounds" in s else "."), "",
         *([" ".join(["**Lines of zeros.** A streaming fill of one array with 0 and with 1.0, interleaved "
                      "(medians):"] + [f"{short(d)} {v['zeros_median_gbs']:.1f} vs {v['ones_median_gbs']:.1f} "
                                       f"GB/s ({v['zeros_over_ones']:.2f}×);" for d, v in s["fill"].items()]
                     + ["so the copy kernel writes the background wherever the shading kernels do (every pixel "
                        "with no coverage), not 0: the same lines with the same values there (kernels/copy.cl)."]),
            ""] if s.get("fill") else []),
         "In cache: the kernel on the frame's most covered band of "
         f"{CACHE_BAND_PIXELS} px, dispatched twice and the second timed, scaled to the frame by covered "
         "work-items: its instructions without the trip to memory.", "",
         markdown(PERF_RUNTIME_HEADER, _perf_runtime_rows(doc["runtimes"]))]
    L += _perf_noise_lines(doc)
    L += ["", "## Peers (same G-buffer, same rounds; verified against clshade on covered pixels, ≤ 1e-4 relative)", "",
          markdown(["peer", "model", "ms", "max rel diff (all covered)", "max rel diff (well-conditioned)", "verified",
                    "note"], [_perf_peer_row(p) for p in doc["peers"]])]
    L += perf_whole_frame_markdown(doc.get("whole_frames", []))
    L += ["", "## Targets (default build)", "",
          markdown(["runtime", "target", "measured", "met", "cause of the miss (same run)"],
                   [[short(t["runtime"]), t["target"], f"{t['value']:.2f}", "met" if t["met"] else "MISSED",
                     t.get("cause", "")] for t in doc["targets"]])]
    return "\n".join(L) + "\n"


def _perf_runtime_rows(runtimes: list[dict]) -> list[list[str]]:
    """One row per runtime × build × model; a build that failed is one row naming its error."""
    from clshade.bench.perf import short
    rows: list[list[str]] = []
    for rt in runtimes:
        if "error" in rt:
            rows.append([short(rt["device"]), rt["build"], MISSING, f"build failed: {rt['error']}"]
                        + [""] * (len(PERF_RUNTIME_HEADER) - 4))
            continue
        rows += [[short(rt["device"]), rt["build"], rt["simd"], r["name"], cell(r["median_ms"], ".2f"),
                  cell(r["copy_ms"], ".2f"), cell(r["copy_ratio"], ".2f"), cell(r.get("cache_frame_ms"), ".2f"),
                  cell(r.get("copy_cache_frame_ms"), ".2f"), cell(r["gbs"], ".1f"), cell(r["copy_gbs"], ".1f"),
                  cell(r["stream_ratio"], ".2f"), cell(r["copy_stream_ratio"], ".2f"),
                  cell(r["max_rel_diff_vs_first"], ".1e")] for r in rt["models"]]
    return rows


def _perf_peer_row(p: dict) -> list[str]:
    if "skipped" in p:
        return [p["peer"], p["model"], MISSING, MISSING, MISSING, MISSING, f"skipped: {p['skipped']}"]
    note = (f"{p['ill_conditioned_pixels']} pixels with {p['ill_conditioned_why']} checked in the first "
            "column only" if p["ill_conditioned_pixels"] else "")
    return [f"{p['peer']} {p['version']}", p["model"], cell(p["median_ms"], ".2f"), cell(p["max_rel_diff"], ".1e"),
            cell(p["max_rel_diff_well_conditioned"], ".1e"), "yes" if p["verified"] else "NO", note]


def _perf_noise_lines(doc: dict) -> list[str]:
    """Builds of one runtime that compiled the same code (same inline_math,
    streaming_stores and prefetch): their time ratios per kernel are this run's noise band."""
    from clshade.bench.perf import short
    out = []
    by_device: dict[str, list[dict]] = {}
    for rt in doc["runtimes"]:
        if "error" not in rt and "inline_math" in rt:
            by_device.setdefault(rt["device"], []).append(rt)
    for device, rts in by_device.items():
        for i, a in enumerate(rts):
            for b in rts[i + 1:]:
                if all(a.get(k) == b.get(k) for k in ("inline_math", "streaming_stores", "prefetch")):
                    ratios = [ra[k] / rb[k] for ra, rb in zip(a["models"], b["models"]) for k in ("median_ms", "copy_ms")]
                    out.append(f"Noise: on {short(device)} the `{a['build']}` and `{b['build']}` builds are the same "
                               f"code; their kernel times differ by {min(ratios):.2f}–{max(ratios):.2f}× in this run.")
    return [""] + out if out else []


def _opencl_stream_keys(result: dict) -> list[tuple[str, str]]:
    """(label, key) of the OpenCL STREAM loops in one `bandwidth.opencl_stream` result (results
    before streaming stores were measured have only the plain ones)."""
    from clshade.bench import bandwidth
    out = []
    for kind, suffix in bandwidth.STORE_KINDS.items():
        for loop in bandwidth.STREAM_LOOPS:
            if f"{loop}{suffix}_best_gbs" in result:
                out.append((loop if not suffix else f"{loop} ({kind} stores)", loop + suffix))
    return out


def perf_whole_frame_markdown(wfs: list[dict]) -> list[str]:
    """The whole-frame section of the performance document: a (median ms, share) column pair per runtime."""
    from clshade.bench.frame import STAGES
    from clshade.bench.perf import short
    if not wfs:
        return []
    wf = wfs[0]
    rows = []
    for k in (*STAGES, "frame"):
        cells = []
        for w in wfs:
            m = w["median_s"]
            ms = f"{m[k] * 1e3:.1f}"
            cells += [f"**{ms}**" if k == "frame" else ms, f"{m[k] / m['frame']:.0%}"]
        rows.append(["**whole frame**" if k == "frame" else k, *cells])
    if all("block_frame_s" in w for w in wfs):
        rows.append(["whole frame, median of each block",
                     *(c for w in wfs for c in (" / ".join(f"{b * 1e3:.1f}" for b in w["block_frame_s"]), ""))])
    L = ["", f"## Whole frames: {wf['scene']} {wf['width']}×{wf['height']}, {wf['model']}, {wf['triangles']} "
         f"triangles, camera orbiting {wf['step_degrees']}° a frame, {wf['frames']} frames"
         + (f" in {wf['blocks']} blocks (before and after the kernel rounds)" if wf.get("blocks", 1) > 1 else "")
         + (", the runtimes interleaved frame by frame" if len(wfs) > 1 else "")
         + f", host stages on {wf.get('host_threads', '?')} threads", "",
         markdown(["stage", *(h for w in wfs for h in (f"{short(w['device'])} median ms", "share"))], rows)]
    loads = (wfs[0].get("load_average") or []) if all("block_frame_s" in w for w in wfs) else []
    if loads and all(x is not None for x in loads):
        L += ["", "1-minute load average of the machine after each block: "
              + " / ".join(f"{x:.2f}" for x in loads) + " (this benchmark's own threads count in it)."]
    return L

"""`clshade bench` documents (docs/bench-schema.md) as text: what the command prints, its CSV and
plots, and the published 1080p results (benchmarks/results/bench_1080p.md, README.md's regions)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from clshade.report.plots import finish, label_points, pyplot
from clshade.report.tables import MISSING, cell, markdown, write_csv

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


def numpy_sentence(doc: dict, up: str) -> str:
    """numpy_guard_line with a link to the baseline's code (`up`: the path from the published file
    to the repository root)."""
    return numpy_guard_line(doc, f"[{NUMPY_BASELINE_CODE}]({up}{NUMPY_BASELINE_CODE})")


def suspect(doc: dict) -> str:
    """' (suspect)' when the straw-man guard marks the NumPy column, else ''."""
    return " (suspect)" if (doc.get("numpy_guard") or {}).get("suspect") else ""


def provenance_text(doc: dict) -> str:
    """' Commit …; load average … at the start and the end.' from a stamped document ('' without provenance)."""
    p, la = doc.get("provenance") or {}, doc.get("load_average")
    load = lambda a: "/".join(f"{x:g}" for x in a)  # noqa: E731
    out = (f" Commit {(p.get('commit') or 'unknown')[:10]}{' (uncommitted changes)' if p.get('dirty') else ''}."
           if p else "")
    if la:
        out += (f" Load average (1/5/15 min) {load(la['start'])} at the start, {load(la['end'])} at the end "
                f"({doc['machine']['cores']} shared cores).")
    return out


# ---------------------------------------------------------------- `clshade bench`


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
    finish(plt, fig, ax, path, title, legend_size=8)


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
    label_points(ax, [(r["mean_ms"], max(r["mean_rel_error"], 1e-9), r["label"]) for r in rows])
    ax.set_xlabel("mean frame time (ms)")
    ax.set_ylabel("mean relative error vs the ladder's exact model (float64)")
    finish(plt, fig, ax, path, title, legend_size=7)


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


def whole_frame_text(wf: dict) -> str:
    """`clshade bench --whole-frames`: per model the whole frames' FPS and lows, then the stage split
    (median ms per stage; the 0.1 % low only from LOW01_MIN_FRAMES frames)."""
    scene = Path(wf["scene"]).name if wf.get("scene") else "scene"
    path = wf["gbuffer"]
    rows = [[r["name"], r["frames"], cell(r["whole_frame_ms_median"], ".1f"), cell(r["avg_fps"], ".1f"),
             cell(r["low1_fps"], ".1f"),
             cell(low01_fps(r), ".1f"), *(cell(r["stage_ms_median"][s], ".1f") for s in wf["stages"])]
            for r in wf["models"]]
    stage_names = {"rasterize": "triangle setup ms" if path["path"] == "device" else "rasterize ms",
                   "g-buffer": "visibility + g-buffer ms" if path["path"] == "device" else "g-buffer ms"}
    header = ["model", "frames", "median ms", "avg FPS", "1 % low", "0.1 % low",
              *(stage_names.get(s, f"{s} ms") for s in wf["stages"])]
    return "\n".join([f"Whole frames: {scene} {wf['width']}x{wf['height']}, {wf['triangles']} triangles, camera "
                      f"orbiting {wf['step_degrees']:g}° a frame, host stages on {wf['host_threads']} threads, "
                      f"g-buffer: {path['path']} ({path['reason']})"
                      + ("; the next frame's triangle setup overlapping this frame (frame = image to image)"
                         if wf.get("overlap") else ""), markdown(header, rows)])


def bench_plots(doc: dict, path: Path) -> None:
    """The FPS bar chart at `path` and, with ladders, the ladder plot beside it."""
    title = f"{Path(doc['scene']).stem if doc.get('scene') else 'scene'} {doc['width']}x{doc['height']}, " \
            f"{doc['device']['name']}"
    plot_fps(doc["models"], path, title)
    if doc["ladder"]:
        plot_ladder(doc["ladder"], path.with_name(path.stem + "_ladder" + path.suffix), title)


# ---------------------------------------------------------------- published tables


def models_table(rows: list[dict]) -> str:
    """The published per-model table (bench_1080p.md, REPORT.md)."""
    return markdown(
        ["model", "frames", "mean ms", "avg FPS", "1 % low", "0.1 % low", "median ms", "p99 ms", "host ms", "× copy",
         "NumPy ms", "× NumPy", "general ref. f32 ms", "× general ref.", "max rel err", "mean rel err"],
        [[r["label"], r["frames"], f"{r['mean_ms']:.2f}", f"{r['avg_fps']:.1f}", f"{r['low1_fps']:.1f}",
          cell(low01_fps(r), ".0f"), f"{r['median_ms']:.2f}", f"{r['p99_ms']:.2f}", f"{r['host_overhead_ms']:.3f}",
          f"{r['copy_ratio']:.2f}", cell(r["numpy_ms"], ".1f"), cell(r["numpy_ratio"], ".1f"),
          cell(r.get("reference_ms"), ".0f"), cell(r.get("reference_ratio"), ".0f"), cell(r["max_rel_error"], ".2e"),
          cell(r["mean_rel_error"], ".2e")] for r in rows])


def ladder_table(rows: list[dict]) -> str:
    """The published ladder table (bench_1080p.md, REPORT.md)."""
    return markdown(
        ["ladder", "rung", "model", "frames", "mean ms", "copy ×", "max rel err", "mean rel err", "error vs",
         "Pareto"],
        [[r["group"], r["label"], r["model"], r["frames"], f"{r['mean_ms']:.2f}", f"{r['copy_ratio']:.2f}",
          cell(r["max_rel_error"], ".2e"), cell(r["mean_rel_error"], ".2e"), r.get("error_target", ""),
          "●" if r.get("pareto") else ""] for r in rows])


def readme_table(bench: dict) -> str:
    """README's 1080p table: one row per preset of bench_1080p.json, and its footnote."""
    table = markdown(
        ["model", "frames", "mean ms", "avg FPS", "1 % low", "0.1 % low", "× copy kernel",
         f"× faster than NumPy{suspect(bench)}", "max rel err"],
        [[r["label"], r["frames"], f"{r['mean_ms']:.1f}", f"{r['avg_fps']:.0f}", f"{r['low1_fps']:.0f}",
          cell(low01_fps(r), ".0f"), f"{r['copy_ratio']:.2f}", cell(r["numpy_ratio"], ".0f"),
          cell(r["max_rel_error"], ".2e")] for r in bench["models"]])
    device = bench["device"]
    pocl = re.search(r"PoCL [^ ]+", device["platform_version"])
    runtime = f", {pocl.group(0)}" if pocl else ""
    return "\n".join([table, "", f"*From benchmarks/results/bench_1080p.json (measured {bench['created'][:10]}, "
                                 f"device `{device['name']}`{runtime}).{provenance_text(bench)} 0.1 % low only with "
                                 f"≥ {LOW01_MIN_FRAMES} frames. {numpy_sentence(bench, '')}*"])


def targets_table(doc: dict) -> str:
    """The targets against the measured rows (thresholds from the document's `targets`)."""
    t, rows, lights = doc["targets"], doc["models"], doc["lights_scaling"]["rows"]
    worst = max(rows, key=lambda r: r["copy_ratio"])
    lam = next((r for r in rows if r["model"] == "lambert"), None)
    slow_np = min(rows, key=lambda r: r["numpy_ratio"] or float("inf"))
    worst_l = max(lights, key=lambda r: r["ratio"])
    worst_f = max(lights, key=lambda r: r["facing_ratio"])
    host = max(r["host_overhead_ms"] for r in rows)
    bpp = max(r["bytes_per_pixel"] for r in rows)
    ok = lambda c: "**met**" if c else "**missed**"  # noqa: E731
    numpy_verdict = ("not judged (NumPy column suspect)" if suspect(doc) else
                     ok((slow_np["numpy_ratio"] or 0) >= t["numpy_ratio"]))
    return markdown(["target", "measured", ""], [
        [f"every model ≤ {t['copy_ratio']}× copy", f"worst {worst['label']} {worst['copy_ratio']:.2f}×",
         ok(worst["copy_ratio"] <= t["copy_ratio"])],
        [f"Lambert ≤ {t['lambert_copy_ratio']}× copy", f"{lam['copy_ratio']:.2f}×",
         ok(lam["copy_ratio"] <= t["lambert_copy_ratio"])] if lam else ["Lambert", "not run", MISSING],
        [f"≥ {t['numpy_ratio']:g}× faster than the NumPy baseline{suspect(doc)}",
         f"worst {slow_np['label']} {cell(slow_np['numpy_ratio'], '.1f')}×", numpy_verdict],
        [f"4 lights ≤ {t['lights4_ratio']}× one light", f"worst {worst_l['label']} {worst_l['ratio']:.2f}×",
         ok(worst_l["ratio"] <= t["lights4_ratio"])],
        ["(4 lights all facing every pixel)", f"worst {worst_f['label']} {worst_f['facing_ratio']:.2f}×",
         ok(worst_f["facing_ratio"] <= t["lights4_ratio"])],
        [f"host overhead ≤ {t['host_overhead_ms']} ms/frame", f"worst {host:.3f} ms",
         ok(host <= t["host_overhead_ms"])],
        [f"bytes/pixel ≤ {t['bytes_per_pixel']}", f"worst {bpp} B", ok(bpp <= t["bytes_per_pixel"])],
    ])


def bench_1080p_markdown(doc: dict) -> str:
    """benchmarks/results/bench_1080p.md from bench_1080p.json."""
    dev, mach = doc["device"], doc["machine"]
    lights = doc["lights_scaling"]
    md = [f"# clshade bench — sphere_grid {doc['width']}×{doc['height']}", "",
          f"Rendered by `python -m benchmarks.publish` from bench_1080p.json, measured {doc['created']} by "
          f"`{doc['command']}`. Device: {dev['name']} [{dev['platform_version']}], local size "
          f"{dev['local_size']}; machine: {mach['cpu']}, {mach['cores']} CPUs (shared), {mach['os']}. "
          f"One directional light + ambient, precise math, float32 G-buffer; {doc['covered_pixels']} of "
          f"{doc['pixels']} pixels covered.{provenance_text(doc)}", "",
          f"**Frames:** {doc['frames']} timed frames per model after {doc['warmup']} warm-up; models and copy "
          f"kernels interleaved in rounds. Ladder {doc['ladder_frames']} frames, lights scaling {lights['frames']} "
          f"frames. The 0.1 % low is printed only with ≥ {LOW01_MIN_FRAMES} frames.", "",
          "## Per model", "", models_table(doc["models"]), "",
          "Columns: host ms = host (enqueue → wait) − device time per frame; × copy = time / the copy kernel "
          "reading the same channels (bandwidth floor); " + numpy_sentence(doc, "../../")
          + " × general ref. = the float64 frame oracle run in float32 (general: every light kind, shadows, "
          "textures; written for clarity) / OpenCL time; error vs float64 reference "
          f"({doc['error_definition']}).",
          "", "![FPS](bench_1080p.png)", "",
          "## Approximation ladders", "",
          "Error of each rung against the float64 reference of the ladder's exact model; ● = Pareto front "
          "(time vs mean error) within the ladder.", "", ladder_table(doc["ladder"]), "",
          "![ladder](bench_1080p_ladder.png)", "",
          "## Lights scaling (1 vs 4 directional lights, same rounds)", "",
          "4 lights: the scene's light and three turned about the vertical axis in 90° steps (each pixel "
          "faces about half of them); all facing: four copies of the scene's light (no light skipped).", "",
          markdown(["model", "1 light ms", "4 lights ms", "ratio", "4 lights all facing ms", "ratio"],
                   [[r["label"], f"{r['one_light_ms']:.2f}", f"{r['four_lights_ms']:.2f}", f"{r['ratio']:.2f}",
                     f"{r['four_facing_ms']:.2f}", f"{r['facing_ratio']:.2f}"] for r in lights["rows"]]),
          "", "## Targets", "", targets_table(doc), "",
          "What limits each kernel (dated notes): [docs/bench-notes.md](../../docs/bench-notes.md).", ""]
    return "\n".join(md)

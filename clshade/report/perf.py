"""The performance document (clshade.bench.perf: `python -m benchmarks.measure.perf`, `clshade bench
--peers`) as Markdown, and the kernel A/B experiment's table (benchmarks/experiments/kernel_ab.py)."""
from __future__ import annotations

import re

from clshade.report.tables import MISSING, cell, markdown


def short_device(device: str) -> str:
    """'pthread-… [OpenCL 3.0 PoCL 3.1+debian …, LLVM 15.0.6, …]' → 'pthread-… (PoCL 3.1+debian, LLVM 15.0.6)';
    another runtime keeps its platform version: 'AMD EPYC [OpenCL 3.1 LINUX]' → 'AMD EPYC (OpenCL 3.1 LINUX)'."""
    name, _, version = device.partition(" [")
    pocl = re.search(r"PoCL (\S+)", device)
    if not pocl:
        return f"{name} ({version.rstrip(']').strip() or '?'})"
    llvm = re.search(r"LLVM (\S+?),", device)
    return f"{name} (PoCL {pocl.group(1)}, LLVM {llvm.group(1) if llvm else '?'})"


PERF_RUNTIME_HEADER = ("runtime", "build", "SIMD", "model", "ms", "copy ms", "× copy", "in cache ms",
                       "copy in cache ms", "GB/s", "copy GB/s", "× STREAM bound", "copy × STREAM bound",
                       "max rel diff vs first column")


def perf_markdown(doc: dict) -> str:
    """The performance document of clshade.bench.perf (`python -m benchmarks.measure.perf`, `clshade bench
    --peers`) as Markdown, from the JSON document only."""
    s = doc["stream"]
    L = ["# Performance on the runtimes users get", "",
         f"Generated {doc['created']} by `{doc.get('command', '')}` "
         f"on {doc['machine']['cpu']} ({doc['machine']['cores']} cores, {doc['machine']['os']}); "
         f"{doc['scene']} {doc['width']}×{doc['height']}, {doc['rounds']} interleaved rounds"
         + (f" ({doc['timed_run']})" if doc.get("timed_run") else "") + ", medians. "
         "Versions: " + ", ".join(f"{k} {v}" for k, v in doc["versions"].items()) + ".", "",
         "Times are of the shading dispatch alone (OpenCL profiling); the whole-frame figure is below. "
         "Builds: `default` = what clshade builds (kernels/simd.h's inline builtins only where PoCL's AVX-512 "
         "builtin library meets a compiler target without AVX-512), `library` = the OpenCL library's "
         "builtins everywhere (the kernels before simd.h's inline ones; CLSHADE_LIBRARY_MATH=1), `inline` = inline "
         "builtins everywhere (CLSHADE_INLINE_MATH=1), `plain stores` = `default` with the image rows written "
         "by plain stores instead of streaming ones (CLSHADE_CACHED_STORES=1; kernels/simd.h, STORE_ROW8), "
         "`no prefetch` = `default` without the software prefetch of the G-buffer ahead (CLSHADE_NO_PREFETCH=1; "
         "kernels/gbuffer.h, PREFETCH_AHEAD). "
         "Targets are judged on `default`.", "",
         f"**STREAM anchor** ({s['before']['method']}, {s['before']['array_mib']} MiB arrays, best of "
         f"{s['before']['repeats']}): copy {s['before']['copy_best_gbs']:.1f} / {s['after']['copy_best_gbs']:.1f} GB/s, "
         f"triad {s['before']['triad_best_gbs']:.1f} / {s['after']['triad_best_gbs']:.1f} GB/s (before / after the "
         f"rounds)"
         + "".join(f"; OpenCL STREAM kernels on {short_device(d)}: " + ", ".join(
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
                      "(medians):"] + [f"{short_device(d)} {v['zeros_median_gbs']:.1f} vs {v['ones_median_gbs']:.1f} "
                                       f"GB/s ({v['zeros_over_ones']:.2f}×);" for d, v in s["fill"].items()]
                     + ["so the copy kernel writes the background wherever the shading kernels do (every pixel "
                        "with no coverage), not 0: the same lines with the same values there (kernels/copy.cl)."]),
            ""] if s.get("fill") else []),
         "In cache: the kernel on the frame's most covered band of "
         f"{doc['cache_band_pixels']} px, dispatched twice and the second timed, scaled to the frame by covered "
         "work-items: its instructions without the trip to memory.", "",
         markdown(PERF_RUNTIME_HEADER, _perf_runtime_rows(doc["runtimes"]))]
    L += _perf_choice_lines(doc["runtimes"])
    L += _perf_noise_lines(doc)
    L += ["", "## Peers (same G-buffer, same rounds; verified against clshade on covered pixels, ≤ 1e-4 relative)", "",
          markdown(["peer", "model", "ms", "max rel diff (all covered)", "max rel diff (well-conditioned)", "verified",
                    "note"], [_perf_peer_row(p) for p in doc["peers"]])]
    L += perf_whole_frame_markdown(doc.get("whole_frames", []))
    L += ["", "## Targets (default build)", "",
          markdown(["runtime", "target", "measured", "met", "cause of the miss (same run)"],
                   [[short_device(t["runtime"]), t["target"], f"{t['value']:.2f}", "met" if t["met"] else "MISSED",
                     t.get("cause", "")] for t in doc["targets"]])]
    return "\n".join(L) + "\n"


def _perf_runtime_rows(runtimes: list[dict]) -> list[list[str]]:
    """One row per runtime × build × model; a build that failed is one row naming its error."""
    rows: list[list[str]] = []
    for rt in runtimes:
        if "error" in rt:
            rows.append([short_device(rt["device"]), rt["build"], MISSING, f"build failed: {rt['error']}"]
                        + [""] * (len(PERF_RUNTIME_HEADER) - 4))
            continue
        rows += [[short_device(rt["device"]), rt["build"], rt["simd"], r["name"], cell(r["median_ms"], ".2f"),
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


def _perf_choice_lines(runtimes: list[dict]) -> list[str]:
    """What `default` built on each runtime: its build choice (measured on the device, or today's rule)
    and where it came from; the other builds add their one switch to it. Results measured before the
    choices were recorded have none."""
    rows = {(rt["device"], rt["choice"], rt["choice_source"]) for rt in runtimes
            if rt.get("build") == "default" and "choice" in rt}
    if not rows:
        return []
    return ["", "Build choices of `default` (the other builds add their one switch to it): "
            + "; ".join(f"{short_device(d)}: {label} ({source})" for d, label, source in sorted(rows)) + "."]


def _perf_noise_lines(doc: dict) -> list[str]:
    """Builds of one runtime that compiled the same code (same inline_math,
    streaming_stores and prefetch): their time ratios per kernel are this run's noise band."""
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
                    out.append(f"Noise: on {short_device(device)} the `{a['build']}` and `{b['build']}` builds are the same "
                               f"code; their kernel times differ by {min(ratios):.2f}–{max(ratios):.2f}× in this run.")
    return [""] + out if out else []


def _opencl_stream_keys(result: dict) -> list[tuple[str, str]]:
    """(label, key) of the OpenCL STREAM loops in one `bandwidth.opencl_stream` result, in its order:
    `LOOP_best_gbs` (plain stores) and `LOOP_KIND_best_gbs` (KIND stores)."""
    out = []
    for name in result:
        if name.endswith("_best_gbs") and name != "best_gbs":
            key = name.removesuffix("_best_gbs")
            loop, _, kind = key.partition("_")
            out.append((loop if not kind else f"{loop} ({kind} stores)", key))
    return out


def perf_whole_frame_markdown(wfs: list[dict]) -> list[str]:
    """The whole-frame section of the performance document: a (median ms, share) column pair per runtime."""
    if not wfs:
        return []
    wf = wfs[0]
    rows = []
    for k in [*(s for s in wf["median_s"] if s != "frame"), "frame"]:      # the stages as measured, in order
        cells = []
        for w in wfs:
            m = w["median_s"]
            ms = f"{m[k] * 1e3:.1f}"
            cells += [f"**{ms}**" if k == "frame" else ms, f"{m[k] / m['frame']:.0%}"]
        rows.append(["**whole frame**" if k == "frame" else k, *cells])
    if all("low1_fps" in w for w in wfs):
        rows.append(["whole frames' 1 % low, FPS", *(c for w in wfs for c in (f"{w['low1_fps']:.1f}", ""))])
    if all("block_frame_s" in w for w in wfs):
        rows.append(["whole frame, median of each block",
                     *(c for w in wfs for c in (" / ".join(f"{b * 1e3:.1f}" for b in w["block_frame_s"]), ""))])
    L = ["", f"## Whole frames: {wf['scene']} {wf['width']}×{wf['height']}, {wf['model']}, {wf['triangles']} "
         f"triangles, camera orbiting {wf['step_degrees']}° a frame, {wf['frames']} frames"
         + (f" in {wf['blocks']} blocks (before and after the kernel rounds)" if wf.get("blocks", 1) > 1 else "")
         + (", the runtimes interleaved frame by frame" if len(wfs) > 1 else "")
         + f", host stages on {wf.get('host_threads', '?')} threads", "",
         markdown(["stage", *(h for w in wfs for h in (f"{short_device(w['device'])} median ms", "share"))], rows)]
    if all("gbuffer" in w for w in wfs):          # results measured since the frame pipeline chose the path
        L += ["", "Raster and G-buffer: " + "; ".join(f"{short_device(w['device'])}: {w['gbuffer']['path']} "
                                                    f"({w['gbuffer']['reason']})" for w in wfs)
              + " (rasterize = the host's triangle setup where the device makes the visibility buffer and G-buffer)."]
    loads = (wfs[0].get("load_average") or []) if all("block_frame_s" in w for w in wfs) else []
    if loads and all(x is not None for x in loads):
        L += ["", "1-minute load average of the machine after each block: "
              + " / ".join(f"{x:.2f}" for x in loads) + " (this benchmark's own threads count in it)."]
    return L


def kernel_ab_markdown(doc: dict, models: tuple[str, ...]) -> str:
    """benchmarks/experiments/kernel_ab.py's result: per runtime and kernel set, each model's time and × copy."""
    header = ["runtime", "kernels", "SIMD", *(h for m in models for h in (f"{m} ms", "× copy"))]
    lines = [f"{doc['scene']} {doc['width']}×{doc['height']}, {doc['rounds']} interleaved rounds.", ""]
    for stat in ("median", "minimum"):
        rows = [[row["runtime"], row["kernels"], row["simd"],
                 *(c for m in models for c in (f"{row[stat][m + ':shade']:.2f}",
                                               f"{row[stat][m + ':shade'] / row[stat][m + ':copy']:.2f}"))]
                for row in doc["rows"]]
        lines += [f"**{stat}**", "", markdown(header, rows), ""]
    return "\n".join(lines)

"""Regenerate benchmarks/results/bench_1080p.{json,md,csv,png} and the ladder plot.

scenes/sphere_grid.toml at 1920×1080, one directional light, precise math:
every preset (FPS, 1 % / 0.1 % lows, copy and NumPy ratios, error), the
approximation ladders, and 1 vs 4 lights per model (3 directional lights added
to a copy of the scene). 1000 frames per model (the CLI's default) take about
2.5 minutes on the 2-core development machine with the SIMD kernels (one
1080p frame 6–25 ms on PoCL 3.1); the whole script about 6 minutes.

    python benchmarks/run_bench.py [--frames 1000] [--ladder-frames 200] [--lights-frames 200]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from clshade.bench.run import (Bench, frame_stats, ladder_cases, mark_pareto,  # noqa: E402
                               report, run_cases, summarize, with_lights)
from clshade.report import bench_csv as write_csv, bench_table as table, plot_fps, plot_ladder  # noqa: E402
from clshade.models import resolve_many  # noqa: E402

OUT = ROOT / "benchmarks" / "results"
TARGETS = dict(copy_ratio=2.0, lambert_copy_ratio=1.3, numpy_ratio=30.0, lights4_ratio=2.0,
               host_overhead_ms=0.1, bytes_per_pixel=64)

NOTES = """\
## What limits the kernels (measured on this machine)

Default device: Debian's PoCL 3.1 (LLVM 15), preferred over pip's PoCL 3.0-rc2 for its
higher version (clshade.device.runtime). Probe figures below are A/B runs of two kernel sources
in one process, interleaved (2026-11-23, this machine).

* **SIMD across pixels is written by hand.** PoCL runs a work-group as a loop over
  work-items and leaves vectorisation to LLVM's loop vectoriser, which refused every
  one-pixel-per-work-item (float3) shade kernel: `POCL_VECTORIZER_REMARKS=1` printed
  "loop not vectorized: instruction return type cannot be vectorized" — float3 arithmetic,
  and the `<2 x float>` pairs PoCL's SLP pass makes of per-channel colour code (seen in the
  `parallel.bc` left by `POCL_LEAVE_KERNEL_COMPILER_TEMP_FILES=1`). The kernels shade 8
  pixels per work-item in float8 lanes (kernels/simd.h): Lambert 15.5 → 5.9 ms,
  GGX height-correlated 47.7 → 9.6 ms, Phong 61.0 → 15.7 ms at that step.
* **Then, per work-item branches on whole vectors** (nothing vectorises across work-items,
  so a branch costs one compare): a work-item whose 8 pixels are all sky reads only depth
  and writes the background (64 % of this frame is sky; the copy kernel skips the same
  reads, so the floor stays fair — see mean B/px); a light below every lane's horizon adds
  nothing and is skipped (4 lights: −27 %); a material shared by all 8 lanes is one table
  row, not 8 lookups. Normal and base colour are planar on the device (three vector loads
  instead of ~40 shuffles per channel, copy kernel alike: −8 %). PoCL's `exp` and `log2`
  on float8 are slow, so Beckmann uses `exp_lanes` and the Phong power `log2_lanes`
  (Cephes polynomials, brdf.h); every helper is force-inlined (a call spilled every live
  vector register).
* **The remaining gap to the copy kernel is arithmetic**: Blinn–Phong's power
  (a polynomial log2 and an exp2 per light) and the half vector's square root and
  division; Cook–Torrance's exp and divisions; the exact conductor Fresnel is three
  channels of square roots and divisions.
* **4 lights**: in the standard case (lights around the vertical axis) each work-item
  faces about half of them and skips the rest; with four lights facing every pixel the
  specular models pay the full per-light BRDF arithmetic four times (the last column).
* **NumPy ratio**: the NumPy baseline shades the covered pixels only; so do the kernels,
  up to the 8-pixel work-item granularity.
* **Host overhead** (enqueue → wait complete − device time) is ≈ 0.08–0.13 ms and moves
  with the machine's load: it is two thread hand-offs on 2 shared cores (PoCL's worker
  threads wake for the command, the Python thread wakes for its completion). The same
  enqueue → wait of a trivial kernel (1024 work-groups, no G-buffer) takes 0.044 ms of
  which the kernel runs a few µs; local size (16–1024), `POCL_AFFINITY` and spinning
  instead of waiting did not lower it (2026-11-23).
* The machine has 2 shared cores used by other engineers concurrently; absolute times
  vary by up to 2× between runs, so only ratios measured in the same rounds are results.
"""


def lights_scaling(bench: Bench, models, frames: int, warmup: int) -> list[dict]:
    """1 vs 4 lights per model, interleaved in the same rounds: the scene's light plus
    three turned about the vertical axis (with_lights: each pixel faces about half), and
    four copies of the scene's light (every lit pixel faces all four: no light is skipped)."""
    scene = bench.frame.scene
    around = with_lights(scene, 4)
    same = dataclasses.replace(scene, lights=[scene.lights[0]] * 4)
    one = [bench.case(m, label=m.label, numpy=False) for m in models]
    four = [bench.case(m, label=m.label, scene=around, numpy=False) for m in models]
    four_same = [bench.case(m, label=m.label, scene=same, numpy=False) for m in models]
    run_cases(one + four + four_same, frames, warmup)
    mean = lambda c: frame_stats(c.device_ms, c.host_ms)["mean_ms"]  # noqa: E731
    rows = []
    for a, b, c in zip(one, four, four_same):
        t1, t4, t4s = mean(a), mean(b), mean(c)
        rows.append(dict(model=a.model.id, label=a.label, one_light_ms=t1, four_lights_ms=t4, ratio=t4 / t1,
                         four_facing_ms=t4s, facing_ratio=t4s / t1))
    return rows


def target_lines(rows: list[dict], lights: list[dict]) -> list[str]:
    t = TARGETS
    worst = max(rows, key=lambda r: r["copy_ratio"])
    lam = next((r for r in rows if r["model"] == "lambert"), None)
    slow_np = min(rows, key=lambda r: r["numpy_ratio"])
    worst_l = max(lights, key=lambda r: r["ratio"])
    worst_f = max(lights, key=lambda r: r["facing_ratio"])
    host = max(r["host_overhead_ms"] for r in rows)
    bpp = max(r["bytes_per_pixel"] for r in rows)
    ok = lambda c: "**met**" if c else "**missed**"  # noqa: E731
    return [
        f"| every model ≤ {t['copy_ratio']}× copy | worst {worst['label']} {worst['copy_ratio']:.1f}× | "
        f"{ok(worst['copy_ratio'] <= t['copy_ratio'])} |",
        f"| Lambert ≤ {t['lambert_copy_ratio']}× copy | {lam['copy_ratio']:.1f}× | "
        f"{ok(lam['copy_ratio'] <= t['lambert_copy_ratio'])} |" if lam else "| Lambert | not run | — |",
        f"| ≥ {t['numpy_ratio']:.0f}× faster than NumPy float32 | worst {slow_np['label']} {slow_np['numpy_ratio']:.1f}× | "
        f"{ok(slow_np['numpy_ratio'] >= t['numpy_ratio'])} |",
        f"| 4 lights ≤ {t['lights4_ratio']}× one light | worst {worst_l['label']} {worst_l['ratio']:.2f}× | "
        f"{ok(worst_l['ratio'] <= t['lights4_ratio'])} |",
        f"| (4 lights all facing every pixel) | worst {worst_f['label']} {worst_f['facing_ratio']:.2f}× | "
        f"{ok(worst_f['facing_ratio'] <= t['lights4_ratio'])} |",
        f"| host overhead ≤ {t['host_overhead_ms']} ms/frame | worst {host:.3f} ms | {ok(host <= t['host_overhead_ms'])} |",
        f"| bytes/pixel ≤ {t['bytes_per_pixel']} | worst {bpp} B | {ok(bpp <= t['bytes_per_pixel'])} |",
    ]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--ladder-frames", type=int, default=200)
    ap.add_argument("--lights-frames", type=int, default=200)
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    args = ap.parse_args()
    start = time.perf_counter()
    OUT.mkdir(parents=True, exist_ok=True)
    bench = Bench.prepare(ROOT / "scenes" / "sphere_grid.toml", args.width, args.height, lights=1)
    models = resolve_many("all")

    cases = [bench.case(m, label=m.label) for m in models]
    copy_ms = run_cases(cases, args.frames, args.warmup)
    rows = summarize(cases, copy_ms)

    ladder = ladder_cases(bench)
    ladder_rows = summarize(ladder, run_cases(ladder, args.ladder_frames, args.warmup))
    mark_pareto(ladder_rows)

    lights = lights_scaling(bench, models, args.lights_frames, args.warmup)

    doc = report(bench, rows, args.frames, args.warmup, ladder_rows)
    doc["lights_scaling"] = dict(frames=args.lights_frames, rows=lights)
    doc["ladder_frames"] = args.ladder_frames
    doc["targets"] = TARGETS
    stem = OUT / f"bench_{args.height}p"
    stem.with_suffix(".json").write_text(json.dumps(doc, indent=2, ensure_ascii=False), encoding="utf-8")
    write_csv(rows, stem.with_suffix(".csv"))
    title = f"sphere_grid {args.width}x{args.height}, 1 light, {bench.runtime.info.device} (PoCL CPU)"
    plot_fps(rows, stem.with_suffix(".png"), title)
    plot_ladder(ladder_rows, stem.with_name(stem.name + "_ladder.png"), title)

    dev, mach = doc["device"], doc["machine"]
    md = [f"# clshade bench — sphere_grid {args.width}×{args.height}",
          "",
          f"Generated by `python benchmarks/run_bench.py` in {time.perf_counter() - start:.0f} s. "
          f"Device: {dev['name']} [{dev['platform_version']}], local size {dev['local_size']}; "
          f"machine: {mach['processor']}, {mach['cpu_count']} CPUs (shared), {mach['os']}. "
          f"One directional light + ambient, precise math, float32 G-buffer; "
          f"{doc['covered_pixels']} of {doc['pixels']} pixels covered.",
          "",
          f"**Frames:** {args.frames} timed frames per model after {args.warmup} warm-up; models and copy "
          f"kernels interleaved in rounds. Ladder {args.ladder_frames} frames, lights scaling "
          f"{args.lights_frames} frames. The 0.1 % low of {args.frames} frames is the mean of the "
          f"{max(1, args.frames // 1000)} slowest.",
          "",
          "## Per model", "", table(rows), "",
          "Columns: host ms = host (enqueue → wait) − device time per frame; B/px = channels read + 16 B "
          "written for a covered pixel; mean B/px = the same averaged over the frame (a work-item whose "
          "pixels are all empty reads only depth, in the model and the copy kernel alike); × copy = time / the copy kernel reading the same channels (bandwidth floor); × NumPy = "
          "NumPy float32 time (covered pixels only) / OpenCL time; error vs float64 reference "
          f"({doc['error_definition']}).",
          "", "![FPS](bench_1080p.png)", "",
          "## Approximation ladders", "",
          "Error of each rung against the float64 reference of the ladder's exact model; ● = Pareto front "
          "(time vs mean error) within the ladder.", "",
          table(ladder_rows, ladder=True), "", "![ladder](bench_1080p_ladder.png)", "",
          "## Lights scaling (1 vs 4 directional lights, same rounds)", "",
          "4 lights: the scene's light and three turned about the vertical axis in 90° steps (each pixel "
          "faces about half of them); all facing: four copies of the scene's light (no light skipped).", "",
          "| model | 1 light ms | 4 lights ms | ratio | 4 lights all facing ms | ratio |", "|---|---|---|---|---|---|",
          *[f"| {r['label']} | {r['one_light_ms']:.2f} | {r['four_lights_ms']:.2f} | {r['ratio']:.2f} | "
            f"{r['four_facing_ms']:.2f} | {r['facing_ratio']:.2f} |" for r in lights],
          "", "## Targets", "", "| target | measured | |", "|---|---|---|", *target_lines(rows, lights), "",
          NOTES]
    stem.with_suffix(".md").write_text("\n".join(md) + "\n", encoding="utf-8")
    print("\n".join(md))
    print(f"\nwrote {stem}.{{json,md,csv,png}} in {time.perf_counter() - start:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Regenerate benchmarks/results/bench_1080p.{json,md,csv,png} and the ladder plot.

scenes/sphere_grid.toml at 1920×1080, one directional light, precise math:
every preset (FPS, 1 % / 0.1 % lows, copy and NumPy ratios, error), the
approximation ladders, and 1 vs 4 lights per model (3 directional lights added
to a copy of the scene). Frame counts are chosen so the script finishes in
about 6–8 minutes on the 2-core development machine (one 1080p frame takes
50–300 ms there); 1000 frames per model would take about 25 minutes.

    python benchmarks/run_bench.py [--frames 100] [--ladder-frames 20] [--lights-frames 15]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from clshade.bench import (Bench, frame_stats, ladder_cases, mark_pareto, plot_fps, plot_ladder,  # noqa: E402
                           report, run_cases, summarize, table, with_lights, write_csv)
from clshade.models import resolve_many  # noqa: E402

OUT = ROOT / "benchmarks" / "results"
TARGETS = dict(copy_ratio=2.0, lambert_copy_ratio=1.3, numpy_ratio=30.0, lights4_ratio=2.0,
               host_overhead_ms=0.1, bytes_per_pixel=64)

NOTES = """\
## Why the compute targets are missed (measured on this machine)

The default device is now Debian's PoCL 3.1 (LLVM 15), picked over the pip
PoCL 3.0-rc2 because its version is higher (clshade.runtime). Both were inspected with
`POCL_LEAVE_KERNEL_COMPILER_TEMP_FILES=1` and `objdump -d` of the kernel `.so` in
`~/.cache/pocl/kcache/*/*/shade/*/shade.so`.

* **No SIMD across pixels on either PoCL.** The generated shade kernels contain 0 `ymm`
  instructions: PoCL's work-item loop is not vectorised, each pixel runs scalar/`xmm`
  float3 code. 8-wide AVX2 across work-items is the missing factor behind the
  5–24× distance to the copy kernel, the low NumPy ratio and the lights scaling.
* **PoCL 3.1:** builtins and clshade helpers are inlined (0 `call`s in the kernel), yet the
  loop is still not vectorised. **PoCL 3.0-rc2 (pip DISTRO build, LLVM 14):** additionally
  nothing is inlined — its kernel library is built for `target-cpu=haswell`, kernels for
  `znver3` with `"no-builtins"`, and LLVM refuses to inline across the mismatch, so
  `dot`, `rsqrt`, `vload3`, `clamp`, `fmax`, `normalize` and even `make_geometry` are
  per-pixel `call`s; there the same frames took 5–10× longer (Lambert 140 ms vs 16 ms).
  Forcing `__attribute__((always_inline))` on the clshade helpers halved Lambert on 3.0
  (76.7 → 40.0 ms, same run); replacing builtins with `__builtin_sqrtf` etc. gave
  24.6 ms; neither produced `ymm` code, and both edits touch every kernel file (owned by
  others, edited concurrently), so none was applied. Next step: find what blocks PoCL's
  loop vectoriser (`POCL_VECTORIZER_REMARKS=1` printed nothing here; candidates are the
  early `return` for the tail, the float3 structs passed by value, the final select).
* The integer `i % width`, `i / width` per pixel is one `divl` (≈ 10 ns) of the
  ≈ 7–35 ns per pixel the kernels take on PoCL 3.1; not the main cause (left unchanged).
* The copy kernel is bandwidth-bound (≈ 3–4 ms for 45–53 B/pixel × 2.07 Mpixel).
* Host overhead (enqueue → wait complete − device time) is ≈ 0.09–0.11 ms per frame at
  1080p (0.03–0.06 ms at 160×90): the wait is on PoCL worker threads that share the 2
  cores with the Python thread; on PoCL 3.0 under load it reached ≈ 1 ms.
* NumPy ratio: the OpenCL kernels shade all 2.07 Mpixel (background included) without
  SIMD, while the NumPy baseline runs SIMD ufuncs on the 0.74 Mpixel covered pixels only.
* 4 lights cost 1.4–2.5× one light: per-light arithmetic dominates for the empirical and
  Cook–Torrance lobes (pow via exp2/log2, exp in Beckmann), so little fixed cost is shared.
* The machine has 2 shared cores used by other engineers concurrently; absolute times
  vary by up to 3× between runs, so only ratios measured in the same rounds are results.
"""


def lights_scaling(bench: Bench, models, frames: int, warmup: int) -> list[dict]:
    """1 vs 4 lights per model, interleaved in the same rounds."""
    scene4 = with_lights(bench.frame.scene, 4)
    one = [bench.case(m, label=m.label, numpy=False) for m in models]
    four = [bench.case(m, label=m.label, scene=scene4, numpy=False) for m in models]
    run_cases(one + four, frames, warmup)
    rows = []
    for a, b in zip(one, four):
        t1, t4 = frame_stats(a.device_ms, a.host_ms)["mean_ms"], frame_stats(b.device_ms, b.host_ms)["mean_ms"]
        rows.append(dict(model=a.model.id, label=a.label, one_light_ms=t1, four_lights_ms=t4, ratio=t4 / t1))
    return rows


def target_lines(rows: list[dict], lights: list[dict]) -> list[str]:
    t = TARGETS
    worst = max(rows, key=lambda r: r["copy_ratio"])
    lam = next((r for r in rows if r["model"] == "lambert"), None)
    slow_np = min(rows, key=lambda r: r["numpy_ratio"])
    worst_l = max(lights, key=lambda r: r["ratio"])
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
        f"| host overhead ≤ {t['host_overhead_ms']} ms/frame | worst {host:.3f} ms | {ok(host <= t['host_overhead_ms'])} |",
        f"| bytes/pixel ≤ {t['bytes_per_pixel']} | worst {bpp} B | {ok(bpp <= t['bytes_per_pixel'])} |",
    ]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--ladder-frames", type=int, default=20)
    ap.add_argument("--lights-frames", type=int, default=15)
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
          f"**Frames:** {args.frames} timed frames per model after {args.warmup} warm-up (not 1000: one 1080p "
          f"frame takes 15–75 ms (PoCL 3.1) to 300 ms (PoCL 3.0), so 1000 frames × 10 models + copies would take ≈ 10–25 min); "
          f"models and copy kernels interleaved in rounds. Ladder {args.ladder_frames} frames, lights "
          f"scaling {args.lights_frames} frames. With so few frames the 0.1 % low is the single slowest frame.",
          "",
          "## Per model", "", table(rows), "",
          "Columns: host ms = host (enqueue → wait) − device time per frame; B/px = channels read + 16 B "
          "written; × copy = time / the copy kernel reading the same channels (bandwidth floor); × NumPy = "
          "NumPy float32 time (covered pixels only) / OpenCL time; error vs float64 reference "
          f"({doc['error_definition']}).",
          "", "![FPS](bench_1080p.png)", "",
          "## Approximation ladders", "",
          "Error of each rung against the float64 reference of the ladder's exact model; ● = Pareto front "
          "(time vs mean error) within the ladder.", "",
          table(ladder_rows, ladder=True), "", "![ladder](bench_1080p_ladder.png)", "",
          "## Lights scaling (1 vs 4 directional lights, same rounds)", "",
          "| model | 1 light ms | 4 lights ms | ratio |", "|---|---|---|---|",
          *[f"| {r['label']} | {r['one_light_ms']:.2f} | {r['four_lights_ms']:.2f} | {r['ratio']:.2f} |" for r in lights],
          "", "## Targets", "", "| target | measured | |", "|---|---|---|", *target_lines(rows, lights), "",
          NOTES]
    stem.with_suffix(".md").write_text("\n".join(md) + "\n", encoding="utf-8")
    print("\n".join(md))
    print(f"\nwrote {stem}.{{json,md,csv,png}} in {time.perf_counter() - start:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

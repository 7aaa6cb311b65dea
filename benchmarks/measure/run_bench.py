"""Measure benchmarks/results/bench_1080p.{json,csv,png} and the ladder plot (JSON only: the Markdown
bench_1080p.md and README's table are rendered from the JSON by `python -m benchmarks.publish`).

scenes/sphere_grid.toml at 1920×1080, one directional light, precise math:
every preset (FPS, 1 % / 0.1 % lows, copy, NumPy-baseline and general-reference ratios, error,
the straw-man guard of the NumPy column), the
approximation ladders, and 1 vs 4 lights per model (3 directional lights added
to a copy of the scene), 1000 frames per model (the CLI's default).

    python -m benchmarks.measure.run_bench [--frames 1000] [--ladder-frames 200] [--lights-frames 200]
    python -m benchmarks.publish
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time

from benchmarks.publish.results_io import RESULTS, ROOT, load_average, write_result
from clshade.bench.run import Bench, frame_stats, ladder_cases, mark_pareto, report, run_cases, summarize, with_lights
from clshade.models.registry import Registry
from clshade.report.bench import bench_csv, plot_fps, plot_ladder
# numpy_ratio: against the NumPy baseline a NumPy user would write (clshade/bench/numpy_baseline.py). The
# kernel runs on every core with 8-wide SIMD in one pass over memory; the baseline's ufuncs run on one
# thread and make a pass per operation: the kernel should be at least 5× faster for every model.
TARGETS = dict(copy_ratio=2.0, lambert_copy_ratio=1.3, numpy_ratio=5.0, lights4_ratio=2.0,
               host_overhead_ms=0.1, bytes_per_pixel=64)



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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--ladder-frames", type=int, default=200)
    ap.add_argument("--lights-frames", type=int, default=200)
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    args = ap.parse_args()
    start, at_start = time.perf_counter(), load_average()
    bench = Bench.prepare(ROOT / "scenes" / "sphere_grid.toml", args.width, args.height, lights=1)
    models = Registry().resolve_many("all")

    cases = [bench.case(m, label=m.label) for m in models]
    guard = bench.guard()
    copy_ms = run_cases(cases, args.frames, args.warmup, guard=guard)
    rows = summarize(cases, copy_ms)

    ladder = ladder_cases(bench)
    ladder_rows = summarize(ladder, run_cases(ladder, args.ladder_frames, args.warmup))
    mark_pareto(ladder_rows)

    lights = lights_scaling(bench, models, args.lights_frames, args.warmup)

    doc = report(bench, rows, args.frames, args.warmup, ladder_rows, guard=guard)
    doc["lights_scaling"] = dict(frames=args.lights_frames, rows=lights)
    doc["ladder_frames"] = args.ladder_frames
    doc["targets"] = TARGETS
    doc["seconds"] = round(time.perf_counter() - start, 1)
    doc["load_average"] = dict(start=at_start, end=load_average())
    stem = RESULTS / f"bench_{args.height}p"
    write_result(stem.with_suffix(".json"), doc, bench.runtime.info.description)
    bench_csv(rows, stem.with_suffix(".csv"))
    title = f"sphere_grid {args.width}x{args.height}, 1 light, {bench.runtime.info.device} (PoCL CPU)"
    plot_fps(rows, stem.with_suffix(".png"), title)
    plot_ladder(ladder_rows, stem.with_name(stem.name + "_ladder.png"), title)

    print(f"wrote {stem}.{{csv,png}} in {time.perf_counter() - start:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Measure benchmarks/results/tuning.json: on every healthy CPU runtime of this machine, the tuner's race
afresh, then every build choice it raced on a full frame per model beside today's rule and the tuned
pick, the tuned build against the fastest, each model's ratio to its copy kernel, the cached key, and
the race of the runtimes (clshade.bench.tuning; JSON only: `python -m benchmarks.publish` renders
tuning.md). Run it on a quiet machine: it writes the tuner's cache entries as a first run would.

    python -m benchmarks.measure.tuning [--rounds 30] [--models all]
"""
from __future__ import annotations

import argparse
import sys

from benchmarks.publish.results_io import RESULTS, load_average, write_result
from clshade.bench.tuning import measure
from clshade.resources import scenes_dir


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(scenes_dir() / "sphere_grid.toml"))
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--models", default="all", help="comma-separated models, a group or 'all' (default)")
    ap.add_argument("--rounds", type=int, default=30)
    ap.add_argument("--warmup", type=int, default=2)
    ap.add_argument("--out", default=str(RESULTS / "tuning.json"))
    args = ap.parse_args(argv)
    start = load_average()
    doc = measure(args.scene, args.width, args.height, args.models, args.rounds, args.warmup)
    doc.update(command="python -m benchmarks.measure.tuning " + " ".join(sys.argv[1:] if argv is None else argv),
               load_average={"start": start, "end": load_average()})
    write_result(args.out, doc)          # every CPU runtime: the host
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

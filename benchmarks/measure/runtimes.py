"""Measure benchmarks/results/runtimes.json: every OpenCL runtime present on one frame, its health,
what each build gets, kernel times and the error against the float64 oracle (clshade.bench.runtimes;
JSON only: `python -m benchmarks.publish` renders runtimes.md).

    python -m benchmarks.measure.runtimes [--rounds 100]
"""
from __future__ import annotations

import argparse

from benchmarks.publish.results_io import RESULTS, load_average, write_result
from clshade.bench.runtimes import measure
from clshade.resources import scenes_dir


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(scenes_dir() / "sphere_grid.toml"))
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--rounds", type=int, default=100)
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--out", default=str(RESULTS / "runtimes.json"))
    args = ap.parse_args(argv)
    start = load_average()
    doc = measure(args.scene, args.width, args.height, args.rounds, args.warmup)
    doc.update(command=f"python -m benchmarks.measure.runtimes --rounds {args.rounds}",
               load_average={"start": start, "end": load_average()})
    write_result(args.out, doc)          # every runtime: the host
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

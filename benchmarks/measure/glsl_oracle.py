"""Every .brdf file against a real GLSL compiler (clshade.verify.glsl_oracle): the project's
scenes/lobes/*.brdf and, where it is there, BRDF Explorer's collection (../shared/assets/brdf-explorer
beside the repository, or --collection), each at its parameter sets (glsl_oracle.parameter_sets),
written to benchmarks/results/glsl_oracle.json. JSON only: `python -m benchmarks.publish` renders
benchmarks/results/glsl_oracle.md from it.

    python -m benchmarks.measure.glsl_oracle [--collection DIR] && python -m benchmarks.publish
"""
from __future__ import annotations

import argparse
import datetime as _dt
import time
from pathlib import Path

from benchmarks.publish.results_io import RESULTS, ROOT, write_result
from clshade.device.runtime import get_runtime
from clshade.errors import ClshadeError
from clshade.verify import glsl_oracle as G

OUT = RESULTS / "glsl_oracle.json"
LOBES = ROOT / "scenes" / "lobes"
COLLECTION = ROOT.parent / "shared" / "assets" / "brdf-explorer"
SETS = ("defaults", "quarter", "three quarters")         # glsl_oracle.parameter_sets, in order


def measure(collection: Path, count: int) -> dict:
    why = G.unavailable()
    if why:
        raise ClshadeError(f"no GLSL oracle here: {why}")
    rt = get_runtime()
    points = G.directions(count)
    files = [("scenes/lobes", p) for p in sorted(LOBES.glob("*.brdf"))]
    files += [("BRDF Explorer", p) for p in sorted(collection.glob("*.brdf"))]
    rows = []
    for origin, path in files:
        for name, values in zip(SETS, G.parameter_sets(path)):
            c = G.compare(path, values, points=points, runtime=rt)
            rows.append(dict(file=path.name, origin=origin, set=name, values={k: list(v) for k, v in values.items()},
                             compared=c.compared, below=c.below, undefined=c.undefined, undefined_by=c.undefined_by,
                             singular=c.singular, finite_mismatch=c.finite_mismatch, max_rel=c.max_rel,
                             median_rel=c.median_rel, conditioned=c.conditioned, max_excess=c.max_excess,
                             agrees=c.agrees))
    return dict(schema=2, created=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                device=rt.info.description, mesa=G.renderer(), points=count, jitters=G.JITTERS,
                conditioning_factor=G.CONDITIONING_FACTOR, tolerance=G.TOLERANCE,
                command="python -m benchmarks.measure.glsl_oracle", rows=rows)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--collection", type=Path, default=COLLECTION)
    parser.add_argument("--points", type=int, default=10_000)
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args()
    start = time.perf_counter()
    doc = measure(args.collection, args.points)
    doc["seconds"] = round(time.perf_counter() - start, 1)
    write_result(args.out, doc, get_runtime().info.description)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

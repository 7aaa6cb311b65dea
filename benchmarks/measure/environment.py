"""Measure benchmarks/results/environment.json: the environment ladder (clshade.bench.environment: every model ×
rung × N, error against the float64 truth beside device time per frame, and the sky's precompute) on
scenes/environment.toml under its own map and under two CC0 maps of shared/assets/hdri (one with a sun ~3e4 ×
the mean), each skipped with its reason when absent; and the error-vs-time plot beside the JSON. JSON only:
`python -m benchmarks.publish` renders environment.md.

    python -m benchmarks.measure.environment [--width 80] [--frames 5] [--samples 1,4,16,64,256,1024]

The defaults keep the run near 5 minutes on 2 quiet cores: an 80×80 frame and 5 timed frames (N = 1024
costs ~0.5 s a frame there; the 0.1 % low of 5 frames is the slowest), 128 truth pixels on the 128×64 map
and 32 with one cell per texel on the 1024×512 ones (the truth's cost grows with pixels × texels).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from benchmarks.publish.results_io import RESULTS, ROOT, load_average, write_result
from clshade.bench.environment import parse_samples, run_environment_bench
from clshade.models.registry import Registry
from clshade.render.scene import load_scene
from clshade.resources import scenes_dir

HDRI = ROOT.parent / "shared" / "assets" / "hdri"
#: The CC0 maps beside the project's own: city has a sun (~3.1e4 × the mean luminance), studio has none
#: (its brightest texel ~1e3 × the mean).
MAPS = ("city.exr", "studio.exr")
#: The study's question under environment light: Lambert, an empirical lobe and two microfacet ones.
MODELS = "lambert,blinn_phong,ggx_correlated,cook_torrance"


def skies(hdri: Path) -> tuple[list[Path | None], list[dict]]:
    """The skies to run (None: the scene's own map) and those skipped, with their reason."""
    run: list[Path | None] = [None]
    skipped = []
    for name in MAPS:
        path = hdri / name
        if path.is_file():
            run.append(path)
        else:
            skipped.append(dict(map=str(path), reason=f"{path} is absent (the CC0 maps of shared/assets/hdri)"))
    return run, skipped


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(scenes_dir() / "environment.toml"))
    ap.add_argument("--hdri", default=str(HDRI), help="folder of the CC0 maps (skipped when absent)")
    ap.add_argument("--width", type=int, default=80)
    ap.add_argument("--height", type=int, default=80)
    ap.add_argument("--models", default=MODELS)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--warmup", type=int, default=1)
    ap.add_argument("--samples", default="1,4,16,64,256,1024", help="the N ladder of the sampled rungs")
    ap.add_argument("--own-pixels", type=int, default=128, help="truth pixels under the scene's own map")
    ap.add_argument("--hdri-pixels", type=int, default=32, help="truth pixels under a 1024×512 map")
    ap.add_argument("--out", default=str(RESULTS / "environment.json"))
    args = ap.parse_args(argv)
    start = load_average()
    scene = load_scene(args.scene)
    models = Registry().resolve_many(args.models)
    samples = parse_samples(args.samples)
    run, skipped = skies(Path(args.hdri))
    docs = []
    for path in run:
        sc = scene if path is None else dataclasses.replace(
            scene, environment=dataclasses.replace(scene.environment, map=path))
        own = path is None
        print(f"environment ladder: {sc.environment.map.name}", file=sys.stderr, flush=True)
        docs.append(run_environment_bench(sc, models, args.frames, args.warmup, width=args.width,
                                          height=args.height, samples=samples,
                                          oracle_pixels=args.own_pixels if own else args.hdri_pixels,
                                          oracle_subdivisions=2 if own else 1))
    doc = dict(command="python -m benchmarks.measure.environment " + " ".join(sys.argv[1:] if argv is None else argv),
               runs=docs, skipped=skipped, load_average={"start": start, "end": load_average()})
    out = Path(args.out)
    write_result(out, doc)
    from clshade.report.environment import environment_plot
    environment_plot(docs, out.with_suffix(".png"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

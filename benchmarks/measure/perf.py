"""Measure benchmarks/results/perf_1080p.json: every healthy CPU runtime and build, the copy
kernels, the peers, the STREAM anchor, whole frames and the targets (clshade.bench.perf; JSON only:
`python -m benchmarks.publish` renders perf_1080p.md). Run it on a quiet machine, with the peers
installed (`pip install -e '.[bench,peers]'`).

    python -m benchmarks.measure.perf [--rounds 200] [--frame-frames 30] [--peers numba,drjit] [--gbuffer auto]

The whole frames go through the frame pipeline of `clshade render` and `clshade bench --whole-frames`
(clshade.bench.frame, clshade.pipeline.GBufferStage): the device's visibility buffer and G-buffer
where verified on each runtime, else the NumPy rasterizer; each runtime's result names its path.
"""
from __future__ import annotations

import argparse
import sys

from benchmarks.publish.results_io import RESULTS, write_result
from clshade.bench import perf
from clshade.pipeline import GBUFFER_MODES, use_gbuffer


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="scenes/sphere_grid.toml")
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--rounds", type=int, default=200)
    ap.add_argument("--warmup", type=int, default=10)
    ap.add_argument("--frame-scene", default="scenes/robot.toml")
    ap.add_argument("--frame-frames", type=int, default=30,
                    help="whole frames per runtime (half before the rounds, half after)")
    ap.add_argument("--peers", default="numba,drjit")
    ap.add_argument("--gbuffer", choices=GBUFFER_MODES, default="auto",
                    help="the whole frames' raster and G-buffer path (clshade render --gbuffer)")
    ap.add_argument("--out", default=str(RESULTS / "perf_1080p.json"))
    a = ap.parse_args(argv)
    with use_gbuffer(a.gbuffer):
        doc = perf.run(a.scene, a.width, a.height, a.rounds, a.warmup, a.frame_scene, a.frame_frames,
                       tuple(p for p in a.peers.split(",") if p))
    doc["command"] = "python -m benchmarks.measure.perf " + " ".join(sys.argv[1:] if argv is None else argv)
    write_result(a.out, doc)             # PoCL CPU and the NumPy/Numba/Dr.Jit peers: the host's CPU
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

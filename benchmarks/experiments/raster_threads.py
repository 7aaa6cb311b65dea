"""Does the rasterizer's triangle setup or coverage gain from the worker threads on this
machine? Each configuration (setup split or not × coverage grids shared out or not) rasterizes
the same orbit cameras, frame by frame in turns (a noisy spell falls on all of them), after a
check that all four give the same fragments bit for bit. Prints medians; stores nothing (the
thresholds it informs are SETUP_PARALLEL_MIN_FACES in raster/triangles.py and
COVER_PARALLEL_MIN_CELLS in raster/tiles.py; the viewer's published figures come from
benchmarks/measure/view_bench.py).

Usage::

    python -m benchmarks.experiments.raster_threads [--scene scenes/robot.toml] [--size 960x540] [--frames 60] [--rounds 3]
"""
from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ("setup 1, cover 1", "setup N, cover 1", "setup 1, cover N", "setup N, cover N")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default=str(ROOT / "scenes" / "robot.toml"))
    parser.add_argument("--size", default="960x540", help="WIDTHxHEIGHT (default 960x540)")
    parser.add_argument("--frames", type=int, default=60, help="orbit cameras 1 degree apart (default 60)")
    parser.add_argument("--rounds", type=int, default=3, help="passes over the cameras (default 3)")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.lower().split("x"))

    from clshade.render.arrays import keep_freed_memory, worker_count
    from clshade.render.meshes import build_geometry
    from clshade.render.raster import RasterMesh, rasterize_mesh, tiles, triangles
    from clshade.render.scene import load_scene
    from clshade.view.session import Orbit

    keep_freed_memory()
    scene = load_scene(args.scene)
    geometry = build_geometry(scene)
    mesh = RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
    camera = scene.camera.with_size(width, height)
    orbit = Orbit.of(camera)
    cameras = [dataclasses.replace(camera, position=orbit.position(float(k), orbit.elevation, orbit.distance))
               for k in range(args.frames)]

    def use(config: str) -> None:
        triangles.SETUP_PARALLEL_MIN_FACES = 1 if "setup N" in config else 1 << 62
        tiles.COVER_PARALLEL_MIN_CELLS = 1 if "cover N" in config else 1 << 62

    def frame(c):
        return rasterize_mesh(mesh, c.view_matrix(), c.projection_matrix(), c.width, c.height)

    first = None
    for config in CONFIGS:            # the same fragments whichever way the work is shared
        use(config)
        f = frame(cameras[len(cameras) // 2])
        got = (f.pixels, f.face, f.face_depth, f.face_bary)
        if first is None:
            first = got
        elif not all(np.array_equal(a, b) for a, b in zip(first, got)):
            print(f"{config}: fragments differ from {CONFIGS[0]}", file=sys.stderr)
            return 1
    times: dict[str, list[float]] = {c: [] for c in CONFIGS}
    for _ in range(args.rounds):
        for c in cameras:
            for config in CONFIGS:
                use(config)
                t0 = time.perf_counter()
                frame(c)
                times[config].append(time.perf_counter() - t0)
    base = statistics.median(times[CONFIGS[0]])
    print(f"{Path(args.scene).name} at {width}x{height}, {len(geometry.faces)} faces, {worker_count()} worker "
          f"threads, {args.frames} cameras x {args.rounds} rounds:")
    for config in CONFIGS:
        m = statistics.median(times[config])
        print(f"  {config}: rasterize {1e3 * m:6.2f} ms (median), {m / base:.2f} x {CONFIGS[0]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

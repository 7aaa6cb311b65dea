"""Two source trees of clshade side by side: are their rasterizer and G-buffer outputs
bitwise the same, and how do their times compare (interleaved, same frames)?

Usage::

    python -m benchmarks.experiments.raster_ab identical OTHER_TREE [--scenes scenes/*.toml]
    python -m benchmarks.experiments.raster_ab time OTHER_TREE [--frames 30] [--rounds 5] [--clock process_time]

OTHER_TREE is a checkout of another commit (e.g. `git worktree add /tmp/main main`, or
`git archive main | tar -x -C DIR`); this script's own tree is the other side. Each tree
runs in a worker process of its own (this file run by path, PYTHONPATH set to the tree: the
other tree need not have this module), so the two never share an import.

- ``identical``: every scene × 4 cameras (the scene's own; an orbit view at 960×540; a close
  view whose near plane cuts the scene; a grazing view with a supersampled, jittered raster):
  the Fragments (pixels, face, depth, barycentrics) and every G-buffer plane, compared byte
  for byte. Exit status 1 on any difference.
- ``time``: the robot at 960×540 over `frames` orbit cameras 1° apart (as the viewer makes
  them), rasterize and G-buffer timed separately; the two workers take turns frame by frame
  for `rounds` rounds. Prints medians and the ratio (this tree / other). Timings are printed,
  not stored: the published figures come from benchmarks/measure/view_bench.py.
"""
from __future__ import annotations

import argparse
import dataclasses
import glob
import json
import os
import pickle
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
ROBOT = ROOT / "scenes" / "robot.toml"


# ------------------------------------------------------------------ worker side (runs in one tree)

def _cameras(scene):
    """The four cameras of the identity check."""
    from clshade.render.samples import jittered, supersampled
    from clshade.view.session import Orbit
    cam = scene.camera
    orbit = Orbit.of(cam)
    wide = cam.with_size(960, 540)
    return {
        "scene": cam,
        "orbit": dataclasses.replace(wide, position=orbit.position(37.0, orbit.elevation + 10.0, orbit.distance)),
        "close": dataclasses.replace(wide, position=orbit.position(200.0, orbit.elevation, 0.25 * orbit.distance)),
        "grazing": supersampled(jittered(dataclasses.replace(cam.with_size(320, 180), position=orbit.position(
            290.0, 1.5, 1.2 * orbit.distance)), 0.25, -0.25), 2),
    }


def _raster(geometry):
    """camera → Fragments: the way the viewer rasterizes (one RasterMesh kept for all views) where the
    tree has RasterMesh, else rasterize()."""
    from clshade.render import raster
    if hasattr(raster, "RasterMesh"):
        mesh = raster.RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
        return lambda c: raster.rasterize_mesh(mesh, c.view_matrix(), c.projection_matrix(), c.width, c.height)
    return lambda c: raster.rasterize(geometry.vertices, geometry.faces, c.view_matrix(), c.projection_matrix(),
                                      c.width, c.height, cull_backfaces=geometry.cull)


def _frame(scene, geometry, camera, raster, faces=None, pool=None, clock=time.perf_counter):
    from clshade.render.gbuffer import build_gbuffer
    t0 = clock()
    frags = raster(camera)
    t1 = clock()
    gbuffer = build_gbuffer(scene, geometry, frags, camera, faces=faces, pool=pool)
    t2 = clock()
    return frags, gbuffer, t1 - t0, t2 - t1


def _dump(paths: list[str]) -> dict:
    """scene → camera → name → bytes of every output array."""
    from clshade.render.meshes import build_geometry
    from clshade.render.scene import load_scene
    out = {}
    for path in paths:
        scene = load_scene(path)
        geometry = build_geometry(scene)
        raster = _raster(geometry)
        for name, camera in _cameras(scene).items():
            frags, gbuffer, _, _ = _frame(scene, geometry, camera, raster)
            arrays = {"pixels": frags.pixels, "face": frags.face, "face_depth": frags.face_depth,
                      "face_bary": frags.face_bary, "coverage": gbuffer.coverage,
                      "materials": gbuffer.materials, "nonfinite": gbuffer.nonfinite_pixels}
            arrays.update({f"plane:{c}": gbuffer.plane(c) for c in gbuffer.channels})
            out[f"{Path(path).name} / {name}"] = {
                k: (str(getattr(v, "dtype", type(v))), getattr(v, "shape", ()), bytes(memoryview(
                    __import__("numpy").ascontiguousarray(v)).cast("B")) if hasattr(v, "dtype") else v)
                for k, v in arrays.items()}
    return out


def _serve_timing(frames: int, clock_name: str) -> None:
    """Answer 'i' lines with the rasterize and G-buffer seconds of orbit camera i."""
    clock = getattr(time, clock_name)
    from clshade.render.arrays import PlanePool, keep_freed_memory
    from clshade.render.gbuffer import face_planes
    from clshade.render.meshes import build_geometry
    from clshade.render.scene import load_scene
    from clshade.view.session import Orbit
    keep_freed_memory()
    scene = load_scene(ROBOT)
    geometry = build_geometry(scene)
    cam = scene.camera.with_size(960, 540)
    orbit = Orbit.of(cam)
    cams = [dataclasses.replace(cam, position=orbit.position(float(k), orbit.elevation, orbit.distance))
            for k in range(frames)]
    faces, pool, raster = face_planes(geometry, list(scene.materials.values())), PlanePool(), _raster(geometry)
    for c in cams[:5]:                                   # warm-up
        _frame(scene, geometry, c, raster, faces, pool)
    print("ready", flush=True)
    for line in sys.stdin:
        _, _, raster_s, gbuffer_s = _frame(scene, geometry, cams[int(line)], raster, faces, pool, clock)
        print(json.dumps([raster_s, gbuffer_s]), flush=True)


# ------------------------------------------------------------------ driver side

def _worker(tree: Path, *args: str, **kw) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(tree))
    return subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "_worker", *args], cwd=tree, env=env,
                            **kw)


def identical(other: Path, scenes: list[str]) -> int:
    dumps = {}
    for label, tree in (("this", ROOT), ("other", other)):
        proc = _worker(tree, "dump", *[str(Path(s).resolve()) for s in scenes], stdout=subprocess.PIPE)
        data, _ = proc.communicate()
        if proc.returncode:
            raise SystemExit(f"{label} tree ({tree}): worker failed")
        dumps[label] = pickle.loads(data)
    bad = 0
    for key, arrays in dumps["other"].items():
        mine = dumps["this"].get(key, {})
        diff = sorted(k for k in arrays.keys() | mine.keys() if arrays.get(k) != mine.get(k))
        covered = len(arrays["pixels"][2]) // 8
        print(f"{key:40s} {covered:8d} covered  {'identical' if not diff else 'DIFFERENT: ' + ', '.join(diff)}")
        bad += bool(diff)
    print(f"{len(dumps['other'])} frames, {len(dumps['other']) - bad} identical, {bad} different")
    return 1 if bad else 0


def timing(other: Path, frames: int, rounds: int, clock: str) -> int:
    workers = {label: _worker(tree, "time", str(frames), clock, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
               for label, tree in (("this", ROOT), ("other", other))}
    for w in workers.values():
        assert w.stdout.readline().strip() == "ready"
    times: dict[str, list] = {label: [] for label in workers}
    for r in range(rounds):
        for i in range(frames):
            order = list(workers) if (r + i) % 2 == 0 else list(workers)[::-1]
            for label in order:
                w = workers[label]
                w.stdin.write(f"{i}\n")
                w.stdin.flush()
                times[label].append(json.loads(w.stdout.readline()))
    for w in workers.values():
        w.stdin.close()
        w.wait()
    med = {label: [statistics.median(t[k] for t in ts) * 1e3 for k in range(2)] for label, ts in times.items()}
    for label in workers:
        r, g = med[label]
        print(f"{label:6s} rasterize {r:6.1f} ms  g-buffer {g:6.1f} ms  both {r + g:6.1f} ms (medians of "
              f"{len(times[label])} frames)")
    (ra, ga), (rb, gb) = med["this"], med["other"]
    print(f"ratio this/other: rasterize {ra / rb:.2f}  g-buffer {ga / gb:.2f}  both {(ra + ga) / (rb + gb):.2f}")
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "_worker":
        if argv[1] == "dump":
            sys.stdout.buffer.write(pickle.dumps(_dump(argv[2:])))
        else:
            _serve_timing(int(argv[2]), argv[3])
        return 0
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=("identical", "time"))
    parser.add_argument("other", type=Path, help="the other source tree")
    parser.add_argument("--scenes", nargs="*", default=sorted(glob.glob(str(ROOT / "scenes" / "*.toml"))))
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--clock", choices=("perf_counter", "process_time"), default="perf_counter",
                        help="wall time, or the CPU time of the worker's threads (less disturbed by other "
                             "processes on a busy machine; with CLSHADE_THREADS=1 the work itself)")
    args = parser.parse_args(argv)
    if args.mode == "identical":
        return identical(args.other.resolve(), args.scenes)
    return timing(args.other.resolve(), args.frames, args.rounds, args.clock)


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark the NumPy rasterizer against Embree first-hit ray casting.

Usage::

    python -m benchmarks.measure.raster_bench [--out benchmarks/results/raster.json]

For each scene (the Stanford bunny from ``../shared/assets`` when present, and
a displaced 327,680-triangle icosphere) at 1920x1080 it times, in the same
run and interleaved (so machine noise hits both alike):

* ``clshade.render.raster.rasterize`` (everything: transform, clip, raster, resolve,
  barycentrics), with back faces kept (same visibility as the ray caster) and
  with back-face culling;
* trimesh + embreex ``mesh.ray.intersects_first`` for all pixel-centre rays
  (rays built beforehand, BVH built beforehand: both excluded from the time).

It also rasterizes a 1,310,720-triangle mesh and reports the peak memory
allocated during the call (tracemalloc sees NumPy's allocations).  Results go
to a JSON file; ``python -m benchmarks.publish`` renders the Markdown table next to it (same name, ``.md``).
"""
from __future__ import annotations

import argparse
import resource
import time
import tracemalloc
from pathlib import Path

import numpy as np
import trimesh

from benchmarks.publish.results_io import RESULTS, ROOT, write_result
from clshade.render.gbuffer import build_gbuffer
from clshade.render.meshes import Geometry
from clshade.render.raster import rasterize
from clshade.render.scene import parse_scene
from clshade.render.transforms import look_at, perspective, pixel_rays

ASSETS = ROOT.parent / "shared" / "assets"
BUNNY = ASSETS / "stanford-bunny" / "stanford-bunny.obj"


def scenes(width: int, height: int):
    """(name, mesh, view, proj) of the benchmark scenes."""
    out = []
    if BUNNY.is_file():
        bunny = trimesh.load(BUNNY, process=False, force="mesh")
        c = bunny.bounds.mean(axis=0)
        r = np.linalg.norm(bunny.bounds[1] - bunny.bounds[0]) / 2
        out.append(("stanford-bunny", bunny,
                    look_at(c + np.array([0.15, 0.1, 1.0]) * 1.9 * r, c),
                    perspective(40.0, width / height, 0.01, 10.0)))
    else:
        print(f"skipping the Stanford bunny: {BUNNY} not found (assets live beside the checkout)")
    sphere = trimesh.creation.icosphere(subdivisions=7)
    v = sphere.vertices
    v = v * (1.0 + 0.06 * np.sin(9.0 * v[:, 0]) * np.cos(7.0 * v[:, 1]) * np.sin(5.0 * v[:, 2]))[:, None]
    out.append(("displaced-icosphere-7", trimesh.Trimesh(v, sphere.faces, process=False),
                look_at((0.4, 0.3, 2.6), (0.0, 0.0, 0.0)),
                perspective(45.0, width / height, 0.1, 100.0)))
    return out


def gbuffer_inputs(mesh):
    """A one-material scene and the Geometry of `mesh`, for timing the full G-buffer stage."""
    scene = parse_scene("[camera]\nposition = [0.0, 0.0, 1.0]\n[materials.m]\nroughness = 0.5\n")
    n = len(mesh.faces)
    geometry = Geometry(np.asarray(mesh.vertices, float), np.asarray(mesh.vertex_normals, np.float32),
                        np.asarray(mesh.faces, np.int64), np.zeros(n, np.int32), np.zeros(n, np.int32),
                        np.ones(n, bool))
    return scene, geometry


def bench_scene(name, mesh, view, proj, width, height, repeats):
    verts = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
    faces = np.ascontiguousarray(mesh.faces, dtype=np.int64)
    origins, dirs = pixel_rays(view, proj, width, height)
    intersector = mesh.ray
    t0 = time.perf_counter()
    intersector.intersects_first(origins[:1], dirs[:1])  # builds the BVH
    bvh_s = time.perf_counter() - t0
    ids = intersector.intersects_first(origins, dirs).reshape(height, width)
    frag = rasterize(verts, faces, view, proj, width, height, cull_backfaces=False)
    rasterize(verts, faces, view, proj, width, height, cull_backfaces=True)
    union = frag.coverage | (ids >= 0)
    agreement = float((frag.tri_id == ids)[union].mean())

    scene, geometry = gbuffer_inputs(mesh)
    t_keep, t_cull, t_embree, t_full = [], [], [], []
    for _ in range(repeats):  # interleaved: noise affects all alike
        t0 = time.perf_counter()
        build_gbuffer(scene, geometry, rasterize(verts, faces, view, proj, width, height, cull_backfaces=geometry.cull))
        t_full.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        rasterize(verts, faces, view, proj, width, height, cull_backfaces=False)
        t_keep.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        rasterize(verts, faces, view, proj, width, height, cull_backfaces=True)
        t_cull.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        intersector.intersects_first(origins, dirs)
        t_embree.append(time.perf_counter() - t0)
    res = {
        "scene": name,
        "triangles": int(len(faces)),
        "width": width,
        "height": height,
        "coverage": float(frag.coverage.mean()),
        "id_agreement_vs_embree": agreement,
        "raster_median_s": float(np.median(t_keep)),
        "raster_min_s": float(np.min(t_keep)),
        "raster_times_s": t_keep,
        "raster_cull_median_s": float(np.median(t_cull)),
        "raster_cull_times_s": t_cull,
        "embree_median_s": float(np.median(t_embree)),
        "embree_min_s": float(np.min(t_embree)),
        "embree_times_s": t_embree,
        "embree_bvh_build_s": bvh_s,
        "gbuffer_full_median_s": float(np.median(t_full)),
        "gbuffer_full_times_s": t_full,
        "speedup_vs_embree": float(np.median(t_embree) / np.median(t_keep)),
        "speedup_cull_vs_embree": float(np.median(t_embree) / np.median(t_cull)),
        "ray_backend": type(intersector).__module__,
    }
    print(f"{name}: {len(faces)} tris, coverage {res['coverage']:.1%}, full G-buffer {res['gbuffer_full_median_s']:.3f} s, "
          f"raster {res['raster_median_s']:.3f} s "
          f"(cull {res['raster_cull_median_s']:.3f} s), embree {res['embree_median_s']:.3f} s, "
          f"speedup x{res['speedup_vs_embree']:.2f}, id agreement {agreement:.4%}")
    return res


def bench_memory(width, height):
    sphere = trimesh.creation.icosphere(subdivisions=8)
    verts = np.ascontiguousarray(sphere.vertices)
    faces = np.ascontiguousarray(sphere.faces, dtype=np.int64)
    view = look_at((0.3, 0.2, 2.4), (0.0, 0.0, 0.0))
    proj = perspective(45.0, width / height, 0.1, 100.0)
    t0 = time.perf_counter()
    frag = rasterize(verts, faces, view, proj, width, height)
    elapsed = time.perf_counter() - t0
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    tracemalloc.start()
    frag = rasterize(verts, faces, view, proj, width, height)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    out_bytes = frag.tri_id.nbytes + frag.depth.nbytes + frag.bary.nbytes
    res = {
        "scene": "icosphere-8",
        "triangles": int(len(faces)),
        "width": width,
        "height": height,
        "time_s": elapsed,
        "coverage": float(frag.coverage.mean()),
        "peak_alloc_during_call_MiB": peak / 2**20,
        "output_MiB": out_bytes / 2**20,
        "input_MiB": (verts.nbytes + faces.nbytes) / 2**20,
        "process_max_rss_MiB": max(rss_before, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) / 1024,
    }
    print(f"memory: {len(faces)} tris in {elapsed:.3f} s, peak allocated during the call "
          f"{res['peak_alloc_during_call_MiB']:.0f} MiB (output {res['output_MiB']:.0f} MiB, "
          f"input {res['input_MiB']:.0f} MiB), process max RSS {res['process_max_rss_MiB']:.0f} MiB")
    return res


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=RESULTS / "raster.json")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--no-memory", action="store_true", help="skip the 1.3M-triangle memory run")
    args = ap.parse_args(argv)
    if args.repeats < 5:
        ap.error("--repeats must be >= 5")
    try:
        import embreex  # noqa: F401
        embreex_version = getattr(embreex, "__version__", "installed")
    except ImportError:
        embreex_version = None
        print("warning: embreex not installed; trimesh falls back to its slow pure-NumPy ray caster")
    data = {
        "versions": {"trimesh": trimesh.__version__, "embreex": embreex_version},
        "repeats": args.repeats,
        "scenes": [],
        "skipped": [] if BUNNY.is_file() else ["stanford-bunny (assets absent)"],
    }
    for name, mesh, view, proj in scenes(args.width, args.height):
        data["scenes"].append(bench_scene(name, mesh, view, proj, args.width, args.height, args.repeats))
    if not args.no_memory:
        data["memory"] = bench_memory(args.width, args.height)
    write_result(args.out, data)            # the NumPy rasterizer: measured on the host CPU


if __name__ == "__main__":
    main()

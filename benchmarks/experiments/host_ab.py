"""Host-side stages of a frame, this checkout against a git ref (default `main`), A/B in one
process: the ref's versions of clshade/render/{arrays,raster,gbuffer,meshes,image} are loaded
beside the checkout's (importing each other) and timed in interleaved rounds on the same inputs; every pair's
outputs are checked equal (bytes) before anything is timed.

Usage::

    python -m benchmarks.experiments.host_ab [--base main] [--rounds 7] [--out benchmarks/results/host_ab.json]

First the whole warm render (`clshade render scenes/robot.toml`, fresh processes, the ref
checked out in a temporary detached worktree). Rows: geometry (robot.toml), rasterize and G-buffer at 640×640 and 1920×1080, the display
transform and the PNG encode at 640×640, and a whole frame (robot at
1920×1080: rasterize + G-buffer + upload + shade + read back, the camera orbiting 2° a
frame, kernel built once before). Medians of process CPU time (user + system, all
threads: what a shared machine inflates least) and of wall time. `python -m benchmarks.publish`
renders host_ab.md from the JSON.
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.publish.results_io import RESULTS, ROOT, measure_and_write

MODULES = ("arrays", "raster", "gbuffer", "meshes", "image")   # in import order
FRAME_TARGET_S = 0.100          # the target: whole robot frame at 1920×1080
ORBIT_DEGREES = 2.0


def _git_text(ref: str, path: str) -> str | None:
    proc = subprocess.run(["git", "show", f"{ref}:{path}"], cwd=ROOT, capture_output=True, text=True)
    return proc.stdout if proc.returncode == 0 else None


def load_base(ref: str, folder: Path) -> dict[str, object]:
    """The ref's clshade/render/<name>.py (or the package clshade/render/<name>/, as the
    rasterizer is since its split) as standalone modules importing each other (their other
    imports resolve to this checkout)."""
    out = {}
    for name in MODULES:
        single = _git_text(ref, f"clshade/render/{name}.py")
        if single is not None:
            files = {f"base_{name}.py": single}
        else:                                    # a package: every module of its folder
            listing = subprocess.run(["git", "ls-tree", "--name-only", f"{ref}:clshade/render/{name}"], cwd=ROOT,
                                     check=True, capture_output=True, text=True).stdout.split()
            files = {f"base_{name}/{f}": _git_text(ref, f"clshade/render/{name}/{f}") for f in listing
                     if f.endswith(".py")}
        for file, text in files.items():
            for other in (*out, name):
                text = text.replace(f"from clshade.render.{other} import", f"from base_{other} import")
                text = text.replace(f"from clshade.render.{other}.", f"from base_{other}.")
            path = folder / file
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
        if single is not None:
            spec = importlib.util.spec_from_file_location(f"base_{name}", folder / f"base_{name}.py")
        else:
            spec = importlib.util.spec_from_file_location(f"base_{name}", folder / f"base_{name}" / "__init__.py",
                                                          submodule_search_locations=[str(folder / f"base_{name}")])
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module          # dataclasses look their module up there
        spec.loader.exec_module(module)
        out[name] = module
    return out


def timed(fn):
    c, w = time.process_time(), time.perf_counter()
    result = fn()
    return result, time.process_time() - c, time.perf_counter() - w


def same(a, b) -> bool:
    if hasattr(a, "channels"):
        return set(a.channels) == set(b.channels) and all(
            a.channels[k].tobytes() == b.channels[k].tobytes() for k in a.channels) and np.array_equal(
            a.coverage, b.coverage)
    if hasattr(a, "tri_id"):
        return all(np.asarray(getattr(a, k)).tobytes() == np.asarray(getattr(b, k)).tobytes()
                   for k in ("tri_id", "depth", "bary"))
    if hasattr(a, "faces"):
        return all(getattr(a, k).tobytes() == getattr(b, k).tobytes() for k in ("vertices", "normals", "faces"))
    return np.asarray(a).tobytes() == np.asarray(b).tobytes()


def render_ab(base_ref: str, rounds: int) -> dict:
    """Warm `clshade render scenes/robot.toml` (640×640 PNG) in fresh processes, the ref (a
    detached worktree, imported through PYTHONPATH) and this checkout in interleaved rounds
    after one warm-up each: median wall and CPU (user + system) seconds; decoded pixels equal."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    with tempfile.TemporaryDirectory() as tmp:
        base_tree = Path(tmp) / "base"
        subprocess.run(["git", "worktree", "add", "--detach", "-q", str(base_tree), base_ref], cwd=ROOT, check=True)
        try:
            trees = {"base": base_tree, "new": ROOT}
            runs = {k: {"wall": [], "cpu": []} for k in trees}
            for r in range(-1, rounds):
                for label in (("base", "new") if r % 2 == 0 else ("new", "base")):
                    png = Path(tmp) / f"{label}.png"
                    cmd = [sys.executable, "-m", "clshade", "render", "scenes/robot.toml", "-o", str(png)]
                    start = time.perf_counter()
                    proc = subprocess.Popen(cmd, cwd=trees[label], env=dict(env, PYTHONPATH=str(trees[label])),
                                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
                    proc.stdout.read()
                    err = proc.stderr.read()
                    _, status, usage = os.wait4(proc.pid, 0)
                    if os.waitstatus_to_exitcode(status):
                        raise SystemExit(f"{label} render failed: {err.decode().strip()}")
                    if r >= 0:
                        runs[label]["wall"].append(time.perf_counter() - start)
                        runs[label]["cpu"].append(usage.ru_utime + usage.ru_stime)
            from clshade.render.image import read_image
            same_pixels = read_image(Path(tmp) / "base.png").tobytes() == read_image(Path(tmp) / "new.png").tobytes()
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(base_tree)], cwd=ROOT, check=False)
    if not same_pixels:
        raise SystemExit("render: the base and the checkout wrote different pixels")
    return {k: {m: statistics.median(v[m]) for m in ("wall", "cpu")} for k, v in runs.items()}


def measure(base_ref: str, rounds: int) -> dict:
    import clshade.render.gbuffer as gbuffer
    import clshade.render.image as image
    import clshade.render.meshes as meshes
    import clshade.render.raster as raster
    from clshade.bench.frame import orbit
    from clshade.device.runtime import get_runtime
    from clshade.device.shade import Shader, scene_features
    from clshade.models.registry import Registry
    from clshade.render.scene import load_scene

    from clshade.render.gbuffer import GBuffer

    new = {"raster": raster, "gbuffer": gbuffer, "meshes": meshes, "image": image}
    scene = load_scene(ROOT / "scenes" / "robot.toml")
    model = Registry().resolve(scene.model)
    rt = get_runtime()
    with tempfile.TemporaryDirectory() as tmp:
        old = load_base(base_ref, Path(tmp))
        geometry = meshes.build_geometry(scene)
        cams = {size: scene.camera.with_size(*size) for size in ((640, 640), (1920, 1080))}

        def raster_of(m, cam):
            return m["raster"].rasterize(geometry.vertices, geometry.faces, cam.view_matrix(),
                                         cam.projection_matrix(), cam.width, cam.height, cull_backfaces=geometry.cull)

        # Each side's G-buffer reads its own rasterizer's fragments (their layouts may differ).
        frags = {label: {s: raster_of(m, c) for s, c in cams.items()} for label, m in (("base", old), ("new", new))}
        radiance = Shader(rt, gbuffer.build_gbuffer(scene, geometry, frags["new"][(640, 640)], cams[(640, 640)]),
                          scene, cams[(640, 640)]).render(model, scene_features(scene, geometry=geometry))
        pixels = image.to_display(radiance)
        png = Path(tmp) / "frame.png"
        items = {"geometry (robot)": lambda m: m["meshes"].build_geometry(scene)}
        for (w, h), cam in cams.items():
            items[f"rasterize {w}×{h}"] = lambda m, cam=cam: raster_of(m, cam)
            items[f"g-buffer {w}×{h}"] = (lambda m, cam=cam, size=(w, h):
                                          m["gbuffer"].build_gbuffer(scene, geometry,
                                                                     frags["new" if m is new else "base"][size], cam))
        items["display transform 640×640"] = lambda m: m["image"].to_display(radiance)
        items["PNG encode 640×640"] = lambda m: (m["image"].write_encoded(png, pixels), png.stat().st_size)[1]

        for name, fn in items.items():
            if name.startswith("PNG"):          # same pixels in both files, the file sizes differ
                fn(old)
                a = image.read_image(png)
                fn(new)
                equal = a.tobytes() == image.read_image(png).tobytes()
            else:
                equal = same(fn(old), fn(new))
            if not equal:
                raise SystemExit(f"{name}: outputs differ between {base_ref} and the checkout")
        rows = {name: {"base": {"cpu": [], "wall": []}, "new": {"cpu": [], "wall": []}} for name in items}
        sizes = {}
        for r in range(rounds):
            order = (("base", old), ("new", new)) if r % 2 == 0 else (("new", new), ("base", old))
            for name, fn in items.items():
                for label, m in order:
                    result, cpu, wall = timed(lambda: fn(m))
                    rows[name][label]["cpu"].append(cpu)
                    rows[name][label]["wall"].append(wall)
                    if name.startswith("PNG"):
                        sizes[label] = result

        # Whole frames: the camera orbits; kernel built before the timed frames.
        base_cam = cams[(1920, 1080)]
        features = scene_features(scene, geometry=geometry)
        frames = {"base": [], "new": []}
        for k in range(rounds * 2 + 2):
            for label, m in ((("base", old), ("new", new)) if k % 2 == 0 else (("new", new), ("base", old))):
                cam = orbit(base_cam, ORBIT_DEGREES * k)
                c0, w0 = time.process_time(), time.perf_counter()
                f = raster_of(m, cam)
                c1, w1 = time.process_time(), time.perf_counter()
                gb = m["gbuffer"].build_gbuffer(scene, geometry, f, cam)
                if not hasattr(gb, "plane"):    # a ref's G-buffer without planes: uploaded as the ref did
                    gb = GBuffer(gb.width, gb.height, gb.channels, gb.materials, gb.coverage)
                c2, w2 = time.process_time(), time.perf_counter()
                shader = Shader(rt, gb, scene, cam)
                dispatch = shader.prepare(model, features)
                shader.enqueue(dispatch).wait()
                shader.read()
                c3, w3 = time.process_time(), time.perf_counter()
                if k >= 2:
                    frames[label].append({"rasterize": (c1 - c0, w1 - w0), "g-buffer": (c2 - c1, w2 - w1),
                                          "upload + shade + read back": (c3 - c2, w3 - w2),
                                          "frame": (c3 - c0, w3 - w0)})
    med = statistics.median
    return {
        "base_ref": base_ref,
        "base_commit": subprocess.run(["git", "rev-parse", "--short", base_ref], cwd=ROOT, capture_output=True,
                                      text=True).stdout.strip(),
        "rounds": rounds, "frame_target_s": FRAME_TARGET_S, "orbit_degrees": ORBIT_DEGREES,
        "png_bytes": sizes,
        "stages": {name: {lab: {"cpu_ms": 1e3 * med(v[lab]["cpu"]), "wall_ms": 1e3 * med(v[lab]["wall"])}
                          for lab in ("base", "new")} for name, v in rows.items()},
        "whole_frame_1080p": {lab: {st: {"cpu_ms": 1e3 * med(f[st][0] for f in fr),
                                         "wall_ms": 1e3 * med(f[st][1] for f in fr)} for st in fr[0]}
                              for lab, fr in frames.items()},
        "render_robot_640_s": render_ab(base_ref, rounds),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", default="main", help="git ref to compare with (default main)")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--out", default=str(RESULTS / "host_ab.json"))
    args = parser.parse_args()
    measure_and_write(args.out, lambda: measure(args.base, args.rounds))
    return 0


if __name__ == "__main__":
    sys.exit(main())

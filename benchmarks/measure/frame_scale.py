"""Where 30 FPS ends: whole-frame time against resolution and against triangle count, through the one frame
path (clshade.bench.frame.orbit_bench, as `clshade bench --whole-frames`): benchmarks/results/frame_scale.json
and its plot frame_scale.png. JSON and plot only: `python -m benchmarks.publish` renders frame_scale.md.

* Resolution: scenes/robot.toml at RESOLUTIONS (540p … 4K).
* Triangles, at --width × --height: the project's scenes (robot, sphere_grid, textured), a sphere of
  about a million triangles made here (MILLION_SUBDIVISIONS: an icosphere written as OBJ into a temporary
  folder, never committed), and the third-party meshes of ../shared/assets (each skipped with its reason when
  absent), each framed by a camera at FRAMING × its bounding radius, one directional light.
Each point: --frames orbit frames (after clshade.bench.frame.WARMUP_FRAMES untimed ones: the path's check,
the kernel build, the planes) of one model (GGX height-correlated) on the default device; the median whole
frame, its 1 % low, the G-buffer path and the stage medians.

    python -m benchmarks.measure.frame_scale [--frames 12] [--width 1920 --height 1080]
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

from benchmarks.publish.results_io import RESULTS, ROOT, load_average, write_result

RESOLUTIONS = ((960, 540), (1280, 720), (1920, 1080), (2560, 1440), (3840, 2160))
SCENES = ("robot.toml", "sphere_grid.toml", "textured.toml")
ASSETS = ROOT.parent / "shared" / "assets"
MESHES = ("stanford-bunny/stanford-bunny.obj", "utah-teapot/teapot.obj", "spot/spot_triangulated.obj",
          "bob/bob_tri.obj")
#: Subdivisions of the generated icosphere: 20·4⁸ = 1 310 720 triangles.
MILLION_SUBDIVISIONS = 8
#: The camera's distance over the mesh's bounding radius (a 30° field of view holds the whole mesh).
FRAMING = 4.2
MODEL = "ggx_correlated"
#: The whole-frame budget of 30 FPS, drawn on the plot.
TARGET_MS = 1000.0 / 30.0


def mesh_scene(folder: Path, mesh: Path) -> Path:
    """A scene of one mesh centred at the origin, scaled to unit radius, one directional light."""
    import trimesh
    m = trimesh.load(mesh, force="mesh")
    centre = [float(x) for x in (m.bounds[0] + m.bounds[1]) / 2.0]
    radius = float(np.max(np.linalg.norm(m.vertices - centre, axis=1))) or 1.0
    s = float(1.0 / radius)
    text = f"""[camera]
position = [0.0, 0.4, {FRAMING}]
target = [0.0, 0.0, 0.0]
fov = 30.0
width = 640
height = 360

[render]
background = [0.02, 0.02, 0.025]

[[lights]]
type = "directional"
direction = [-0.45, -0.5, -1.0]
irradiance = [3.0, 3.0, 3.0]

[materials.grey]
base_color = [0.7, 0.7, 0.7]
roughness = 0.35

[[objects]]
name = "mesh"
mesh = "{mesh.as_posix()}"
scale = {s!r}
translate = [{-centre[0] * s!r}, {-centre[1] * s!r}, {-centre[2] * s!r}]
material = "grey"
"""
    path = folder / (mesh.stem + ".toml")
    path.write_text(text, encoding="utf-8")
    return path


def million(folder: Path) -> Path:
    """An icosphere of MILLION_SUBDIVISIONS subdivisions as OBJ in `folder`."""
    import trimesh
    path = folder / "million_sphere.obj"
    trimesh.creation.icosphere(subdivisions=MILLION_SUBDIVISIONS).export(path)
    return path


def point(scene_path: Path, width: int, height: int, frames: int, runtime, model) -> dict:
    from clshade.bench.frame import orbit_bench
    from clshade.render.scene import load_scene
    doc = orbit_bench(load_scene(scene_path), [model], runtime, width, height, frames)
    row = doc["models"][0]
    return dict(width=doc["width"], height=doc["height"], triangles=doc["triangles"], gbuffer=doc["gbuffer"],
                frame_ms=row["whole_frame_ms_median"], low1_fps=row["low1_fps"], avg_fps=row["avg_fps"],
                stage_ms=row["stage_ms_median"], load_average=doc["load_average"])


def _label_sides(xs: list[float], ys: list[float]) -> list[int]:
    """Vertical offsets (points) of each point's label: above it when it lies above its nearest
    neighbour along x, below otherwise, so that two close points' labels part."""
    sides = []
    for i, (x, y) in enumerate(zip(xs, ys)):
        others = [j for j in range(len(xs)) if j != i]
        near = min(others, key=lambda j: abs(xs[j] - x)) if others else i
        sides.append(4 if y >= ys[near] else -11)
    return sides


def plot(doc: dict, out: Path) -> None:
    from clshade.report.plots import pyplot, write_figure
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    res = doc["resolution"]
    a.plot([r["width"] * r["height"] / 1e6 for r in res], [r["frame_ms"] for r in res], "o-")
    xs = [r["width"] * r["height"] / 1e6 for r in res]
    for x, r, side in zip(xs, res, _label_sides(xs, [r["frame_ms"] for r in res])):
        a.annotate(f"{r['height']}p", (x, r["frame_ms"]), textcoords="offset points", xytext=(4, side), fontsize=8)
    a.set_xlabel("megapixels (robot.toml)")
    a.set_title("whole frame against resolution")
    tri = sorted(doc["triangles"], key=lambda r: r["triangles"])
    b.loglog([r["triangles"] for r in tri], [r["frame_ms"] for r in tri], "o")
    sides = _label_sides([math.log(r["triangles"]) for r in tri], [math.log(r["frame_ms"]) for r in tri])
    for r, side in zip(tri, sides):
        b.annotate(r["name"], (r["triangles"], r["frame_ms"]), textcoords="offset points", xytext=(4, side), fontsize=7)
    b.set_xlim(right=max(r["triangles"] for r in tri) * 8)     # room for the largest mesh's name
    b.set_xlabel("triangles")
    b.set_title(f"whole frame against triangles ({doc['width']}×{doc['height']})")
    for ax in (a, b):
        ax.axhline(TARGET_MS, color="tab:red", linestyle="--", linewidth=1, label="30 FPS (33.3 ms)")
        ax.set_ylabel("median whole frame, ms")
        ax.grid(True, which="both", alpha=0.3)
        ax.margins(y=0.12)                  # room for the labels of the lowest and highest points
        ax.legend(loc="upper left", fontsize=8)
    title = f"{doc['device']} — {doc['model']}, commit {(doc['provenance']['commit'] or '')[:10]}"
    fig.suptitle(textwrap.fill(title, 130), fontsize=9)     # a device's description can be longer than the figure
    fig.tight_layout()
    write_figure(plt, fig, out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--device", default=None)
    ap.add_argument("--assets", type=Path, default=ASSETS)
    ap.add_argument("--out", default=str(RESULTS / "frame_scale.json"))
    args = ap.parse_args()
    from clshade.device.runtime import get_runtime
    from clshade.models.registry import Registry
    start = load_average()
    runtime = get_runtime(args.device)
    model = Registry().resolve(MODEL)
    scenes = ROOT / "scenes"
    # Untimed: the process's first frames pay for its first allocations and page faults (the first
    # point measured alone ran slower than the next, larger one).
    point(scenes / "robot.toml", *RESOLUTIONS[0], 2, runtime, model)
    resolution = []
    for w, h in RESOLUTIONS:
        print(f"robot {w}x{h}", file=sys.stderr, flush=True)
        resolution.append(point(scenes / "robot.toml", w, h, args.frames, runtime, model))
    triangles, skipped = [], []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        sources = [(name, scenes / name) for name in SCENES]
        sources.append(("icosphere 8 (generated)", mesh_scene(folder, million(folder))))
        for rel in MESHES:
            mesh = args.assets / rel
            if mesh.is_file():
                sources.append((mesh.stem, mesh_scene(folder, mesh)))
            else:
                skipped.append(dict(mesh=rel, reason=f"{mesh} is absent"))
        for name, path in sources:
            print(f"{name} {args.width}x{args.height}", file=sys.stderr, flush=True)
            triangles.append(dict(name=name, **point(path, args.width, args.height, args.frames, runtime, model)))
    doc = dict(command="python -m benchmarks.measure.frame_scale " + " ".join(sys.argv[1:]),
               created=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), device=runtime.info.description,
               model=MODEL, frames=args.frames, width=args.width, height=args.height, target_ms=TARGET_MS,
               resolution=resolution, triangles=triangles, skipped=skipped,
               load_average={"start": start, "end": load_average()})
    doc = write_result(args.out, doc, runtime.info.description)
    plot(doc, Path(args.out).with_suffix(".png"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

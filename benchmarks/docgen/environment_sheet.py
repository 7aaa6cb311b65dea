"""The README's environment image: the robot of scenes/environment.toml under two skies in every rung
of the ladder, each tile with its device time per frame (docs/images/environment_rungs.png).

Rows: the project's own sky (scenes/environments/courtyard_128x64.exr) and, where the shared assets are
there, the sunniest CC0 map of ../shared/assets/hdri (a row is left out, with a line saying so, when
absent). Columns: every rung of clshade/render/environment.py at least once (`rungs`), the sampled ones at
SAMPLE_COUNTS.

    python -m benchmarks.docgen.environment_sheet [--model ggx_correlated] [--size 256]
"""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "docs" / "images" / "environment_rungs.png"
SCENE = ROOT / "scenes" / "environment.toml"
HDRI = ROOT.parent / "shared" / "assets" / "hdri"
#: The sampled rungs' sample counts shown: one (the noise) and the top of the ladder's useful range.
SAMPLE_COUNTS = (4, 256)
#: Device-timed dispatches per tile (median shown).
REPEATS = 5


def rungs() -> list[tuple[str, str, int]]:
    """(diffuse, specular, samples) per column, every rung of clshade/render/environment.py at least once:
    each precomputed diffuse rung without a specular one, each precomputed specular rung beside the default
    diffuse, then both sampled at each of SAMPLE_COUNTS (samples 0: the column does not sample)."""
    from clshade.render import environment as E
    out = [(d, "none", 0) for d in E.DIFFUSE_RUNGS if d != "sampled"]
    out += [(E.DEFAULT_DIFFUSE, s, 0) for s in E.SPECULAR_RUNGS if s not in ("none", "sampled")]
    return out + [("sampled", "sampled", n) for n in SAMPLE_COUNTS]


def row(scene, model, spec, size: int, runtime) -> list[tuple[np.ndarray, str, str]]:
    """The tiles of one sky: each rung rendered and timed on the device."""
    from clshade.compare import scene_display
    from clshade.pipeline import prepare_frame, render
    tiles = []
    frame = None
    for diffuse, specular, n in rungs():
        s = dataclasses.replace(scene, environment=dataclasses.replace(spec, diffuse=diffuse, specular=specular,
                                                                       samples=max(n, 1)))
        frame = prepare_frame(s, size, size, runtime=runtime) if frame is None else dataclasses.replace(frame, scene=s)
        r = render(s, model, runtime=runtime, frame=frame)
        times = []
        for _ in range(REPEATS):
            event = r.shader.enqueue(r.shader.prepare(model, r.features))
            event.wait()
            times.append((event.profile.end - event.profile.start) * 1e-6)
        label = f"{diffuse} + {specular}" + (f" N={n}" if n else "")
        tiles.append((scene_display(r.image, s), label, f"{np.median(times):.2f} ms"))
    return tiles


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="ggx_correlated")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    from benchmarks.measure.mitsuba_envmap import sunniest
    from clshade.compare import layout, write_sheet
    from clshade.device.runtime import get_runtime
    from clshade.models.registry import Registry
    from clshade.render.scene import load_scene
    runtime = get_runtime()
    scene = load_scene(SCENE)
    model = Registry().resolve(args.model)
    rows = [(f"{Path(scene.environment.map).name} (scenes/environments) — {model.name}, {runtime.info.runtime}, device ms per frame",
             row(scene, model, scene.environment, args.size, runtime))]
    sun = sunniest(HDRI) if HDRI.is_dir() else None
    if sun is not None:
        spec = dataclasses.replace(scene.environment, map=sun)
        rows.append((f"{sun.name} (shared/assets/hdri, CC0: the sunniest)", row(scene, model, spec, args.size, runtime)))
    else:
        print(f"no shared maps in {HDRI}: one row")
    write_sheet(args.out, layout(rows, max_columns=len(rungs())))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

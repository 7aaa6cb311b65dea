"""BRDF Explorer's collection as a user brings it: every `.brdf` file of ../shared/assets/brdf-explorer
(or --collection) through the commands a user runs, on the white sphere (scenes/white_sphere.toml),
written to benchmarks/results/brdf_explorer.json with a labelled contact sheet
(benchmarks/results/brdf_explorer.png, `clshade compare`). JSON only: `python -m benchmarks.publish`
renders benchmarks/results/brdf_explorer.md.

Per file: `clshade models --lobes DIR` lists it (its id); `clshade render -m FILE` exits 0; one
`clshade bench -m lambert,FILE,…` run times every file in the same interleaved rounds (device ms per
frame, × copy kernel, × Lambert, max and mean relative error of the frame against its float64 build);
`clshade check stability --model FILE` gives the verdict and its NaN/Inf/negative counts; the GLSL
oracle's agreement comes from benchmarks/results/glsl_oracle.json (measured by its own command).

    python -m benchmarks.measure.brdf_explorer [--collection DIR] && python -m benchmarks.publish
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.publish.results_io import RESULTS, ROOT, write_result
from clshade.device.runtime import get_runtime

OUT = RESULTS / "brdf_explorer.json"
SHEET = RESULTS / "brdf_explorer.png"
ORACLE = RESULTS / "glsl_oracle.json"
SCENE = ROOT / "scenes" / "white_sphere.toml"
COLLECTION = ROOT.parent / "shared" / "assets" / "brdf-explorer"
SHEET_TILE = 128           # contact-sheet tile width: 30 tiles stay a small committed PNG


def clshade(*args: str) -> subprocess.CompletedProcess:
    """`clshade ARGS` with this interpreter, from the repository root."""
    return subprocess.run([sys.executable, "-m", "clshade", *args], cwd=ROOT, capture_output=True, text=True)


def last_line(text: str) -> str:
    lines = [line for line in text.strip().splitlines() if line.strip()]
    return lines[-1] if lines else ""


def listed_ids(collection: Path) -> dict[str, str]:
    """File name -> the id `clshade models --lobes` lists it under."""
    run = clshade("models", "--lobes", str(collection), "--json")
    if run.returncode:
        raise SystemExit(f"clshade models --lobes {collection}: {last_line(run.stderr)}")
    return {Path(lobe["path"]).name: lobe["id"] for lobe in json.loads(run.stdout)["lobes"] if lobe["path"]}


def render(path: Path, folder: Path) -> dict:
    start = time.perf_counter()
    run = clshade("render", str(SCENE), "-m", str(path), "-o", str(folder / f"{path.stem}.png"))
    return dict(exit=run.returncode, seconds=round(time.perf_counter() - start, 2),
                message=last_line(run.stderr) if run.returncode else "")


def bench(paths: list[Path], frames: int, width: int, height: int, folder: Path) -> dict[str, dict]:
    """One `clshade bench` over Lambert and every file: rows by model id."""
    out = folder / "bench.json"
    run = clshade("bench", str(SCENE), "-m", ",".join(["lambert", *map(str, paths)]), "--frames", str(frames),
                  "--width", str(width), "--height", str(height), "--numpy-frames", "0", "--no-progress",
                  "--json", str(out))
    if run.returncode:
        raise SystemExit(f"clshade bench: {last_line(run.stderr)}")
    return {row["model"]: row for row in json.loads(out.read_text())["models"]}


def stability(path: Path) -> dict:
    run = clshade("check", "stability", "--model", str(path), "--json")
    if not run.stdout.strip():
        return dict(exit=run.returncode, message=last_line(run.stderr))
    doc = json.loads(run.stdout)
    raw = doc["raw_radiance"]
    return dict(exit=run.returncode, ok=doc["ok"], cases=doc["cases"], nonfinite=doc["nonfinite"],
                negative=doc["negative"], shipped_nonfinite=raw["clamped_build_nonfinite"],
                max_radiance=raw["max_radiance"], failures=doc["failures"][:3])


def oracle_rows(name: str) -> list[dict]:
    doc = json.loads(ORACLE.read_text()) if ORACLE.exists() else {"rows": []}
    return [dict(set=r["set"], agrees=r["agrees"], max_excess=r["max_excess"], max_rel=r["max_rel"],
                 compared=r["compared"]) for r in doc["rows"] if r["origin"] == "BRDF Explorer" and r["file"] == name]


def measure(collection: Path, frames: int, width: int, height: int) -> dict:
    paths = sorted(collection.glob("*.brdf"))
    if not paths:
        raise SystemExit(f"no .brdf files in {collection}")
    ids = listed_ids(collection)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        renders = {p.name: render(p, folder) for p in paths}
        timed = bench(paths, frames, width, height, folder)
    sheet = clshade("compare", str(SCENE), "-m", ",".join(map(str, paths)), "--tile", str(SHEET_TILE),
                    "-o", str(SHEET))
    if sheet.returncode:
        raise SystemExit(f"clshade compare: {last_line(sheet.stderr)}")
    lambert = timed["lambert"]
    rows = []
    for path in paths:
        model = ids.get(path.name)
        t = timed.get(model or "", {})
        rows.append(dict(
            file=path.name, id=model, render=renders[path.name],
            mean_ms=t.get("mean_ms"), copy_ratio=t.get("copy_ratio"), lambert_ratio=t.get("lambert_ratio"),
            max_rel_error=t.get("max_rel_error"), mean_rel_error=t.get("mean_rel_error"),
            stability=stability(path), oracle=oracle_rows(path.name)))
    return dict(schema=1, created=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                device=get_runtime().info.description, scene=str(SCENE.relative_to(ROOT)),
                collection=collection.name, width=width, height=height, frames=frames,
                lambert_ms=lambert["mean_ms"], sheet=str(SHEET.relative_to(ROOT)), sheet_tile=SHEET_TILE,
                oracle_measured=json.loads(ORACLE.read_text())["provenance"]["commit"] if ORACLE.exists() else None,
                command="python -m benchmarks.measure.brdf_explorer", rows=rows)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--collection", type=Path, default=COLLECTION)
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--width", type=int, default=960)
    parser.add_argument("--height", type=int, default=540)
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args()
    start = time.perf_counter()
    doc = measure(args.collection, args.frames, args.width, args.height)
    doc["seconds"] = round(time.perf_counter() - start, 1)
    write_result(args.out, doc, get_runtime().info.description)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

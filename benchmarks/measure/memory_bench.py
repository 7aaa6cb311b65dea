"""Peak host memory of `clshade render` by frame size (the limit: ≤ 64 B/px + a fixed base).

Usage::

    python -m benchmarks.measure.memory_bench [--sizes 512,2048,4096,16384] [--out benchmarks/results/memory.json]

Each size renders scenes/robot.toml to a PNG in a fresh process (`python -m clshade render`);
its peak resident set (ru_maxrss from wait4, the kernel's own count) and wall time are
recorded, with the exit status and the first stderr line (a refusal is a result too). The
bytes per pixel are the slope between two sizes, (peak_b − peak_a) / (pixels_b − pixels_a),
and the whole-process figure peak / pixels; the fixed base is the smallest size's peak.
Results go to JSON; `python -m benchmarks.publish` renders the Markdown table (same name, .md).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.publish.results_io import RESULTS, ROOT, measure_and_write

SCENE = ROOT / "scenes" / "robot.toml"
LIMIT_BYTES_PER_PIXEL = 64


def run_one(size: int, folder: Path) -> dict:
    out = folder / f"robot_{size}.png"
    cmd = [sys.executable, "-m", "clshade", "render", str(SCENE), "--width", str(size), "--height", str(size),
           "-o", str(out)]
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    stdout, stderr = proc.stdout.read().decode(), proc.stderr.read().decode()
    proc.returncode = os.waitstatus_to_exitcode(status)
    stages = next((line for line in stdout.splitlines() if line.startswith("stages:")), "")
    row = {"size": size, "pixels": size * size, "exit_status": proc.returncode, "wall_s": round(wall, 2),
           "peak_rss_bytes": usage.ru_maxrss * 1024, "stderr": stderr.strip().splitlines()[-1] if stderr.strip() else "",
           "stages": stages.removeprefix("stages: "), "written": out.is_file()}
    if out.is_file():
        out.unlink()
    return row


def summarize(rows: list[dict]) -> dict:
    ok = [r for r in rows if r["exit_status"] == 0]
    base = min(ok, key=lambda r: r["pixels"]) if ok else None
    for r in rows:
        r["bytes_per_pixel_whole_process"] = round(r["peak_rss_bytes"] / r["pixels"], 2)
        if base is not None and r["exit_status"] == 0 and r is not base:
            r["bytes_per_pixel_above_base"] = round((r["peak_rss_bytes"] - base["peak_rss_bytes"])
                                                    / (r["pixels"] - base["pixels"]), 2)
            r["within_limit"] = r["peak_rss_bytes"] <= LIMIT_BYTES_PER_PIXEL * r["pixels"] + base["peak_rss_bytes"]
    return {"base_size": base["size"] if base else None, "base_peak_rss_bytes": base["peak_rss_bytes"] if base else None}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="512,2048,4096,16384")
    parser.add_argument("--out", default=str(RESULTS / "memory.json"))
    args = parser.parse_args()

    def measure() -> dict:
        rows = []
        with tempfile.TemporaryDirectory() as tmp:
            for size in (int(s) for s in args.sizes.split(",")):
                rows.append(run_one(size, Path(tmp)))
                print(json.dumps(rows[-1]), flush=True)
        return {"scene": "scenes/robot.toml", "limit_bytes_per_pixel": LIMIT_BYTES_PER_PIXEL, "rows": rows,
                "summary": summarize(rows)}

    measure_and_write(args.out, measure)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Is each published result measured on the code that produces it now?

Every results JSON names the commit it was measured on (its "provenance", written by
clshade.provenance.stamp; a file written before that existed counts as measured at the
commit that last changed the file). A result is *stale* when a later commit changed the
code that produced it: the kernels or its measuring module (PRODUCERS). tests/test_freshness.py
fails on a stale result.

    python benchmarks/freshness.py      # list every result: fresh, or the commits since
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path("benchmarks") / "results"

# results file → the code that produced it (paths relative to the repository root).
PRODUCERS: dict[str, tuple[str, ...]] = {
    "stability.json": ("kernels", "clshade/verify/stability.py", "clshade/verify/torture.py",
                       "clshade/verify/bias.py", "clshade/device/evaluate.py", "clshade/device/counts.py"),
    "floor_bias.json": ("kernels", "clshade/verify/bias.py", "benchmarks/floor_bias.py"),
    "accuracy.json": ("kernels", "clshade/verify/accuracy.py", "benchmarks/accuracy_table.py"),
    "bench_1080p.json": ("kernels", "clshade/bench/run.py", "clshade/bench/numpy_baseline.py", "benchmarks/run_bench.py"),
    "perf_1080p.json": ("kernels", "clshade/bench/perf.py", "clshade/bench/bandwidth.py"),
    "effects.json": ("kernels", "benchmarks/effects_bench.py"),
    "aa.json": ("kernels", "clshade/bench/aa.py"),
    "host_ab.json": ("benchmarks/host_ab.py",),
    "memory.json": ("benchmarks/memory_bench.py",),
    "startup.json": ("benchmarks/startup_bench.py",),
    "raster.json": ("clshade/render/raster", "benchmarks/raster_bench.py"),
    "runtimes.json": ("kernels", "clshade/bench/runtimes.py", "clshade/device/health.py"),
    "user_lobes.json": ("kernels", "clshade/models/glsl", "clshade/models/brdf_file.py", "benchmarks/user_lobes.py"),
    "view.json": ("kernels", "clshade/view", "clshade/render", "clshade/device/display.py", "clshade/device/shade.py",
                  "clshade/device/variants.py", "clshade/device/visibility.py", "clshade/device/runtime.py",
                  "benchmarks/view_bench.py"),
    # The same benchmark on pip's PoCL 3.0, the runtime a fresh install gives (CLSHADE_DEVICE='PoCL 3.0').
    "view_pocl30.json": ("kernels", "clshade/view", "clshade/render", "clshade/device/display.py",
                         "clshade/device/shade.py", "clshade/device/variants.py", "clshade/device/visibility.py",
                         "clshade/device/runtime.py", "benchmarks/view_bench.py"),
    "mutants.json": ("benchmarks/mutation", "kernels", "clshade", "tests", "scenes", "pyproject.toml"),
}

# Results measured before the code they depend on last changed, not yet regenerated (expensive: the lead
# reruns them); tests/test_freshness.py marks them xfail, strict: a regenerated one fails there until it
# leaves this list. The list lives here, outside every result's producers, so that taking a result off it
# does not make that result stale again (tests/ produces mutants.json).
KNOWN_STALE: dict[str, str] = {
    "mutants.json": "mutation catalogue (benchmarks/mutation, hours on 2 cores): 218 of 267 mutants measured "
                    "on f9e9f0c (none survived) by a run that stopped at its time budget; the other 49 (kernel "
                    "mutants, about 4 min each) listed as not run until benchmarks.mutation.run --resume measures them",
}


def git(root: Path, *args: str) -> str | None:
    proc = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True)
    return proc.stdout.strip() if proc.returncode == 0 else None


def measured_commit(root: Path, result: Path) -> str | None:
    """The commit the result names; else the commit that last changed the file; None if neither."""
    doc = json.loads((root / result).read_text(encoding="utf-8"))
    recorded = (doc.get("provenance") or {}).get("commit") if isinstance(doc, dict) else None
    return recorded or git(root, "log", "-1", "--format=%H", "--", str(result)) or None


def changes_since(root: Path, commit: str, code: tuple[str, ...]) -> list[str] | None:
    """Commits after `commit` (up to HEAD) that changed `code`, newest first; None when `commit`
    is not in this checkout's history (a shallow clone: unknown)."""
    if git(root, "cat-file", "-e", f"{commit}^{{commit}}") is None:
        return None
    out = git(root, "rev-list", f"{commit}..HEAD", "--", *code)
    return out.split() if out else []


def staleness(root: Path = ROOT, producers: dict[str, tuple[str, ...]] = PRODUCERS,
              results: Path = RESULTS) -> dict[str, list[str] | None]:
    """Each existing result → the commits that changed its code since it was measured
    ([] = fresh; None = unknown: no commit recorded or not in the history)."""
    out: dict[str, list[str] | None] = {}
    for name, code in producers.items():
        if not (root / results / name).exists():
            continue
        commit = measured_commit(root, results / name)
        out[name] = changes_since(root, commit, code) if commit else None
    return out


def main() -> int:
    stale = 0
    for name, since in staleness().items():
        if since is None:
            print(f"unknown  {name}")
        elif since:
            stale += 1
            known = " (known: " + KNOWN_STALE[name] + ")" if name in KNOWN_STALE else ""
            print(f"STALE    {name}: {len(since)} later commit(s) changed its code, newest {since[0][:10]}{known}")
        else:
            print(f"fresh    {name}")
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())

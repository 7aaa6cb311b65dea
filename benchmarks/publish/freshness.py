"""Is each published result measured on the code that produces it now?

Every results JSON names the commit it was measured on (its "provenance", written by
clshade.provenance.stamp; a file written before that existed counts as measured at the
commit that last changed the file). A result is *stale* when a later commit changed the
code that produced it: its producers in the results registry (benchmarks/publish/registry.py).
tests/contracts/test_freshness.py fails on a stale result.

    python -m benchmarks.publish.freshness      # list every result: fresh, or the commits since
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from benchmarks.publish.registry import RESULTS, Result

ROOT = Path(__file__).resolve().parents[2]

# Results measured before the code they depend on last changed, not yet regenerated (expensive: the lead
# reruns them); tests/contracts/test_freshness.py marks them xfail, strict: a regenerated one fails there until it
# leaves this list. The list lives here, outside every result's producers, so that taking a result off it
# does not make that result stale again (tests/ produces mutants.json).
#: Why the results measured on pip's PoCL 3.0 (their commands name it) are not measured again on 2026-11-30.
_POCL30_ELSEWHERE = ("measured on an AMD EPYC of family 25 with pip's PoCL 3.0, the runtime its command names; the "
                     "2026-11-30 session's machine is of family 26 (Zen 5), where pip's PoCL 3.0 builds nothing, and "
                     "its kernel and frame-path changes (streaming stores and exclusive dispatches in the device "
                     "G-buffer, AVX-512 gathers, images read in place; later the viewer's frames sent as runs and a "
                     "branch-free display kernel) came after; measure again where PoCL 3.0 builds")
KNOWN_STALE: dict[str, str] = {
    "benchmarks/results/bench_1080p.json": _POCL30_ELSEWHERE,
    "benchmarks/report/report.json": _POCL30_ELSEWHERE,
    "benchmarks/results/view_pocl30.json": _POCL30_ELSEWHERE,
}


def git(root: Path, *args: str) -> str | None:
    proc = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True)
    return proc.stdout.strip() if proc.returncode == 0 else None


def measured_commit(root: Path, result: str) -> str | None:
    """The commit the result names; else the commit that last changed the file; None if neither."""
    doc = json.loads((root / result).read_text(encoding="utf-8"))
    recorded = (doc.get("provenance") or {}).get("commit") if isinstance(doc, dict) else None
    return recorded or git(root, "log", "-1", "--format=%H", "--", result) or None


def changes_since(root: Path, commit: str, code: tuple[str, ...]) -> list[str] | None:
    """Commits after `commit` (up to HEAD) that changed `code`, newest first; None when `commit`
    is not in this checkout's history (a shallow clone: unknown)."""
    if git(root, "cat-file", "-e", f"{commit}^{{commit}}") is None:
        return None
    out = git(root, "rev-list", f"{commit}..HEAD", "--", *code)
    return out.split() if out else []


def staleness(root: Path = ROOT, results: tuple[Result, ...] = RESULTS) -> dict[str, list[str] | None]:
    """Each result whose JSON exists (its path) → the commits that changed its producers since it was
    measured ([] = fresh; None = unknown: no commit recorded or not in the history)."""
    out: dict[str, list[str] | None] = {}
    for result in results:
        if not (root / result.json).exists():
            continue
        commit = measured_commit(root, result.json)
        out[result.json] = changes_since(root, commit, result.producers) if commit else None
    return out


def main() -> int:
    stale = 0
    for result, since in staleness().items():
        if since is None:
            print(f"unknown  {result}")
        elif since:
            stale += 1
            known = " (known: " + KNOWN_STALE[result] + ")" if result in KNOWN_STALE else ""
            print(f"STALE    {result}: {len(since)} later commit(s) changed its code, newest {since[0][:10]}{known}")
        else:
            print(f"fresh    {result}")
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())

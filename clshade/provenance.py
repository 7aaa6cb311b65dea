"""What a results file records about where it was measured: the commit (and whether the
checkout had uncommitted changes), the device and the time. Every results JSON carries it
under "provenance" (benchmarks/freshness.py compares the commit with the last change to
the code that produced the file)."""
from __future__ import annotations

import platform
import subprocess
import time
from pathlib import Path
from typing import Any

_ROOT = Path(__file__).resolve().parents[1]


#: What a measurement writes or publish.py renders from the results (tables between markers):
#: changed in the checkout, they do not make a measurement "dirty".
RENDERED: tuple[str, ...] = ("benchmarks/results", "README.md", "REPORT.md", "docs")


def _git(*args: str, root: Path = _ROOT) -> str | None:
    try:
        proc = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    return proc.stdout.strip() if proc.returncode == 0 else None


def checkout_commit(root: Path = _ROOT) -> tuple[str | None, bool]:
    """(HEAD of the checkout clshade runs from, whether tracked files other than the results and
    the documents rendered from them (RENDERED) differ from it); (None, False) outside a git checkout."""
    commit = _git("rev-parse", "HEAD", root=root)
    if commit is None:
        return None, False
    return commit, bool(_git("status", "--porcelain", "--untracked-files=no", "--", ".",
                             *(f":!{path}" for path in RENDERED), root=root))


def host_description() -> str:
    """The CPU model (for host-only measurements)."""
    info = Path("/proc/cpuinfo")
    if info.exists():
        for line in info.read_text().splitlines():
            if line.startswith("model name"):
                return "host CPU: " + line.split(":", 1)[1].strip()
    return "host CPU: " + (platform.processor() or platform.machine())


def provenance(device: str | None = None, commit: str | None = None) -> dict[str, Any]:
    """{commit, dirty, device, measured_at (UTC, ISO 8601)}; `device` defaults to the host CPU;
    `commit`: measured on that commit's clean snapshot, not on this checkout."""
    commit, dirty = (commit, False) if commit else checkout_commit()
    return {"commit": commit, "dirty": dirty, "device": device or host_description(),
            "measured_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}


def stamp(doc: dict[str, Any], device: str | None = None, commit: str | None = None) -> dict[str, Any]:
    """`doc` with its provenance (a new dict, "provenance" first)."""
    return {"provenance": provenance(device, commit), **{k: v for k, v in doc.items() if k != "provenance"}}

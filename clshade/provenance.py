"""Where a results file was measured: the commit (and whether the checkout had uncommitted
changes), the device, the time, and the machine. Every results JSON carries the first four
under "provenance" and the machine under "machine", both written by :func:`stamp`
(benchmarks/publish/freshness.py compares the commit with the last change to the code that
produced the file; docs/bench-schema.md lists the keys)."""
from __future__ import annotations

import os
import platform
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np

from clshade.budget import meminfo_bytes

_ROOT = Path(__file__).resolve().parents[1]


#: What a measurement writes or `python -m benchmarks.publish` renders from the results (tables between
#: markers): changed in the checkout, they do not make a measurement "dirty".
RENDERED: tuple[str, ...] = ("benchmarks/results", "benchmarks/report", "benchmarks/REPORT.md", "README.md", "docs")


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


def cpu_name() -> str:
    """The CPU model from /proc/cpuinfo, else what `platform` knows."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> dict[str, Any]:
    """The machine record of every results JSON, one set of keys (docs/bench-schema.md, *Machine*)."""
    return {"cpu": cpu_name(), "cores": os.cpu_count(), "memory_bytes": meminfo_bytes("MemTotal"),
            "arch": platform.machine(), "os": platform.platform(), "python": platform.python_version(),
            "numpy": np.__version__}


def host_description() -> str:
    """The device of host-only measurements: the CPU model."""
    return "host CPU: " + cpu_name()


def provenance(device: str | None = None, commit: str | None = None) -> dict[str, Any]:
    """{commit, dirty, device, measured_at (UTC, ISO 8601)}; `device` defaults to the host CPU;
    `commit`: measured on that commit's clean snapshot, not on this checkout."""
    commit, dirty = (commit, False) if commit else checkout_commit()
    return {"commit": commit, "dirty": dirty, "device": device or host_description(),
            "measured_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}


def stamp(doc: dict[str, Any], device: str | None = None, commit: str | None = None) -> dict[str, Any]:
    """`doc` with its provenance and the machine record (a new dict, those two first; a "machine"
    the document had is replaced)."""
    return {"provenance": provenance(device, commit), "machine": machine(),
            **{k: v for k, v in doc.items() if k not in ("provenance", "machine")}}

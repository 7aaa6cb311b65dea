"""clshade's caches on disk (program binaries, device health, tuned build choices, tessellations): where they live, atomic
writes, and pruning to the most recently used entries.

Every cache is a folder under $XDG_CACHE_HOME/clshade (~/.cache/clshade) holding one file
per key; an entry is written to a temporary file in the same folder and renamed into place,
so concurrent runs read a whole entry or none, and a reader marks an entry used by touching
its modification time, which pruning orders by.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path


ENV_NO_BINARY_CACHE = "CLSHADE_NO_BINARY_CACHE"
ENV_CACHE_DIR = "CLSHADE_CACHE_DIR"


def user_cache_dir(name: str) -> Path:
    """$XDG_CACHE_HOME/clshade/<name>, else ~/.cache/clshade/<name>."""
    base = os.environ.get("XDG_CACHE_HOME", "").strip() or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "clshade" / name


def binary_cache_dir() -> Path | None:
    """The folder of cached program binaries (clshade.device.runtime) and device health results
    (clshade.device.health): $CLSHADE_CACHE_DIR, else user_cache_dir("programs"); None when
    CLSHADE_NO_BINARY_CACHE=1. A warm build from source still costs the driver ~30 ms of CPU
    (PoCL hashes and links it again); from the binary ~5 ms."""
    if os.environ.get(ENV_NO_BINARY_CACHE, "").strip() not in ("", "0"):
        return None
    folder = os.environ.get(ENV_CACHE_DIR, "").strip()
    return Path(folder) if folder else user_cache_dir("programs")


def tuning_cache_dir() -> Path | None:
    """The folder of measured build choices and device rankings (clshade.device.tuned): `tuning`
    beside the program binaries, so that clearing or relocating that cache clears or moves these
    too; None when CLSHADE_NO_BINARY_CACHE=1."""
    folder = binary_cache_dir()
    return folder / "tuning" if folder is not None else None


def read_entry(path: Path) -> bytes | None:
    """The bytes of an entry, marked as used; None when it cannot be read. An entry that
    can be read but not touched (a read-only cache) is still returned."""
    try:
        data = path.read_bytes()
    except OSError:
        return None
    try:
        os.utime(path)
    except OSError:
        pass
    return data


def write_entry(path: Path, data: bytes, keep: int) -> bool:
    """Store an entry atomically, then prune its folder to the `keep` most recently used
    entries with the same suffix. False (the cache as it was) when it cannot be written."""
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".", suffix=path.suffix, dir=path.parent)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
        tmp = None
    except OSError:
        return False
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
    prune(path.parent, path.suffix, keep)
    return True


def prune(folder: Path, suffix: str, keep: int) -> None:
    """Delete the least recently used entries (`*<suffix>`, not the hidden temporaries) beyond `keep`."""
    entries = []
    try:
        with os.scandir(folder) as it:
            for entry in it:
                if entry.name.endswith(suffix) and not entry.name.startswith("."):
                    try:
                        entries.append((entry.stat().st_mtime_ns, entry.path))
                    except OSError:
                        pass
    except OSError:
        return
    for _, stale in sorted(entries)[:max(0, len(entries) - keep)]:
        try:
            os.unlink(stale)
        except OSError:
            pass

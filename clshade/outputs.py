"""Output files of the commands (JSON, CSV, plots): checked before any work starts,
so a long run never ends in a traceback about a path that could not be written."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from clshade.errors import ClshadeError


def check_output_file(path: str | Path, flag: str, suffixes: tuple[str, ...] | None = None) -> Path:
    """Refuse `path` (given with option `flag`) when its suffix is not one of `suffixes`,
    it names a folder, or its folder is missing or not writable."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffixes is not None and suffix not in suffixes:
        raise ClshadeError(f"{flag} {path}: unsupported format {suffix or '(none)'}; use {', '.join(suffixes)}")
    if path.is_dir():
        raise ClshadeError(f"{flag} {path}: is a folder, not a file")
    folder = path.resolve().parent
    if not folder.is_dir():
        raise ClshadeError(f"{flag} {path}: output folder {folder} does not exist")
    if not folder_writable(folder) or (path.exists() and not os.access(path, os.W_OK)):
        raise ClshadeError(f"{flag} {path}: not writable")
    return path


def folder_writable(folder: Path) -> bool:
    """Whether a file can be created in `folder`, found by creating (and removing) one: os.access
    says yes to root everywhere, also in folders no one can write such as /sys and /proc."""
    try:
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False

"""Output files of the commands (images, JSON, CSV, plots): checked before any work starts,
so a long run never ends in a traceback about a path that could not be written, never
writes over one of its inputs (the scene, its meshes and textures) and never writes two of
its outputs to one path; written atomically (a temporary file in the same folder, then a
rename), so a failed or interrupted write leaves the old file or nothing."""
from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path

from clshade.errors import ClshadeError

#: Prefix of the temporary file an output is written to before its rename: short and fixed,
#: so that any name the file system accepts for the output also fits the temporary file.
TEMP_PREFIX = ".clshade-"


def check_output_file(path: str | Path, flag: str, suffixes: tuple[str, ...] | None = None,
                      protected: Iterable[Path | None] = ()) -> Path:
    """Refuse `path` (given with option `flag`) when it is one of the `protected` inputs, its
    suffix is not one of `suffixes`, it names a folder or another non-regular file, its name is
    too long, or its folder is missing or not writable."""
    path = Path(path)
    refuse_inputs(path, flag, protected)
    suffix = path.suffix.lower()
    if suffixes is not None and suffix not in suffixes:
        raise ClshadeError(f"{flag} {path}: unsupported format {suffix or '(none)'}; use {', '.join(suffixes)}")
    try:
        return _check_writable(path, flag)
    except OSError as exc:       # ENAMETOOLONG from stat, ELOOP, EACCES on a parent, ...
        raise ClshadeError(f"{flag} {path}: {exc.strerror or exc}") from None


def _check_writable(path: Path, flag: str) -> Path:
    resolved = path.resolve()
    folder = resolved.parent
    name_max = _name_max(folder)
    if len(os.fsencode(resolved.name)) > name_max:
        raise ClshadeError(f"{flag} {path}: file name is {len(os.fsencode(resolved.name))} bytes long, "
                           f"the limit of this file system is {name_max}")
    if resolved.is_dir():
        raise ClshadeError(f"{flag} {path}: is a folder, not a file")
    if not folder.is_dir():
        raise ClshadeError(f"{flag} {path}: output folder {folder} does not exist")
    if os.path.lexists(resolved) and not stat.S_ISREG(os.stat(resolved).st_mode):
        raise ClshadeError(f"{flag} {path}: exists and is not a regular file (a device, FIFO or socket)")
    if not folder_writable(folder) or (resolved.exists() and not os.access(resolved, os.W_OK)):
        raise ClshadeError(f"{flag} {path}: not writable")
    return path


def _name_max(folder: Path) -> int:
    """The longest file name (bytes) the file system of `folder` takes (255 when unknown or
    when the folder does not exist)."""
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return 255


def refuse_inputs(path: Path, flag: str, protected: Iterable[Path | None]) -> None:
    """Refuse an output path that is one of the run's inputs (the same file, whatever the spelling)."""
    resolved = _resolved(path)
    for p in protected:
        if p is not None and (_resolved(Path(p)) == resolved or _same_file(path, Path(p))):
            raise ClshadeError(f"{flag} {path}: refusing to overwrite an input of the scene ({p})")


def check_distinct(outputs: Iterable[tuple[str, Path | str | None]]) -> None:
    """Refuse two outputs of one run (flag, path) that name the same file."""
    seen: dict[Path, str] = {}
    for flag, path in outputs:
        if path is None:
            continue
        key = _resolved(Path(path))
        if key in seen:
            raise ClshadeError(f"{flag} {path}: the same file as {seen[key]}; give each output its own path")
        seen[key] = f"{flag} {path}"


def _resolved(path: Path) -> Path:
    try:
        return path.resolve()
    except (OSError, RuntimeError):
        return path.absolute()


def _same_file(a: Path, b: Path) -> bool:
    """Whether two existing paths are one file (hard links too)."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def folder_writable(folder: Path) -> bool:
    """Whether a file can be created in `folder`, found by creating (and removing) one: os.access
    says yes to root everywhere, also in folders no one can write such as /sys and /proc."""
    try:
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False


def new_file_mode(path: Path) -> int:
    """The mode a new file gets from open(): 0666 less the umask; an overwritten file keeps its own."""
    try:
        return path.stat().st_mode & 0o7777
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def write_atomic(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Call `write(tmp)` on a temporary file beside `path`, then rename it over `path`: a
    failed or interrupted write leaves nothing behind (and the old file, if any, intact)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=TEMP_PREFIX, suffix=path.suffix, dir=path.resolve().parent)
    os.close(fd)
    try:
        write(Path(tmp))
        os.chmod(tmp, new_file_mode(path))     # mkstemp creates 0600
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def write_text_atomic(path: str | Path, text: str) -> Path:
    """`text` as UTF-8 at `path`, atomically."""
    return write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))

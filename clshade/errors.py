"""The project error: library code raises it, only the CLI prints it."""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any


class ClshadeError(Exception):
    """An error a user can act on; its message is one line naming what is wrong. `detail`
    (a build log, a library's own messages) is shown only with `clshade --debug`."""

    def __init__(self, message: str, detail: str = "") -> None:
        super().__init__(one_line(message))
        self.detail = detail


def one_line(text: str) -> str:
    """A message from a library (OpenImageIO, a compiler) as one line: its non-blank lines,
    without repeats, joined by '; '."""
    lines: list[str] = []
    for line in str(text).splitlines():
        line = line.strip()
        if line and line not in lines:
            lines.append(line)
    return "; ".join(lines)


# pyopencl's own wrapping of a build log, never the compiler's reason.
_PYOPENCL_WRAPPING = re.compile(r"^(clBuildProgram failed|Build on <|\(options:|=+$)")


def first_error(log: str) -> str:
    """The line of a compiler log a reader needs first: its first line naming an error (else its
    first non-blank line), pyopencl's wrapping lines ('clBuildProgram failed', 'Build on <…>',
    '(options: …)') left out where anything else remains."""
    lines = [line.strip() for line in str(log).splitlines() if line.strip()]
    useful = [line for line in lines if not _PYOPENCL_WRAPPING.match(line)] or lines
    return next((line for line in useful if "error" in line.lower()), useful[0] if useful else "")


def located(message: str, file: str | Path | None = None, key: str | None = None,
            value: Any = None, *, has_value: bool = False) -> ClshadeError:
    """Build an error whose message names the file, the key and the value."""
    parts = []
    if file is not None:
        parts.append(str(file))
    if key is not None:
        parts.append(key if not has_value else f"{key} = {plain(value)!r}")
    where = ": ".join(parts)
    return ClshadeError(f"{where}: {message}" if where else message)


def plain(value: Any) -> Any:
    """NumPy scalars and arrays (also inside lists and tuples) as Python numbers and lists,
    so messages read `[0.0, 1.0]`, not `[np.float64(0.0), ...]`."""
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        return value.tolist()
    return value

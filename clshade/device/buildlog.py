"""Compiler locations in a build log, mapped back to the files of the assembled program.

clshade assembles every program itself (clshade/device/variants.py `assemble`; the display,
resolve and accuracy sources likewise) and marks where each file starts with `#line N "file"`.
PoCL's clang honours the markers and names `surface.h:154:13`; NVIDIA's OpenCL compiler
ignores them and names the line of the whole program, `<kernel>:1050:13`. `relocate` rewrites such locations through the markers, so that
the error handling after it (clshade.device.runtime) reads `file:line:col:` from every compiler.
"""
from __future__ import annotations

import re

# `#line N` or `#line N "file"`: the next line of the source is line N of that file.
_MARKER = re.compile(r'^[ \t]*#[ \t]*line[ \t]+(?P<line>\d+)(?:[ \t]+"(?P<file>[^"]*)")?[ \t]*$')
# A compiler's location `name:line:col:`, the name being what the compiler calls the program
# (`<kernel>` on NVIDIA): no blank, no colon, at the start of a line or after a blank.
_LOCATION = re.compile(r"(?<![^\s(])(?P<name>[^\s:]+):(?P<line>\d+):(?P<col>\d+):")


def source_lines(source: str) -> list[tuple[str, int] | None]:
    """(file, line) of each physical line of `source` (index 0 = line 1) as its `#line`
    markers declare it; None for the markers themselves and the lines before the first one."""
    out: list[tuple[str, int] | None] = []
    file: str | None = None
    line = 0
    for text in source.split("\n"):
        marker = _MARKER.match(text)
        if marker:
            file = marker.group("file") if marker.group("file") is not None else file
            line = int(marker.group("line"))
            out.append(None)
        else:
            out.append((file, line) if file is not None else None)
            line += 1
    return out


def relocate(log: str, source: str) -> str:
    """`log` with each `name:N:C:` location that counts lines of the whole `source` rewritten
    as `file:line:C:` of the file its `#line` markers put there. A log that names any of the
    marked files at a location is the log of a compiler that honours the markers (PoCL): it
    comes back unchanged, as does a location before the first marker or past the source's end."""
    lines = source_lines(source)
    files = {entry[0] for entry in lines if entry is not None}
    if not files or re.search("(?:" + "|".join(map(re.escape, sorted(files))) + r"):\d+:", log):
        return log

    def mapped(m: re.Match) -> str:
        physical = int(m.group("line"))
        entry = lines[physical - 1] if 1 <= physical <= len(lines) else None
        return f"{entry[0]}:{entry[1]}:{m.group('col')}:" if entry is not None else m.group(0)

    return _LOCATION.sub(mapped, log)

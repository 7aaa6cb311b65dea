"""What other libraries say while clshade runs: NumPy's RuntimeWarnings, libpng's messages,
OpenImageIO's errors. None of it reaches stderr, which carries only clshade's own line on an
error (and nothing on success); it is kept here and shown by `clshade --debug`."""
from __future__ import annotations

import os
import sys
import tempfile
import warnings
from collections.abc import Iterator
from contextlib import contextmanager

#: The messages captured in this process, oldest first (`clshade --debug` prints them).
NOTES: list[str] = []


def note(source: str, text: str) -> None:
    """Keep a third-party message (one entry per message, blank ones dropped)."""
    text = text.strip()
    if text:
        NOTES.append(f"{source}: {text}")


@contextmanager
def stderr_captured(source: str) -> Iterator[None]:
    """Run the block with file descriptor 2 pointed at a temporary file, so that what C
    libraries write there (libpng's "libpng error: ...") is kept in NOTES, not printed."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):   # no descriptor 2 (embedded): nothing to capture
        yield
        return
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            note(source, tmp.read().decode("utf-8", "replace"))


@contextmanager
def warnings_captured() -> Iterator[None]:
    """Run the block with Python warnings (NumPy's RuntimeWarnings among them) kept in NOTES."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            yield
        finally:
            for w in caught:
                note(f"{w.category.__name__} at {os.path.basename(w.filename)}:{w.lineno}", str(w.message))

"""glibc malloc's thresholds (mallopt(3)), set by the processes that render frame after frame.

No NumPy here: the command line sets them before NumPy is imported (clshade.cli.process.tune_allocator),
and the live viewer raises them further (clshade.render.arrays.keep_freed_memory)."""
from __future__ import annotations

import ctypes

#: glibc's mallopt(3) parameters (malloc.h).
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3


def set_malloc_thresholds(mmap_threshold: int, trim_threshold: int) -> bool:
    """Set glibc malloc's mmap and trim thresholds (mallopt); False (nothing more changed) where the
    C library has no mallopt (musl, macOS) or refuses a value."""
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return bool(mallopt(M_MMAP_THRESHOLD, mmap_threshold)) and bool(mallopt(M_TRIM_THRESHOLD, trim_threshold))

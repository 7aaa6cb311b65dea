"""Settings of the `clshade` process, made by `run` before and after its command: the cyclic
garbage collector, glibc's allocator thresholds, NumPy's BLAS threads, and a closed stdout."""
from __future__ import annotations

import gc
import os
import sys


def start_process() -> None:
    """What `run` does before the command line is parsed (benchmarks/measure/startup_bench.py times it
    with the imports): collector paused, allocator tuned, NumPy loaded."""
    gc.disable()
    tune_allocator()
    load_numpy_single_threaded_blas()


BLAS_THREADS = "OPENBLAS_NUM_THREADS"


def load_numpy_single_threaded_blas() -> None:
    """Import NumPy with its OpenBLAS limited to one thread, unless the user set
    OPENBLAS_NUM_THREADS. OpenBLAS otherwise starts a worker thread per core that busy-waits
    after start-up and after each call, on the core PoCL's threads need; clshade's BLAS
    calls are 3×3 transforms of vertex arrays. OpenBLAS
    reads the variable once, when it loads: it is removed again, so child processes see the
    environment the user gave."""
    if "numpy" in sys.modules or BLAS_THREADS in os.environ:
        return
    os.environ[BLAS_THREADS] = "1"
    try:
        import numpy  # noqa: F401
    finally:
        del os.environ[BLAS_THREADS]


#: Blocks up to this size come from the heap, where freed blocks are reused, instead of
#: fresh mmap(2)s that the kernel zero-fills page by page on first touch (32 MiB: glibc's
#: largest allowed value). A render allocates and frees NumPy temporaries of a few MB all
#: the time; with glibc's default (a threshold that adapts from 128 KiB, and the heap's top
#: returned to the system) they were faulted in again and again.
MMAP_THRESHOLD = 32 << 20
#: Free memory at the top of the heap kept for reuse instead of being returned to the
#: system (glibc's default is twice the adapted mmap threshold).
TRIM_THRESHOLD = 128 << 20


def tune_allocator() -> bool:
    """Set MMAP_THRESHOLD and TRIM_THRESHOLD with glibc's mallopt; False (nothing changed)
    where the C library has no mallopt (musl, macOS) or refuses a value."""
    from clshade.allocator import set_malloc_thresholds
    return set_malloc_thresholds(MMAP_THRESHOLD, TRIM_THRESHOLD)


def resume_gc() -> None:
    """Freeze what start-up allocated and collect again from here on."""
    gc.freeze()
    gc.enable()


def quiet_broken_pipe() -> int:
    """stdout's reader went away (`clshade models | head`): stop quietly. stdout is
    pointed at /dev/null so that the interpreter's final flush does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):   # not a real file (tests replace stdout)
        pass
    return 141   # 128 + SIGPIPE, as a shell reports a process killed by it

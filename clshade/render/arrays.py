"""Array helpers of the per-pixel stages: the padding of per-pixel planes, and chunked
work spread over the CPU's cores.

The per-pixel stages work on planes (struct of arrays): NumPy gathers and scatters
one contiguous plane several times faster than interleaved (N, 3) rows. NumPy
releases the GIL inside its loops (ufuncs, take, fancy indexing), so independent
chunks of a per-pixel stage run in parallel on threads; each chunk writes only its
own pixels.
"""
from __future__ import annotations

import os
import sys
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from clshade.allocator import set_malloc_thresholds
from clshade.errors import ClshadeError

#: Below this many items a stage runs on the calling thread: splitting costs
#: more than it saves (pool hand-off ~50 µs a chunk vs ~2 ns an item and op).
PARALLEL_MIN_ITEMS: int = 1 << 16

#: Per-pixel planes (G-buffer channels, device buffers) hold a multiple of this many
#: pixels: the widest SIMD width a kernel work-item reads (kernels/simd.h), so the
#: last work-item reads whole vectors; padding pixels are zero (depth 0: empty).
PIXEL_PAD: int = 16

_pool: ThreadPoolExecutor | None = None
_pool_lock = threading.Lock()


#: Alignment of per-pixel planes in bytes: OpenCL CPU devices can use host memory in
#: place when a buffer is aligned to CL_DEVICE_MEM_BASE_ADDR_ALIGN (1024 bits on PoCL).
PLANE_ALIGN: int = 128


def aligned_zeros(shape: tuple[int, ...], dtype: type, align: int = PLANE_ALIGN) -> np.ndarray:
    """np.zeros(shape, dtype) whose data starts at a multiple of `align` bytes."""
    nbytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
    raw = np.zeros(nbytes + align, np.uint8)
    start = (-raw.ctypes.data) % align
    return raw[start:start + nbytes].view(dtype).reshape(shape)


#: The live viewer's settings (keep_freed_memory): allocations up to this size come from the heap
#: instead of a mapping of their own, and the heap keeps up to KEEP_TRIM_THRESHOLD of free memory
#: instead of giving it back to the system.
KEEP_MMAP_THRESHOLD: int = 256 << 20
KEEP_TRIM_THRESHOLD: int = 1 << 30


def keep_freed_memory() -> bool:
    """Ask glibc's malloc to keep freed memory for the next frame. By default an array above
    its mmap threshold (128 KiB, raised to the size of a large mapped block when one is freed,
    32 MiB at most) gets a mapping of its own, unmapped when freed, and the heap's free top is
    trimmed; a loop that makes the same arrays every frame then pays a page fault per 4 KiB
    page of each, every frame. The viewer frees no large blocks (PlanePool keeps the G-buffer's
    planes), so the threshold stays low and the rasterizer's temporaries were mapped afresh every
    frame: with the pool alone the viewer's rasterize stage was slower than before the pool, with
    this as well it is back where it was (robot, 960×540, the shared 2-core machine). Process-wide and
    permanent; for long-running frame loops (the live viewer). False where the C library is not
    glibc (nothing changed)."""
    return set_malloc_thresholds(KEEP_MMAP_THRESHOLD, KEEP_TRIM_THRESHOLD)


class PlanePool:
    """aligned_zeros from memory used before: on a virtual machine, filling a fresh 2 MB plane
    costs more in page faults than the stage that writes it. A block is handed out again only
    when nothing else refers to it: no array made from it (a G-buffer's plane, a view of
    it, a device buffer sharing it: pyopencl holds the array) is alive, which the block's
    reference count tells exactly. Zero-filled before it is handed out, as aligned_zeros."""

    def __init__(self, limit: int = 64) -> None:
        self.limit = limit
        self._blocks: list[np.ndarray] = []

    def zeros(self, shape: tuple[int, ...], dtype: type, align: int = PLANE_ALIGN) -> np.ndarray:
        return self.empty(shape, dtype, align, fill=True)

    def empty(self, shape: tuple[int, ...], dtype: type, align: int = PLANE_ALIGN, fill: bool = False) -> np.ndarray:
        """An aligned array whose contents are left as they are (for a pass that writes every
        element); `fill`: zero-filled (zeros)."""
        nbytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
        raw = None
        for i in range(len(self._blocks)):
            # 2 references: the list's and getrefcount's argument; any view made from it adds one.
            if self._blocks[i].size == nbytes + align and sys.getrefcount(self._blocks[i]) == 2:
                raw = self._blocks[i]
                if fill:
                    raw.fill(0)
                break
        if raw is None:
            raw = np.zeros(nbytes + align, np.uint8)
            if len(self._blocks) < self.limit:
                self._blocks.append(raw)
        start = (-raw.ctypes.data) % align
        return raw[start:start + nbytes].view(dtype).reshape(shape)

    def copy(self, array: np.ndarray) -> np.ndarray:
        """A copy of `array` in a block of the pool (aligned)."""
        out = self.zeros(array.shape, array.dtype)
        out[...] = array
        return out


def padded(count: int) -> int:
    """`count` rounded up to a multiple of PIXEL_PAD."""
    return (count + PIXEL_PAD - 1) // PIXEL_PAD * PIXEL_PAD


def worker_count() -> int:
    """Threads for per-pixel stages: CLSHADE_THREADS if set (≥ 1), else the CPUs this
    process may run on."""
    env = os.environ.get("CLSHADE_THREADS", "").strip()
    if env:
        try:
            count = int(env)
        except ValueError:
            count = 0
        if count < 1:
            raise ClshadeError(f"environment variable CLSHADE_THREADS = {env!r}: expected an integer ≥ 1")
        return count
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def workers_for(items: int, min_items: int | None = None) -> int:
    """Worker threads worth using for `items` items of work: 1 below `min_items` (default
    PARALLEL_MIN_ITEMS, for per-pixel work)."""
    return worker_count() if items >= (PARALLEL_MIN_ITEMS if min_items is None else min_items) else 1


def _executor(workers: int) -> ThreadPoolExecutor:
    global _pool
    with _pool_lock:
        if _pool is None or _pool._max_workers != workers:  # noqa: SLF001 (resized when the setting changes)
            if _pool is not None:
                _pool.shutdown(wait=False)
            _pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="clshade")
        return _pool


def chunks(n: int, parts: int) -> list[slice]:
    """`n` items as at most `parts` contiguous slices of (nearly) equal size."""
    parts = max(1, min(parts, n))
    bounds = np.linspace(0, n, parts + 1).round().astype(int).tolist()
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]


def run_chunked(n: int, work: Callable[[slice], None], *, max_chunk: int | None = None,
                parts_per_worker: int = 2) -> None:
    """Call `work(slice)` over contiguous chunks of range(n) (at most `max_chunk` items each), on
    the worker threads when `n` is large enough to pay for it. `work` must write only its own
    chunk's outputs."""
    workers = workers_for(n)
    parts = workers * parts_per_worker if workers > 1 else 1
    if max_chunk:
        parts = max(parts, -(-n // max_chunk))
    pieces = chunks(n, parts)
    if workers == 1:
        for piece in pieces:
            work(piece)
        return
    run_tasks([lambda piece=piece: work(piece) for piece in pieces], workers)


def run_tasks(tasks: list[Callable[[], None]], workers: int | None = None) -> None:
    """Run independent tasks on the worker threads (in order on the calling thread when
    there is one worker); re-raises the first task's exception."""
    workers = workers or worker_count()
    if workers == 1 or len(tasks) < 2:
        for task in tasks:
            task()
        return
    for future in [_executor(workers).submit(task) for task in tasks]:
        future.result()

"""The machine's streaming memory bandwidth, STREAM-style (McCalpin): the anchor
every shading pass is compared with, measured without OpenCL.

Copy (c = a) and triad (a = b + s·c) over arrays far larger than the caches, on
every core. Bytes counted as STREAM counts them: copy 2 × 4 B per element (one
read, one write), triad 3 × 4 B (write-allocate traffic not counted). The
fastest available method is used: Numba's parallel loops when Numba is
installed (`pip install 'clshade[peers]'`), else NumPy on one thread per core
over contiguous slices (NumPy releases the GIL inside copyto/add/multiply; its
triad takes two passes, so its rate is a lower bound). Rates are the best of
`repeats` (STREAM's convention) with the median beside it.
"""
from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

STREAM_MIB = 256            # per array: ≫ the last-level cache (32 MiB on this EPYC)
# Bytes per float32 element as STREAM counts them: copy reads one and writes one, triad reads two and
# writes one (write-allocate traffic not counted).
STREAM_BYTES = {"copy": 2 * 4, "triad": 3 * 4}
STREAM_LOOPS = tuple(STREAM_BYTES)
TRIAD_SCALAR = np.float32(3.0)


def _numba_kernels():
    try:
        import numba
    except ImportError:
        return None

    @numba.njit(parallel=True, fastmath=True, cache=False)
    def copy(a, c):
        for i in numba.prange(a.size):
            c[i] = a[i]

    @numba.njit(parallel=True, fastmath=True, cache=False)
    def triad(a, b, c, s):
        for i in numba.prange(a.size):
            a[i] = b[i] + s * c[i]

    return copy, triad, f"numba {numba.__version__} prange, {numba.get_num_threads()} threads"


def _numpy_kernels(threads: int):
    pool = ThreadPoolExecutor(threads)

    def _split(n: int) -> list[slice]:
        step = (n + threads - 1) // threads
        return [slice(k, min(k + step, n)) for k in range(0, n, step)]

    def copy(a, c):
        list(pool.map(lambda s: np.copyto(c[s], a[s]), _split(a.size)))

    def triad(a, b, c, s):
        def part(sl):
            np.multiply(c[sl], s, out=a[sl])
            np.add(a[sl], b[sl], out=a[sl])
        list(pool.map(part, _split(a.size)))

    return copy, triad, f"numpy {np.__version__}, {threads} threads"


def stream(repeats: int = 10, mib: int = STREAM_MIB, method: str = "auto") -> dict[str, object]:
    """Copy and triad bandwidth in GB/s (10⁹ B/s): best and median of `repeats`."""
    n = mib * 2 ** 20 // 4
    a = np.full(n, 1.0, np.float32)
    b = np.full(n, 2.0, np.float32)
    c = np.full(n, 0.5, np.float32)
    threads = os.cpu_count() or 1
    kernels = _numba_kernels() if method in ("auto", "numba") else None
    if kernels is None:
        kernels = _numpy_kernels(threads)
    copy, triad, how = kernels
    copy(a, c)
    triad(a, b, c, TRIAD_SCALAR)         # compile / warm the pages
    times: dict[str, list[float]] = {"copy": [], "triad": []}
    for _ in range(repeats):             # interleaved, like the shading rounds
        t0 = time.perf_counter()
        copy(a, c)
        times["copy"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        triad(a, b, c, TRIAD_SCALAR)
        times["triad"].append(time.perf_counter() - t0)
    moved = {k: b * n for k, b in STREAM_BYTES.items()}
    out: dict[str, object] = dict(method=how, array_mib=mib, repeats=repeats, threads=threads)
    for k, ts in times.items():
        out[f"{k}_best_gbs"] = moved[k] / min(ts) / 1e9
        out[f"{k}_median_gbs"] = moved[k] / float(np.median(ts)) / 1e9
    out["anchor_gbs"] = max(out["copy_best_gbs"], out["triad_best_gbs"])
    return out


# The same two STREAM loops as OpenCL kernels, 16 floats a work-item: what the OpenCL runtime itself
# streams (its work-group scheduling and threads, no G-buffer layout), beside the anchor above. Each
# twice: with plain stores, and on x86 with streaming (non-temporal) stores, which skip the read for
# ownership of every written line — the store the image kernels use (kernels/simd.h, STORE_ROW8),
# and STREAM's own when its compiler emits them; the anchor is the faster.
OPENCL_STREAM_SOURCE = """
#if defined(__x86_64__)
#define STREAMING_STORE(v, p) __builtin_nontemporal_store((v), (p))
#else
#define STREAMING_STORE(v, p) (*(p) = (v))
#endif
__kernel void copy(__global const float16* a, __global float16* c) {
    size_t i = get_global_id(0);
    c[i] = a[i];
}
__kernel void triad(__global float16* a, __global const float16* b, __global const float16* c, const float s) {
    size_t i = get_global_id(0);
    a[i] = b[i] + s * c[i];   /* STREAM triad */
}
__kernel void copy_streaming(__global const float16* a, __global float16* c) {
    size_t i = get_global_id(0);
    STREAMING_STORE(a[i], c + i);
}
__kernel void triad_streaming(__global float16* a, __global const float16* b, __global const float16* c,
                              const float s) {
    size_t i = get_global_id(0);
    STREAMING_STORE(b[i] + s * c[i], a + i);
}
__kernel void fill_streaming(__global float16* c, const float v) {
    size_t i = get_global_id(0);
    STREAMING_STORE((float16)(v), c + i);
}
"""
# The OpenCL STREAM loops by store kind: the suffix of their kernel names and of their result keys.
STORE_KINDS = {"plain": "", "streaming": "_streaming"}


class OpenCLStream:
    """The STREAM copy and triad as OpenCL kernels on a clshade Runtime's device, over three arrays of
    `mib` MiB: c = b, then a = b + s·c (fixed values every repeat, so `check()` can verify them), with
    plain or streaming stores (STORE_KINDS)."""

    def __init__(self, runtime, mib: int = STREAM_MIB) -> None:
        self.rt, self.n = runtime, mib * 2 ** 20 // 4
        self.a, self.b, self.c = (runtime.to_device(np.full(self.n, v, np.float32)) for v in (1.0, 2.0, 0.5))
        self._kernels = {(loop, kind): runtime.kernel(OPENCL_STREAM_SOURCE, loop + suffix,
                                                      label=f"STREAM {loop} ({kind} stores)")
                         for loop in STREAM_LOOPS for kind, suffix in STORE_KINDS.items()}
        self._fill = runtime.kernel(OPENCL_STREAM_SOURCE, "fill_streaming", label="STREAM fill (streaming stores)")
        self.items = runtime.global_size(self.n // 16)
        if self.items != self.n // 16:
            raise ValueError(f"{mib} MiB is not a multiple of the work-group size {runtime.local_size} × 16 floats")

    def _run(self, kernel, *args) -> float:
        kernel.set_args(*args)
        ev = self.rt.cl.enqueue_nd_range_kernel(self.rt.queue, kernel, (self.items,), (self.rt.local_size,))
        ev.wait()
        return (ev.profile.end - ev.profile.start) * 1e-9

    def copy(self, stores: str = "plain") -> float:
        """One copy c = b; its kernel time in s."""
        return self._run(self._kernels["copy", stores], self.b, self.c)

    def triad(self, stores: str = "plain") -> float:
        """One triad a = b + s·c; its kernel time in s."""
        return self._run(self._kernels["triad", stores], self.a, self.b, self.c, TRIAD_SCALAR)

    def fill(self, value: float) -> float:
        """One streaming-store fill c = value; its kernel time in s."""
        return self._run(self._fill, self.c, np.float32(value))

    def check_fill(self, value: float) -> None:
        got = np.empty(self.n, np.float32)
        self.rt.cl.enqueue_copy(self.rt.queue, got, self.c)
        if not np.all(got == np.float32(value)):
            raise RuntimeError(f"the OpenCL fill of {value} wrote other values on {self.rt.info.description}")

    def check(self) -> None:
        got_a, got_c = np.empty(self.n, np.float32), np.empty(self.n, np.float32)
        self.rt.cl.enqueue_copy(self.rt.queue, got_a, self.a)
        self.rt.cl.enqueue_copy(self.rt.queue, got_c, self.c)
        if not (np.all(got_c == 2.0) and np.all(got_a == np.float32(2.0) + TRIAD_SCALAR * np.float32(2.0))):
            raise RuntimeError(f"OpenCL STREAM kernels computed wrong values on {self.rt.info.description}")


def opencl_stream(runtime, repeats: int = 10, mib: int = STREAM_MIB) -> dict[str, object]:
    """Copy and triad bandwidth of OpenCL kernels on `runtime`'s device (a clshade Runtime), counted
    as STREAM counts (best and median of `repeats`, from the profiling events), in GB/s: keys
    copy_… and triad_… with plain stores, copy_streaming_… and triad_streaming_… with streaming
    ones. Each kind's result is checked (`OpenCLStream.check`) after its repeats."""
    st = OpenCLStream(runtime, mib)
    loops = [(loop, kind) for kind in STORE_KINDS for loop in STREAM_LOOPS]
    times: dict[tuple[str, str], list[float]] = {key: [] for key in loops}
    for loop, kind in loops:                 # warm the pages and build
        getattr(st, loop)(kind)
    for kind in STORE_KINDS:
        for _ in range(repeats):             # copy and triad interleaved, like the shading rounds
            for loop in STREAM_LOOPS:
                times[loop, kind].append(getattr(st, loop)(kind))
        st.check()
    n = st.n
    out: dict[str, object] = dict(method=f"OpenCL float16 kernels on {runtime.info.description}", array_mib=mib,
                                  repeats=repeats)
    for (loop, kind), ts in times.items():
        key = loop + STORE_KINDS[kind]
        out[f"{key}_best_gbs"] = STREAM_BYTES[loop] * n / min(ts) / 1e9
        out[f"{key}_median_gbs"] = STREAM_BYTES[loop] * n / float(np.median(ts)) / 1e9
    out["best_gbs"] = max(v for k, v in out.items() if k.endswith("_best_gbs"))
    return out


# The two values of `opencl_fill`: whether lines of zeros are written faster than lines of anything
# else (some CPUs elide zero lines; docs/bench-notes.md). copy.cl writes the background, as shade.cl does.
FILL_VALUES = {"zeros": 0.0, "ones": 1.0}


def opencl_fill(runtime, repeats: int = 10, mib: int = STREAM_MIB) -> dict[str, object]:
    """Write bandwidth (4 B per element, GB/s, best and median of `repeats`) of a streaming-store
    fill of one `mib` MiB array with 0 and with 1.0, interleaved, on `runtime`'s device: keys
    zeros_… and ones_…, and `zeros_over_ones` (ratio of the medians). Each fill's values are
    checked after its last repeat."""
    st = OpenCLStream(runtime, mib)
    times: dict[str, list[float]] = {k: [] for k in FILL_VALUES}
    for r in range(repeats + 1):             # the first round warms the pages and is not kept
        for name, v in FILL_VALUES.items():
            t = st.fill(v)
            if r:
                times[name].append(t)
            if r == repeats:
                st.check_fill(v)
    out: dict[str, object] = dict(method=f"OpenCL float16 streaming fill on {runtime.info.description}",
                                  array_mib=mib, repeats=repeats)
    for name, ts in times.items():
        out[f"{name}_best_gbs"] = 4 * st.n / min(ts) / 1e9
        out[f"{name}_median_gbs"] = 4 * st.n / float(np.median(ts)) / 1e9
    out["zeros_over_ones"] = out["zeros_median_gbs"] / out["ones_median_gbs"]
    return out


def numba_triad(mib: int):
    """(one Numba STREAM triad over three `mib` MiB arrays → its time in s, method) or None without Numba."""
    kernels = _numba_kernels()
    if kernels is None:
        return None
    _, triad, how = kernels
    n = mib * 2 ** 20 // 4
    a, b, c = (np.full(n, v, np.float32) for v in (1.0, 2.0, 0.5))
    triad(a, b, c, TRIAD_SCALAR)

    def once() -> float:
        t0 = time.perf_counter()
        triad(a, b, c, TRIAD_SCALAR)
        return time.perf_counter() - t0
    return once, how

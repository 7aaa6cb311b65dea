"""The display transform on the device (kernels/display.cl), bit for bit that of
clshade.render.image.to_display, for frames that go to a screen (`clshade view`).

to_display maps each channel on its own and never decreases as the radiance grows,
so a channel's 8-bit level is the count of 255 thresholds at or below it. The
thresholds are found here with to_display itself (one source of truth; bisection over
float32 bit patterns), and each one is checked against its neighbours: if rounding
ever made the transform step down near a threshold, `thresholds` refuses rather than
show a frame that differs from the file `clshade render` writes.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from clshade.device.runtime import Runtime
from clshade.errors import ClshadeError
from clshade.render.arrays import PIXEL_PAD
from clshade.render.image import to_display
from clshade.resources import kernels_dir

DISPLAY_SOURCE = "display.cl"
LEVELS = 255                       # 8-bit levels above 0: one threshold each
#: Largest finite float32 as a bit pattern; every non-negative float32 up to it orders like its bits.
F32_MAX_BITS = 0x7F7FFFFF
#: Float32 steps checked on each side of a threshold: to_display's float64 arithmetic rounds
#: within an ulp or two, so a step down (non-monotone rounding) could only hide this close.
CHECK_ULPS = 64


def _levels(bits: np.ndarray, method: str, exposure: float) -> np.ndarray:
    """to_display's 8-bit level of each float32 bit pattern."""
    x = np.ascontiguousarray(bits, np.uint32).view(np.float32)
    image = np.repeat(x[None, :, None], 3, axis=2)
    return to_display(image, method, exposure)[0, :, 0].astype(np.int64)


@lru_cache(maxsize=64)
def thresholds(method: str, exposure: float) -> np.ndarray:
    """(255,) float32 ascending: entry k is the least float32 whose level is > k (+inf if none)."""
    want = np.arange(1, LEVELS + 1)
    lo = np.zeros(LEVELS, np.int64)
    hi = np.full(LEVELS, F32_MAX_BITS + 1, np.int64)     # F32_MAX_BITS + 1 stands for "none"
    while np.any(lo < hi):
        mid = (lo + hi) // 2
        up = _levels(np.minimum(mid, F32_MAX_BITS), method, exposure) >= want
        up &= mid <= F32_MAX_BITS
        hi = np.where(up & (lo < hi), mid, hi)
        lo = np.where(~up & (lo < hi), mid + 1, lo)
    reached = lo <= F32_MAX_BITS
    t = np.where(reached, lo, 0).astype(np.uint32).view(np.float32).copy()
    t[~reached] = np.inf
    _check(lo[reached], want[reached], method, exposure)
    return t


def _check(found: np.ndarray, want: np.ndarray, method: str, exposure: float) -> None:
    """Around each threshold, every float32 below maps below the level and every one at or
    above maps to it or higher."""
    offsets = np.arange(-CHECK_ULPS, CHECK_ULPS + 1)
    bits = np.clip(found[:, None] + offsets, 0, F32_MAX_BITS)
    levels = _levels(bits.ravel(), method, exposure).reshape(bits.shape)
    ok = np.where(bits >= found[:, None], levels >= want[:, None], levels < want[:, None])
    if not ok.all():
        k = int(want[~ok.all(axis=1)][0])
        raise ClshadeError(f"display transform ({method}, exposure {exposure:g}) is not monotone near level {k}: "
                           f"the device display cannot reproduce it")


#: Float32 bits below a bucket's index (kernels/display.cl, BUCKET_SHIFT): buckets of the
#: non-negative floats, each 2⁻⁸ of an octave wide.
BUCKET_SHIFT = 15


@lru_cache(maxsize=64)
def bucket_tables(method: str, exposure: float) -> tuple[np.ndarray, np.ndarray, int]:
    """(base, cross, first): for the buckets of positive float32 values from the one of the first
    finite threshold to the one of the last (kernels/display.cl clamps a value's bucket into
    them), the level of each bucket's least value and the one threshold inside it (+inf if
    none), from `thresholds`; `first` the first bucket's index. Refuses a bucket that holds two
    thresholds."""
    t = thresholds(method, exposure)
    finite = t[np.isfinite(t)]
    if finite.size == 0:    # every value shows as 0 (a very low exposure): one bucket that nothing crosses, +∞ included
        return np.zeros(1, np.uint8), np.full(1, np.nan, np.float32), 0
    first, end = (int(finite[k].view(np.uint32)) >> BUCKET_SHIFT for k in (0, -1))
    start = np.arange(first, end + 1, dtype=np.int64) << BUCKET_SHIFT
    low = start.astype(np.uint32).view(np.float32)
    high = (start + (1 << BUCKET_SHIFT) - 1).astype(np.uint32).view(np.float32)
    base = np.searchsorted(t, low, side="right")
    steps = np.searchsorted(t, high, side="right") - base
    if steps.max() > 1:
        raise ClshadeError(f"display transform ({method}, exposure {exposure:g}): a bucket of float32 values "
                           f"holds {steps.max()} level steps; the device display cannot reproduce it")
    cross = np.where(steps == 1, t[np.minimum(base, LEVELS - 1)], np.inf).astype(np.float32)
    return base.astype(np.uint8), cross, first


#: Pixels a work-item of kernels/display.cl transforms: the radiance buffer holds the pixel count
#: rounded up to a multiple of it (the shading kernels' and the resolve's outputs do), the output too.
PIXELS_PER_ITEM = 4
if PIXEL_PAD % PIXELS_PER_ITEM:     # the resolve's output is padded(): whole work-items
    raise ImportError(f"PIXEL_PAD {PIXEL_PAD} is not a multiple of PIXELS_PER_ITEM {PIXELS_PER_ITEM}")


def items(pixels: int) -> int:
    """The display kernel's work-items for `pixels`: one per PIXELS_PER_ITEM, the last one partial."""
    return -(-int(pixels) // PIXELS_PER_ITEM)


class Display:
    """Radiance buffer (float4 per pixel) → RGBA8 on the device, then read back (or read in place)."""

    def __init__(self, runtime: Runtime) -> None:
        self.rt = runtime
        text = (kernels_dir() / DISPLAY_SOURCE).read_text(encoding="utf-8")
        built = runtime.kernel(f"#line 1 \"{DISPLAY_SOURCE}\"\n{text}\n", "display",
                               (f"-DPIXELS_PER_ITEM={PIXELS_PER_ITEM}",), label="display")
        cl = runtime.cl
        self.kernel = cl.Kernel(built.get_info(cl.kernel_info.PROGRAM), "display")
        self._tables: dict[tuple[str, float], tuple[object, ...]] = {}
        #: (pixels, slot) → (buffer, host array or None): Runtime.host_output's, one per view of a frame.
        self._out: dict[tuple[int, str], tuple[object, np.ndarray | None]] = {}

    def table(self, method: str, exposure: float):
        key = (method, float(exposure))
        if key not in self._tables:
            if len(self._tables) > 64:
                self._tables.clear()
            base, cross, first = bucket_tables(method, float(exposure))
            self._tables[key] = (self.rt.to_device(base), self.rt.to_device(cross), np.uint32(first),
                                 np.uint32(len(base) - 1))
        return self._tables[key]

    def enqueue(self, radiance, pixels: int, method: str, exposure: float, wait_for=None, slot: str = "a"):
        """Enqueue the transform of `pixels` float4 of `radiance` into the output of `slot` (each
        view of a frame its own: one read in place is not overwritten by the next view's);
        returns (event, output buffer). `radiance` holds `pixels` rounded up to PIXELS_PER_ITEM."""
        rounded = items(pixels) * PIXELS_PER_ITEM
        need = rounded * 16
        if radiance.size < need:
            raise ClshadeError(f"display transform: the radiance buffer holds {radiance.size} bytes, the kernel "
                               f"reads {need} ({pixels} pixels rounded up to {PIXELS_PER_ITEM})")
        if any(size != pixels for size, _ in self._out):
            self._out = {}                  # a new frame size: the old outputs go
        if (pixels, slot) not in self._out:
            self._out[(pixels, slot)] = self.rt.host_output(rounded, np.uint32)
        out = self._out[(pixels, slot)][0]
        self.kernel.set_args(np.uint32(pixels), radiance, *self.table(method, exposure), out)
        event = self.rt.cl.enqueue_nd_range_kernel(self.rt.queue, self.kernel, (self.rt.global_size(items(pixels)),),
                                                   (self.rt.local_size,), wait_for=wait_for)
        return event, out

    def read(self, out, height: int, width: int, copy: bool = True) -> np.ndarray:
        """The (height, width, 4) uint8 image in `out`. `copy=False`: where the output lives in host
        memory (CPU devices) the image is that memory, valid until the next transform into the
        same slot; elsewhere a copy."""
        host = next((array for buffer, array in self._out.values() if buffer is out), None)
        if not copy and host is not None:
            self.rt.read_in_place((out, host))
            return host[:height * width].view(np.uint8).reshape(height, width, 4)
        rgba = np.empty((height, width, 4), np.uint8)
        self.rt.cl.enqueue_copy(self.rt.queue, rgba, out)
        return rgba

"""The buffers of a Runtime: uploads, shared host arrays, kernel outputs read in place; and
Staging, buffers reused frame after frame for a stream's per-frame inputs.

A mixin of clshade.device.runtime.Runtime, which gives it `cl` (pyopencl), `context`, `queue`,
`device` and `info` (DeviceInfo: `kind` says whether the device is a CPU, where a buffer can be
host memory itself).
"""
from __future__ import annotations

import numpy as np

from clshade import budget
from clshade.render.arrays import aligned_zeros


class DeviceBuffers:
    """Buffer helpers over a Runtime's context and queue."""

    def to_device(self, array: np.ndarray):
        """Upload a contiguous array into a read-only device buffer."""
        mf = self.cl.mem_flags
        array = np.ascontiguousarray(array)
        return self.cl.Buffer(self.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=array)

    def share(self, array: np.ndarray):
        """A read-only device buffer of a contiguous array that the caller keeps unchanged
        while the buffer lives. On a CPU device with the array aligned as the device needs
        (CL_DEVICE_MEM_BASE_ADDR_ALIGN; clshade.render.arrays.aligned_zeros) the buffer is the
        array itself (CL_MEM_USE_HOST_PTR: no copy; unaligned, PoCL would copy it at every
        launch); otherwise it is a copy, as to_device."""
        array = np.ascontiguousarray(array)
        if "cpu" in self.info.kind and array.ctypes.data % self.base_align == 0:
            mf = self.cl.mem_flags
            return self.cl.Buffer(self.context, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=array)
        return self.to_device(array)

    @property
    def base_align(self) -> int:
        """The device's buffer base alignment in bytes."""
        if not hasattr(self, "_base_align"):
            self._base_align = max(1, int(self.device.get_info(self.cl.device_info.MEM_BASE_ADDR_ALIGN)) // 8)
        return self._base_align

    def empty(self, nbytes: int):
        return self.cl.Buffer(self.context, self.cl.mem_flags.READ_WRITE, size=max(int(nbytes), 1))

    def host_output(self, count: int, dtype: type = np.float32) -> tuple[object, np.ndarray | None]:
        """A buffer of `count` elements that kernels write: on a CPU device a host array's own memory
        (CL_MEM_USE_HOST_PTR on an aligned array: the host reads the result in place, after a map,
        with no copy), returned with it; elsewhere a device buffer and None."""
        if "cpu" not in self.info.kind:
            return self.empty(count * np.dtype(dtype).itemsize), None
        array = aligned_zeros((max(int(count), 1),), dtype, max(self.base_align, 64))
        mf = self.cl.mem_flags
        return self.cl.Buffer(self.context, mf.READ_WRITE | mf.USE_HOST_PTR, hostbuf=array), array

    def read_in_place(self, *pairs: tuple[object, np.ndarray]) -> None:
        """Make each (buffer, host array) pair of host_output's hold the kernels' last writes:
        map for reading and unmap (no copy where the buffer uses the array's memory), then wait."""
        cl = self.cl
        for buffer, array in pairs:
            mapped, _ = cl.enqueue_map_buffer(self.queue, buffer, cl.map_flags.READ, 0, array.size, array.dtype,
                                              is_blocking=False)
            mapped.base.release(self.queue)
        self.queue.finish()


class Staging:
    """Buffers reused frame after frame for a stream's per-frame inputs (a frame's triangle setup,
    its coverage batches), one per slot, grown to the next power of two when an input outgrows it,
    instead of a new buffer a frame: a new buffer costs an allocation and first-touch page faults on
    the copy (on Intel's CPU runtime a noticeable share of a 1080p viewer frame; docs/bench-notes.md).
    A slot keeps its largest size; on a CPU device each growth is checked against the memory available
    (budget.check_memory; elsewhere the runtime refuses a buffer its device cannot hold).
    On a CPU device a slot is an aligned host array that is the buffer's memory
    (CL_MEM_USE_HOST_PTR), written by the host with no command — as `share`, this relies on the CPU
    runtimes (PoCL, Intel's) using that memory itself, not a copy; elsewhere a device buffer written
    by a non-blocking copy on the in-order queue, its event kept until the slot is written again
    (pyopencl's copy event blocks when dropped). The caller writes a slot only once the kernels that
    read its last contents are done (DeviceGBuffer.build ends each frame by waiting for them)."""

    def __init__(self, runtime: DeviceBuffers) -> None:
        self.rt = runtime
        self._host = "cpu" in runtime.info.kind
        self._slots: dict[object, tuple[object, np.ndarray | None]] = {}
        #: slot → the pending copy's event (off CPU devices; pyopencl's event keeps its source array alive).
        self._copies: dict[object, object] = {}

    def upload(self, slot: object, array: np.ndarray):
        """A read-only buffer of the kernels' that holds `array` (contiguous) from its start; its size
        may be larger (the kernels read as many elements as they are told)."""
        array = np.ascontiguousarray(array)
        cl = self.rt.cl
        buffer, host = self._slots.get(slot, (None, None))
        if buffer is None or buffer.size < array.nbytes:
            size = 1 << max(int(array.nbytes) - 1, 63).bit_length()      # a power of two, at least 64 bytes
            if self._host:
                budget.check_memory(f"the staging buffer for {slot!r} ({array.nbytes} bytes of input)", size)
                host = aligned_zeros((size,), np.uint8, max(self.rt.base_align, 64))
                buffer = cl.Buffer(self.rt.context, cl.mem_flags.READ_ONLY | cl.mem_flags.USE_HOST_PTR, hostbuf=host)
            else:
                buffer = cl.Buffer(self.rt.context, cl.mem_flags.READ_ONLY, size=size)
            self._slots[slot] = buffer, host
        if host is not None:
            host[:array.nbytes] = array.reshape(-1).view(np.uint8)
        elif array.nbytes:
            self._copies[slot] = cl.enqueue_copy(self.rt.queue, buffer, array, is_blocking=False)
        return buffer

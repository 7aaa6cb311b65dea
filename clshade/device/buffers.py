"""The buffers of a Runtime: uploads, shared host arrays, kernel outputs read in place.

A mixin of clshade.device.runtime.Runtime, which gives it `cl` (pyopencl), `context`, `queue`,
`device` and `info` (DeviceInfo: `kind` says whether the device is a CPU, where a buffer can be
host memory itself).
"""
from __future__ import annotations

import numpy as np

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

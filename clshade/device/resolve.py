"""The supersampling resolve on the device: N×N shaded samples → one pixel (kernels/resolve.cl).

`Resolver` owns the output buffer of the resolved image and the built kernel;
`ResolvedEvent` joins the shading event and the resolve event so that callers
timing `Shader.enqueue` (the bench, contact sheets) see the whole frame: from the
start of the shading kernel to the end of the resolve.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from clshade.device.runtime import Runtime
from clshade.render.arrays import padded
from clshade.resources import kernels_dir

RESOLVE_SOURCE = "resolve.cl"


def resolve_source(samples: int) -> str:
    """The resolve program for N = `samples` (a compile-time constant)."""
    text = (kernels_dir() / RESOLVE_SOURCE).read_text(encoding="utf-8")
    return f"#define SAMPLES {int(samples)}\n#line 1 \"{RESOLVE_SOURCE}\"\n{text}\n"


@dataclass(frozen=True)
class _Profile:
    start: int
    end: int


class ResolvedEvent:
    """Shading then resolve, waited on and profiled as one frame."""

    def __init__(self, shade, resolve) -> None:
        self.shade, self.resolve = shade, resolve

    def wait(self) -> None:
        self.resolve.wait()

    @property
    def profile(self) -> _Profile:
        return _Profile(self.shade.profile.start, self.resolve.profile.end)


class Resolver:
    """Box-filter a (N·H, N·W) float4 samples buffer into (H, W) on the device."""

    def __init__(self, runtime: Runtime, width: int, height: int, samples: int, source_buffer) -> None:
        self.rt, self.width, self.height, self.samples = runtime, width, height, samples
        self.source = source_buffer        # held: a kernel's arguments do not keep their buffers alive
        self.out = runtime.empty(padded(width * height) * 16)   # whole float4 rows of PIXEL_PAD: the display reads them
        built = runtime.kernel(resolve_source(samples), "resolve", label=f"resolve {samples}x{samples}")
        cl = runtime.cl
        self.kernel = cl.Kernel(built.get_info(cl.kernel_info.PROGRAM), "resolve")
        self.kernel.set_args(np.uint32(width), np.uint32(width * height), source_buffer, self.out)
        self.global_size = runtime.global_size(width * height)

    def enqueue(self, after):
        """Resolve once `after` (the shading event) is complete; returns a ResolvedEvent."""
        event = self.rt.cl.enqueue_nd_range_kernel(self.rt.queue, self.kernel, (self.global_size,),
                                                   (self.rt.local_size,), wait_for=[after])
        return ResolvedEvent(after, event)

    def read(self) -> np.ndarray:
        image = np.empty((self.height, self.width, 4), np.float32)
        self.rt.cl.enqueue_copy(self.rt.queue, image, self.out)
        return image


class CoverageBlend:
    """The MSAA-style resolve: blend a once-per-pixel shaded image with the background
    by each pixel's sample coverage, in place on the device (kernels/resolve.cl)."""

    def __init__(self, runtime: Runtime, coverage: np.ndarray, background: np.ndarray, image_buffer) -> None:
        self.rt = runtime
        self.height, self.width = coverage.shape
        self.coverage = runtime.to_device(np.ascontiguousarray(coverage, np.float32).ravel())
        self.image = image_buffer
        # resolve_source needs a SAMPLES value; blend_coverage does not use it.
        built = runtime.kernel(resolve_source(1), "blend_coverage", label="blend_coverage")
        cl = runtime.cl
        self.kernel = cl.Kernel(built.get_info(cl.kernel_info.PROGRAM), "blend_coverage")
        n = coverage.size
        self.kernel.set_args(np.uint32(n), self.coverage, np.asarray(background, np.float32), image_buffer)
        self.global_size = runtime.global_size(n)

    def enqueue(self, after):
        event = self.rt.cl.enqueue_nd_range_kernel(self.rt.queue, self.kernel, (self.global_size,),
                                                   (self.rt.local_size,), wait_for=[after])
        return ResolvedEvent(after, event)

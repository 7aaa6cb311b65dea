"""The G-buffer from a visibility buffer on the device (kernels/visibility.cl): the winners'
barycentrics and depth and the per-pixel interpolation of build_gbuffer in one kernel, bit for
bit the G-buffer that build_gbuffer makes from rasterize_mesh's fragments.

The live viewer's orbit frames use it: the rasterizer stops at the visibility buffer
(clshade.render.raster.rasterize_visibility) and the device does the rest, instead of NumPy's
winners step and G-buffer passes. Scenes with textures (the texture sampling is NumPy's), a
tangent channel, or a device without double precision keep the host path (`supports`).
"""
from __future__ import annotations

import numpy as np

from clshade.device.runtime import Runtime
from clshade.render.arrays import PlanePool, aligned_zeros, padded
from clshade.render.gbuffer import CHANNELS, GBuffer
from clshade.render.meshes import Geometry
from clshade.render.raster import Visibility
from clshade.resources import kernels_dir

SOURCE = "visibility.cl"
#: Pixels per work-item (LANES in kernels/visibility.cl); the planes' padding (PIXEL_PAD) is a multiple.
LANES = 8
#: The kernel's float division and square root must round as NumPy's do (IEEE, correctly rounded).
EXACT_OPTIONS = ("-cl-fp32-correctly-rounded-divide-sqrt",)


def supports(runtime: Runtime, geometry: Geometry) -> bool:
    """Whether the device path gives build_gbuffer's G-buffer for this geometry: no textures
    (sampled on the host), and a device with double precision (the winners' step)."""
    return geometry.face_texture is None and "cl_khr_fp64" in runtime.device.extensions


class DeviceGBuffer:
    """One geometry's face tables on the device and the kernel that fills a G-buffer's planes."""

    def __init__(self, runtime: Runtime, geometry: Geometry, faces: dict[str, np.ndarray]) -> None:
        """`faces`: face_planes(geometry, materials) (without tangents)."""
        if not supports(runtime, geometry):
            raise ValueError("DeviceGBuffer: textured geometry or a device without double precision "
                             "(build_gbuffer makes that G-buffer)")
        self.rt = runtime
        self.emissive = "emissive0" in faces
        text = (kernels_dir() / SOURCE).read_text(encoding="utf-8")
        options = EXACT_OPTIONS + (f"-DHAS_EMISSIVE={int(self.emissive)}",)
        built = runtime.kernel(f"#line 1 \"{SOURCE}\"\n{text}\n", "visibility", options, label="visibility")
        cl = runtime.cl
        self.kernel = cl.Kernel(built.get_info(cl.kernel_info.PROGRAM), "visibility")
        self.n_faces = len(geometry.faces)
        stack = lambda names, dtype: runtime.to_device(np.stack([faces[k] for k in names]).astype(dtype))  # noqa: E731
        self.tables = [
            runtime.to_device(np.ascontiguousarray(geometry.faces.T, np.int32)),
            np.uint32(self.n_faces),
            stack([f"n{c}{d}" for c in range(3) for d in range(3)], np.float32),
            stack([f"base{d}" for d in range(3)], np.float32),
            runtime.to_device(faces["roughness"].astype(np.float32)),
            runtime.to_device(faces["metallic"].astype(np.float32)),
            runtime.to_device(faces["material"].astype(np.uint8)),
        ]
        self.emissive_table = [stack([f"emissive{d}" for d in range(3)], np.float32)] if self.emissive else []

    def build(self, visibility: Visibility, materials: np.ndarray,
              pool: PlanePool | None = None) -> tuple[GBuffer, np.ndarray]:
        """The G-buffer of `visibility` (a view of this geometry) with the material table
        `materials` (clshade.render.gbuffer.material_table), and per pixel whether a fragment
        covers it (uint8: 0 empty, 1 covered, 2 covered by non-finite inputs, replaced). The
        planes are host arrays (from `pool` when given) that the kernel writes through."""
        rt, cl = self.rt, self.rt.cl
        w, h = visibility.width, visibility.height
        n = w * h
        plane = padded(n)
        names = [name for name in CHANNELS if name not in ("tangent", "emissive", "occlusion")
                 or (name == "emissive" and self.emissive)]
        empty = pool.empty if pool is not None else aligned_zeros
        planes = {name: empty((CHANNELS[name][1], plane), CHANNELS[name][0]) for name in names}
        cover = empty((plane,), np.uint8)
        t = visibility.tris
        if t is None:
            setup, tri_face, vdepth, ntri = np.zeros((10, 1)), np.zeros(1, np.int32), np.zeros(1), 1
        else:
            ntri = len(t.face)
            setup = np.concatenate([t.persp_a, t.persp_b, t.persp_c, t.area2[None]])
            tri_face, vdepth = t.face.astype(np.int32), t.vdepth
        mf = cl.mem_flags
        outputs = {name: cl.Buffer(rt.context, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=a.reshape(-1))
                   for name, a in (*planes.items(), ("cover", cover))}
        order = (["emissive"] if self.emissive else []) + ["depth", "normal", "base", "roughness", "metallic", "material", "cover"]
        # Kept referenced until the kernel has run (set_args does not hold the buffers).
        inputs = [rt.to_device(a) for a in (visibility.tri, setup, tri_face, vdepth)]
        self.kernel.set_args(np.uint32(n), np.uint32(plane), np.uint32(w), np.uint32(ntri),
                             np.uint32(visibility.w_is_depth), *inputs, *self.tables,
                             *self.emissive_table, *(outputs[name] for name in order))
        cl.enqueue_nd_range_kernel(rt.queue, self.kernel, (rt.global_size(plane // LANES),), (rt.local_size,))
        for buffer, array in zip(outputs.values(), (*planes.values(), cover)):
            # Mapped and unmapped: the host arrays then hold the result (no copy on a CPU device).
            mapped, _ = cl.enqueue_map_buffer(rt.queue, buffer, cl.map_flags.READ, 0, array.size, array.dtype)
            mapped.base.release(rt.queue)
        rt.queue.finish()
        covered = cover[:n]
        gbuffer = GBuffer.from_planes(w, h, planes, materials, (covered == 1).reshape(h, w),
                                      int(np.count_nonzero(covered == 2)), unit_normals=True)
        return gbuffer, covered

"""The visibility buffer and the G-buffer from it on the device (kernels/visibility.cl): the
rasterizer's coverage tests and depth resolve (kernel `cover`), then the winners'
barycentrics and depth and build_gbuffer's per-pixel interpolation (kernel `visibility`),
bit for bit the G-buffer that build_gbuffer makes from rasterize_mesh's fragments.

The live viewer's orbit frames use it: the host does the triangle setup
(clshade.render.raster.setup_view), the device the rest, instead of NumPy's coverage grids,
winners step and G-buffer passes. Scenes with textures (the texture sampling is NumPy's), a
tangent channel, or a device without double precision or 64-bit atomics keep the host path
(`supports`).
"""
from __future__ import annotations

import numpy as np

from clshade.device.runtime import Runtime
from clshade.render.arrays import PlanePool, aligned_zeros, padded
from clshade.render.gbuffer import CHANNELS, GBuffer, build_gbuffer, channel_names, material_table
from clshade.render.meshes import Geometry
from clshade.render.raster import RasterMesh, ViewSetup, rasterize_mesh, setup_view
from clshade.render.scene import Camera, Scene
from clshade.render.raster.resolve import EMPTY_KEY
from clshade.resources import kernels_dir

SOURCE = "visibility.cl"
#: The kernels' float division and square root must round as NumPy's do (IEEE, correctly rounded).
EXACT_OPTIONS = ("-cl-fp32-correctly-rounded-divide-sqrt",)
#: What the kernels need of the device: doubles (the winners' step) and atom_min on 64-bit keys.
EXTENSIONS = ("cl_khr_fp64", "cl_khr_int64_base_atomics", "cl_khr_int64_extended_atomics")


def supports(runtime: Runtime, geometry: Geometry) -> bool:
    """Whether the device path gives build_gbuffer's G-buffer for this geometry: no textures
    (sampled on the host), and a device with doubles and 64-bit atomics."""
    extensions = runtime.device.extensions.split()
    return geometry.face_texture is None and all(e in extensions for e in EXTENSIONS)


class DeviceGBuffer:
    """One geometry's face tables on the device and the kernel that fills a G-buffer's planes."""

    def __init__(self, runtime: Runtime, geometry: Geometry, faces: dict[str, np.ndarray],
                 lanes: int | None = None) -> None:
        """`faces`: face_planes(geometry, materials) (without tangents); `lanes`: 4 or 8 pixels
        per work-item (default: the device's, Runtime.double_lanes)."""
        if not supports(runtime, geometry):
            raise ValueError("DeviceGBuffer: textured geometry, or a device without double precision or "
                             "64-bit atomics (rasterize_mesh and build_gbuffer make that G-buffer)")
        self.rt = runtime
        self.emissive = geometry.has_emission
        #: The G-buffer's channels (no textures, hence no occlusion; no tangents).
        self.channels = channel_names(geometry)
        text = (kernels_dir() / SOURCE).read_text(encoding="utf-8")
        #: Pixels per work-item (LANES in the kernel); the planes' padding (PIXEL_PAD) is a multiple.
        self.lanes = lanes or runtime.double_lanes
        options = EXACT_OPTIONS + (f"-DHAS_EMISSIVE={int(self.emissive)}", f"-DLANES={self.lanes}")
        built = runtime.kernel(f"#line 1 \"{SOURCE}\"\n{text}\n", "visibility", options, label="visibility")
        cl = runtime.cl
        program = built.get_info(cl.kernel_info.PROGRAM)
        self.kernel, self.cover = cl.Kernel(program, "visibility"), cl.Kernel(program, "cover")
        self._key_pixels, self._key_buffer = 0, None
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

    def build(self, view: ViewSetup, materials: np.ndarray,
              pool: PlanePool | None = None) -> tuple[GBuffer, np.ndarray]:
        """The G-buffer of the view set up in `view` (a view of this geometry) with the material
        table `materials` (clshade.render.gbuffer.material_table), and per pixel whether a fragment
        covers it (uint8: 0 empty, 1 covered, 2 covered by non-finite inputs, replaced). The
        planes are host arrays (from `pool` when given) that the kernel writes through."""
        rt, cl = self.rt, self.rt.cl
        w, h = view.width, view.height
        n = w * h
        plane = padded(n)
        names = self.channels
        empty = pool.empty if pool is not None else aligned_zeros
        planes = {name: empty((CHANNELS[name][1], plane), CHANNELS[name][0]) for name in names}
        cover = empty((plane,), np.uint8)
        keys = self._keys(plane)
        t = view.tris
        # Kept referenced until the kernels have run (set_args does not hold the buffers).
        inputs: list[object] = []
        if t is None:
            ntri, setup, tri_face, vdepth = 1, np.zeros((10, 1)), np.zeros(1, np.int32), np.zeros(1)
        else:
            ntri = len(t.face)
            setup = np.concatenate([t.persp_a, t.persp_b, t.persp_c, t.area2[None]])
            tri_face, vdepth = t.face.astype(np.int32), t.vdepth
            tiles = (((t.col1 - t.col0) // view.tile) + 1) * (((t.row1 - t.row0) // view.tile) + 1)
            tile_end = np.cumsum(tiles).astype(np.uint32)
            box = np.stack([t.col0, t.row0, t.col1, t.row1]).astype(np.int32)
            edge = np.concatenate([t.edge_a, t.edge_b, t.edge_c, t.edge_thr, t.z_a[None], t.z_b[None], t.z_c[None]])
            inputs += [rt.to_device(a) for a in (tile_end, box, edge)]
            ntiles = int(tile_end[-1])
            self.cover.set_args(np.uint32(ntiles), np.uint32(ntri), np.uint32(w), np.uint32(view.tri_bits),
                                np.float64(view.z_scale), np.float64(-1.0 - view.depth_eps),
                                np.float64(1.0 + view.depth_eps), *inputs, keys)
            cl.enqueue_nd_range_kernel(rt.queue, self.cover, (rt.global_size(ntiles),), (rt.local_size,))
        mf = cl.mem_flags
        outputs = {name: cl.Buffer(rt.context, mf.WRITE_ONLY | mf.USE_HOST_PTR, hostbuf=a.reshape(-1))
                   for name, a in (*planes.items(), ("cover", cover))}
        order = (["emissive"] if self.emissive else []) + ["depth", "normal", "base", "roughness", "metallic",
                                                           "material", "cover"]
        inputs += [rt.to_device(a) for a in (setup, tri_face, vdepth)]
        self.kernel.set_args(np.uint32(plane), np.uint32(w), np.uint32(ntri), np.uint32(view.w_is_depth),
                             np.uint32(view.tri_bits), keys, *inputs[-3:], *self.tables, *self.emissive_table,
                             *(outputs[name] for name in order))
        cl.enqueue_nd_range_kernel(rt.queue, self.kernel, (rt.global_size(plane // self.lanes),), (rt.local_size,))
        for buffer, array in zip(outputs.values(), (*planes.values(), cover)):
            # Mapped and unmapped: the host arrays then hold the result (no copy on a CPU device).
            mapped, _ = cl.enqueue_map_buffer(rt.queue, buffer, cl.map_flags.READ, 0, array.size, array.dtype,
                                              is_blocking=False)
            mapped.base.release(rt.queue)
        rt.queue.finish()
        covered = cover[:n]
        gbuffer = GBuffer.from_planes(w, h, planes, materials, (covered == 1).reshape(h, w),
                                      int(np.count_nonzero(covered == 2)), unit_normals=True)
        return gbuffer, covered

    def _keys(self, plane: int):
        """The device's key buffer of `plane` pixels, all empty (the visibility kernel leaves it so)."""
        if self._key_pixels != plane:
            cl = self.rt.cl
            self._key_buffer = cl.Buffer(self.rt.context, cl.mem_flags.READ_WRITE, size=plane * 8)
            cl.enqueue_fill_buffer(self.rt.queue, self._key_buffer, np.int64(EMPTY_KEY), 0, plane * 8)
            self._key_pixels = plane
        return self._key_buffer


#: The frame size of `verify`'s check: small enough to cost a few milliseconds on the host.
VERIFY_SIZE = (96, 54)


def verify(device: DeviceGBuffer, scene: Scene, geometry: Geometry, mesh: RasterMesh, camera: Camera,
           faces: dict[str, np.ndarray]) -> str | None:
    """Whether `device` makes the host's G-buffer on this device: one small frame of `camera`'s
    view (VERIFY_SIZE) both ways, compared bit for bit. None when they agree, else what differs
    (the live viewer then keeps the host path: a device that rounds otherwise, or a compiler
    that breaks the program, must not change the picture)."""
    small = camera.with_size(*VERIFY_SIZE)
    view, proj = small.view_matrix(), small.projection_matrix()
    setup = setup_view(mesh, view, proj, small.width, small.height)
    if setup is None:
        return None                     # more than one face batch: the device path is not used
    fragments = rasterize_mesh(mesh, view, proj, small.width, small.height)
    expected = build_gbuffer(scene, geometry, fragments, small, faces=faces)
    got, cover = device.build(setup, material_table(scene))
    if sorted(got.channels) != sorted(expected.channels):
        return f"channels {sorted(got.channels)}, the host's {sorted(expected.channels)}"
    for name in expected.channels:
        a, b = expected.plane(name), got.plane(name)
        bits = f"u{a.itemsize}"         # compared as bit patterns (NaN, -0), a pixel per column
        differ = int((a.view(bits) != b.view(bits)).any(axis=0).sum())
        if differ:
            return f"{differ} of {small.width * small.height} pixels differ from the host's in {name}"
    if not np.array_equal(np.flatnonzero(cover), fragments.pixels):
        return "the covered pixels differ from the host's"
    return None

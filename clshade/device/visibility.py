"""The visibility buffer and the G-buffer from it on the device (kernels/visibility.cl): the
rasterizer's coverage tests and depth resolve (kernel `cover`), then the winners'
barycentrics and depth and build_gbuffer's per-pixel interpolation (kernel `visibility`),
bit for bit the G-buffer that build_gbuffer makes from rasterize_mesh's fragments.

Textured geometry: its texture sets' mip pyramids are uploaded once (DeviceTextures, within
clshade.budget's texture limits) and kernel `texture` samples them per textured pixel as
gbuffer.py's _texture_pixels does (base colour, metallic-roughness, normal, emissive and
occlusion maps; mip level, trilinear filtering, repeat wrapping). Every plane is bit for bit
the host's but for the textured channels of a few textured pixels, whose mip level's last bits
differ (TEXTURE_TOLERANCE says by how much and why).

The live viewer's orbit frames use it: the host does the triangle setup
(clshade.render.raster.setup_view), the device the rest, instead of NumPy's coverage grids,
winners step and G-buffer passes. A tangent channel, textures that are not RGB, or a device
without double precision or 64-bit atomics keep the host path (`supports`).
"""
from __future__ import annotations

import contextlib

import numpy as np

from clshade import budget
from clshade.device.buffers import Staging
from clshade.device.runtime import Runtime
from clshade.render.arrays import PlanePool, aligned_zeros, padded
from clshade.render.gbuffer import CHANNELS, GBuffer, build_gbuffer, channel_names, material_table
from clshade.render.meshes import Geometry
from clshade.render.raster import RasterMesh, ViewSetup, rasterize_mesh, setup_view
from clshade.render.scene import Camera, Scene
from clshade.render.textures import Texture, TextureSet
from clshade.render.raster.resolve import EMPTY_KEY
from clshade.resources import kernels_dir

SOURCE = "visibility.cl"
#: Most (triangle, tile) pairs kernel `cover` takes in one dispatch: its per-tile triangle list is
#: 4 bytes a pair, so long slivers (a triangle's bounding box spans many tiles) would otherwise
#: grow it with the triangle count times the frame's tiles; more pairs are dispatched in batches of
#: whole triangles (keys resolve by atomic minimum, so the batches' order does not matter).
COVER_BATCH_TILES = 1 << 24
#: Triangles with at least this many tiles are dispatched alone, largest first and before the others
#: (kernel `cover`'s `exclusive`: a plain compare and store per fragment instead of a locked atom_min).
#: A floor or a wall covers much of a frame with a few triangles; each dispatch costs an enqueue.
EXCLUSIVE_MIN_TILES = 512
#: At most this many triangles are dispatched alone per frame (the largest).
EXCLUSIVE_MAX = 8
#: The kernels' float division and square root must round as NumPy's do (IEEE, correctly rounded).
EXACT_OPTIONS = ("-cl-fp32-correctly-rounded-divide-sqrt",)
#: What the kernels need of the device: doubles (the winners' step) and atom_min on 64-bit keys.
EXTENSIONS = ("cl_khr_fp64", "cl_khr_int64_base_atomics", "cl_khr_int64_extended_atomics")


#: Per texture set, the float32 values kernel `texture` reads (SET_FLOATS there): base factor (3),
#: roughness and metallic factors, emissive factor (3), normal scale, occlusion strength.
SET_FLOATS = 10
#: Per texture set, its textures in kernel `texture`'s slots (SET_SLOTS there), -1 for none.
SET_SLOTS = ("base_color", "metallic_roughness", "normal", "emissive", "occlusion")
#: The textured channels (base, roughness, metallic, normal, emission, occlusion) of a textured pixel
#: may differ from the host's by this much (absolute; the channels are factors x [0, 1] texels and unit
#: normals): the host inverts the faces' clip matrices with LAPACK's LU and takes the mip level's log2
#: with NumPy's, the device with the adjugate and its own log2, so λ = log2 ρ can differ in its last
#: bits; trilinear filtering is continuous in λ and in the UV, so a level or texel flip moves a value by
#: about that relative error times the texels' range (measured: <= 7e-8 on the bundled scenes).
TEXTURE_TOLERANCE = 1e-5
#: The share of covered pixels whose textured channels may differ at all, by at most TEXTURE_TOLERANCE
#: (measured: 1 pixel in 3.6e5 at 960x540 on textured.toml, none on the glTF samples; a wrong level,
#: texel, wrap mode or channel changes most textured pixels).
TEXTURE_DIFFER_SHARE = 1e-3
#: Kernel `texture` indexes the texel floats (and the level table holds their offsets) with 32-bit
#: integers: geometries with more keep the host path (`supports`).
MAX_TEXEL_FLOATS = 2 ** 31
#: The channels textures write (the others stay bit for bit the host's).
TEXTURED_CHANNELS = ("normal", "base", "roughness", "metallic", "emissive", "occlusion")


def cover_batches(tile_end: np.ndarray, limit: int) -> list[tuple[int, int, int]]:
    """Triangle ranges [first, last) whose tiles (`tile_end`: the inclusive running count per
    triangle) are at most `limit` each, or one triangle where that triangle alone has more;
    each with `base`, the tiles of the triangles before it."""
    batches, first, n = [], 0, len(tile_end)
    while first < n:
        base = int(tile_end[first - 1]) if first else 0
        last = min(max(int(np.searchsorted(tile_end, base + limit, side="right")), first + 1), n)
        batches.append((first, last, base))
        first = last
    return batches


def exclusive_triangles(tiles: np.ndarray, min_tiles: int | None = None, most: int | None = None) -> np.ndarray:
    """The triangles (indices into `tiles`, each triangle's tile count) that kernel `cover` takes
    alone, one dispatch each: the `most` largest with at least `min_tiles` tiles, largest first
    (defaults: EXCLUSIVE_MAX and EXCLUSIVE_MIN_TILES)."""
    big = np.flatnonzero(tiles >= (EXCLUSIVE_MIN_TILES if min_tiles is None else min_tiles))
    return big[np.argsort(-tiles[big], kind="stable")][:EXCLUSIVE_MAX if most is None else most]


def refusal(runtime: Runtime, geometry: Geometry) -> str | None:
    """Why the device path cannot give build_gbuffer's G-buffer for this geometry, else None. It needs a
    device with doubles and 64-bit atomics (EXTENSIONS) and, for a textured geometry, UVs, tangents and
    textures the device can hold: RGB pyramids whose texels fit in one device buffer (the device's largest
    allocation) and number fewer than MAX_TEXEL_FLOATS floats (kernel `texture`'s 32-bit indices)."""
    has = set(runtime.device.extensions.split())
    missing = [e for e in EXTENSIONS if e not in has]
    if missing:
        return f"{runtime.info.runtime} lacks {', '.join(missing)}"
    if geometry.face_texture is None:
        return None
    lacking = [name for name in ("uvs", "tangents") if getattr(geometry, name) is None]
    if lacking:
        return f"textured faces without {' or '.join(lacking)}"
    textures = distinct_textures(geometry.texture_sets)
    if any(t.levels[0].ndim != 3 or t.levels[0].shape[2] != 3 for t in textures):
        return "textures that are not RGB (kernel texture samples three channels)"
    floats = texel_floats(textures)
    if 4 * floats > runtime.device.max_mem_alloc_size:
        return (f"textures of {4 * floats} bytes, more than the device's largest buffer "
                f"({runtime.device.max_mem_alloc_size} bytes)")
    if floats >= MAX_TEXEL_FLOATS:
        return (f"textures of {floats} texel floats, not fewer than {MAX_TEXEL_FLOATS} (kernel texture's 32-bit "
                "indices)")
    return None


def supports(runtime: Runtime, geometry: Geometry) -> bool:
    """Whether the device path gives build_gbuffer's G-buffer for this geometry (`refusal` says why not)."""
    return refusal(runtime, geometry) is None


def texel_floats(textures: list[Texture]) -> int:
    """The floats of every level of `textures` (DeviceTextures' buffer)."""
    return sum(level.size for t in textures for level in t.levels)


def distinct_textures(sets: tuple[TextureSet, ...]) -> list[Texture]:
    """The distinct textures of the sets (one upload for a texture that several sets share)."""
    seen: dict[int, Texture] = {}
    for t in sets:
        for name in SET_SLOTS:
            texture = getattr(t, name)
            if texture is not None:
                seen.setdefault(id(texture), texture)
    return list(seen.values())


class DeviceTextures:
    """One geometry's texture sets on the device, uploaded once: every level of every texture in
    one float buffer, a (texture: first level, levels, width, height) table, a (level: offset,
    width, height) table, and each set's factors and slots (kernel `texture`'s tables)."""

    def __init__(self, runtime: Runtime, geometry: Geometry) -> None:
        sets = geometry.texture_sets
        textures = distinct_textures(sets)
        index = {id(t): k for k, t in enumerate(textures)}
        texels = texel_floats(textures)
        budget.check_memory(f"the device copy of {len(textures)} textures ({texels // 3} texels)", 4 * texels)
        info, levels, chunks, offset = [], [], [], 0
        for t in textures:
            info.append((len(levels), len(t.levels), *t.size))
            for level in t.levels:
                levels.append((offset, level.shape[1], level.shape[0]))
                chunks.append(level.reshape(-1))
                offset += level.size
        values = np.zeros((max(len(sets), 1), SET_FLOATS), np.float32)
        slots = np.full((max(len(sets), 1), len(SET_SLOTS)), -1, np.int32)
        uv_scale = np.ones(max(len(sets), 1), np.float64)
        with np.errstate(over="ignore"):        # a factor past float32's range is inf, as on the host
            for k, t in enumerate(sets):
                values[k] = [*t.base_factor, t.roughness_factor, t.metallic_factor, *t.emissive_factor,
                             t.normal_scale, t.occlusion_strength]
                uv_scale[k] = t.uv_scale
                for j, name in enumerate(SET_SLOTS):
                    texture = getattr(t, name)
                    # The host samples the emissive map only where the set emits (TextureSet.has_emission).
                    if texture is not None and (name != "emissive" or t.has_emission):
                        slots[k, j] = index[id(texture)]
        #: Bytes of texels on the device.
        self.nbytes = 4 * texels
        self.buffers = [runtime.to_device(a) for a in (
            geometry.face_texture.astype(np.int32), values, uv_scale, slots,
            np.array(info or [(0, 0, 0, 0)], np.int32), np.array(levels or [(0, 0, 0)], np.int32),
            np.concatenate(chunks) if chunks else np.zeros(1, np.float32))]
        self.mesh = [runtime.to_device(a) for a in (
            np.ascontiguousarray(geometry.vertices, np.float64), np.ascontiguousarray(geometry.uvs, np.float32),
            np.ascontiguousarray(geometry.tangents, np.float32))]


class DeviceGBuffer:
    """One geometry's face tables on the device and the kernel that fills a G-buffer's planes."""

    def __init__(self, runtime: Runtime, geometry: Geometry, faces: dict[str, np.ndarray],
                 lanes: int | None = None) -> None:
        """`faces`: face_planes(geometry, materials) (without tangents); `lanes`: 4 or 8 pixels
        per work-item (default: the device's, Runtime.double_lanes)."""
        reason = refusal(runtime, geometry)
        if reason is not None:
            raise ValueError(f"DeviceGBuffer: {reason} (rasterize_mesh and build_gbuffer make that G-buffer)")
        self.rt = runtime
        self.emissive = geometry.has_emission
        self.occlusion = geometry.has_occlusion
        #: The geometry's textures on the device (None: untextured).
        self.textures = DeviceTextures(runtime, geometry) if geometry.face_texture is not None else None
        #: The G-buffer's channels (no tangents).
        self.channels = channel_names(geometry)
        text = (kernels_dir() / SOURCE).read_text(encoding="utf-8")
        #: Pixels per work-item (LANES in the kernel); the planes' padding (PIXEL_PAD) is a multiple.
        self.lanes = lanes or runtime.double_lanes
        options = EXACT_OPTIONS + (f"-DHAS_EMISSIVE={int(self.emissive)}", f"-DLANES={self.lanes}",
                                   f"-DHAS_TEXTURES={int(self.textures is not None)}",
                                   f"-DHAS_OCCLUSION={int(self.occlusion)}")
        built = runtime.kernel(f"#line 1 \"{SOURCE}\"\n{text}\n", "visibility", options, label="visibility")
        cl = runtime.cl
        program = built.get_info(cl.kernel_info.PROGRAM)
        self.kernel, self.cover = cl.Kernel(program, "visibility"), cl.Kernel(program, "cover")
        self.texture = cl.Kernel(program, "texture") if self.textures is not None else None
        self._key_pixels, self._key_buffer = 0, None
        self._scratch_pixels, self._scratch = 0, ()
        self._staging = Staging(runtime)       # the per-frame inputs' buffers, reused
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

    def build(self, view: ViewSetup, materials: np.ndarray, pool: PlanePool | None = None,
              alone_min_tiles: int | None = None) -> tuple[GBuffer, np.ndarray]:
        """The G-buffer of the view set up in `view` (a view of this geometry) with the material
        table `materials` (clshade.render.gbuffer.material_table), and per pixel whether a fragment
        covers it (uint8: 0 empty, 1 covered, 2 covered by non-finite inputs, replaced). The
        planes are host arrays (from `pool` when given) that the kernel writes through.
        `alone_min_tiles`: the tiles from which a triangle is covered alone (default
        EXCLUSIVE_MIN_TILES; `verify` lowers it so that its small frame takes that path too)."""
        if self.textures is not None and view.mvp is None:     # before any kernel reads a staged input
            raise ValueError("DeviceGBuffer.build: a textured geometry's view needs its mvp (setup_view's)")
        try:
            return self._build(view, materials, pool, alone_min_tiles)
        except BaseException:
            # Refused part way (an upload over the memory budget, a buffer the runtime would not
            # create, an interrupt): `cover` may have written keys that only the visibility kernel
            # empties. The keys are refilled before the next frame, once the queued kernels are done.
            self._key_pixels = 0
            with contextlib.suppress(Exception):
                self.rt.queue.finish()
            raise

    def _build(self, view: ViewSetup, materials: np.ndarray, pool: PlanePool | None,
               alone_min_tiles: int | None) -> tuple[GBuffer, np.ndarray]:
        rt, cl, stage = self.rt, self.rt.cl, self._staging
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
            box = stage.upload("box", np.stack([t.col0, t.row0, t.col1, t.row1]).astype(np.int32))
            edge = stage.upload("edge", np.concatenate([t.edge_a, t.edge_b, t.edge_c, t.edge_thr,
                                                        t.z_a[None], t.z_b[None], t.z_c[None]]))
            inputs += [box, edge]
            alone = exclusive_triangles(tiles, alone_min_tiles)
            for tri in alone:                   # the largest first, each alone: no atomics
                # The kernel takes the triangle from `first` and reads neither tile list (box stands in).
                self._cover(int(tiles[tri]), ntri, w, view, int(tri), 1, [box, box], box, edge, keys)
            if len(alone):                  # the rest: every other triangle's tiles
                tiles = tiles.copy()
                tiles[alone] = 0
            tile_end = np.cumsum(tiles, dtype=np.int64)
            for k, (first, last, base) in enumerate(cover_batches(tile_end, COVER_BATCH_TILES)):
                # The batch's own running counts, from its first triangle (at most the limit, or one
                # triangle's tiles: uint32 as long as one triangle has fewer than 2^32 tiles).
                batch_end = (tile_end[first:last] - base).astype(np.uint32)
                tile_tri = np.repeat(np.arange(first, last, dtype=np.uint32), tiles[first:last])
                if not len(tile_tri):       # every triangle of the batch went alone
                    continue
                batch = [stage.upload(("batch end", k), batch_end), stage.upload(("batch tiles", k), tile_tri)]
                inputs += batch
                self._cover(len(tile_tri), ntri, w, view, first, 0, batch, box, edge, keys)
        mf = cl.mem_flags
        # The texture kernel reads back what the visibility kernel wrote (normal, depth, cover).
        flags = mf.READ_WRITE if self.textures is not None else mf.WRITE_ONLY
        outputs = {name: cl.Buffer(rt.context, flags | mf.USE_HOST_PTR, hostbuf=a.reshape(-1))
                   for name, a in (*planes.items(), ("cover", cover))}
        tail = [outputs[name] for name in ("depth", "normal", "base", "roughness", "metallic", "material", "cover")]
        textured = []
        if self.textures is not None:
            tex_face, tex_bary = self._scratch_of(plane)
            textured = [self.textures.buffers[0], tex_face, tex_bary]
        inputs += [stage.upload(name, a) for name, a in (("setup", setup), ("face", tri_face), ("depth", vdepth))]
        self.kernel.set_args(np.uint32(plane), np.uint32(w), np.uint32(ntri), np.uint32(view.w_is_depth),
                             np.uint32(view.tri_bits), keys, *inputs[-3:], *self.tables,
                             *((*self.emissive_table, outputs["emissive"]) if self.emissive else ()), *textured,
                             *((outputs["occlusion"],) if self.occlusion else ()), *tail)
        cl.enqueue_nd_range_kernel(rt.queue, self.kernel, (rt.global_size(plane // self.lanes),), (rt.local_size,))
        if self.textures is not None and t is not None:
            mvp = stage.upload("mvp", np.ascontiguousarray(view.mvp[[0, 1, 3]], np.float64))
            inputs.append(mvp)
            self.texture.set_args(np.uint32(n), np.uint32(plane), np.uint32(w), np.uint32(h), np.uint32(self.n_faces),
                                  *textured[1:], mvp, self.tables[0], *self.textures.mesh, *self.textures.buffers,
                                  *((outputs["emissive"],) if self.emissive else ()),
                                  *((outputs["occlusion"],) if self.occlusion else ()),
                                  *(outputs[name] for name in ("depth", "normal", "base", "roughness", "metallic",
                                                               "cover")))
            cl.enqueue_nd_range_kernel(rt.queue, self.texture, (rt.global_size(plane // self.lanes),),
                                       (rt.local_size,))
        rt.read_in_place(*zip(outputs.values(), (*planes.values(), cover)))
        covered = cover[:n]
        gbuffer = GBuffer.from_planes(w, h, planes, materials, (covered == 1).reshape(h, w),
                                      int(np.count_nonzero(covered == 2)), unit_normals=True)
        return gbuffer, covered

    def _cover(self, count: int, ntri: int, width: int, view: ViewSetup, first: int, exclusive: int,
               batch: list, box, edge, keys) -> None:
        """Enqueue kernel `cover` on `count` tiles: `batch` (running tile counts from triangle
        `first`, each tile's triangle); `exclusive` 1 where they are triangle `first`'s tiles alone
        (then the kernel reads neither of `batch`'s buffers)."""
        rt = self.rt
        self.cover.set_args(np.uint32(count), np.uint32(ntri), np.uint32(width), np.uint32(view.tri_bits),
                            np.float64(view.z_scale), np.float64(-1.0 - view.depth_eps),
                            np.float64(1.0 + view.depth_eps), np.uint32(first), np.uint32(exclusive), *batch,
                            box, edge, keys)
        rt.cl.enqueue_nd_range_kernel(rt.queue, self.cover, (rt.global_size(count),), (rt.local_size,))

    def _scratch_of(self, plane: int) -> tuple:
        """The device's per-pixel textured face (int) and barycentrics (3 float planes) of `plane` pixels."""
        if self._scratch_pixels != plane:
            cl = self.rt.cl
            self._scratch = tuple(cl.Buffer(self.rt.context, cl.mem_flags.READ_WRITE, size=plane * k * 4)
                                  for k in (1, 3))
            self._scratch_pixels = plane
        return self._scratch

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


def plane_differences(expected: GBuffer, got: GBuffer, textured: bool) -> str | None:
    """What differs between two G-buffers' planes, or None: bit for bit (as bit patterns: NaN,
    -0), except that where `textured` the TEXTURED_CHANNELS of up to TEXTURE_DIFFER_SHARE of the
    pixels may differ by up to TEXTURE_TOLERANCE."""
    if sorted(got.channels) != sorted(expected.channels):
        return f"channels {sorted(got.channels)}, the host's {sorted(expected.channels)}"
    pixels = expected.pixels
    for name in expected.channels:
        a, b = expected.plane(name)[:, :pixels], got.plane(name)[:, :pixels]
        bits = f"u{a.itemsize}"         # a pixel per column
        differ = (a.view(bits) != b.view(bits)).any(axis=0)
        count = int(differ.sum())
        if not count:
            continue
        if textured and name in TEXTURED_CHANNELS and count <= TEXTURE_DIFFER_SHARE * pixels:
            with np.errstate(invalid="ignore"):
                worst = float(np.abs(a[:, differ].astype(np.float64) - b[:, differ]).max())
            if worst <= TEXTURE_TOLERANCE:      # NaN compares false: refused
                continue
        return f"{count} of {pixels} pixels differ from the host's in {name}"
    return None


def verify(device: DeviceGBuffer, scene: Scene, geometry: Geometry, mesh: RasterMesh, camera: Camera,
           faces: dict[str, np.ndarray]) -> str | None:
    """Whether `device` makes the host's G-buffer on this device: one small frame of `camera`'s
    view (VERIFY_SIZE) both ways, compared bit for bit (a textured geometry's textured channels
    within TEXTURE_TOLERANCE, plane_differences); the device's twice, once with its largest
    triangles covered alone. None when they agree, else what differs (the live viewer then keeps
    the host path: a device that rounds otherwise, or a compiler that breaks the program, must not
    change the picture). Every frame the pipeline verifies for is a Camera's, a perspective
    projection (ViewSetup.w_is_depth), as this one is."""
    small = camera.with_size(*VERIFY_SIZE)
    view, proj = small.view_matrix(), small.projection_matrix()
    setup = setup_view(mesh, view, proj, small.width, small.height)
    if setup is None:
        return None                     # more triangles than its keys number: the device path is not used
    fragments = rasterize_mesh(mesh, view, proj, small.width, small.height)
    expected = build_gbuffer(scene, geometry, fragments, small, faces=faces)
    # A small frame's triangles span few tiles: built again with its largest covered alone (kernel
    # `cover`'s exclusive path, which a full frame's floors and walls take).
    for alone_min_tiles, path in ((None, ""), (1, " (its largest triangles covered alone)")):
        got, cover = device.build(setup, material_table(scene), alone_min_tiles=alone_min_tiles)
        why = plane_differences(expected, got, device.textures is not None)
        if why is not None:
            return why + path
        if not np.array_equal(np.flatnonzero(cover), fragments.pixels):
            return "the covered pixels differ from the host's" + path
    return None

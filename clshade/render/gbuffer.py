"""Fragments + scene → the G-buffer: named per-pixel channels, one flat array each.

A channel exists only when the scene and model need it (see variants.py for
which ones a kernel variant reads). Non-finite inputs are replaced here,
before upload, and counted so the CLI can warn: the kernels then see only
finite values, and a bad pixel cannot affect any other.
"""
from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

import numpy as np

from clshade.render.arrays import PlanePool, aligned_zeros, padded, run_chunked
from clshade.render.meshes import Geometry
from clshade.render.raster import Fragments
from clshade.render.scene import Camera, Scene
from clshade.render.textures import MIN_TANGENT_LEN2, TextureSet


def material_row(params: dict[str, object]) -> np.ndarray:
    """Pack one material's constants into MATERIAL_STRIDE float4 (see surface.h)."""
    row = np.zeros((4, 4), np.float32)
    row[0] = [params["kd"], params["ks"], params["ka"], params["shininess"]]
    row[1, :2] = [params["ior"], params["f90"]]
    row[2, :3] = params["eta"]
    row[3, :3] = params["k"]
    return row


#: Covered pixels interpolated at a time: bounds the per-chunk temporaries (~100 bytes
#: a pixel) whatever the frame size, and keeps them in the cores' caches.
GBUFFER_CHUNK: int = 1 << 17

# The channels the rasterizer pass can write, with their element type and
# components per pixel (struct of arrays, row-major, row 0 at the top).
CHANNELS: dict[str, tuple[type, int]] = {
    "depth": (np.float32, 1), "normal": (np.float32, 3), "base": (np.float32, 3),
    "roughness": (np.float32, 1), "metallic": (np.float32, 1), "material": (np.uint8, 1),
    # Present only when the scene has them (Features.emissive / Features.occlusion):
    "emissive": (np.float32, 3),     # emitted radiance, added unlit
    "occlusion": (np.float32, 1),    # ambient occlusion in [0, 1], multiplies the ambient term
    # Present only when asked for (a lobe reads the tangent frame) and the geometry has tangents
    # (UVs: textured meshes): the interpolated mesh tangent ∂P/∂u, not yet orthogonal to n.
    "tangent": (np.float32, 3),
}


class PlaneChannels(Mapping):
    """Read-only name → (H·W·components,) interleaved channel view of planar channels
    ((components, padded pixels) arrays), each made on first access and kept."""

    def __init__(self, planes: dict[str, np.ndarray], pixels: int) -> None:
        self._planes, self._pixels = planes, pixels
        self._made: dict[str, np.ndarray] = {}

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._made:
            plane = self._planes[name][:, :self._pixels]
            self._made[name] = plane[0].copy() if len(plane) == 1 else np.ascontiguousarray(plane.T).reshape(-1)
        return self._made[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._planes)

    def __len__(self) -> int:
        return len(self._planes)


@dataclass
class GBuffer:
    width: int
    height: int
    channels: Mapping[str, np.ndarray]       # name → (H·W·components,) interleaved array
    materials: np.ndarray                    # (M, 4, 4) float32 material table
    coverage: np.ndarray                     # (H, W) bool
    nonfinite_pixels: int = 0                # pixels whose inputs were not finite (replaced)
    stats: dict[str, float] = field(default_factory=dict)
    # Every normal is unit length to float32 rounding, or zero (build_gbuffer normalises them): the
    # kernels then do not normalise again (UNIT_NORMALS). False for G-buffers made by hand.
    unit_normals: bool = False
    # name → (components, padded pixels) planes, the device layout (gbuffer.h); made from
    # `channels` on demand (not an init field: dataclasses.replace() never copies stale planes).
    _planes: dict[str, np.ndarray] = field(default_factory=dict, init=False, repr=False, compare=False)

    @classmethod
    def from_planes(cls, width: int, height: int, planes: dict[str, np.ndarray], materials: np.ndarray,
                    coverage: np.ndarray, nonfinite_pixels: int = 0, unit_normals: bool = False) -> GBuffer:
        """A G-buffer whose channels are given as planes (what build_gbuffer writes)."""
        gbuffer = cls(width, height, PlaneChannels(planes, width * height), materials, coverage, nonfinite_pixels,
                      unit_normals=unit_normals)
        gbuffer._planes.update(planes)
        return gbuffer

    @property
    def pixels(self) -> int:
        return self.width * self.height

    def plane(self, name: str) -> np.ndarray:
        """Channel `name` as (components, padded pixels) planes, zero padding (gbuffer.h)."""
        if name not in self._planes:
            comps = CHANNELS[name][1]
            data = np.asarray(self.channels[name]).reshape(self.pixels, comps)
            planes = aligned_zeros((comps, padded(self.pixels)), data.dtype)
            planes[:, :self.pixels] = data.T
            self._planes[name] = planes
        return self._planes[name]

    def shares_plane(self, other: GBuffer, name: str) -> bool:
        """Whether channel `name` is the same plane array in both G-buffers (made, not copied)."""
        mine = self._planes.get(name)
        return mine is not None and mine is other._planes.get(name)

    def bytes_per_pixel(self, names: tuple[str, ...] | list[str], half: bool = False) -> int:
        """Bytes a pass reads per pixel for these channels (3-component channels as half when `half`)."""
        total = 0
        for name in names:
            dtype, comps = CHANNELS[name]
            size = 2 if half and comps == 3 else np.dtype(dtype).itemsize
            total += size * comps
        return total

    def mean_bytes_per_pixel(self, names: tuple[str, ...] | list[str], half: bool, simd: int,
                             written: int) -> float:
        """Bytes a pass moves per pixel of the frame: a work-item of `simd` pixels
        (the last one padded) reads every channel when one of its pixels is covered and
        only depth otherwise (the kernels' sky skip, shade.cl and copy.cl), and writes
        `written` bytes per pixel."""
        cov = np.zeros(-(-self.pixels // simd) * simd, bool)
        cov[:self.pixels] = self.coverage.ravel()
        active = int(cov.reshape(-1, simd).any(axis=1).sum())
        groups = len(cov) // simd
        full = self.bytes_per_pixel(names, half) + written
        empty = self.bytes_per_pixel(("depth",)) + written
        return simd * (active * full + (groups - active) * empty) / self.pixels

    def channel(self, name: str, half: bool = False) -> np.ndarray:
        data = self.channels[name]
        if half and CHANNELS[name][1] == 3:
            return data.astype(np.float16)
        return data


def material_table(scene: Scene) -> np.ndarray:
    """(M, 4, 4) float32: every material's constants in the layout of surface.h."""
    rows = [material_row(m.constants()) for m in scene.materials.values()]
    return np.stack(rows) if rows else np.zeros((0, 4, 4), np.float32)


def uv_derivatives(geometry: Geometry, tri: np.ndarray, pixels: np.ndarray, camera: Camera,
                   width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Screen-space UV derivatives (∂uv/∂x, ∂uv/∂y per pixel step), analytic on each
    pixel's own triangle: with A = [c0 c1 c2] the clip (x, y, w) of its corners, the
    perspective-correct barycentrics at NDC point s are A⁻¹(s, 1) normalised to sum 1;
    the UVs one pixel right and one pixel down minus the UV at the centre.
    Valid for any projection with w > 0 (orthographic included)."""
    mvp = camera.projection_matrix() @ camera.view_matrix()
    faces, inverse = np.unique(tri, return_inverse=True)
    corners = geometry.faces[faces]                                   # (U, 3)
    clip = geometry.vertices[corners] @ mvp[[0, 1, 3], :3].T + mvp[[0, 1, 3], 3]   # (U, 3 corners, xyw)
    A = np.swapaxes(clip, 1, 2)                                       # columns = corners
    det = np.linalg.det(A)
    ok = np.abs(det) > 0
    inv = np.zeros_like(A)
    inv[ok] = np.linalg.inv(A[ok])
    uv_c = geometry.uvs[corners].astype(np.float64)                   # (U, 3, 2)
    py, px = np.divmod(pixels, width)
    x = (px + 0.5) / width * 2.0 - 1.0
    y = 1.0 - (py + 0.5) / height * 2.0

    def uv_at(sx: np.ndarray, sy: np.ndarray) -> np.ndarray:
        s = np.stack([sx, sy, np.ones_like(sx)], axis=1)
        b = np.einsum("kij,kj->ki", inv[inverse], s)
        total = b.sum(axis=1, keepdims=True)
        b = np.divide(b, total, out=np.full_like(b, 1.0 / 3.0), where=np.abs(total) > 0)
        return np.einsum("ki,kid->kd", b, uv_c[inverse])

    centre = uv_at(x, y)
    dx = uv_at(x + 2.0 / width, y) - centre
    dy = uv_at(x, y - 2.0 / height) - centre
    bad = ~ok[inverse] | ~np.isfinite(dx).all(1) | ~np.isfinite(dy).all(1)
    dx[bad] = 0.0
    dy[bad] = 0.0
    return dx, dy


def _apply_texture_set(t: TextureSet, uv: np.ndarray, dx: np.ndarray, dy: np.ndarray, normal: np.ndarray,
                       tangent: np.ndarray) -> tuple[np.ndarray, ...]:
    """Base colour, roughness, metallic, shading normal, emission and ambient occlusion
    of K pixels from one texture set (glTF: value = factor × texture)."""
    uv, dx, dy = uv * t.uv_scale, dx * t.uv_scale, dy * t.uv_scale
    k = len(uv)
    base = np.broadcast_to(np.asarray(t.base_factor, np.float32), (k, 3)).copy()
    rough = np.full(k, t.roughness_factor, np.float32)
    metal = np.full(k, t.metallic_factor, np.float32)
    if t.base_color is not None:
        base *= t.base_color.sample(uv, t.base_color.lod(dx, dy))
    if t.metallic_roughness is not None:
        mr = t.metallic_roughness.sample(uv, t.metallic_roughness.lod(dx, dy))
        rough *= mr[:, 1]
        metal *= mr[:, 2]
    emissive = np.broadcast_to(np.asarray(t.emissive_factor, np.float32), (k, 3)).copy()
    if t.emissive is not None and t.has_emission:
        emissive *= t.emissive.sample(uv, t.emissive.lod(dx, dy))
    occlusion = np.ones(k, np.float32)
    if t.occlusion is not None:
        occlusion = 1.0 + t.occlusion_strength * (t.occlusion.sample(uv, t.occlusion.lod(dx, dy))[:, 0] - 1.0)
    if t.normal is not None:
        m = t.normal.sample(uv, t.normal.lod(dx, dy)) * 2.0 - 1.0
        m[:, :2] *= t.normal_scale
        T = tangent[:, :3] - normal * np.einsum("ij,ij->i", tangent[:, :3], normal)[:, None]
        tlen2 = np.einsum("ij,ij->i", T, T)
        good = tlen2 > MIN_TANGENT_LEN2
        T = T / np.sqrt(np.where(good, tlen2, 1.0))[:, None]
        B = np.where(tangent[:, 3:4] < 0.0, -1.0, 1.0) * np.cross(normal, T)
        mapped = m[:, 0:1] * T + m[:, 1:2] * B + m[:, 2:3] * normal
        length = np.linalg.norm(mapped, axis=1, keepdims=True)
        good &= length[:, 0] > 0
        normal = np.where(good[:, None], mapped / np.where(length > 0, length, 1.0), normal)
    return base, rough, metal, normal.astype(np.float32), emissive, occlusion


def _texture_pixels(geometry: Geometry, tri: np.ndarray, pixels: np.ndarray, bary: np.ndarray, camera: Camera,
                    width: int, height: int, planes: dict[str, np.ndarray]) -> np.ndarray:
    """Overwrite the channel planes of textured pixels in place (emissive / occlusion when
    present); returns the positions in `pixels` that were textured."""
    tex = geometry.face_texture[tri]
    sel = np.flatnonzero(tex >= 0)
    if not len(sel):
        return sel
    t_tri, t_bary = tri[sel], bary[sel].astype(np.float64)
    corners = geometry.faces[t_tri]
    uv = np.einsum("kc,kcd->kd", t_bary, geometry.uvs[corners].astype(np.float64))
    tangent = np.einsum("kc,kcd->kd", t_bary, geometry.tangents[corners].astype(np.float64))
    dx, dy = uv_derivatives(geometry, t_tri, pixels[sel], camera, width, height)
    for index in np.unique(tex[sel]):
        part = tex[sel] == index
        rows = pixels[sel][part]
        b, r, m, n, e, o = _apply_texture_set(geometry.texture_sets[index], uv[part], dx[part], dy[part],
                                              planes["normal"][:, rows].T.astype(np.float64), tangent[part])
        planes["base"][:, rows], planes["normal"][:, rows] = b.T, n.T
        planes["roughness"][0, rows], planes["metallic"][0, rows] = r, m
        if "emissive" in planes:
            planes["emissive"][:, rows] = e.T
        if "occlusion" in planes:
            planes["occlusion"][0, rows] = o
    return sel


# One-component surface channels a kernel variant may compile in as a constant (variants.py).
UNIFORM_CANDIDATES = ("roughness", "metallic")


def uniform_channels(geometry: Geometry, mats: list) -> tuple[tuple[str, float], ...]:
    """(name, value) of each UNIFORM_CANDIDATES channel that has one value on every face of the
    scene: each face's material, or for a face with a glTF texture set its factor, gives the same
    value, and no metallic-roughness texture scales it (the values face_planes and the texture
    sets write into the G-buffer). A kernel variant compiles such a channel in instead of reading
    it per pixel; the G-buffer still holds it. Decided from the whole scene, not the visible
    pixels, so every frame of a scene shares one variant."""
    if not len(geometry.face_material):
        return ()
    tex = geometry.face_texture
    textured = tex >= 0 if tex is not None else np.zeros(len(geometry.face_material), bool)
    used_sets = [geometry.texture_sets[int(i)] for i in np.unique(tex[textured])] if textured.any() else []
    if any(t.metallic_roughness is not None for t in used_sets):
        return ()
    out = []
    for name in UNIFORM_CANDIDATES:
        values = np.array([getattr(m, name) for m in mats], np.float32)[geometry.face_material]
        if textured.any():
            with np.errstate(over="ignore"):       # float32 as the G-buffer holds them (1e39 → inf)
                factors = np.array([getattr(t, f"{name}_factor") for t in geometry.texture_sets], np.float32)
            values = np.where(textured, factors[np.where(textured, tex, 0)], values)
        if np.all(values == values[0]):
            # In [0, 1] as the kernels saturate the per-pixel value (a glTF factor is not range-checked:
            # 1e39 is inf in float32, which saturates to 1 but is no float literal). NaN never compares equal.
            out.append((name, min(max(float(values[0]), 0.0), 1.0)))
    return tuple(out)


def face_planes(geometry: Geometry, mats: list, tangents: bool = False) -> dict[str, np.ndarray]:
    """Per-face lookup tables, one contiguous (F,) plane each: the corners' normal components
    (``n{corner}{axis}``) and the face material's values. Gathering one plane by triangle id
    is several times faster than gathering interleaved rows (F is small next to the pixels)."""
    planes: dict[str, np.ndarray] = {}
    corner_normals = geometry.normals[geometry.faces]                 # (F, 3 corners, 3 axes)
    for c in range(3):
        for d in range(3):
            planes[f"n{c}{d}"] = np.ascontiguousarray(corner_normals[:, c, d])
    mid = geometry.face_material
    base_of = np.array([m.base_color for m in mats], np.float32).reshape(-1, 3)
    for d in range(3):
        planes[f"base{d}"] = np.ascontiguousarray(base_of[mid, d])
    planes["roughness"] = np.array([m.roughness for m in mats], np.float32)[mid]
    planes["metallic"] = np.array([m.metallic for m in mats], np.float32)[mid]
    planes["material"] = mid.astype(np.uint8)
    if geometry.has_emission:
        emissive_of = np.array([m.emissive for m in mats], np.float32).reshape(-1, 3)
        for d in range(3):
            planes[f"emissive{d}"] = np.ascontiguousarray(emissive_of[mid, d])
    if tangents:
        corner_tangents = geometry.tangents[geometry.faces][:, :, :3]
        for c in range(3):
            for d in range(3):
                planes[f"t{c}{d}"] = np.ascontiguousarray(corner_tangents[:, c, d])
    return planes


def channel_names(geometry: Geometry, tangents: bool = False) -> list[str]:
    """The channels of `geometry`'s G-buffer, in CHANNELS' order: emission and occlusion where
    the geometry has them, the tangents where asked for (and the geometry has them)."""
    tangents = tangents and geometry.tangents is not None
    return [name for name in CHANNELS if (name != "emissive" or geometry.has_emission)
            and (name != "occlusion" or geometry.has_occlusion) and (name != "tangent" or tangents)]


def build_gbuffer(scene: Scene, geometry: Geometry, fragments: Fragments, camera: Camera | None = None,
                  tangents: bool = False, faces: dict[str, np.ndarray] | None = None,
                  pool: PlanePool | None = None) -> GBuffer:
    """Interpolate normals and look up material values for every covered pixel; where a
    face has a texture set, sample its textures (trilinear, see textures.py). `camera`
    (default: the scene's, at the fragments' size) gives the UV screen derivatives.
    `tangents` (a lobe reads the tangent frame) adds the interpolated mesh tangents where the
    geometry has them (UVs); without them the kernel builds a frame from the normal.
    Channels are written as planes (the device layout); the untextured work runs in
    chunks of covered pixels on the worker threads (clshade.render.arrays.run_chunked),
    each chunk writing only its own pixels. `faces`: face_planes(geometry, the scene's materials,
    tangents) made before (the live viewer keeps them while the camera moves); `pool`: the planes
    are taken from it (memory of G-buffers no longer in use) instead of newly allocated."""
    h, w = fragments.shape
    n = h * w
    pix = fragments.pixels                                 # covered pixels (integer gathers/scatters)
    mats = list(scene.materials.values())

    tangents = tangents and geometry.tangents is not None
    names = channel_names(geometry, tangents)
    zeros = pool.zeros if pool is not None else aligned_zeros
    planes = {name: zeros((CHANNELS[name][1], padded(n)), CHANNELS[name][0]) for name in names}
    depth = planes["depth"][0]                             # 0 where empty
    finite = np.ones(len(pix), bool)
    cov = np.zeros(n, bool)
    cov[pix] = True
    if len(pix):
        face = faces if faces is not None else face_planes(geometry, mats, tangents)

        def shade_inputs(part: slice) -> None:
            # The chunk's pixels are the covered ones of the span lo:hi (pixels ascend): written
            # through the coverage mask, several times faster than through their indices.
            lo, hi = int(pix[part.start]), int(pix[part.stop - 1]) + 1
            mask = cov[lo:hi]

            def put(plane: np.ndarray, values: np.ndarray) -> None:
                plane[lo:hi][mask] = values

            # Gathers index with intp: np.take converts an int32 index array on every call.
            tri = fragments.face[part].astype(np.intp)
            b = fragments.face_bary[:, part]
            put(depth, fragments.face_depth[part])
            nrm = []
            term = np.empty(len(tri), np.float32)
            for d in range(3):
                # ((0 + b0 n0) + b1 n1) + b2 n2: 0 + x turns -0.0 into +0.0 (in place, the same roundings).
                acc = np.take(face[f"n0{d}"], tri)
                acc *= b[0]
                acc += 0.0
                for c in (1, 2):
                    np.take(face[f"n{c}{d}"], tri, out=term, mode="clip")   # tri < F: clip never clips
                    term *= b[c]
                    acc += term
                nrm.append(acc)
            len2 = nrm[0] * nrm[0]
            for d in (1, 2):
                np.multiply(nrm[d], nrm[d], out=term)
                len2 += term
            # 1/|n| where |n| > 0; 0 elsewhere, so a zero normal stays 0 and a NaN/Inf one
            # becomes NaN (NaN·0, Inf·0), counted below as non-finite.
            with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
                inv = np.sqrt(len2)
                np.divide(1.0, inv, out=inv)
                inv[~(len2 > 0)] = 0.0
            ok = np.isfinite(fragments.face_depth[part])
            for d in range(3):
                nd = nrm[d]
                nd *= inv
                ok &= np.isfinite(nd)
                put(planes["normal"][d], nd)
                put(planes["base"][d], np.take(face[f"base{d}"], tri, out=term, mode="clip"))
                if "emissive" in planes:
                    put(planes["emissive"][d], np.take(face[f"emissive{d}"], tri))
                if "tangent" in planes:
                    put(planes["tangent"][d], np.take(face[f"t0{d}"], tri) * b[0] + np.take(face[f"t1{d}"], tri) * b[1]
                        + np.take(face[f"t2{d}"], tri) * b[2])
            finite[part] = ok
            for name in ("roughness", "metallic"):
                put(planes[name][0], np.take(face[name], tri, out=term, mode="clip"))
            put(planes["material"][0], np.take(face["material"], tri))
            if "occlusion" in planes:
                planes["occlusion"][0][lo:hi][mask] = 1.0

        run_chunked(len(pix), shade_inputs, max_chunk=GBUFFER_CHUNK)
        if geometry.face_texture is not None:
            camera = (camera or scene.camera).with_size(w, h)
            textured = _texture_pixels(geometry, fragments.face, pix, fragments.face_bary.T, camera, w, h, planes)
            if len(textured):   # textures replaced normal and base there: check them again
                rows = pix[textured]
                finite[textured] = (np.isfinite(depth[rows]) & np.isfinite(planes["normal"][:, rows]).all(0)
                                    & np.isfinite(planes["base"][:, rows]).all(0))

    # Replace non-finite inputs (from NaN vertices, bad normals in a mesh file):
    # the pixel shades as empty/neutral and is counted; no other pixel is touched.
    bad = pix[~finite]
    if len(bad):
        for name in ("depth", "normal", "base", "emissive", "tangent"):
            if name in planes:
                planes[name][:, bad] = 0.0
        cov[bad] = False
    # Normals: interpolated ones scaled by 1/|n| above (0 stays 0), mapped ones normalised in
    # _apply_texture_set, replaced ones 0: unit or zero.
    return GBuffer.from_planes(w, h, planes, material_table(scene), cov.reshape(h, w), len(bad), unit_normals=True)

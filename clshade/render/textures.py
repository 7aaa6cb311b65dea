"""Textures: loading, mipmaps, trilinear sampling, UVs for primitives and tangents.

Textures are sampled on the host while the G-buffer is written (gbuffer.py),
so they become the ordinary base / roughness / metallic / normal channels and
the shading kernel is the same with or without them.

Conventions (stated once):
  - UV origin at the bottom left, V up (OpenGL; trimesh flips glTF's top-left V
    on load, and primitives are given UVs the same way). Image row 0 is the top,
    at V = 1. Wrapping repeats (glTF's default sampler).
  - Base colour images with integer pixels are sRGB-encoded and decoded to linear
    here (glTF); float images (EXR, HDR) are taken as linear. Metallic-roughness
    and normal images are linear data.
  - metallic-roughness: G = roughness, B = metallic (glTF; R is ignored, the
    WaterBottle sample keeps occlusion there).
  - Normal maps are tangent space with +Y along +V (glTF's "green up"); the
    bitangent is B = w · (N × T), w = ±1 the handedness of the UV layout.
  - Minification: an isotropic mip pyramid (2×2 box filter in linear space) and
    trilinear filtering; the level is λ = log2 ρ with ρ the larger screen-space
    UV footprint of one pixel step in x or y, in texels (OpenGL 4.6 §8.14),
    computed analytically on the pixel's own triangle (gbuffer.uv_derivatives).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from clshade import budget
from clshade.diagnostics import stderr_captured
from clshade.errors import ClshadeError, located, one_line
from clshade.render.image import srgb_decode

# A texture set whose tangent frame has |T|² below this keeps the interpolated
# normal: degenerate UVs (all corners mapped to one texel) define no tangent.
MIN_TANGENT_LEN2 = 1e-20


def _half(a: np.ndarray) -> np.ndarray:
    """One mip step: 2×2 box filter. An odd last row/column is averaged with
    itself (clamped), so sizes halve with floor and nothing wraps."""
    h, w = a.shape[:2]
    h2, w2 = max(h // 2, 1), max(w // 2, 1)
    r0, r1 = np.arange(h2) * 2, np.minimum(np.arange(h2) * 2 + 1, h - 1)
    c0, c1 = np.arange(w2) * 2, np.minimum(np.arange(w2) * 2 + 1, w - 1)
    return 0.25 * (a[r0][:, c0] + a[r0][:, c1] + a[r1][:, c0] + a[r1][:, c1])


@dataclass(frozen=True)
class Texture:
    """A mip pyramid of linear float32 (h, w, c) images; level 0 is the full image."""
    levels: tuple[np.ndarray, ...]
    name: str = ""

    @classmethod
    def from_pixels(cls, pixels: np.ndarray, name: str = "") -> "Texture":
        level = np.ascontiguousarray(pixels, np.float32)
        if level.ndim == 2:
            level = level[..., None]
        levels = [level]
        while max(level.shape[:2]) > 1:
            level = _half(level)
            levels.append(level)
        return cls(tuple(levels), name)

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of level 0."""
        return int(self.levels[0].shape[1]), int(self.levels[0].shape[0])

    def lod(self, duv_dx: np.ndarray, duv_dy: np.ndarray) -> np.ndarray:
        """Mip level λ = log2 ρ, ρ = max(|∂(u,v)/∂x|, |∂(u,v)/∂y|) in texels, clamped to the pyramid."""
        scale = np.array(self.size, np.float64)
        rho = np.maximum(np.linalg.norm(duv_dx * scale, axis=1), np.linalg.norm(duv_dy * scale, axis=1))
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = np.log2(rho)
        return np.clip(np.nan_to_num(lam, nan=0.0, neginf=0.0, posinf=len(self.levels) - 1.0),
                       0.0, len(self.levels) - 1.0)

    def sample(self, uv: np.ndarray, lod: np.ndarray | None = None) -> np.ndarray:
        """Trilinear sample (bilinear within a level, linear between levels) at (K, 2) UVs."""
        uv = np.asarray(uv, np.float64)
        if lod is None:
            return _bilinear(self.levels[0], uv)
        l0 = np.floor(lod).astype(np.int64)
        frac = (lod - l0).astype(np.float32)
        l1 = np.minimum(l0 + 1, len(self.levels) - 1)
        out = np.zeros((len(uv), self.levels[0].shape[2]), np.float32)
        for level in np.unique(np.concatenate([l0, l1])):
            lower, upper = l0 == level, (l1 == level) & (l1 != l0)
            if lower.any():
                out[lower] += (1.0 - frac[lower])[:, None] * _bilinear(self.levels[level], uv[lower])
            if upper.any():
                out[upper] += frac[upper][:, None] * _bilinear(self.levels[level], uv[upper])
        return out


def _bilinear(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear filtering with repeat wrapping; texel centres at (i + 0.5) / size."""
    h, w = image.shape[:2]
    x = uv[:, 0] * w - 0.5
    y = (1.0 - uv[:, 1]) * h - 0.5          # V up, row 0 at the top
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0).astype(np.float32)[:, None], (y - y0).astype(np.float32)[:, None]
    i0, j0 = np.mod(y0, h).astype(np.int64), np.mod(x0, w).astype(np.int64)
    i1, j1 = (i0 + 1) % h, (j0 + 1) % w
    top = image[i0, j0] * (1.0 - fx) + image[i0, j1] * fx
    bottom = image[i1, j0] * (1.0 - fx) + image[i1, j1] * fx
    return top * (1.0 - fy) + bottom * fy


def _to_rgb(pixels: np.ndarray) -> np.ndarray:
    """Grey, grey+alpha, RGB or RGBA → RGB (alpha is not used: no blending)."""
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    if pixels.shape[2] < 3:
        return np.repeat(pixels[..., :1], 3, axis=2)
    return pixels[..., :3]


def load_texture_file(path: Path, srgb: bool, scene_file: Path | str | None, key: str) -> Texture:
    """Read an image file with OpenImageIO (PNG, JPEG, EXR, TIFF, ...) as a Texture: its size
    from the header first (budget.texture_pixels), then the pixels. What the image libraries
    print (libpng's "libpng error: ...") goes to clshade.diagnostics, not to stderr."""
    def refuse(message: str) -> ClshadeError:
        return located(message, scene_file, key, str(path), has_value=True)

    try:
        budget.regular_file(path, "texture file")
    except ClshadeError as exc:
        raise refuse(str(exc).removeprefix(f"{path}: ")) from None
    with stderr_captured(f"OpenImageIO reading {path.name}"):
        pixels, is_float = _read_pixels(path, refuse)
    rgb = _to_rgb(pixels)
    if not np.isfinite(rgb).all():
        raise refuse("texture has non-finite pixels")
    if srgb and not is_float:
        rgb = srgb_decode(rgb)
    return Texture.from_pixels(rgb, path.name)


def _read_pixels(path: Path, refuse, what: str = "texture", check=None) -> tuple[np.ndarray, bool]:
    """(float32 (h, w, c) pixels of the first sub-image, whether the file stores floats); the
    header's size is checked against the budget (and by `check(width, height, channels)`, which
    raises) before any pixel is decoded. `what` names the image in the messages."""
    import OpenImageIO as oiio
    image = oiio.ImageInput.open(str(path))
    if image is None:
        raise refuse(f"cannot read {what} ({one_line(oiio.geterror()) or 'unknown format'})")
    try:
        spec = image.spec()
        width, height, channels = spec.width, spec.height, spec.nchannels
        if width <= 0 or height <= 0 or channels <= 0:
            raise refuse(f"cannot read {what} (no pixels: {width}x{height}, {channels} channels)")
        try:
            budget.texture_pixels(width, height, channels)
        except ClshadeError as exc:
            raise refuse(str(exc)) from None
        if check is not None:
            check(width, height, channels)
        pixels = image.read_image(0, 0, 0, channels, oiio.FLOAT)
        if pixels is None:
            raise refuse(f"cannot read {what} ({one_line(image.geterror()) or 'no pixels'})")
        is_float = spec.format.basetype in (oiio.FLOAT, oiio.HALF, oiio.DOUBLE)
    finally:
        image.close()
    return np.asarray(pixels, np.float32).reshape(height, width, channels), is_float


def texture_from_image(image, srgb: bool, name: str = "") -> Texture:
    """A PIL image (as trimesh loads glTF textures) → Texture. 8-bit values decode through a
    256-entry table of the same codec (srgb_decode of k/255): equal values, no per-pixel pow."""
    try:
        budget.texture_pixels(*image.size, len(image.getbands()))
    except ClshadeError as exc:
        raise ClshadeError(f"{name}: {exc}") from None
    codes = _to_rgb(np.asarray(image.convert("RGB") if image.mode not in ("RGB", "L") else image, np.uint8))
    levels = np.arange(256, dtype=np.float32) / np.float32(255.0)
    table = srgb_decode(levels) if srgb else levels
    return Texture.from_pixels(table[codes], name)


@dataclass(frozen=True)
class TextureSet:
    """A metallic-roughness material's textures and factors (glTF 2.0 semantics:
    value = factor × texture; a missing texture counts as 1)."""
    base_factor: tuple[float, float, float] = (1.0, 1.0, 1.0)
    roughness_factor: float = 1.0
    metallic_factor: float = 1.0
    base_color: Texture | None = None
    metallic_roughness: Texture | None = None
    normal: Texture | None = None
    normal_scale: float = 1.0
    uv_scale: float = 1.0
    name: str = ""
    # Emission (glTF emissiveFactor × emissiveTexture, sRGB) and ambient occlusion
    # (glTF occlusionTexture, linear R channel: 1 + strength · (R − 1), ambient only).
    emissive_factor: tuple[float, float, float] = (0.0, 0.0, 0.0)
    emissive: Texture | None = None
    occlusion: Texture | None = None
    occlusion_strength: float = 1.0

    @property
    def images(self) -> tuple[tuple[str, Texture | None], ...]:
        return (("base colour", self.base_color), ("metallic-roughness", self.metallic_roughness),
                ("normal", self.normal), ("emissive", self.emissive), ("occlusion", self.occlusion))

    @property
    def has_images(self) -> bool:
        return any(t is not None for _, t in self.images)

    @property
    def has_emission(self) -> bool:
        """True when the set emits light (a non-zero emissive factor; the texture multiplies it)."""
        return any(c > 0 for c in self.emissive_factor)

    def describe(self) -> str:
        parts = [f"{label} {t.name} {t.size[0]}x{t.size[1]}" for label, t in self.images if t is not None]
        if self.has_emission:
            parts.append("emissive factor " + ", ".join(f"{c:g}" for c in self.emissive_factor))
        return f"{self.name}: {', '.join(parts) or 'factors only'}"


# ---------------------------------------------------------------- UVs and tangents


def primitive_uvs(kind: str, vertices: np.ndarray, faces: np.ndarray, size: float = 1.0):
    """UVs for a primitive: plane 0..1 across its size; sphere longitude/latitude
    (seam triangles get their own corners, u continued past 1); the others a box
    projection on each face's dominant axis, one UV unit per object unit.
    Returns (vertices, faces, corner_index, uvs); corner_index maps new vertices
    to the input ones (for normals)."""
    v = np.asarray(vertices, np.float64)
    if kind == "plane":
        uv = np.stack([v[:, 0] / size + 0.5, -v[:, 2] / size + 0.5], axis=1)
        return v, faces, np.arange(len(v)), uv
    corner = np.asarray(faces, np.int64).reshape(-1)     # unshared: 3 vertices per face
    p = v[corner]
    new_faces = np.arange(len(corner)).reshape(-1, 3)
    if kind == "sphere":
        d = p / np.maximum(np.linalg.norm(p, axis=1, keepdims=True), 1e-30)
        u = 0.5 + np.arctan2(d[:, 0], d[:, 2]) / (2 * np.pi)
        vv = 0.5 + np.arcsin(np.clip(d[:, 1], -1, 1)) / np.pi
        uf = u.reshape(-1, 3)
        wraps = (uf.max(1) - uf.min(1)) > 0.5
        uf[wraps] = np.where(uf[wraps] < 0.5, uf[wraps] + 1.0, uf[wraps])
        return p, new_faces, corner, np.stack([uf.reshape(-1), vv], axis=1)
    tri = p.reshape(-1, 3, 3)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    axis = np.repeat(np.argmax(np.abs(normal), axis=1), 3)
    sign = np.repeat(np.sign(normal[np.arange(len(normal)), np.argmax(np.abs(normal), axis=1)]), 3)
    sign[sign == 0] = 1.0
    # (u, v) axes per dominant axis, mirrored on the negative side so the
    # layout is right-handed seen from outside.
    u_axis = np.array([2, 0, 0])[axis]
    v_axis = np.array([1, 2, 1])[axis]
    u_sign = np.where(axis == 2, sign, np.where(axis == 0, -sign, 1.0))
    v_sign = np.where(axis == 1, -sign, 1.0)
    rows = np.arange(len(p))
    uv = np.stack([u_sign * p[rows, u_axis], v_sign * p[rows, v_axis]], axis=1)
    return p, new_faces, corner, uv


def vertex_tangents(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, uvs: np.ndarray) -> np.ndarray:
    """(V, 4) float32 per-vertex tangents (xyz) and handedness w = ±1, MikkTSpace-like:
    per face T = ∂P/∂u and B = ∂P/∂v from the UV Jacobian, summed at the vertices
    with area weights, then Gram–Schmidt against the vertex normal."""
    p = np.asarray(vertices, np.float64)[faces]
    t = np.asarray(uvs, np.float64)[faces]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    # Multiplying by sign(det) instead of dividing by det weights each face by
    # its area over its UV area, and keeps degenerate UV faces (det = 0) out.
    s = np.sign(det)[:, None]
    tan = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * s
    bit = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * s
    T = np.zeros_like(np.asarray(vertices, np.float64))
    B = np.zeros_like(T)
    for k in range(3):
        np.add.at(T, faces[:, k], tan)
        np.add.at(B, faces[:, k], bit)
    n = np.asarray(normals, np.float64)
    T -= n * np.einsum("ij,ij->i", T, n)[:, None]
    length = np.linalg.norm(T, axis=1, keepdims=True)
    T = np.divide(T, length, out=np.zeros_like(T), where=length ** 2 > MIN_TANGENT_LEN2)
    w = np.where(np.einsum("ij,ij->i", np.cross(n, T), B) < 0.0, -1.0, 1.0)
    return np.concatenate([T, w[:, None]], axis=1).astype(np.float32)

"""Output: exposure, tone mapping, sRGB encoding and atomic image writes (OpenImageIO).

`.exr` receives linear float RGBA radiance, untouched. PNG/JPEG receive
8-bit sRGB: radiance × 2^exposure → tone map → sRGB OETF → round.
Tone maps: `none` (clip to [0, 1]), `reinhard` (x / (1 + x)), `aces`
(Narkowicz 2015 fit of the ACES RRT+ODT, applied to 0.6·x as in his post).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from clshade.errors import ClshadeError, one_line
from clshade.outputs import check_output_file, refuse_inputs, write_atomic

LINEAR_SUFFIXES = (".exr",)
DISPLAY_SUFFIXES = (".png", ".jpg", ".jpeg")

#: Pixels per chunk of :func:`to_display`: the display transform is elementwise, so it runs
#: over chunks of rows whose float64 temporaries (~0.8 MB each) stay in cache and are
#: recycled by malloc; same values as one whole-image pass, ~2× less CPU at 640×640.
DISPLAY_CHUNK_PIXELS = 1 << 15
#: PNG encoding: zlib level 1 without row filters. The pixels are the same at any level;
#: level 6 with adaptive filters (libpng's default) makes files ~1.5× smaller but costs
#: ~5× the encoding CPU time, which was most of a 640×640 render's write stage.
PNG_COMPRESSION_LEVEL = 1
PNG_FILTER_NONE = 0x08      # libpng's PNG_FILTER_NONE mask


def tonemap(rgb: np.ndarray, method: str = "aces", exposure: float = 0.0) -> np.ndarray:
    """Scene-linear RGB → display-linear RGB in [0, 1], float64: NaN and negative radiance
    count as 0, +∞ (and anything beyond float32's range) as float32's largest value.
    Computed in place on one float64 copy of the input, each step with the values of the
    textbook expression."""
    if method not in ("none", "reinhard", "aces"):
        raise ClshadeError(f"unknown tone map {method!r}; choose none, reinhard or aces")
    scale = 2.0 ** exposure
    x = np.array(rgb, np.float64)
    x *= scale
    np.fmax(x, 0.0, out=x)                          # NaN, −∞ and negatives → 0
    np.minimum(x, float(np.finfo(np.float32).max) * scale, out=x)   # +∞ → float32's largest
    if method == "reinhard":                        # x / (1 + x)
        x /= x + 1.0
    elif method == "aces":                          # x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14) at 0.6·x
        x *= 0.6
        with np.errstate(over="ignore", invalid="ignore"):
            num = 2.51 * x
            num += 0.03
            num *= x
            den = 2.43 * x
            den += 0.59
            den *= x
            den += 0.14
            num /= den
        np.copyto(num, 2.51 / 2.43, where=~np.isfinite(num))
        x = num
    return np.clip(x, 0.0, 1.0, out=x)


# The sRGB codec (IEC 61966-2-1): the one encode and the one decode of the package.
def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """The sRGB OETF on values in [0, 1] (clipped)."""
    c = np.clip(linear, 0.0, 1.0)
    out = np.power(c, 1 / 2.4, out=np.empty_like(c))   # an array also for 0-d input (in-place steps)
    out *= 1.055
    out -= 0.055
    np.multiply(c, 12.92, out=out, where=c <= 0.0031308)
    return out


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """The sRGB EOTF: encoded [0, 1] (clipped) → linear, float32."""
    c = np.clip(encoded, 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def display(image: np.ndarray, method: str = "aces", exposure: float = 0.0) -> np.ndarray:
    """The display transform: (H, W, 3 or 4) linear radiance → (H, W, 3) sRGB-encoded float32
    in [0, 1] (exposure, tone map, sRGB OETF)."""
    return srgb_encode(tonemap(image[..., :3], method, exposure)).astype(np.float32)


def to_display(image: np.ndarray, method: str = "aces", exposure: float = 0.0) -> np.ndarray:
    """:func:`display` quantised to (H, W, 3) uint8, as PNG/JPEG store it (in chunks of
    DISPLAY_CHUNK_PIXELS pixels: the same values as one pass)."""
    height, width = image.shape[:2]
    out = np.empty((height, width, 3), np.uint8)
    rows = max(1, DISPLAY_CHUNK_PIXELS // max(width, 1))
    for r in range(0, max(height, 1), rows):
        encoded = display(image[r:r + rows], method, exposure)
        encoded *= 255.0
        out[r:r + rows] = np.round(encoded, out=encoded)
    return out


def check_output_path(path: Path, protected: list[Path] | tuple[Path, ...] = (), flag: str = "-o") -> Path:
    """Refuse outputs that would overwrite an input, have no supported format, or
    sit in a folder that does not exist or cannot be written (clshade.outputs)."""
    path = Path(path)
    # Inputs first: `-o scene.toml` must say why it is refused, not only that .toml is no image format.
    refuse_inputs(path, flag, protected)
    suffix = path.suffix.lower()
    if suffix not in LINEAR_SUFFIXES + DISPLAY_SUFFIXES:
        raise ClshadeError(f"{flag} {path}: unsupported output format {suffix or '(none)'}; "
                           f"use .exr (linear float), .png or .jpg (sRGB 8-bit)")
    return check_output_file(path, flag)


def write_image(path: str | Path, image: np.ndarray, method: str = "aces", exposure: float = 0.0,
                protected: list[Path] | tuple[Path, ...] = ()) -> Path:
    """Write atomically: a temporary file in the same folder, then a rename, so a
    failed or interrupted write never leaves a truncated image."""
    path = check_output_path(Path(path), protected)
    if path.suffix.lower() in LINEAR_SUFFIXES:
        return write_encoded(path, image.astype(np.float32, copy=False), protected)
    return write_encoded(path, to_display(image, method, exposure), protected)


def write_encoded(path: str | Path, pixels: np.ndarray, protected: list[Path] | tuple[Path, ...] = ()) -> Path:
    """Write pixels already in the file's encoding — float32 linear RGBA for .exr, uint8 sRGB
    RGB for .png/.jpg (to_display) — atomically (a temporary file, then a rename)."""
    import OpenImageIO as oiio
    path = check_output_path(Path(path), protected)
    linear = path.suffix.lower() in LINEAR_SUFFIXES
    expected = np.float32 if linear else np.uint8
    if pixels.dtype != expected:
        raise ClshadeError(f"{path}: internal error: {pixels.dtype} pixels for a {path.suffix} file")
    pixels = np.ascontiguousarray(pixels)
    fmt = "float" if linear else "uint8"
    height, width, channels = pixels.shape

    def encode(tmp: Path) -> None:
        spec = oiio.ImageSpec(width, height, channels, fmt)
        if linear:
            spec.channelnames = ("R", "G", "B", "A")[:channels]
            spec.alpha_channel = 3 if channels == 4 else -1
        elif path.suffix.lower() == ".png":
            # No oiio:ColorSpace here: OpenImageIO's PNG writer puts the sRGB, gAMA and cHRM
            # chunks in by default (the file is byte-identical with the attribute), and the
            # attribute costs ~30 ms of colour-configuration setup per process.
            spec.attribute("png:compressionLevel", PNG_COMPRESSION_LEVEL)
            spec.attribute("png:filter", PNG_FILTER_NONE)
        else:
            spec.attribute("oiio:ColorSpace", "sRGB")
        out = oiio.ImageOutput.create(str(tmp))
        if out is None:
            raise ClshadeError(f"{path}: OpenImageIO cannot write this format ({one_line(oiio.geterror())})")
        ok = out.open(str(tmp), spec) and out.write_image(pixels)
        error = out.geterror() if not ok else ""
        out.close()
        if not ok:
            raise ClshadeError(f"{path}: writing failed ({one_line(error)})")

    return write_atomic(path, encode)


def read_image(path: str | Path) -> np.ndarray:
    """Read an image as float32 (H, W, C) (used by tests and the comparison sheets)."""
    import OpenImageIO as oiio
    buf = oiio.ImageBuf(str(path))
    if buf.has_error:
        raise ClshadeError(f"{path}: cannot read image ({one_line(buf.geterror())})")
    return buf.get_pixels(oiio.FLOAT)

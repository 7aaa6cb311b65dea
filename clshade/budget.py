"""The resource budget: every size that comes from input is decided here, before the
allocation it would cause, against a fixed ceiling and the memory available now.

A size over its ceiling is refused whatever the machine (the ceilings keep a run's time and
memory bounded, so a typo such as `--lights 1000000000` fails at once); a size under its
ceiling is refused when its estimated bytes exceed the memory the system can give without
swapping. Either refusal is one line naming the value and the limit (README: Resource limits).

The input files are here too: a path that is read must be a regular file (not a device such
as /dev/zero, a FIFO, a socket or a folder) and, for text read whole, of bounded size.
"""
from __future__ import annotations

import os
import stat
from pathlib import Path

from clshade.errors import ClshadeError

MiB = 1 << 20
GiB = 1 << 30

#: Scene files are read whole; the largest bundled scene is ~5 kB.
MAX_SCENE_FILE_BYTES = 4 * MiB
#: A lobe file (.cl, .brdf) is read whole and a .brdf translated: the largest bundled lobe is
#: ~2.4 kB (scenes/lobes/ggx_brdf.brdf), so 256 KiB leaves a hundred times that.
MAX_LOBE_FILE_BYTES = 256 * 1024
#: Lobe files (*.cl, *.brdf) in one lobe folder: every command that uses the folder reads each
#: (a .brdf is translated, ~2 ms on the reference machine), so 1000 bound that to seconds.
MAX_LOBE_FOLDER_FILES = 1000
#: Decoded texture pixels (width × height of the largest sub-image): 4096² is 16.7 M texels;
#: textures are sampled per pixel of a frame of at most a few megapixels, so a larger image
#: only adds mip levels that are never read.
MAX_TEXTURE_PIXELS = 4096 * 4096
#: Host bytes per texel of a decoded texture: the decoded float32 channels (≤ 4), an RGB
#: float32 copy and the mip pyramid (4/3 of RGB float32): 16 + 12 + 16.
TEXTURE_BYTES_PER_TEXEL = 44
#: Texels of all shadow maps of a frame together (float32 depth each): 8192² = one map of
#: the largest size, sixteen of 2048², or sixty-four of the default 1024²; 256 MiB.
MAX_SHADOW_TEXELS = 8192 * 8192
SHADOW_BYTES_PER_TEXEL = 4
#: Lights of a frame (scene [[lights]] or `bench --lights`): the shading kernel loops over
#: every light for every pixel, so a frame's time grows linearly with the count (the largest
#: bundled scene has a handful).
MAX_LIGHTS = 256
#: Frames of one timed series (`bench --frames`, `--warmup`, `--numpy-frames`, `aa --frames`).
MAX_FRAMES = 100_000
#: Columns of `clshade sweep` (each keeps a G-buffer and a tile per model until the sheet is drawn).
MAX_SWEEP_COLUMNS = 32
#: Pixels of a contact sheet (compare, sweep): 8192² pixels.
MAX_SHEET_PIXELS = 8192 * 8192
#: Host bytes per sheet pixel: the float32 RGBA tile, the display copy, the RGBA written out,
#: and the G-buffer of the frame it was shaded from (~60 B per pixel).
SHEET_BYTES_PER_PIXEL = 128
#: Host bytes per sample of a whole (not streamed) frame: fragments, G-buffer, device buffers
#: and the image (bench, compare, sweep and aa hold whole frames; render streams bands).
FRAME_BYTES_PER_SAMPLE = 256
#: Scene coordinates (camera position and target, light positions, object translations): the
#: camera's view matrix squares differences of them; ±1e12 keeps every product finite in
#: float64 and float32 (camera.far's own limit is 1e12).
MAX_COORDINATE = 1e12


def meminfo_bytes(key: str) -> int | None:
    """A /proc/meminfo field (`MemAvailable`, `MemTotal`) in bytes; None where there is none (not Linux)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def available_memory() -> int | None:
    """Bytes the system can give without swapping (MemAvailable, Linux); None when unknown."""
    found = meminfo_bytes("MemAvailable")
    if found is not None:
        return found
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def check_count(name: str, value: int, high: int, low: int = 0) -> int:
    """Refuse `name = value` outside [low, high] (an option or key counted in items)."""
    if not low <= value <= high:
        raise ClshadeError(f"{name} = {value}: must be within [{low}, {high}]")
    return value


def check_memory(what: str, need: int, available: int | None = None) -> int:
    """Refuse an allocation of `need` bytes (described by `what`, which names the value) that
    exceeds the memory available now."""
    available = available_memory() if available is None else available
    if available is not None and need > available:
        raise ClshadeError(f"{what} needs about {need / GiB:.2f} GiB of memory, {available / GiB:.2f} GiB available")
    return need


def texture_pixels(width: int, height: int, channels: int) -> int:
    """A decoded texture's size, read from its header before decoding: refused over
    MAX_TEXTURE_PIXELS or the available memory. Returns the estimated bytes."""
    pixels = width * height
    if pixels > MAX_TEXTURE_PIXELS:
        raise ClshadeError(f"{width}x{height} texture exceeds the limit of {MAX_TEXTURE_PIXELS} pixels "
                           f"(4096x4096); scale it down")
    need = pixels * (TEXTURE_BYTES_PER_TEXEL + 4 * max(channels - 4, 0))
    return check_memory(f"a {width}x{height} texture", need)


def shadow_texels(count: int, size: int) -> int:
    """All shadow maps of a frame: `count` maps of size² texels, refused over MAX_SHADOW_TEXELS
    or the available memory. Returns their bytes."""
    texels = count * size * size
    if texels > MAX_SHADOW_TEXELS:
        raise ClshadeError(f"{count} shadow maps of {size}x{size} = {texels} texels exceed the limit of "
                           f"{MAX_SHADOW_TEXELS} (8192x8192 in all); lower render.shadow_map_size or cast fewer shadows")
    return check_memory(f"{count} shadow maps of {size}x{size}", texels * SHADOW_BYTES_PER_TEXEL)


def sheet_pixels(rows: int, columns: int, width: int, height: int) -> int:
    """A contact sheet of rows × columns tiles of width × height: refused over MAX_SHEET_PIXELS
    or the available memory. Returns its estimated bytes."""
    pixels = rows * columns * width * height
    if pixels > MAX_SHEET_PIXELS:
        raise ClshadeError(f"a sheet of {rows}x{columns} tiles of {width}x{height} = {pixels} pixels exceeds the "
                           f"limit of {MAX_SHEET_PIXELS} (8192x8192); use fewer models or columns, or smaller tiles")
    return check_memory(f"a sheet of {rows}x{columns} tiles of {width}x{height}", pixels * SHEET_BYTES_PER_PIXEL)


def frame_samples(width: int, height: int, samples: int) -> int:
    """A whole frame of width × height pixels with samples × samples each: refused when its
    working set exceeds the available memory (the raster's side is capped by MAX_RESOLUTION
    in clshade.render.samples). Returns its estimated bytes."""
    return check_memory(f"a {width}x{height} frame with {samples}x{samples} samples per pixel",
                        width * height * samples * samples * FRAME_BYTES_PER_SAMPLE)


def regular_file(path: str | Path, what: str, limit: int | None = None) -> Path:
    """`path` when it names a regular file (symbolic links followed) of at most `limit` bytes
    (when given); a device, FIFO, socket or folder is refused without being opened (reading
    /dev/zero never ends, opening a FIFO waits for a writer). `what` says what the file is
    for ("scene file", "texture")."""
    path = Path(path)
    try:
        found = os.stat(path)
    except FileNotFoundError:
        raise ClshadeError(f"{path}: {what} not found") from None
    except OSError as exc:
        raise ClshadeError(f"{path}: cannot read {what} ({exc.strerror or exc})") from None
    mode = found.st_mode
    if not stat.S_ISREG(mode):
        kind = ("a folder" if stat.S_ISDIR(mode) else "a FIFO" if stat.S_ISFIFO(mode)
                else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a socket" if stat.S_ISSOCK(mode)
                else "not a regular file")
        raise ClshadeError(f"{path}: {what} is {kind}, not a regular file")
    if limit is not None and found.st_size > limit:
        raise ClshadeError(f"{path}: {what} is larger than the limit of {limit} bytes")
    return path


def read_text(path: str | Path, what: str, limit: int) -> str:
    """The UTF-8 text of a regular file of at most `limit` bytes (checked on the open file, so
    a file that grows between the checks is still cut at the limit and refused)."""
    path = regular_file(path, what)
    try:
        with open(path, "rb") as f:
            if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):      # replaced since regular_file
                raise ClshadeError(f"{path}: {what} is not a regular file")
            data = f.read(limit + 1)
    except OSError as exc:
        raise ClshadeError(f"{path}: cannot read {what} ({exc.strerror or exc})") from None
    if len(data) > limit:
        raise ClshadeError(f"{path}: {what} is larger than the limit of {limit} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ClshadeError(f"{path}: cannot read {what} (not UTF-8: {exc.reason} at byte {exc.start})") from None

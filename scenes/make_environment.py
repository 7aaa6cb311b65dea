"""Make the small sky of scenes/environment.toml (committed): a Poly Haven map (CC0) box-filtered down.

    python scenes/make_environment.py ../shared/assets/hdri/courtyard.exr

Reads the 1024×512 equirectangular EXR, sets the texels its lossy (DWA) compression rang below 0 to 0,
averages FACTOR×FACTOR blocks (a box filter: the mean radiance is kept, up to that clamp) and writes
scenes/environments/courtyard_128x64.exr as half floats with ZIP compression (about 40 kB).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

FACTOR = 8                   # 1024×512 → 128×64: texels of 2.8°, a 40 kB file
OUT = Path(__file__).resolve().parent / "environments" / "courtyard_128x64.exr"


def downscale(pixels: np.ndarray, factor: int) -> np.ndarray:
    """Mean of factor×factor blocks of an (H, W, C) image (H and W multiples of factor)."""
    h, w, c = pixels.shape
    return pixels.reshape(h // factor, factor, w // factor, factor, c).mean(axis=(1, 3))


def main(source: str) -> None:
    image = oiio.ImageInput.open(source)
    if image is None:
        raise SystemExit(f"{source}: {oiio.geterror()}")
    spec = image.spec()
    pixels = np.asarray(image.read_image(0, 0, 0, 3, oiio.FLOAT), np.float64).reshape(spec.height, spec.width, 3)
    image.close()
    small = downscale(np.maximum(pixels, 0.0), FACTOR).astype(np.float32)
    out = oiio.ImageSpec(small.shape[1], small.shape[0], 3, oiio.HALF)
    out.attribute("compression", "zip")
    writer = oiio.ImageOutput.create(str(OUT))
    if writer is None or not writer.open(str(OUT), out) or not writer.write_image(small) or not writer.close():
        raise SystemExit(f"{OUT}: {oiio.geterror()}")
    print(f"wrote {OUT} ({small.shape[1]}x{small.shape[0]}, mean {small.mean(axis=(0, 1))}, max {small.max():g})")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else str(Path(__file__).resolve().parents[2] / "shared/assets/hdri/courtyard.exr"))

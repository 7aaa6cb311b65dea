"""Generate the small textures of scenes/textured.toml into scenes/textures/ (committed).

    python scenes/make_textures.py

checker_base.png   sRGB base colour: an 8×8 checker of warm white and terracotta
                   with a thin dark grout line (shows minification/aliasing)
roughness_mr.png   linear metallic-roughness (glTF: G = roughness, B = metallic):
                   roughness rising left to right 0.1 → 0.9, metallic in the top
                   quarter
bumps_normal.png   linear tangent-space normal map (glTF: +Y green up) of a grid
                   of hemispherical bumps, from the analytic height field
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

SIZE = 256                   # texels per side: small files, 9 mip levels
CHECKS = 8                   # checker cells per side
BUMPS = 8                    # bumps per side
BUMP_RADIUS = 0.38           # bump radius as a fraction of its cell
BUMP_HEIGHT = 0.6            # bump height relative to its radius (slope of the normals)
OUT = Path(__file__).resolve().parent / "textures"


def _grid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Texel-centre coordinates in [0, 1): x rightwards, y downwards (image rows)."""
    c = (np.arange(n) + 0.5) / n
    return np.meshgrid(c, c)


def checker() -> np.ndarray:
    x, y = _grid(SIZE)
    cell = (np.floor(x * CHECKS) + np.floor(y * CHECKS)) % 2
    light, dark = np.array([232, 224, 206]), np.array([176, 78, 52])
    rgb = np.where(cell[..., None] > 0, dark, light).astype(np.float64)
    fx, fy = (x * CHECKS) % 1.0, (y * CHECKS) % 1.0
    grout = (np.minimum(fx, 1 - fx) < 0.03) | (np.minimum(fy, 1 - fy) < 0.03)
    rgb[grout] = [60, 55, 50]
    return rgb.astype(np.uint8)


def roughness_metallic() -> np.ndarray:
    x, y = _grid(SIZE)
    rough = 0.1 + 0.8 * x
    metal = (y < 0.25).astype(float)
    mr = np.stack([np.zeros_like(x), rough, metal], axis=-1)
    return np.round(mr * 255).astype(np.uint8)


def bumps() -> np.ndarray:
    x, y = _grid(SIZE)
    u, v = (x * BUMPS) % 1.0 - 0.5, (y * BUMPS) % 1.0 - 0.5     # cell-local, v downwards
    r2 = u * u + v * v
    inside = r2 < BUMP_RADIUS ** 2
    h = np.sqrt(np.maximum(BUMP_RADIUS ** 2 - r2, 1e-12))
    # Height z = BUMP_HEIGHT·sqrt(R² − r²): ∂z/∂u = −BUMP_HEIGHT·u/h; image v grows
    # downwards, tangent-space +Y is up, so ∂z/∂Y = +BUMP_HEIGHT·v/h.
    dzdx = np.where(inside, -BUMP_HEIGHT * u / h, 0.0)
    dzdy = np.where(inside, BUMP_HEIGHT * v / h, 0.0)
    n = np.stack([-dzdx, -dzdy, np.ones_like(x)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return np.round((n * 0.5 + 0.5) * 255).astype(np.uint8)


def main() -> None:
    OUT.mkdir(exist_ok=True)
    for name, pixels in (("checker_base.png", checker()), ("roughness_mr.png", roughness_metallic()),
                         ("bumps_normal.png", bumps())):
        Image.fromarray(pixels, "RGB").save(OUT / name, optimize=True)
        print(f"wrote {OUT / name}")


if __name__ == "__main__":
    main()

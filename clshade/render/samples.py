"""Sample patterns inside a pixel: where the N×N samples of supersampling lie.

clshade supersamples on an *ordered (stratified) grid*: sample (a, b) of pixel
(row i, column j) sits at (j + (a + 0.5)/N, i + (b + 0.5)/N) in pixel units, the
centre of cell (a, b) when the pixel is cut into N×N equal cells. Rasterising the
G-buffer at N·W × N·H with the same camera puts the pixel centres of the larger
image exactly there (clshade/pipeline.py), and the device box-filters each N×N
block back into one pixel (clshade/device/resolve.py). A frame shaded with the
camera `shift`ed by one of `sample_offsets(N)` holds one sample of every pixel;
the mean of the N² jittered frames is the same pixel estimate, in memory of one
frame (the float64 ground truth of clshade/bench/aa.py is computed that way).

An ordered grid was chosen over a rotated grid because the rasterizer samples
pixel centres on a regular lattice: the grid is one larger raster, no new sample
positions in the rasterizer. Its weakness, as measured in the AA ladder, is
near-horizontal and near-vertical edges, where only N (not N²) coverage levels
occur.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from clshade.errors import ClshadeError
from clshade.render.gbuffer import CHANNELS, GBuffer
from clshade.render.scene import MAX_RESOLUTION, MAX_SAMPLES, Camera, Scene


def sample_offsets(n: int) -> np.ndarray:
    """(n², 2) offsets (x right, y down) of the ordered-grid samples from the pixel centre,
    in pixels, row by row: ((a + 0.5)/n − 0.5, (b + 0.5)/n − 0.5)."""
    if n < 1:
        raise ClshadeError(f"samples = {n}: must be ≥ 1")
    t = (np.arange(n) + 0.5) / n - 0.5
    yy, xx = np.meshgrid(t, t, indexing="ij")
    return np.stack([xx.ravel(), yy.ravel()], axis=1)


def jittered(camera: Camera, dx: float, dy: float) -> Camera:
    """The camera whose pixel centres sample (j + 0.5 + dx, i + 0.5 + dy)."""
    return dataclasses.replace(camera, shift=(float(dx), float(dy)))


def check_samples(samples: int, width: int, height: int, where: str = "samples") -> None:
    """Reject a sample count outside 1 … MAX_SAMPLES or a supersampled raster beyond MAX_RESOLUTION."""
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not 1 <= samples <= MAX_SAMPLES:
        raise ClshadeError(f"{where} = {samples!r}: must be an integer within [1, {MAX_SAMPLES}]")
    if max(width, height) * samples > MAX_RESOLUTION:
        raise ClshadeError(f"{where} = {samples}: {width}x{height} pixels × {samples} samples per axis exceeds "
                           f"the raster limit {MAX_RESOLUTION}")


def supersampled(camera: Camera, samples: int) -> Camera:
    """The camera of the N·W × N·H raster whose pixel centres are the N×N grid samples
    (a jitter `shift` stays the same fraction of an output pixel)."""
    if samples == 1:
        return camera
    crop = (camera.crop[0] * samples, camera.crop[1] * samples) if camera.crop else None
    return dataclasses.replace(camera, width=camera.width * samples, height=camera.height * samples, crop=crop,
                               shift=(camera.shift[0] * samples, camera.shift[1] * samples))


def with_antialiasing(scene: Scene, samples: int | None = None, specular_aa: bool = False) -> Scene:
    """The scene with command-line overrides: N×N `samples` (None keeps the scene's) and
    specular anti-aliasing switched on when `specular_aa`."""
    if samples is not None:
        check_samples(samples, 1, 1, where="--samples")
        scene = dataclasses.replace(scene, samples=samples)
    if specular_aa:
        scene = dataclasses.replace(scene, specular_aa=True)
    return scene


def coverage_gbuffer(gbuffer: GBuffer, samples: int) -> tuple[GBuffer, np.ndarray]:
    """MSAA-style: from an N·W × N·H G-buffer (coverage and depth at N×N samples per
    pixel), the W × H G-buffer that shades each pixel once — with the attributes of its
    covered sample nearest the pixel centre (the centre itself for odd N; centroid-like
    for even N) — and the (H, W) covered fraction. Unlike hardware MSAA a pixel holding
    two surfaces is shaded once, for the one nearest its centre."""
    n = samples
    h, w = gbuffer.height // n, gbuffer.width // n
    off = sample_offsets(n)
    order = np.argsort(np.hypot(off[:, 0], off[:, 1]), kind="stable")          # nearest the centre first

    def blocks(a: np.ndarray, comps: int) -> np.ndarray:            # (H, W, N², comps), samples row by row
        return a.reshape(h, n, w, n, comps).transpose(0, 2, 1, 3, 4).reshape(h, w, n * n, comps)

    covered = blocks(gbuffer.channels["depth"], 1)[..., 0] > 0
    pick = order[np.argmax(covered[..., order], axis=-1)]            # first covered in that order (or order[0])
    channels = {}
    for name, data in gbuffer.channels.items():
        comps = CHANNELS[name][1]
        channels[name] = np.take_along_axis(blocks(data, comps), pick[..., None, None], axis=2).reshape(-1)
    fraction = covered.mean(axis=-1)
    out = dataclasses.replace(gbuffer, width=w, height=h, channels=channels, coverage=fraction > 0)
    return out, fraction

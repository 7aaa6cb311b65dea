"""Side-by-side comparison: one rasterisation, every model shades the same
G-buffer, tiles laid out in a labelled contact sheet (the study's figures),
with an optional false-colour difference view against a reference model; and
the smoothness sweep (rows = models, columns = roughness), the study's Figure 4.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from clshade.errors import ClshadeError
from clshade.render.image import display, srgb_decode
from clshade.models.model import GROUPS, Model
from clshade.pipeline import Frame, prepare_frame, reads_tangents
from clshade.device.runtime import Runtime, get_runtime
from clshade.render.scene import Scene, load_scene
from clshade.device.shade import Shader, scene_features

FONT = "DroidSans"          # bundled with OpenImageIO
LABEL_SIZE = 15              # px
LABEL_HEIGHT = 40            # px under each tile: two lines
TITLE_HEIGHT = 30            # px above each group row
GAP = 6                      # px between tiles
SHEET_BACKGROUND = (0.08, 0.08, 0.09)
MAX_COLUMNS = 5              # tiles per row before a row wraps (contact sheets; sweeps never wrap)
MAX_TILE = 4096              # px: largest sweep/compare tile side (a sheet holds many)
TIMING_REPEATS = 7           # device-timed dispatches per tile; the median is shown


@dataclass
class Tile:
    model: Model
    image: np.ndarray        # (H, W, 4) linear radiance + coverage
    ms: float                # median device time per frame


def shade_all(frame: Frame, models: list[Model], runtime: Runtime, repeats: int = TIMING_REPEATS,
              progress=None) -> list[Tile]:
    """Shade one G-buffer with every model; time each kernel (median device time);
    `progress(done, total)` after each model."""
    shader = Shader(runtime, frame.gbuffer, frame.scene, frame.camera, frame.shadows)
    features = scene_features(frame.scene, geometry=frame.geometry)
    tiles = []
    for model in models:
        dispatch = shader.prepare(model, features)
        shader.enqueue(dispatch).wait()                  # warm-up (first-run compile per local size)
        times = []
        for _ in range(repeats):
            event = shader.enqueue(dispatch)
            event.wait()
            times.append((event.profile.end - event.profile.start) * 1e-6)
        tiles.append(Tile(model, shader.read(), float(np.median(times))))
        if progress is not None:
            progress(len(tiles), len(models))
    return tiles


def scene_display(image: np.ndarray, scene: Scene) -> np.ndarray:
    """image.display with the scene's tone map and exposure (sRGB floats in [0, 1])."""
    return display(image, scene.tonemap, scene.exposure)


def false_colour(x: np.ndarray) -> np.ndarray:
    """Map [0, 1] to a perceptual dark-blue → yellow ramp (viridis-like control points)."""
    stops = np.array([[0.267, 0.005, 0.329], [0.229, 0.322, 0.546], [0.128, 0.567, 0.551],
                      [0.369, 0.789, 0.383], [0.993, 0.906, 0.144]])
    t = np.clip(x, 0, 1) * (len(stops) - 1)
    i = np.minimum(t.astype(int), len(stops) - 2)
    f = (t - i)[..., None]
    return (stops[i] * (1 - f) + stops[i + 1] * f).astype(np.float32)


def difference(a: np.ndarray, b: np.ndarray, scale: float | None = None) -> tuple[np.ndarray, float]:
    """False-colour |a − b| of display values (max over RGB), normalised by `scale`
    (default: the largest difference). Returns the image and the scale used."""
    d = np.abs(a - b).max(axis=-1)
    scale = float(scale or d.max() or 1.0)
    return false_colour(d / scale), scale


def _text(buf, x: int, y: int, text: str, size: int = LABEL_SIZE, colour=(0.92, 0.92, 0.92)) -> None:
    import OpenImageIO as oiio
    if not oiio.ImageBufAlgo.render_text(buf, x, y, text, size, FONT, colour):
        raise ClshadeError(f"cannot render text with font {FONT!r}: {oiio.geterror()}")


def layout(rows: list[tuple[str, list[tuple[np.ndarray, str, str]]]], max_columns: int = MAX_COLUMNS) -> np.ndarray:
    """Rows of (title, [(tile RGB in [0, 1], line 1, line 2)]) → one sheet (H, W, 3) float;
    rows longer than `max_columns` wrap."""
    import OpenImageIO as oiio
    wrapped = []
    for title, tiles in rows:
        for start in range(0, len(tiles), max_columns):
            wrapped.append((title if start == 0 else "", tiles[start:start + max_columns]))
    rows = wrapped
    th, tw = rows[0][1][0][0].shape[:2]
    columns = max(len(tiles) for _, tiles in rows)
    width = GAP + columns * (tw + GAP)
    height = sum(TITLE_HEIGHT + th + LABEL_HEIGHT + GAP for _ in rows) + GAP
    sheet = np.empty((height, width, 3), np.float32)
    sheet[:] = SHEET_BACKGROUND
    labels: list[tuple[int, int, str, int]] = []
    y = GAP
    for title, tiles in rows:
        if title:
            labels.append((GAP, y + TITLE_HEIGHT - 9, title, LABEL_SIZE + 3))
        y += TITLE_HEIGHT
        for c, (rgb, line1, line2) in enumerate(tiles):
            x = GAP + c * (tw + GAP)
            sheet[y:y + th, x:x + tw] = rgb
            labels.append((x + 2, y + th + 17, line1, LABEL_SIZE))
            labels.append((x + 2, y + th + 35, line2, LABEL_SIZE - 2))
        y += th + LABEL_HEIGHT + GAP
    buf = oiio.ImageBuf(oiio.ImageSpec(width, height, 3, "float"))
    buf.set_pixels(oiio.ROI(0, width, 0, height, 0, 1, 0, 3), sheet)
    for x, yy, text, size in labels:
        _text(buf, x, yy, text, size)
    return buf.get_pixels(oiio.FLOAT)[..., :3]


def group_rows(tiles: list[Tile]) -> list[tuple[str, list[Tile]]]:
    """Group tiles as the study's figures do (diffuse, empirical, microfacet); others last."""
    rows: dict[str, list[Tile]] = {}
    for tile in tiles:
        rows.setdefault(tile.model.family, []).append(tile)
    order = [g for g in GROUPS if g in rows] + [g for g in rows if g not in GROUPS]
    return [(g, rows[g]) for g in order]


def compare_sheet(scene: Scene | str | Path, models: list[Model], *, width: int | None = None,
                  height: int | None = None, reference: Model | None = None, runtime: Runtime | None = None,
                  device: str | None = None, progress=None) -> tuple[np.ndarray, list[Tile]]:
    """The contact sheet (H, W, 3) display floats, and the shaded tiles; `progress(done, total)` per model."""
    rt = runtime or get_runtime(device)
    frame = prepare_frame(scene, width, height, tangents=reads_tangents(models + ([reference] if reference else [])),
                          runtime=rt)
    tiles = shade_all(frame, models, rt, progress=progress)
    rows = []
    for group, items in group_rows(tiles):
        rows.append((group, [(scene_display(t.image, frame.scene), model_title(t.model), f"{t.ms:.2f} ms/frame")
                             for t in items]))
    if reference is not None:
        ref_tile = next((t for t in tiles if t.model == reference), None) or shade_all(frame, [reference], rt)[0]
        ref_rgb = scene_display(ref_tile.image, frame.scene)
        diffs = [difference(scene_display(t.image, frame.scene), ref_rgb) for t in tiles if t.model != reference]
        scale = max((s for _, s in diffs), default=1.0)
        rows.append((f"|model - {reference.label}| (display values, full scale = {scale:.3f})",
                     [(difference(scene_display(t.image, frame.scene), ref_rgb, scale)[0], t.model.label,
                       f"max {np.abs(scene_display(t.image, frame.scene) - ref_rgb).max():.3f}")
                      for t in tiles if t.model != reference]))
    return layout(rows), tiles


SWEEP_ROUGHNESS = (0.05, 0.15, 0.3, 0.5, 0.7, 0.9)


def sweep_sheet(scene: Scene | str | Path, models: list[Model], roughness: tuple[float, ...] = SWEEP_ROUGHNESS,
                *, size: int = 160, runtime: Runtime | None = None, device: str | None = None,
                progress=None) -> np.ndarray:
    """Rows = models, columns = roughness (every material of the scene set to it; the
    Phong exponent follows as n = 2/α² − 2). The study's Figure 4. `progress(done, total)` per column."""
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    rt = runtime or get_runtime(device)
    columns = []
    for r in roughness:
        mats = {k: dataclasses.replace(m, roughness=r) for k, m in scene.materials.items()}
        frame = prepare_frame(dataclasses.replace(scene, materials=mats), size, size, tangents=reads_tangents(models),
                              runtime=rt)
        columns.append((r, frame, shade_all(frame, models, rt, repeats=1)))
        if progress is not None:
            progress(len(columns), len(roughness))
    rows = []
    for i, model in enumerate(models):
        cells = []
        for r, frame, tiles in columns:
            n = next(iter(frame.scene.materials.values())).exponent
            cells.append((scene_display(tiles[i].image, frame.scene), *sweep_labels(model, r, n)))
        rows.append((model_title(model), cells))
    return layout(rows, max_columns=len(roughness))    # one row per model: every roughness side by side


def model_title(model: Model) -> str:
    """The model's label, with its Fresnel term when a lobe uses one."""
    return f"{model.label}, {model.fresnel.capitalize()} Fresnel" if model.uses_fresnel else model.label


def sweep_labels(model: Model, roughness: float, exponent: float) -> tuple[str, str]:
    """A sweep tile's two label lines: the roughness, and the Phong exponent for lobes that have one."""
    return f"r = {roughness:g}", (f"n = {exponent:.3g}" if "shininess" in model.uses else "")


def write_sheet(path: str | Path, sheet: np.ndarray, protected=()) -> Path:
    """Write a display-referred sheet (already sRGB encoded) as 8-bit."""
    from clshade.render.image import write_image
    # write_image tone maps linear input; hand it values that survive 'none' + sRGB unchanged.
    linear = srgb_decode(sheet)
    rgba = np.concatenate([linear, np.ones(linear.shape[:2] + (1,), np.float32)], axis=-1)
    return write_image(path, rgba, "none", 0.0, protected)

"""Anti-aliasing as an accuracy-vs-time ladder.

A pixel's true value is the mean of the radiance over its area (a box filter).
The ground truth is that integral estimated by a dense ordered grid of samples
(`TRUTH_SAMPLES`² per pixel, clshade/render/samples.py), each sample evaluated in
float64 by the independent reference: one jittered frame per sample offset, so the
memory is that of one frame. Its convergence is shown by the same error measures
between the `TRUTH_SAMPLES`² and the `CHECK_SAMPLES`² truth.

Rungs (`RUNGS`): one sample per pixel, N×N supersampling resolved on the device,
specular anti-aliasing (kernels/specular_aa.h), both, and an MSAA-style rung
(coverage at 4×4 samples, one shade per pixel, blended with the background on the
device). Each rung gets its
device frame time (shading + resolve, mean and median over frames interleaved
across rungs; the host rasterisation of the N²-times larger G-buffer is reported
apart, it is not part of the frame time) and its error
against the truth as the mean per-pixel relative error over the whole frame, over
silhouette pixels (true coverage strictly between 0 and 1) and over highlight
pixels (fully covered, true radiance ≥ HIGHLIGHT_RATIO × the true radiance of the
model's diffuse lobe alone).

Temporal stability: `TEMPORAL_FRAMES` frames with the image plane moved by
`TEMPORAL_STEP` pixels per frame (a sub-pixel pan, Camera.shift). Each sphere's
highlight energy is the sum, over the sphere's cell (the pixels nearest its moving
projected centre), of the rung's image of the specular lobe alone (no ambient,
black background); the content only translates, so the exact energy is constant
and every frame-to-frame change is aliasing. Reported per sphere as
mean |E(t+1) − E(t)| / mean E.

Measuring functions return data; clshade/report/aa.py (aa_markdown, plot_aa) renders
it and `crop_sheet` builds the zoomed crops.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from clshade import __version__
from clshade.bench import CHECK_SAMPLES, TEMPORAL_FRAMES, TRUTH_SAMPLES
from clshade.bench.run import REL_ERROR_FLOOR, device_record, mark_pareto
from clshade.compare import layout, scene_display
from clshade.device.resolve import CoverageBlend
from clshade.device.runtime import Runtime, get_runtime
from clshade.device.shade import Shader, scene_features
from clshade.models.model import NONE, Model
from clshade.models.registry import Registry
from clshade.pipeline import Frame, prepare_frame
from clshade.render.meshes import Geometry, build_geometry
from clshade.render.samples import coverage_gbuffer, jittered, sample_offsets
from clshade.render.scene import Scene, load_scene
from clshade.report.tables import cell
from clshade.verify import reference


@dataclass(frozen=True)
class Rung:
    """One anti-aliasing setting: N×N samples per pixel, specular AA on or off; `msaa`:
    coverage at N×N samples but one shade per pixel (render/samples.py coverage_gbuffer)."""
    label: str
    samples: int
    specular_aa: bool
    msaa: bool = False


RUNGS = (Rung("1 sample", 1, False), Rung("2×2", 2, False), Rung("4×4", 4, False),
         Rung("specular AA", 1, True), Rung("specular AA + 2×2", 2, True),
         Rung("MSAA-style 4×4 coverage", 4, False, msaa=True))
HIGHLIGHT_RATIO = 2.0       # highlight pixel: true radiance ≥ 2 × the diffuse lobe's alone
TEMPORAL_STEP = (0.3, 0.15)  # pixels per frame (x right, y down): 4.8 px in all
WINDOW_MARGIN_PX = 3        # a sphere's cell reaches this far beyond its projected radius
CROP_PX = 20                # crop sheet: crop size in pixels, zoomed ZOOM× nearest-neighbour
ZOOM = 10


def diffuse_model(model: Model) -> Model:
    """The model's diffuse lobe alone, in the model's workflow (no lobe: black but for the ambient term,
    for a model without one: a lone specular lobe, a BRDF Explorer file)."""
    if model.diffuse == NONE:
        return dataclasses.replace(model, specular=NONE)
    return Model(model.diffuse, NONE, "schlick", model.workflow, lobes=model.lobes)


def specular_model(model: Model) -> Model:
    """The model's specular lobe alone (its Fresnel and workflow kept)."""
    return dataclasses.replace(model, diffuse=NONE)


# ---------------------------------------------------------------- frames


def _frame(scene: Scene, geometry: Geometry, *, samples: int = 1, specular_aa: bool = False,
           shift: tuple[float, float] = (0.0, 0.0)) -> Frame:
    cam = jittered(scene.camera, *shift)
    return prepare_frame(dataclasses.replace(scene, camera=cam, samples=samples, specular_aa=specular_aa),
                         geometry=geometry)


def sample_radiance(frame: Frame, model: Model) -> np.ndarray:
    """(H·W, 3) float64 radiance of one single-sample frame: the frame oracle
    (reference.radiance; f = 0 where n·v ≤ 0, at a few silhouette-rim samples)."""
    rad = reference.radiance(frame.gbuffer, frame.scene, model, dtype=np.float64, camera=frame.camera)
    return np.asarray(rad, np.float64).reshape(-1, 3)


@dataclass
class Truth:
    """The pixel integral estimated with samples² float64 samples per pixel."""
    samples: int
    radiance: np.ndarray       # (H, W, 3)
    diffuse: np.ndarray        # (H, W, 3) the diffuse lobe alone
    coverage: np.ndarray       # (H, W) covered fraction
    seconds: float


def truth_frame(scene: Scene, geometry: Geometry, model: Model, samples: int) -> Truth:
    """Mean of samples² jittered single-sample frames (one frame in memory at a time)."""
    start = time.perf_counter()
    h, w = scene.camera.height, scene.camera.width
    rad, dif, cov = np.zeros((h * w, 3)), np.zeros((h * w, 3)), np.zeros(h * w)
    dmodel = diffuse_model(model)
    for dx, dy in sample_offsets(samples):
        frame = _frame(scene, geometry, shift=(scene.camera.shift[0] + dx, scene.camera.shift[1] + dy))
        rad += sample_radiance(frame, model)
        dif += sample_radiance(frame, dmodel)
        cov += frame.gbuffer.coverage.ravel()
    n = samples * samples
    return Truth(samples, (rad / n).reshape(h, w, 3), (dif / n).reshape(h, w, 3), (cov / n).reshape(h, w),
                 time.perf_counter() - start)


# ---------------------------------------------------------------- errors


def pixel_error(image: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(H, W) per-pixel largest-channel relative error |L − L_true| / max(|L_true|, floor),
    floor = REL_ERROR_FLOOR · peak(L_true) (as the bench's other errors)."""
    floor = REL_ERROR_FLOOR * max(float(np.abs(truth).max()), 1e-30)
    return (np.abs(image[..., :3] - truth) / np.maximum(np.abs(truth), floor)).max(axis=-1)


def masks(truth: Truth) -> dict[str, np.ndarray]:
    """Pixel sets the errors are reported on."""
    full = truth.coverage >= 1.0
    lum, dlum = truth.radiance.sum(-1), truth.diffuse.sum(-1)
    return {"frame": np.ones_like(full), "silhouette": (truth.coverage > 0) & ~full,
            "highlight": full & (lum >= HIGHLIGHT_RATIO * dlum)}


def errors(image: np.ndarray, truth: Truth) -> dict[str, float]:
    """Mean relative error over the whole frame, silhouette and highlight pixels."""
    err = pixel_error(image, truth.radiance)
    return {f"{name}_rel_error": float(err[m].mean()) if m.any() else None for name, m in masks(truth).items()}


# ---------------------------------------------------------------- timing


def _time(shaders: list[tuple["RungFrame", object]], frames: int, warmup: int) -> list[list[float]]:
    """Device ms per frame for each (rung frame, dispatch), interleaved round by round."""
    times: list[list[float]] = [[] for _ in shaders]
    for r in range(warmup + frames):
        for k, (shader, dispatch) in enumerate(shaders):
            event = shader.enqueue(dispatch)
            event.wait()
            if r >= warmup:
                times[k].append((event.profile.end - event.profile.start) * 1e-6)
    return times


# ---------------------------------------------------------------- the ladder


@dataclass
class RungFrame:
    """A rung's prepared frame: the shader of its G-buffer and, for the MSAA-style rung,
    the coverage blend that follows each shading dispatch."""
    rung: Rung
    frame: Frame
    shader: Shader
    blend: CoverageBlend | None = None

    def enqueue(self, dispatch):
        event = self.shader.enqueue(dispatch)
        return self.blend.enqueue(event) if self.blend is not None else event

    def render(self, model: Model) -> np.ndarray:
        self.enqueue(self.shader.prepare(model, _features(self))).wait()
        return self.shader.read()


def rung_frames(scene: Scene, geometry: Geometry, runtime: Runtime,
                shift: tuple[float, float] = (0.0, 0.0)) -> list[RungFrame]:
    out = []
    for rung in RUNGS:
        frame = _frame(scene, geometry, samples=rung.samples, specular_aa=rung.specular_aa, shift=shift)
        if rung.msaa:
            gb, fraction = coverage_gbuffer(frame.gbuffer, rung.samples)
            one = dataclasses.replace(frame.scene, samples=1)
            shader = Shader(runtime, gb, one, jittered(scene.camera, *shift), frame.shadows)
            blend = CoverageBlend(runtime, fraction, shader.background, shader.out)
            out.append(RungFrame(rung, dataclasses.replace(frame, scene=one, gbuffer=gb), shader, blend))
        else:
            out.append(RungFrame(rung, frame, Shader(runtime, frame.gbuffer, frame.scene, frame.camera,
                                                     frame.shadows)))
    return out


def raster_ms(scene: Scene, geometry: Geometry, samples: int, repeats: int = 3) -> float:
    """Median host time of rasterising and writing the G-buffer at samples² per pixel."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        _frame(scene, geometry, samples=samples)
        times.append((time.perf_counter() - t0) * 1e3)
    return float(np.median(times))


def _features(rf: RungFrame):
    return scene_features(rf.frame.scene, geometry=rf.frame.geometry)


def ladder(scene: Scene, geometry: Geometry, models: list[Model], truths: dict[str, Truth], runtime: Runtime,
           frames: int, warmup: int) -> tuple[list[dict], dict[tuple[str, str], np.ndarray]]:
    """Rows (model × rung: time and errors) and the rung images by (model id, rung label)."""
    rfs = rung_frames(scene, geometry, runtime)
    pairs = [(rf, m) for m in models for rf in rfs]
    dispatches = [(rf, rf.shader.prepare(m, _features(rf))) for rf, m in pairs]
    times = _time(dispatches, frames, warmup)
    raster = {n: raster_ms(scene, geometry, n) for n in dict.fromkeys(r.samples for r in RUNGS)}
    rows, images = [], {}
    for (rf, m), t in zip(pairs, times):
        image = rf.render(m)
        images[(m.id, rf.rung.label)] = image
        row = dict(group=m.label, model=m.id, label=rf.rung.label, samples=rf.rung.samples,
                   specular_aa=rf.rung.specular_aa, frames=len(t), mean_ms=float(np.mean(t)),
                   median_ms=float(np.median(t)), raster_ms=raster[rf.rung.samples],
                   msaa=rf.rung.msaa, shaded_samples=rf.frame.gbuffer.pixels,
                   **errors(image, truths[m.id]))
        row["mean_rel_error"] = row["frame_rel_error"]
        rows.append(row)
    mark_pareto(rows)
    # The fronts of the plot's other panels (errors floored as drawn on its log axes).
    mark_pareto(rows, "silhouette_rel_error", "pareto_silhouette", floor=1e-9)
    mark_pareto(rows, "highlight_rel_error", "pareto_highlight", floor=1e-9)
    return rows, images


def convergence(truth: Truth, check: Truth) -> dict[str, object]:
    """The errors of the truth against the denser check truth: how far from converged."""
    return dict(truth_samples=truth.samples, check_samples=check.samples, **errors(truth.radiance, check))


# ---------------------------------------------------------------- temporal stability


@dataclass(frozen=True)
class Sphere:
    """A sphere of the scene as the camera sees it: projected centre and radius (pixels)."""
    name: str
    roughness: float
    x: float
    y: float
    radius: float

    def box(self) -> tuple[int, int, int, int]:
        """(row0, row1, col0, col1) of its bounding square (may extend past the image)."""
        r = self.radius
        return int(self.y - r), int(np.ceil(self.y + r)) + 1, int(self.x - r), int(np.ceil(self.x + r)) + 1


def spheres(scene: Scene) -> list[Sphere]:
    """Every sphere primitive of the scene, projected with the scene's camera."""
    cam = scene.camera
    view, proj = cam.view_matrix(), cam.projection_matrix()
    out = []
    for obj in scene.objects:
        if obj.primitive != "sphere":
            continue
        centre = view @ np.array([*obj.translate, 1.0])
        depth = -centre[2]
        radius = float(obj.params.get("radius", 1.0)) * max(obj.scale)
        clip = proj @ centre
        x = (clip[0] / clip[3] + 1) * 0.5 * cam.width
        y = (1 - clip[1] / clip[3]) * 0.5 * cam.height
        r_px = radius / max(depth - radius, 1e-9) * proj[1, 1] * 0.5 * cam.height
        out.append(Sphere(obj.name, scene.materials[obj.material].roughness, x, y, r_px))
    return out


def sphere_cells(balls: list[Sphere], shape: tuple[int, int], shift: tuple[float, float]) -> np.ndarray:
    """(H, W) index of the sphere each pixel belongs to (−1: none) for a camera moved by
    `shift` pixels: the nearest projected centre (content moves by −shift), within the
    sphere's radius + WINDOW_MARGIN_PX. Cells move with the content, so the energy in a
    cell changes only by aliasing (pixels between spheres are black in the temporal study)."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    dist = np.stack([np.hypot(xx - (b.x - shift[0]), yy - (b.y - shift[1])) for b in balls])
    near = dist.argmin(axis=0)
    limit = np.array([b.radius + WINDOW_MARGIN_PX for b in balls])
    return np.where(dist.min(axis=0) <= limit[near], near, -1)


def temporal(scene: Scene, geometry: Geometry, models: list[Model], runtime: Runtime,
             frames: int = TEMPORAL_FRAMES, step: tuple[float, float] = TEMPORAL_STEP) -> list[dict]:
    """Per model and rung: each sphere's frame-to-frame highlight energy change. The
    energy is that of the specular lobe alone under the lights, with no ambient and a
    black background, summed over the sphere's cell (sphere_cells), so that only the
    highlight counts and the exact value is constant."""
    balls = spheres(scene)
    dark = dataclasses.replace(scene, ambient=(0.0, 0.0, 0.0), background=(0.0, 0.0, 0.0))
    energy = {(m.id, r.label): [] for m in models for r in RUNGS}
    shape = (scene.camera.height, scene.camera.width)
    for t in range(frames):
        shift = (step[0] * t, step[1] * t)
        cells = sphere_cells(balls, shape, shift)
        for rf in rung_frames(dark, geometry, runtime, shift=shift):
            for m in models:
                spec = rf.render(specular_model(m))[..., :3].astype(np.float64).sum(-1)
                energy[(m.id, rf.rung.label)].append(
                    np.bincount(cells[cells >= 0], spec[cells >= 0], minlength=len(balls)))
    rows = []
    for m in models:
        for rung in RUNGS:
            e = np.array(energy[(m.id, rung.label)])               # (frames, spheres)
            change = np.abs(np.diff(e, axis=0)).mean(axis=0) / np.maximum(np.abs(e).mean(axis=0), 1e-30)
            rows.append(dict(group=m.label, model=m.id, label=rung.label,
                             spheres=[dict(name=b.name, roughness=b.roughness, energy_change=float(c))
                                      for b, c in zip(balls, change)],
                             mean_energy_change=float(change.mean()), max_energy_change=float(change.max())))
    return rows


# ---------------------------------------------------------------- crop sheet


def crop_boxes(truth: Truth, scene: Scene) -> dict[str, tuple[int, int]]:
    """Top-left corners of a highlight crop (the brightest highlight pixel of the
    sharpest sphere that has highlight pixels; else the brightest covered pixel) and a
    silhouette crop (the top-left rim of the same sphere; else any silhouette pixel)."""
    m = masks(truth)
    h, w = truth.coverage.shape
    lum = truth.radiance.sum(-1)
    box = np.ones((h, w), bool)
    for ball in sorted(spheres(scene), key=lambda b: b.roughness):
        r0, r1, c0, c1 = ball.box()
        inside = np.zeros((h, w), bool)
        inside[max(r0, 0):max(r1, 0), max(c0, 0):max(c1, 0)] = True
        if (m["highlight"] & inside).any():
            box = inside
            break
    spot = m["highlight"] & box if (m["highlight"] & box).any() else (truth.coverage > 0)
    y, x = np.unravel_index(int(np.argmax(np.where(spot, lum, -np.inf))), lum.shape)
    rim = m["silhouette"] & box if (m["silhouette"] & box).any() else m["silhouette"]
    sil = np.argwhere(rim) if rim.any() else np.array([[y, x]])
    sy, sx = sil[np.argmin(sil[:, 0] + sil[:, 1])]
    clamp = lambda a, n: int(min(max(a - CROP_PX // 2, 0), max(n - CROP_PX, 0)))  # noqa: E731
    return {"highlight": (clamp(y, h), clamp(x, w)), "silhouette": (clamp(sy + 4, h), clamp(sx + 4, w))}


def _zoom(image: np.ndarray, corner: tuple[int, int]) -> np.ndarray:
    y, x = corner
    crop = image[y:y + CROP_PX, x:x + CROP_PX]
    return np.repeat(np.repeat(crop, ZOOM, axis=0), ZOOM, axis=1)      # nearest neighbour, no filtering


def crop_sheet(scene: Scene, models: list[Model], images: dict[tuple[str, str], np.ndarray],
               truths: dict[str, Truth], rows: list[dict]) -> np.ndarray:
    """Rows = rungs and the truth; per model a highlight and a silhouette crop."""
    err = {(r["model"], r["label"]): r for r in rows}
    corners = {m.id: crop_boxes(truths[m.id], scene) for m in models}
    sides = ("left", "right") if len(models) == 2 else tuple(str(i + 1) for i in range(len(models)))
    columns = ", ".join(f"{m.label} ({side} pair)" for m, side in zip(models, sides))
    out = []
    for rung in [*RUNGS, None]:
        tiles = []
        for m in models:
            t = truths[m.id]
            img = t.radiance if rung is None else images[(m.id, rung.label)][..., :3]
            disp = scene_display(np.asarray(img, np.float32), scene)
            for kind in ("highlight", "silhouette"):
                r = None if rung is None else err[(m.id, rung.label)]
                sub = (f"{t.samples}x{t.samples} float64" if r is None
                       else f"err {cell(r[kind + '_rel_error'], '.3f')}, {r['mean_ms']:.2f} ms")
                tiles.append((_zoom(disp, corners[m.id][kind]), kind, sub))
        title = f"{t.samples}x{t.samples} ground truth" if rung is None else rung.label
        out.append((f"{title} — {columns}", tiles))
    return layout(out)


# ---------------------------------------------------------------- report


def run(scene_path: str | Path, models: list[Model], *, width: int | None = None, height: int | None = None,
        frames: int = 30, warmup: int = 3, truth_samples: int = TRUTH_SAMPLES,
        check_samples: int | None = CHECK_SAMPLES, temporal_frames: int = TEMPORAL_FRAMES,
        device: str | None = None, registry: Registry | None = None) -> tuple[dict, np.ndarray]:
    """The whole study: ladder, convergence of the truth, temporal table; and the crop sheet
    (the scene read with `registry`, load_scene)."""
    for m in models:
        reference.check_model(m)
    scene = load_scene(scene_path, registry)
    scene = dataclasses.replace(scene, camera=scene.camera.with_size(width, height), samples=1, specular_aa=False)
    runtime = get_runtime(device)
    geometry = build_geometry(scene)
    truths = {m.id: truth_frame(scene, geometry, m, truth_samples) for m in models}
    conv = []
    if check_samples:
        for m in models:
            check = truth_frame(scene, geometry, m, check_samples)
            conv.append(dict(group=m.label, model=m.id, **convergence(truths[m.id], check)))
    rows, images = ladder(scene, geometry, models, truths, runtime, frames, warmup)
    temp = temporal(scene, geometry, models, runtime, temporal_frames) if temporal_frames > 1 else []
    doc = dict(clshade=__version__, date=time.strftime("%Y-%m-%d", time.gmtime()),
               scene=Path(scene_path).name, width=scene.camera.width, height=scene.camera.height,
               frames=frames, warmup=warmup, device=device_record(runtime),
               definitions=dict(
                   frame_time="device time of one frame: shading kernel start to resolve kernel end, mean over "
                              "frames interleaved across rungs; raster_ms: rasterisation + G-buffer by the frame "
                              "pipeline's path (the JSON's gbuffer), median of 3 (grows with the samples; not in "
                              "the frame time)",
                   error=f"per pixel max over RGB of |L - L_true| / max(|L_true|, {REL_ERROR_FLOOR:g} * peak(L_true)), "
                         f"mean over the pixel set; L_true: {truth_samples}x{truth_samples} ordered-grid samples "
                         f"per pixel, float64 reference",
                   silhouette="pixels with true coverage strictly between 0 and 1",
                   highlight=f"fully covered pixels with true radiance >= {HIGHLIGHT_RATIO:g} x that of the "
                             "model's diffuse lobe alone",
                   temporal=f"{temporal_frames} frames, image plane moved {TEMPORAL_STEP} px per frame; per sphere "
                            "mean |E(t+1) - E(t)| / mean E of the highlight energy E (the specular lobe alone, no "
                            "ambient, black background, summed over the sphere's cell, which moves with it); "
                            "exact value 0"),
               truth=[dict(model=m.id, samples=truths[m.id].samples, seconds=truths[m.id].seconds)
                      for m in models],
               convergence=conv, ladder=rows, temporal=temp)
    return doc, crop_sheet(scene, models, images, truths, rows)

"""`clshade render`: one scene, one model, one image."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from clshade.cli.common import check_size, load_scene_with_overrides, progress_bar
from clshade.errors import ClshadeError


def _exposure(value: float | None) -> float | None:
    """--exposure checked like the scene key render.exposure (finite, within ±64 stops)."""
    from clshade.render.scene import EXPOSURE_RANGE
    low, high = EXPOSURE_RANGE
    if value is not None and not (math.isfinite(value) and low <= value <= high):
        raise ClshadeError(f"--exposure = {value:g}: must be a finite number of stops within [{low:g}, {high:g}]")
    return value


def _model_spec(value: str | None, default: str) -> str:
    """-m as given (an empty one is refused, not replaced by the scene's model)."""
    if value is None:
        return default
    if not value.strip():
        raise ClshadeError("-m '': no model given; `clshade models` lists them")
    return value


def _light_warning(scene, emission: bool) -> str | None:
    """A warning for a scene without lights (None when it has some)."""
    if scene.lights or scene.environment is not None:
        return None
    name = scene.path.name if scene.path else "the scene"
    if any(a > 0 for a in scene.ambient) or emission:
        lit = " and ".join(w for w, on in (("the ambient term", any(a > 0 for a in scene.ambient)),
                                           ("emission", emission)) if on)
        return f"{name} has no [[lights]]: surfaces get only {lit}"
    return f"{name} has no [[lights]], no ambient and no emission: every surface renders black"


def cmd_render(args: argparse.Namespace) -> int:
    """Render in bands of rows (pipeline.render_streamed): only the output image is
    full-frame, so a frame too large for memory is refused before anything is allocated."""
    import numpy as np
    from clshade.pipeline import Timings, check_frame_memory, render_streamed
    from clshade.render.image import LINEAR_SUFFIXES, check_output_path, to_display, write_encoded

    timings = Timings()
    with timings.stage("load scene"):
        scene = load_scene_with_overrides(args.scene, args)
    out = Path(args.output) if args.output else Path.cwd() / f"{Path(args.scene).stem}.png"
    protected = scene.inputs()
    check_output_path(out, protected)
    exposure = scene.exposure if args.exposure is None else _exposure(args.exposure)
    tonemap = args.tonemap or scene.tonemap
    registry = args.registry.with_lobes(*scene.lobes)
    model = registry.resolve(_model_spec(args.model, scene.model), args.fresnel, args.workflow)
    cam = scene.camera.with_size(check_size(args.width, "width"), check_size(args.height, "height"))
    linear = out.suffix.lower() in LINEAR_SUFFIXES
    check_frame_memory(cam.width, cam.height, 16 if linear else 3)
    pixels = np.empty((cam.height, cam.width, 4 if linear else 3), np.float32 if linear else np.uint8)

    def keep(first_row: int, band: np.ndarray) -> None:
        pixels[first_row:first_row + len(band)] = band if linear else to_display(band, tonemap, exposure)

    with progress_bar("render", "band") as progress:
        result = render_streamed(scene, model, keep, width=cam.width, height=cam.height, device=args.device,
                                 half_gbuffer=args.half, fast_math=args.fast_math, general=args.general,
                                 timings=timings, progress=progress, gbuffer=args.gbuffer)
    warning = _light_warning(scene, result.geometry.has_emission)
    if warning:
        print(f"clshade: warning: {warning}", file=sys.stderr)
    if args.explain:
        _explain(model, result)
    if result.nonfinite:
        print(f"clshade: warning: {result.nonfinite} pixels had non-finite G-buffer inputs "
              f"(NaN/Inf vertices or normals) and were shaded as background", file=sys.stderr)
    with timings.stage("write"):
        write_encoded(out, pixels, protected)
    n = scene.samples
    aa = (f", {n}x{n} samples per pixel" if n > 1 else "") + (", specular AA" if scene.specular_aa else "")
    print(f"wrote {out} ({cam.width}x{cam.height}{aa}, {model.label}, {result.geometry.triangle_count} triangles, "
          f"{result.covered} covered {'samples' if n > 1 else 'pixels'})")
    print(f"stages: {timings.line()}")
    return 0


def _explain_environment(model, shader, features) -> None:
    """--explain's lines on the sky: what it is, its precomputed data, and the sampled rung's strategies."""
    from clshade.device.variants import environment_rungs, environment_strategies
    spec, sky = shader.scene.environment, shader.environment
    w, h = sky.size
    print(f"environment: {spec.describe()}; {w}x{h} texels, mean radiance "
          + ", ".join(f"{c:.4g}" for c in sky.mean) + " (kernels/environment.h)")
    diffuse, specular = environment_rungs(model, features)
    strategies = environment_strategies(model, features)
    print(f"environment rungs: diffuse {diffuse}, specular {specular}"
          + (f"; sampled: {spec.samples} samples per pixel at run time from {' + '.join(strategies)} "
             "(Hammersley, per-pixel Cranley–Patterson rotation, balance-heuristic MIS)" if strategies else ""))


def _explain(model, result) -> None:
    """--explain: the kernel variant of a render (every band uses the same one)."""
    shader = result.shader
    variant = shader.variant(model, result.features)
    print(f"model: {model.label} ({model.id}); lobes: {', '.join(l.id for l in model.lobes)}; "
          f"fresnel: {model.fresnel if model.uses_fresnel else 'n/a'}; workflow: {model.workflow}")
    for line in result.features.describe():
        print(f"feature {line}")
    print(f"G-buffer channels: {', '.join(variant.channels)} "
          f"({shader.gb.bytes_per_pixel(variant.channels, result.features.half_gbuffer)} B/pixel read, 16 B written)")
    print("G-buffer normals: " + ("unit or zero, not normalised again (UNIT_NORMALS)" if variant.unit_normals
                                  else "normalised in the kernel"))
    print(result.gbuffer_path.line())
    if result.bands > 1:
        print(f"bands: {result.bands} (rows rasterised, written to the G-buffer and shaded band by band)")
    if result.shadows is not None:
        print(f"shadow maps: {result.shadows.count} x {result.shadows.size}² (lights "
              f"{', '.join(str(i) for i in shader.scene.shadow_lights)}; directional: orthographic "
              f"fitted to the scene bounds, spot: perspective), PCF {result.shadows.pcf}x{result.shadows.pcf} in the "
              f"shade kernel")
    for tset in result.geometry.texture_sets:
        print(f"texture set {tset.describe()}")
    if result.features.environment is not None:
        _explain_environment(model, shader, result.features.environment)
    n = shader.samples
    print(f"samples: {n}x{n} per pixel on an ordered grid, resolved on the device (kernels/resolve.cl)" if n > 1
          else "samples: 1 per pixel (centre)")
    print(f"build options: {' '.join(variant.options()) or '(none)'}")
    built = shader.rt.for_model(model)           # the build choice of the model's family
    print(f"build choice: {built.choice.label()} ({built.choice_source})")
    simd = built.simd
    print("defines: " + " ".join(f"{k}={v}" for k, v in {"SIMD": str(simd), **variant.defines()}.items()))
    print(f"device: {shader.rt.info.description}; {simd} pixel{'s' if simd > 1 else ''} per work-item "
          f"(kernels/simd.h; CLSHADE_SIMD to override)")
    for info, reason in getattr(shader.rt, "skipped", ()):
        print(f"skipped device: {info.spec} {info.description}: {reason}")

"""The `clshade` command line. Only this module prints; library code raises ClshadeError."""
from __future__ import annotations

import argparse
import gc
import math
import os
import sys
from contextlib import contextmanager
from pathlib import Path

from clshade import __version__, budget
from clshade.errors import ClshadeError, one_line


@contextmanager
def progress_bar(description: str, unit: str):
    """Yields progress(done, total) drawing a tqdm bar on stderr — only when stderr is a
    terminal (logs get no bar) and only once there is more than one step."""
    if not sys.stderr.isatty():
        yield None
        return
    bar = None

    def progress(done: int, total: int) -> None:
        nonlocal bar
        if bar is None and total > 1:
            from tqdm import tqdm
            bar = tqdm(total=total, desc=description, unit=unit, file=sys.stderr, leave=False, dynamic_ncols=True)
        if bar is not None:
            bar.update(done - bar.n)

    try:
        yield progress
    finally:
        if bar is not None:
            bar.close()


def _add_device(p: argparse.ArgumentParser) -> None:
    p.add_argument("--device", metavar="D",
                   help="OpenCL device: P:D index, cpu/gpu, or a substring such as 'PoCL 3.1' "
                        "(default: $CLSHADE_DEVICE, else the PoCL CPU device)")


def _add_model_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--fresnel", choices=("schlick", "dielectric", "conductor"),
                   help="Fresnel term of microfacet lobes (default schlick)")
    p.add_argument("--workflow", choices=("metallic", "kdks"),
                   help="metallic-roughness, or the study's k_d + k_s = 1 rule (default: kdks for empirical lobes)")
    p.add_argument("--half", action="store_true", help="store normal and base colour as half floats (vload_half)")
    p.add_argument("--fast-math", action="store_true", help="build with -cl-fast-relaxed-math")


def _add_aa_options(p: argparse.ArgumentParser) -> None:
    """--samples and --specular-aa (scenes/README.md: [render] samples, specular_aa)."""
    p.add_argument("--samples", type=int, metavar="N",
                   help="N×N samples per pixel, box-filtered on the device (default: the scene's render.samples)")
    p.add_argument("--specular-aa", action="store_true",
                   help="widen specular lobes by the normal's screen-space variance (render.specular_aa)")


def _load_scene(path, args: argparse.Namespace):
    """The scene file with the --samples / --specular-aa overrides."""
    from clshade.render.samples import with_antialiasing
    from clshade.render.scene import load_scene
    return with_antialiasing(load_scene(path), args.samples, args.specular_aa)


class _Parser(argparse.ArgumentParser):
    """Usage errors in one line, like every other error (`clshade render: error: ...`), exit status 2;
    subcommand parsers inherit the class."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message}; see `{self.prog} --help`\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="clshade", description="OpenCL deferred shading: compare lighting models "
                                     "as images, measure their cost and their accuracy.")
    parser.add_argument("--version", action="version", version=f"clshade {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser("render", help="render a scene to an image", description="Rasterise SCENE into a G-buffer, "
                       "shade it with one lighting model on the OpenCL device and write an image.")
    p.add_argument("scene", help="scene file (TOML, see scenes/README.md)")
    p.add_argument("-m", "--model", help="preset (e.g. ggx_correlated), diffuse+specular pair "
                   "(e.g. oren_nayar+ggx_correlated); default: the scene's render.model")
    p.add_argument("-o", "--output", help="output image: .exr (linear float) or .png/.jpg (sRGB); "
                   "default: <scene name>.png in the current folder")
    p.add_argument("--width", type=int, help="override camera.width")
    p.add_argument("--height", type=int, help="override camera.height")
    p.add_argument("--exposure", type=float, help="exposure in stops (default: the scene's render.exposure)")
    p.add_argument("--tonemap", choices=("none", "reinhard", "aces"), help="tone map for PNG/JPEG")
    p.add_argument("--explain", action="store_true",
                   help="print the feature set, build options and G-buffer channels of the kernel variant")
    p.add_argument("--general", action="store_true",
                   help="shade with the general kernel (runtime light loop and effect switches): same image, slower")
    _add_aa_options(p)
    _add_model_options(p)
    _add_device(p)
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("models", help="list the lighting models", description="List presets and lobes with their "
                       "formula, parameters and source, read from kernels/models/*.cl.")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=cmd_models)

    p = sub.add_parser("devices", help="list OpenCL platforms and devices")
    p.set_defaults(func=cmd_devices)

    _add_compare(sub)
    _add_view(sub)
    _add_bench(sub)
    _add_aa(sub)
    check = sub.add_parser("check", help="measure physical plausibility or numerical stability",
                           description="Measurements that back the claims clshade makes about its models.")
    checks = check.add_subparsers(dest="check", metavar="CHECK")
    checks.required = True
    _add_checks(checks)
    for name, command in sub.choices.items():
        if name not in ("check", "devices"):
            _add_lobe_options(command)
    for command in checks.choices.values():
        _add_lobe_options(command)
    return parser


def _add_lobe_options(p: argparse.ArgumentParser) -> None:
    """--lobes and --param: the user's lobes (docs/user-lobes.md)."""
    p.add_argument("--lobes", action="append", metavar="DIR", default=[],
                   help="a folder (or file) of your own lobes, *.cl and *.brdf; repeatable "
                        "(also $CLSHADE_LOBES and the scene key render.lobes)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", default=[],
                   help="a parameter of a .brdf lobe (float, bool 0/1, colour R,G,B); repeatable")


def _apply_lobe_options(args: argparse.Namespace) -> None:
    """Register --lobes folders, the lobe files -m names, and --param values before the command runs."""
    from clshade import models
    values = {}
    for item in getattr(args, "param", []):
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise ClshadeError(f"--param {item!r}: expected NAME=VALUE")
        values[name.strip()] = value.strip()
    models.set_params(values)
    for folder in getattr(args, "lobes", []):
        models.add_lobes(folder)
    if values:
        declared = {p.name for l in models.lobes().values() if l.origin == models.BRDF_FILE for p in l.params}
        for spec in (getattr(args, "model", None), getattr(args, "models", None)):
            for item in (spec or "").split(","):
                path = models._lobe_path(item.strip()) if item.strip() else None
                if path is not None:
                    for lobe_id in models.add_lobes(path):
                        declared |= {p.name for p in models.lobes()[lobe_id].params}
        unknown = sorted(set(values) - declared)
        if unknown and declared:
            raise ClshadeError(f"--param {unknown[0]}: no .brdf lobe in use has that parameter "
                               f"(theirs: {', '.join(sorted(declared))})")


def _add_compare(sub: argparse._SubParsersAction) -> None:
    from clshade.compare import SWEEP_ROUGHNESS
    p = sub.add_parser("compare", help="contact sheet of several models on one G-buffer",
                       description="Rasterise once, shade with every model, write a labelled contact sheet "
                                   "(model name and device time per frame under each tile).")
    p.add_argument("scene")
    p.add_argument("-m", "--models", default="all", help="comma-separated models, a group "
                   "(diffuse, empirical, microfacet) or all (default)")
    p.add_argument("-o", "--output", default="sheet.png")
    p.add_argument("--reference", help="add a false-colour difference row against this model")
    p.add_argument("--width", type=int, default=None)
    p.add_argument("--height", type=int, default=None)
    p.add_argument("--tile", type=int, default=320, help="tile width when --width is not given (default 320)")
    _add_aa_options(p)
    p.add_argument("--device")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("sweep", help="smoothness sweep: rows = models, columns = roughness",
                       description="The study's Figure 4: the same material at increasing roughness, per model. "
                                   "Normalised models brighten their highlights as they narrow.")
    p.add_argument("scene", nargs="?", help="scene (default: the bundled red_ball.toml)")
    p.add_argument("-m", "--models", default="phong,phong_normalized,blinn_phong,blinn_phong_normalized,"
                   "cook_torrance,walter_ggx,ggx_correlated")
    p.add_argument("-o", "--output", default="sweep.png")
    p.add_argument("--roughness", default=",".join(f"{r:g}" for r in SWEEP_ROUGHNESS),
                   help="comma-separated roughness values (columns)")
    p.add_argument("--size", type=int, default=160, help="tile size in pixels")
    _add_aa_options(p)
    p.add_argument("--device")
    p.set_defaults(func=cmd_sweep)


def _add_view(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("view", help="explore lighting models live in the browser",
                       description="Serve a local web page that renders SCENE live: drag to orbit, wheel to zoom, "
                                   "two models split on one G-buffer, |A - B|, sliders from the models' parameters, "
                                   "each model's shading time; save writes a scene that `clshade render` reproduces.")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--width", type=int, help="override camera.width")
    p.add_argument("--height", type=int, help="override camera.height")
    p.add_argument("-o", "--output-dir", default=".", metavar="DIR",
                   help="folder where 'save' writes NAME.toml, NAME.png and NAME.exr (default: the current folder)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1; any other address requires the random token "
                        "of the printed URL)")
    p.add_argument("--port", type=int, default=0, help="port (default: a free one)")
    p.add_argument("--no-browser", action="store_true", help="print the URL, do not open a browser")
    p.add_argument("--keep-running", action="store_true", help="keep serving after the last page is closed")
    _add_device(p)
    p.set_defaults(func=cmd_view)


def _add_bench(sub: argparse._SubParsersAction) -> None:
    from clshade.bench import NUMPY_FRAMES
    p = sub.add_parser("bench", help="frame-time statistics, accuracy and bandwidth floor per model",
                       description="Rasterise SCENE once, dispatch each model's kernel N times and report FPS "
                                   "with 1 % and 0.1 % lows, the copy-kernel floor, the NumPy float32 "
                                   "baseline (timed in the same rounds, wall time on both sides) and the error "
                                   "against the float64 frame oracle.")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("-m", "--models", default="all", help="comma-separated models, a group or 'all' (default)")
    p.add_argument("--frames", type=int, default=1000, help="timed frames per model (default 1000)")
    p.add_argument("--warmup", type=int, default=10, help="untimed frames per kernel first (default 10)")
    p.add_argument("--width", type=int, help="override camera.width")
    p.add_argument("--height", type=int, help="override camera.height")
    p.add_argument("--lights", type=int, help="use exactly N lights (extra directional lights are added)")
    _add_aa_options(p)
    p.add_argument("--ladder", action="store_true", help="also run the approximation ladders")
    p.add_argument("--numpy-frames", type=int, default=NUMPY_FRAMES,
                   help=f"NumPy frames per model, spread over the timed rounds (median; default {NUMPY_FRAMES})")
    p.add_argument("--json", metavar="OUT", help="write the results as JSON (docs/bench-schema.md)")
    p.add_argument("--csv", metavar="OUT", help="write the per-model table as CSV")
    p.add_argument("--plot", metavar="OUT.png", help="bar chart of FPS and lows (ladder plot beside it)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.add_argument("--device", metavar="D", help="OpenCL device (see `clshade devices`)")
    p.add_argument("--peers", metavar="P,Q", help="also time peers (numba, drjit; pip install 'clshade[peers]') on "
                   "the same G-buffer with every PoCL runtime and the STREAM anchor, in interleaved rounds")
    p.set_defaults(func=cmd_bench)


def _add_aa(sub: argparse._SubParsersAction) -> None:
    from clshade.bench import CHECK_SAMPLES, DEFAULT_MODELS, TEMPORAL_FRAMES, TRUTH_SAMPLES
    p = sub.add_parser("aa", help="anti-aliasing ladder: supersampling and specular AA vs the float64 pixel integral",
                       description="Render SCENE at each anti-aliasing rung (1 sample, 2x2, 4x4, specular AA, "
                                   "specular AA + 2x2, MSAA-style 4x4 coverage), time it, and measure its error "
                                   "against the pixel integral "
                                   "(a dense supersampled float64 frame from the oracle); temporal stability under a "
                                   "sub-pixel pan; a crop sheet of one highlight and one silhouette per rung.")
    p.add_argument("scene", nargs="?", help="scene (default: the bundled aa_spheres.toml)")
    p.add_argument("-m", "--models", default=DEFAULT_MODELS, help=f"comma-separated models (default {DEFAULT_MODELS})")
    p.add_argument("--width", type=int, help="override camera.width")
    p.add_argument("--height", type=int, help="override camera.height")
    p.add_argument("--frames", type=int, default=30, help="timed frames per rung, interleaved (default 30)")
    p.add_argument("--truth-samples", type=int, default=TRUTH_SAMPLES,
                   help=f"ground truth: N×N float64 samples per pixel (default {TRUTH_SAMPLES})")
    p.add_argument("--check-samples", type=int, default=CHECK_SAMPLES,
                   help=f"denser truth for the convergence check (default {CHECK_SAMPLES}; 0 = skip)")
    p.add_argument("--temporal-frames", type=int, default=TEMPORAL_FRAMES,
                   help=f"frames of the sub-pixel pan (default {TEMPORAL_FRAMES}; 0 = skip)")
    p.add_argument("-o", "--output", default="aa", metavar="PREFIX",
                   help="writes PREFIX.json, PREFIX.md, PREFIX_ladder.png and PREFIX_crops.png (default aa)")
    _add_device(p)
    p.set_defaults(func=cmd_aa)


def _add_checks(checks: argparse._SubParsersAction) -> None:
    p = checks.add_parser("plausibility", help="non-negativity, reciprocity and energy conservation of every preset",
                          description="Measure, on the OpenCL device, each preset's minimum f, reciprocity error "
                                      "and maximum directional albedo over a roughness/shininess sweep, and give "
                                      "the verdicts (physically based = all three).")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument("--device", metavar="D", help="OpenCL device (see `clshade devices`)")
    p.add_argument("--quick", action="store_true", help="the reduced sweep of `clshade models` (a few seconds)")
    p.add_argument("--model", metavar="M", help="restrict to these models (comma-separated; default: every preset "
                   "and each of your lobes)")
    p.set_defaults(func=cmd_plausibility)

    p = checks.add_parser("stability", help="torture grid: raw NaN/Inf/negative counts before any clamp, "
                          "saturated pixels, deviation from float64",
                          description="Hard inputs for every preset on the device, both builds (precise and fast "
                                      "math), through the BRDF evaluation and the whole shading pass with every "
                                      "light kind; NaN/Inf/negative counted on the raw radiance.")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument("--device", metavar="D", help="OpenCL device (see `clshade devices`)")
    p.add_argument("--model", metavar="M", help="restrict to these models (comma-separated; default: every preset, "
                   "microfacet presets with each Fresnel)")
    p.set_defaults(func=cmd_stability)


def _size(value: int | None, name: str) -> int | None:
    if value is not None and not (1 <= value <= 16384):
        raise ClshadeError(f"--{name} = {value}: must be within [1, 16384]")
    return value


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
    if scene.lights:
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
    from clshade.models import resolve
    from clshade.pipeline import Timings, check_frame_memory, render_streamed
    from clshade.render.image import LINEAR_SUFFIXES, check_output_path, to_display, write_encoded

    timings = Timings()
    with timings.stage("load scene"):
        scene = _load_scene(args.scene, args)
    out = Path(args.output) if args.output else Path.cwd() / f"{Path(args.scene).stem}.png"
    protected = scene.inputs()
    check_output_path(out, protected)
    exposure = scene.exposure if args.exposure is None else _exposure(args.exposure)
    tonemap = args.tonemap or scene.tonemap
    model = resolve(_model_spec(args.model, scene.model), args.fresnel, args.workflow)
    cam = scene.camera.with_size(_size(args.width, "width"), _size(args.height, "height"))
    linear = out.suffix.lower() in LINEAR_SUFFIXES
    check_frame_memory(cam.width, cam.height, 16 if linear else 3)
    pixels = np.empty((cam.height, cam.width, 4 if linear else 3), np.float32 if linear else np.uint8)

    def keep(first_row: int, band: np.ndarray) -> None:
        pixels[first_row:first_row + len(band)] = band if linear else to_display(band, tonemap, exposure)

    with progress_bar("render", "band") as progress:
        result = render_streamed(scene, model, keep, width=cam.width, height=cam.height, device=args.device,
                                 half_gbuffer=args.half, fast_math=args.fast_math, general=args.general,
                                 timings=timings, progress=progress)
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
    if result.bands > 1:
        print(f"bands: {result.bands} (rows rasterised, written to the G-buffer and shaded band by band)")
    if result.shadows is not None:
        print(f"shadow maps: {result.shadows.count} x {result.shadows.size}² (lights "
              f"{', '.join(str(i) for i in shader.scene.shadow_lights)}; directional: orthographic "
              f"fitted to the scene bounds, spot: perspective), PCF {result.shadows.pcf}x{result.shadows.pcf} in the "
              f"shade kernel")
    for tset in result.geometry.texture_sets:
        print(f"texture set {tset.describe()}")
    n = shader.samples
    print(f"samples: {n}x{n} per pixel on an ordered grid, resolved on the device (kernels/resolve.cl)" if n > 1
          else "samples: 1 per pixel (centre)")
    print(f"build options: {' '.join(variant.options()) or '(none)'}")
    simd = shader.rt.simd
    print("defines: " + " ".join(f"{k}={v}" for k, v in {"SIMD": str(simd), **variant.defines()}.items()))
    print(f"device: {shader.rt.info.description}; {simd} pixel{'s' if simd > 1 else ''} per work-item "
          f"(kernels/simd.h; CLSHADE_SIMD to override)")
    for info, reason in getattr(shader.rt, "skipped", ()):
        print(f"skipped device: {info.spec} {info.description}: {reason}")


def cmd_models(args: argparse.Namespace) -> int:
    import json
    from clshade.models import GROUPS, lobes, presets
    from clshade.verify.plausibility import physically_based
    try:  # measured on the device with a reduced sweep (`clshade check plausibility` for the full one)
        with progress_bar("measuring albedo", "preset") as progress:
            measured: dict[str, bool] = physically_based(progress=progress)
    except ClshadeError as exc:
        print(f"clshade: warning: physically_based not measured ({exc})", file=sys.stderr)
        measured = {}
    if args.json:
        data = {
            "presets": [{"id": m.id, "name": m.label, "diffuse": m.diffuse, "specular": m.specular,
                         "family": m.family, "workflow": m.workflow, "fresnel": m.fresnel if m.uses_fresnel else None,
                         "physically_based": measured.get(m.id)}
                        for m in presets()],
            "lobes": [{"id": l.id, "name": l.name, "kind": l.kind, "family": l.family, "formula": l.formula,
                       "source": l.source, "uses": sorted(l.uses), "notes": list(l.notes),
                       "origin": l.origin, "path": str(l.path) if l.is_users else None,
                       "deviations": list(l.deviations),
                       "params": [{"name": p.name, "min": p.low, "max": p.high, "default": p.default,
                                   "description": p.description} for p in l.params]}
                      for l in lobes().values()],
            "groups": {k: list(v) for k, v in GROUPS.items()},
        }
        print(json.dumps(data, indent=2, ensure_ascii=False))
        return 0
    print("Presets (the study's shaders):")
    for m in presets():
        pb = {True: "physically based", False: "not physically based", None: "unmeasured"}[measured.get(m.id)]
        print(f"  {m.id:32s} {m.label:26s} {m.family:10s} workflow={m.workflow:8s} {pb} (measured)")
    print("\nLobes (combine as diffuse+specular, e.g. oren_nayar+ggx_correlated; append @dielectric or "
          "@conductor for exact Fresnel):")
    for l in lobes().values():
        params = ", ".join(_param_text(p) for p in l.params) or "no parameters"
        print(f"  {l.id:24s} {l.kind:8s} {l.family:10s} {l.formula}")
        print(f"  {'':24s} params: {params}")
        print(f"  {'':24s} source: {l.source}")
        if l.is_users:
            print(f"  {'':24s} yours: {l.path} ({'BRDF Explorer file' if l.origin == 'brdf' else 'lobe file'})")
    return 0


def _param_text(p) -> str:
    """One parameter for `clshade models`: range and default, and the value compiled in where set."""
    if p.kind in ("float", "color") and not p.value and p.description.startswith("the material key"):
        return f"{p.name} = the material key (per pixel)"
    if p.kind == "color":
        return f"{p.name} (colour) = {','.join(f'{c:g}' for c in p.value)}"
    if p.kind == "bool":
        return f"{p.name} (bool) = {int(p.value[0])}"
    text = f"{p.name} [{p.low:g}, {p.high:g}] = {p.default:g}"
    return text + (f" (set to {p.value[0]:g})" if p.value and p.value[0] != p.default else "")


def default_rule(default) -> str:
    """How `clshade devices` explains its starred default (clshade.device.runtime.preference)."""
    if default is None:
        return "none, no device passes the health probe"
    if "cpu" in default.kind:
        return "the first healthy CPU device in clshade.device.runtime.RUNTIME_PREFERENCE"
    kind = default.kind.split("|")[-1].strip()        # "all | gpu" → "gpu"
    return f"no CPU device is healthy, so the first healthy device ({kind}) in clshade.device.runtime.preference order"


def cmd_devices(args: argparse.Namespace) -> int:
    from clshade.device.runtime import choose_device, device_health, list_devices
    from clshade.errors import ClshadeError
    try:
        default = choose_device(None).info
    except ClshadeError:
        default = None
    for info, device in list_devices():
        mark = "*" if info == default else " "
        state = device_health(info, device)
        status = "healthy" if state.ok else f"BROKEN: {state.reason}"
        print(f"{mark} {info.spec}  {info.kind:10s} {info.device}  |  {info.platform} | {info.platform_version}")
        print(f"        {info.runtime}: {status}")
    print(f"(* = default: {default_rule(default)}; choose with --device P:D or CLSHADE_DEVICE)")
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    from clshade.compare import MAX_TILE, compare_sheet, write_sheet
    from clshade.models import resolve, resolve_many
    from clshade.render.image import check_output_path
    scene = _load_scene(args.scene, args)
    check_output_path(Path(args.output), scene.inputs())
    models = resolve_many(args.models)
    for flag, value, high in (("--tile", args.tile, MAX_TILE), ("--width", args.width, 16384),
                              ("--height", args.height, 16384)):
        if value is not None and not 1 <= value <= high:
            raise ClshadeError(f"{flag} = {value}: must be within [1, {high}]")
    width = args.width or args.tile
    height = args.height or max(1, round(width * scene.camera.height / scene.camera.width))
    reference = resolve(args.reference) if args.reference else None
    budget.sheet_pixels(len(models) + (reference is not None), 1, width, height)
    with progress_bar("compare", "model") as progress:
        sheet, tiles = compare_sheet(scene, models, width=width, height=height, reference=reference,
                                     device=args.device, progress=progress)
    out = write_sheet(args.output, sheet, scene.inputs())
    print(f"wrote {out} ({len(tiles)} models, {width}x{height} tiles)")
    for t in tiles:
        print(f"  {t.model.label:28s} {t.ms:8.3f} ms/frame")
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    from clshade.compare import MAX_TILE, sweep_sheet, write_sheet
    from clshade.models import resolve_many
    from clshade.render.image import check_output_path
    from clshade.resources import scenes_dir
    scene = _load_scene(args.scene or scenes_dir() / "red_ball.toml", args)
    check_output_path(Path(args.output), scene.inputs())
    try:
        values = tuple(float(x) for x in args.roughness.split(",") if x.strip())
    except ValueError as exc:
        raise ClshadeError(f"--roughness = {args.roughness!r}: not a list of numbers") from exc
    if not values or any(not 0 <= v <= 1 for v in values):
        raise ClshadeError(f"--roughness = {args.roughness!r}: values must be within [0, 1]")
    if len(values) > budget.MAX_SWEEP_COLUMNS:
        raise ClshadeError(f"--roughness: {len(values)} values exceed the limit of {budget.MAX_SWEEP_COLUMNS} columns")
    if not 1 <= args.size <= MAX_TILE:
        raise ClshadeError(f"--size = {args.size}: must be within [1, {MAX_TILE}]")
    models = resolve_many(args.models)
    budget.sheet_pixels(len(models), len(values), args.size, args.size)
    with progress_bar("sweep", "column") as progress:
        sheet = sweep_sheet(scene, models, values, size=args.size, device=args.device, progress=progress)
    out = write_sheet(args.output, sheet, scene.inputs())
    print(f"wrote {out}")
    return 0


def cmd_view(args: argparse.Namespace) -> int:
    import asyncio
    import webbrowser
    from clshade.view.server import ViewServer
    from clshade.view.session import ViewSession
    if not 0 <= args.port <= 65535:
        raise ClshadeError(f"--port = {args.port}: must be within [0, 65535]")
    session = ViewSession(args.scene, args.output_dir, _size(args.width, "width"), _size(args.height, "height"),
                          device=args.device)
    server = ViewServer(session, args.host, args.port, linger=None if args.keep_running else 3.0)

    def ready(url: str) -> None:
        print(f"clshade view: serving {url} (Ctrl-C to stop)", flush=True)
        if not args.no_browser:
            webbrowser.open(url)

    try:
        asyncio.run(server.serve(ready))
    except OSError as exc:
        raise ClshadeError(f"--host {args.host} --port {args.port}: cannot listen ({exc.strerror or exc})") from exc
    print("clshade view: stopped", flush=True)
    return 0


PLOT_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg")


def _check_bench_outputs(args: argparse.Namespace, protected: list[Path]) -> None:
    """Every output path (none an input, no two the same; --plot's ladder plot beside it with
    --ladder), and matplotlib for --plot, before the benchmark runs."""
    from clshade.outputs import check_distinct, check_output_file
    from clshade.report.plots import pyplot
    ladder_plot = None
    if args.json:
        check_output_file(args.json, "--json", protected=protected)
    if args.csv:
        check_output_file(args.csv, "--csv", protected=protected)
    if args.plot:
        check_output_file(args.plot, "--plot", PLOT_SUFFIXES, protected=protected)
        if args.ladder:
            plot = Path(args.plot)
            ladder_plot = plot.with_name(plot.stem + "_ladder" + plot.suffix)
            check_output_file(ladder_plot, "--plot (its ladder plot)", PLOT_SUFFIXES, protected=protected)
        pyplot()
    check_distinct([("--json", args.json), ("--csv", args.csv), ("--plot", args.plot),
                    ("--plot (its ladder plot)", ladder_plot)])


def _check_bench_options(args: argparse.Namespace) -> None:
    """The counts of `clshade bench`, before the scene is prepared: each within its budget."""
    _size(args.width, "width")
    _size(args.height, "height")
    budget.check_count("--frames", args.frames, budget.MAX_FRAMES, low=1)
    budget.check_count("--warmup", args.warmup, budget.MAX_FRAMES)
    budget.check_count("--numpy-frames", args.numpy_frames, budget.MAX_FRAMES)
    if args.lights is not None:
        budget.check_count("--lights", args.lights, budget.MAX_LIGHTS)
    if args.peers is not None:
        from clshade.bench.peers import PEERS
        names = [p.strip() for p in args.peers.split(",") if p.strip()]
        unknown = [p for p in names if p not in PEERS]
        if unknown or not names:
            raise ClshadeError(f"--peers = {args.peers!r}: {'unknown peer ' + repr(unknown[0]) if unknown else 'no peer'}"
                               f"; choose from {', '.join(PEERS)}")


def cmd_bench(args: argparse.Namespace) -> int:
    import json
    from clshade.bench.run import run_bench
    from clshade.models import resolve_many
    from clshade.outputs import write_text_atomic
    from clshade.report.bench import bench_csv, bench_plots, bench_text
    _check_bench_options(args)
    scene = _load_scene(args.scene, args)
    _check_bench_outputs(args, scene.inputs())
    with progress_bar("bench", "round") as progress:
        doc = run_bench(scene, resolve_many(args.models), args.frames, args.warmup, width=args.width,
                        height=args.height, lights=args.lights, ladder=args.ladder, numpy_frames=args.numpy_frames,
                        device=args.device, progress=None if args.no_progress else progress)
    print(bench_text(doc))
    if args.peers:
        from clshade.bench import perf
        from clshade.report.perf import perf_markdown
        doc["peers"] = perf.bench_peers(args)
        print()
        print(perf_markdown(doc["peers"]))
    if args.json:
        write_text_atomic(args.json, json.dumps(doc, indent=2, ensure_ascii=False))
    if args.csv:
        bench_csv(doc["models"], Path(args.csv))
    if args.plot:
        bench_plots(doc, Path(args.plot))
    return 0


def _check_aa_outputs(prefix: Path, protected: list[Path]) -> None:
    """The four output files (none an input of the scene) and matplotlib (the ladder plot),
    before the long run."""
    from clshade.outputs import check_output_file
    from clshade.report.plots import pyplot
    for suffix in (".json", ".md", "_ladder.png", "_crops.png"):
        check_output_file(prefix.with_name(prefix.name + suffix), "-o", protected=protected)
    try:
        pyplot()
    except ClshadeError as exc:
        raise ClshadeError(f"clshade aa plots the ladder: {exc}") from exc


def cmd_aa(args: argparse.Namespace) -> int:
    import json
    from clshade.bench.aa import run
    from clshade.compare import write_sheet
    from clshade.models import resolve_many
    from clshade.outputs import write_text_atomic
    from clshade.render.scene import load_scene
    from clshade.provenance import stamp
    from clshade.report.aa import aa_markdown, plot_aa
    from clshade.resources import scenes_dir
    scene = args.scene or str(scenes_dir() / "aa_spheres.toml")
    _check_aa_outputs(Path(args.output), load_scene(scene).inputs())
    budget.check_count("--frames", args.frames, budget.MAX_FRAMES, low=1)
    budget.check_count("--temporal-frames", args.temporal_frames, budget.MAX_FRAMES)
    if args.frames < 1 or args.truth_samples < 1 or args.check_samples < 0 or args.temporal_frames < 0:
        raise ClshadeError(f"--frames = {args.frames}, --truth-samples = {args.truth_samples}, --check-samples = "
                           f"{args.check_samples}, --temporal-frames = {args.temporal_frames}: need ≥ 1, ≥ 1, ≥ 0, ≥ 0")
    doc, sheet = run(scene, resolve_many(args.models), width=_size(args.width, "width"),
                     height=_size(args.height, "height"), frames=args.frames, truth_samples=args.truth_samples,
                     check_samples=args.check_samples, temporal_frames=args.temporal_frames, device=args.device)
    opts = {"models": args.models, "width": args.width, "height": args.height, "frames": args.frames,
            "truth-samples": args.truth_samples, "check-samples": args.check_samples,
            "temporal-frames": args.temporal_frames}
    doc["command"] = " ".join(["clshade aa", args.scene or "scenes/aa_spheres.toml",
                               *(f"--{k} {v}" for k, v in opts.items() if v is not None), "-o", args.output])
    prefix = Path(args.output)
    doc = stamp(doc, doc["device"]["name"] if isinstance(doc.get("device"), dict) else None)
    write_text_atomic(prefix.with_name(prefix.name + ".json"), json.dumps(doc, indent=2, ensure_ascii=False))
    text = aa_markdown(doc)
    write_text_atomic(prefix.with_name(prefix.name + ".md"), text)
    plot_aa(doc, prefix.with_name(prefix.name + "_ladder.png"))
    write_sheet(prefix.with_name(prefix.name + "_crops.png"), sheet)
    print(text)
    return 0


def cmd_plausibility(args: argparse.Namespace) -> int:
    import json
    from dataclasses import asdict
    from clshade.verify import plausibility as P
    from clshade.models import resolve_many
    from clshade.report.plausibility import plausibility_table
    sweep = P.QUICK if args.quick else P.Sweep()
    chosen = resolve_many(args.model) if args.model else None
    with progress_bar("plausibility", "preset") as progress:
        verdicts = P.evaluate_presets(sweep, args.device, models=chosen, progress=progress)
    if args.json:
        print(json.dumps({"energy_tol": P.ENERGY_TOL, "reciprocity_tol": P.RECIPROCITY_TOL,
                          "sweep": asdict(sweep), "presets": [v.as_dict() for v in verdicts]},
                         indent=2, ensure_ascii=False))
    else:
        for line in [plausibility_table(verdicts), ""] + P.describe_method(sweep):
            print(line)
    return 0 if all(v.non_negative and v.reciprocal for v in verdicts) else 1


def cmd_stability(args: argparse.Namespace) -> int:
    import json
    from clshade.models import resolve_many
    from clshade.report.stability import stability_text
    from clshade.verify import stability
    models = None
    if args.model is not None:
        if not args.model.replace(",", "").strip():
            raise ClshadeError(f"--model = {args.model!r}: no model given; `clshade models` lists them")
        models = [v for m in resolve_many(args.model) for v in stability.variants_of(m)]
    with progress_bar("stability", "step") as progress:
        rep = stability.run(models, device=args.device, progress=progress)
    if args.json:
        print(json.dumps(rep.as_dict(), indent=2, ensure_ascii=False, default=str))
    else:
        print(stability_text(rep))
    return 0 if rep.ok else 1


def _quiet_broken_pipe() -> int:
    """stdout's reader went away (`clshade models | head`): stop quietly. stdout is
    pointed at /dev/null so that the interpreter's final flush does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):   # not a real file (tests replace stdout)
        pass
    return 141   # 128 + SIGPIPE, as a shell reports a process killed by it


def run() -> int:
    """The process entry point (the `clshade` script, `python -m clshade`): `main()` with
    the cyclic garbage collector tuned for a process that ends with its command.

    - Paused while the modules are imported and the parser is built: that allocates tens of
      thousands of long-lived objects (functions, classes, module dicts) and no garbage,
      which the collector would otherwise traverse again and again.
    - Then `gc.freeze()`: the survivors go to the permanent generation, which later
      collections skip; collection is on again for the command itself.
    - `gc.freeze()` once more when the command returns (not after a reported error):
      interpreter shutdown then does not traverse every object in its final full collections.
      Shutdown is otherwise complete: atexit handlers run, streams are flushed, objects are
      released by reference count; only objects in reference cycles are left to the operating
      system.

    And the allocator tuned (tune_allocator), NumPy's BLAS single-threaded
    (load_numpy_single_threaded_blas)."""
    start_process()
    status = 1
    try:
        status = main(after_parse=_resume_gc)
        return status
    finally:
        if status != 2:
            # Not after a reported error (exit status 2): objects of OpenImageIO's bindings
            # held in a cycle by the error's traceback would be frozen too, and nanobind
            # reports them at exit ("leaked 269 instances") on stderr, after clshade's one line.
            gc.freeze()


def start_process() -> None:
    """What `run` does before the command line is parsed (benchmarks/measure/startup_bench.py times it
    with the imports): collector paused, allocator tuned, NumPy loaded."""
    gc.disable()
    tune_allocator()
    load_numpy_single_threaded_blas()


BLAS_THREADS = "OPENBLAS_NUM_THREADS"


def load_numpy_single_threaded_blas() -> None:
    """Import NumPy with its OpenBLAS limited to one thread, unless the user set
    OPENBLAS_NUM_THREADS. OpenBLAS otherwise starts a worker thread per core that busy-waits
    after start-up and after each call, on the core PoCL's threads need; clshade's BLAS
    calls are 3×3 transforms of vertex arrays. OpenBLAS
    reads the variable once, when it loads: it is removed again, so child processes see the
    environment the user gave."""
    if "numpy" in sys.modules or BLAS_THREADS in os.environ:
        return
    os.environ[BLAS_THREADS] = "1"
    try:
        import numpy  # noqa: F401
    finally:
        del os.environ[BLAS_THREADS]


#: Blocks up to this size come from the heap, where freed blocks are reused, instead of
#: fresh mmap(2)s that the kernel zero-fills page by page on first touch (32 MiB: glibc's
#: largest allowed value). A render allocates and frees NumPy temporaries of a few MB all
#: the time; with glibc's default (a threshold that adapts from 128 KiB, and the heap's top
#: returned to the system) they were faulted in again and again.
MMAP_THRESHOLD = 32 << 20
#: Free memory at the top of the heap kept for reuse instead of being returned to the
#: system (glibc's default is twice the adapted mmap threshold).
TRIM_THRESHOLD = 128 << 20


def tune_allocator() -> bool:
    """Set MMAP_THRESHOLD and TRIM_THRESHOLD with glibc's mallopt; False (nothing changed)
    where the C library has no mallopt (musl, macOS) or refuses a value."""
    from clshade.allocator import set_malloc_thresholds
    return set_malloc_thresholds(MMAP_THRESHOLD, TRIM_THRESHOLD)


def _resume_gc() -> None:
    """Freeze what start-up allocated and collect again from here on."""
    gc.freeze()
    gc.enable()


def main(argv: list[str] | None = None, after_parse=None) -> int:
    """Run one command (argv: sys.argv[1:] by default); `after_parse()` is called once the
    arguments are parsed, before the command runs. Returns the exit status."""
    try:
        return _main(argv, after_parse)
    except BrokenPipeError:
        return _quiet_broken_pipe()


def _main(argv: list[str] | None, after_parse=None) -> int:
    from clshade import diagnostics
    parser = build_parser()
    args = parser.parse_args(argv)
    if after_parse is not None:
        after_parse()
    try:
        with diagnostics.warnings_captured():
            _apply_lobe_options(args)
            status = int(args.func(args) or 0)
        sys.stdout.flush()      # a closed pipe shows here, inside the handler, not at exit
        return status
    except BrokenPipeError:
        raise
    except (ClshadeError, OSError, MemoryError) as exc:
        # OSError and MemoryError: the system refused (disk full, permissions, memory) where
        # no check could tell in advance; one line too, with the traceback under --debug.
        if args.debug:
            raise
        print(f"clshade: error: {_one_line_error(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("clshade: interrupted", file=sys.stderr)
        return 130
    finally:
        if args.debug:
            _print_debug(diagnostics.NOTES, sys.exc_info()[1])
        diagnostics.NOTES.clear()


def _one_line_error(exc: BaseException) -> str:
    if isinstance(exc, MemoryError):
        return f"out of memory ({exc or 'MemoryError'}); see the README's Resource limits"
    if isinstance(exc, OSError):
        where = f"{exc.filename}: " if exc.filename else ""
        return one_line(f"{where}{exc.strerror or exc}")
    return str(exc)


def _print_debug(notes: list[str], exc: BaseException | None) -> None:
    """--debug: the messages of other libraries captured during the run, and an error's detail
    (a build log), on stderr."""
    for text in notes:
        print(f"clshade: debug: {text}", file=sys.stderr)
    detail = getattr(exc, "detail", "")
    if detail:
        print(f"clshade: debug: detail of the error:\n{detail}", file=sys.stderr)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(run())

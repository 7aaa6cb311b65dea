"""The argument parser: one-line usage errors, every command's options, and the option
groups several commands share (device, model, anti-aliasing, lobes)."""
from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from clshade import __version__
from clshade.cli.commands import aa, bench, check, compare, devices, render, sweep, view
from clshade.cli.commands import models as models_command
from clshade.errors import ClshadeError

if TYPE_CHECKING:
    from clshade.models.registry import Registry


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
    _add_size(p)
    p.add_argument("--exposure", type=float, help="exposure in stops (default: the scene's render.exposure)")
    p.add_argument("--tonemap", choices=("none", "reinhard", "aces"), help="tone map for PNG/JPEG")
    p.add_argument("--explain", action="store_true",
                   help="print the feature set, build options and G-buffer channels of the kernel variant")
    p.add_argument("--general", action="store_true",
                   help="shade with the general kernel (runtime light loop and effect switches): same image, slower")
    _add_aa_options(p)
    _add_environment_options(p)
    _add_model_options(p)
    _add_device(p)
    p.set_defaults(func=render.cmd_render)

    p = sub.add_parser("models", help="list the lighting models", description="List presets and lobes with their "
                       "formula, parameters and source, read from kernels/models/*.cl.")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=models_command.cmd_models)

    p = sub.add_parser("devices", help="list OpenCL platforms and devices")
    p.add_argument("--tune", action="store_true", help="measure every device's build choices and the devices' "
                   "order again (≤ 10 s a device) and show the measurements")
    p.set_defaults(func=devices.cmd_devices)

    _add_compare(sub)
    _add_view(sub)
    _add_bench(sub)
    _add_aa(sub)
    check_parser = sub.add_parser("check", help="measure physical plausibility or numerical stability",
                                  description="Measurements that back the claims clshade makes about its models.")
    checks = check_parser.add_subparsers(dest="check", metavar="CHECK")
    checks.required = True
    _add_checks(checks)
    for name, command in sub.choices.items():
        if name not in ("check", "devices"):
            _add_lobe_options(command)
        if name in ("render", "compare", "bench", "aa"):
            _add_gbuffer(command)
    for command in checks.choices.values():
        _add_lobe_options(command)
    return parser


def _add_gbuffer(p: argparse.ArgumentParser) -> None:
    """--gbuffer: which path makes the raster and G-buffer (clshade.pipeline.GBufferStage)."""
    p.add_argument("--gbuffer", choices=("auto", "host", "device"), default="auto",
                   help="raster and G-buffer: on the device where it is supported and verified bit for bit "
                        "against the NumPy rasterizer on this device (auto, default), the NumPy rasterizer "
                        "(host), or the device path required (device; refused where it cannot serve)")


def _add_size(p: argparse.ArgumentParser) -> None:
    """--width and --height: the frame size instead of the scene camera's."""
    p.add_argument("--width", type=int, help="override camera.width")
    p.add_argument("--height", type=int, help="override camera.height")


def _add_device(p: argparse.ArgumentParser) -> None:
    p.add_argument("--device", metavar="D",
                   help="OpenCL device: P:D index, cpu/gpu, or a substring such as 'PoCL 3.1' (default: "
                        "$CLSHADE_DEVICE, else the first healthy CPU device in the measured runtime order)")


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


def _add_environment_options(p: argparse.ArgumentParser) -> None:
    """The rungs of the scene's [environment] (scenes/README.md): --environment-diffuse, -specular, -samples."""
    from clshade.render.environment import DIFFUSE_RUNGS, MAX_SAMPLES, SPECULAR_RUNGS
    p.add_argument("--environment-diffuse", choices=DIFFUSE_RUNGS,
                   help="the diffuse lobe's rung under the sky (default: the scene's environment.diffuse)")
    p.add_argument("--environment-specular", choices=SPECULAR_RUNGS,
                   help="the specular lobe's rung under the sky: split_sum (prefiltered map × DFG table), "
                        "split_sum_ms (+ multiple-scattering compensation) or sampled "
                        "(default: the scene's environment.specular)")
    p.add_argument("--environment-samples", type=int, metavar="N",
                   help=f"samples per pixel of the sampled rungs, 1 … {MAX_SAMPLES} (environment.samples)")


def _add_lobe_options(p: argparse.ArgumentParser) -> None:
    """--lobes and --param: the user's lobes (docs/user-lobes.md)."""
    p.add_argument("--lobes", action="append", metavar="DIR", default=[],
                   help="a folder (or file) of your own lobes, *.cl and *.brdf; repeatable "
                        "(also $CLSHADE_LOBES and the scene key render.lobes)")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", default=[],
                   help="a parameter of a .brdf lobe (float, bool 0/1, colour R,G,B); repeatable")


def lobe_registry(args: argparse.Namespace) -> Registry:
    """The command's Registry: built-ins, $CLSHADE_LOBES, --lobes folders and --param values (with
    --param, the lobe files -m names too, to check the names); a scene's render.lobes join it
    where the scene is read (Registry.with_lobes)."""
    from clshade.models.lobe import BRDF_FILE
    from clshade.models.registry import Registry, lobe_path
    values = {}
    for item in getattr(args, "param", []):
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise ClshadeError(f"--param {item!r}: expected NAME=VALUE")
        values[name.strip()] = value.strip()
    registry = Registry.from_env().with_params(values)
    if getattr(args, "lobes", []):
        registry = registry.with_lobes(*args.lobes)
        registry.lobes      # read now, once for all folders: a broken lobe file fails before the command starts
    if values:
        declared = {p.name for l in registry.lobes.values() if l.origin == BRDF_FILE for p in l.params}
        for spec in (getattr(args, "model", None), getattr(args, "models", None)):
            for item in (spec or "").split(","):
                path = lobe_path(item.strip()) if item.strip() else None
                if path is not None:
                    registry = registry.with_lobes(path)
                    for lobe_id in registry.ids_in(path):
                        declared |= {p.name for p in registry.lobes[lobe_id].params}
        unknown = sorted(set(values) - declared)
        if unknown and declared:
            raise ClshadeError(f"--param {unknown[0]}: no .brdf lobe in use has that parameter "
                               f"(theirs: {', '.join(sorted(declared))})")
    return registry


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
    _add_environment_options(p)
    p.add_argument("--device")
    p.set_defaults(func=compare.cmd_compare)

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
    p.set_defaults(func=sweep.cmd_sweep)


def _add_view(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("view", help="explore lighting models live in the browser",
                       description="Serve a local web page that renders SCENE live: drag to orbit, wheel to zoom, "
                                   "two models split on one G-buffer, |A - B|, sliders from the models' parameters, "
                                   "each model's shading time, an environment picker with the rungs' cost and error; "
                                   "save writes a scene that `clshade render` reproduces. Without --width/--height the "
                                   "canvas follows the window (device pixel ratio included), up to --max-canvas.")
    p.add_argument("scene", help="scene file (TOML)")
    _add_size(p)
    p.add_argument("--max-canvas", default="1920x1080", metavar="WxH",
                   help="largest canvas rendered when it follows the window (default 1920x1080; aspect kept)")
    p.add_argument("-o", "--output-dir", default=".", metavar="DIR",
                   help="folder where 'save' writes NAME.toml, NAME.png and NAME.exr (default: the current folder)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1; any other address requires the random token "
                        "of the printed URL)")
    p.add_argument("--port", type=int, default=0, help="port (default: a free one)")
    p.add_argument("--no-browser", action="store_true", help="print the URL, do not open a browser")
    p.add_argument("--keep-running", action="store_true", help="keep serving after the last page is closed")
    _add_device(p)
    p.set_defaults(func=view.cmd_view)


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
    _add_size(p)
    p.add_argument("--lights", type=int, help="use exactly N lights (extra directional lights are added)")
    _add_aa_options(p)
    p.add_argument("--ladder", action="store_true", help="also run the approximation ladders")
    p.add_argument("--environment-ladder", metavar="N,N", default=None,
                   help="a scene with an [environment]: the sample counts of the sampled rungs "
                        "(default 1,4,16,64,256,1024; docs/environment-ladder.md)")
    p.add_argument("--oracle-pixels", type=int, metavar="K", default=None,
                   help="a scene with an [environment]: pixels the float64 truth integrates (default 256)")
    p.add_argument("--numpy-frames", type=int, default=NUMPY_FRAMES,
                   help=f"NumPy frames per model, spread over the timed rounds (median; default {NUMPY_FRAMES})")
    p.add_argument("--json", metavar="OUT", help="write the results as JSON (docs/bench-schema.md)")
    p.add_argument("--csv", metavar="OUT", help="write the per-model table as CSV")
    p.add_argument("--plot", metavar="OUT.png", help="bar chart of FPS and lows (ladder plot beside it)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.add_argument("--whole-frames", type=int, metavar="N", default=0,
                   help="also time N whole frames per model with the camera orbiting (setup, raster and "
                        "G-buffer, upload, shade, read back): average FPS, 1 %% and 0.1 %% lows, the stage split")
    p.add_argument("--overlap", action="store_true",
                   help="with --whole-frames on the device G-buffer path: the next frame's triangle setup on a "
                        "second thread while this frame is made on the device (the same images)")
    p.add_argument("--device", metavar="D", help="OpenCL device (see `clshade devices`)")
    p.add_argument("--peers", metavar="P,Q", help="also time peers (numba, drjit; pip install 'clshade[peers]') on "
                   "the same G-buffer with every PoCL runtime and the STREAM anchor, in interleaved rounds")
    p.set_defaults(func=bench.cmd_bench)


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
    _add_size(p)
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
    p.set_defaults(func=aa.cmd_aa)


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
    p.set_defaults(func=check.cmd_plausibility)

    p = checks.add_parser("stability", help="torture grid: raw NaN/Inf/negative counts before any clamp, "
                          "saturated pixels, deviation from float64",
                          description="Hard inputs for every preset on the device, both builds (precise and fast "
                                      "math), through the BRDF evaluation and the whole shading pass with every "
                                      "light kind; NaN/Inf/negative counted on the raw radiance.")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument("--device", metavar="D", help="OpenCL device (see `clshade devices`)")
    p.add_argument("--model", metavar="M", help="restrict to these models (comma-separated; default: every preset, "
                   "microfacet presets with each Fresnel)")
    p.add_argument("--no-environment", action="store_true",
                   help="skip the environment cases (a sun sky in every rung: NaN/Inf/negative, fireflies)")
    p.set_defaults(func=check.cmd_stability)

"""The `clshade` command line. Only this module prints; library code raises ClshadeError."""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from importlib import import_module
from pathlib import Path

from clshade import __version__
from clshade.errors import ClshadeError


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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="clshade", description="OpenCL deferred shading: compare lighting models "
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
    _add_model_options(p)
    _add_device(p)
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("models", help="list the lighting models", description="List presets and lobes with their "
                       "formula, parameters and source, read from kernels/models/*.cl.")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=cmd_models)

    p = sub.add_parser("devices", help="list OpenCL platforms and devices")
    p.set_defaults(func=cmd_devices)

    check = sub.add_parser("check", help="measure physical plausibility or numerical stability",
                           description="Measurements that back the claims clshade makes about its models.")
    checks = check.add_subparsers(dest="check", metavar="CHECK")
    checks.required = True
    for module in EXTENSIONS:
        import_module(f"clshade.{module}").add_parser(sub, checks)
    return parser


# Modules that add commands: each defines add_parser(sub, checks), where `sub`
# holds the top-level commands and `checks` the `clshade check ...` commands.
EXTENSIONS: tuple[str, ...] = ("compare", "bench.run", "verify.stability", "verify.plausibility")


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
    from clshade.render.image import check_output_path, write_image
    from clshade.models import resolve
    from clshade.pipeline import Timings, prepare_frame, render
    from clshade.render.scene import load_scene

    timings = Timings()
    with timings.stage("load scene"):
        scene = load_scene(args.scene)
    out = Path(args.output) if args.output else Path.cwd() / f"{Path(args.scene).stem}.png"
    protected = scene.inputs()
    check_output_path(out, protected)
    exposure = scene.exposure if args.exposure is None else _exposure(args.exposure)
    model = resolve(_model_spec(args.model, scene.model), args.fresnel, args.workflow)
    frame = prepare_frame(scene, _size(args.width, "width"), _size(args.height, "height"), timings)
    warning = _light_warning(scene, frame.geometry.has_emission)
    if warning:
        print(f"clshade: warning: {warning}", file=sys.stderr)
    result = render(scene, model, device=args.device, half_gbuffer=args.half, fast_math=args.fast_math, frame=frame,
                    general=args.general)
    timings.update(result.timings)
    if args.explain:
        variant = result.shader.variant(model, result.features)
        print(f"model: {model.label} ({model.id}); lobes: {', '.join(l.id for l in model.lobes)}; "
              f"fresnel: {model.fresnel if model.uses_fresnel else 'n/a'}; workflow: {model.workflow}")
        for line in result.features.describe():
            print(f"feature {line}")
        print(f"G-buffer channels: {', '.join(variant.channels)} "
              f"({frame.gbuffer.bytes_per_pixel(variant.channels, result.features.half_gbuffer)} B/pixel read, 16 B written)")
        if frame.shadows is not None:
            print(f"shadow maps: {frame.shadows.count} x {frame.shadows.size}² (lights "
                  f"{', '.join(str(i) for i in frame.scene.shadow_lights)}; directional: orthographic fitted to the "
                  f"scene bounds, spot: perspective), PCF {frame.shadows.pcf}x{frame.shadows.pcf} in the shade kernel")
        for tset in frame.geometry.texture_sets:
            print(f"texture set {tset.describe()}")
        print(f"build options: {' '.join(variant.options()) or '(none)'}")
        simd = result.shader.rt.simd
        print("defines: " + " ".join(f"{k}={v}" for k, v in {"SIMD": str(simd), **variant.defines()}.items()))
        print(f"device: {result.shader.rt.info.description}; {simd} pixel{'s' if simd > 1 else ''} per work-item "
              f"(kernels/simd.h; CLSHADE_SIMD to override)")
    if frame.gbuffer.nonfinite_pixels:
        print(f"clshade: warning: {frame.gbuffer.nonfinite_pixels} pixels had non-finite G-buffer inputs "
              f"(NaN/Inf vertices or normals) and were shaded as background", file=sys.stderr)
    with timings.stage("write"):
        write_image(out, result.image, args.tonemap or scene.tonemap, exposure, protected)
    cam = frame.camera
    print(f"wrote {out} ({cam.width}x{cam.height}, {model.label}, {frame.geometry.triangle_count} triangles, "
          f"{int(frame.gbuffer.coverage.sum())} covered pixels)")
    print(f"stages: {timings.line()}")
    return 0


def cmd_models(args: argparse.Namespace) -> int:
    from clshade.models import GROUPS, lobes, presets
    from clshade.verify.plausibility import physically_based
    try:  # measured on the device with a reduced sweep (`clshade check plausibility` for the full one)
        measured: dict[str, bool] = physically_based()
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
        params = ", ".join(f"{p.name} [{p.low:g}, {p.high:g}] = {p.default:g}" for p in l.params) or "no parameters"
        print(f"  {l.id:24s} {l.kind:8s} {l.family:10s} {l.formula}")
        print(f"  {'':24s} params: {params}")
        print(f"  {'':24s} source: {l.source}")
    return 0


def cmd_devices(args: argparse.Namespace) -> int:
    from clshade.device.runtime import list_devices, select_device
    default, _ = select_device(None)
    for info, device in list_devices():
        mark = "*" if info == default else " "
        print(f"{mark} {info.spec}  {info.kind:10s} {info.device}  |  {info.platform} | {info.platform_version}")
    print("(* = default; choose with --device P:D or CLSHADE_DEVICE)")
    return 0


def _quiet_broken_pipe() -> int:
    """stdout's reader went away (`clshade models | head`): stop quietly. stdout is
    pointed at /dev/null so that the interpreter's final flush does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):   # not a real file (tests replace stdout)
        pass
    return 141   # 128 + SIGPIPE, as a shell reports a process killed by it


def main(argv: list[str] | None = None) -> int:
    try:
        return _main(argv)
    except BrokenPipeError:
        return _quiet_broken_pipe()


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        status = int(args.func(args) or 0)
        sys.stdout.flush()      # a closed pipe shows here, inside the handler, not at exit
        return status
    except ClshadeError as exc:
        if args.debug:
            raise
        print(f"clshade: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("clshade: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

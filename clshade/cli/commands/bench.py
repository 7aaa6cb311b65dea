"""`clshade bench`: frame-time statistics, accuracy and bandwidth floor per model."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from clshade import budget
from clshade.cli.common import check_size, load_scene_with_overrides, progress_bar
from clshade.errors import ClshadeError


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
    check_size(args.width, "width")
    check_size(args.height, "height")
    budget.check_count("--frames", args.frames, budget.MAX_FRAMES, low=1)
    budget.check_count("--warmup", args.warmup, budget.MAX_FRAMES)
    budget.check_count("--numpy-frames", args.numpy_frames, budget.MAX_FRAMES)
    budget.check_count("--whole-frames", args.whole_frames, budget.MAX_FRAMES)
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
    from clshade.outputs import write_text_atomic
    from clshade.pipeline import use_gbuffer
    from clshade.report.bench import bench_csv, bench_plots, bench_text
    _check_bench_options(args)
    scene = load_scene_with_overrides(args.scene, args)
    if scene.environment is not None:
        return _environment_bench(args, scene)
    for flag, value in (("--environment-ladder", args.environment_ladder), ("--oracle-pixels", args.oracle_pixels)):
        if value is not None:
            raise ClshadeError(f"{flag}: {scene.path or 'the scene'} has no [environment] table (the ladder needs a sky)")
    _check_bench_outputs(args, scene.inputs())
    registry = args.registry.with_lobes(*scene.lobes)
    models = registry.resolve_many(args.models)
    with progress_bar("bench", "round") as progress, use_gbuffer(args.gbuffer, args.device) as paths:
        doc = run_bench(scene, models, args.frames, args.warmup, width=args.width,
                        height=args.height, lights=args.lights, ladder=args.ladder, numpy_frames=args.numpy_frames,
                        device=args.device, progress=None if args.no_progress else progress)
    doc["gbuffer"] = [dict(path=p.path, reason=p.reason) for p in paths]
    print(bench_text(doc))
    print(build_line(doc["device"]["build"]))
    for path in paths:
        print(path.line())
    if args.whole_frames:
        doc["whole_frames"] = _whole_frames(args, scene, models)
    if args.peers:
        from clshade.report.perf import perf_markdown
        doc["peers"] = _peers(args, models, registry)
        print()
        print(perf_markdown(doc["peers"]))
    if args.json:
        write_text_atomic(args.json, json.dumps(doc, indent=2, ensure_ascii=False))
    if args.csv:
        bench_csv(doc["models"], Path(args.csv))
    if args.plot:
        bench_plots(doc, Path(args.plot))
    return 0


def _whole_frames(args: argparse.Namespace, scene, models: list) -> dict:
    """`--whole-frames N`: N orbit frames per model through the frame pipeline (clshade.bench.frame),
    printed beside the dispatch tables."""
    from clshade.bench.frame import orbit_bench
    from clshade.device.runtime import get_runtime
    from clshade.report.bench import whole_frame_text
    doc = orbit_bench(scene, models, get_runtime(args.device), args.width, args.height, args.whole_frames,
                      gbuffer=args.gbuffer, overlap=args.overlap)
    print()
    print(whole_frame_text(doc))
    return doc

def _environment_bench(args: argparse.Namespace, scene) -> int:
    """`clshade bench` on a scene with a sky: the environment ladder (clshade.bench.environment) instead of
    the point-light tables; --json writes its document, --plot its error-vs-time plot."""
    import json
    from clshade.bench.environment import SAMPLE_LADDER, parse_samples, run_environment_bench
    from clshade.outputs import write_text_atomic
    from clshade.report.environment import environment_markdown, environment_plot
    from clshade.verify.environment_oracle import DEFAULT_PIXELS
    unsupported = [flag for flag, on in (("--ladder", args.ladder), ("--csv", args.csv), ("--peers", args.peers),
                                         ("--lights", args.lights is not None),
                                         ("--whole-frames", bool(args.whole_frames))) if on]
    if unsupported:
        raise ClshadeError(f"{unsupported[0]}: not measured with an [environment] ({scene.path or 'the scene'}): "
                           "the environment ladder has --json and --plot")
    samples = parse_samples(args.environment_ladder) if args.environment_ladder is not None else SAMPLE_LADDER
    pixels = DEFAULT_PIXELS if args.oracle_pixels is None else budget.check_count(
        "--oracle-pixels", args.oracle_pixels, budget.MAX_FRAMES, low=1)
    _check_bench_outputs(args, scene.inputs())
    models = args.registry.with_lobes(*scene.lobes).resolve_many(args.models)
    with progress_bar("bench", "round") as progress:
        doc = run_environment_bench(scene, models, args.frames, args.warmup, width=args.width, height=args.height,
                                    samples=samples, oracle_pixels=pixels, device=args.device,
                                    progress=None if args.no_progress else progress)
    print(environment_markdown(doc))
    print(build_line(doc["device"]["build"]))
    if args.json:
        write_text_atomic(args.json, json.dumps(doc, indent=2, ensure_ascii=False))
    if args.plot:
        environment_plot([doc], Path(args.plot))
    return 0


def build_line(build: dict) -> str:
    """The build choices the benchmark ran with (the JSON's device.build), in one line."""
    yes = {True: "on", False: "off"}
    forced = f"; forced by {', '.join(build['forced_by'])}" if build["forced_by"] else ""
    return (f"build choices: {build['label']} ({build['source']}{forced}): {build['simd']} lanes, work-group "
            f"{build['local_size']}, inline math {yes[build['inline_math']]}, streaming stores "
            f"{yes[build['streaming_stores']]}, prefetch {yes[build['prefetch']]}"
            + ("; per model family (its kernels build with): "
               + ", ".join(f"{f} {label}" for f, label in build["families"].items())
               + "; the above for other families" if build.get("families") else ""))


def _peers(args: argparse.Namespace, models: list, registry) -> dict:
    """`--peers`: the runtimes, builds and peer implementations on the command's models and registry,
    stamped (printed as Markdown)."""
    from clshade.bench import perf
    from clshade.provenance import stamp
    doc = perf.compare(args.scene, models, args.width, args.height, min(args.frames, 200), args.warmup,
                       tuple(p for p in args.peers.split(",") if p), library=False, registry=registry)
    doc["targets"] = perf.targets(doc)
    doc["command"] = "clshade bench " + " ".join(sys.argv[2:])
    return stamp(doc)

"""`clshade aa`: the anti-aliasing ladder against the float64 pixel integral."""
from __future__ import annotations

import argparse
from pathlib import Path

from clshade import budget
from clshade.cli.common import check_size, refuse_environment
from clshade.errors import ClshadeError


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
    from clshade.pipeline import use_gbuffer
    from clshade.outputs import write_text_atomic
    from clshade.render.scene import load_scene
    from clshade.provenance import stamp
    from clshade.report.aa import aa_markdown, plot_aa
    from clshade.resources import scenes_dir
    scene = args.scene or str(scenes_dir() / "aa_spheres.toml")
    loaded = load_scene(scene, args.registry)
    refuse_environment(loaded, "aa")
    _check_aa_outputs(Path(args.output), loaded.inputs())
    budget.check_count("--frames", args.frames, budget.MAX_FRAMES, low=1)
    budget.check_count("--temporal-frames", args.temporal_frames, budget.MAX_FRAMES)
    if args.frames < 1 or args.truth_samples < 1 or args.check_samples < 0 or args.temporal_frames < 0:
        raise ClshadeError(f"--frames = {args.frames}, --truth-samples = {args.truth_samples}, --check-samples = "
                           f"{args.check_samples}, --temporal-frames = {args.temporal_frames}: need ≥ 1, ≥ 1, ≥ 0, ≥ 0")
    registry = args.registry.with_lobes(*loaded.lobes)
    with use_gbuffer(args.gbuffer, args.device) as paths:
        doc, sheet = run(scene, registry.resolve_many(args.models), width=check_size(args.width, "width"),
                         height=check_size(args.height, "height"), frames=args.frames,
                         truth_samples=args.truth_samples, check_samples=args.check_samples,
                         temporal_frames=args.temporal_frames, device=args.device,
                         registry=registry)
    doc["gbuffer"] = [dict(path=p.path, reason=p.reason) for p in paths]
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
    for path in paths:
        print(path.line())
    return 0

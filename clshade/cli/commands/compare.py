"""`clshade compare`: a contact sheet of several models on one G-buffer."""
from __future__ import annotations

import argparse
from pathlib import Path

from clshade import budget
from clshade.cli.common import load_scene_with_overrides, progress_bar
from clshade.errors import ClshadeError


def cmd_compare(args: argparse.Namespace) -> int:
    from clshade.compare import MAX_TILE, compare_sheet, write_sheet
    from clshade.pipeline import use_gbuffer
    from clshade.render.image import check_output_path
    scene = load_scene_with_overrides(args.scene, args)
    check_output_path(Path(args.output), scene.inputs())
    registry = args.registry.with_lobes(*scene.lobes)
    models = registry.resolve_many(args.models)
    for flag, value, high in (("--tile", args.tile, MAX_TILE), ("--width", args.width, 16384),
                              ("--height", args.height, 16384)):
        if value is not None and not 1 <= value <= high:
            raise ClshadeError(f"{flag} = {value}: must be within [1, {high}]")
    width = args.width or args.tile
    height = args.height or max(1, round(width * scene.camera.height / scene.camera.width))
    reference = registry.resolve(args.reference) if args.reference else None
    budget.sheet_pixels(len(models) + (reference is not None), 1, width, height)
    with progress_bar("compare", "model") as progress, use_gbuffer(args.gbuffer, args.device) as paths:
        sheet, tiles = compare_sheet(scene, models, width=width, height=height, reference=reference,
                                     device=args.device, progress=progress)
    out = write_sheet(args.output, sheet, scene.inputs())
    print(f"wrote {out} ({len(tiles)} models, {width}x{height} tiles)")
    for path in paths:
        print(path.line())
    for t in tiles:
        print(f"  {t.model.label:28s} {t.ms:8.3f} ms/frame")
    return 0

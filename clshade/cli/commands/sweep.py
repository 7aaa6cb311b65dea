"""`clshade sweep`: rows of models, columns of roughness."""
from __future__ import annotations

import argparse
from pathlib import Path

from clshade import budget
from clshade.cli.common import load_scene_with_overrides, progress_bar
from clshade.errors import ClshadeError


def cmd_sweep(args: argparse.Namespace) -> int:
    from clshade.compare import MAX_TILE, sweep_sheet, write_sheet
    from clshade.render.image import check_output_path
    from clshade.resources import scenes_dir
    scene = load_scene_with_overrides(args.scene or scenes_dir() / "red_ball.toml", args)
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
    models = args.registry.with_lobes(*scene.lobes).resolve_many(args.models)
    budget.sheet_pixels(len(models), len(values), args.size, args.size)
    with progress_bar("sweep", "column") as progress:
        sheet = sweep_sheet(scene, models, values, size=args.size, device=args.device, progress=progress)
    out = write_sheet(args.output, sheet, scene.inputs())
    print(f"wrote {out}")
    return 0

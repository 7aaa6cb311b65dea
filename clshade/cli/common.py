"""What the commands share: the progress bar, the scene file with the --samples /
--specular-aa overrides, and the check of a --width / --height."""
from __future__ import annotations

import argparse
import sys
from contextlib import contextmanager

from clshade.errors import ClshadeError


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


def load_scene_with_overrides(path, args: argparse.Namespace):
    """The scene file with the --samples / --specular-aa overrides and, for the commands that have them,
    --environment-diffuse / --environment-specular / --environment-samples."""
    import dataclasses
    from clshade.render.environment import with_overrides
    from clshade.render.samples import with_antialiasing
    from clshade.render.scene import load_scene
    scene = with_antialiasing(load_scene(path, args.registry), args.samples, args.specular_aa)
    sky = with_overrides(scene.environment, getattr(args, "environment_diffuse", None),
                         getattr(args, "environment_specular", None), getattr(args, "environment_samples", None))
    return scene if sky is scene.environment else dataclasses.replace(scene, environment=sky)


def refuse_environment(scene, command: str) -> None:
    """Refuse a scene with an [environment] in a command whose truth does not include the sky yet (bench and
    aa compare with the point-light frame oracle): one line, rather than errors against the wrong truth."""
    if scene.environment is not None:
        name = scene.path or "the scene"
        raise ClshadeError(f"{name}: environment: clshade {command} does not measure environment light yet (its "
                           f"truth is the point-light frame oracle); render and compare shade it, and "
                           f"clshade.verify.environment_oracle measures its error")


def check_size(value: int | None, name: str) -> int | None:
    """--width or --height (`name`) within [1, 16384]; None (the scene's size) passes."""
    if value is not None and not (1 <= value <= 16384):
        raise ClshadeError(f"--{name} = {value}: must be within [1, 16384]")
    return value

"""Helpers of the lobe tests (tests/models/): a BRDF Explorer file written from its shader, and the
samples and directions a lobe is evaluated at on the device (clshade.device.evaluate)."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def write_brdf(folder: Path, name: str, shader: str, params: str = "") -> str:
    """folder/NAME.brdf holding `params` and `shader` (the shader's first line is the file's line 6)."""
    path = folder / f"{name}.brdf"
    path.write_text(f"analytic\n::begin parameters\n{params}\n::end parameters\n::begin shader\n{shader}\n::end shader\n",
                    encoding="utf-8")
    return str(path)


def directions(count: int = 64, seed: int = 3) -> np.ndarray:
    """Unit directions in the upper hemisphere of n = +z (the eval kernel zeroes f below it)."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(count, 3))
    d[:, 2] = np.abs(d[:, 2]) + 0.05
    return (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)


def samples_like(k: int, l: np.ndarray | None = None, n: np.ndarray | None = None):
    """K samples with n = v = +z (or n for all three), l = +z (or the given l), white, r = 0.5."""
    from clshade.device.evaluate import Samples, constant_materials
    up = np.tile(np.array([[0.0, 0.0, 1.0]], np.float32), (k, 1)) if n is None else n
    return Samples(up, up if l is None else l, up, np.ones((k, 3), np.float32), np.full(k, 0.5, np.float32),
                   np.zeros(k, np.float32), constant_materials(k))


def eval_at(model, l: np.ndarray, double: bool = False) -> np.ndarray:
    """f at n = v = +z for the light directions l, in float64."""
    from clshade.device.evaluate import eval_brdf
    return eval_brdf(model, samples_like(len(l), l=l), double=double).astype(np.float64)

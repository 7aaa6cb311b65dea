"""The shading kernels of this checkout against a git ref's (default `main`), A/B in one process:
the ref's kernels/ folder is extracted to a temporary directory and both sets are built on every
PoCL runtime of the machine (the ref at its own SIMD width: 8 on a runtime whose compiler target
lacks AVX-512, unless told otherwise), then each model and its copy kernel are timed in
interleaved rounds (a new random order each round) on the same 1080p G-buffer. Every image is
checked against the first configuration's before anything is timed (≤ 1e-5 relative, covered
pixels), so a speed-up that changed the output stops the run.

Usage::

    python -m benchmarks.experiments.kernel_ab [--base main] [--base-simd-no-avx512 8] [--rounds 150]

Prints a Markdown table (medians and minima of the OpenCL profiling times); writes nothing.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import tarfile
import tempfile
from contextlib import contextmanager
from io import BytesIO
from pathlib import Path

import numpy as np

import clshade.device.variants as variants
from clshade.bench import peers as peer_mod
from clshade.bench.perf import MODELS, cpu_runtimes, settle
from clshade.device.runtime import Runtime
from clshade.device.shade import Shader, scene_features
from clshade.models.registry import Registry
from clshade.pipeline import prepare_frame
from clshade.render.scene import load_scene
from clshade.report.perf import kernel_ab_markdown, short_device

ROOT = Path(__file__).resolve().parents[2]
SAME_IMAGE_RTOL = 1e-5


def extract_kernels(ref: str, into: Path) -> Path:
    """kernels/ of git `ref` under `into`; returns the folder."""
    data = subprocess.run(["git", "archive", ref, "kernels"], cwd=ROOT, check=True, capture_output=True).stdout
    with tarfile.open(fileobj=BytesIO(data)) as tar:
        tar.extractall(into, filter="data")
    return into / "kernels"


@contextmanager
def kernels_from(folder: Path | None):
    """Assemble programs from `folder` (None: this checkout's kernels) inside the block."""
    original = variants.kernels_dir
    if folder is not None:
        variants.kernels_dir = lambda: folder
    try:
        yield
    finally:
        variants.kernels_dir = original


def measure(base_kernels: Path, base_label: str, rounds: int, base_simd_no_avx512: int,
            scene: str = "scenes/sphere_grid.toml", width: int = 1920, height: int = 1080) -> dict:
    """Median and minimum ms of every (runtime, kernels, model, entry) over interleaved rounds."""
    frame = prepare_frame(load_scene(scene), width, height)
    gb, sc, cam = frame.gbuffer, frame.scene, frame.camera
    feats = scene_features(sc, geometry=frame.geometry)
    covered = np.flatnonzero(gb.channels["depth"] > 0)
    configs, reference = [], {}
    for spec in cpu_runtimes():
        rt = Runtime(spec)
        for label, folder in (("this checkout", None), (base_label, base_kernels)):
            simd = rt.simd
            if folder is not None and "avx512" not in rt.info.device:
                simd = base_simd_no_avx512
            os.environ["CLSHADE_SIMD"] = str(simd)
            try:
                with kernels_from(folder):
                    shader = Shader(rt, gb, sc, cam)
                    dispatches = {(m, e): shader.prepare(Registry().resolve(m), feats, entry=e)
                                  for m in MODELS for e in ("shade", "copy")}
                    for m in MODELS:
                        image = shader.render(Registry().resolve(m), feats)
                        reference.setdefault(m, image)
                        diff = peer_mod.verify(image, reference[m], covered)
                        if diff > SAME_IMAGE_RTOL:
                            raise SystemExit(f"{label} on {short_device(rt.info.description)}: {m} differs by {diff:.1e}")
            finally:
                os.environ.pop("CLSHADE_SIMD", None)
            configs.append(dict(runtime=short_device(rt.info.description), kernels=label, simd=simd, shader=shader,
                                dispatches=dispatches, ms={k: [] for k in dispatches}))
    items = [(c, k) for c in configs for k in c["dispatches"]]
    rng = np.random.default_rng(15)
    for r in range(rounds + 5):
        for j in rng.permutation(len(items)):
            c, k = items[j]
            settle()
            ev = c["shader"].enqueue(c["dispatches"][k])
            ev.wait()
            if r >= 5:
                c["ms"][k].append((ev.profile.end - ev.profile.start) * 1e-6)
    return dict(rounds=rounds, scene=scene, width=width, height=height,
                rows=[dict(runtime=c["runtime"], kernels=c["kernels"], simd=c["simd"],
                           median={f"{m}:{e}": float(np.median(v)) for (m, e), v in c["ms"].items()},
                           minimum={f"{m}:{e}": float(np.min(v)) for (m, e), v in c["ms"].items()})
                      for c in configs])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="main", help="git ref whose kernels/ are the B side")
    ap.add_argument("--base-simd-no-avx512", type=int, default=8,
                    help="the B side's SIMD on a runtime whose compiler target lacks AVX-512")
    ap.add_argument("--rounds", type=int, default=150)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        doc = measure(extract_kernels(a.base, Path(tmp)), f"{a.base} kernels", a.rounds, a.base_simd_no_avx512)
    print(kernel_ab_markdown(doc, MODELS))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""clshade's truth under an environment against Mitsuba 3's `envmap` emitter (an independent renderer):
benchmarks/results/mitsuba_envmap.json. JSON only: `python -m benchmarks.publish` renders
benchmarks/results/mitsuba_envmap.md from it.

Two checks per sky, each on the map as clshade prepares it (clshade.render.environment.prepare_spec):
1. Orientation: Mitsuba's emitter evaluated along the direction clshade assigns to every texel centre
   (map_directions, turned by the rotation as Mitsuba's `to_world` rotate about +y), for rotations 0°,
   30° and −75°: the largest relative difference.
2. The integral: irradiance E(n) = ∫ L(l) (n·l)⁺ dl at the normals of the oracle's pixels of
   scenes/environment.toml (environment_oracle.oracle_pixels), by clshade's oracle cells
   (environment_oracle.sky_cells: a sum over texels, exact for the piecewise-constant map but for the
   midpoint rule of the cosine) and by Monte Carlo with Mitsuba's own importance sampling of the emitter
   (`sample_direction`, independent uniform samples): relative RMSE, largest relative difference, and
   the largest |difference| in Mitsuba's standard errors — which should read like noise (≲ 4.5 over a
   few hundred values).
Mitsuba interpolates its map bilinearly, clshade's is piecewise constant: the map handed to Mitsuba is
clshade's upsampled UPSAMPLE× by repetition (the same function to clshade), so that the two differ only
in bands 1/UPSAMPLE of a texel wide.

Needs `pip install mitsuba` (its LLVM backend wants libLLVM ≥ 16: DRJIT_LIBLLVM_PATH, found below
when unset) — not a dependency of clshade.

    python -m benchmarks.measure.mitsuba_envmap [--pixels 64] [--samples-log2 20] && python -m benchmarks.publish
"""
from __future__ import annotations

import argparse
import datetime as _dt
import glob
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.publish.results_io import RESULTS, ROOT, write_result
from clshade.errors import ClshadeError

OUT = RESULTS / "mitsuba_envmap.json"
SCENE = ROOT / "scenes" / "environment.toml"
HDRI = ROOT.parent / "shared" / "assets" / "hdri"
#: Repetitions of each texel, per side, in the map handed to Mitsuba (module docstring); the product
#: with the map's width is capped at MAX_UPSAMPLED_WIDTH (a 4096×2048 float map is 100 MB). On the
#: 128×64 courtyard at 2²⁰ samples, the gap to Mitsuba shrinks about as 1/UPSAMPLE and reaches
#: Mitsuba's Monte Carlo noise at 32 (at 8 it is still twice the noise).
UPSAMPLE = 32
MAX_UPSAMPLED_WIDTH = 4096
#: Oracle cells per texel side for E(n): the cosine over a cell is the midpoint rule's only error.
SUBDIVISIONS = 4
ROTATIONS = (0.0, 30.0, -75.0)
#: Monte Carlo samples per batch (the rest of the samples in later batches): bounds memory (~1 GB).
BATCH = 1 << 22


def _mitsuba():
    """Mitsuba's LLVM variant, or a ClshadeError saying why not."""
    if "DRJIT_LIBLLVM_PATH" not in os.environ:
        found = sorted(glob.glob("/usr/lib/x86_64-linux-gnu/libLLVM.so.1[6-9]*") +
                       glob.glob("/usr/lib/x86_64-linux-gnu/libLLVM-1[6-9]*.so*"))
        if found:
            os.environ["DRJIT_LIBLLVM_PATH"] = found[-1]
    try:
        import mitsuba as mi
        mi.set_variant("llvm_ad_rgb")
    except (ImportError, AttributeError, RuntimeError) as e:
        raise ClshadeError(f"no Mitsuba 3 here ({e}): pip install mitsuba, and libLLVM >= 16") from e
    return mi


def _rows(a) -> np.ndarray:
    """A Dr.Jit 3-vector array as an (N, 3) NumPy array."""
    a = np.asarray(a)
    return a.T if a.shape[0] == 3 and a.ndim == 2 and a.shape[1] != 3 else a


def _emitter(mi, path: Path, rotation: float):
    scene = mi.load_dict({"type": "scene",
                          "sky": {"type": "envmap", "filename": str(path),
                                  "to_world": mi.ScalarTransform4f().rotate([0, 1, 0], rotation)},
                          "ball": {"type": "sphere", "radius": 1.0}})
    return scene.emitters()[0]


def _write_exr(path: Path, pixels: np.ndarray) -> None:
    import OpenImageIO as oiio
    out = oiio.ImageOutput.create(str(path))
    if out is None or not out.open(str(path), oiio.ImageSpec(pixels.shape[1], pixels.shape[0], 3, "float")) \
            or not out.write_image(np.ascontiguousarray(pixels, np.float32)) or not out.close():
        raise ClshadeError(f"{path}: cannot write ({oiio.geterror()})")


def orientation(mi, emitter_for, radiance: np.ndarray) -> dict[str, float]:
    """Largest relative difference between Mitsuba's emitter and clshade's texels, per rotation."""
    import drjit as dr
    from clshade.render import environment as E
    h, w = radiance.shape[:2]
    uu, vv = np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)
    ref = radiance.reshape(-1, 3).astype(np.float64)
    out = {}
    for rot in ROTATIONS:
        d = E.map_directions(uu.ravel(), vv.ravel()) @ E.rotation_matrix(rot).T
        si = dr.zeros(mi.SurfaceInteraction3f, len(d))
        si.wi = mi.Vector3f(*(-d.T.astype(np.float32)))
        got = _rows(emitter_for(rot).eval(si)).astype(np.float64)
        out[f"{rot:g}"] = float(np.max(np.abs(got - ref) / np.maximum(np.abs(ref), 1e-6 * ref.max())))
    return out


def irradiance_ours(env, normals: np.ndarray) -> np.ndarray:
    """(K, 3) E(n) by the oracle's cells (environment_oracle.sky_cells), float64."""
    from clshade.verify import environment_oracle as O
    w, h = env.size
    dirs, omega, texel = O.sky_cells(w, h, SUBDIVISIONS, env.rotation)
    lw = env.radiance.reshape(-1, 3).astype(np.float64)[texel] * omega[:, None]
    out = np.zeros((len(normals), 3))
    step = max(1, (1 << 24) // len(dirs))
    for a in range(0, len(normals), step):
        out[a:a + step] = np.maximum(normals[a:a + step] @ dirs.T, 0.0) @ lw
    return out


def irradiance_mitsuba(mi, emitter, normals: np.ndarray, samples: int, seed: int = 1
                       ) -> tuple[np.ndarray, np.ndarray]:
    """(K, 3) E(n) and its standard error by Mitsuba's emitter sampling, `samples` per normal."""
    import drjit as dr
    rng = np.random.default_rng(seed)
    k = len(normals)
    total, square = np.zeros((k, 3)), np.zeros((k, 3))
    per = max(1, min(samples, BATCH // k))
    done = 0
    while done < samples:
        m = min(per, samples - done)
        it = dr.zeros(mi.Interaction3f, k * m)
        u = rng.random((2, k * m), dtype=np.float32)
        ds, weight = emitter.sample_direction(it, mi.Point2f(u[0], u[1]))
        d, wgt = _rows(ds.d).astype(np.float64), _rows(weight).astype(np.float64)
        cos = np.maximum(np.einsum("ij,ij->i", np.repeat(normals, m, axis=0), d), 0.0)
        x = (wgt * cos[:, None]).reshape(k, m, 3)
        total += x.sum(axis=1)
        square += (x * x).sum(axis=1)
        done += m
    mean = total / samples
    var = np.maximum(square / samples - mean * mean, 0.0)
    return mean, np.sqrt(var / max(samples - 1, 1))


def sunniest(folder: Path) -> Path | None:
    """The shared map whose brightest texel is the most times its mean luminance (a sun: the hard case
    for the integral), or None without maps."""
    from clshade.render import environment as E
    best, ratio = None, 0.0
    for path in sorted(folder.glob("*.exr")) + sorted(folder.glob("*.hdr")):
        lum = E.read_map(path) @ np.asarray(E.LUMINANCE)
        if lum.max() / max(lum.mean(), 1e-30) > ratio:
            best, ratio = path, float(lum.max() / max(lum.mean(), 1e-30))
    return best


def compare_sky(mi, label: str, spec, scene_path: Path, normals: np.ndarray, samples: int) -> dict:
    from clshade.render import environment as E
    env = E.prepare_spec(spec, scene_path)
    radiance = np.asarray(env.radiance, np.float32)
    h, w = radiance.shape[:2]
    k = max(1, min(UPSAMPLE, MAX_UPSAMPLED_WIDTH // w))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "sky.exr"
        _write_exr(path, np.repeat(np.repeat(radiance, k, axis=0), k, axis=1))
        emitters = {}

        def emitter_for(rot: float):
            if rot not in emitters:
                emitters[rot] = _emitter(mi, path, rot)
            return emitters[rot]

        start = time.perf_counter()
        orient = orientation(mi, emitter_for, radiance)
        ours = irradiance_ours(env, normals)
        t_ours = time.perf_counter() - start
        start = time.perf_counter()
        theirs, se = irradiance_mitsuba(mi, emitter_for(env.rotation), normals, samples)
        t_theirs = time.perf_counter() - start
    diff = theirs - ours
    from clshade.render.environment import LUMINANCE
    lum = radiance.reshape(-1, 3).astype(np.float64) @ np.asarray(LUMINANCE)
    return dict(sky=label, size=[w, h], upsample=k, rotation=env.rotation,
                peak_over_mean=float(lum.max() / max(lum.mean(), 1e-30)),
                orientation_max_rel=orient, normals=len(normals), samples=samples,
                rel_rmse=float(np.sqrt(np.sum(diff ** 2) / np.sum(ours ** 2))),
                max_rel=float(np.max(np.abs(diff) / np.maximum(np.abs(ours), 1e-12))),
                median_rel_se=float(np.median(se / np.maximum(np.abs(ours), 1e-12))),
                max_z=float(np.max(np.abs(diff) / np.maximum(se, 1e-30))),
                seconds_ours=round(t_ours, 1), seconds_mitsuba=round(t_theirs, 1))


def measure(pixels: int, samples: int, hdri: Path) -> dict:
    mi = _mitsuba()
    from dataclasses import replace
    from clshade.pipeline import prepare_frame
    from clshade.render.scene import load_scene
    from clshade.verify import environment_oracle as O
    scene = load_scene(SCENE)
    frame = prepare_frame(scene)
    px = O.oracle_pixels(frame.gbuffer, scene.camera, pixels)
    rows = [compare_sky(mi, f"{Path(scene.environment.map).name} ({SCENE.relative_to(ROOT)})", scene.environment,
                        scene.path, px.n, samples)]
    sun = sunniest(hdri) if hdri.is_dir() else None
    if sun is not None:
        rows.append(compare_sky(mi, f"{sun.name} (shared/assets/hdri: the sunniest), turned 30°",
                                replace(scene.environment, map=sun, rotation=30.0), scene.path, px.n, samples))
    skipped = None if sun is not None else f"no maps in {hdri}"
    return dict(schema=1, created=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                mitsuba=mi.__version__, variant=mi.variant(), scene=str(SCENE.relative_to(ROOT)),
                subdivisions=SUBDIVISIONS, rows=rows, skipped=skipped,
                command="python -m benchmarks.measure.mitsuba_envmap")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pixels", type=int, default=64, help="oracle pixels of the scene (their normals)")
    parser.add_argument("--samples-log2", type=int, default=20, help="Mitsuba's samples per normal, log2")
    parser.add_argument("--hdri", type=Path, default=HDRI)
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args()
    start = time.perf_counter()
    doc = measure(args.pixels, 1 << args.samples_log2, args.hdri)
    doc["seconds"] = round(time.perf_counter() - start, 1)
    write_result(args.out, doc)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Evaluate a lighting model's f on the OpenCL device for arrays of directions
and parameters (kernels/eval.cl), with exactly the composition that renders.

Used by the accuracy tests, the plausibility measurements and the stability
grid; the float64 counterpart is clshade.verify.reference.brdf.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from clshade.device import counts
from clshade.errors import ClshadeError
from clshade.models.model import Model
from clshade.device.runtime import Runtime, get_runtime
from clshade.render.scene import GOLD_ETA, GOLD_K
from clshade.device.variants import Features, Variant
from clshade.render.gbuffer import material_row


@dataclass
class Samples:
    """N evaluation points. Directions need not be unit length."""
    n: np.ndarray                 # (N, 3)
    l: np.ndarray                 # (N, 3)
    v: np.ndarray                 # (N, 3)
    base: np.ndarray              # (N, 3)
    roughness: np.ndarray         # (N,)
    metallic: np.ndarray          # (N,)
    materials: np.ndarray         # (N, 4, 4) material constants (gbuffer.material_row)
    tangent: np.ndarray | None = None   # (N, 3) the surface's tangent (the G-buffer's); None: the normal's frame

    def __len__(self) -> int:
        return len(self.n)


def constant_materials(count: int, *, kd: float = 0.7, ks: float = 0.3, ka: float = 1.0,
                       shininess: float | np.ndarray = 32.0, ior: float | np.ndarray = 1.5, f90: float = 1.0,
                       eta=GOLD_ETA, k=GOLD_K) -> np.ndarray:
    """(count, 4, 4) material rows; scalar or per-sample shininess / ior."""
    rows = np.broadcast_to(material_row(dict(kd=kd, ks=ks, ka=ka, shininess=0.0, ior=1.5, f90=f90, eta=eta, k=k)),
                           (count, 4, 4)).copy()
    rows[:, 0, 3] = shininess
    rows[:, 1, 0] = ior
    return rows


def _f4(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, np.float32).reshape(-1, 3)
    return np.ascontiguousarray(np.concatenate([x, np.zeros((len(x), 1), np.float32)], axis=1))


def has_fp64(runtime: Runtime) -> bool:
    """Whether the device computes in double precision (cl_khr_fp64)."""
    return "cl_khr_fp64" in runtime.device.extensions.split()


def eval_brdf(model: Model, samples: Samples, runtime: Runtime | None = None,
              fast_math: bool = False, double: bool = False, horizon: bool = True) -> np.ndarray:
    """f (N, 3) on the device, float32; float64 from the double-precision build of the same
    source with `double` (kernels/simd.h REAL_DOUBLE). Rows whose l is below the horizon are 0,
    unless `horizon` is False: then f as composed there (kernels/eval.cl EVAL_BELOW_HORIZON)."""
    return _eval(model, samples, runtime or get_runtime(), fast_math, double, None, horizon)


def eval_brdf_counted(model: Model, samples: Samples, runtime: Runtime | None = None,
                      fast_math: bool = False) -> tuple[np.ndarray, dict[str, dict[str, int]]]:
    """eval_brdf in the counting build (kernels/count.h, float32), with its term counters."""
    rt = runtime or get_runtime()
    buffer = counts.zeros(rt)
    f = _eval(model, samples, rt, fast_math, False, buffer)
    return f, counts.read(rt, buffer)


def _eval(model: Model, samples: Samples, rt: Runtime, fast_math: bool, double: bool, term_counts,
          horizon: bool = True) -> np.ndarray:
    cl = rt.cl
    if double and not has_fp64(rt):
        raise ClshadeError(f"{rt.info.description} has no double precision (cl_khr_fp64): "
                           f"no float64 build of {model.id}")
    features = Features(fast_math=fast_math, double=double, count_terms=term_counts is not None)
    variant = Variant(model, features, ("depth", "normal", "base"), None)
    options = variant.options() + (() if horizon else ("-DEVAL_BELOW_HORIZON",))
    kernel = rt.kernel(variant.source("eval.cl"), "eval_brdf", options,
                       label=f"{model.id} (eval{', float64' if double else ''})")
    count = len(samples)
    params = np.zeros((count, 4), np.float32)
    params[:, 0] = samples.roughness
    params[:, 1] = samples.metallic
    bufs = [rt.to_device(_f4(a)) for a in (samples.n, samples.l, samples.v, samples.base)]
    bufs.append(rt.to_device(params))
    bufs.append(rt.to_device(np.ascontiguousarray(samples.materials, np.float32).reshape(-1, 4)))
    tangent = samples.tangent if samples.tangent is not None else np.zeros((count, 3), np.float32)
    bufs.append(rt.to_device(_f4(tangent)))
    dtype = np.float64 if double else np.float32
    out = rt.empty(count * 4 * np.dtype(dtype).itemsize)
    kernel.set_args(np.uint32(count), *bufs, out, *([term_counts] if term_counts is not None else []))
    cl.enqueue_nd_range_kernel(rt.queue, kernel, (rt.global_size(count),), (rt.local_size,)).wait()
    result = np.empty((count, 4), dtype)
    cl.enqueue_copy(rt.queue, result, out)
    return result[:, :3]

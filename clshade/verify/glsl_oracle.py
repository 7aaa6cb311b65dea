"""A real GLSL compiler as the oracle of the .brdf translator (clshade.models.glsl).

Mesa's GLSL (llvmpipe: a GLSL 4.30 compute shader, headless through EGL) evaluates a file's
`BRDF(L, V, N, X, Y)` at the directions where clshade's translation is evaluated on the OpenCL
device (clshade.device.evaluate), both in float32, with the same parameter values: the file's
parameters are uniforms on the GLSL side, as in BRDF Explorer, and compiled in on clshade's (a
material-key parameter fixed by `--param`, so both read one value). Needs moderngl and Mesa's EGL
(Debian: libegl1 libegl-mesa0 libgl1-mesa-dri); `unavailable()` says why where they are absent.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Mapping

import numpy as np

from clshade.errors import ClshadeError
from clshade.models.brdf_file import read_source

GLSL_TYPES = {"float": "float", "color": "vec3", "bool": "bool"}
LOCAL_SIZE = 64
# Identifiers of the wrapper start with `oracle_`, a prefix no BRDF Explorer file uses.
_HEAD = f"""#version 430
layout(local_size_x = {LOCAL_SIZE}) in;
layout(std430, binding = 0) readonly buffer OracleIn {{ float oracle_in[]; }};
layout(std430, binding = 1) writeonly buffer OracleOut {{ float oracle_out[]; }};
uniform uint oracle_count;
"""
_MAIN = """
vec3 oracle_vec(uint i, uint k)
{
    uint at = 15u * i + 3u * k;
    return vec3(oracle_in[at], oracle_in[at + 1u], oracle_in[at + 2u]);
}

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= oracle_count)
        return;
    vec3 f = BRDF(oracle_vec(i, 0u), oracle_vec(i, 1u), oracle_vec(i, 2u), oracle_vec(i, 3u), oracle_vec(i, 4u));
    oracle_out[3u * i] = f.x;
    oracle_out[3u * i + 1u] = f.y;
    oracle_out[3u * i + 2u] = f.z;
}
"""


@dataclass(frozen=True)
class Directions:
    """K evaluation points, float32 (K, 3) each: unit L, V, the normal N and the tangent frame X, Y."""
    l: np.ndarray
    v: np.ndarray
    n: np.ndarray
    x: np.ndarray
    y: np.ndarray

    def __len__(self) -> int:
        return len(self.l)


def directions(count: int = 10_000, seed: int = 1) -> Directions:
    """Random frames and directions with the hard cases in fixed shares: grazing L or V
    (n·l or n·v = 1e-3), L = V, V the mirror direction of L, and L below the horizon (n·l < 0)."""
    from clshade.verify.reference.vectors import orthonormal_basis
    rng = np.random.default_rng(seed)
    n = rng.normal(size=(count, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    x, y = orthonormal_basis(n)

    def hemisphere(k: int) -> np.ndarray:
        d = rng.normal(size=(k, 3))
        d[:, 2] = np.abs(d[:, 2])
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    l, v = hemisphere(count), hemisphere(count)
    share = count // 10
    cases = np.arange(count) // share if share else np.zeros(count, int)
    for case, vec in ((0, l), (1, v)):                 # grazing
        rows = cases == case
        vec[rows, 2] = 1e-3
        vec[rows, :2] *= np.sqrt((1 - 1e-6) / np.sum(vec[rows, :2] ** 2, axis=1, keepdims=True))
    v[cases == 2] = l[cases == 2]                      # L = V
    mirror = cases == 3
    v[mirror] = l[mirror] * np.array([-1.0, -1.0, 1.0])
    l[cases == 4, 2] *= -1.0                           # below the horizon
    world = [(d[:, :1] * x + d[:, 1:2] * y + d[:, 2:] * n) for d in (l, v)]
    f32 = [np.ascontiguousarray(a, np.float32) for a in (*world, n, x, y)]
    return Directions(*f32)


@lru_cache(maxsize=1)
def _context():
    import moderngl
    return moderngl.create_standalone_context(backend="egl", require=430)


def unavailable() -> str | None:
    """Why Mesa's GLSL cannot run here, or None where it can."""
    try:
        import moderngl  # noqa: F401
    except ImportError:
        return "moderngl is not installed (pip install moderngl)"
    try:
        _context()
    except Exception as exc:       # moderngl raises plain Exceptions for a missing EGL or GL 4.3
        return f"no GLSL 4.30 context through EGL ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})"
    return None


def compute_shader(path: Path) -> str:
    """The file's shader as a GLSL 4.30 compute shader: its parameters as uniforms, then the shader
    (its lines numbered as in the file), then a main() evaluating BRDF at each point."""
    source = read_source(path)
    declared = set(re.findall(r"\buniform\s+\w+\s+(\w+)\s*;", source.shader))
    uniforms = "".join(f"uniform {GLSL_TYPES[kind]} {name};\n" for kind, name, _, _ in source.params
                       if name not in declared)
    return f"{_HEAD}{uniforms}#line {source.shader_line}\n{source.shader}\n{_MAIN}"


def glsl_values(path: Path, values: Mapping[str, tuple[float, ...]], points: Directions) -> np.ndarray:
    """f (K, 3) float32 from Mesa's GLSL for the file at `path` with its parameters set to `values`."""
    ctx = _context()
    try:
        program = ctx.compute_shader(compute_shader(path))
    except Exception as exc:
        raise ClshadeError(f"{path}: Mesa's GLSL compiler refuses the shader: {' '.join(str(exc).split())}") from None
    for kind, name, default, _ in read_source(path).params:
        if name in program:            # a uniform the shader never reads is optimised away
            value = values.get(name, default)
            program[name].value = bool(value[0]) if kind == "bool" else (tuple(value) if kind == "color" else value[0])
    count = len(points)
    data = np.stack([points.l, points.v, points.n, points.x, points.y], axis=1).astype(np.float32)
    inp = ctx.buffer(data.tobytes())
    out = ctx.buffer(reserve=count * 3 * 4)
    inp.bind_to_storage_buffer(0)
    out.bind_to_storage_buffer(1)
    program["oracle_count"].value = count
    program.run(group_x=(count + LOCAL_SIZE - 1) // LOCAL_SIZE)
    result = np.frombuffer(out.read(), np.float32).reshape(count, 3).copy()
    inp.release()
    out.release()
    program.release()
    return result


def clshade_values(path: Path, values: Mapping[str, tuple[float, ...]], points: Directions,
                   runtime=None) -> np.ndarray:
    """f (K, 3) float32 from clshade's translation on the OpenCL device; every parameter is fixed to
    its value in `values` (else its default). Rows with n·l ≤ 0 are 0 (the eval kernel's horizon)."""
    from clshade.device.evaluate import Samples, constant_materials, eval_brdf
    from clshade.models.registry import Registry
    fixed = {name: (str(int(bool(values.get(name, default)[0]))) if kind == "bool"
                    else ",".join(repr(float(c)) for c in values.get(name, default)))
             for kind, name, default, _ in read_source(path).params}
    model = Registry().with_params(fixed).resolve(str(path))
    k = len(points)
    samples = Samples(points.n, points.l, points.v, np.ones((k, 3), np.float32), np.full(k, 0.5, np.float32),
                      np.zeros(k, np.float32), constant_materials(k), tangent=points.x)
    return eval_brdf(model, samples, runtime)


@dataclass(frozen=True)
class Comparison:
    """clshade's translation against Mesa's GLSL at the points above the horizon."""
    path: Path
    compared: int              # values compared (3 per point with n·l > 0)
    both_finite: int
    finite_mismatch: int       # one side finite, the other not
    max_rel: float             # over the values finite on both sides, |a − b| / max(|b|, tiny)
    median_rel: float


def compare(path: Path, values: Mapping[str, tuple[float, ...]] | None = None, points: Directions | None = None,
            runtime=None) -> Comparison:
    """Both evaluations of one file and how far apart they are."""
    points = points or directions()
    values = values or {}
    want = glsl_values(path, values, points)
    got = clshade_values(path, values, points, runtime)
    above = np.sum(points.n * points.l, axis=1) > 0
    a, b = got[above].ravel().astype(np.float64), want[above].ravel().astype(np.float64)
    fa, fb = np.isfinite(a), np.isfinite(b)
    both = fa & fb
    rel = np.abs(a[both] - b[both]) / np.maximum(np.abs(b[both]), np.finfo(np.float32).tiny)
    return Comparison(path, int(a.size), int(both.sum()), int((fa != fb).sum()),
                      float(rel.max()) if rel.size else 0.0, float(np.median(rel)) if rel.size else 0.0)

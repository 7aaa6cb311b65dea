"""A real GLSL compiler as the oracle of the .brdf translator (clshade.models.glsl).

Mesa's GLSL (llvmpipe: a GLSL 4.30 compute shader, headless through EGL) evaluates a file's
`BRDF(L, V, N, X, Y)` at the directions where clshade's translation is evaluated on the OpenCL
device (clshade.device.evaluate), both in float32, with the same parameter values: the file's
parameters are uniforms on the GLSL side, as in BRDF Explorer, and compiled in on clshade's (a
material-key parameter fixed by `--param`, so both read one value). Needs moderngl and Mesa's EGL
(Debian: libegl1 libegl-mesa0 libgl1-mesa-dri); `unavailable()` says why where they are absent.

Not counted as disagreement, but counted: points where a built-in is called where GLSL leaves it
undefined (UNDEFINED: each call is checked on Mesa's side), points at a singularity (a conditioning
draw finite where the evaluation is not, or the reverse), and differences within the point's float32
conditioning, measured as how far Mesa's f moves when the inputs move by one ulp (`jittered`) and
each built-in's result within the error GLSL 4.30 allows it (ALLOWED): a dot product cancelling at
grazing angles, acos near 1, 1 − e^(−x) for small x.
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
uint oracle_undefined = 0u;     // bit k: the point called UNDEFINED[k] outside its domain
"""
# The built-ins whose result GLSL 4.30 leaves undefined for some arguments (§8.1, §8.2): each call
# is checked by a wrapper, and points where one was undefined are left out of the comparison.
UNDEFINED = {          # name: (arity, GLSL condition on the arguments' components {a}, {b})
    "pow": (2, "{a} < 0.0 || ({a} == 0.0 && {b} <= 0.0)"),
    "log": (1, "{a} <= 0.0"),
    "log2": (1, "{a} <= 0.0"),
    "sqrt": (1, "{a} < 0.0"),
    "inversesqrt": (1, "{a} <= 0.0"),
    "asin": (1, "abs({a}) > 1.0"),
    "acos": (1, "abs({a}) > 1.0"),
    "atan": (2, "{a} == 0.0 && {b} == 0.0"),
}
# Mesa's asin and acos are approximations within ≈2e-4 relative (GLSL gives them no precision),
# 100 times clshade's error, which a steep lobe (exp(−θ²/c²) at c = 0.1) amplifies to 1e-2: on the
# oracle's side they are Cephes' asinf and acosf (S. Moshier; ≤ 2 ulp), from sqrt, + and ×.
_ASIN_ACOS = """
float oracle_asin1(float x)
{
    float a = abs(x);
    bool wide = a > 0.5;
    float z = wide ? 0.5 * (1.0 - a) : a * a;
    float s = wide ? sqrt(z) : a;
    float p = ((((4.2163199048e-2 * z + 2.4181311049e-2) * z + 4.5470025998e-2) * z
                + 7.4953002686e-2) * z + 1.6666752422e-1) * z * s + s;
    return sign(x) * (wide ? 1.5707963267948966 - 2.0 * p : p);
}
float oracle_acos1(float x)
{
    if (x < -0.5)
        return 3.14159265358979323846 - 2.0 * oracle_asin1(sqrt(0.5 * (1.0 + x)));
    if (x > 0.5)
        return 2.0 * oracle_asin1(sqrt(0.5 * (1.0 - x)));
    return 1.5707963267948966 - oracle_asin1(x);
}
"""


# The error GLSL 4.30 allows each built-in (§4.7.1), as (relative, absolute) GLSL expressions of a
# component's arguments x, y; oracle_ulp is float32's relative ulp bound 2^-23. exp and exp2: 3 + 2|x|
# ulp; log and log2: 3 ulp, but 2^-21 absolute inside [0.5, 2]; pow: inherited from
# exp2(y·log2 x); inversesqrt 2 ulp, sqrt inherited from 1/inversesqrt. The others have no
# stated precision and get 2 ulp (a dot product may sum in any order). In the conditioning runs
# (`glsl_values` with allowance 1) each call's result moves by a pseudo-random share of it.
_LOG_REL = "((x < 0.5 || x > 2.0) ? 3.0 * oracle_ulp : 0.0)"
_LOG_ABS = "((x < 0.5 || x > 2.0) ? 0.0 : 4.76837158e-7)"
ALLOWED = {
    "exp": ("(3.0 + 2.0 * abs(x)) * oracle_ulp", "0.0"),
    "exp2": ("(3.0 + 2.0 * abs(x)) * oracle_ulp", "0.0"),
    "log": (_LOG_REL, _LOG_ABS),
    "log2": (_LOG_REL, _LOG_ABS),
    "pow": ("x == 0.0 ? 0.0 : 0.6931472 * abs(y) * ((x < 0.5 || x > 2.0) ? 3.0 * oracle_ulp * abs(log2(x))"
            " : 4.76837158e-7) + (3.0 + 2.0 * abs(y * log2(x))) * oracle_ulp", "0.0"),    # 0^y > 0 is exactly 0
    "inversesqrt": ("2.0 * oracle_ulp", "0.0"),
    "sqrt": ("5.0 * oracle_ulp", "0.0"),
}
ROUNDED = {**{name: arity for name, (arity, _) in UNDEFINED.items()},
           "exp": 1, "exp2": 1, "sin": 1, "cos": 1, "tan": 1,
           "dot": 2, "length": 1, "distance": 2, "normalize": 1}
_VECTOR_ARGS = {"dot", "length", "distance", "normalize"}      # a vector in, moved as a whole
_ROUND = """
const float oracle_ulp = 1.1920929e-7;
uniform float oracle_allowance;  // 0 in the evaluation; 1 in the conditioning runs
uniform uint oracle_seed;
uint oracle_calls = 0u;
float oracle_move(float r, float rel, float ab)
{
    if (oracle_allowance == 0.0)
        return r;
    uint h = gl_GlobalInvocationID.x * 747796405u + (oracle_calls++) * 2891336453u + oracle_seed * 277803737u;
    h ^= h >> 16; h *= 0x7feb352du; h ^= h >> 15; h *= 0x846ca68bu; h ^= h >> 16;
    float u = (float(h >> 8) / 8388608.0 - 1.0) * oracle_allowance;
    return r * (1.0 + u * rel) + u * ab;
}
float oracle_move(float r) { return oracle_move(r, 2.0 * oracle_ulp, 0.0); }
vec2 oracle_move(vec2 r) { return vec2(oracle_move(r.x), oracle_move(r.y)); }
vec3 oracle_move(vec3 r) { return vec3(oracle_move(r.x), oracle_move(r.y), oracle_move(r.z)); }
vec4 oracle_move(vec4 r) { return vec4(oracle_move(r.x), oracle_move(r.y), oracle_move(r.z), oracle_move(r.w)); }
"""


def _wrappers(hidden: set[str]) -> str:
    """GLSL wrappers of the ROUNDED built-ins for float and vec2–vec4 (noting the UNDEFINED ones'
    calls outside their domain, moving results within ALLOWED in the conditioning runs), then
    macros that route the shader's calls through them; a built-in the shader defines itself
    (hiding GLSL's) is left alone."""
    out = [_ROUND, _ASIN_ACOS]
    for name, arity in ROUNDED.items():
        if name in hidden:
            continue
        for n in ((1, 2) if name == "atan" else (arity,)):           # atan(y_over_x) and atan(y, x)
            call = ", ".join("xy"[:n])
            value = f"oracle_{name}1(x)" if name in ("asin", "acos") else f"{name}({call})"
            check = ""
            if name in UNDEFINED and n == UNDEFINED[name][0]:
                bit = 1 << list(UNDEFINED).index(name)
                check = f"if ({UNDEFINED[name][1].format(a='x', b='y')}) oracle_undefined |= {bit}u; "
            rel, ab = ALLOWED.get(name, ("2.0 * oracle_ulp", "0.0"))
            kinds = ("float", "vec2", "vec3", "vec4")
            if name in _VECTOR_ARGS:
                for kind in kinds:
                    result = kind if name == "normalize" else "float"
                    out.append(f"{result} oracle_{name}({', '.join(f'{kind} {v}' for v in 'xy'[:n])}) "
                               f"{{ return oracle_move({name}({call})); }}\n")
                continue
            out.append(f"float oracle_{name}({', '.join(f'float {v}' for v in 'xy'[:n])}) "
                       f"{{ {check}return oracle_move({value}, {rel}, {ab}); }}\n")
            for size, kind in enumerate(kinds[1:], start=2):       # component by component
                parts = ", ".join(f"oracle_{name}({', '.join(f'{v}[{c}]' for v in 'xy'[:n])})" for c in range(size))
                out.append(f"{kind} oracle_{name}({', '.join(f'{kind} {v}' for v in 'xy'[:n])}) "
                           f"{{ return {kind}({parts}); }}\n")
    out += [f"#define {name} oracle_{name}\n" for name in ROUNDED if name not in hidden]
    return "".join(out)
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
    oracle_out[4u * i] = f.x;
    oracle_out[4u * i + 1u] = f.y;
    oracle_out[4u * i + 2u] = f.z;
    oracle_out[4u * i + 3u] = float(oracle_undefined);
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


def jittered(points: Directions, seed: int) -> Directions:
    """The points with every input component moved by about one float32 ulp (a relative step of
    ±2^-23, the sign random): how far Mesa's value moves under it is the float32 conditioning there."""
    rng = np.random.default_rng(seed)
    step = lambda a: (a * (1.0 + rng.choice([-1.0, 1.0], size=a.shape) * 2.0 ** -23)).astype(np.float32)
    return Directions(*(step(a) for a in (points.l, points.v, points.n, points.x, points.y)))


@lru_cache(maxsize=1)
def _context():
    import moderngl
    return moderngl.create_standalone_context(backend="egl", require=430)


def renderer() -> str:
    """The GL renderer and version the oracle runs on (Mesa's llvmpipe here)."""
    ctx = _context()
    return f"{ctx.info['GL_RENDERER']}, {ctx.info['GL_VERSION']}"


def unavailable() -> str | None:
    """Why Mesa's GLSL cannot run here, or None where it can."""
    try:
        import moderngl  # noqa: F401
    except ImportError:
        return "moderngl is not installed (pip install 'clshade[glsl]')"
    try:
        _context()
    except Exception as exc:       # moderngl raises plain Exceptions for a missing EGL or GL 4.3
        return f"no GLSL 4.30 context through EGL ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})"
    return None


def compute_shader(path: Path) -> str:
    """The file's shader as a GLSL 4.30 compute shader: its parameters as uniforms, then the shader
    (its lines numbered as in the file), then a main() evaluating BRDF at each point and noting
    which UNDEFINED built-ins it called outside their domain."""
    source = read_source(path)
    declared = set(re.findall(r"\buniform\s+\w+\s+(\w+)\s*;", source.shader))
    uniforms = "".join(f"uniform {GLSL_TYPES[kind]} {name};\n" for kind, name, _, _ in source.params
                       if name not in declared)
    hidden = set(re.findall(r"\b(?:float|int|bool|vec[234])\s+(\w+)\s*\(", source.shader)) & set(ROUNDED)
    return f"{_HEAD}{uniforms}{_wrappers(hidden)}#line {source.shader_line}\n{source.shader}\n{_MAIN}"


def glsl_values(path: Path, values: Mapping[str, tuple[float, ...]], points: Directions, allowance: float = 0.0,
                seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """f (K, 3) float32 from Mesa's GLSL for the file at `path` with its parameters set to `values`,
    and per point the bits of the UNDEFINED built-ins called outside their domain (K,); allowance
    1 moves each ROUNDED built-in's result by a random share of its ALLOWED error (from `seed`)."""
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
    out = ctx.buffer(reserve=count * 4 * 4)
    inp.bind_to_storage_buffer(0)
    out.bind_to_storage_buffer(1)
    program["oracle_count"].value = count
    for name, value in (("oracle_allowance", allowance), ("oracle_seed", seed)):
        if name in program:
            program[name].value = value
    program.run(group_x=(count + LOCAL_SIZE - 1) // LOCAL_SIZE)
    result = np.frombuffer(out.read(), np.float32).reshape(count, 4).copy()
    inp.release()
    out.release()
    program.release()
    return result[:, :3], result[:, 3].astype(np.uint32)


def clshade_values(path: Path, values: Mapping[str, tuple[float, ...]], points: Directions,
                   runtime=None) -> np.ndarray:
    """f (K, 3) float32 from clshade's translation on the OpenCL device; every parameter is fixed to
    its value in `values` (else its default); below the horizon too (the renderer's cut at n·l ≤ 0
    is left out: the file's BRDF is compared as a function of every direction, as GLSL evaluates it)."""
    from clshade.device.evaluate import Samples, constant_materials, eval_brdf
    from clshade.models.registry import Registry
    fixed = {name: (str(int(bool(values.get(name, default)[0]))) if kind == "bool"
                    else ",".join(repr(float(c)) for c in values.get(name, default)))
             for kind, name, default, _ in read_source(path).params}
    model = Registry().with_params(fixed).resolve(str(path))
    k = len(points)
    samples = Samples(points.n, points.l, points.v, np.ones((k, 3), np.float32), np.full(k, 0.5, np.float32),
                      np.zeros(k, np.float32), constant_materials(k), tangent=points.x)
    return eval_brdf(model, samples, runtime, horizon=False)


# Conditioning (module docstring): the most Mesa's f moves over JITTERS draws (with 4, a third of
# pow(x, 750)'s movement was missed); a difference within CONDITIONING_FACTOR times it is not
# counted, and what exceeds it must stay within TOLERANCE relative.
JITTERS = 8
CONDITIONING_FACTOR = 4.0
TOLERANCE = 1e-5


def parameter_sets(path: Path) -> list[dict[str, tuple[float, ...]]]:
    """The values a file is compared at: its defaults; then every float at a quarter of its range
    with every bool flipped; then every float at three quarters (range ends are left out: a
    parameter at 0 may divide by zero on purpose)."""
    source = read_source(path)
    sets: list[dict[str, tuple[float, ...]]] = [{}]
    for share, flip in ((0.25, True), (0.75, False)):
        values = {}
        for kind, name, default, _ in source.params:
            if kind == "float":
                low, high = source.ranges[name]
                values[name] = (low + share * (high - low),)
            elif kind == "bool" and flip:
                values[name] = (1.0 - default[0],)
        sets.append(values)
    return sets


@dataclass(frozen=True)
class Comparison:
    """clshade's translation against Mesa's GLSL at the points (above and below the horizon) where
    every built-in call of the GLSL side was inside its domain, also one ulp away."""
    path: Path
    compared: int              # values compared (3 per point with nothing undefined)
    below: int                 # points compared with l below the horizon (n·l ≤ 0)
    undefined: int             # points left out: a built-in called outside its domain
    undefined_by: dict         # built-in name -> points where it was (within an ulp of the inputs)
    singular: int              # points left out: a conditioning draw's finiteness differs
    both_finite: int
    finite_mismatch: int       # one side finite, the other not
    peak: float                # max |f| of Mesa's finite values
    max_rel: float             # over values finite on both sides, |a − b| / |b| (|b| ≥ FLT_MIN)
    median_rel: float
    conditioned: int           # values whose difference exceeds TOLERANCE but is float32 conditioning
    max_excess: float          # max of (|a − b| − CONDITIONING_FACTOR·conditioning) / scale, ≥ 0

    @property
    def agrees(self) -> bool:
        return self.finite_mismatch == 0 and self.max_excess <= TOLERANCE


def compare(path: Path, values: Mapping[str, tuple[float, ...]] | None = None, points: Directions | None = None,
            runtime=None) -> Comparison:
    """Both evaluations of one file and how far apart they are."""
    points = points or directions()
    values = values or {}
    want, undefined = glsl_values(path, values, points)
    sens = np.zeros(want.shape)
    singular = np.zeros(len(points), bool)
    for seed in range(JITTERS):
        moved, moved_undefined = glsl_values(path, values, jittered(points, seed + 1), 1.0, seed + 1)
        undefined |= moved_undefined
        singular |= (np.isfinite(moved) != np.isfinite(want)).any(axis=1)
        with np.errstate(invalid="ignore"):
            sens = np.fmax(sens, np.abs(moved.astype(np.float64) - want))
    got = clshade_values(path, values, points, runtime)
    singular &= undefined == 0
    keep = (undefined == 0) & ~singular
    below = int((keep & (np.sum(points.n * points.l, axis=1) <= 0)).sum())
    by = {name: int((undefined & (1 << bit) != 0).sum()) for bit, name in enumerate(UNDEFINED)}
    a, b = got[keep].ravel().astype(np.float64), want[keep].ravel().astype(np.float64)
    fa, fb = np.isfinite(a), np.isfinite(b)
    both = fa & fb
    peak = float(np.abs(b[both]).max()) if both.any() else 0.0
    scale = np.maximum(np.abs(b[both]), float(np.finfo(np.float32).tiny))
    diff = np.abs(a[both] - b[both])
    rel = diff / scale
    excess = np.maximum(diff - CONDITIONING_FACTOR * sens[keep].ravel()[both], 0.0) / scale
    return Comparison(path, int(a.size), below, int((undefined != 0).sum()), {k: v for k, v in by.items() if v},
                      int(singular.sum()), int(both.sum()), int((fa != fb).sum()), peak,
                      float(rel.max()) if rel.size else 0.0, float(np.median(rel)) if rel.size else 0.0,
                      int(((rel > TOLERANCE) & (excess <= TOLERANCE)).sum()),
                      float(excess.max()) if excess.size else 0.0)

"""The .brdf translator (clshade/models/glsl/) fuzzed with generated GLSL (Hypothesis).

Two properties:

- *Every shader gets an answer.* Generated shaders — random typed expression trees, statements,
  helper functions calling each other (recursion included), loops with any bounds and steps,
  #defines, comments, then hostile edits: nesting hundreds deep, huge or malformed literals,
  keywords and clshade's own names as identifiers, stray tokens, cut-off text — either translate to
  OpenCL C no larger than MAX_CODE_BYTES, or are refused with one line `FILE:LINE: …` naming a line
  of the file; never another exception (RecursionError, ValueError …), within a bounded time.
- *Translated code computes what the GLSL says.* Well-typed shaders (float and vec3 expressions of
  L, V (both varying), N, a parameter and literals: arithmetic, built-ins, swizzles, indexing, `?:`, helper
  functions, if/else with assignments and early returns) are built in the double-precision build
  and evaluated on the device at 64 directions; NumPy evaluates the same trees in float64. They agree
  to 1e-12 of each expression's magnitude (the sum of its terms' absolute values), directions where a
  comparison, step() or sign() is too close to call left out.

Profiles (CLSHADE_HYPOTHESIS_PROFILE, as tests/contracts/test_hostile_properties.py): `hostile-ci`
(default: 250 shaders translated, 12 built and evaluated, 30–40 s on 2 shared cores) and
`hostile-long` (ten times as many). The counts are printed at the end of the module.
"""
from __future__ import annotations

import os
import re
import time
from collections import Counter
from dataclasses import dataclass
from typing import Callable

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from clshade.models.glsl.emitter import translate
from clshade.models.glsl.lexer import TranslateError
from clshade.models.glsl.limits import MAX_CODE_BYTES, MAX_NESTING

PROFILES = {"hostile-ci": (250, 12, True), "hostile-long": (2500, 120, False)}    # translated, evaluated, derandomize
PROFILE = os.environ.get("CLSHADE_HYPOTHESIS_PROFILE", "hostile-ci")
if PROFILE not in PROFILES:
    raise pytest.UsageError(f"CLSHADE_HYPOTHESIS_PROFILE={PROFILE!r}: use hostile-ci or hostile-long")
TRANSLATED, EVALUATED, DERANDOMIZE = PROFILES[PROFILE]


def profile(examples: int) -> settings:
    return settings(max_examples=examples, deadline=None, derandomize=DERANDOMIZE, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.filter_too_much])


#: Wall time of translating one generated shader: milliseconds when linear; a quadratic scan or an
#: exponential expansion of the generated sizes takes minutes.
SECONDS_PER_SHADER = 5.0
#: Agreement of the device's float64 build with NumPy's float64, relative to the magnitude of the
#: expression (rounding: a few 1e-16 per operation, for trees of at most ~50 operations).
RTOL = 1e-12
PATH = "fuzz.brdf"
HEAD = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n"
COUNTS: Counter = Counter()


@pytest.fixture(scope="module", autouse=True)
def report_counts():
    yield
    print(f"\nGLSL fuzz ({PROFILE}): " + "; ".join(f"{k}: {n}" for k, n in sorted(COUNTS.items())))


# ---------------------------------------------------------------- typed expressions with a NumPy meaning

@dataclass(frozen=True)
class Expr:
    """A generated GLSL expression: its type ("float" or "vec3"), its text, and its meaning:
    `value(env)` → (value, magnitude) as float64 arrays over the directions; `env["ok"]` is
    cleared where a comparison in it is too close to call."""
    type: str
    text: str
    value: Callable[[dict], tuple[np.ndarray, np.ndarray]]


def _lit(x: float) -> Expr:
    text = repr(float(x))
    return Expr("float", text, lambda env: (np.full(env["n"], float(text)), np.full(env["n"], abs(float(text)))))


def _close(env: dict, gap: np.ndarray, mag: np.ndarray) -> None:
    """Leave out directions where a decision hangs on less than the rounding of its operands."""
    env["ok"] &= np.abs(gap) > 1e-9 * (1.0 + mag)


def _cmp(op: str, a: Expr, b: Expr) -> Callable[[dict], np.ndarray]:
    fn = {"<": np.less, ">": np.greater, "<=": np.less_equal, ">=": np.greater_equal}[op]

    def value(env: dict) -> np.ndarray:
        (x, mx), (y, my) = a.value(env), b.value(env)
        _close(env, x - y, mx + my)
        return fn(x, y)
    return value


@dataclass(frozen=True)
class Scope:
    """The names an expression may read: vec3 arguments (BRDF's L, V, N; a helper's P) and float
    locals; the file's parameter k is read everywhere."""
    vecs: tuple[str, ...] = ("L", "V", "N")
    names: tuple[str, ...] = ()


def _leaf(text: str) -> Expr:
    def value(env: dict):
        if text == "k":
            v = np.full(env["n"], env["k"])
        elif "[" in text:
            v = env[text[0]][:, int(text[2])]
        else:
            v = env[text[0]][:, "xyzrgbstp".index(text[2]) % 3]
        return v, np.abs(v)
    return Expr("float", text, value)


def _locals_leaf(name: str) -> Expr:
    return Expr("float", name, lambda env: env["vars"][name])


@st.composite
def floats(draw, depth: int, scope: Scope = Scope()) -> Expr:
    """A float expression at most `depth` deep over `scope`."""
    if depth <= 0 or draw(st.integers(0, 3)) == 0:
        kind = draw(st.integers(0, 3))
        if kind == 0:
            return _lit(draw(st.sampled_from([0.0, 0.5, 1.0, 2.0, -1.5, 3.25, 0.125])))
        if kind == 1 and scope.names:
            return _locals_leaf(draw(st.sampled_from(scope.names)))
        if kind == 2:
            i = draw(st.integers(0, 4))         # an int literal, converted (GLSL's implicit int → float)
            return Expr("float", str(i), lambda env: (np.full(env["n"], float(i)), np.full(env["n"], float(i))))
        vec = draw(st.sampled_from(scope.vecs))
        return _leaf(draw(st.sampled_from([f"{vec}.x", f"{vec}.y", f"{vec}.z", f"{vec}.r", f"{vec}[2]", f"{vec}.s",
                                           "k"])))
    sub = floats(depth - 1, scope)
    form = draw(st.sampled_from(["neg", "+", "-", "*", "div", "abs", "min", "max", "clamp", "mix", "sin", "cos",
                                 "expneg", "hypot1", "pow", "ternary", "step", "sign", "fdot", "dot", "length",
                                 "comp"]))
    a = draw(sub)
    if form == "neg":
        return Expr("float", f"-{a.text}" if a.text[0] != "-" else f"-({a.text})",
                    lambda env: (lambda v: (-v[0], v[1]))(a.value(env)))
    if form in ("+", "-", "*"):
        b = draw(sub)
        fn = {"+": np.add, "-": np.subtract, "*": np.multiply}[form]

        def arith(env):
            (x, mx), (y, my) = a.value(env), b.value(env)
            return fn(x, y), (mx * my if form == "*" else mx + my)
        return Expr("float", f"({a.text} {form} {b.text})", arith)
    if form == "div":
        b = draw(sub)

        def div(env):
            (x, mx), (y, my) = a.value(env), b.value(env)
            return x / (1.0 + y * y), mx * (1.0 + 2.0 * my * my)
        return Expr("float", f"({a.text} / (1.0 + {b.text} * {b.text}))", div)
    if form in ("abs", "sin", "cos", "expneg", "hypot1"):
        text = {"abs": "abs({})", "sin": "sin({})", "cos": "cos({})", "expneg": "exp(-abs({}))",
                "hypot1": "sqrt(1.0 + {0} * {0})"}[form].format(a.text)
        fn = {"abs": np.abs, "sin": np.sin, "cos": np.cos, "expneg": lambda x: np.exp(-np.abs(x)),
              "hypot1": lambda x: np.sqrt(1.0 + x * x)}[form]
        return Expr("float", text, lambda env: (lambda v: (fn(v[0]), v[1] * (1.0 + v[1]) + 1.0))(a.value(env)))
    if form == "fdot":        # dot of two floats: their product
        b = draw(sub)
        return Expr("float", f"dot({a.text}, {b.text})",
                    lambda env: (lambda u, v: (u[0] * v[0], u[1] * v[1]))(a.value(env), b.value(env)))
    if form in ("min", "max"):
        b = draw(sub)
        fn = np.minimum if form == "min" else np.maximum
        return Expr("float", f"{form}({a.text}, {b.text})",
                    lambda env: (lambda u, v: (fn(u[0], v[0]), u[1] + v[1]))(a.value(env), b.value(env)))
    if form == "clamp":
        return Expr("float", f"clamp({a.text}, -0.75, 1.5)",
                    lambda env: (lambda v: (np.clip(v[0], -0.75, 1.5), v[1]))(a.value(env)))
    if form == "mix":
        b, t = draw(sub), draw(sub)

        def mix(env):
            (x, mx), (y, my), (w, mw) = a.value(env), b.value(env), t.value(env)
            return x + (y - x) * w, mx + (mx + my) * (1.0 + mw)
        return Expr("float", f"mix({a.text}, {b.text}, {t.text})", mix)
    if form == "pow":
        p = draw(st.sampled_from(["1.0", "2.0", "3.0", "4.0", "5.0", "0.5", "2.5"]))

        def power(env):
            x, mx = a.value(env)
            base, e = np.abs(x) + 1.0, float(p)
            return base ** e, (mx + 1.0) ** max(e, 1.0) * (1.0 + e)
        return Expr("float", f"pow(abs({a.text}) + 1.0, {p})", power)
    if form == "ternary":
        b = draw(sub)
        text, cond = draw(conditions(depth - 1, scope))

        def select(env):
            pick = cond(env)
            (x, mx), (y, my) = a.value(env), b.value(env)
            return np.where(pick, x, y), np.maximum(mx, my)
        return Expr("float", f"({text} ? {a.text} : {b.text})", select)
    if form in ("step", "sign"):
        b = draw(sub)

        def jump(env):
            (x, mx), (y, my) = a.value(env), b.value(env)
            if form == "step":
                _close(env, y - x, mx + my)
                return (y >= x).astype(float), np.ones(env["n"])
            _close(env, x, mx)
            return np.sign(x), np.ones(env["n"])
        return Expr("float", f"step({a.text}, {b.text})" if form == "step" else f"sign({a.text})", jump)
    v = draw(vectors(depth - 1, scope))
    if form == "dot":
        w = draw(vectors(depth - 1, scope))
        return Expr("float", f"dot({v.text}, {w.text})",
                    lambda env: (lambda p, q: (np.sum(p[0] * q[0], axis=1), np.sum(p[1] * q[1], axis=1)))(
                        v.value(env), w.value(env)))
    if form == "length":
        return Expr("float", f"length({v.text})",
                    lambda env: (lambda p: (np.linalg.norm(p[0], axis=1), np.sum(p[1], axis=1)))(v.value(env)))
    i = draw(st.integers(0, 2))
    suffix = draw(st.sampled_from([f".{'xyz'[i]}", f".{'rgb'[i]}", f"[{i}]", f"[{i} + 0]"]))
    return Expr("float", f"{v.text}{suffix}", lambda env: (lambda p: (p[0][:, i], p[1][:, i]))(v.value(env)))


@st.composite
def conditions(draw, depth: int, scope: Scope) -> tuple[str, Callable[[dict], np.ndarray]]:
    """A comparison that differs between directions: a component of L, V or P, moved by at most
    ±0.25 by a generated expression, against a threshold. (text, mask of where it holds)."""
    c = draw(floats(depth, scope))
    vec = draw(st.sampled_from([v for v in scope.vecs if v != "N"]))
    i = draw(st.integers(0, 2))
    threshold = _lit(draw(st.sampled_from([-0.3, 0.0, 0.2, 0.5])))

    def lhs(env: dict) -> tuple[np.ndarray, np.ndarray]:
        x, mx = c.value(env)
        return env[vec][:, i] + 0.25 * np.sin(x), np.abs(env[vec][:, i]) + 0.25 * (1.0 + mx)
    op = draw(st.sampled_from(["<", ">", "<=", ">="]))
    text = f"{vec}.{'xyz'[i]} + 0.25 * sin({c.text}) {op} {threshold.text}"
    return text, _cmp(op, Expr("float", "", lhs), threshold)


SWIZZLES = ["zyx", "yzx", "xxy", "bgr", "zzz", "xyz"]


@st.composite
def vectors(draw, depth: int, scope: Scope = Scope()) -> Expr:
    """A vec3 expression at most `depth` deep over `scope`."""
    if depth <= 0 or draw(st.integers(0, 3)) == 0:
        name = draw(st.sampled_from(scope.vecs))
        return Expr("vec3", name, lambda env: (env[name], np.abs(env[name])))
    sub, fsub = vectors(depth - 1, scope), floats(depth - 1, scope)
    form = draw(st.sampled_from(["ctor", "splat", "+", "-", "*", "scale", "neg", "abs", "min", "mix", "cross",
                                 "swizzle", "from2", "ternary", "normalize", "reflect"]))
    if form == "ctor":
        a, b, c = draw(fsub), draw(fsub), draw(fsub)
        return Expr("vec3", f"vec3({a.text}, {b.text}, {c.text})",
                    lambda env: tuple(np.stack(z, axis=1) for z in zip(a.value(env), b.value(env), c.value(env))))
    if form == "splat":
        a = draw(fsub)
        return Expr("vec3", f"vec3({a.text})",
                    lambda env: tuple(np.repeat(z[:, None], 3, axis=1) for z in a.value(env)))
    v = draw(sub)
    if form in ("+", "-", "*", "min"):
        w = draw(sub)
        fn = {"+": np.add, "-": np.subtract, "*": np.multiply, "min": np.minimum}[form]
        text = f"min({v.text}, {w.text})" if form == "min" else f"({v.text} {form} {w.text})"
        return Expr("vec3", text, lambda env: (lambda p, q: (fn(p[0], q[0]), p[1] * q[1] if form == "*" else
                                                             p[1] + q[1]))(v.value(env), w.value(env)))
    if form == "scale":
        a = draw(fsub)
        left = draw(st.booleans())
        return Expr("vec3", f"({a.text} * {v.text})" if left else f"({v.text} * {a.text})",
                    lambda env: (lambda p, s: (p[0] * s[0][:, None], p[1] * s[1][:, None]))(v.value(env), a.value(env)))
    if form == "neg":
        return Expr("vec3", f"-{v.text}" if v.text[0] != "-" else f"-({v.text})",
                    lambda env: (lambda p: (-p[0], p[1]))(v.value(env)))
    if form == "abs":
        return Expr("vec3", f"abs({v.text})", lambda env: (lambda p: (np.abs(p[0]), p[1]))(v.value(env)))
    if form == "mix":
        w, t = draw(sub), draw(fsub)
        return Expr("vec3", f"mix({v.text}, {w.text}, {t.text})",
                    lambda env: (lambda p, q, s: (p[0] + (q[0] - p[0]) * s[0][:, None],
                                                  p[1] + (p[1] + q[1]) * (1.0 + s[1][:, None])))(
                        v.value(env), w.value(env), t.value(env)))
    if form == "cross":
        w = draw(sub)
        return Expr("vec3", f"cross({v.text}, {w.text})",
                    lambda env: (lambda p, q: (np.cross(p[0], q[0]), 2.0 * np.sum(p[1], axis=1)[:, None] *
                                               np.sum(q[1], axis=1)[:, None] * np.ones((1, 3))))(
                        v.value(env), w.value(env)))
    if form == "swizzle":
        sw = draw(st.sampled_from(SWIZZLES))
        idx = ["xyzrgb".index(c) % 3 for c in sw]
        return Expr("vec3", f"{v.text}.{sw}", lambda env: (lambda p: (p[0][:, idx], p[1][:, idx]))(v.value(env)))
    if form == "from2":
        a = draw(fsub)
        return Expr("vec3", f"vec3({v.text}.zx, {a.text})",
                    lambda env: (lambda p, s: (np.column_stack([p[0][:, 2], p[0][:, 0], s[0]]),
                                               np.column_stack([p[1][:, 2], p[1][:, 0], s[1]])))(
                        v.value(env), a.value(env)))
    if form == "ternary":
        w = draw(sub)
        text, cond = draw(conditions(depth - 1, scope))

        def select(env):
            pick = cond(env)[:, None]
            (x, mx), (y, my) = v.value(env), w.value(env)
            return np.where(pick, x, y), np.maximum(mx, my)
        return Expr("vec3", f"({text} ? {v.text} : {w.text})", select)
    if form == "normalize":      # of a vector of length >= 1: no singularity
        def unit(env):
            x, mx = v.value(env)
            u = 1.0 + np.abs(x)
            return u / np.linalg.norm(u, axis=1, keepdims=True), (1.0 + mx) * 2.0
        return Expr("vec3", f"normalize(vec3(1.0) + abs({v.text}))", unit)
    return Expr("vec3", f"reflect({v.text}, vec3(0.0, 0.0, 1.0))",
                lambda env: (lambda p: (p[0] * np.array([1.0, 1.0, -1.0]), p[1]))(v.value(env)))


# ---------------------------------------------------------------- statements: if-conversion and early returns

@st.composite
def shaders(draw, depth: int = 3) -> tuple[str, Callable[[dict], tuple[np.ndarray, np.ndarray]]]:
    """A shader (a helper function and BRDF with locals, if/else, assignments, early returns) and
    its meaning: env → (f, magnitude), each (n, 3)."""
    helper_body = draw(floats(depth, Scope(("P",), ("a",))))
    lines = [f"float helper(float a, vec3 P) {{ return {helper_body.text}; }}", HEAD + "{"]
    names: list[str] = []
    program: list[Callable[[dict], None]] = []

    def call(arg: Expr) -> Expr:
        return Expr("float", f"helper({arg.text}, L)",
                    lambda env: helper_body.value({**env, "P": env["L"], "vars": {"a": arg.value(env)}}))

    def assign(name: str, e: Expr, op: str, mask: Callable[[dict], np.ndarray]) -> Callable[[dict], None]:
        def run(env):
            p = mask(env) & ~env["done"]
            old, mold = env["vars"][name]
            new, mnew = e.value(env)
            if op == "+=":
                new, mnew = old + new, mold + mnew
            elif op == "*=":
                new, mnew = old * new, mold * mnew
            env["vars"][name] = (np.where(p, new, old), np.maximum(mold, mnew))
        return run

    def ret(v: Expr, mask: Callable[[dict], np.ndarray]) -> Callable[[dict], None]:
        def run(env):
            p = mask(env) & ~env["done"]
            x, mx = v.value(env)
            env["f"] = np.where(p[:, None], x, env["f"])
            env["mag"] = np.maximum(env["mag"], mx)
            env["done"] = env["done"] | p
        return run

    every = lambda env: np.ones(env["n"], bool)      # noqa: E731
    for k in range(draw(st.integers(1, 3))):
        e = draw(floats(depth, Scope(names=tuple(names))))
        if draw(st.booleans()):
            e = call(e)
        lines.append(f"    float t{k} = {e.text};")
        name = f"t{k}"
        program.append(lambda env, name=name, e=e: env["vars"].__setitem__(name, e.value(env)))
        names.append(name)
    for branch in range(draw(st.integers(0, 3))):
        here = Scope(names=tuple(names))
        text, cond = draw(conditions(depth - 1, here))
        # The condition is evaluated once, where the if is (as the translation's mask).
        program.append(lambda env, key=branch, cond=cond: env["masks"].__setitem__(key, cond(env)))
        then_mask = lambda env, key=branch: env["masks"][key]      # noqa: E731
        else_mask = lambda env, key=branch: ~env["masks"][key]     # noqa: E731
        lines.append(f"    if ({text}) {{")
        for mask, end in ((then_mask, "    } else {"), (else_mask, "    }")):
            for _ in range(draw(st.integers(0, 2))):
                if draw(st.integers(0, 4)) == 0:
                    v = draw(vectors(depth - 1, here))
                    lines.append(f"        return {v.text};")
                    program.append(ret(v, mask))
                else:
                    name, op = draw(st.sampled_from(names)), draw(st.sampled_from(["=", "+=", "*="]))
                    e = draw(floats(depth - 1, here))
                    lines.append(f"        {name} {op} {e.text};")
                    program.append(assign(name, e, op, mask))
            lines.append(end)
    here = Scope(names=tuple(names))
    final = draw(st.one_of(vectors(depth, here),
                           st.tuples(*(floats(depth, here),) * 3).map(
                               lambda abc: Expr("vec3", f"vec3({', '.join(x.text for x in abc)})",
                                                lambda env: tuple(np.stack(z, axis=1) for z in
                                                                  zip(*(x.value(env) for x in abc)))))))
    lines += [f"    return {final.text};", "}"]
    program.append(ret(final, every))

    def meaning(env: dict) -> tuple[np.ndarray, np.ndarray]:
        env.update(vars={}, masks={}, done=np.zeros(env["n"], bool), f=np.zeros((env["n"], 3)),
                   mag=np.zeros((env["n"], 3)))
        for step in program:
            step(env)
        return env["f"], env["mag"]
    return "\n".join(lines), meaning


# ---------------------------------------------------------------- hostile edits

WORDS = ["float", "int", "vec3", "vec4", "mat3", "while", "do", "break", "struct", "out", "inout", "uniform",
         "return", "if", "else", "for", "const", "void", "true", "false", "discard", "precision", "BRDF", "main",
         "s", "real", "mask", "G_LIT", "Surface", "v3", "x_ret", "x_done", "x_if1", "u_f_BRDF", "u_p_k", "x_sw3_zyx",
         "specular_lobe", "k", "L", "texture2D", "dFdx", "helper", "__x", "gl_FragColor", "a" * 300]
PUNCT = ["(", ")", "{", "}", "[", "]", ";", ",", ".", "?", ":", "=", "+=", "++", "--", "-", "+", "*", "/", "%", "<",
         "<=", "==", "!=", "&&", "||", "^^", "!", "&", "|", "^", "~", "<<", "#", "@", "$", "\\", "'", '"', "`"]
LITERALS = ["0", "00", "007", "2147483647", "2147483648", "4294967296", "9" * 70, "1" * 5000, "1.", ".5", "1e38",
            "3.4028235e38", "1e39", "1e309", "1e-320", "1e+", "0x1F", "1.0f", "1.0F", "1.5e", "1e99999", "0.0e0"]
NESTERS = {"(": ("(", ")"), "-": ("-", ""), "!": ("!", ""), "abs": ("abs(", ")"), "vec3": ("vec3(", ")"),
           ".x": ("", ".x"), ".zyx": ("", ".zyx"), "[0]": ("", "[0]"), "+": ("1.0 + ", ""), "* (": ("L.x * (", ")"),
           "?:": ("L.x > 0.0 ? 1.0 : ", ""), "{": ("{", "}"), "if": ("if (L.x > 0.0) ", "")}


@st.composite
def hostile_shaders(draw) -> str:
    """A generated shader, then up to four hostile edits."""
    text, _ = draw(shaders(depth=draw(st.integers(0, 3))))
    for _ in range(draw(st.integers(0, 4))):
        edit = draw(st.sampled_from(["token", "nest", "cut", "loop", "calls", "define", "comment", "literal"]))
        at = draw(st.integers(0, len(text)))
        if edit == "token":
            piece = draw(st.sampled_from(WORDS + PUNCT + LITERALS))
            text = text[:at] + f" {piece} " + text[at:]
        elif edit == "literal":
            text = re.sub(r"\b\d+\.\d+\b", lambda m: draw(st.sampled_from(LITERALS)), text, count=1)
        elif edit == "nest":
            opener, closer = NESTERS[draw(st.sampled_from(sorted(NESTERS)))]
            n = draw(st.sampled_from([1, 2, MAX_NESTING - 8, MAX_NESTING - 1, MAX_NESTING, MAX_NESTING + 1, 200, 2000]))
            text = text.replace("return ", "return " + opener * n, 1)
            text = text.replace(";", closer * n + ";", text.count(";") and 1) if closer else text
        elif edit == "cut":
            text = text[:at]
        elif edit == "loop":
            start, bound, step = (draw(st.sampled_from([0, 1, -5, 10, 4096, 2147483647, -2147483647, 3000]))
                                  for _ in range(3))
            op = draw(st.sampled_from(["<", "<=", ">", ">=", "!=", "=="]))
            inc = draw(st.sampled_from([f"i += {step}", f"i -= {step}", "i++", "i--", f"i = i + {step}", "i *= 2"]))
            loop = f"    for (int i = {start}; i {op} {bound}; {inc}) {{ t0 += 1.0; }}\n"
            text = text.replace("    return", loop + "    return", 1)
        elif edit == "calls":
            n = draw(st.integers(2, 6))
            edges = draw(st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=8))
            protos = "".join(f"float g{i}(float x);\n" for i in range(n))
            bodies = "".join(f"float g{i}(float x) {{ return x" +
                             "".join(f" + g{b}(x)" for a, b in edges if a == i) + "; }\n" for i in range(n))
            text = protos + bodies + text.replace("return ", "return g0(1.0) * ", 1)
        elif edit == "define":
            n = draw(st.integers(1, 14))
            width = draw(st.integers(1, 5))
            defines = "".join(f"#define D{i + 1} {' '.join([f'D{i}'] * width)}\n" for i in range(n))
            text = defines + "#define D0 + 1.0\n" + text.replace("return ", "return 0.0 D" + str(n) + " + ", 1)
        else:
            comment = draw(st.sampled_from(["/* a */", "/* a\n b */", "// a\n", "/*", "/* " * 5000, "*/", "/**/"]))
            text = text[:at] + comment + text[at:]
    return text


# ---------------------------------------------------------------- the properties

@profile(TRANSLATED)
@given(text=hostile_shaders())
def test_every_generated_shader_translates_or_is_refused_in_one_line(text):
    start = time.perf_counter()
    try:
        code = translate(text, PATH, {"k": ("float", "G_LIT(0.5)")}).code
        COUNTS["translated"] += 1
        assert len(code) <= MAX_CODE_BYTES + 4096, len(code)    # + the parameters' #defines and prototypes
    except TranslateError as err:
        COUNTS["refused"] += 1
        message = str(err)
        m = re.match(rf"{re.escape(PATH)}:(\d+): \S", message)
        assert m and "\n" not in message, message
        assert 1 <= int(m.group(1)) <= text.count("\n") + 1, message
    assert time.perf_counter() - start < SECONDS_PER_SHADER


@pytest.fixture(scope="module")
def fp64(runtime):
    from clshade.device.evaluate import has_fp64
    if not has_fp64(runtime):
        pytest.skip(f"{runtime.info.description} has no double precision: the translated code is compared in float64")
    return runtime


DIRECTIONS = 256


def _directions(seed: int) -> np.ndarray:
    """Unit directions above the horizon of n = +z (the eval kernel zeroes f below it), float32."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(DIRECTIONS, 3))
    d[:, 2] = np.abs(d[:, 2]) + 0.05
    return (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)


@profile(EVALUATED)
@given(shader=shaders(), k=st.sampled_from([0.25, 0.5, 0.75]))
def test_translated_shaders_compute_what_the_glsl_says(fp64, tmp_path_factory, shader, k):
    from clshade.device.evaluate import Samples, constant_materials, eval_brdf
    from clshade.models.registry import Registry
    text, meaning = shader
    folder = tmp_path_factory.mktemp("fuzz")
    path = folder / "fuzz.brdf"
    path.write_text(f"analytic\n::begin parameters\nfloat k 0 1 {k}\n::end parameters\n::begin shader\n{text}\n"
                    f"::end shader\n", encoding="utf-8")
    model = Registry().resolve(str(path))
    l32, v32 = _directions(11), _directions(12)
    up = np.tile(np.array([[0.0, 0.0, 1.0]], np.float32), (DIRECTIONS, 1))
    samples = Samples(up, l32, v32, np.ones((DIRECTIONS, 3), np.float32), np.full(DIRECTIONS, 0.5, np.float32),
                      np.zeros(DIRECTIONS, np.float32), constant_materials(DIRECTIONS))
    got = eval_brdf(model, samples, double=True).astype(np.float64)
    l, v = (d.astype(np.float64) / np.linalg.norm(d.astype(np.float64), axis=1, keepdims=True)    # as the kernel
            for d in (l32, v32))
    env = {"n": DIRECTIONS, "L": l, "V": v, "N": up.astype(np.float64), "k": k, "ok": np.ones(DIRECTIONS, bool)}
    want, mag = meaning(env)
    ok = env["ok"]
    COUNTS["evaluated"] += 1
    COUNTS["directions compared"] += int(ok.sum())      # none where a decision is a tie everywhere (0.0 < 0.0)
    err = np.abs(got - want)[ok]
    assert (err <= RTOL * (1.0 + mag[ok])).all(), (text, float((err / (1.0 + mag[ok])).max()))

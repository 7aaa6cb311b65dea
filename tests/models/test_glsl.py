"""The GLSL translator (clshade/models/glsl/: lexer, parser, emitter) that turns a BRDF Explorer shader
into an OpenCL lobe: translated expressions and control flow evaluate as GLSL defines them, lane by lane
(checked on the device against the same formulas in NumPy); the translation reports which of X and Y the
shader reads; an unsupported or malformed shader is refused naming the file and its line."""
from __future__ import annotations

import numpy as np
import pytest

from clshade.errors import ClshadeError
from clshade.models.registry import Registry

from lobe_helpers import directions, eval_at, write_brdf

BUILT_IN = Registry()          # the built-in lobes


EXPRESSIONS = """
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{
    float a = L.x;
    float b = L.y;
    float c = L.z;
    float p = a + b * c - a / 2 * b + float(7 / 2);   // precedence; int-to-float; int division
    vec3 s = L.zyx;
    float t = s[0] * 10.0 + s.g - L.rgb.b + pow(c, 3.0);   // swizzles, constant indexing; x³ as products
    return vec3(p, t, -a * -b + (a > b ? 1 : 2) + pow(c, 2.5));   // ?: with int branches
}
"""

CONTROL = """
float helper(float x);      // a prototype: defined after BRDF, as GLSL allows

vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{
    float x = abs(L.x);
    float acc = 0.0;
    for (int i = 0; i < 3; i++)
        acc += x;
    if (x < 0.2) {
        acc = -1.0;
    } else if (x < 0.4)
        acc = -2.0;
    if (L.y > 0.6)
        return vec3(7.0);
    return vec3(acc, helper(x), mix(1.0, 3.0, x) + sin(x) + exp(-x) + log(1.0 + x) + atan(L.y, x));
}

float helper(float x)
{
    if (x > 0.5)
        return 2.0 * x;
    return x * x;
}
"""


def test_translated_expressions_follow_glsl(tmp_path, runtime):
    model = BUILT_IN.resolve(write_brdf(tmp_path, "expressions", EXPRESSIONS))
    l = directions()
    f = eval_at(model, l)
    a, b, c = (l[:, i].astype(np.float64) for i in range(3))
    want = np.stack([a + b * c - a / 2 * b + 3.0, c * 10.0 + b - c + c ** 3,
                     a * b + np.where(a > b, 1.0, 2.0) + c ** 2.5], axis=1)
    np.testing.assert_allclose(f, want, rtol=1e-5, atol=1e-6)


def test_translated_control_flow_is_per_pixel(tmp_path, runtime):
    """if/else, an early return and a helper with two returns act lane by lane, loops run their count."""
    model = BUILT_IN.resolve(write_brdf(tmp_path, "control", CONTROL))
    l = directions(256)
    f = eval_at(model, l)
    x, y = np.abs(l[:, 0].astype(np.float64)), l[:, 1].astype(np.float64)
    acc = np.where(x < 0.2, -1.0, np.where(x < 0.4, -2.0, 3.0 * x))
    want = np.stack([acc, np.where(x > 0.5, 2.0 * x, x * x),
                     1.0 + 2.0 * x + np.sin(x) + np.exp(-x) + np.log1p(x) + np.arctan2(y, x)], axis=1)
    want[y > 0.6] = 7.0
    assert (y > 0.6).any() and (x < 0.2).any() and ((x > 0.2) & (x < 0.4)).any() and (x > 0.5).any()
    np.testing.assert_allclose(f, want, rtol=1e-5, atol=1e-6)


def test_translation_reports_what_brdf_reads():
    """clshade.models.glsl.emitter.translate: X/Y read through a helper count; a parameter of the file is a #define."""
    from clshade.models.glsl.emitter import translate
    shader = ("float aniso(vec3 t) { return t.x; }\n"
              "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(aniso(Y)) * k; }")
    tr = translate(shader, "t.brdf", {"k": ("float", "G_LIT(2.0)")})
    assert tr.reads == {"Y"} and "#define u_p_k G_LIT(2.0)" in tr.code


FIXED_BOOLS = """
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{
    float x = abs(L.x);
    float a = on ? x : 2.0 * x;
    float b = (!on && x > 0.3) ? 5.0 : 1.0;
    float c = (false || on) ? 10.0 : 20.0;
    if (on)
        c += 1.0;
    else if (x > 0.5)
        c -= 1.0;
    c += (on ^^ x > 0.4) ? 100.0 : 0.0;
    c += (x > 0.4 ^^ x > 0.6) ? 1000.0 : 0.0;
    if (!on)
        return vec3(a, b, c + dot(X, L) * 0.0);
    return vec3(a, b, c);
}
"""


@pytest.mark.parametrize("on", [0, 1])
def test_bool_parameters_fix_branches(tmp_path, runtime, on):
    """A bool parameter is compiled in: ?:, if/else, !, &&, || and ^^ on it take the branch its value
    chooses, lane by lane as before; the branch left out is not in the kernel and what only it reads
    (X here) is not read."""
    from clshade.models.glsl.emitter import translate
    path = write_brdf(tmp_path, "fixed", FIXED_BOOLS, "bool on 0")
    model = BUILT_IN.with_params({"on": str(on)}).resolve(path)
    l = directions(256)
    x = np.abs(l[:, 0].astype(np.float64))
    band = np.where((x > 0.4) != (x > 0.6), 1000.0, 0.0)
    want = (np.stack([x, np.ones_like(x), 11.0 + np.where(x > 0.4, 0.0, 100.0) + band], axis=1) if on else
            np.stack([2 * x, np.where(x > 0.3, 5.0, 1.0),
                      np.where(x > 0.5, 19.0, 20.0) + np.where(x > 0.4, 100.0, 0.0) + band], axis=1))
    assert (x > 0.5).any() and (x < 0.3).any() and ((x > 0.4) & (x < 0.6)).any() and (x > 0.6).any()
    np.testing.assert_allclose(eval_at(model, l), want, rtol=1e-6)
    reads = translate(FIXED_BOOLS, "fixed.brdf", {"on": ("bool", "G_TRUE" if on else "G_FALSE")}).reads
    assert reads == ({"L"} if on else {"L", "X"})


@pytest.mark.parametrize("shader, line, message", [
    ("vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{\n    return vec3(1.0) +;\n}", 8, "syntax error"),
    ("vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{\n    return vec3(frobnicate(L.x));\n}", 8,
     "unknown function 'frobnicate'"),
    ("vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{\n    vec4 c = vec4(1.0);\n    return c.rgb;\n}", 8,
     "unsupported construct: type vec4"),
    ("vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{\n    while (true) { }\n    return L;\n}", 8,
     "unsupported construct: while loop"),
    ("float f(out float x) { x = 1.0; return x; }\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return L; }",
     6, "unsupported construct: out parameter"),
    ("vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{\n    return L * nope;\n}", 8, "unknown name 'nope'"),
    ("vec3 shade(vec3 L) { return L; }", 6, "defines no 'vec3 BRDF"),
    ("float k = 1.0;\nfloat bump(float x) { k = x; return x; }\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n"
     "{\n    return vec3(bump(L.x) + k);\n}", 7, "global variable 'k' is assigned in 'bump'"),
    ("float twice(float x) { return x; }\nfloat twice(float y) { return y; }\n"
     "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return L; }", 7, "'twice(float)' is defined twice"),
    ("float G(float x) { return x; }\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{\n    float G = 1.0;\n"
     "    return vec3(G(G));\n}", 10, "'G' is a variable here, not a function"),
])
def test_brdf_errors_name_file_and_line(tmp_path, shader, line, message):
    path = write_brdf(tmp_path, "broken", shader)
    with pytest.raises(ClshadeError) as info:
        BUILT_IN.resolve(path)
    text = str(info.value)
    assert text.startswith(f"{path}:{line}: ") and message in text and "\n" not in text


# ------------------------------------------------------------------ GLSL's scoping rules

def test_argument_and_local_shadow_a_parameter(tmp_path, runtime):
    """A function argument or a local named like a parameter of the file hides it (GLSL scoping), also
    a parameter that is a material key (ior reads the Surface per pixel)."""
    shader = """
float GGX(float NdotH, float alphaG) { return alphaG * NdotH; }
float Fresnel(float c, float ior) { return ior + c; }
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{
    float b = alphaG;
    {
        float alphaG = 10.0;
        b += alphaG;
        float b = 1.0;      // hides the outer b to the end of the block
        b += 5.0;
    }
    return vec3(GGX(L.z, 2.0), b + Fresnel(L.x, 3.0), alphaG);
}
"""
    model = BUILT_IN.resolve(write_brdf(tmp_path, "shadow_param", shader,
                                        "float alphaG 0 1 0.25\nfloat ior 1 3 1.5"))
    l = directions()
    f = eval_at(model, l)
    want = np.stack([2.0 * l[:, 2], 13.25 + l[:, 0], np.full(len(l), 0.25)], axis=1)
    np.testing.assert_allclose(f, want, rtol=1e-6, atol=1e-6)


def test_user_function_hides_a_builtin(tmp_path, runtime):
    """A user function named like a GLSL built-in (reflect, smoothstep) is the one called."""
    shader = """
vec3 reflect(vec3 I, vec3 N) { return 2.0 * I + N; }
float smoothstep(float a, float b, float x) { return a + b + x; }
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{
    return reflect(L, N) + vec3(smoothstep(1.0, 2.0, L.x));
}
"""
    model = BUILT_IN.resolve(write_brdf(tmp_path, "shadow_builtin", shader))
    l = directions()
    f = eval_at(model, l)
    want = 2.0 * l + np.array([0.0, 0.0, 1.0]) + (3.0 + l[:, :1])
    np.testing.assert_allclose(f, want, rtol=1e-6, atol=1e-6)


def test_non_const_globals(tmp_path, runtime):
    """A global never assigned is a constant; one assigned in BRDF starts at its initialiser in every
    evaluation; a local named like a function hides it only after its own initialiser."""
    shader = """
float PI = 3.0;
float acc = 1.0, unused;
float G(float x) { return PI * x; }
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{
    acc += L.x;
    if (L.y > 0.0)
        acc *= 2.0;
    float G = G(L.z);
    G += unused;
    return vec3(acc, G, PI);
}
"""
    model = BUILT_IN.resolve(write_brdf(tmp_path, "globals", shader))
    l = directions()
    f = eval_at(model, l)
    acc = np.where(l[:, 1] > 0, 2.0 * (1.0 + l[:, 0]), 1.0 + l[:, 0])
    want = np.stack([acc, 3.0 * l[:, 2], np.full(len(l), 3.0)], axis=1)
    np.testing.assert_allclose(f, want, rtol=1e-6, atol=1e-6)


def test_user_function_overloads(tmp_path, runtime):
    """Overloads resolve by argument types: an exact match first, then with int converted to float."""
    shader = """
float twice(float x) { return 2.0 * x; }
vec3 twice(vec3 v) { return v * 3.0; }
float twice(float x, float y) { return x + y; }
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{
    return twice(L) + vec3(twice(L.x) + twice(1, L.y));
}
"""
    model = BUILT_IN.resolve(write_brdf(tmp_path, "overloads", shader))
    l = directions()
    f = eval_at(model, l)
    want = 3.0 * l + (2.0 * l[:, :1] + 1.0 + l[:, 1:2])
    np.testing.assert_allclose(f, want, rtol=1e-6, atol=1e-6)


# GLSL's keywords (4.30, with those reserved for future use) and built-ins: not a user's identifier.
GLSL_WORDS = set("""attribute const uniform varying buffer shared coherent volatile restrict readonly writeonly
layout centroid flat smooth noperspective patch sample break continue do for while switch case default if else
subroutine in out inout float double int void bool true false invariant precise discard return uint lowp mediump
highp precision struct common partition active asm class union enum typedef template this resource goto inline
noinline public static extern external interface long short half fixed unsigned superp input output filter sizeof
cast namespace using main""".split())


def _clshade_identifiers() -> list[str]:
    """Every identifier clshade's kernels define (macros, types, functions) and those the translator
    emits beside a shader's (the Surface `s`, the masks of if-conversion), less GLSL's own words."""
    import re
    from clshade.models.glsl.emitter import COMPONENTWISE, GEOMETRIC
    from clshade.models.glsl.parser import TYPES, UNSUPPORTED_TYPES, UNSUPPORTED_WORDS
    from clshade.resources import kernels_dir
    text = "\n".join(p.read_text(encoding="utf-8") for p in sorted(kernels_dir().rglob("*.[hc]*")))
    names = set(re.findall(r"#\s*define\s+([A-Za-z_]\w*)", text))
    names |= set(re.findall(r"typedef\b[^;{]*?\b([A-Za-z_]\w*)\s*;", text))
    names |= set(re.findall(r"}\s*([A-Za-z_]\w*)\s*;", text))
    names |= set(re.findall(r"\b([A-Za-z_]\w*)\s*\([^;{)]*\)\s*\{", text))
    names |= {"s", "g", "x_ret", "x_done", "x_if1", "x_else1", "kernel", "select", "M_PI", "real", "mask"}
    glsl = (GLSL_WORDS | set(TYPES) | set(UNSUPPORTED_TYPES) | set(UNSUPPORTED_WORDS) | set(COMPONENTWISE)
            | GEOMETRIC | {"texture", "vec4", "mat3"})
    return sorted(n for n in names if n not in glsl and "__" not in n and not n.startswith("gl_")
                  and not n.startswith("u_"))


def test_user_names_never_collide_with_clshade_names(tmp_path, runtime):
    """Each identifier of clshade's kernels as a parameter of the file, a global constant or a function,
    and as an argument and a local: the shader is translated and evaluates to its sum."""
    names = _clshade_identifiers()
    assert {"s", "real", "mask", "G_LIT", "Surface", "specular_lobe", "v3"} <= set(names)
    params, shader, total = [], [], 0.0
    body = ["vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)", "{", "    float total = 0.0;",
            "    if (L.z < -2.0) return vec3(-1.0);"]
    for i in range(0, len(names) - 2, 3):
        p, c, fn = names[i:i + 3]
        pv, cv = (i + 1) / 1000.0, (i + 2) / 1000.0
        params.append(f"float {p} 0 1 {pv!r}")
        shader.append(f"const float {c} = {cv!r};")
        shader.append(f"float {fn}(float {p}) {{ float {c} = {p} * 2.0; if ({c} < 0.0) return 0.0; return {c}; }}")
        body.append(f"    total += {p} + {c} + {fn}({p});")
        body.append(f"    {{ float {fn} = 0.5; total += {fn}; }}")
        total += 3.0 * pv + cv + 0.5
    body += ["    return vec3(total);", "}"]
    path = write_brdf(tmp_path, "names", "\n".join(shader + body), "\n".join(params))
    f = eval_at(BUILT_IN.resolve(path), directions(8))
    np.testing.assert_allclose(f, total, rtol=1e-5)


EDGES = """
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{
    float zero = max(0, -abs(L.x));              // exactly 0
    return vec3(pow(zero, e), pow(zero, 0.1 * e), exp(-87.0 - 0.3 * abs(L.x)));
}
"""


def test_pow_of_zero_and_exp_down_to_the_smallest_normal(tmp_path, runtime):
    """GLSL's pow(0, y > 0) is 0 (not a floor's power), and exp(x) is the normal float it is down to
    x = ln FLT_MIN ≈ −87.34 (not 0 from −87 on)."""
    model = BUILT_IN.with_params({"e": "1.0"}).resolve(
        write_brdf(tmp_path, "edges", EDGES, "float e 0.5 2 1"))
    l = directions()
    f = eval_at(model, l)
    assert (f[:, :2] == 0).all(), f[:, :2].max()
    want = np.exp(-87.0 - 0.3 * np.abs(l[:, 0].astype(np.float64)))
    np.testing.assert_allclose(f[:, 2], want, rtol=1e-5)


EDGE_OF_ACOS = """
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{
    float over = 1.0 + 0.5 * abs(L.x);        // rounding past ±1, as n·h of a mirror direction
    return vec3(acos(over), acos(-over), asin(over));
}
"""


def test_acos_and_asin_past_one_are_their_value_at_one(tmp_path, runtime):
    """GLSL leaves acos and asin undefined for |x| > 1; the translation gives their value at ±1,
    as Mesa does, so that n·h rounded to 1 + 1 ulp at the mirror direction is the lobe's peak."""
    model = BUILT_IN.resolve(write_brdf(tmp_path, "edge_of_acos", EDGE_OF_ACOS))
    f = eval_at(model, directions())
    np.testing.assert_allclose(f, np.tile([0.0, np.pi, np.pi / 2], (len(f), 1)), rtol=1e-6, atol=0)


# ------------------------------------------------------------------ hostile shaders: the translator's limits
# (clshade/models/glsl/limits.py). Each is refused in one line naming the file, the line and the limit,
# with exit status 2, from `clshade render -m` and `clshade check stability --model`, and fast.

from clshade.models.glsl import limits                      # noqa: E402
from clshade.models.glsl.emitter import trip_count, translate  # noqa: E402
from clshade.models.glsl.lexer import TranslateError         # noqa: E402

from conftest import SCENES, refused                         # noqa: E402

HEAD = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)\n{\n"        # the body starts on the file's line 8
DEEP = 3000          # far past MAX_NESTING, and past what Python's 1,000 frames allowed before


def brdf(body: str, before: str = "") -> str:
    return f"{before}{HEAD}{body}\n}}"


def render_args(path: str, tmp_path) -> list[str]:
    return ["render", str(SCENES / "red_ball.toml"), "-m", path, "-o", str(tmp_path / "x.png"),
            "--width", "16", "--height", "16"]


def refused_everywhere(capsys, tmp_path, path: str, *needles: str) -> str:
    """The translation is refused (checked first: a shader let through would run — a loop of 10⁹
    iterations, a recursion — where the commands below build it), then `clshade render -m` and
    `clshade check stability --model` both refuse in one line (exit 2)."""
    with pytest.raises(ClshadeError) as info:
        BUILT_IN.resolve(path)
    assert all(n in str(info.value) for n in needles), (needles, str(info.value))
    err = refused(capsys, render_args(path, tmp_path), *needles)
    assert refused(capsys, ["check", "stability", "--model", path], *needles) == err
    return err


NESTED = {       # construct → shader nesting it n deep
    "parentheses": lambda n: brdf("return vec3(" + "(" * n + "L.x" + ")" * n + ");"),
    "unary minus": lambda n: brdf("return vec3(" + "- " * n + "L.x);"),
    "long sum": lambda n: brdf("return vec3(" + " + ".join(["L.x"] * n) + ");"),
    "right operands": lambda n: brdf("return vec3(" + "L.x * (" * n + "L.y" + ")" * n + ");"),
    "blocks": lambda n: brdf("{" * n + "return L;" + "}" * n),
    "ifs": lambda n: brdf("float a = 0.0;\n" + "if (L.x > 0.0) " * n + "a = 1.0;\nreturn vec3(a);"),
    "chained ?:": lambda n: brdf("return vec3(" + "L.x > 0.0 ? 1.0 : " * n + "0.0);"),
    "a = a = …": lambda n: brdf("float a = 0.0;\n" + "a = " * n + "1.0;\nreturn vec3(a);"),
    "calls": lambda n: brdf("return vec3(" + "abs(" * n + "L.x" + ")" * n + ");"),
    "swizzles": lambda n: brdf("return L" + ".zyx" * n + ";"),
    "a global": lambda n: brdf("return vec3(k);", "const float k = " + "(" * n + "1.0" + ")" * n + ";\n"),
}


@pytest.mark.parametrize("kind", NESTED)
def test_deep_nesting_is_refused_in_one_line(capsys, tmp_path, kind):
    """Thousands of levels of any construct: one line naming MAX_NESTING, not a RecursionError."""
    path = write_brdf(tmp_path, "deep", NESTED[kind](DEEP))
    err = refused_everywhere(capsys, tmp_path, path, f"{path}:", "nested deeper than 64 levels", "MAX_NESTING")
    assert int(err.split(f"{path}:")[1].split(":")[0]) in (6, 7, 8, 9)


def _deepest(make) -> int:
    """The deepest n whose shader translates (the others are refused for their nesting)."""
    for n in range(1, 2 * limits.MAX_NESTING):
        try:
            translate(make(n), "deep.brdf", {})
        except TranslateError as err:
            assert "nested deeper than" in str(err), err
            return n - 1
    raise AssertionError("never refused")


# Levels of nesting one repeat of a construct takes: `x * (` is an operand and a parenthesis.
LEVELS_PER_REPEAT = {"right operands": 2}


@pytest.mark.parametrize("kind", [k for k in NESTED if k != "a = a = …"])      # refused for being assignments
def test_nesting_up_to_the_limit_translates_on_a_deep_stack(kind):
    """Each construct translates up to the limit (a few levels are the statement and the call
    around it), also from a caller already 500 frames deep: the limit is below Python's."""
    deepest = _deepest(NESTED[kind])
    assert limits.MAX_NESTING - 6 <= deepest * LEVELS_PER_REPEAT.get(kind, 1) <= limits.MAX_NESTING, deepest

    def nested_call(frames: int):
        return nested_call(frames - 1) if frames else translate(NESTED[kind](deepest), "deep.brdf", {})
    assert nested_call(500).entry


def test_code_nested_to_the_limit_builds_and_evaluates(tmp_path, runtime):
    """The OpenCL compiler takes translations nested to the limit (its own limit is 256 brackets)
    and they evaluate as written: 58 unary minus signs, 58 chained ?:, 14 levels of abs(-(x * …)),
    55 nested blocks."""
    shader = brdf("float a = " + "- " * 58 + "L.x;\n" + "float b = " + "L.y > 0.0 ? 1.0 : " * 58 + "0.0;\n" +
                  "float c = " + "abs(-(L.x * " * 14 + "L.y" + "))" * 14 + ";\n" + "{" * 55 + "a += 1.0;" + "}" * 55 +
                  "\nreturn vec3(a, b + c, 1.0);")
    model = BUILT_IN.resolve(write_brdf(tmp_path, "limit", shader))
    l = directions()
    f = eval_at(model, l)
    x, y = l[:, 0].astype(np.float64), l[:, 1].astype(np.float64)
    np.testing.assert_allclose(f[:, 0], x + 1.0, rtol=1e-6, atol=1e-6)       # float32: 1 + x rounds at 1e-7
    np.testing.assert_allclose(f[:, 1], (y > 0) + np.abs(x) ** 14 * np.abs(y), rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("body, needles", [
    ("int i = " + "9" * 5000 + ";\nreturn L;", ("a number of 5000 characters", "MAX_LITERAL_CHARS (64)")),
    ("return vec3(L[" + "0" * 4400 + "1]);", ("a number of 4401 characters", "MAX_LITERAL_CHARS")),
    ("return vec3(L[2147483648 - 2147483647]);", ("integer literal 2147483648 is past GLSL's int range",)),
    ("const int a = 46341;\nconst int b = a * a;\nreturn L;", ("constant int expression is 2147488281, outside "
                                                               "GLSL's int range",)),
    ("const int a = 99999;\n" + "".join(f"const int a{k} = a * a{'' if k == 0 else k - 1};\n" for k in range(3)) +
     "return L;", ("constant int expression is 9999800001",)),
    ("return vec3(1e39);", ("float literal 1e39 is past the largest float",)),
    ("return vec3(" + "9" * 60 + ".0);", ("is past the largest float",)),
])
def test_literals_past_their_limits(capsys, tmp_path, body, needles):
    """Huge integer literals and folded constants (which Python's int() once refused with a
    ValueError past 4,300 digits) and floats past float range: one line each."""
    path = write_brdf(tmp_path, "literal", brdf(body))
    refused_everywhere(capsys, tmp_path, path, f"{path}:", *needles)


def _code_bytes(shader: str) -> int:
    return len(translate(shader, "t.brdf", {}).code)


def test_generated_code_grows_linearly():
    """A chain of n swizzles (each once copying its operand's code: 3ⁿ) or of n ops adds the same
    few bytes per link; the helpers a swizzle calls are defined once."""
    for chain in (lambda n: brdf("return L" + ".zyx" * n + ";"), lambda n: brdf("return L" + ".yx.xyy" * n + ";"),
                  lambda n: brdf("return vec3(" + "L.x * " * n + "1.0);")):
        sizes = [_code_bytes(chain(n)) for n in (5, 10, 20)]
        assert sizes[2] - sizes[1] == 2 * (sizes[1] - sizes[0]) < 20 * 30, sizes
    code = translate(brdf("return L.zyx + V.zyx.zyx;"), "t.brdf", {}).code
    assert code.count("INLINE vec3 x_sw3_zyx(") == 1


@pytest.mark.parametrize("name, shader, needles", [
    ("semicolons", brdf(";" * 200_000 + "return L;"), ("more than 65536 tokens", "MAX_TOKENS")),
    ("defines", "".join(f"#define D{k + 1} D{k} D{k} D{k} D{k}\n" for k in range(12)) + "#define D0 +L.x\n" +
     brdf("return vec3(0.0 D12);"), ("more than 65536 tokens once #defines are expanded",)),
    ("globals", "const float g0 = 1.0;\n" + "".join(f"const float g{k + 1} = g{k} + g{k};\n" for k in range(40)) +
     brdf("return vec3(g40);"), ("passes 262144 bytes", "MAX_CODE_BYTES")),
    ("calls", "".join(f"float f{k}(float x) {{ return f{k + 1}(x) + f{k + 1}(-x); }}\n" for k in range(40)) +
     "float f40(float x) { return x; }\n" + brdf("return vec3(f0(L.x));"), ("'f", "with the functions it calls inlined",
                                                                            "MAX_CODE_BYTES")),
])
def test_generated_code_is_bounded(capsys, tmp_path, name, shader, needles):
    """Code that multiplies where the OpenCL compiler expands it (nested #defines, globals doubled
    by the preprocessor, calls doubled by inlining) or a file of 200,000 statements: refused
    before anything is built."""
    path = write_brdf(tmp_path, name, shader)
    refused_everywhere(capsys, tmp_path, path, f"{path}:", *needles)


def test_comment_scanning_is_linear(capsys, tmp_path):
    """80,000 comment openers without a close: one scan (it took minutes when every '/' searched
    the rest of the file); a closed comment keeps the lines after it right."""
    import time
    path = write_brdf(tmp_path, "comments", brdf("/* " * 80_000 + "return L;"))
    start = time.perf_counter()
    refused_everywhere(capsys, tmp_path, path, f"{path}:8: unterminated comment")
    assert time.perf_counter() - start < 10.0
    path = write_brdf(tmp_path, "comment_lines", brdf("/* one\ntwo /* three\n*/ return L +;"))
    refused(capsys, render_args(path, tmp_path), f"{path}:10: syntax error")


@pytest.mark.parametrize("before, body, line, cycle", [
    ("float f(float x) { return f(x) * 0.5; }\n", "return vec3(f(L.x));", 6, "'f' → 'f'"),
    ("float g(float x);\nfloat f(float x) { return g(x); }\nfloat g(float x) { return f(x) + 1.0; }\n",
     "return vec3(f(L.x));", 8, "'f' → 'g' → 'f'"),
    ("float c(float x);\nfloat a(float x) { return x; }\nfloat b(float x) { return c(x); }\n"
     "float c(float x) { if (x > 0.0) return b(x - 1.0); return a(x); }\n", "return vec3(a(L.x));", 9,
     "'b' → 'c' → 'b'"),
    ("float g(float x);\nconst float k = g(1.0);\nfloat g(float x) { return k * x; }\n", "return vec3(g(L.x));",
     7, "'g' → 'g'"),
])
def test_recursion_is_refused(capsys, tmp_path, before, body, line, cycle):
    """Direct, mutual, through an if and through a global's #define (GLSL has no recursion; compiled,
    one hung the dispatch and one crashed the process)."""
    path = write_brdf(tmp_path, "recursive", brdf(body, before))
    refused_everywhere(capsys, tmp_path, path, f"{path}:{line}: recursion: {cycle}", "GLSL forbids")


def test_calls_without_a_cycle_are_not_recursion():
    """A function called from several others (a diamond), and through a prototype, is not a cycle."""
    shader = ("float d(float x);\nfloat b(float x) { return d(x); }\nfloat c(float x) { return d(x) + b(x); }\n"
              "float d(float x) { return 2.0 * x; }\n" + brdf("return vec3(b(L.x) + c(L.y) + d(L.z));"))
    assert translate(shader, "t.brdf", {}).entry


@pytest.mark.parametrize("loop, needles", [
    ("for (int i = 0; i < 1000000000; i++) a += 1.0;", ("runs 1000000000 iterations", "MAX_LOOP_ITERATIONS (4096)")),
    ("for (int i = 0; i < 10; i += 0) a += 1.0;", ("never ends: from 0 in steps of 0, i < 10 stays true",)),
    ("for (int i = 0; i < 10; i--) a += 1.0;", ("never ends: from 0 in steps of -1",)),
    ("for (int i = 0; i != 9; i += 2) a += 1.0;", ("never ends: from 0 in steps of 2, i != 9",)),
    ("for (int i = 0; i < 100; i++) for (int j = 0; j < 100; j++) a += 1.0;",
     ("runs 100 iterations inside loops of 100 iterations",)),
    ("int n = 10;\n    for (int i = 0; i < n; i++) a += 1.0;", ("constant A, B and C (GLSL ES 1.00, Appendix A)",
                                                               "does not compare 'i' with a constant int")),
    ("for (int i = 0; i < 10; i *= 2) a += 1.0;", ("its step does not add a constant int to 'i'",)),
    ("for (int i = 0; i < 3000; i++) a += 1.0;\n    for (int j = 0; j < 3000; j++) a += 1.0;",
     ("one call of 'BRDF' runs more than 4096 for loop iterations",)),
    ("for (int i = 0; i < 100; i++) a += twice(1.0);", ("one call of 'BRDF' runs more than 4096",)),
])
def test_loops_that_run_too_long_are_refused(capsys, tmp_path, loop, needles):
    """A loop that never ends or runs past MAX_LOOP_ITERATIONS in one evaluation (nested loops
    multiplied, a called function's loops counted per call), or one not of GLSL ES 1.00's constant
    form (its trip count unknown): refused at the loop's line."""
    helper = "float twice(float x) { float y = 0.0; for (int k = 0; k < 64; k++) y += x; return y; }\n"
    path = write_brdf(tmp_path, "loop", brdf(f"    float a = 0.0;\n    {loop}\n    return vec3(a);", helper))
    refused_everywhere(capsys, tmp_path, path, f"{path}:", *needles)


def test_trip_count_is_the_loops_own():
    """trip_count against running the loop, for every relation, small bounds and steps."""
    import operator
    ops = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge, "==": operator.eq,
           "!=": operator.ne}
    for relation, holds in ops.items():
        for first in range(-4, 5):
            for bound in range(-4, 5):
                for step in range(-3, 4):
                    i, runs = first, 0
                    while holds(i, bound) and runs < 100:
                        i, runs = i + step, runs + 1
                    assert trip_count(first, relation, bound, step) == (None if runs == 100 else runs), \
                        (first, relation, bound, step)


LOOPS = """
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{
    float a = 0.0, b = 0.0, c = 0.0;
    for (int i = 10; i > 0; i -= 3) a += L.x;
    for (int i = 0; 7 >= i; i = i + 2) b += 1.0;
    for (int i = 0; i < 8; ++i) for (int j = 0; j != 9; j += 3) c += 1.0;
    return vec3(a, b, c);
}
"""


def test_constant_loops_run_their_trip_count(tmp_path, runtime):
    """Loops counting down, with the bound on the left, stepping by i = i + 2, nested: they run
    the trip count the translator checked (4, 4 and 8 × 3 times)."""
    model = BUILT_IN.resolve(write_brdf(tmp_path, "loops", LOOPS))
    l = directions()
    f = eval_at(model, l)
    assert trip_count(10, ">", 0, -3) == 4 and trip_count(0, "<=", 7, 2) == 4
    np.testing.assert_allclose(f, np.stack([4.0 * l[:, 0], np.full(len(l), 4.0), np.full(len(l), 24.0)], axis=1),
                               rtol=1e-6)


def test_dot_of_floats_multiplies_its_arguments(tmp_path, runtime):
    """dot(float, float) is a product, whatever code its arguments are (a call with commas inside),
    and an int argument converts (GLSL's implicit conversion: dot(x, 2))."""
    shader = brdf("return vec3(dot(mix(L.x, L.y, 0.25), clamp(L.z, 0.0, 0.5)), dot(L.y, 2), 1.0);")
    f = eval_at(BUILT_IN.resolve(write_brdf(tmp_path, "dotf", shader)), directions())
    l = directions().astype(np.float64)
    np.testing.assert_allclose(f[:, 0], (0.75 * l[:, 0] + 0.25 * l[:, 1]) * np.clip(l[:, 2], 0, 0.5), rtol=1e-6,
                               atol=1e-7)
    np.testing.assert_allclose(f[:, 1], 2.0 * l[:, 1], rtol=1e-6)


def test_docs_state_the_limits_as_they_are(checkout):
    """README's Resource limits rows and docs/user-lobes.md's table give each limit as limits.py holds it."""
    import re
    readme = (checkout / "README.md").read_text(encoding="utf-8")
    section = readme[readme.index("## Resource limits"):readme.index("## What it measures")]
    doc = (checkout / "docs" / "user-lobes.md").read_text(encoding="utf-8")
    table = doc[doc.index("### Translator limits"):doc.index("### Checked against a real GLSL compiler")]
    for name, readme_shown, doc_shown in (
            ("MAX_TOKENS", f"{limits.MAX_TOKENS:,}".replace(",", " "), f"{limits.MAX_TOKENS:,}".replace(",", " ")),
            ("MAX_NESTING", str(limits.MAX_NESTING), str(limits.MAX_NESTING)),
            ("MAX_LITERAL_CHARS", str(limits.MAX_LITERAL_CHARS), str(limits.MAX_LITERAL_CHARS)),
            ("MAX_CODE_BYTES", f"{limits.MAX_CODE_BYTES >> 10} KiB", f"{limits.MAX_CODE_BYTES >> 10} KiB"),
            ("MAX_LOOP_ITERATIONS", str(limits.MAX_LOOP_ITERATIONS),
             f"{limits.MAX_LOOP_ITERATIONS:,}".replace(",", " "))):
        assert re.search(rf"{re.escape(readme_shown)}[^|\n]*`{name}`", section), (name, readme_shown)
        assert re.search(rf"`{name}` \| {re.escape(doc_shown)} \|", table), (name, doc_shown)
    assert limits.INT_MAX == 2 ** 31 - 1 and f"{limits.MAX_FLOAT:.8g}" == "3.4028235e+38"

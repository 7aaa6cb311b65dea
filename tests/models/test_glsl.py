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
    if (!on)
        return vec3(a, b, c + dot(X, L) * 0.0);
    return vec3(a, b, c);
}
"""


@pytest.mark.parametrize("on", [0, 1])
def test_bool_parameters_fix_branches(tmp_path, runtime, on):
    """A bool parameter is compiled in: ?:, if/else, !, && and || on it take the branch its value
    chooses, lane by lane as before; the branch left out is not in the kernel and what only it reads
    (X here) is not read."""
    from clshade.models.glsl.emitter import translate
    path = write_brdf(tmp_path, "fixed", FIXED_BOOLS, "bool on 0")
    model = BUILT_IN.with_params({"on": str(on)}).resolve(path)
    l = directions(256)
    x = np.abs(l[:, 0].astype(np.float64))
    want = (np.stack([x, np.ones_like(x), np.full_like(x, 11.0)], axis=1) if on else
            np.stack([2 * x, np.where(x > 0.3, 5.0, 1.0), np.where(x > 0.5, 19.0, 20.0)], axis=1))
    assert (x > 0.5).any() and (x < 0.3).any()
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

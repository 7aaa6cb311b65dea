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
    assert tr.reads == {"Y"} and "#define u_k G_LIT(2.0)" in tr.code


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
])
def test_brdf_errors_name_file_and_line(tmp_path, shader, line, message):
    path = write_brdf(tmp_path, "broken", shader)
    with pytest.raises(ClshadeError) as info:
        BUILT_IN.resolve(path)
    text = str(info.value)
    assert text.startswith(f"{path}:{line}: ") and message in text and "\n" not in text

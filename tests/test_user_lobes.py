"""User lobes: clshade-format .cl files and BRDF Explorer .brdf files through the one registry.

Kernel side: the translated shaders' built-ins (kernels/glsl.h), the tangent frame of surface.h, the
double-precision build of simd.h (REAL_DOUBLE).

The .brdf files of scenes/lobes/ that restate a built-in model (Lambert, Blinn–Phong, GGX) must render
the same frame as the built-in to 1e-4 relative on every covered pixel: a wrong translation (operator
precedence, a swizzle, an implicit conversion, a lost branch) changes those pixels.
"""
from __future__ import annotations

import numpy as np
import pytest

from clshade.errors import ClshadeError
from clshade.models.lobe import BRDF_FILE
from clshade.models.model import NONE
from clshade.models.registry import LOBES_ENV, Registry
from clshade.pipeline import prepare_frame, render
from clshade.render.scene import parse_scene
from conftest import SCENES
from scene_toml import two_spheres

LOBES = SCENES / "lobes"
MATCH_RTOL = 1e-4
BUILT_IN = Registry()          # the built-in lobes; a lobe file named as a model is read for that model


@pytest.fixture(scope="module")
def frame():
    return prepare_frame(parse_scene(two_spheres(), "match.toml"))


def _relative_mismatch(a: np.ndarray, b: np.ndarray) -> float:
    covered = b[..., 3] > 0
    assert covered.sum() > 1000
    got, want = a[covered][:, :3].astype(np.float64), b[covered][:, :3].astype(np.float64)
    return float(np.max(np.abs(got - want) / np.maximum(np.abs(want), 1e-6)))


@pytest.mark.parametrize("file, builtin, params", [
    ("lambert_brdf.brdf", "lambert", {}),
    ("blinn_phong_brdf.brdf", "blinn_phong", {"kd": "0.6", "ks": "0.4"}),
    ("ggx_brdf.brdf", "ggx_correlated", {"metallic": "0"}),
])
def test_brdf_file_matches_builtin(frame, runtime, file, builtin, params):
    user = Registry().with_params(params).resolve(str(LOBES / file))
    assert user.lobes[0].origin == BRDF_FILE
    got = render(frame.scene, user, frame=frame, runtime=runtime).image
    want = render(frame.scene, BUILT_IN.resolve(builtin), frame=frame, runtime=runtime).image
    assert _relative_mismatch(got, want) <= MATCH_RTOL


def test_param_override_changes_the_frame(frame, runtime):
    """--param reaches the kernel: doubling ks of the Blinn–Phong file no longer matches the built-in."""
    registry = Registry().with_params({"kd": "0.6", "ks": "0.8"})
    got = render(frame.scene, registry.resolve(str(LOBES / "blinn_phong_brdf.brdf")), frame=frame, runtime=runtime).image
    want = render(frame.scene, BUILT_IN.resolve("blinn_phong"), frame=frame, runtime=runtime).image
    assert _relative_mismatch(got, want) > 1e-2


# ------------------------------------------------------------------ the translator's semantics

def _write_brdf(folder, name: str, shader: str, params: str = "") -> str:
    path = folder / f"{name}.brdf"
    path.write_text(f"analytic\n::begin parameters\n{params}\n::end parameters\n::begin shader\n{shader}\n::end shader\n",
                    encoding="utf-8")
    return str(path)


def _directions(count: int = 64, seed: int = 3) -> np.ndarray:
    """Unit directions in the upper hemisphere of n = +z (the eval kernel zeroes f below it)."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(count, 3))
    d[:, 2] = np.abs(d[:, 2]) + 0.05
    return (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)


def _eval(model, l: np.ndarray, double: bool = False) -> np.ndarray:
    """f at n = v = +z for the light directions l."""
    from clshade.device.evaluate import eval_brdf
    return eval_brdf(model, _samples_like(len(l), l=l), double=double).astype(np.float64)


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
    model = BUILT_IN.resolve(_write_brdf(tmp_path, "expressions", EXPRESSIONS))
    l = _directions()
    f = _eval(model, l)
    a, b, c = (l[:, i].astype(np.float64) for i in range(3))
    want = np.stack([a + b * c - a / 2 * b + 3.0, c * 10.0 + b - c + c ** 3,
                     a * b + np.where(a > b, 1.0, 2.0) + c ** 2.5], axis=1)
    np.testing.assert_allclose(f, want, rtol=1e-5, atol=1e-6)


def test_translated_control_flow_is_per_pixel(tmp_path, runtime):
    """if/else, an early return and a helper with two returns act lane by lane, loops run their count."""
    model = BUILT_IN.resolve(_write_brdf(tmp_path, "control", CONTROL))
    l = _directions(256)
    f = _eval(model, l)
    x, y = np.abs(l[:, 0].astype(np.float64)), l[:, 1].astype(np.float64)
    acc = np.where(x < 0.2, -1.0, np.where(x < 0.4, -2.0, 3.0 * x))
    want = np.stack([acc, np.where(x > 0.5, 2.0 * x, x * x),
                     1.0 + 2.0 * x + np.sin(x) + np.exp(-x) + np.log1p(x) + np.arctan2(y, x)], axis=1)
    want[y > 0.6] = 7.0
    assert (y > 0.6).any() and (x < 0.2).any() and ((x > 0.2) & (x < 0.4)).any() and (x > 0.5).any()
    np.testing.assert_allclose(f, want, rtol=1e-5, atol=1e-6)


def test_tangent_frame_reaches_only_lobes_that_read_it(tmp_path, runtime):
    import dataclasses
    from clshade.device.variants import Features, Variant
    from clshade.verify.reference import _orthonormal_basis
    reads = BUILT_IN.resolve(_write_brdf(tmp_path, "frame", "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) "
                                                         "{ return X + 2.0 * Y; }"))
    ignores = BUILT_IN.resolve(str(LOBES / "ggx_brdf.brdf"))
    assert "GEOMETRY_TANGENTS" in Variant(reads, Features(), ("depth",)).defines()
    assert "GEOMETRY_TANGENTS" not in Variant(ignores, Features(), ("depth",)).defines()
    from clshade.device.evaluate import eval_brdf
    n = _directions(32, seed=5)
    k = len(n)
    s = _samples_like(k, n=n)
    t, b = _orthonormal_basis(n.astype(np.float64))
    np.testing.assert_allclose(eval_brdf(reads, s), t + 2.0 * b, atol=1e-5)
    # A surface tangent (the G-buffer's): x = its part orthogonal to n, normalised; y = n × x.
    tangent = np.random.default_rng(7).normal(size=(k, 3)).astype(np.float32)
    nn = n.astype(np.float64)
    x = tangent - nn * np.sum(nn * tangent, axis=1, keepdims=True)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(nn, x)
    got = eval_brdf(reads, dataclasses.replace(s, tangent=tangent))
    np.testing.assert_allclose(got, x + 2.0 * y, atol=1e-5)


# ------------------------------------------------------------------ errors name the file and the line

def test_translation_reports_what_brdf_reads():
    """clshade.models.glsl.emitter.translate: X/Y read through a helper count; a parameter of the file is a #define."""
    from clshade.models.glsl.emitter import translate
    shader = ("float aniso(vec3 t) { return t.x; }\n"
              "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(aniso(Y)) * k; }")
    tr = translate(shader, "t.brdf", {"k": ("float", "G_LIT(2.0)")})
    assert tr.reads == {"Y"} and "#define u_k G_LIT(2.0)" in tr.code


def test_brdf_parameter_lines(tmp_path):
    """clshade.models.brdf_file: float/color/bool lines, defaults, --param values, material keys."""
    from clshade.models.brdf_file import load_brdf
    path = tmp_path / "p.brdf"
    path.write_text("analytic\n::begin parameters\nfloat n 1 100 10\ncolor tint 1 0.5 0\nbool on 1\n"
                    "float roughness 0 1 0.2\n::end parameters\n::begin shader\n"
                    "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return tint * n * roughness; }\n"
                    "::end shader\n", encoding="utf-8")
    lobe = load_brdf(path, {"n": "20", "tint": "0.25"})
    by_name = {p.name: p for p in lobe.params}
    assert by_name["n"].value == (20.0,) and by_name["n"].default == 10.0
    assert by_name["tint"].value == (0.25, 0.25, 0.25) and by_name["on"].value == (1.0,)
    assert by_name["roughness"].value == () and "roughness" in lobe.uses     # the material key, per pixel
    assert "#define u_roughness (s.roughness)" in lobe.code

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
    path = _write_brdf(tmp_path, "broken", shader)
    with pytest.raises(ClshadeError) as info:
        BUILT_IN.resolve(path)
    text = str(info.value)
    assert text.startswith(f"{path}:{line}: ") and message in text and "\n" not in text


@pytest.mark.parametrize("header, message", [
    ("id: bad_header\n * name Lobe without colon", ":3: header line 'name Lobe without colon' is not 'key: value'"),
    ("id: bad_header\n * name: x\n * kind: diffuse\n * family: diffuse\n * formula: f\n * source: s\n * uses: sparkle",
     ":8: uses sparkle: not an input of a lobe"),
    ("id: bad_header\n * name: x\n * kind: specular\n * family: diffuse\n * formula: f\n * source: s",
     "kind: specular needs a function 'INLINE vec3 specular_lobe"),
])
def test_cl_lobe_header_errors(tmp_path, header, message):
    path = tmp_path / "bad_header.cl"
    path.write_text(f"/*! clshade-model\n * {header}\n */\nINLINE real diffuse_lobe(const Geometry g, const Surface s) "
                    "{ return 1.0f; }\n", encoding="utf-8")
    with pytest.raises(ClshadeError) as info:
        Registry().with_lobes(path).lobes
    assert str(info.value).startswith(str(path)) and message in str(info.value)


def test_compile_error_is_one_line_with_the_compilers_message(tmp_path, runtime):
    path = tmp_path / "no_member.cl"
    path.write_text("/*! clshade-model\n * id: no_member\n * name: n\n * kind: diffuse\n * family: diffuse\n"
                    " * formula: f\n * source: s\n */\nINLINE real diffuse_lobe(const Geometry g, const Surface s) {\n"
                    "    return g.no_such_member;\n}\n", encoding="utf-8")
    from clshade.device.evaluate import eval_brdf
    with pytest.raises(ClshadeError) as info:
        eval_brdf(BUILT_IN.resolve(str(path)), _samples_like(4), runtime)
    assert str(info.value).startswith(f"{path}:10: no member named 'no_such_member'") and "\n" not in str(info.value)


def test_compile_error_names_the_lobe_file_where_the_compiler_ignores_line_markers(tmp_path, runtime, nvidia_compiler):
    """NVIDIA's compiler names `<kernel>:N` (N: the line in the assembled program); the error still
    names the user's file and line (clshade/device/buildlog.py maps N through the #line markers)."""
    path = tmp_path / "no_member.cl"
    path.write_text("/*! clshade-model\n * id: no_member\n * name: n\n * kind: diffuse\n * family: diffuse\n"
                    " * formula: f\n * source: s\n */\nINLINE real diffuse_lobe(const Geometry g, const Surface s) {\n"
                    "    return g.no_such_member;\n}\n", encoding="utf-8")
    nvidia_compiler("no_such_member;", "no member named 'no_such_member' in 'Geometry'")
    from clshade.device.evaluate import eval_brdf
    with pytest.raises(ClshadeError) as info:
        eval_brdf(BUILT_IN.resolve(str(path)), _samples_like(4), runtime)
    assert str(info.value).startswith(f"{path}:10: no member named 'no_such_member' in 'Geometry'"), str(info.value)
    assert "\n" not in str(info.value) and "<kernel>" not in str(info.value)


def _samples_like(k: int, l: np.ndarray | None = None, n: np.ndarray | None = None):
    """K samples with n = v = +z (or n for all three), l = +z (or the given l), white, r = 0.5."""
    from clshade.device.evaluate import Samples, constant_materials
    up = np.tile(np.array([[0.0, 0.0, 1.0]], np.float32), (k, 1)) if n is None else n
    return Samples(up, up if l is None else l, up, np.ones((k, 3), np.float32), np.full(k, 0.5, np.float32),
                   np.zeros(k, np.float32), constant_materials(k))


# ------------------------------------------------------------------ the same evidence as the built-ins

def test_stability_check_finds_the_naive_ward_infinity(runtime, checkout):
    """Ward's 1/√((n·l)(n·v)) overflows at n·v = 1e-40 without a floor; the shipped sample floors it."""
    from clshade.verify import stability
    grid = stability.geometry_grid()
    naive = BUILT_IN.resolve(str(checkout / "tests" / "data" / "lobes" / "ward_naive.brdf"))
    floored = BUILT_IN.resolve(str(LOBES / "ward.brdf"))
    bad = stability.run_model(naive, grid, runtime, False, {})
    good = stability.run_model(floored, grid, runtime, False, {})
    assert bad.nonfinite > 0 and good.nonfinite == 0 and good.negative == 0
    assert good.max_deviation_unclamped < 1e-4      # float32 against the lobe's own float64 build


def test_double_build_agrees_with_the_python_oracle(runtime):
    """The float64 device build of a built-in model equals clshade.verify.reference (the independent
    formulas) to the rounding of the float constants the shared source holds (π as float: 4e-8)."""
    from clshade.verify import accuracy as A
    for spec in ("blinn_phong", "ggx_correlated@conductor", "cook_torrance"):   # pow, the conductor, exp
        model = BUILT_IN.resolve(spec)
        case = A.model_case(model, 400, np.random.default_rng(2))
        s = case.samples
        n, l, v = (np.asarray(x, np.float64) for x in (s.n, s.l, s.v))
        f64 = _eval_samples(model, s, double=True)
        oracle = A.reference_brdf(model, n, l, v, case.reference)
        err = A._rel_err(f64, oracle, 1e-9 * np.maximum(oracle.max(axis=1), 1e-30))
        assert err.max() < 2e-7, spec


def _eval_samples(model, s, double: bool) -> np.ndarray:
    from clshade.device.evaluate import eval_brdf
    return eval_brdf(model, s, double=double).astype(np.float64)


# ------------------------------------------------------------------ the command line

def _scene_with_lobes(tmp_path, model: str) -> str:
    path = tmp_path / "scene.toml"
    path.write_text(two_spheres(32, 32, lobes=str(LOBES), model=model), encoding="utf-8")
    return str(path)


def test_models_lists_the_users_lobes_with_their_paths(capsys, monkeypatch):
    from clshade.cli import main
    monkeypatch.setenv(LOBES_ENV, str(LOBES))
    monkeypatch.setattr("clshade.verify.plausibility.physically_based", lambda **kw: {})
    assert main(["models"]) == 0
    out = capsys.readouterr().out
    assert f"yours: {LOBES / 'ward.brdf'} (BRDF Explorer file)" in out
    assert f"yours: {LOBES / 'lommel_seeliger.cl'} (lobe file)" in out
    assert "alpha_x [0.01, 1] = 0.12" in out


def test_scene_key_names_the_lobe_folder_and_param_overrides(capsys, tmp_path):
    """render.lobes names the folder of the scene's model; --param reaches that lobe (another frame)."""
    from clshade.cli import main
    from clshade.render.image import read_image
    scene = _scene_with_lobes(tmp_path, "ward")
    assert main(["render", scene, "-o", str(tmp_path / "w.png"), "--param", "alpha_x=0.3"]) == 0
    assert "ward" in capsys.readouterr().out
    assert main(["render", scene, "-o", str(tmp_path / "default.png")]) == 0
    assert not np.array_equal(read_image(tmp_path / "w.png"), read_image(tmp_path / "default.png"))


@pytest.mark.parametrize("argv_tail, message", [
    (["--param", "no_such=1"], "--param no_such: no .brdf lobe in use has that parameter"),
    (["--param", "alpha_x=7"], "--param alpha_x=7: outside [0.01, 1]"),
    (["--param", "isotropic=maybe"], "--param isotropic: 'maybe' is not 0, 1, true or false"),
])
def test_bad_params_fail_in_one_line(capsys, tmp_path, argv_tail, message):
    from clshade.cli import main
    assert main(["render", str(SCENES / "red_ball.toml"), "-m", str(LOBES / "ward.brdf"),
                 "-o", str(tmp_path / "x.png"), *argv_tail]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_broken_brdf_on_the_command_line(capsys, tmp_path):
    from clshade.cli import main
    path = _write_brdf(tmp_path, "oops", "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return L ** 2; }")
    assert main(["render", str(SCENES / "red_ball.toml"), "-m", path, "-o", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"clshade: error: {path}:6: syntax error") and err.count("\n") == 1


def test_gbuffer_tangents_reach_an_anisotropic_lobe(runtime):
    """On a textured scene (meshes with UVs) the G-buffer carries the mesh tangents for Ward, and the frame
    equals its float64 frame computed with those tangents; shaded with the normal's frame instead, it does not."""
    import dataclasses
    from clshade.device.shade import Shader
    from clshade.verify import reference as R
    ward = BUILT_IN.resolve(str(LOBES / "ward.brdf"))
    done = render(SCENES / "textured.toml", ward, width=120, height=75, runtime=runtime)
    gb, fr = done.frame.gbuffer, done.frame
    assert "tangent" in gb.channels and "tangent" in done.shader.variant(ward, done.features).channels
    assert "tangent" not in render(fr.scene, BUILT_IN.resolve("ggx_correlated"), frame=fr,
                                   runtime=runtime).shader.variant(BUILT_IN.resolve("ggx_correlated"), done.features).channels
    want = R.radiance(gb, fr.scene, ward, camera=fr.camera, shadows=fr.shadows)
    px = R.pixels(gb, fr.camera)
    keep = np.sum(px.n * px.v, axis=1) > 0.05
    got = done.image[..., :3].reshape(-1, 3)[px.index[keep]].astype(np.float64)
    ref = want.reshape(-1, 3)[px.index[keep]]
    assert np.max(np.abs(got - ref) / np.maximum(ref, 1e-3)) < 1e-3
    normal_frame = dataclasses.replace(gb, channels={k: v for k, v in gb.channels.items() if k != "tangent"})
    plain = Shader(runtime, normal_frame, fr.scene, fr.camera, fr.shadows).render(ward, done.features)
    other = plain[..., :3].reshape(-1, 3)[px.index[keep]].astype(np.float64)
    assert np.max(np.abs(other - ref) / np.maximum(ref, 1e-3)) > 1e-2


def test_aa_splits_a_model_without_diffuse_lobe():
    """`clshade aa` compares a highlight with the diffuse lobe alone: a .brdf file has none (black)."""
    from clshade.bench.aa import diffuse_model
    ward = BUILT_IN.resolve(str(LOBES / "ward.brdf"))
    alone = diffuse_model(ward)
    assert alone.diffuse == NONE and alone.specular == NONE


def test_a_folder_names_every_lobe_in_it():
    chosen = BUILT_IN.resolve_many(f"lambert,{LOBES}/")
    ids = [m.id for m in chosen]
    assert ids[0] == "lambert" and {"ward", "ggx_brdf", "lommel_seeliger", "lambert_brdf"} <= set(ids)
    assert all(m.is_users for m in chosen[1:])


def test_bench_gives_a_user_lobe_the_built_ins_columns(runtime):
    """Time, × copy, × Lambert and the error against its float64 frame (its own double build); no NumPy
    formula exists for it, so that column stays empty."""
    from clshade.bench.run import run_bench
    doc = run_bench(SCENES / "red_ball.toml", [BUILT_IN.resolve("lambert"), BUILT_IN.resolve(str(LOBES / "ward.brdf"))],
                    3, 1, width=48, height=48, numpy_frames=1)
    lam, ward = doc["models"]
    for key in ("mean_ms", "copy_ratio", "lambert_ratio", "max_rel_error", "mean_rel_error"):
        assert ward[key] is not None and np.isfinite(ward[key]), key
    assert ward["max_rel_error"] < 1e-4 and ward["numpy_ms"] is None and lam["numpy_ms"] is not None


def test_checks_cover_the_users_lobes_by_default(monkeypatch):
    """`clshade check stability` and `check plausibility` without --model: every preset, then each user lobe."""
    from clshade.verify import stability
    monkeypatch.setenv(LOBES_ENV, str(LOBES))
    registry = Registry.from_env()
    ids = [m.id for m in stability.grid_models(registry)]
    assert "lambert+ggx_correlated" in ids and {"ward", "lommel_seeliger", "ggx_brdf"} <= set(ids)
    assert [m.id for m in registry.user_models()] == [i for i in ids if registry.resolve(i).is_users]
    assert [m.id for m in stability.grid_models()] == [i for i in ids if not registry.resolve(i).is_users]

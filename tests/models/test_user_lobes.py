"""User lobes end to end: clshade-format .cl lobe files and BRDF Explorer .brdf files through the one
registry, in every command. Kernel side: the tangent frame of surface.h, the double-precision build of
simd.h (REAL_DOUBLE); a .cl header or a lobe that does not compile fails naming the lobe file and line.
The translator itself is tests/models/test_glsl.py, the .brdf format tests/models/test_brdf_file.py.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from clshade.errors import ClshadeError
from clshade.models.model import NONE
from clshade.models.registry import LOBES_ENV, Registry
from clshade.pipeline import render

from conftest import SCENES, call_beside_fifo
from lobe_helpers import directions, samples_like, write_brdf
from scene_toml import two_spheres

LOBES = SCENES / "lobes"
BUILT_IN = Registry()          # the built-in lobes; a lobe file named as a model is read for that model


def test_tangent_frame_reaches_only_lobes_that_read_it(tmp_path, runtime):
    import dataclasses
    from clshade.device.variants import Features, Variant
    from clshade.verify.reference.vectors import orthonormal_basis
    reads = BUILT_IN.resolve(write_brdf(tmp_path, "frame", "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) "
                                                         "{ return X + 2.0 * Y; }"))
    ignores = BUILT_IN.resolve(str(LOBES / "ggx_brdf.brdf"))
    assert "GEOMETRY_TANGENTS" in Variant(reads, Features(), ("depth",)).defines()
    assert "GEOMETRY_TANGENTS" not in Variant(ignores, Features(), ("depth",)).defines()
    from clshade.device.evaluate import eval_brdf
    n = directions(32, seed=5)
    k = len(n)
    s = samples_like(k, n=n)
    t, b = orthonormal_basis(n.astype(np.float64))
    np.testing.assert_allclose(eval_brdf(reads, s), t + 2.0 * b, atol=1e-5)
    # A surface tangent (the G-buffer's): x = its part orthogonal to n, normalised; y = n × x.
    tangent = np.random.default_rng(7).normal(size=(k, 3)).astype(np.float32)
    nn = n.astype(np.float64)
    x = tangent - nn * np.sum(nn * tangent, axis=1, keepdims=True)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(nn, x)
    got = eval_brdf(reads, dataclasses.replace(s, tangent=tangent))
    np.testing.assert_allclose(got, x + 2.0 * y, atol=1e-5)


# ------------------------------------------------------------------ errors name the lobe file and the line

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
        eval_brdf(BUILT_IN.resolve(str(path)), samples_like(4), runtime)
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
        eval_brdf(BUILT_IN.resolve(str(path)), samples_like(4), runtime)
    assert str(info.value).startswith(f"{path}:10: no member named 'no_such_member' in 'Geometry'"), str(info.value)
    assert "\n" not in str(info.value) and "<kernel>" not in str(info.value)


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


def test_lobes_of_one_name_get_ids_from_their_folders(tmp_path, capsys, monkeypatch):
    """Two lambert.brdf in two folders (named like a built-in, and like each other) work side by side:
    each id is its folder and name; `-m FOLDER/lambert.brdf` means that file, `-m lambert` the built-in."""
    from clshade.cli import main
    for folder, value in (("mine", "0.1"), ("theirs", "0.2")):
        (tmp_path / folder).mkdir()
        write_brdf(tmp_path / folder, "lambert", f"vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) {{ return vec3({value}); }}")
    mine, theirs = tmp_path / "mine" / "lambert.brdf", tmp_path / "theirs" / "lambert.brdf"
    both = BUILT_IN.resolve_many(f"{mine},{theirs},lambert")
    assert [m.id for m in both] == ["mine_lambert", "theirs_lambert", "lambert"]
    assert [m.lobes[0].path for m in both[:2]] == [mine, theirs] and not both[2].is_users
    assert "G_LIT(0.2)" in both[1].lobes[0].code and "G_LIT(0.1)" in both[0].lobes[0].code
    registry = BUILT_IN.with_lobes(tmp_path / "mine", tmp_path / "theirs")
    assert registry.resolve("theirs_lambert").lobes[0].path == theirs
    monkeypatch.setattr("clshade.verify.plausibility.physically_based", lambda **kw: {})
    assert main(["models", "--lobes", str(tmp_path / "mine"), "--lobes", str(tmp_path / "theirs")]) == 0
    out = capsys.readouterr().out
    assert f"yours: {mine} (BRDF Explorer file)" in out and f"yours: {theirs} (BRDF Explorer file)" in out
    assert "  mine_lambert " in out and "  theirs_lambert " in out and "  lambert " in out


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


# ------------------------------------------------------------------ hostile lobe files, folders and --param

def _cl_lobe(ident: str, params: str = "", padding: str = "") -> str:
    """The text of a diffuse .cl lobe `ident` with header `params` lines (`param: ...`) and `padding`."""
    return (f"/*! clshade-model\n * id: {ident}\n * name: n\n * kind: diffuse\n * family: diffuse\n * formula: f\n"
            f" * source: s\n{params} */\n{padding}INLINE real diffuse_lobe(const Geometry g, const Surface s) "
            "{ return 1.0f; }\n")


def _one_line(info) -> str:
    text = str(info.value)
    assert "\n" not in text, text
    return text


CONSTANT = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(0.25); }"


def test_reserved_words_are_never_a_users_lobe_id(tmp_path):
    """`none` means "no lobe" and `all`/group names mean lists: a file so named gets its folder prefix,
    so `-m none.brdf` shades with that file (not black), `-m none.cl` likewise."""
    folder = tmp_path / "mine"
    folder.mkdir()
    for name in ("none", "all", "diffuse"):
        write_brdf(folder, name, CONSTANT)
    (folder / "empirical.cl").write_text(_cl_lobe("empirical"), encoding="utf-8")
    lone = tmp_path / "none.cl"
    lone.write_text(_cl_lobe("none"), encoding="utf-8")
    model = BUILT_IN.resolve(str(folder / "none.brdf"))
    assert model.specular == "mine_none" and model.specular_lobe.path == folder / "none.brdf"
    assert BUILT_IN.resolve(str(lone)).diffuse != NONE and BUILT_IN.resolve(str(lone)).lobes
    ids = set(BUILT_IN.with_lobes(folder).lobes)
    assert {"mine_none", "mine_all", "mine_diffuse", "mine_empirical"} <= ids
    assert not {"none", "all", "diffuse", "empirical"} & ids


def test_an_at_sign_in_a_lobe_files_name_is_no_fresnel_suffix(tmp_path):
    path = write_brdf(tmp_path, "ward@home", CONSTANT)
    model = BUILT_IN.resolve(path)
    assert model.id == "ward_home" and model.specular_lobe.path.name == "ward@home.brdf"
    with pytest.raises(ClshadeError, match="drop '@dielectric'"):      # a real suffix is still checked
        BUILT_IN.resolve("lambert@dielectric")


@pytest.mark.parametrize("name", ["new\nline", 'quo"te', "back\\slash", "tab\tbed", "sep\u2028arator"])
def test_a_lobe_path_no_line_marker_can_name_is_refused(tmp_path, name):
    """The kernel names each lobe file in `#line N "path"`: a path that would break the marker is refused
    in one line (escaped), whether named as a model, given as --lobes or found in a folder."""
    folder = tmp_path / "odd"
    folder.mkdir()
    path = write_brdf(folder, name, CONSTANT)
    for attempt in (lambda: BUILT_IN.resolve(path), lambda: BUILT_IN.with_lobes(path).lobes,
                    lambda: BUILT_IN.with_lobes(folder).lobes):
        with pytest.raises(ClshadeError, match="would break the kernel's #line markers") as info:
            attempt()
        _one_line(info)


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e309", "0.5,inf,0", "0.2,0.2,NaN"])
@pytest.mark.parametrize("name", ["rho_d", "alpha_x", "isotropic"])
def test_param_values_must_be_finite(value, name):
    """NaN, inf and 1e309 (inf as a double) never reach the compiler: one line naming the parameter."""
    with pytest.raises(ClshadeError) as info:
        BUILT_IN.with_params({name: value}).resolve(str(LOBES / "ward.brdf"))
    assert _one_line(info).startswith(f"--param {name}: ") and "not a finite number" in str(info.value)


@pytest.mark.parametrize("value", ["-5", "0.5,1.5,0", "0,0,-0.001"])
def test_a_colour_param_outside_its_range_is_refused(value):
    """A colour is declared [0, 1] per channel (a negative one gives negative radiance): refused like a float
    outside its range, naming the parameter, the range and the file."""
    with pytest.raises(ClshadeError) as info:
        BUILT_IN.with_params({"rho_d": value}).resolve(str(LOBES / "ward.brdf"))
    assert _one_line(info).startswith(f"--param rho_d={value}: R, G and B must be within [0, 1]")
    assert "ward.brdf" in str(info.value)
    ward = BUILT_IN.with_params({"rho_d": "0,1,0.5"}).resolve(str(LOBES / "ward.brdf"))
    assert next(p for p in ward.specular_lobe.params if p.name == "rho_d").value == (0.0, 1.0, 0.5)


@pytest.mark.parametrize("line, message", [
    (" * param: p | 0 | nan | 0.5 | x\n", ":9: param p: max = nan is not a finite number"),
    (" * param: p | -inf | 1 | 0.5 | x\n", ":9: param p: min = -inf is not a finite number"),
    (" * param: p | 0 | 1 | 1e309 | x\n", ":9: param p: default = 1e309 is not a finite number"),
    (" * param: p | 0 | 1 | 2 | x\n", ":9: param p: default 2 is outside [0, 1]"),
])
def test_cl_header_params_must_be_finite(tmp_path, line, message):
    path = tmp_path / "header.cl"
    path.write_text(_cl_lobe("header", params=" * uses: -\n" + line), encoding="utf-8")
    with pytest.raises(ClshadeError) as info:
        BUILT_IN.with_lobes(path).lobes
    assert _one_line(info) == f"{path}{message}"


def test_models_json_never_writes_nan(capsys, monkeypatch):
    """`clshade models --json` is JSON (no NaN or Infinity): a lobe that carried one is named instead."""
    import argparse
    import dataclasses
    import json
    from types import SimpleNamespace
    from clshade.cli.commands.models import cmd_models
    monkeypatch.setattr("clshade.verify.plausibility.physically_based", lambda **kw: {})
    ward = BUILT_IN.resolve(str(LOBES / "ward.brdf")).specular_lobe
    bad = dataclasses.replace(ward, params=(dataclasses.replace(ward.params[2], high=float("nan")),))
    args = argparse.Namespace(json=True, registry=SimpleNamespace(lobes={**BUILT_IN.lobes, "ward": ward}))
    assert cmd_models(args) == 0
    json.loads(capsys.readouterr().out, parse_constant=lambda name: pytest.fail(f"{name} in the JSON"))
    args.registry = SimpleNamespace(lobes={**BUILT_IN.lobes, "ward": bad})
    with pytest.raises(ClshadeError) as info:
        cmd_models(args)
    assert str(info.value).startswith(f"{ward.source}: param alpha_x: a number that is not finite")


def test_a_lobe_file_that_is_not_utf8_is_one_line(tmp_path):
    path = tmp_path / "latin.cl"
    path.write_bytes(_cl_lobe("latin").replace("name: n", "name: caf\xe9").encode("latin-1"))
    with pytest.raises(ClshadeError, match="cannot read lobe file \\(not UTF-8") as info:
        BUILT_IN.with_lobes(tmp_path).lobes
    assert _one_line(info).startswith(str(path))


def test_a_symbolic_link_loop_as_lobes_is_one_line(tmp_path, capsys, monkeypatch):
    from conftest import refused
    loop = tmp_path / "loop"
    (tmp_path / "back").symlink_to(loop)
    loop.symlink_to(tmp_path / "back")
    with pytest.raises(ClshadeError, match="cannot resolve the \\$CLSHADE_LOBES folder"):
        Registry.from_env({LOBES_ENV: str(loop)})
    with pytest.raises(ClshadeError, match="cannot resolve the lobe file or folder"):
        BUILT_IN.with_lobes(loop)
    refused(capsys, ["models", "--lobes", str(loop)], str(loop), "cannot resolve")
    monkeypatch.setenv(LOBES_ENV, str(loop))
    refused(capsys, ["models"], str(loop), "CLSHADE_LOBES")


def test_special_files_are_refused_without_being_opened(tmp_path, checkout):
    """A FIFO, a device (a link to /dev/null: reading /dev/zero would never end) and a socket named like a
    lobe are refused wherever a lobe is read — in a folder, as --lobes, as a model — unopened."""
    import os
    import socket
    made = {}
    for kind in ("fifo", "device", "socket"):
        folder = tmp_path / kind
        folder.mkdir()
        (folder / "fine.cl").write_text(_cl_lobe("fine"), encoding="utf-8")
        made[kind] = folder / "odd.brdf"
    os.mkfifo(made["fifo"])
    made["device"].symlink_to("/dev/null")
    server = socket.socket(socket.AF_UNIX)
    server.bind(str(made["socket"]))
    answers: dict = {}

    def attempt(key, call):
        try:
            call()
            answers[key] = "accepted"
        except ClshadeError as exc:
            answers[key] = str(exc)
        except Exception as exc:     # noqa: BLE001 — the answer today: a traceback's exception
            answers[key] = f"{type(exc).__name__}: {exc}"

    def attempts():
        for kind, path in made.items():
            attempt((kind, "folder"), lambda: BUILT_IN.with_lobes(path.parent).lobes)
            attempt((kind, "--lobes"), lambda: BUILT_IN.with_lobes(path).lobes)
            attempt((kind, "-m"), lambda: BUILT_IN.resolve(str(path)))

    _, stuck = call_beside_fifo(made["fifo"], attempts)     # stuck opening the FIFO: let go on, then fail
    assert not stuck, "a lobe reader opened the FIFO"
    server.close()
    words = {"fifo": "a FIFO", "device": "a device", "socket": "a socket"}
    for (kind, where), answer in answers.items():
        assert answer.startswith((str(made[kind]), str(made[kind].resolve()))), (kind, where, answer)
        assert f"lobe file is {words[kind]}, not a regular file" in answer, (kind, where, answer)
    assert len(answers) == 9


@pytest.mark.parametrize("suffix", [".cl", ".brdf"])
def test_a_lobe_file_over_the_size_limit_is_refused(tmp_path, suffix):
    from clshade import budget
    padding = "/" * (budget.MAX_LOBE_FILE_BYTES + 1)
    if suffix == ".cl":
        path = tmp_path / "big.cl"
        path.write_text(_cl_lobe("big", padding=padding + "\n"), encoding="utf-8")
    else:
        path = Path(write_brdf(tmp_path, "big", CONSTANT + "\n" + padding))
    for attempt in (lambda: BUILT_IN.with_lobes(tmp_path).lobes, lambda: BUILT_IN.with_lobes(path),
                    lambda: BUILT_IN.resolve(str(path))):
        with pytest.raises(ClshadeError) as info:
            attempt()
        assert _one_line(info) == f"{path}: lobe file is larger than the limit of {budget.MAX_LOBE_FILE_BYTES} bytes"


def test_a_lobe_folder_over_the_file_count_limit_is_refused_before_reading(tmp_path, capsys, monkeypatch):
    """10,000 lobe files: refused by count, before any is read (it took minutes and gigabytes to read
    them all for `clshade models`); a folder at the limit is read."""
    import time
    from clshade import budget
    from conftest import refused
    many = tmp_path / "many"
    many.mkdir()
    for i in range(10_000):
        (many / f"lobe{i:05d}.cl").write_text(_cl_lobe(f"lobe{i:05d}"), encoding="utf-8")
    start = time.perf_counter()
    with pytest.raises(ClshadeError) as info:
        BUILT_IN.with_lobes(many).lobes
    assert _one_line(info) == (f"{many}: more than {budget.MAX_LOBE_FOLDER_FILES} lobe files (*.cl, *.brdf), "
                               f"the limit of a lobe folder; split it")
    refused(capsys, ["models", "--lobes", str(many)], str(many), str(budget.MAX_LOBE_FOLDER_FILES))
    assert time.perf_counter() - start < 60      # reading them all took minutes; the count is milliseconds
    small = tmp_path / "small"
    small.mkdir()
    for i in range(4):
        (small / f"lobe{i}.cl").write_text(_cl_lobe(f"lobe{i}"), encoding="utf-8")
    (small / ".hidden.cl").write_text("not a lobe", encoding="utf-8")      # hidden files are not lobes
    monkeypatch.setattr(budget, "MAX_LOBE_FOLDER_FILES", 4)
    assert {f"lobe{i}" for i in range(4)} <= set(BUILT_IN.with_lobes(small).lobes)
    (small / "lobe4.cl").write_text(_cl_lobe("lobe4"), encoding="utf-8")
    with pytest.raises(ClshadeError, match="more than 4 lobe files"):
        BUILT_IN.with_lobes(small).lobes


def test_lobes_folders_are_read_once_each(tmp_path, monkeypatch):
    """`--lobes A --lobes B --lobes C` reads each lobe file once (not A, then A and B, then A, B and C)."""
    import argparse
    import clshade.models.registry as registry_module
    from clshade.cli.parser import lobe_registry
    folders = []
    for name in "abc":
        folder = tmp_path / name
        folder.mkdir()
        for i in range(2):
            (folder / f"{name}{i}.cl").write_text(_cl_lobe(f"{name}{i}"), encoding="utf-8")
        folders.append(str(folder))
    reads = []
    real = registry_module.parse_lobe
    monkeypatch.setattr(registry_module, "parse_lobe", lambda path, origin: reads.append(path) or real(path, origin))
    monkeypatch.delenv(LOBES_ENV, raising=False)
    registry = lobe_registry(argparse.Namespace(lobes=folders, param=[], model=None))
    assert {f"{n}{i}" for n in "abc" for i in range(2)} <= set(registry.lobes)
    assert len(reads) == 6

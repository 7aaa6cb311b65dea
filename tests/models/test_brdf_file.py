"""BRDF Explorer `.brdf` files (clshade/models/brdf_file.py): the parameter block (float, color and bool
lines, defaults, --param values, parameters named like material keys), and the files of scenes/lobes/ that
restate a built-in model (Lambert, Blinn–Phong, GGX) rendering the same frame as the built-in to 1e-4
relative on every covered pixel: a wrong translation (operator precedence, a swizzle, an implicit
conversion, a lost branch) changes those pixels. A bad parameter value or a broken file on the command
line fails in one line."""
from __future__ import annotations

import numpy as np
import pytest

from clshade.models.lobe import BRDF_FILE
from clshade.models.registry import Registry
from clshade.pipeline import prepare_frame, render
from clshade.render.scene import parse_scene

from conftest import SCENES, refused
from lobe_helpers import write_brdf
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
    assert "#define u_p_roughness (s.roughness)" in lobe.code


@pytest.mark.parametrize("argv_tail, message", [
    (["--param", "no_such=1"], "--param no_such: no .brdf lobe in use has that parameter"),
    (["--param", "alpha_x=7"], "--param alpha_x=7: outside [0.01, 1]"),
    (["--param", "isotropic=maybe"], "--param isotropic: 'maybe' is not 0, 1, true or false"),
])
def test_bad_params_fail_in_one_line(capsys, tmp_path, argv_tail, message):
    refused(capsys, ["render", str(SCENES / "red_ball.toml"), "-m", str(LOBES / "ward.brdf"),
                     "-o", str(tmp_path / "x.png"), *argv_tail], message)


def test_broken_brdf_on_the_command_line(capsys, tmp_path):
    path = write_brdf(tmp_path, "oops", "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return L ** 2; }")
    err = refused(capsys, ["render", str(SCENES / "red_ball.toml"), "-m", path, "-o", str(tmp_path / "x.png")])
    assert err.startswith(f"clshade: error: {path}:6: syntax error")


# ------------------------------------------------------------------ hostile .brdf files

def test_a_define_may_name_another(tmp_path, runtime):
    """#define of a #define expands, also of one defined after it (as in C, where it is used); a
    macro naming itself stays a name (no endless expansion)."""
    from lobe_helpers import directions, eval_at
    shader = ("#define TWICE_K (2.0 * K)\n#define K HALF\n#define HALF 0.5\n#define SELF SELF\n"
              "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { float SELF = 3.0; return vec3(TWICE_K, SELF, K); }")
    f = eval_at(BUILT_IN.resolve(write_brdf(tmp_path, "defines", shader)), directions(8))
    np.testing.assert_allclose(f, np.tile([1.0, 3.0, 0.5], (8, 1)))


def test_a_chain_of_defines_is_expanded_without_recursion():
    """5,000 #defines each naming the next: an expansion loop, not 5,000 nested calls."""
    from clshade.models.glsl.lexer import tokenize
    text = "".join(f"#define M{k} M{k + 1}\n" for k in range(5000)) + "#define M5000 1.0\nM0"
    assert [t.text for t in tokenize(text, "t.brdf")] == ["1.0", ""]


def _file(tmp_path, parameters: str, shader: str = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return L; }",
          extra: str = "") -> str:
    path = tmp_path / "hostile.brdf"
    path.write_text(f"analytic\n::begin parameters\n{parameters}\n::end parameters\n::begin shader\n{shader}\n"
                    f"::end shader\n{extra}", encoding="utf-8")
    return str(path)


@pytest.mark.parametrize("parameters, extra, needles", [
    ("float k 0 1 0.5",
     "::begin shader\nvec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return V; }\n::end shader\n",
     (":8: a second '::begin shader' block (the first begins at line 5)",)),
    ("float k 0 1 0.5", "::begin parameters\nfloat q 0 1 0.5\n::end parameters\n",
     (":8: a second '::begin parameters' block (the first begins at line 2)",)),
    ("float k nan 1 0.5", "", (":3: parameter 'k': 'nan' is not a finite number",)),
    ("float k 0 inf 0.5", "", (":3: parameter 'k': 'inf' is not a finite number",)),
    ("float k 0 1 1e309", "", (":3: parameter 'k': '1e309' is not a finite number",)),
    ("float k 0 1e39 1", "", (":3: parameter 'k': 1e39 is past the largest float",)),
    ("float a 0 1 0.5\ncolor k 0 -Infinity 1", "", (":4: parameter 'k': '-Infinity' is not a finite number",)),
    ("bool k NaN", "", (":3: parameter 'k': 'NaN' is not a finite number",)),
    ("float k 0 1 2", "", (":3: parameter 'k': default 2 outside its range [0, 1]",)),
    ("float k 1 0 0.5", "", (":3: parameter 'k': default 0.5 outside its range [1, 0]",)),
    ("color k 0 -5 1", "", (":3: colour parameter 'k': default 0 -5 1 has a component outside [0, 1]",)),
])
def test_bad_blocks_and_numbers_fail_in_one_line(capsys, tmp_path, parameters, extra, needles):
    """A second block is refused (it silently replaced the first); NaN, an infinity or a float past
    float range in a range, default or colour name the file, line and parameter (they reached the
    OpenCL compiler as `nan`, `inf`)."""
    path = _file(tmp_path, parameters, extra=extra)
    for args in (["render", str(SCENES / "red_ball.toml"), "-m", path, "-o", str(tmp_path / "x.png")],
                 ["check", "stability", "--model", path]):
        refused(capsys, args, *(f"{path}{n}" for n in needles))


def test_a_file_past_the_size_limit(capsys, tmp_path):
    """A .brdf file past budget.MAX_LOBE_FILE_BYTES is refused before it is read whole (a 10 MB file of
    ';' once took 3.9 GB)."""
    from clshade.budget import MAX_LOBE_FILE_BYTES
    shader = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { " + ";" * MAX_LOBE_FILE_BYTES + " return L; }"
    path = _file(tmp_path, "", shader)
    refused(capsys, ["render", str(SCENES / "red_ball.toml"), "-m", path, "-o", str(tmp_path / "x.png")],
            f"{path}: lobe file is larger than the limit of {MAX_LOBE_FILE_BYTES} bytes")


def test_a_special_file_is_not_read(tmp_path):
    """read_source refuses a FIFO without opening it (opening one blocks until a writer comes; a reader
    that did is let go on after a while, so that the test fails instead of hanging)."""
    import os
    from pathlib import Path
    from clshade.errors import ClshadeError
    from clshade.models.brdf_file import read_source
    from conftest import call_beside_fifo
    fifo = tmp_path / "pipe.brdf"
    os.mkfifo(fifo)
    answer, stuck = call_beside_fifo(fifo, lambda: read_source(Path(fifo)), seconds=10.0)
    assert not stuck, "read_source opened the FIFO"
    assert isinstance(answer, ClshadeError) and "not a regular file" in str(answer), answer

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
    assert "#define u_roughness (s.roughness)" in lobe.code


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

"""User lobes: clshade-format .cl files and BRDF Explorer .brdf files through the one registry.

The .brdf files of scenes/lobes/ that restate a built-in model (Lambert, Blinn–Phong, GGX) must render
the same frame as the built-in to 1e-4 relative on every covered pixel: a wrong translation (operator
precedence, a swizzle, an implicit conversion, a lost branch) changes those pixels.
"""
from __future__ import annotations

import numpy as np
import pytest

from clshade import models
from clshade.pipeline import prepare_frame, render
from clshade.render.scene import parse_scene
from tests.conftest import SCENES

LOBES = SCENES / "lobes"
MATCH_RTOL = 1e-4

SCENE = """
[camera]
position = [0.0, 0.0, 4.2]
fov = 30.0
width = 96
height = 96
[render]
background = [0.0, 0.0, 0.0]
[[lights]]
type = "directional"
direction = [-0.45, -0.5, -1.0]
irradiance = [3.0, 3.0, 3.0]
[[lights]]
type = "point"
position = [2.0, 1.0, 2.5]
intensity = [4.0, 3.0, 2.0]
[materials.m]
base_color = [0.8, 0.3, 0.05]
roughness = 0.5
metallic = 0.0
kd = 0.6
ks = 0.4
shininess = 40.0
[[objects]]
primitive = "sphere"
radius = 1.0
subdivisions = 4
material = "m"
"""


@pytest.fixture(autouse=True)
def _fresh_registry():
    models.reset_user_lobes()
    yield
    models.reset_user_lobes()


@pytest.fixture(scope="module")
def frame():
    return prepare_frame(parse_scene(SCENE, "match.toml"))


def _relative_mismatch(a: np.ndarray, b: np.ndarray) -> float:
    covered = b[..., 3] > 0
    assert covered.sum() > 1000
    got, want = a[covered][:, :3].astype(np.float64), b[covered][:, :3].astype(np.float64)
    return float(np.max(np.abs(got - want) / np.maximum(np.abs(want), 1e-6)))


@pytest.mark.parametrize("file, builtin, params", [
    ("lambert_brdf.brdf", "lambert", {"albedo": "0.8,0.3,0.05"}),
    ("blinn_phong_brdf.brdf", "blinn_phong", {"albedo": "0.8,0.3,0.05", "kd": "0.6", "ks": "0.4", "shininess": "40"}),
    ("ggx_brdf.brdf", "ggx_correlated", {"base_color": "0.8,0.3,0.05", "roughness": "0.5", "metallic": "0"}),
])
def test_brdf_file_matches_builtin(frame, runtime, file, builtin, params):
    models.set_params(params)
    user = models.resolve(str(LOBES / file))
    assert user.lobes[0].origin == models.BRDF_FILE
    got = render(frame.scene, user, frame=frame, runtime=runtime).image
    want = render(frame.scene, models.resolve(builtin), frame=frame, runtime=runtime).image
    assert _relative_mismatch(got, want) <= MATCH_RTOL


def test_param_override_changes_the_frame(frame, runtime):
    """--param reaches the kernel: doubling ks of the Blinn–Phong file no longer matches the built-in."""
    models.set_params({"albedo": "0.8,0.3,0.05", "kd": "0.6", "ks": "0.8", "shininess": "40"})
    got = render(frame.scene, models.resolve(str(LOBES / "blinn_phong_brdf.brdf")), frame=frame, runtime=runtime).image
    want = render(frame.scene, models.resolve("blinn_phong"), frame=frame, runtime=runtime).image
    assert _relative_mismatch(got, want) > 1e-2

"""Light from the whole sky (scenes/README.md, [environment]; kernels/environment.h): the table and its
one-line refusals, every rung's furnace (a white Lambert surface under a uniform white sky is 1), the SH9
rung against the irradiance of a sky with known coefficients, the map's orientation as the issue states
it, a turned sky equal to the camera and scene turned back, and the sampled rung's reproducibility."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from clshade import budget
from clshade.device.shade import scene_features
from clshade.models.registry import Registry
from clshade.pipeline import prepare_frame, render
from clshade.render.environment import DIFFUSE_RUNGS, SPECULAR_RUNGS
from clshade.render.scene import load_scene

from conftest import SCENES, refused, render_refused, run_cli, write_scene
from scene_toml import camera, material, obj, render as render_table, scene, table
from sky_maps import coordinates, rotate_y, sky_of, write_map

LAMBERT = Registry().resolve("lambert")
# A sum of N float32 terms of 1/N each is 1 to within N/2 ulp; 16 samples: 1e-6.
FURNACE_TOLERANCE = 1e-6


def white_sphere(sky: dict, width: int = 24, height: int = 24, background: str | None = None, **more) -> str:
    """A white sphere filling most of a small frame under `sky` (the [environment] keys)."""
    return scene(camera(position=[0.0, 0.0, 3.2], fov=45.0, width=width, height=height),
                 render_table(background=background),
                 table("environment", **sky),
                 material("white", base_color=[1.0, 1.0, 1.0], roughness=0.5),
                 obj(primitive="sphere", subdivisions=5, material="white"), *more)


def covered(image: np.ndarray) -> np.ndarray:
    return image[..., :3][image[..., 3] > 0]


# ---------------------------------------------------------------- the table and its refusals


@pytest.mark.parametrize("case, pixels, needle", [
    ("nan", "nan", "1 NaN or Inf texel(s), the first at row 2, column 5"),
    ("inf", "inf", "1 NaN or Inf texel(s)"),
    ("negative", "negative", "1 negative texel(s), the first at row 2, column 5: -1 (radiance is ≥ 0)"),
    ("not 2:1", "square", "an equirectangular map is 2:1, this one is 16x16"),
    ("unreadable", "garbage", "cannot read environment map"),
])
def test_bad_maps_are_refused_in_one_line(tmp_path, capsys, case, pixels, needle):
    path = tmp_path / "sky.exr"
    if pixels == "garbage":
        path.write_bytes(b"not an image at all")
    else:
        sky = np.ones((16, 16 if pixels == "square" else 32, 3), np.float32)
        sky[2, 5, 1] = {"nan": np.nan, "inf": np.inf, "negative": -1.0, "square": 1.0}[pixels]
        write_map(path, sky)
    render_refused(tmp_path, capsys, white_sphere(dict(map="sky.exr")), "environment.map", "sky.exr", needle)


def test_compression_ringing_below_zero_reads_as_black(tmp_path):
    """Texels a little below 0 (lossy EXR compression rings there) are 0, not refused: −0.5 % of the mean."""
    sky = np.ones((16, 32, 3), np.float32)
    sky[3, 4] = -0.005
    write_map(tmp_path / "sky.exr", sky)
    s = load_scene(write_scene(tmp_path, white_sphere(dict(map="sky.exr"))))
    from clshade.render.environment import sky_radiance
    assert sky_radiance(s.environment, s.path)[3, 4].tolist() == [0.0, 0.0, 0.0]


def test_a_map_over_the_budget_is_refused_before_it_is_decoded(tmp_path, capsys, monkeypatch):
    write_map(tmp_path / "sky.exr", np.ones((16, 32, 3), np.float32))
    monkeypatch.setattr(budget, "MAX_TEXTURE_PIXELS", 256)
    render_refused(tmp_path, capsys, white_sphere(dict(map="sky.exr")), "environment.map", "32x16 texture exceeds")


@pytest.mark.parametrize("sky, render_keys, needle", [
    (dict(uniform=1.0, specular="split"), {}, "did you mean 'split_sum'?"),
    (dict(uniform=1.0, map="sky.exr"), {}, "needs exactly one of 'map' (a file) or 'uniform'"),
    (dict(intensity=2.0), {}, "needs exactly one of 'map'"),
    (dict(uniform=1.0, samples=0), {}, "environment.samples = 0: must be within [1, 1024]"),
    (dict(uniform=1.0, diffuse="sh8"), {}, "did you mean 'sh9'?"),
    (None, dict(background="environment"), "render.background = 'environment': needs an [environment] table"),
    (None, dict(background="sky"), 'must be a list of 3 numbers or "environment"'),
])
def test_bad_environment_keys_are_refused(tmp_path, capsys, sky, render_keys, needle):
    write_map(tmp_path / "sky.exr", np.ones((8, 16, 3), np.float32))
    text = scene(camera(position=[0.0, 0.0, 3.0], width=8, height=8), render_table(**render_keys),
                 table("environment", **sky) if sky else "", material("m"), obj(primitive="sphere", material="m"))
    render_refused(tmp_path, capsys, text, needle)


@pytest.mark.parametrize("flags, needle", [
    (["--environment-samples", "2000"], "--environment-samples 2000: samples must be within [1, 1024]"),
])
def test_bad_environment_flags_are_refused(tmp_path, capsys, flags, needle):
    path = write_scene(tmp_path, white_sphere(dict(uniform=1.0)))
    refused(capsys, ["render", str(path), "-o", str(tmp_path / "o.png"), *flags], needle)


@pytest.mark.parametrize("command", ["aa"])
def test_commands_without_the_skys_truth_refuse_it(tmp_path, capsys, command):
    """aa measures against the point-light frame oracle: a sky there is refused, not mismeasured (bench
    measures the environment ladder instead: tests/bench/test_environment_bench.py)."""
    path = write_scene(tmp_path, white_sphere(dict(uniform=1.0)))
    refused(capsys, [command, str(path)], "scene.toml: environment: clshade " + command + " does not measure")


def test_environment_flags_need_an_environment(tmp_path, capsys):
    path = write_scene(tmp_path, scene(camera(position=[0.0, 0.0, 3.0], width=8, height=8), material("m"),
                                       obj(primitive="sphere", material="m")))
    refused(capsys, ["render", str(path), "-o", str(tmp_path / "o.png"), "--environment-diffuse", "sh9"],
            "--environment-diffuse: the scene has no [environment] table")


# ---------------------------------------------------------------- the furnace: every rung


@pytest.mark.parametrize("diffuse", DIFFUSE_RUNGS)
@pytest.mark.parametrize("specular", SPECULAR_RUNGS)
def test_white_lambert_under_a_white_sky_is_one_in_every_rung(tmp_path, diffuse, specular):
    s = load_scene(write_scene(tmp_path, white_sphere(dict(uniform=[1.0, 1.0, 1.0], diffuse=diffuse, specular=specular,
                                                          samples=16))))
    values = covered(render(s, LAMBERT).image)
    assert len(values) > 200
    assert np.abs(values - 1.0).max() <= FURNACE_TOLERANCE, (diffuse, values.min(), values.max())


def test_intensity_scales_the_sky(tmp_path):
    s = load_scene(write_scene(tmp_path, white_sphere(dict(uniform=[1.0, 0.5, 0.25], intensity=2.0,
                                                          diffuse="sampled", samples=16))))
    values = covered(render(s, LAMBERT).image)
    assert np.abs(values - [2.0, 1.0, 0.5]).max() <= 2 * FURNACE_TOLERANCE


# ---------------------------------------------------------------- SH9 against a sky of known coefficients


def known_sky(d: np.ndarray) -> np.ndarray:
    """Radiance with every band-0, 1 and 2 function of y-up SH in it (positive everywhere)."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return (3.0 + 0.5 * (x + y + z) + (x * y + y * z + x * z) + 0.5 * (3 * y * y - 1) + 0.5 * (x * x - z * z))


def known_irradiance_over_pi(n: np.ndarray) -> np.ndarray:
    """E(n)/π of known_sky: band l scaled by Â_l/π = 1, 2/3, 1/4 (Funk–Hecke with the clamped cosine)."""
    x, y, z = n[..., 0], n[..., 1], n[..., 2]
    return (3.0 + (2.0 / 3.0) * 0.5 * (x + y + z)
            + 0.25 * ((x * y + y * z + x * z) + 0.5 * (3 * y * y - 1) + 0.5 * (x * x - z * z)))


@pytest.mark.parametrize("rotation", [0.0, 90.0])
def test_sh9_rung_gives_the_irradiance_of_a_known_sky(tmp_path, rotation):
    """The SH9 rung of a white Lambert sphere is E(n)/π of a sky made of bands 0–2 only, to the map's
    discretisation (128×64 texels of centre samples: ≤ 3e-3 of E/π ≈ 3), the sky turned by `rotation`."""
    write_map(tmp_path / "sky.exr", sky_of(known_sky, 128, 64))
    s = load_scene(write_scene(tmp_path, white_sphere(dict(map="sky.exr", diffuse="sh9", specular="none",
                                                          rotation=rotation))))
    r = render(s, LAMBERT)
    cov = r.image[..., 3].reshape(-1) > 0
    n = r.frame.gbuffer.channels["normal"].reshape(-1, 3)[cov].astype(np.float64)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    want = known_irradiance_over_pi(rotate_y(n, -rotation))
    got = r.image[..., :3].reshape(-1, 3)[cov]
    assert np.abs(got - want[:, None]).max() < 3e-3 * 3.0


# ---------------------------------------------------------------- orientation and rotation


def uv_sky(width: int = 64, height: int = 32) -> np.ndarray:
    """A map whose texels hold their own centre's (u, v, 1)."""
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    return np.stack(np.broadcast_arrays(u[None, :], v[:, None], np.ones((height, width))), axis=-1).astype(np.float32)


@pytest.mark.parametrize("target, rotation", [([1.0, 0.0, 0.0], 0.0), ([0.0, 0.3, 1.0], 0.0), ([-0.4, -0.2, -1.0], 0.0),
                                              ([1.0, 0.0, 0.0], 30.0)])
def test_the_background_looks_up_the_map_as_the_issue_states(tmp_path, target, rotation):
    """u = atan2(d.x, −d.z)/2π, v = acos(d.y)/π at R_y(−θ)·d: the background of an empty scene, bilinear
    between texel centres, returns (u, v) itself, to 1e-6, wherever no seam or pole row is in the filter."""
    write_map(tmp_path / "sky.exr", uv_sky())
    behind = (-np.array(target, float) / np.linalg.norm(target) * 5.0).tolist()   # out of view
    text = scene(camera(position=[0.0, 0.0, 0.0], target=target, fov=60.0, width=32, height=24),
                 render_table(background="environment"),
                 table("environment", map="sky.exr", rotation=rotation, diffuse="sh9", specular="none"),
                 material("white", base_color=[1.0, 1.0, 1.0], roughness=0.5),
                 obj(primitive="sphere", radius=0.1, translate=behind, material="white"))
    s = load_scene(write_scene(tmp_path, text))
    image = render(s, LAMBERT).image
    assert (image[..., 3] == 0).all()
    from clshade.render.transforms import pixel_rays
    cam = s.camera
    _, d = pixel_rays(cam.view_matrix(), cam.projection_matrix(), cam.width, cam.height, np.arange(32 * 24))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    u, v = coordinates(rotate_y(d, -rotation))
    inner = (u > 1.5 / 64) & (u < 1 - 1.5 / 64) & (v > 1.5 / 32) & (v < 1 - 1.5 / 32)
    assert inner.sum() > 500
    got = image[..., :2].reshape(-1, 2)[inner]
    assert np.abs(got - np.stack([u, v], axis=1)[inner]).max() < 1e-6   # float32 rays, atan2 (< 3.1e-7 rad) and bilinear weights


def _turned(text_keys: dict, degrees: float) -> str:
    """Three white objects and a camera, everything turned by `degrees` about +y."""
    def turn(p):
        return rotate_y(np.array(p, float), degrees).tolist()
    return scene(camera(position=turn([2.0, 1.2, 3.5]), target=turn([0.0, 0.3, 0.0]), fov=40.0, width=48, height=36),
                 render_table(background="environment"),
                 table("environment", **text_keys),
                 material("white", base_color=[1.0, 1.0, 1.0], roughness=0.5),
                 obj(primitive="sphere", radius=0.6, rotate=[0.0, degrees, 0.0], translate=turn([-0.7, 0.3, 0.0]),
                     material="white"),
                 obj(primitive="box", size=[0.8, 0.5, 0.6], rotate=[0.0, 20.0 + degrees, 0.0],
                     translate=turn([0.8, 0.25, 0.2]), material="white"),
                 obj(primitive="plane", size=4.0, rotate=[0.0, degrees, 0.0], material="white"))


def lopsided_sky(d: np.ndarray) -> np.ndarray:
    """A sky with a bright warm patch towards +x, up, and a blue band towards −z."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    patch = 20.0 * np.exp(-((x - 0.8) ** 2 + (y - 0.5) ** 2 + z ** 2) / 0.05)
    return np.stack([0.3 + patch, 0.3 + 0.5 * patch, 0.3 + 0.6 * np.maximum(-z, 0.0)], axis=-1)


def test_turning_the_sky_equals_turning_camera_and_scene_back(tmp_path):
    """rotation = θ renders what rotation = 0 renders with the camera and every object turned by −θ: the
    background and the SH9 rung to float32 rounding, the sampled rung to its noise (its tangent frames
    are not turned with the scene)."""
    write_map(tmp_path / "sky.exr", sky_of(lopsided_sky, 64, 32))
    theta = 70.0
    images = {}
    for name, keys, turn in (("sky", dict(rotation=theta), 0.0), ("world", dict(rotation=0.0), -theta)):
        for rung in ("sh9", "sampled"):
            sky = dict(map="sky.exr", diffuse=rung, specular="none", samples=64, **keys)
            s = load_scene(write_scene(tmp_path, _turned(sky, turn), f"{name}.toml"))
            images[name, rung] = render(s, LAMBERT).image
    a, b = images["sky", "sh9"], images["world", "sh9"]
    cov, sky_px = (a[..., 3] > 0) & (b[..., 3] > 0), (a[..., 3] == 0) & (b[..., 3] == 0)
    assert (cov | sky_px).mean() > 0.99 and cov.sum() > 300 and sky_px.sum() > 300
    assert np.abs(a[..., :3] - b[..., :3])[cov | sky_px].max() < 1e-5 * np.abs(b[..., :3]).max()
    a, b = images["sky", "sampled"][cov][:, :3], images["world", "sampled"][cov][:, :3]
    assert np.sqrt(((a - b) ** 2).sum() / (b ** 2).sum()) < 0.1      # 64 samples: 5 % apart measured



def test_turning_the_sky_prepares_nothing_again(tmp_path, monkeypatch):
    """The rotation is the kernels' (env_to_map): a sky turned by the viewer's slider reuses the prepared
    map, SH9 and CDFs, and only its rotation (the params' first row) changes."""
    from clshade.render import environment as E
    write_map(tmp_path / "sky.exr", sky_of(lopsided_sky, 64, 32))
    E._prepare_cached.cache_clear()
    real, calls = E.prepare, []

    def counted(radiance, *args):
        calls.append(1)
        return real(radiance, *args)
    monkeypatch.setattr(E, "prepare", counted)
    envs = [E.prepare_spec(E.EnvironmentSpec(map=tmp_path / "sky.exr", rotation=theta), tmp_path / "s.toml")
            for theta in (0.0, 70.0, -20.0, 70.0)]
    assert len(calls) == 1
    assert [e.rotation for e in envs] == [0.0, 70.0, -20.0, 70.0]
    assert all(e.sh9 is envs[0].sh9 and e.pdf is envs[0].pdf for e in envs)
    p0 = [e.params()[0] for e in envs]
    assert np.allclose(p0[1][:2], [np.cos(np.radians(70.0)), np.sin(np.radians(70.0))])
    assert np.array_equal(p0[1], p0[3]) and not np.array_equal(p0[0], p0[1])



def test_a_rebound_shader_turns_the_sky(tmp_path, runtime):
    """Shader.rebind to a scene whose sky only turned (the viewer's slider: no new Shader) shades what a
    new Shader of that scene shades, background and SH9 light alike; another map is refused."""
    from clshade.device.shade import Shader
    write_map(tmp_path / "sky.exr", sky_of(lopsided_sky, 64, 32))
    write_map(tmp_path / "other.exr", sky_of(lopsided_sky, 32, 16))
    scenes = {}
    for name, keys in (("still", dict(map="sky.exr")), ("turned", dict(map="sky.exr", rotation=70.0)),
                       ("other", dict(map="other.exr"))):
        sky = dict(diffuse="sh9", specular="none", **keys)
        scenes[name] = load_scene(write_scene(tmp_path, _turned(sky, 0.0), f"{name}.toml"))
    frame = prepare_frame(scenes["still"], runtime=runtime)
    features = scene_features(scenes["still"])
    kept = Shader(runtime, frame.gbuffer, scenes["still"])
    before = kept.render(LAMBERT, features)
    kept.rebind(frame.gbuffer, scenes["turned"])
    after = kept.render(LAMBERT, features)
    fresh = Shader(runtime, frame.gbuffer, scenes["turned"]).render(LAMBERT, features)
    assert np.array_equal(after, fresh) and not np.allclose(after, before)
    with pytest.raises(ValueError, match="another sky"):
        kept.rebind(frame.gbuffer, scenes["other"])


# ---------------------------------------------------------------- the sampled rung


def test_every_built_in_specular_lobe_has_its_own_sampling():
    """A built-in lobe left out of LOBE_SAMPLING would be sampled by the cosine alone: slow to converge."""
    from clshade.models.lobe import builtin_lobes
    from clshade.render.environment import LOBE_SAMPLING
    specular = {lobe.id for lobe in builtin_lobes().values() if lobe.kind == "specular"}
    assert specular and specular == set(LOBE_SAMPLING)


def test_a_constant_sky_is_not_sampled_by_luminance(tmp_path):
    """A uniform sky's luminance sampling is uniform sphere sampling, worse than the BRDF's own: the
    feature set leaves the map strategy out (the furnace above is exact because of it)."""
    s = load_scene(write_scene(tmp_path, white_sphere(dict(uniform=0.5, diffuse="sampled"))))
    assert scene_features(s).environment.map_sampling is False
    write_map(tmp_path / "sky.exr", sky_of(lopsided_sky, 32, 16))
    s = load_scene(write_scene(tmp_path, white_sphere(dict(map="sky.exr", diffuse="sampled"))))
    assert scene_features(s).environment.map_sampling is True


# ---------------------------------------------------------------- the command line and the bundled scene


def test_bundled_scene_renders_with_rung_flags_and_explains_them(tmp_path, capsys):
    out = tmp_path / "robot.exr"
    code, stdout, err = run_cli(capsys, ["render", str(SCENES / "environment.toml"), "-o", str(out), "--width", "32",
                                         "--height", "32", "--explain", "--environment-diffuse", "sampled",
                                         "--environment-samples", "4"])
    assert code == 0 and err == "", err
    assert "environment rungs: diffuse sampled, specular sampled; sampled: 4 samples per pixel at run time from " \
           "cosine + ggx + map" in stdout
    assert "ENV_DIFFUSE=ENV_SAMPLED" in stdout and "ENV_BACKGROUND=1" in stdout
    from clshade.render.image import read_image
    image = read_image(out)
    assert np.isfinite(image).all() and image[..., :3].min() >= 0 and image[..., :3].max() > 0.05


# ---------------------------------------------------------------- the split-sum rungs

GGX = Registry().resolve("ggx_correlated")
# Roughness of the four spheres of the conductor test: from near-mirror to the roughest.
ROUGHNESS = (0.05, 0.3, 0.6, 1.0)
# The DFG table's rule (up to 2.3e-3 at grazing, tests/render/test_prefilter.py) and its bilinear
# interpolation between nodes 1/31 apart: the split sum's own error under a uniform sky, where the
# prefiltered factor is exactly 1 (measured at most 1.3e-3 on these pixels).
SPLIT_ALBEDO_TOLERANCE = 3e-3
# split_sum_ms of an F0 = 1 conductor: E·(1 + (1/E − 1)) = 1 up to float32 rounding of a few operations.
MS_TOLERANCE = 1e-3


def conductor_spheres(sky: dict, background: str | None = None, base_color=(1.0, 1.0, 1.0)) -> str:
    """Four metal spheres of ROUGHNESS in a row under `sky`, F0 = base_color (white: 1)."""
    mats = [material(f"m{i}", base_color=list(base_color), roughness=r, metallic=1.0) for i, r in enumerate(ROUGHNESS)]
    objs = [obj(primitive="sphere", radius=0.45, subdivisions=5, translate=[-1.5 + i, 0.0, 0.0], material=f"m{i}")
            for i in range(len(ROUGHNESS))]
    return scene(camera(position=[0.0, 0.0, 5.0], fov=34.0, width=96, height=32), render_table(background=background),
                 table("environment", **sky), *mats, *objs)


def reference_albedo(mu: float, roughness: float, f0: float = 1.0) -> float:
    """E(μ) of ggx_correlated with Schlick's Fresnel of `f0` (f90 = 1; F = 1 by default) by the float64
    reference (clshade.verify.reference)."""
    from clshade.verify.reference import albedo, compose

    def f(n, l, v):
        h = l + v
        h = h / np.linalg.norm(h, axis=1, keepdims=True)
        vh = np.sum(v * h, axis=1)
        out = compose.ggx_correlated(l[:, 2], v[:, 2], h[:, 2], vh, max(roughness ** 2, 1e-4))
        return np.asarray(out).reshape(len(l), -1)[:, 0] * (f0 + (1.0 - f0) * (1.0 - vh) ** 5)
    return float(albedo.directional_albedo(f, 16, v=(np.sqrt(max(1.0 - mu * mu, 0.0)), 0.0, mu)))


@pytest.fixture(scope="module")
def conductor_frame(tmp_path_factory):
    folder = tmp_path_factory.mktemp("conductors")
    s = load_scene(write_scene(folder, conductor_spheres(dict(uniform=1.0, diffuse="constant", specular="split_sum"))))
    frame = prepare_frame(s)
    from clshade.verify import reference as R
    px = R.pixels(frame.gbuffer, frame.camera)
    return s, frame, px


def _pick(px, roughness: float) -> list[int]:
    """Pixels of the sphere of `roughness` spread over n·v: one nearest each of 0.1, 0.3, 0.6, 0.9, 1."""
    nv = np.sum(px.n * px.v, axis=1)
    mine = np.flatnonzero(np.abs(px.roughness - roughness) < 1e-6)
    return [int(mine[np.argmin(np.abs(nv[mine] - target))]) for target in (0.1, 0.3, 0.6, 0.9, 1.0)]


def test_split_sum_of_an_f0_one_conductor_is_the_reference_albedo(conductor_frame):
    """A GGX conductor with F0 = 1 under a uniform white sky: split_sum is E(μ), single scatter, at every
    roughness from 0.05 to 1 and n·v from grazing to normal (the prefiltered sky is 1 exactly)."""
    s, frame, px = conductor_frame
    image = render(s, GGX, frame=frame).image[..., :3].reshape(-1, 3)
    for r in ROUGHNESS:
        for k in _pick(px, r):
            mu = float(px.n[k] @ px.v[k])
            want = reference_albedo(mu, r)
            assert np.abs(image[px.index[k]] - want).max() < SPLIT_ALBEDO_TOLERANCE, (r, mu, image[px.index[k]], want)


def test_split_sum_of_a_tinted_conductor_is_schlicks_albedo_per_channel(tmp_path):
    """Metal of base colour F0 = (0.2, 0.5, 0.9) under a uniform white sky: each channel is the reference's
    albedo with Schlick's Fresnel of that F0, F0·A + B of the DFG table's scale A and bias B (an F0 = 1
    conductor sees only A + B)."""
    f0 = (0.2, 0.5, 0.9)
    text = conductor_spheres(dict(uniform=1.0, diffuse="constant", specular="split_sum"), base_color=f0)
    s = load_scene(write_scene(tmp_path, text))
    frame = prepare_frame(s)
    from clshade.verify import reference as R
    px = R.pixels(frame.gbuffer, frame.camera)
    image = render(s, GGX, frame=frame).image[..., :3].reshape(-1, 3)
    for r in ROUGHNESS:
        for k in _pick(px, r):
            mu = float(px.n[k] @ px.v[k])
            one, zero = reference_albedo(mu, r, 1.0), reference_albedo(mu, r, 0.0)    # A + B and B
            want = np.array([c * one + (1.0 - c) * zero for c in f0])                # linear in F0
            assert np.abs(image[px.index[k]] - want).max() < SPLIT_ALBEDO_TOLERANCE, (r, mu, image[px.index[k]], want)


def test_split_sum_is_the_same_one_lane_at_a_time(tmp_path, device_runtime):
    """Spheres of four roughnesses (four chain levels) on a sky of distinct texels, at 8 lanes a work-item and
    at 1: where a work-item's lanes fall on different levels (sphere edges: covered beside uncovered lanes) the
    level table is gathered per lane, elsewhere read once; one lane is always read once. The same image."""
    from clshade.device.buildchoice import BuildChoice
    from clshade.device.runtime import Runtime
    rng = np.random.default_rng(9)
    write_map(tmp_path / "sky.exr", (rng.random((32, 64, 3)) * 4.0).astype(np.float32))
    s = load_scene(write_scene(tmp_path, conductor_spheres(dict(map="sky.exr", diffuse="sh9", specular="split_sum"))))
    spec = device_runtime.info.spec
    images = [render(s, GGX, runtime=Runtime(spec, choice=BuildChoice(lanes=lanes))).image for lanes in (8, 1)]
    assert images[0][..., :3].std() > 0.1
    assert np.abs(images[0] - images[1]).max() <= 1e-5 * np.abs(images[0]).max()


def test_split_sum_of_a_coloured_sky_reads_each_channel_at_its_scale(tmp_path):
    """The chain's texels are RGB9E5 words on the device (clshade/render/prefilter.py): under a uniform sky of
    three unequal channels, one above RGB9E5's largest value (a scaled chain), the F0 = 1 conductor
    reflects E(μ) × each channel, the sky as the format holds it (within 1/511.5 of the brightest)."""
    from clshade.render import prefilter as P
    sky = np.array([9.0e4, 2500.0, 17000.0])
    s = load_scene(write_scene(tmp_path, conductor_spheres(dict(uniform=sky.tolist(), diffuse="constant",
                                                                  specular="split_sum"))))
    frame = prepare_frame(s)
    from clshade.verify import reference as R
    px = R.pixels(frame.gbuffer, frame.camera)
    image = render(s, GGX, frame=frame).image[..., :3].reshape(-1, 3)
    scale = P.rgb9e5_scale_exponent(sky[None])
    held = P.unpack_rgb9e5(P.pack_rgb9e5(sky[None], scale), scale)[0]
    assert scale == 1 and held[0] != sky[0] and np.all(np.abs(held - sky) <= sky.max() / 511.5)
    for r in ROUGHNESS:
        for k in _pick(px, r):
            want = reference_albedo(float(px.n[k] @ px.v[k]), r) * held
            assert np.all(np.abs(image[px.index[k]] - want) <= SPLIT_ALBEDO_TOLERANCE * held), (r, image[px.index[k]], want)


def test_split_sum_ms_of_an_f0_one_conductor_is_one(conductor_frame):
    """Energy compensation: the same conductor reflects the whole white sky, 1 within 1e-3, where single
    scattering loses up to ~40 % at roughness 1."""
    s, frame, px = conductor_frame
    s2 = dataclasses.replace(s, environment=dataclasses.replace(s.environment, specular="split_sum_ms"))
    image = render(s2, GGX, frame=dataclasses.replace(frame, scene=s2)).image[..., :3].reshape(-1, 3)
    values = image[px.index]
    assert np.abs(values - 1.0).max() < MS_TOLERANCE, (values.min(), values.max())
    single = render(s, GGX, frame=frame).image[..., :3].reshape(-1, 3)[px.index]
    assert single.min() < 0.8          # the compensation has something to do


def test_both_gather_paths_read_the_sky_alike(tmp_path, device_runtime):
    """The split sum's chain and table and the background, read with AVX2's or AVX-512's gathers (kernels/simd.h,
    PoCL on x86) and lane by lane (CLSHADE_SCALAR_GATHER, each lane's texels blended as float4): the same image on a
    sky of distinct texels, metal spheres from mirror to rough, grazing edges and background included."""
    from clshade.device.buildchoice import FIXED, SCALAR_GATHER
    from clshade.device.runtime import Runtime
    rng = np.random.default_rng(5)
    write_map(tmp_path / "sky.exr", (rng.random((32, 64, 3)) * 4.0).astype(np.float32))
    s = load_scene(write_scene(tmp_path, conductor_spheres(dict(map="sky.exr", diffuse="sh9", specular="split_sum"),
                                                           background="environment")))
    spec = device_runtime.info.spec
    images = [render(s, GGX, runtime=Runtime(spec, options=options, choice=FIXED)).image
              for options in ((), (SCALAR_GATHER,))]
    assert images[0][..., :3].std() > 0.1 and (images[0][..., 3] == 0).any()      # a varied sky, and background
    assert np.abs(images[0] - images[1]).max() <= 1e-5 * np.abs(images[0]).max()


def test_split_sum_refuses_a_users_lobe_and_names_the_model():
    from clshade.device.variants import EnvironmentFeatures, environment_defines
    from clshade.errors import ClshadeError
    model = Registry().with_lobes(SCENES / "lobes" / "ward.brdf").resolve("ward")
    with pytest.raises(ClshadeError, match=r"model '.*ward.*': environment.specular = 'split_sum' .* "
                                           r"use specular = 'sampled'"):
        environment_defines(model, EnvironmentFeatures(specular="split_sum"))
    assert environment_defines(model, EnvironmentFeatures(specular="sampled"))["ENV_SPECULAR"] == "ENV_SAMPLED"


def test_split_sum_is_compiled_only_when_asked_and_explained(tmp_path, capsys):
    from clshade.device.variants import EnvironmentFeatures, environment_defines
    assert "ENV_SPLIT_FAMILY" not in environment_defines(GGX, EnvironmentFeatures(specular="sampled"))
    d = environment_defines(Registry().resolve("phong"), EnvironmentFeatures(specular="split_sum_ms"))
    assert d["ENV_SPECULAR"] == "ENV_SPLIT_SUM_MS" and d["ENV_SPLIT_FAMILY"] == "ENV_LOBE_PHONG"
    assert d["ENV_SPLIT_FRESNEL"] == "0" and d["ENV_SPLIT_NORM"] == "1"
    code, stdout, err = run_cli(capsys, ["render", str(SCENES / "environment.toml"), "-o", str(tmp_path / "r.exr"),
                                         "--width", "24", "--height", "24", "--explain",
                                         "--environment-specular", "split_sum"])
    assert code == 0 and err == "", err
    assert "specular split_sum (a 6-level prefiltered mip chain in RGB9E5 × a 32² DFG table)" in stdout
    assert "ENV_SPECULAR=ENV_SPLIT_SUM " in stdout and "ENV_SPLIT_FAMILY=ENV_LOBE_GGX" in stdout

"""The NumPy baseline (clshade/bench/numpy_baseline.py) shades what the kernels shade: its image
equals clshade's on covered pixels (≤ VERIFY_RTOL relative, the peers' rule) for every preset, on
coloured lights, on a metallic G-buffer and in both layouts; a baseline that differs is not timed;
the straw-man guard's verdict. No timing assertions (the machine is shared)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import clshade.bench.numpy_baseline as nb
from clshade.bench.peers import VERIFY_RTOL, verify, well_conditioned
from clshade.bench.run import Bench, prepare_baseline
from clshade.models.model import PRESETS, preset
from clshade.models.registry import Registry
from clshade.render.scene import Light

from conftest import SCENES

resolve = Registry().resolve          # the built-in lobes


@pytest.fixture(scope="module")
def bench() -> Bench:
    return Bench.prepare(SCENES / "sphere_grid.toml", 64, 48)


def _unit(x) -> np.ndarray:
    x = np.asarray(x, float)
    return x / np.linalg.norm(x)


def coloured(scene):
    """Two coloured directional lights and a coloured ambient: no grey scalar to lean on."""
    return dataclasses.replace(scene, ambient=(0.05, 0.02, 0.01), lights=(
        Light("directional", np.array([3.0, 1.0, 0.5]), direction=_unit([-0.5, -0.6, -1.0])),
        Light("directional", np.array([0.4, 0.6, 0.9]), direction=_unit([0.3, -0.2, -1.0]))))


def difference(bench: Bench, model, layout: str = "covered", **kw) -> tuple[float, np.ndarray, np.ndarray]:
    """(largest relative difference from the kernel's image on the well-conditioned covered pixels,
    baseline RGB, kernel RGBA)."""
    case = bench.case(model, **kw)
    image = case.shader.render(model, case.features).reshape(-1, 4)
    rgb = nb.numpy_shader(model, case.gbuffer, case.scene, case.shader.camera, case.features, layout).run()
    covered = np.flatnonzero(case.gbuffer.coverage.ravel())
    mine = np.concatenate([rgb, np.ones((len(rgb), 1), np.float32)], axis=1)
    return verify(mine, image, covered[well_conditioned(model, case.gbuffer, covered)]), rgb, image


@pytest.mark.parametrize("name", list(PRESETS))
def test_baseline_matches_the_kernel_image(bench, name):
    err, rgb, image = difference(bench, preset(name))
    assert err <= VERIFY_RTOL
    empty = ~bench.frame.gbuffer.coverage.ravel()
    assert np.array_equal(rgb[empty], image[empty, :3])        # the scene's background


@pytest.mark.parametrize("name", ["lambert", "oren_nayar", "burley", "phong_normalized", "blinn_phong",
                                  "cook_torrance", "walter_ggx", "ggx_correlated"])
def test_baseline_matches_with_coloured_lights(bench, name):
    assert difference(bench, preset(name), scene=coloured(bench.frame.scene))[0] <= VERIFY_RTOL


@pytest.mark.parametrize("name", ["burley", "ggx_correlated", "lambert+ggx_smith_schlick"])
def test_baseline_matches_on_metal_and_every_pixel(bench, name):
    """Metallic 1 (per-pixel F0 and diffuse colour) and the every-pixel layout."""
    assert difference(bench, resolve(name), gbuffer=bench.metal_gbuffer())[0] <= VERIFY_RTOL
    err, rgb, image = difference(bench, resolve(name), layout="all")
    assert err <= VERIFY_RTOL
    empty = ~bench.frame.gbuffer.coverage.ravel()
    assert np.array_equal(rgb[empty], image[empty, :3])


def test_a_zero_normal_faces_the_viewer(bench):
    """A covered pixel with a zero normal shades as if the normal were the view direction (shade.cl)."""
    gb = bench.frame.gbuffer
    normal = gb.channels["normal"].reshape(-1, 3).copy()
    hit = np.flatnonzero(gb.coverage.ravel())[::7]
    normal[hit] = 0.0
    zeroed = dataclasses.replace(gb, channels={**gb.channels, "normal": normal.reshape(-1)})
    for name in ("lambert", "ggx_correlated"):
        assert difference(bench, preset(name), gbuffer=zeroed)[0] <= VERIFY_RTOL


def test_a_broken_baseline_is_not_timed(bench, monkeypatch):
    """The bench checks the baseline against the kernel's image first: a baseline with a wrong
    lobe gets a note and no time, a right one is kept."""
    case = bench.case(preset("ggx_correlated"))
    prepare_baseline(case)
    assert case.baseline is not None and case.numpy_check <= VERIFY_RTOL and not case.numpy_note
    correct = nb.fs_ggx_correlated
    monkeypatch.setitem(nb.SPECULAR, "ggx_correlated", (lambda g, s: 1.01 * correct(g, s), nb.MICROFACET))
    broken = bench.case(preset("ggx_correlated"))
    prepare_baseline(broken)
    assert broken.baseline is None and broken.numpy_check > VERIFY_RTOL and "not timed" in broken.numpy_note


def test_unsupported_scene_has_a_reason(bench):
    from clshade.render.scene import load_scene
    case = Bench.prepare(SCENES / "shadows.toml", 32, 24).case(preset("lambert"))
    prepare_baseline(case)
    assert case.baseline is None and case.numpy_note
    with pytest.raises(nb.Unsupported, match="Schlick"):
        nb.check_supported(resolve("ggx_correlated@conductor"), load_scene(SCENES / "sphere_grid.toml"),
                           bench.features)


def test_minimal_lambert_is_lambert(bench):
    """The guard's yardstick shades Lambert (grey light, covered pixels) like the kernel."""
    err, _, image = difference(bench, preset("lambert"))
    rgb = nb.minimal_lambert(bench.frame.gbuffer, bench.frame.scene)()
    covered = np.flatnonzero(bench.frame.gbuffer.coverage.ravel())
    mine = np.concatenate([rgb, np.ones((len(rgb), 1), np.float32)], axis=1)
    assert verify(mine, image, covered) <= VERIFY_RTOL


def test_suspect_flag():
    """baseline Lambert / minimal Lambert: the median of paired ratios, suspect above 1.5."""
    assert nb.suspect([15.0] * 5, [10.0] * 5) == (1.5, False)
    ratio, bad = nb.suspect([16.0] * 5, [10.0] * 5)
    assert ratio == pytest.approx(1.6) and bad
    # one pair slowed by load on one side only does not move the median
    assert nb.suspect([12.0, 12.0, 90.0], [10.0, 10.0, 10.0]) == (pytest.approx(1.2), False)
    assert nb.suspect([], []) == (None, None)


def test_phong_behind_the_mirror_reads_shininess_as_the_kernel() -> None:
    """0ⁿ where r·v ≤ 0: 1 for n below MIN_SHININESS (denormals included, kernels/brdf.h), else 0 —
    the kernel's Fs_Phong, term for term."""
    from types import SimpleNamespace

    from clshade.verify import accuracy as A
    n = np.array([1e-40, 1e-45, 0.0, 1e-37, 0.1], np.float32)
    rv = np.full(len(n), -0.5, np.float32)
    x = np.zeros((len(n), 4), np.float32)
    x[:, 0], x[:, 1] = rv, n
    kernel = A.eval_term("Fs_Phong", x, np.zeros_like(x), np.zeros_like(x))[:, 0]
    mine = nb.fs_phong(SimpleNamespace(rv=rv), SimpleNamespace(shininess=n))
    np.testing.assert_array_equal(mine, kernel)
    np.testing.assert_array_equal(kernel, [1.0, 1.0, 1.0, 0.0, 0.0])

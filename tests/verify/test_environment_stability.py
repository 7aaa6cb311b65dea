"""The environment cases of `clshade check stability` (clshade/verify/environment_stability.py): the synthetic
sun, the firefly and bad-pixel counts, the grid's hard cases, and a NaN from the kernel reaching the failures."""
from __future__ import annotations

import numpy as np
import pytest

from clshade.models.registry import Registry
from clshade.render import environment as E
from clshade.verify import environment_stability as S
from clshade.verify import stability

GGX = Registry().resolve("ggx_correlated")


def test_the_synthetic_sun_is_its_ratio_times_the_mean_of_the_rest():
    sky = S.sun_sky(64, 32, 3.5e4).astype(np.float64)[..., 0]
    # Solid angles from the row edges, written here: (2π/W)(cos θ_top − cos θ_bottom).
    c = np.cos(np.pi * np.arange(33) / 32)
    omega = np.broadcast_to(((2 * np.pi / 64) * (c[:-1] - c[1:]))[:, None], sky.shape)
    i, j = np.unravel_index(np.argmax(sky), sky.shape)
    rest = (np.sum(sky * omega) - sky[i, j] * omega[i, j]) / (4 * np.pi - omega[i, j])
    assert sky[i, j] / rest == pytest.approx(3.5e4, rel=1e-5)
    assert np.sum(sky > 10) == 1 and 0 < i < 16          # one texel, above the horizon


def test_a_firefly_is_above_the_factor_times_the_truth():
    truth = np.array([1.0, 1.0, 1.0, 0.0, 2.0])
    lum = np.array([9.99, 10.0, 10.01, 0.5, 25.0])
    # 10.01 > 10 × 1; 25 > 10 × 2; the black pixel's truth is floored at 1e-3 × the peak 2: 0.5 > 0.02.
    assert S.fireflies(lum, truth, factor=10.0) == 3
    assert S.fireflies(lum, truth, factor=10.0, floor=0.1) == 2
    assert S.fireflies(np.array([3.0]), np.array([1.0]), factor=2.0) == 1


def test_bad_pixels_counts_nan_inf_and_negative_apart():
    raw = np.array([[1.0, np.nan, np.inf], [np.inf, 0.0, 0.0], [-1e-9, 0.0, 1.0], [1.0, 1.0, 1.0]])
    assert S.bad_pixels(raw) == dict(nan=1, inf=1, negative=1)


def test_the_grid_holds_the_hard_cases():
    channels, width, height, rough = S.grid(GGX)
    n = channels["normal"].reshape(-1, 3)
    assert {0.0, 1.0} <= set(rough.tolist())
    assert np.isclose(n[:, 2], 0.0).any() and (n[:, 2] < 0).any() and ((n[:, 2] > 0) & (n[:, 2] <= 1e-3)).any()
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-6) and width * height == len(rough)


@pytest.fixture(scope="module")
def ggx_results():
    from clshade.device.runtime import get_runtime
    return S.run_environment(GGX, get_runtime())


def test_ggx_under_the_sun_has_no_nan_inf_or_negative_in_any_rung(ggx_results):
    synthetic = [r for r in ggx_results if r.sky == "synthetic sun"]
    assert {(r.rung, r.samples) for r in synthetic} == {(f"{r.diffuse}/{r.specular}", r.samples)
                                                        for r in S.ladder_rungs(S.ENV_SAMPLES)}
    for r in ggx_results:
        assert (r.nan, r.inf, r.negative, r.clamped_nonfinite) == (0, 0, 0, 0), r
        assert r.max_radiance > 0
    counted = [r for r in synthetic if r.fireflies is not None]
    assert counted and all(r.rung.startswith("sampled/") and r.firefly_pixels > 0 for r in counted)


def test_a_nan_from_the_kernel_fails_the_check(monkeypatch):
    """A rung that writes a NaN (a real bug: a pdf of 0 divided) fails `check stability` in one line."""
    from clshade.device.shade import Shader
    real = Shader.render

    def render(self, model, features):
        image = real(self, model, features)
        if features.environment is not None and features.environment.specular == "sampled":
            image[0, 0, 1] = np.nan
        return image
    monkeypatch.setattr(Shader, "render", render)
    from clshade.device.runtime import get_runtime
    sun = S.SUN_MAP
    monkeypatch.setattr(S, "SUN_MAP", sun.with_name("absent.exr"))
    results = S.run_environment(Registry().resolve("phong"), get_runtime())
    rep = stability.Report([], [], [], [], "test", 0.0, environment=results)
    bad = [f for f in rep.failures() if "nan" in f]
    assert bad and all("sampled" in f for f in bad) and not rep.ok
    assert rep.as_dict()["environment_summary"]["nan"] == len([r for r in results if r.rung.endswith("/sampled")])
    from clshade.report.stability import stability_text
    text = stability_text(rep)
    assert "environment (precise build, raw radiance): NaN " in text and "FAIL lambert+phong under synthetic sun" in text and "FAILED" in text


def test_a_users_lobe_runs_every_rung_but_the_prefiltered_ones():
    """split_sum prefilters for built-in lobe families only: the ladder (bench and stability) leaves it out for a
    user's lobe instead of stopping at the kernel's refusal; Lambert runs the specular "none" rungs alone."""
    from pathlib import Path
    from clshade.verify.environment_rungs import PREFILTERED, ladder_rungs, model_rungs
    rungs = ladder_rungs((1, 4))
    lobes = Path(__file__).resolve().parents[2] / "scenes" / "lobes"
    user = Registry().with_lobes(lobes / "ward.brdf").resolve("lambert+ward")
    got = model_rungs(user, rungs)
    assert got and not any(r.specular in PREFILTERED for r in got)
    assert {r.specular for r in got} == set(E.SPECULAR_RUNGS) - set(PREFILTERED)
    assert model_rungs(GGX, rungs) == rungs
    assert {r.specular for r in model_rungs(Registry().resolve("lambert"), rungs)} == {"none"}


def test_check_stability_of_a_users_lobe_under_the_sky(capsys):
    from pathlib import Path
    from clshade.cli import main
    lobe = Path(__file__).resolve().parents[2] / "scenes" / "lobes" / "ward.brdf"
    assert main(["check", "stability", "--model", str(lobe)]) == 0, capsys.readouterr().err

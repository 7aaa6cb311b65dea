"""Physical plausibility measured on the device (clshade.verify.plausibility): closed-form
albedos within 1e-3, and the verdicts that separate empirical from physically based models."""
from __future__ import annotations

import math

import pytest

from clshade.verify import plausibility as P
from clshade.models.model import Model

CLOSED_FORM_TOL = 1.0e-3


@pytest.mark.parametrize("name, model, setting, expected", [
    ("GGX correlated, F = 1, α = 1", Model("none", "ggx_correlated"), P.Setting(roughness=1.0, metallic=1.0),
     1.0 - math.log(2.0)),
    ("Burley r = 0", Model("burley", "none"), P.Setting(roughness=0.0), 1.0 - 1.0 / 42.0),
    *[(f"normalized Phong n = {n:g}", Model("none", "phong_normalized", workflow="kdks"),
       P.Setting(shininess=n, kd=0.0, ks=1.0), 1.0) for n in (0.0, 1.0, 32.0, 512.0)],
    *[(f"Oren–Nayar σ = {s:g}", Model("oren_nayar", "none"), P.Setting(roughness=s),
       1.0 - 0.5 * s * s / (s * s + 0.33)) for s in (0.25, 0.5, 1.0)],
    ("Lambert", Model("lambert", "none"), P.Setting(), 1.0),
])
def test_closed_form_albedo_at_normal_view(name, model, setting, expected, runtime) -> None:
    value, err = P.albedo(model, setting, view_cos=1.0, runtime=runtime)
    assert abs(value - expected) <= CLOSED_FORM_TOL, f"{name}: {value} vs {expected}"
    assert err <= 1e-5, f"{name}: quadrature error estimate {err}"


def test_burley_exceeds_one_at_roughness_one(runtime) -> None:
    value, _ = P.albedo(Model("burley", "none"), P.Setting(roughness=1.0), runtime=runtime)
    assert value > 1.0 + CLOSED_FORM_TOL


def test_verdicts_separate_empirical_from_physically_based() -> None:
    verdicts = {v.preset: v for v in P.evaluate_presets(P.QUICK)}
    for preset in ("lambert+phong", "lambert+blinn_phong"):            # unnormalised: albedo > 1
        assert verdicts[preset].max_albedo > 1.5 and not verdicts[preset].physically_based
    for preset in ("lambert", "lambert+phong_normalized", "lambert+ggx_correlated", "lambert+walter_ggx",
                   "lambert+cook_torrance"):
        assert verdicts[preset].physically_based, verdicts[preset]
    assert not verdicts["burley"].energy_conserving
    for v in verdicts.values():
        assert v.non_negative and v.reciprocal, v
    # The metallic workflow's coupling k_d = (1 − F(n·l))(1 − F(n·v)) keeps the composed model ≤ 1,
    # while the study's k_d + k_s = 1 rule with an unnormalised lobe does not.
    for preset in ("lambert+ggx_correlated", "lambert+walter_ggx", "lambert+cook_torrance"):
        assert verdicts[preset].composed_albedo <= 1.0 + P.ENERGY_TOL, verdicts[preset]
    assert verdicts["lambert+phong"].composed_albedo > 1.0 + P.ENERGY_TOL


def test_cli_json(capsys) -> None:
    import json
    from clshade.cli import main
    assert main(["check", "plausibility", "--quick", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert {p["preset"] for p in data["presets"]} >= {"lambert", "lambert+ggx_correlated"}
    assert main(["models", "--json"]) == 0
    presets = json.loads(capsys.readouterr().out)["presets"]
    assert all(isinstance(p["physically_based"], bool) for p in presets)

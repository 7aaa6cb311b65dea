"""Every lighting model, as it renders (kernels/eval.cl, precise math), against the
float64 reference (clshade.verify.reference.brdf): ≥ 1e5 random samples each, max relative
error ≤ 1e-4 inside the limits documented in clshade/verify/accuracy.py.

Run with `pytest -s tests/verify/test_accuracy.py` to see the per-model figures;
benchmarks/measure/accuracy_table.py measures them for docs/accuracy.md.
"""
from __future__ import annotations

import pytest

from clshade.verify import accuracy as A

MODELS = A.accuracy_models()


def test_coverage() -> None:
    """Every preset, each microfacet preset with each Fresnel, and the study's pairs."""
    ids = {m.id for m in MODELS}
    for fresnel in ("", "@dielectric", "@conductor"):
        for lobe in ("cook_torrance", "walter_ggx", "ggx_correlated"):
            assert f"lambert+{lobe}{fresnel}" in ids
    for pair in ("oren_nayar+ggx_correlated", "lambert+ggx_correlated", "burley+walter_ggx",
                 "lambert+ggx_smith_schlick", "lambert", "oren_nayar", "burley", "lambert+phong",
                 "lambert+phong_normalized", "lambert+blinn_phong", "lambert+blinn_phong_normalized"):
        assert pair in ids


@pytest.mark.parametrize("model", MODELS, ids=[m.id for m in MODELS])
def test_model_accuracy(model, runtime) -> None:
    result = A.model_accuracy(model, runtime=runtime)
    hard = "" if result.hard_max_rel_err is None else \
        f"; outside the limits ({result.hard_samples} samples): {result.hard_max_rel_err:.2e}"
    print(f"\n{model.id:34s} max rel err {result.max_rel_err:.2e} over {result.samples} samples{hard}")
    assert result.samples >= A.SAMPLES
    assert result.ok, f"{model.id}: {result.max_rel_err:.3g} > {A.TARGET:g} at {result.worst_input}"


def test_metric_floor() -> None:
    """The metric is relative above FLOOR_REL · peak and absolute below it."""
    import numpy as np
    err = A._rel_err(np.array([[1.0001], [1e-6], [0.0]]), np.array([[1.0], [0.0], [0.0]]), np.array([1e-3] * 3))
    assert np.allclose(err, [1e-4, 1e-3, 0.0])

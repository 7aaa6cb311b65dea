"""The float64 oracle states its constants and model composition itself
(clshade.verify.reference); here they are compared with the kernels' and the model
registry's, so that a change on either side fails instead of being inherited by the
truth the kernels are checked against."""
from __future__ import annotations

import pytest

from clshade.models.lobe import builtin_lobes
from clshade.models.model import FRESNELS, WORKFLOWS, presets
from clshade.models.registry import Registry
from clshade.resources import constant
from clshade.verify import reference as R


@pytest.mark.parametrize("name", ["MIN_LIGHT_DIST2", "MIN_ALPHA", "MIN_SHININESS", "SHADOW_NORMAL_OFFSET_TEXELS", "SHADOW_BIAS_TEXELS"])
def test_stated_constant_is_the_kernels(name: str) -> None:
    assert getattr(R, name) == pytest.approx(constant(name), rel=1e-7), \
        f"reference.{name} = {getattr(R, name)!r}, kernels: {constant(name)!r}"


def test_lobe_families_are_the_registry() -> None:
    registry = builtin_lobes()
    assert set(R.DIFFUSE_MODELS) - {"none"} == {k for k, v in registry.items() if v.kind == "diffuse"}
    assert set(R.MICROFACET_MODELS) == {k for k, v in registry.items() if v.family == "microfacet"}
    assert set(R.EMPIRICAL_MODELS) == {k for k, v in registry.items() if v.family == "empirical"}
    assert R.FRESNEL_LOBES == {k for k, v in registry.items() if "fresnel" in v.uses}


def test_composition_is_the_registry() -> None:
    models = [m.with_options(fresnel=f, workflow=w) for m in presets() for f in FRESNELS for w in WORKFLOWS]
    models += [Registry().resolve(spec) for spec in ("ggx_correlated", "burley+walter_ggx", "oren_nayar+phong")]
    for model in models:
        assert R.uses_fresnel(model) == model.uses_fresnel, model.id


def test_the_oracle_reads_no_kernel_file() -> None:
    """With kernels/ unreadable the oracle still renders: it needs none of it."""
    import numpy as np

    import clshade.resources as resources
    from clshade.render.gbuffer import GBuffer, material_table
    from clshade.render.scene import Camera, Light, Material, Scene

    w, h = 2, 1
    channels = {"depth": np.ones(2, np.float32), "normal": np.tile([0, 0, 1.0], 2).astype(np.float32),
                "base": np.full(6, 0.5, np.float32), "roughness": np.full(2, 0.005, np.float32),
                "metallic": np.zeros(2, np.float32), "material": np.zeros(2, np.uint8)}
    camera = Camera(position=np.array([0.0, 0.0, 1.0]), target=np.zeros(3), up=np.array([0.0, 1.0, 0.0]),
                    fov=10.0, width=w, height=h)
    scene = Scene(path=None, camera=camera, lights=(Light("point", np.ones(3), position=np.array([0.0, 0.0, 0.0])),),
                  materials={"m": Material("m")}, objects=(), ambient=(0.0, 0.0, 0.0))
    gb = GBuffer(w, h, channels, material_table(scene), np.ones((h, w), bool))
    saved = resources._all_defines
    try:
        resources._all_defines = lambda: (_ for _ in ()).throw(AssertionError("the oracle read kernels/"))
        L = R.radiance(gb, scene, Registry().resolve("ggx_correlated"), camera=camera)
    finally:
        resources._all_defines = saved
    assert np.isfinite(L).all()

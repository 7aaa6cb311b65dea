"""A reduced torture grid (clshade.verify.stability): finite, non-negative, close to the reference."""
from __future__ import annotations

from clshade.verify import stability
from clshade.models.registry import Registry
from clshade.report.stability import stability_text

resolve = Registry().resolve          # the built-in lobes

# docs/stability.md: "where no clamp is active the precise build stays within 3e-4 of the float64 reference".
DOCUMENTED_PRECISE_DEVIATION = 3e-4


def test_grid_finite_non_negative_and_accurate(device_runtime) -> None:
    models = [resolve("ggx_correlated@conductor"), resolve("ggx_correlated@dielectric"), resolve("phong")]
    rep = stability.run(models, extras=False, runtime=device_runtime)
    assert rep.ok, stability_text(rep)
    assert rep.results and all(r.cases > 0 for r in rep.results)
    precise = [r for r in rep.results if not r.fast_math]
    assert all(r.max_deviation_unclamped < DOCUMENTED_PRECISE_DEVIATION for r in precise), stability_text(rep)


def test_raw_radiance_shows_what_the_clamp_hides(runtime) -> None:
    """A NaN in the shading sum (here a NaN ambient channel, which scene files cannot
    produce) is turned into MAX_RADIANCE by the shipped build's fmin, and −∞ (a user's lobe
    can run there) into −MAX_RADIANCE; the raw build that `check stability` counts on writes
    them as computed."""
    import dataclasses

    import numpy as np

    from clshade.device.shade import Shader, scene_features
    from clshade.render.gbuffer import GBuffer, material_table
    from clshade.render.scene import Camera, Material, Scene

    w, h = 8, 2
    npix = w * h
    channels = {"depth": np.full(npix, 1.0, np.float32), "normal": np.tile([0, 0, 1.0], npix).astype(np.float32),
                "base": np.full(3 * npix, 0.5, np.float32), "roughness": np.full(npix, 0.5, np.float32),
                "metallic": np.zeros(npix, np.float32), "material": np.zeros(npix, np.uint8)}
    camera = Camera(position=np.array([0.0, 0.0, 1.0]), target=np.zeros(3), up=np.array([0.0, 1.0, 0.0]),
                    fov=10.0, width=w, height=h)
    scene = Scene(path=None, camera=camera, lights=(), materials={"m": Material("m")}, objects=(),
                  ambient=(1.0, float("nan"), float("-inf")))
    gb = GBuffer(w, h, channels, material_table(scene), np.ones((h, w), bool))
    shader = Shader(runtime, gb, scene, camera)
    features = scene_features(scene)
    model = resolve("lambert")
    shipped = shader.render(model, features)[..., :3]
    raw = shader.render(model, dataclasses.replace(features, raw_radiance=True))[..., :3]
    assert np.isfinite(shipped).all() and (shipped[..., 1] == np.float32(stability.MAX_RADIANCE)).all()
    assert (shipped[..., 2] == -np.float32(stability.MAX_RADIANCE)).all() and (shipped[..., 0] > 0).all()
    assert np.isnan(raw[..., 1]).all() and (raw[..., 2] == -np.inf).all() and np.isfinite(raw[..., 0]).all()


def test_json_reports_raw_counts_saturation_and_distinct_inputs() -> None:
    rep = stability.run([resolve("lambert")], extras=False).as_dict()
    raw = rep["raw_radiance"]
    assert {"nan", "inf", "negative", "saturated_pixels", "max_radiance", "clamped_build_nonfinite"} <= set(raw)
    assert set(rep["distinct_inputs"]) == {"precise", "fast"} == set(rep["builds"])
    # per build, distinct inputs are fewer than the evaluations of both builds (normal scales coincide)
    assert 0 < rep["distinct_inputs"]["precise"] < rep["cases"] / 2
    assert all(s["deviation_pixels"] > 0 and s["max_deviation"] < stability.PRECISE_TOLERANCE for s in rep["shading"])


def test_kdks_reads_each_materials_ior_under_every_fresnel(runtime) -> None:
    """k_d + k_s = 1: F0 = ((ior − 1)/(ior + 1))² enters the ambient term (k_s·F0) whatever the
    Fresnel, so materials that differ only in IOR must not share one compiled-in IOR (the
    conductor variant baked the first material's: found by the shaded grid's IOR 1.5 and 3)."""
    import numpy as np

    from clshade.device.shade import Shader, scene_features
    from clshade.render.gbuffer import GBuffer, material_table
    from clshade.render.scene import Camera, Material, Scene
    from clshade.verify import reference as R

    w, h = 4, 2
    npix = w * h
    channels = {"depth": np.full(npix, 1.0, np.float32), "normal": np.tile([0, 0, 1.0], npix).astype(np.float32),
                "base": np.full(3 * npix, 0.5, np.float32), "roughness": np.full(npix, 0.5, np.float32),
                "metallic": np.zeros(npix, np.float32), "material": np.repeat([0, 1], w).astype(np.uint8)}
    camera = Camera(position=np.array([0.0, 0.0, 1.0]), target=np.zeros(3), up=np.array([0.0, 1.0, 0.0]),
                    fov=10.0, width=w, height=h)
    scene = Scene(path=None, camera=camera, lights=(), objects=(), ambient=(1.0, 1.0, 1.0),
                  materials={"a": Material("a", ior=1.5), "b": Material("b", ior=3.0)})
    gb = GBuffer(w, h, channels, material_table(scene), np.ones((h, w), bool))
    for fresnel in ("schlick", "dielectric", "conductor"):
        model = resolve(f"ggx_correlated@{fresnel}/kdks")
        got = Shader(runtime, gb, scene, camera).render(model, scene_features(scene))[..., :3]
        want = R.radiance(gb, scene, model, camera=camera).reshape(h, w, 3)
        assert np.allclose(got, want, rtol=1e-5), (fresnel, got[:, 0], want[:, 0])


def test_denormal_shininess_shades_alike_with_denormals_flushed_or_kept(runtime) -> None:
    """A denormal shininess (1e-40: the torture grid's) reads as 0 in a build that flushes denormals
    (NVIDIA's -cl-fast-relaxed-math; here -cl-denorms-are-zero, which PoCL honours), so 0ⁿ behind the
    mirror (r·v ≤ 0) took its n = 0 branch there (1) and its n > 0 branch (0) elsewhere: the H100
    fast Phong build deviated from the float64 reference by 1000. Every build and the
    reference must give the same lobe for n below MIN_SHININESS (FLT_MIN), at, behind and off the mirror.
    Each case fills 16 lanes, so that a work-item of SIMD ≤ 16 holds one case (the skip test decides per work-item)."""
    import numpy as np

    from clshade.device.evaluate import Samples, constant_materials, eval_brdf
    from clshade.device.runtime import Runtime
    from clshade.verify.torture import reference_f

    s, lanes = np.sqrt(0.75), 16
    shininess = np.repeat(np.array([1e-40, 1e-45, 0.0, 1e-37, 1e-40, 1e-40, 0.0], np.float32), lanes)
    l = np.repeat(np.array([[s, 0, 0.5]] * 4 + [[-s, 0, 0.5], [0, s, 0.5], [-s, 0, 0.5]], np.float32), lanes, axis=0)
    k = len(l)
    v = np.tile([[s, 0.0, 0.5]], (k, 1)).astype(np.float32)          # l = v (the first four): r·v = −0.5
    up = np.tile([[0.0, 0.0, 1.0]], (k, 1)).astype(np.float32)
    samples = Samples(up, l, v, np.ones((k, 3), np.float32), np.full(k, 0.5, np.float32), np.zeros(k, np.float32),
                      constant_materials(k, kd=0.0, ks=1.0, shininess=shininess))
    flushed = Runtime(runtime.info.spec, options=("-cl-denorms-are-zero",))
    dim = Samples(up, up, up, np.full((1, 3), 1e-40, np.float32), np.full(1, 0.5, np.float32), np.zeros(1, np.float32),
                  constant_materials(1, kd=1.0, ks=0.0))
    if eval_brdf(resolve("lambert"), dim, flushed)[0, 0] != 0.0:
        import pytest
        pytest.skip(f"{runtime.info.description} keeps denormals under -cl-denorms-are-zero")
    for model in (resolve("phong"), resolve("phong_normalized")):
        ref = reference_f(model, samples)
        for rt in (runtime, flushed):
            for fast in (False, True):
                got = eval_brdf(model, samples, rt, fast_math=fast)
                np.testing.assert_allclose(got, ref, rtol=1e-5, atol=1e-7,
                                           err_msg=f"{model.id}, {rt.options}, fast math {fast}")

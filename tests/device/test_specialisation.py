"""Specialisation never changes results: every specialised kernel variant equals the
general kernel (-D GENERAL=1: runtime light loop, ambient/shadow switches, every
channel read) with the same effects, and a variant without an effect equals the
general kernel with that effect neutral (no shadows = factor 1, no ambient = 0).
A scene without shadows compiles no shadow code and binds no shadow argument."""
from __future__ import annotations

import platform
from dataclasses import replace

import numpy as np
import pyopencl as cl
import pytest

from clshade.models.registry import Registry
from clshade.pipeline import prepare_frame
from clshade.render.scene import parse_scene
from clshade.device.shade import Shader, scene_features
from scene_toml import light, shadowed_floor_and_ball

BUILT_IN = Registry()          # the built-in lobes

# float32 kernels that run the same operations in the same order agree to
# round-off; what remains is the compiler contracting differently (FMA) in two
# programs: a few ulp of the radiance.
RTOL = 2e-5
ATOL_REL = 1e-6        # absolute tolerance as a fraction of the image maximum

SCENE = shadowed_floor_and_ball()


@pytest.fixture(scope="module")
def frame():
    return prepare_frame(parse_scene(SCENE))


@pytest.fixture(scope="module")
def shader(runtime, frame):
    return Shader(runtime, frame.gbuffer, frame.scene, frame.camera, frame.shadows)


def _close(a: np.ndarray, b: np.ndarray) -> None:
    np.testing.assert_allclose(a, b, rtol=RTOL, atol=ATOL_REL * float(np.abs(b).max()))


@pytest.mark.parametrize("model", ["ggx_correlated", "lambert", "phong"])
def test_specialised_equals_general(shader, frame, model):
    """All effects on: the specialised variant (compile-time counts, PCF, baked or
    table constants) equals the general kernel with the same runtime switches."""
    m = BUILT_IN.resolve(model)
    features = scene_features(frame.scene, geometry=frame.geometry)
    assert features.shadows and features.ambient and features.num_lights == 3
    special = shader.render(m, features)
    general = shader.render(m, replace(features, general=True))
    assert np.isfinite(special).all()
    _close(special, general)


@pytest.mark.parametrize("effect, neutral", [
    ("shadows", dict(shadows=False, shadow_pcf=1)),
    ("ambient", dict(ambient=False)),
])
def test_effect_off_equals_general_neutral(shader, frame, effect, neutral):
    """A variant compiled without an effect equals the general kernel with the effect
    switched to its neutral value, and differs from the one with the effect."""
    m = BUILT_IN.resolve("ggx_correlated")
    full = scene_features(frame.scene, geometry=frame.geometry)
    without = replace(full, **neutral)
    special = shader.render(m, without)
    general = shader.render(m, replace(without, general=True))
    _close(special, general)
    assert np.abs(special - shader.render(m, full)).max() > 1e-3      # the effect is visible


def test_light_counts_are_runtime_in_general(runtime):
    """16 lights of two kinds: compile-time loops equal the runtime loop."""
    c = lambda x: round(float(x), 3)  # noqa: E731 - positions on a circle, to 3 decimals
    lights = [light("point", position=[c(np.cos(k)), 1.5, c(np.sin(k))], intensity=0.4) if k % 2 else
              light("spot", position=[c(2 * np.cos(k)), 2.0, c(2 * np.sin(k))],
                    direction=[c(-np.cos(k)), -1.0, c(-np.sin(k))], intensity=3.0, outer_angle=40.0)
              for k in range(16)]
    frame = prepare_frame(parse_scene(shadowed_floor_and_ball(shadows=False, lights=lights)))
    shader = Shader(runtime, frame.gbuffer, frame.scene, frame.camera, frame.shadows)
    features = scene_features(frame.scene)
    assert (features.num_point, features.num_spot) == (8, 8)
    m = BUILT_IN.resolve("ggx_correlated")
    _close(shader.render(m, features), shader.render(m, replace(features, general=True)))


def test_no_shadow_code_or_arguments_without_shadows(shader, frame, runtime):
    """Shadows off: HAS_SHADOWS=0, shadow.h not assembled, no shadow identifier in the
    source, and the kernel has exactly 3 arguments fewer (size, maps, parameters)."""
    m = BUILT_IN.resolve("ggx_correlated")
    on = scene_features(frame.scene)
    off = replace(on, shadows=False, shadow_pcf=1)
    v_off, v_on = shader.variant(m, off), shader.variant(m, on)
    src_off, src_on = v_off.source(), v_on.source()
    assert v_off.defines()["HAS_SHADOWS"] == "0" and "SHADOW_PCF" not in v_off.defines()
    assert '#line 1 "shadow.h"' not in src_off and "shadow_factor" not in src_off.split('#line 1 "shade.cl"')[0]
    assert '#line 1 "shadow.h"' in src_on

    def arg_names(source: str) -> list[str]:
        kernel = runtime.kernel(source, "shade", ("-cl-kernel-arg-info",))
        count = kernel.get_info(cl.kernel_info.NUM_ARGS)
        return [kernel.get_arg_info(i, cl.kernel_arg_info.NAME) for i in range(count)]

    names_off, names_on = arg_names(src_off), arg_names(src_on)
    assert not [n for n in names_off if "shadow" in n]
    assert [n for n in names_on if "shadow" in n] == ["shadow_size", "shadow_maps", "shadow_params"]
    assert len(names_on) - len(names_off) == 3
    # The bound dispatch of the real (option-free) build agrees.
    assert shader.prepare(m, off).kernel.get_info(cl.kernel_info.NUM_ARGS) == len(names_off)


def test_variant_key_includes_effects_and_options(shader, frame):
    m = BUILT_IN.resolve("ggx_correlated")
    f = scene_features(frame.scene)
    keys = {shader.variant(m, x).key for x in (f, replace(f, shadows=False), replace(f, ambient=False),
                                                replace(f, fast_math=True), replace(f, shadow_pcf=5))}
    assert len(keys) == 5


@pytest.mark.parametrize("model,variant", [("ggx_correlated", "specialised"), ("phong", "specialised"),
                                           ("ggx_correlated", "half G-buffer"), ("phong", "general")])
def test_simd_width_never_changes_results(runtime, monkeypatch, model, variant):
    """1, 4, 8 or 16 pixels per work-item (kernels/simd.h) shade every pixel alike: a
    37×23 image (851 pixels: rows and the image end mid-vector) with shadows,
    three light kinds, ambient and a per-pixel material table; also the half-float
    planar G-buffer loads and the general kernel."""
    frame = prepare_frame(parse_scene(shadowed_floor_and_ball(37, 23)))
    features = scene_features(frame.scene, geometry=frame.geometry)
    if variant == "half G-buffer":
        features = replace(features, half_gbuffer=True)
    elif variant == "general":
        features = replace(features, general=True)
    m = BUILT_IN.resolve(model)
    images = {}
    widths = ("1", "4", "8", "16") if runtime.native_simd >= 16 else ("1", "4", "8")
    for simd in widths:
        monkeypatch.setenv("CLSHADE_SIMD", simd)
        shader = Shader(runtime, frame.gbuffer, frame.scene, frame.camera, frame.shadows)
        assert shader.prepare(m, features).global_size * int(simd) >= 851
        images[simd] = shader.render(m, features)
    assert images["1"].shape == (23, 37, 4) and (images["1"][..., 3] > 0).any() and (images["1"][..., 3] == 0).any()
    for simd in widths[1:]:
        _close(images[simd], images["1"])


def test_simd_16_runs_where_the_device_has_avx512(runtime):
    """The width the device prefers is the default: 16 lanes where the CPU has AVX-512 (as one
    register where the compiler targets it, as two AVX2 registers with simd.h's inline builtins
    where it does not: pip's PoCL 3.0 on this EPYC)."""
    if runtime.native_simd < 16:
        pytest.skip(f"{runtime.info.description}: compiler target without AVX-512 (SIMD 16 not built)")
    assert runtime.simd == 16


def test_simd_width_is_validated(runtime, monkeypatch):
    monkeypatch.setenv("CLSHADE_SIMD", "3")
    with pytest.raises(Exception, match="CLSHADE_SIMD='3'"):
        runtime.simd


@pytest.mark.parametrize("lanes", ["device", "16"])
@pytest.mark.parametrize("model,half", [("ggx_correlated", False), ("phong", False), ("cook_torrance@conductor", False),
                                        ("ggx_correlated", True)])
def test_inline_math_matches_library_math(runtime, model, half, lanes, monkeypatch):
    """kernels/simd.h's inline fmax/fmin/sqrt/rsqrt/clamp/fabs/floor/loads/stores/conversions
    give the image the OpenCL library's builtins give, shadows (floor, saturating
    conversion) and three light kinds included; with `half` the half-float G-buffer
    loads (vcvtph2ps). `lanes = "16"` checks the 16-lane paths (two 8-lane AVX halves) on
    every x86 CPU device: the runtime picks them only on AVX-512 hosts (`native_simd`), for
    speed, but they are plain AVX code that any AVX target builds."""
    from clshade.device.buildchoice import INLINE_MATH, LIBRARY_MATH
    from clshade.device.runtime import Runtime
    if lanes == "16":
        if "cpu" not in runtime.info.kind or platform.machine() not in ("x86_64", "AMD64"):
            pytest.skip(f"{runtime.info.description}: simd.h's 16-lane inline paths are x86 CPU code")
        if runtime.native_simd < 16:
            monkeypatch.setattr(Runtime, "native_simd", property(lambda self: 16))
        monkeypatch.setenv("CLSHADE_SIMD", "16")
    frame = prepare_frame(parse_scene(SCENE))
    features = replace(scene_features(frame.scene, geometry=frame.geometry), half_gbuffer=half)
    m = BUILT_IN.resolve(model)
    runtimes = [Runtime(runtime.info.spec, options=(opt,)) for opt in (INLINE_MATH, LIBRARY_MATH)]
    if lanes == "16":
        assert [r.simd for r in runtimes] == [16, 16]
    images = [Shader(r, frame.gbuffer, frame.scene, frame.camera, frame.shadows).render(m, features)
              for r in runtimes]
    _close(images[0], images[1])


def test_inline_math_only_where_the_builtin_library_cannot_inline(runtime):
    """The runtime tells simd.h whether the host has AVX-512: inline builtins exactly
    where the host has it and the kernel's compiler target does not (pip's PoCL 3.0
    on this EPYC), the library's builtins elsewhere (PoCL 3.1 compiles for AVX-512)."""
    import pyopencl as cl
    from clshade.device.runtime import host_has_avx512f
    source = """__kernel void probe(__global int* out) {
    #if defined(__AVX512F__)
        out[0] = 1;
    #else
        out[0] = 0;
    #endif
    #if defined(__x86_64__) && defined(__AVX__)
        out[1] = 1;
    #else
        out[1] = 0;
    #endif
    }"""
    kernel = runtime.kernel(source, "probe")
    out = np.zeros(2, np.int32)
    buf = runtime.empty(out.nbytes)
    kernel.set_args(buf)
    cl.enqueue_nd_range_kernel(runtime.queue, kernel, (1,), (1,)).wait()
    cl.enqueue_copy(runtime.queue, out, buf)
    target_avx512, x86_avx = (bool(x) for x in out)
    assert runtime.inline_math == (x86_avx and host_has_avx512f() and not target_avx512)


def switch_pair(runtime, option: str, prop: str, what: str):
    """(default, switched) runtimes for one of kernels/simd.h's A/B build options: the
    Runtime property `prop` is False with `option`, and True by default on an x86 CPU."""
    from clshade.device.runtime import Runtime
    default, switched = Runtime(runtime.info.spec), Runtime(runtime.info.spec, options=(option,))
    assert not getattr(switched, prop)
    # What each runtime gets (README, "Runtimes"): simd.h's x86 paths need the compiler's __x86_64__
    # (and __AVX__), which PoCL's CPU compiler defines and Intel's OpenCL CPU compiler does not.
    x86_pocl = ("cpu" in runtime.info.kind and "PoCL" in runtime.info.platform_version
                and __import__("platform").machine() == "x86_64")
    assert getattr(default, prop) == x86_pocl, (what, runtime.info.description)
    return default, switched


@pytest.mark.parametrize("simd", ["8", "16"])
def test_streaming_stores_write_the_image_plain_stores_write(device_runtime, monkeypatch, simd):
    """kernels/simd.h's STORE_ROW8 (streaming stores on x86) writes every row where the
    plain stores do: the same image bit for bit, sky work-items and covered ones."""
    from clshade.device.buildchoice import CACHED_STORES
    runtime = device_runtime
    if simd == "16" and runtime.native_simd < 16 and not runtime.inline_math:
        pytest.skip("16 lanes build here only with simd.h's inline builtins")
    monkeypatch.setenv("CLSHADE_SIMD", simd)
    frame = prepare_frame(parse_scene(SCENE))
    features = scene_features(frame.scene, geometry=frame.geometry)
    streaming, plain = switch_pair(runtime, CACHED_STORES, "streaming_stores",
                                   "an x86 CPU device with AVX writes rows with streaming stores")
    for model in ("lambert", "ggx_correlated"):
        m = BUILT_IN.resolve(model)
        a, b = (Shader(rt, frame.gbuffer, frame.scene, frame.camera, frame.shadows).render(m, features)
                for rt in (streaming, plain))
        assert (a[..., 3] == 0).any() and (a[..., 3] == 1).any(), "the frame has sky and covered pixels"
        np.testing.assert_array_equal(a, b)


def _prefetch_shaders(runtime):
    """(features, [(shader with prefetch, its runtime), (shader without, its runtime)]) for the
    specialised and the general kernel in turn, and the model."""
    from clshade.device.buildchoice import NO_PREFETCH
    frame = prepare_frame(parse_scene(SCENE))
    features = scene_features(frame.scene, geometry=frame.geometry)
    on, off = switch_pair(runtime, NO_PREFETCH, "prefetches", "an x86 CPU device prefetches the G-buffer ahead")
    for feats in (features, replace(features, general=True)):
        yield feats, [(Shader(rt, frame.gbuffer, frame.scene, frame.camera, frame.shadows), rt) for rt in (on, off)]


def test_prefetch_changes_no_pixel(device_runtime):
    """kernels/gbuffer.h's PREFETCH_AHEAD is a hint (x86): with it and without it
    (CLSHADE_NO_PREFETCH) the specialised and the general kernel write the same image,
    bit for bit."""
    m = BUILT_IN.resolve("ggx_correlated")
    for feats, shaders in _prefetch_shaders(device_runtime):
        a, b = (sh.render(m, feats) for sh, _ in shaders)
        assert (a[..., 3] == 1).any(), "the frame has covered pixels"
        np.testing.assert_array_equal(a, b)


@pytest.mark.text
def test_prefetch_hint_is_in_the_built_programs(device_runtime):
    """The hint is in the built programs (PoCL's binary is LLVM bitcode) exactly where it should
    be: the shading kernel and its copy kernel, which must make the same traffic. A search of
    compiled code for a string: prefetching changes no pixel, so no behavioural test can see it."""
    m = BUILT_IN.resolve("ggx_correlated")
    for feats, shaders in _prefetch_shaders(device_runtime):
        for sh, rt in shaders:
            for entry in ("shade",) if feats.general else ("shade", "copy"):
                program = sh.prepare(m, feats, entry=entry).kernel.program
                binary = b"".join(program.get_info(cl.program_info.BINARIES))
                if "PoCL" in rt.info.platform_version:
                    assert (b"llvm.prefetch" in binary) == rt.prefetches, (entry, rt.options, rt.prefetches)


def test_copy_kernel_writes_the_background_where_shade_does(runtime):
    """The bandwidth floor writes the same values as the shading kernel over every uncovered
    pixel (the background, in sky work-items and in the sky lanes of covered ones) and no pixel
    of zeros elsewhere: lines of zeros are written faster on the machine this was tuned on
    (perf's fill rows), so a floor that wrote 0 there was a floor no shading kernel could reach."""
    frame = prepare_frame(parse_scene(SCENE))
    features = scene_features(frame.scene, geometry=frame.geometry)
    sh = Shader(runtime, frame.gbuffer, frame.scene, frame.camera, frame.shadows)
    for name in ("lambert", "ggx_correlated"):
        shaded = sh.render(BUILT_IN.resolve(name), features)
        sh.enqueue(sh.prepare(BUILT_IN.resolve(name), features, entry="copy")).wait()
        copied = sh.read()
        sky = shaded[..., 3] == 0
        assert sky.any() and (~sky).any(), "the frame has sky and covered pixels"
        np.testing.assert_array_equal(copied[sky], shaded[sky])
        assert np.all(shaded[sky][:, :3] == np.float32(frame.scene.background)), "shade.cl writes the background"
        assert np.all(np.abs(copied[~sky]).sum(axis=1) > 0), "a covered pixel written as zeros"


def test_image_kernels_have_one_store_site():
    """shade.cl and copy.cl write their pixels at one store4 call each: with two, LLVM merges
    the last stores of both paths and drops their streaming mark (kernels/gbuffer.h)."""
    from clshade.resources import kernels_dir
    for name in ("shade.cl", "copy.cl"):
        body = (kernels_dir() / name).read_text(encoding="utf-8").split("__kernel void", 1)[1]
        assert body.count("store4(") == 1, f"kernels/{name}: {body.count('store4(')} store4 calls"


def uniform_scene(metallic: str) -> str:
    """SCENE with roughness 0.3 and the given metallic on the floor and the ball alike."""
    return shadowed_floor_and_ball(floor=dict(roughness=0.3, metallic=float(metallic)),
                                   ball=dict(metallic=float(metallic)))


@pytest.mark.parametrize("model, metallic", [("ggx_correlated", "0.5"), ("lambert", "0.5"), ("burley", "0.5"),
                                             ("ggx_correlated", "0.0"), ("cook_torrance", "0.0")])
def test_uniform_channels_are_compiled_in(runtime, model, metallic):
    """Roughness and metallic with one value on every face (floor and ball alike) are
    compiled in: the variant reads neither channel, and its image equals the general
    kernel's, which reads both per pixel. Metallic 0 takes make_surface's dielectric
    branch (grey F0, base colour as diffuse colour: kernels/surface.h). Where the values
    differ (SCENE), both are read."""
    frame = prepare_frame(parse_scene(uniform_scene(metallic)))
    features = scene_features(frame.scene, geometry=frame.geometry)
    assert dict(features.uniform) == {"roughness": pytest.approx(0.3), "metallic": pytest.approx(float(metallic))}
    m = BUILT_IN.resolve(model)
    shader = Shader(runtime, frame.gbuffer, frame.scene, frame.camera, frame.shadows)
    variant = shader.variant(m, features)
    assert not {"roughness", "metallic"} & set(variant.channels)
    assert variant.defines()["METALLIC_VALUE"] == f"{metallic}f"
    _close(shader.render(m, features), shader.render(m, replace(features, general=True)))
    varied = prepare_frame(parse_scene(SCENE))
    assert scene_features(varied.scene, geometry=varied.geometry).uniform == ()


def test_uniform_channels_follow_gltf_factors_and_textures():
    """A face with a glTF texture set takes the set's factor, not its scene material's value;
    a metallic-roughness texture makes neither channel uniform."""
    from clshade.render.gbuffer import uniform_channels
    from clshade.render.textures import Texture, TextureSet
    frame = prepare_frame(parse_scene(uniform_scene("0.5")))
    geo, mats = frame.geometry, list(frame.scene.materials.values())
    assert dict(uniform_channels(geo, mats)) == {"roughness": pytest.approx(0.3), "metallic": pytest.approx(0.5)}
    faces = len(geo.face_material)
    half = np.where(np.arange(faces) < faces // 2, 0, -1).astype(np.int32)
    same = replace(geo, face_texture=half, texture_sets=(TextureSet(roughness_factor=0.3, metallic_factor=0.5),))
    assert dict(uniform_channels(same, mats)) == dict(uniform_channels(geo, mats))
    other = replace(geo, face_texture=half, texture_sets=(TextureSet(roughness_factor=0.3, metallic_factor=1.0),))
    assert dict(uniform_channels(other, mats)) == {"roughness": pytest.approx(0.3)}
    huge = replace(geo, face_texture=np.zeros(faces, np.int32),
                   texture_sets=(TextureSet(roughness_factor=1e39, metallic_factor=-2.0),))
    assert dict(uniform_channels(huge, mats)) == {"roughness": 1.0, "metallic": 0.0}   # saturated, as per pixel
    image = Texture.from_pixels(np.ones((4, 4, 3), np.float32))
    mapped = replace(geo, face_texture=half, texture_sets=(TextureSet(roughness_factor=0.3, metallic_factor=0.5,
                                                                      metallic_roughness=image),))
    assert uniform_channels(mapped, mats) == ()


@pytest.mark.parametrize("scene_name", ["sphere_grid.toml", "textured.toml"])
def test_gbuffer_normals_are_unit_or_zero(scene_name):
    """build_gbuffer's contract behind UNIT_NORMALS: every covered normal (interpolated, or
    from a normal map in textured.toml) is unit to float32 rounding, or exactly zero."""
    from clshade.resources import scenes_dir
    from clshade.render.scene import load_scene
    frame = prepare_frame(load_scene(scenes_dir() / scene_name), 160, 96)
    gb = frame.gbuffer
    assert gb.unit_normals
    n = np.asarray(gb.channels["normal"], np.float64).reshape(-1, 3)[gb.channels["depth"] > 0]
    len2 = np.sum(n * n, axis=1)
    assert len(n) and np.all((np.abs(len2 - 1.0) <= 8 * 2.0 ** -23) | (len2 == 0.0)), np.abs(len2 - 1.0).max()


def test_unit_normals_only_where_the_gbuffer_promises_them(runtime, frame):
    """Frame G-buffers compile UNIT_NORMALS in (general kernel too); a hand-made G-buffer and
    the half-float one normalise in the kernel."""
    from clshade.render.gbuffer import GBuffer
    m = BUILT_IN.resolve("ggx_correlated")
    features = scene_features(frame.scene, geometry=frame.geometry)
    own = Shader(runtime, frame.gbuffer, frame.scene, frame.camera, frame.shadows)
    assert own.variant(m, features).defines().get("UNIT_NORMALS") == "1"
    assert own.variant(m, replace(features, general=True)).defines().get("UNIT_NORMALS") == "1"
    assert "UNIT_NORMALS" not in own.variant(m, replace(features, half_gbuffer=True)).defines()
    gb = frame.gbuffer
    by_hand = GBuffer(gb.width, gb.height, dict(gb.channels), gb.materials, gb.coverage)
    other = Shader(runtime, by_hand, frame.scene, frame.camera, frame.shadows)
    assert "UNIT_NORMALS" not in other.variant(m, features).defines()

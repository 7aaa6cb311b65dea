"""Textured meshes on the device G-buffer path (kernels/visibility.cl, kernel `texture`): the
G-buffer setup_view + DeviceGBuffer.build makes equals rasterize_mesh + build_gbuffer's on the
project's textured scene and Khronos' glTF samples (base colour, metallic-roughness, normal,
emissive and occlusion maps), over orbit cameras, plane by plane: bit for bit, except that the
textured channels of at most TEXTURE_DIFFER_SHARE of the pixels may differ by TEXTURE_TOLERANCE
(the mip level's last bits). verify() finds a broken texture upload (a wrong mip level, swapped
channels)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from clshade.device.runtime import get_runtime
from clshade.device.visibility import (TEXTURE_DIFFER_SHARE, TEXTURE_TOLERANCE, TEXTURED_CHANNELS, DeviceGBuffer,
                                       plane_differences, refusal, supports, verify)
from clshade.render.gbuffer import build_gbuffer, face_planes, material_table
from clshade.render.meshes import build_geometry
from clshade.render.raster import RasterMesh, rasterize_mesh, setup_view
from clshade.render.scene import load_scene, parse_scene
from clshade.render.textures import Texture
from clshade.resources import scenes_dir
from clshade.view.session import Orbit
from scene_toml import camera, light, material, obj, render, scene

W, H = 192, 108


def usable(runtime, geometry):
    reason = refusal(runtime, geometry)
    if reason is not None:
        pytest.skip(f"{runtime.info.description}: {reason} (the host rasterizes)")
    return runtime


@pytest.fixture(scope="module")
def textured():
    scene = load_scene(scenes_dir() / "textured.toml")
    return scene, build_geometry(scene)


def gltf_scene(assets: Path, name: str, position: list[float], target: list[float]):
    """Khronos' glTF sample `name` with its own materials, from `position`."""
    path = assets / "gltf" / name / f"{name}.gltf"
    if not path.is_file():
        pytest.skip(f"{path} not present")
    text = scene(camera(position=position, target=target, fov=40.0, near=0.01, width=W, height=H),
                 render(ambient=[0.25, 0.25, 0.28]), light("directional", direction=[-0.6, -0.5, -0.7]),
                 material("gltf", roughness=1.0), obj(mesh=str(path), mesh_material=True, material="gltf"))
    parsed = parse_scene(text)
    return parsed, build_geometry(parsed)


def orbit(scene, azimuth: float, elevation: float | None = None, scale: float = 1.0):
    cam = scene.camera.with_size(W, H)
    o = Orbit.of(cam)
    return dataclasses.replace(cam, position=o.position(azimuth, o.elevation if elevation is None else elevation,
                                                        o.distance * scale))


def host_and_device(scene, geometry, cam, device):
    mesh = RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
    view, proj = cam.view_matrix(), cam.projection_matrix()
    fragments = rasterize_mesh(mesh, view, proj, cam.width, cam.height)
    faces = face_planes(geometry, list(scene.materials.values()))
    expected = build_gbuffer(scene, geometry, fragments, cam, faces=faces)
    got, cover = device.build(setup_view(mesh, view, proj, cam.width, cam.height), material_table(scene))
    return fragments, expected, got, cover


def assert_same(scene, geometry, cam, device):
    """Every plane bit for bit but the textured channels, which differ on at most
    TEXTURE_DIFFER_SHARE of the pixels by at most TEXTURE_TOLERANCE; coverage and the replaced
    pixels exactly."""
    fragments, expected, got, cover = host_and_device(scene, geometry, cam, device)
    assert set(got.channels) == set(expected.channels)
    for name in expected.channels:
        a, b = expected.plane(name), got.plane(name)
        assert a.dtype == b.dtype and a.shape == b.shape, name
        differ = (a.view(f"u{a.itemsize}") != b.view(f"u{b.itemsize}")).any(axis=0)
        if name not in TEXTURED_CHANNELS:
            assert not differ.any(), f"{name}: {int(differ.sum())} pixels differ"
        else:
            assert differ.sum() <= TEXTURE_DIFFER_SHARE * expected.pixels, f"{name}: {int(differ.sum())} pixels differ"
            assert np.abs(a[:, differ].astype(np.float64) - b[:, differ]).max(initial=0.0) <= TEXTURE_TOLERANCE, name
    assert plane_differences(expected, got, textured=True) is None
    np.testing.assert_array_equal(got.coverage, expected.coverage)
    assert got.nonfinite_pixels == expected.nonfinite_pixels
    np.testing.assert_array_equal(np.flatnonzero(cover), fragments.pixels)
    return expected


@pytest.mark.parametrize("azimuth, elevation, scale", [(0.0, None, 1.0), (40.0, None, 1.0), (135.0, 35.0, 1.0),
                                                       (250.0, 5.0, 0.5), (300.0, 70.0, 2.5), (10.0, 2.0, 0.15)])
def test_textured_scene(textured, device_runtime, azimuth, elevation, scale):
    """scenes/textured.toml: the checker floor receding to the horizon (every mip level), the
    bumpy sphere (metallic-roughness and normal maps), the box (base colour and normal maps)."""
    scene, geometry = textured
    device = DeviceGBuffer(usable(device_runtime, geometry), geometry,
                           face_planes(geometry, list(scene.materials.values())))
    expected = assert_same(scene, geometry, orbit(scene, azimuth, elevation, scale), device)
    assert expected.coverage.sum() > 0.2 * expected.pixels


@pytest.mark.parametrize("size", [(12, 10), (16, 8)])
def test_textures_of_any_size_wrap_as_the_hosts(tmp_path, device_runtime, size):
    """A repeated texture (uv_scale 3.5) whose sizes are not powers of two (12×10: levels 12×10, 6×5,
    3×2 wrap by the remainder) and one whose are (16×8: by a mask): texel coordinates past either edge,
    negative ones included, wrap as np.mod does on the host."""
    from PIL import Image
    from conftest import write_scene
    w, h = size
    rng = np.random.default_rng(7)
    Image.fromarray(rng.integers(0, 256, (h, w, 3), dtype=np.uint8)).save(tmp_path / "noise.png")
    text = scene(camera(position=[0.4, 1.6, 1.9], target=[0.0, 0.0, 0.0], fov=50.0, width=W, height=H),
                 light("directional", direction=[-0.3, -1.0, -0.4]),
                 material("noise", base_color=[1.0, 1.0, 1.0], base_color_texture="noise.png", uv_scale=3.5),
                 obj(primitive="plane", size=3.0, material="noise"))
    loaded = load_scene(write_scene(tmp_path, text))
    geometry = build_geometry(loaded)
    device = DeviceGBuffer(usable(device_runtime, geometry), geometry,
                           face_planes(geometry, list(loaded.materials.values())))
    expected = assert_same(loaded, geometry, loaded.camera.with_size(W, H), device)
    assert expected.coverage.sum() > 0.5 * expected.pixels


@pytest.mark.parametrize("lanes", [4, 8])
def test_textured_frames_one_after_another(textured, device_runtime, lanes):
    """One DeviceGBuffer (its textures uploaded once), frame after frame at three sizes; at 97 x 61
    a work-item's pixels straddle rows and the last one the frame's end (kernel `texture` does
    LANES pixels at a time). Both lane widths: 8 runs as two 256-bit halves on a device without
    AVX-512, except where such vectors break the program (Runtime.narrow_target)."""
    scene, geometry = textured
    runtime = usable(device_runtime, geometry)
    if lanes == 8 and runtime.narrow_target:
        pytest.skip(f"{runtime.info.description}: 512-bit vectors break its programs (Runtime.narrow_target)")
    device = DeviceGBuffer(runtime, geometry, face_planes(geometry, list(scene.materials.values())), lanes=lanes)
    assert device.lanes == lanes
    uploaded = device.textures.buffers
    for azimuth, size in ((20.0, (W, H)), (80.0, (96, 54)), (300.0, (97, 61)), (160.0, (W, H))):
        assert_same(scene, geometry, orbit(scene, azimuth).with_size(*size), device)
    assert device.textures.buffers is uploaded
    distinct = {id(t): t for s in geometry.texture_sets for _, t in s.images if t is not None}
    assert device.textures.nbytes == 4 * sum(level.size for t in distinct.values() for level in t.levels)


def test_textured_bad_normals(textured, device_runtime):
    """Corner normals that are NaN or infinite on textured faces: the pixels are replaced and
    counted as on the host, and keep their textured roughness and metallic."""
    scene, geometry = textured
    normals = geometry.normals.copy()
    rng = np.random.default_rng(3)
    for value in (np.nan, np.inf, 0.0):
        normals[rng.choice(len(normals), len(normals) // 20, replace=False)] = value
    bad = dataclasses.replace(geometry, normals=normals)
    device = DeviceGBuffer(usable(device_runtime, bad), bad, face_planes(bad, list(scene.materials.values())))
    expected = assert_same(scene, bad, orbit(scene, 30.0), device)
    assert expected.nonfinite_pixels > 0


def test_nonfinite_uvs_read_inside_the_texture(textured, device_runtime):
    """Texture coordinates that are NaN or infinite (build_geometry refuses them in mesh files; a
    Geometry made otherwise can hold them) read texel 0 on the device, never memory outside the
    level: the frame completes, their pixels are non-finite inputs, replaced and counted as
    `visibility` does, and every other covered pixel's channels are finite."""
    scene, geometry = textured
    uvs = geometry.uvs.copy()
    rng = np.random.default_rng(5)
    for value in (np.nan, np.inf, -np.inf):
        uvs[rng.choice(len(uvs), len(uvs) // 10, replace=False), rng.integers(0, 2)] = value
    bad = dataclasses.replace(geometry, uvs=uvs)
    device = DeviceGBuffer(usable(device_runtime, bad), bad, face_planes(bad, list(scene.materials.values())))
    cam = orbit(scene, 30.0)
    mesh = RasterMesh(bad.vertices, bad.faces, bad.cull)
    got, cover = device.build(setup_view(mesh, cam.view_matrix(), cam.projection_matrix(), W, H),
                              material_table(scene))
    covered = got.coverage.reshape(-1)
    assert covered.sum() > 0.02 * got.pixels and got.nonfinite_pixels > 0.1 * got.pixels
    assert got.nonfinite_pixels == int(np.count_nonzero(cover[:got.pixels] == 2))
    for name in got.channels:
        assert np.isfinite(got.plane(name)[:, covered]).all(), name
    replaced = cover[:got.pixels] == 2
    assert not got.plane("base")[:, replaced].any() and not got.plane("normal")[:, replaced].any()


@pytest.mark.parametrize("name, position, target", [
    ("WaterBottle", [0.12, 0.06, 0.42], [0.0, 0.0, 0.0]),
    ("Avocado", [0.05, 0.09, 0.12], [0.0, 0.03, 0.0])])
@pytest.mark.parametrize("azimuth", [0.0, 100.0, 220.0])
def test_gltf_samples(assets, device_runtime, name, position, target, azimuth):
    """Khronos' samples with their own textures (WaterBottle: emissive and occlusion too)."""
    scene, geometry = gltf_scene(assets, name, position, target)
    device = DeviceGBuffer(usable(device_runtime, geometry), geometry,
                           face_planes(geometry, list(scene.materials.values())))
    expected = assert_same(scene, geometry, orbit(scene, azimuth), device)
    assert expected.coverage.sum() > 1000
    if name == "WaterBottle":
        assert {"emissive", "occlusion"} <= set(expected.channels)


def test_verify_accepts_textured_and_finds_a_broken_upload(textured):
    """verify passes the device's textured frame, and names the channel a broken upload changes:
    every texture read one mip level too coarse, the texels' red and blue swapped."""
    scene, geometry = textured
    runtime = usable(get_runtime(None), geometry)
    mesh = RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
    faces = face_planes(geometry, list(scene.materials.values()))
    cam = orbit(scene, 30.0)
    device = DeviceGBuffer(runtime, geometry, faces)
    assert verify(device, scene, geometry, mesh, cam, faces) is None
    tables = device.textures.buffers
    info = np.array([(first + 1, levels - 1, w, h) for first, levels, w, h in _read(runtime, tables[4], np.int32, 4)],
                    np.int32)
    device.textures.buffers = [*tables[:4], runtime.to_device(info), *tables[5:]]
    why = verify(device, scene, geometry, mesh, cam, faces)
    assert why is not None and "differ from the host's in normal" in why       # the first textured channel
    texels = _read(runtime, tables[6], np.float32, 3)[:, ::-1]
    device.textures.buffers = [*tables[:6], runtime.to_device(np.ascontiguousarray(texels))]
    why = verify(device, scene, geometry, mesh, cam, faces)
    assert why is not None and "differ from the host's in" in why


def _read(runtime, buffer, dtype, columns: int) -> np.ndarray:
    out = np.empty(buffer.size // np.dtype(dtype).itemsize, dtype)
    runtime.cl.enqueue_copy(runtime.queue, out, buffer)
    return out.reshape(-1, columns)


def test_textures_that_are_not_rgb_keep_the_host_path(textured):
    """A one-channel texture (Texture.from_pixels of a 2-D array): the kernel samples RGB only."""
    scene, geometry = textured
    runtime = get_runtime(None)
    usable(runtime, geometry)
    grey = Texture.from_pixels(np.full((4, 4), 0.5, np.float32), "grey")
    sets = tuple(dataclasses.replace(t, base_color=grey) for t in geometry.texture_sets)
    assert not supports(runtime, dataclasses.replace(geometry, texture_sets=sets))
    with pytest.raises(ValueError, match="textures that are not RGB"):
        DeviceGBuffer(runtime, dataclasses.replace(geometry, texture_sets=sets),
                      face_planes(geometry, list(scene.materials.values())))


def test_more_texels_than_32_bit_indices_keep_the_host_path(textured, monkeypatch):
    """Kernel `texture` indexes texel floats with 32-bit integers: a geometry whose textures hold
    MAX_TEXEL_FLOATS or more keeps the host path (the limit lowered to the scene's own count)."""
    from clshade.device import visibility
    scene, geometry = textured
    runtime = usable(get_runtime(None), geometry)
    floats = visibility.texel_floats(visibility.distinct_textures(geometry.texture_sets))
    assert floats > 0
    monkeypatch.setattr(visibility, "MAX_TEXEL_FLOATS", floats + 1)
    assert supports(runtime, geometry)
    monkeypatch.setattr(visibility, "MAX_TEXEL_FLOATS", floats)
    assert not supports(runtime, geometry)
    assert f"textures of {floats} texel floats" in visibility.refusal(runtime, geometry)


def _fake_runtime(extensions, largest_buffer=1 << 40):
    """What `refusal` reads of a runtime: its extensions, its largest allocation, its name."""
    from types import SimpleNamespace
    return SimpleNamespace(device=SimpleNamespace(extensions=" ".join(extensions), max_mem_alloc_size=largest_buffer),
                           info=SimpleNamespace(runtime="Fake CL 9.9"))


def test_refusal_names_what_the_device_lacks(textured):
    """Without a device: the doubles or the atomics missing are named; with them, the untextured robot
    and the textured scene are served, until the textures outgrow the device's largest buffer or the
    geometry lacks its UVs or tangents."""
    from clshade.device import visibility
    scene, geometry = textured
    robot = build_geometry(load_scene(scenes_dir() / "robot.toml"))
    every = visibility.EXTENSIONS
    assert visibility.refusal(_fake_runtime(every), robot) is None
    assert visibility.refusal(_fake_runtime(every), geometry) is None
    for missing in every:
        got = visibility.refusal(_fake_runtime([e for e in every if e != missing]), robot)
        assert got == f"Fake CL 9.9 lacks {missing}", got
    floats = visibility.texel_floats(visibility.distinct_textures(geometry.texture_sets))
    assert visibility.refusal(_fake_runtime(every, 4 * floats), geometry) is None
    got = visibility.refusal(_fake_runtime(every, 4 * floats - 1), geometry)
    assert got is not None and "more than the device's largest buffer" in got, got
    for lacking in ("uvs", "tangents"):
        got = visibility.refusal(_fake_runtime(every), dataclasses.replace(geometry, **{lacking: None}))
        assert got == f"textured faces without {lacking}", got


def test_a_textured_view_needs_its_matrices(textured):
    """Refused before any kernel runs: the next frame on the same device (its key buffer, its
    staged inputs) is still the host's."""
    scene, geometry = textured
    runtime = usable(get_runtime(None), geometry)
    faces = face_planes(geometry, list(scene.materials.values()))
    device = DeviceGBuffer(runtime, geometry, faces)
    cam = orbit(scene, 0.0)
    mesh = RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
    setup = setup_view(mesh, cam.view_matrix(), cam.projection_matrix(), W, H)
    with pytest.raises(ValueError, match="mvp"):
        device.build(dataclasses.replace(setup, mvp=None), material_table(scene))
    assert_same(scene, geometry, orbit(scene, 40.0, 60.0), device)


def test_the_viewer_orbits_a_textured_scene_on_the_device(tmp_path):
    """The live viewer takes the device path for textured.toml (supports and verify pass) and
    shows the frames of a session that rasterizes on the host: orbit, a slider, a close view."""
    from clshade.view.controls import parse_controls
    from clshade.view.session import DEVICE_GBUFFER_STAGE, ViewSession
    path = scenes_dir() / "textured.toml"
    device, host = ViewSession(path, tmp_path, 96, 64), ViewSession(path, tmp_path, 96, 64, device_gbuffer=False)
    usable(device.runtime, build_geometry(load_scene(path)))
    states = [{}, dict(materials={"bumpy": {"roughness": 0.5}}), dict(azimuth=40.0), dict(azimuth=95.0, distance=3.0)]
    for state in states:
        d, h = (s.render(parse_controls(dict(s.initial_controls(), **state), s.limits)) for s in (device, host))
        assert device.device_gbuffer_off is None
        assert DEVICE_GBUFFER_STAGE in d.stages and DEVICE_GBUFFER_STAGE not in h.stages or "materials" in state
        for view in h.views:    # RGBA8: a pixel within TEXTURE_TOLERANCE may round to the next code
            differ = np.abs(d.views[view].astype(int) - h.views[view]).max(axis=-1)
            assert differ.max() <= 1 and np.count_nonzero(differ) <= TEXTURE_DIFFER_SHARE * differ.size, view

"""The visibility buffer and the G-buffer the device makes from a view's triangle setup
(kernels/visibility.cl) are the host path's, bit for bit: setup_view + DeviceGBuffer.build against
rasterize_mesh + build_gbuffer, over orbit cameras (near-plane clipping included), frame after frame
on one key buffer, an orthographic camera, emission, and normals that are zero, NaN or infinite."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from clshade.device.runtime import get_runtime
from clshade.device.visibility import DeviceGBuffer, supports
from clshade.render.arrays import PlanePool
from clshade.render.gbuffer import build_gbuffer, face_planes, material_table
from clshade.render.meshes import build_geometry
from clshade.render.raster import RasterMesh, rasterize_mesh, setup_view
from clshade.render.scene import load_scene
from clshade.resources import scenes_dir
from clshade.view.session import Orbit

W, H = 192, 108


@pytest.fixture(scope="module")
def robot():
    scene = load_scene(scenes_dir() / "robot.toml")
    return scene, build_geometry(scene)


def assert_same(scene, geometry, view, proj, camera, pool=None, device=None):
    """The device G-buffer of one view equals build_gbuffer's, plane by plane and bit for bit."""
    mesh = RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
    fragments = rasterize_mesh(mesh, view, proj, W, H)
    setup = setup_view(mesh, view, proj, W, H)
    mats = list(scene.materials.values())
    faces = face_planes(geometry, mats)
    expected = build_gbuffer(scene, geometry, fragments, camera, faces=faces)
    device = device or DeviceGBuffer(get_runtime(None), geometry, faces)
    got, cover = device.build(setup, material_table(scene), pool)
    assert set(got.channels) == set(expected.channels)
    for name in expected.channels:
        a, b = expected.plane(name), got.plane(name)
        assert a.dtype == b.dtype and a.shape == b.shape, name
        differ = (a.view(np.uint8) != b.view(np.uint8)).reshape(a.shape[0], -1).any(axis=0)
        assert not differ.any(), f"{name}: {int(differ.sum())} pixels differ, first {np.flatnonzero(differ)[:5]}"
    np.testing.assert_array_equal(got.coverage, expected.coverage)
    assert got.nonfinite_pixels == expected.nonfinite_pixels
    np.testing.assert_array_equal(np.flatnonzero(cover), fragments.pixels)
    np.testing.assert_array_equal(got.materials, expected.materials)
    return expected, device


def orbit_camera(scene, azimuth, elevation=None, scale=1.0):
    camera = scene.camera.with_size(W, H)
    orbit = Orbit.of(camera)
    return dataclasses.replace(camera, position=orbit.position(
        azimuth, orbit.elevation if elevation is None else elevation, orbit.distance * scale))


def test_frames_one_after_another_share_one_key_buffer(robot):
    """One DeviceGBuffer, view after view: each frame's keys start empty (the last frame's
    nearer fragments never win in the next), so every G-buffer is the host's."""
    scene, geometry = robot
    device = None
    for azimuth, scale in ((0.0, 0.4), (70.0, 1.0), (200.0, 2.0), (20.0, 0.07)):
        camera = orbit_camera(scene, azimuth, scale=scale)
        _, device = assert_same(scene, geometry, camera.view_matrix(), camera.projection_matrix(), camera,
                                device=device)


@pytest.mark.parametrize("azimuth, elevation, scale", [(0.0, None, 1.0), (33.0, None, 1.0), (137.0, 60.0, 1.0),
                                                       (250.0, -10.0, 0.6), (15.0, None, 0.08), (190.0, 5.0, 0.03)])
def test_device_gbuffer_is_build_gbuffers(robot, azimuth, elevation, scale):
    """Orbit views, the close ones with the camera among the robot's parts (faces clipped at the near plane)."""
    scene, geometry = robot
    camera = orbit_camera(scene, azimuth, elevation, scale)
    expected, _ = assert_same(scene, geometry, camera.view_matrix(), camera.projection_matrix(), camera,
                              PlanePool())
    assert expected.coverage.any()


def test_device_gbuffer_orthographic(robot):
    """A projection whose clip w is not the view depth (the depth is interpolated from the corners'),
    with near and far planes that cut through the scene (fragments beyond them are dropped)."""
    from test_effects import orthographic
    scene, geometry = robot
    camera = orbit_camera(scene, 40.0)
    d = Orbit.of(scene.camera).distance
    for near, far in ((0.5, 40.0), (d - 1.0, d + 1.5)):
        expected, _ = assert_same(scene, geometry, camera.view_matrix(), orthographic(-3.0, 3.0, -1.7, 1.7, near, far),
                                  camera)
        assert expected.coverage.any()


def test_device_gbuffer_far_plane_cuts_the_scene(robot):
    """A perspective camera whose far plane cuts through the robot and the ground."""
    scene, geometry = robot
    camera = dataclasses.replace(orbit_camera(scene, 75.0), far=Orbit.of(scene.camera).distance)
    full = orbit_camera(scene, 75.0)
    expected, _ = assert_same(scene, geometry, camera.view_matrix(), camera.projection_matrix(), camera)
    unclipped = build_gbuffer(scene, geometry, rasterize_mesh(RasterMesh(geometry.vertices, geometry.faces, geometry.cull),
                                                              full.view_matrix(), full.projection_matrix(), W, H), full)
    assert 0 < expected.coverage.sum() < unclipped.coverage.sum()


def test_device_gbuffer_emission_and_bad_normals(robot):
    """An emitting material, and corner normals that are zero, NaN or infinite: the pixels they
    reach are replaced (depth, normal, base colour and emission 0) and counted as on the host."""
    scene, geometry = robot
    name = next(iter(scene.materials))
    materials = dict(scene.materials)
    materials[name] = dataclasses.replace(materials[name], emissive=(2.0, 0.5, 0.25))
    glowing = dataclasses.replace(scene, materials=materials)
    normals = geometry.normals.copy()
    rng = np.random.default_rng(7)
    for value in (0.0, np.nan, np.inf, -np.inf, 3e38):
        normals[rng.choice(len(normals), 400, replace=False)] = value
    bad = dataclasses.replace(geometry, normals=normals, emission=True)
    camera = orbit_camera(scene, 20.0)
    expected, _ = assert_same(glowing, bad, camera.view_matrix(), camera.projection_matrix(), camera)
    assert "emissive" in expected.channels and expected.nonfinite_pixels > 0
    assert (expected.plane("emissive")[0] == np.float32(2.0)).any()
    assert (expected.plane("normal") == 0).all(axis=0).any()           # a zero normal stays zero


def test_planes_from_the_pool_are_written_whole(robot):
    """Planes handed out by the pool hold the last frame's values: every pixel is written (the
    empty ones and the padding with zeros), so a frame from a dirty pool is the host's."""
    scene, geometry = robot
    pool = PlanePool()
    first = orbit_camera(scene, 0.0, scale=0.5)
    _, device = assert_same(scene, geometry, first.view_matrix(), first.projection_matrix(), first, pool)
    for block in pool._blocks:
        block.fill(0x7F)                                # what a frame left there
    wide = orbit_camera(scene, 90.0, scale=1.5)
    assert_same(scene, geometry, wide.view_matrix(), wide.projection_matrix(), wide, pool, device)


def test_textured_geometry_keeps_the_host_path():
    scene = load_scene(scenes_dir() / "textured.toml")
    geometry = build_geometry(scene)
    runtime = get_runtime(None)
    assert geometry.face_texture is not None and not supports(runtime, geometry)
    with pytest.raises(ValueError, match="textured geometry"):
        DeviceGBuffer(runtime, geometry, face_planes(geometry, list(scene.materials.values())))

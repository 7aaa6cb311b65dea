"""The visibility buffer and the G-buffer the device makes from a view's triangle setup
(kernels/visibility.cl) are the host path's, bit for bit: setup_view + DeviceGBuffer.build against
rasterize_mesh + build_gbuffer, over orbit cameras (near-plane clipping included), frame after frame
on one key buffer, an orthographic camera, emission, and normals that are zero, NaN or infinite —
on every healthy device, at 4 and 8 pixels per work-item, and again from the compilers' caches.
The viewer checks the device on a small frame first (verify) and keeps the host path where it differs."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from clshade.device import visibility
from clshade.device.runtime import Runtime, get_runtime
from clshade.device.visibility import DeviceGBuffer, supports, verify
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


def assert_same(scene, geometry, view, proj, camera, pool=None, device=None, runtime=None, lanes=None):
    """The device G-buffer of one view (on `runtime`, default the default device) equals
    build_gbuffer's, plane by plane and bit for bit."""
    mesh = RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
    fragments = rasterize_mesh(mesh, view, proj, W, H)
    setup = setup_view(mesh, view, proj, W, H)
    mats = list(scene.materials.values())
    faces = face_planes(geometry, mats)
    expected = build_gbuffer(scene, geometry, fragments, camera, faces=faces)
    device = device or DeviceGBuffer(usable(runtime or get_runtime(None), geometry), geometry, faces, lanes)
    got, cover = device.build(setup, material_table(scene), pool)
    assert set(got.channels) == set(expected.channels)
    for name in expected.channels:
        a, b = expected.plane(name), got.plane(name)
        assert a.dtype == b.dtype and a.shape == b.shape, name
        differ = (a.view(f"u{a.itemsize}") != b.view(f"u{b.itemsize}")).any(axis=0)     # bit patterns, per pixel
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


def usable(runtime, geometry) -> Runtime:
    if not supports(runtime, geometry):
        pytest.skip(f"{runtime.info.description}: no doubles or 64-bit atomics (the viewer rasterizes on the host)")
    return runtime


@pytest.mark.parametrize("lanes", [4, 8])
def test_frames_one_after_another_share_one_key_buffer(robot, device_runtime, lanes):
    """One DeviceGBuffer, view after view: each frame's keys start empty (the last frame's
    nearer fragments never win in the next), so every G-buffer is the host's — at both lane
    widths the kernel has (8, the default only where the device compiles 512-bit vectors, runs as
    two 256-bit halves elsewhere, except where such vectors break the program: Runtime.narrow_target)."""
    scene, geometry = robot
    runtime = usable(device_runtime, geometry)
    if lanes == 8 and runtime.narrow_target:
        pytest.skip(f"{runtime.info.description}: 512-bit vectors break its programs (Runtime.narrow_target)")
    device = None
    for azimuth, scale in ((0.0, 0.4), (70.0, 1.0), (200.0, 2.0), (20.0, 0.07)):
        camera = orbit_camera(scene, azimuth, scale=scale)
        _, device = assert_same(scene, geometry, camera.view_matrix(), camera.projection_matrix(), camera,
                                device=device, runtime=runtime, lanes=lanes)
    assert device.lanes == lanes


def test_a_frame_refused_part_way_leaves_the_next_frames_the_hosts(robot, device_runtime):
    """A frame whose triangle setup is refused after kernel `cover` has written its keys (a staging slot
    over the memory budget, say) raises; the frames after it on the same DeviceGBuffer, whose key buffer
    only the visibility kernel empties, are still the host's."""
    from clshade.errors import ClshadeError
    scene, geometry = robot
    runtime = usable(device_runtime, geometry)
    camera = orbit_camera(scene, 0.0)
    _, device = assert_same(scene, geometry, camera.view_matrix(), camera.projection_matrix(), camera,
                            runtime=runtime)
    upload = device._staging.upload

    def refused(slot, array):
        if slot == "setup":
            raise ClshadeError("the staging buffer for 'setup' needs more memory than is available")
        return upload(slot, array)

    near = orbit_camera(scene, 0.0, scale=0.3)         # large triangles: exclusive and batched cover
    mesh = RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
    device._staging.upload = refused
    with pytest.raises(ClshadeError, match="staging buffer for 'setup'"):
        device.build(setup_view(mesh, near.view_matrix(), near.projection_matrix(), W, H), material_table(scene))
    device._staging.upload = upload
    for azimuth, scale in ((90.0, 2.0), (0.0, 1.0)):
        camera = orbit_camera(scene, azimuth, scale=scale)
        assert_same(scene, geometry, camera.view_matrix(), camera.projection_matrix(), camera, device=device)


def test_the_program_builds_again_from_the_caches(robot, device_runtime):
    """New runtimes on the same device build the program again, from PoCL's kernel cache and
    clshade's binary cache, and it still has its kernels and makes the host's G-buffer. (double8
    on pip's PoCL 3.0 on an AVX-512 host: the first build ran, the cached one listed no kernels.)"""
    scene, geometry = robot
    usable(device_runtime, geometry)
    mesh = RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
    faces = face_planes(geometry, list(scene.materials.values()))
    camera = orbit_camera(scene, 30.0)
    for _ in range(2):
        runtime = Runtime(device_runtime.info.spec)
        assert verify(DeviceGBuffer(runtime, geometry, faces), scene, geometry, mesh, camera, faces) is None


def test_lanes_follow_what_the_device_compiles():
    """8 doubles per vector only where the device's native double width is 8 and PoCL's target
    has AVX-512; pip's PoCL 3.0 reports AVX-512 widths but compiles for a CPU name without it."""
    from types import SimpleNamespace as NS

    def lanes(platform, name, floats, doubles):
        fake = NS(device=NS(native_vector_width_float=floats, native_vector_width_double=doubles),
                  info=NS(platform_version=platform, device=name))
        fake.narrow_target = Runtime.narrow_target.fget(fake)
        return Runtime.double_lanes.fget(fake)

    assert lanes("OpenCL 3.0 PoCL 3.1+debian", "pthread-skylake-avx512-AMD EPYC", 16, 8) == 8
    assert lanes("OpenCL 3.0 PoCL 3.0-rc2", "pthread-AMD EPYC", 16, 8) == 4
    assert lanes("OpenCL 3.0 PoCL 3.0-rc2", "pthread-haswell", 8, 4) == 4
    assert lanes("OpenCL 3.1 LINUX", "AMD EPYC 9R14", 16, 8) == 8
    assert lanes("OpenCL 3.0 CUDA", "NVIDIA H100", 1, 1) == 4


def checked(robot) -> tuple:
    """verify's arguments for the robot seen from 30°: (a DeviceGBuffer on the default device, scene,
    geometry, raster mesh, camera, face tables)."""
    scene, geometry = robot
    runtime = usable(get_runtime(None), geometry)
    mesh = RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
    faces = face_planes(geometry, list(scene.materials.values()))
    return DeviceGBuffer(runtime, geometry, faces), scene, geometry, mesh, orbit_camera(scene, 30.0), faces


def test_verify_finds_a_device_that_differs(robot, monkeypatch):
    """verify compares the device's small frame with the host's and names what differs: face
    tables of other materials (the roughness), a pixel dropped from the coverage."""
    device, scene, geometry, mesh, camera, faces = checked(robot)
    assert verify(device, scene, geometry, mesh, camera, faces) is None
    rougher = dict(faces, roughness=np.minimum(faces["roughness"] + 0.125, 1.0))
    why = verify(DeviceGBuffer(device.rt, geometry, rougher), scene, geometry, mesh, camera, faces)
    assert why is not None and "in roughness" in why
    build = device.build

    def dropped(*args, **kwargs):
        gbuffer, cover = build(*args, **kwargs)
        cover[np.flatnonzero(cover == 0)[0]] = 1        # one more pixel said to be covered
        return gbuffer, cover
    monkeypatch.setattr(device, "build", dropped)
    assert verify(device, scene, geometry, mesh, camera, faces) == "the covered pixels differ from the host's"


def test_verify_covers_the_largest_triangles_alone_too(robot, monkeypatch):
    """verify's small frame has no triangle of EXCLUSIVE_MIN_TILES tiles (a full frame's floors and walls
    have), so it builds that frame again with its largest triangles covered alone: a device whose
    exclusive dispatches are lost is caught, and the reason names that pass."""
    device, scene, geometry, mesh, camera, faces = checked(robot)
    cover, dispatched = device._cover, []

    def lost_alone(count, ntri, width, view, first, exclusive, *rest):
        dispatched.append(exclusive)
        if not exclusive:
            cover(count, ntri, width, view, first, exclusive, *rest)
    monkeypatch.setattr(device, "_cover", lost_alone)
    why = verify(device, scene, geometry, mesh, camera, faces)
    assert why is not None and why.endswith("(its largest triangles covered alone)"), why
    assert dispatched.count(1) == visibility.EXCLUSIVE_MAX
    monkeypatch.setattr(device, "_cover", cover)
    assert verify(device, scene, geometry, mesh, camera, faces) is None


@pytest.mark.parametrize("azimuth, elevation, scale", [(0.0, None, 1.0), (33.0, None, 1.0), (137.0, 60.0, 1.0),
                                                       (250.0, -10.0, 0.6), (15.0, None, 0.08), (190.0, 5.0, 0.03)])
def test_device_gbuffer_is_build_gbuffers(robot, device_runtime, azimuth, elevation, scale):
    """Orbit views, the close ones with the camera among the robot's parts (faces clipped at the near plane)."""
    scene, geometry = robot
    camera = orbit_camera(scene, azimuth, elevation, scale)
    expected, _ = assert_same(scene, geometry, camera.view_matrix(), camera.projection_matrix(), camera,
                              PlanePool(), runtime=device_runtime)
    assert expected.coverage.any()


@pytest.mark.parametrize("limit", [1, 37, 4096])
def test_cover_in_batches_is_the_single_dispatch(robot, device_runtime, monkeypatch, limit):
    """Kernel `cover` dispatched over triangle batches of at most `limit` (triangle, tile) pairs
    (one triangle a batch at 1, batches cutting through the list elsewhere) still makes the host's
    G-buffer bit for bit: each batch's tiles are counted from its first triangle."""
    import clshade.device.visibility as visibility
    monkeypatch.setattr(visibility, "COVER_BATCH_TILES", limit)
    scene, geometry = robot
    camera = orbit_camera(scene, 33.0, scale=0.6)
    expected, _ = assert_same(scene, geometry, camera.view_matrix(), camera.projection_matrix(), camera,
                              runtime=device_runtime)
    assert expected.coverage.any()


def test_cover_batches_split_whole_triangles_within_the_limit():
    from clshade.device.visibility import cover_batches
    tiles = np.array([3, 1, 5, 2, 2, 9, 1])
    end = np.cumsum(tiles)
    for limit in (1, 2, 3, 4, 6, 9, 10, 100):
        batches = cover_batches(end, limit)
        assert [a for a, _, _ in batches] == [0] + [b for _, b, _ in batches[:-1]] and batches[-1][1] == len(tiles)
        for a, b, base in batches:
            assert base == tiles[:a].sum()
            assert tiles[a:b].sum() <= limit or b - a == 1
            # Greedy: the next triangle would not have fitted.
            assert b == len(tiles) or tiles[a:b + 1].sum() > limit
    assert cover_batches(end[:0], 4) == []


def test_device_gbuffer_orthographic(robot, device_runtime):
    """A projection whose clip w is not the view depth (the depth is interpolated from the corners'),
    with near and far planes that cut through the scene (fragments beyond them are dropped)."""
    from clshade.render.transforms import orthographic
    scene, geometry = robot
    camera = orbit_camera(scene, 40.0)
    d = Orbit.of(scene.camera).distance
    for near, far in ((0.5, 40.0), (d - 1.0, d + 1.5)):
        expected, _ = assert_same(scene, geometry, camera.view_matrix(), orthographic(-3.0, 3.0, -1.7, 1.7, near, far),
                                  camera, runtime=device_runtime)
        assert expected.coverage.any()


def test_device_gbuffer_far_plane_cuts_the_scene(robot, device_runtime):
    """A perspective camera whose far plane cuts through the robot and the ground."""
    scene, geometry = robot
    camera = dataclasses.replace(orbit_camera(scene, 75.0), far=Orbit.of(scene.camera).distance)
    full = orbit_camera(scene, 75.0)
    expected, _ = assert_same(scene, geometry, camera.view_matrix(), camera.projection_matrix(), camera,
                              runtime=device_runtime)
    unclipped = build_gbuffer(scene, geometry, rasterize_mesh(RasterMesh(geometry.vertices, geometry.faces, geometry.cull),
                                                              full.view_matrix(), full.projection_matrix(), W, H), full)
    assert 0 < expected.coverage.sum() < unclipped.coverage.sum()


def test_device_gbuffer_emission_and_bad_normals(robot, device_runtime):
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
    expected, _ = assert_same(glowing, bad, camera.view_matrix(), camera.projection_matrix(), camera,
                              runtime=device_runtime)
    assert "emissive" in expected.channels and expected.nonfinite_pixels > 0
    assert (expected.plane("emissive")[0] == np.float32(2.0)).any()
    assert (expected.plane("normal") == 0).all(axis=0).any()           # a zero normal stays zero


def test_planes_from_the_pool_are_written_whole(robot, device_runtime):
    """Planes handed out by the pool hold the last frame's values: every pixel is written (the
    empty ones and the padding with zeros), so a frame from a dirty pool is the host's."""
    scene, geometry = robot
    pool = PlanePool()
    first = orbit_camera(scene, 0.0, scale=0.5)
    _, device = assert_same(scene, geometry, first.view_matrix(), first.projection_matrix(), first, pool,
                            runtime=device_runtime)
    for block in pool._blocks:
        block.fill(0x7F)                                # what a frame left there
    wide = orbit_camera(scene, 90.0, scale=1.5)
    assert_same(scene, geometry, wide.view_matrix(), wide.projection_matrix(), wide, pool, device,
                runtime=device_runtime)



def coplanar_layers(tmp_path):
    """Three coplanar floors (red first, then a sphere of 1280 faces, then green and blue at the same place,
    in that face order) seen from above, and a sphere of 320 faces last (winners of the last indices): the
    floors' fragments tie in depth, and rasterize_mesh's merge decides."""
    from conftest import write_scene
    from scene_toml import camera, material, obj, scene
    floor = dict(primitive="plane", size=2.0)
    text = scene(camera(position=[0.3, 3.0, 1.2], target=[0.0, 0.0, 0.0], fov=50.0, width=64, height=48),
                 material("red", base_color=[1.0, 0.0, 0.0]), material("green", base_color=[0.0, 1.0, 0.0]),
                 material("blue", base_color=[0.0, 0.0, 1.0]), material("grey"),
                 obj(material="red", **floor), obj(primitive="sphere", subdivisions=3, radius=0.5,
                                                   translate=[0.2, 0.3, 0.0], material="grey"),
                 obj(material="green", **floor), obj(material="blue", **floor),
                 obj(primitive="sphere", subdivisions=2, radius=0.3, translate=[-0.5, 0.3, 0.3], material="grey"))
    loaded = load_scene(write_scene(tmp_path, text))
    return loaded, build_geometry(loaded)


# Face batches of 256 and 512 (FACE_BATCH monkeypatched): the smallest whose depth quantisation is exact in
# float64, as the default's is (key_layout: 2^(62 - tri_bits) - 1 below 2^53).
@pytest.mark.parametrize("face_batch", [256, 512])
def test_several_face_batches_resolve_as_the_hosts_merge(tmp_path, device_runtime, monkeypatch, face_batch):
    """A mesh of several face batches in one device pass: its batches' triangles joined in order, keys of the
    batches' depth quantisation with an index over all of them. At depth ties the host keeps the earlier
    batch's fragment, and in a batch the lower index: the red floor (batch 0) over green and blue (the last
    batch), everywhere the sphere leaves it visible; and the G-buffer is the host's bit for bit, with more
    set-up triangles than one batch's keys number at 256 faces a batch."""
    from clshade.render.raster import batches
    from clshade.render.raster.resolve import key_layout
    monkeypatch.setattr(batches, "FACE_BATCH", face_batch)
    scene, geometry = coplanar_layers(tmp_path)
    camera = scene.camera.with_size(W, H)
    view, proj = camera.view_matrix(), camera.projection_matrix()
    mesh = RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
    setup = setup_view(mesh, view, proj, W, H)
    assert setup is not None and len(geometry.faces) > 2 * face_batch       # three batches or more
    if face_batch == 256:                       # the last sphere's triangles are numbered past 2^tri_bits
        assert len(setup.tris.face) > (1 << key_layout(face_batch)[0]) + 100
    expected, _ = assert_same(scene, geometry, view, proj, camera, runtime=device_runtime)
    base = expected.plane("base").reshape(3, -1)[:, :W * H][:, expected.coverage.reshape(-1)]
    assert (base[0] == 1.0).sum() > 1000 and not (base[1] == 1.0).any() and not (base[2] == 1.0).any()


@pytest.mark.parametrize("min_tiles, most", [(1, 8), (1, 100_000), (4, 3)])
def test_triangles_covered_alone_resolve_as_the_hosts_merge(tmp_path, device_runtime, monkeypatch, min_tiles, most):
    """Kernel `cover`'s exclusive dispatches (the largest triangles, each alone, before the rest; at
    (1, 100000) every triangle alone) keep the least key as the atomic pass does: the coplanar floors'
    depth ties still go to the red floor (the lowest index), whichever floor's triangle ran first."""
    import clshade.device.visibility as visibility
    monkeypatch.setattr(visibility, "EXCLUSIVE_MIN_TILES", min_tiles)
    monkeypatch.setattr(visibility, "EXCLUSIVE_MAX", most)
    scene, geometry = coplanar_layers(tmp_path)
    camera = scene.camera.with_size(W, H)
    expected, _ = assert_same(scene, geometry, camera.view_matrix(), camera.projection_matrix(), camera,
                              runtime=device_runtime)
    base = expected.plane("base").reshape(3, -1)[:, :W * H][:, expected.coverage.reshape(-1)]
    assert (base[0] == 1.0).sum() > 1000 and not (base[1] == 1.0).any() and not (base[2] == 1.0).any()


def test_exclusive_triangles_are_the_largest_first():
    from clshade.device.visibility import exclusive_triangles
    tiles = np.array([3, 600, 1, 9000, 512, 511, 700])
    assert exclusive_triangles(tiles).tolist() == [3, 6, 1, 4]
    assert exclusive_triangles(tiles, most=2).tolist() == [3, 6]
    assert exclusive_triangles(tiles, min_tiles=1, most=100).tolist() == [3, 6, 1, 4, 5, 0, 2]
    assert exclusive_triangles(tiles[:0]).tolist() == []


def test_a_view_with_more_triangles_than_the_keys_number_is_left_to_the_host(tmp_path, monkeypatch):
    """setup_view refuses a view whose set-up triangles its keys cannot number (view_max_triangles: 1023 at
    256 faces a batch), and takes one that fits."""
    from clshade.render.raster import batches
    from clshade.render.raster.resolve import view_max_triangles
    monkeypatch.setattr(batches, "FACE_BATCH", 256)
    assert view_max_triangles(256) == 1023
    scene, geometry = coplanar_layers(tmp_path)
    camera = scene.camera.with_size(W, H)
    mesh = RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
    assert 1023 >= len(setup_view(mesh, camera.view_matrix(), camera.projection_matrix(), W, H).tris.face) > 512
    doubled = RasterMesh(geometry.vertices, np.concatenate([geometry.faces, geometry.faces[::-1]]),
                         np.concatenate([geometry.cull, geometry.cull[::-1]]))
    assert setup_view(doubled, camera.view_matrix(), camera.projection_matrix(), W, H) is None


def far_plane_fan(count: int):
    """`count` faces: count − 1 small triangles in the left half at z_view = −0.5, the last one over the right
    half at the far plane of an orthographic (0, 0, −1) projection (z_ndc = 1: the deepest key)."""
    from clshade.render.meshes import Geometry
    verts, faces = [], []
    for i in range(count - 1):
        x, y = -0.9 + 0.8 * (i % 32) / 32, -0.9 + 1.8 * (i // 32) / (count // 32 + 1)
        b = len(verts)
        verts += [(x, y, -0.5), (x + 0.1, y, -0.5), (x, y + 0.1, -0.5)]
        faces.append((b, b + 1, b + 2))
    b = len(verts)
    verts += [(0.05, -1.0, -1.0), (1.0, -1.0, -1.0), (1.0, 1.0, -1.0)]
    faces.append((b, b + 1, b + 2))
    verts, faces = np.array(verts, np.float64), np.array(faces, np.int64)
    normals = np.tile(np.array([0.0, 0.0, 1.0], np.float32), (len(verts), 1))
    return Geometry(verts, normals, faces, np.zeros(count, np.int32), np.zeros(count, np.int32),
                    np.zeros(count, bool))


def test_the_last_triangle_at_the_far_plane_is_not_the_empty_key(device_runtime, monkeypatch):
    """At view_max_triangles set-up triangles, the last one's key at the deepest depth stays below EMPTY_KEY:
    the device covers every pixel the host covers (a key equal to it would read as no fragment). One
    triangle more is left to the host."""
    from clshade.render.raster import batches
    from clshade.render.raster.resolve import view_max_triangles
    monkeypatch.setattr(batches, "FACE_BATCH", 256)
    count = view_max_triangles(256)
    view, proj = np.eye(4), np.diag([1.0, 1.0, -1.0, 1.0])
    assert setup_view(RasterMesh(*(lambda g: (g.vertices, g.faces, False))(far_plane_fan(count + 1))),
                      view, proj, 64, 64) is None
    geometry = far_plane_fan(count)
    mesh = RasterMesh(geometry.vertices, geometry.faces, False)
    setup = setup_view(mesh, view, proj, 64, 64)
    assert setup is not None and len(setup.tris.face) == count
    fragments = rasterize_mesh(mesh, view, proj, 64, 64)
    assert (fragments.face == count - 1).sum() > 500

    class Grey:
        base_color, roughness, metallic, emissive = (1.0, 1.0, 1.0), 0.5, 0.0, (0.0, 0.0, 0.0)
    device = DeviceGBuffer(usable(device_runtime, geometry), geometry, face_planes(geometry, [Grey()]))
    _, cover = device.build(setup, np.zeros((1, 8), np.float32))
    np.testing.assert_array_equal(np.flatnonzero(cover[:64 * 64]), fragments.pixels)

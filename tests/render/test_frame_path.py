"""The whole-frame path: the per-pixel stages on worker threads give bit-identical
results to one thread, and the G-buffer's planes reach a CPU device without a copy.

The rasterizer shares its candidate grids out to the workers, each resolving into its
own key array (merged by a minimum), and writes the winners in chunks; the G-buffer
interpolates chunks of covered pixels in parallel (clshade.render.arrays). Small test
frames normally stay on one thread, so the threshold is lowered here.
"""
from __future__ import annotations

import numpy as np
import pytest

from clshade.render import arrays
from clshade.render.raster import batches, tiles, triangles
from clshade.render.gbuffer import build_gbuffer
from clshade.render.meshes import build_geometry
from clshade.render.raster import rasterize
from clshade.render.scene import load_scene

from conftest import SCENES


def frame(scene, geometry, width, height):
    camera = scene.camera.with_size(width, height)
    fragments = rasterize(geometry.vertices, geometry.faces, camera.view_matrix(), camera.projection_matrix(),
                          width, height, cull_backfaces=geometry.cull)
    return fragments, build_gbuffer(scene, geometry, fragments, camera)


@pytest.mark.parametrize("threads", ["2", "3"])
def test_threads_give_the_serial_result(monkeypatch, threads):
    scene = load_scene(SCENES / "robot.toml")
    geometry = build_geometry(scene)
    monkeypatch.setenv("CLSHADE_THREADS", "1")
    serial_f, serial_g = frame(scene, geometry, 200, 150)
    monkeypatch.setenv("CLSHADE_THREADS", threads)
    monkeypatch.setattr(arrays, "PARALLEL_MIN_ITEMS", 1)
    monkeypatch.setattr(batches, "WINNER_CHUNK", 997)        # many winner chunks, odd-sized
    monkeypatch.setattr(batches, "GRID_CHUNK_CELLS", 4096)   # many candidate grids to share out
    monkeypatch.setattr(triangles, "SETUP_PARALLEL_MIN_FACES", 1)
    monkeypatch.setattr(tiles, "COVER_PARALLEL_MIN_CELLS", 1)
    par_f, par_g = frame(scene, geometry, 200, 150)
    # A second view after it: the workers' key arrays are kept between calls and must come back empty.
    import dataclasses
    from clshade.view.session import Orbit
    orbit = Orbit.of(scene.camera)
    turned = dataclasses.replace(scene, camera=dataclasses.replace(
        scene.camera, position=orbit.position(140.0, orbit.elevation, 0.8 * orbit.distance)))
    par2_f, _ = frame(turned, geometry, 200, 150)
    monkeypatch.setenv("CLSHADE_THREADS", "1")
    serial2_f, _ = frame(turned, geometry, 200, 150)
    np.testing.assert_array_equal(par2_f.tri_id, serial2_f.tri_id)
    np.testing.assert_array_equal(par2_f.bary_planes, serial2_f.bary_planes)
    assert serial_f.coverage.sum() > 5000
    np.testing.assert_array_equal(par_f.tri_id, serial_f.tri_id)
    np.testing.assert_array_equal(par_f.depth, serial_f.depth)
    np.testing.assert_array_equal(par_f.bary_planes, serial_f.bary_planes)
    assert set(par_g.channels) == set(serial_g.channels)
    for name in serial_g.channels:
        np.testing.assert_array_equal(par_g.plane(name), serial_g.plane(name), err_msg=name)


def test_thread_setting_is_checked(monkeypatch):
    monkeypatch.setenv("CLSHADE_THREADS", "0")
    with pytest.raises(Exception, match="CLSHADE_THREADS"):
        arrays.worker_count()


def test_chunks_cover_the_range_once():
    for n, parts in ((0, 3), (1, 4), (10, 3), (1000, 7)):
        pieces = arrays.chunks(n, parts)
        covered = np.concatenate([np.arange(n)[p] for p in pieces]) if pieces else np.zeros(0, int)
        np.testing.assert_array_equal(covered, np.arange(n))
        assert len(pieces) <= max(1, parts)


def test_gbuffer_planes_are_shared_with_a_cpu_device(runtime):
    """On a CPU device the shading kernel reads the G-buffer's own (aligned) planes: the device
    buffer's host pointer is the plane's memory, and the render still equals a copied upload."""
    from clshade.device.shade import Shader, scene_features
    from clshade.models.registry import Registry
    resolve = Registry().resolve          # the built-in lobes

    if "cpu" not in runtime.info.kind:
        pytest.skip(f"zero-copy sharing is for CPU devices; this one is {runtime.info.kind}")
    scene = load_scene(SCENES / "robot.toml")
    geometry = build_geometry(scene)
    _, gbuffer = frame(scene, geometry, 64, 48)
    shader = Shader(runtime, gbuffer, scene, scene.camera.with_size(64, 48))
    buffer = shader.buffer("normal")
    assert all(gbuffer.plane(name).ctypes.data % runtime.base_align == 0 for name in gbuffer.channels)
    plane = gbuffer.plane("normal")
    assert buffer.get_host_array(plane.size, plane.dtype).ctypes.data == plane.ctypes.data
    model, features = resolve("ggx_correlated"), scene_features(scene, geometry=geometry)
    shared = shader.render(model, features)
    copied = Shader(runtime, gbuffer, scene, scene.camera.with_size(64, 48))
    copied._buffers = {key: runtime.to_device(gbuffer.plane(key[0]).reshape(-1))
                       for key in ((c, False) for c in gbuffer.channels)}
    np.testing.assert_array_equal(shared, copied.render(model, features))

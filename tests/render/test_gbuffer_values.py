"""The G-buffer's per-pixel values against a float64 model of what they mean (not against the
code that wrote them): normals are the pixel's barycentric blend of its face's corner normals,
normalised; material channels are the face material's values; a face with zero normals gives
zero normals (finite, covered), not NaN."""
from __future__ import annotations

import numpy as np
import pytest

from clshade.render.gbuffer import build_gbuffer
from clshade.render.meshes import build_geometry
from clshade.render.raster import rasterize
from clshade.render.scene import load_scene
from clshade.resources import scenes_dir


@pytest.fixture(scope="module")
def spheres():
    scene = load_scene(scenes_dir() / "sphere_grid.toml")
    geometry = build_geometry(scene)
    camera = scene.camera.with_size(200, 120)
    frags = rasterize(geometry.vertices, geometry.faces, camera.view_matrix(), camera.projection_matrix(),
                      camera.width, camera.height, cull_backfaces=geometry.cull)
    return scene, geometry, camera, frags


def test_normals_are_the_normalised_blend_of_the_corner_normals(spheres):
    scene, geometry, camera, frags = spheres
    gb = build_gbuffer(scene, geometry, frags, camera)
    corners = geometry.normals[geometry.faces[frags.face]].astype(np.float64)        # (K, 3 corners, 3)
    blend = np.einsum("kc,kcd->kd", frags.face_bary.T.astype(np.float64), corners)
    expected = blend / np.linalg.norm(blend, axis=1, keepdims=True)
    got = gb.plane("normal")[:, frags.pixels].T
    assert len(got) > 5000 and gb.nonfinite_pixels == 0
    np.testing.assert_allclose(got, expected, atol=2e-6)
    smooth = np.abs(corners[:, 0] - corners[:, 2]).max(axis=1) > 1e-3                # corner normals differ
    assert smooth.sum() > 1000
    mats = list(scene.materials.values())
    material = geometry.face_material[frags.face]
    np.testing.assert_array_equal(gb.plane("material")[0, frags.pixels], material)
    np.testing.assert_array_equal(gb.plane("roughness")[0, frags.pixels],
                                  np.array([m.roughness for m in mats], np.float32)[material])
    np.testing.assert_array_equal(gb.plane("base")[:, frags.pixels].T,
                                  np.array([m.base_color for m in mats], np.float32)[material])


def test_zero_corner_normals_give_a_zero_normal_not_nan(spheres):
    scene, geometry, camera, frags = spheres
    import dataclasses
    obj = geometry.face_object[frags.face]
    target = int(np.argmax(np.bincount(obj)))                     # the object covering most pixels
    normals = geometry.normals.copy()
    normals[geometry.faces[geometry.face_object == target]] = 0.0
    gb = build_gbuffer(scene, dataclasses.replace(geometry, normals=normals), frags, camera)
    own = frags.pixels[obj == target]
    assert len(own) > 100
    assert gb.nonfinite_pixels == 0 and gb.coverage.reshape(-1)[own].all()
    assert (gb.plane("normal")[:, own] == 0.0).all()

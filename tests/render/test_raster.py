"""Tests of the NumPy rasterizer (clshade.render.raster).

The main oracle is an independent ray caster: rays through the pixel centres
are built by inverting ``proj @ view`` (nothing from the rasterizer is reused)
and cast with trimesh's ``ray.intersects_first`` (Embree when embreex is
installed).  Hit points are recomputed in float64 from the hit triangle's
plane.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from clshade.render.raster import batches, tiles
from clshade.render import transforms
from clshade.render.raster import Fragments, rasterize
from clshade.render.transforms import look_at, pixel_rays

from conftest import ASSETS

W, H = 320, 240
NEAR, FAR = 0.1, 100.0
ID_AGREEMENT = 0.995  # fraction of covered pixels whose triangle ids must match
DEPTH_RTOL = 1e-4  # relative depth tolerance where ids agree


# --------------------------------------------------------------------------
# Camera helpers and the independent ray caster
# --------------------------------------------------------------------------

def perspective(fovy_deg: float, aspect: float, near: float = NEAR, far: float = FAR) -> np.ndarray:
    """gluPerspective with this file's default clip planes."""
    return transforms.perspective(fovy_deg, aspect, near, far)


def unit_perspective(near: float = NEAR, far: float = FAR) -> np.ndarray:
    """90 degree square frustum with exactly representable entries (x_ndc = -x/z)."""
    m = perspective(90.0, 1.0, near, far)
    m[0, 0] = m[1, 1] = 1.0
    return m


def ray_cast(vertices, faces, view, proj, width=W, height=H):
    """First-hit triangle id, view depth and hit point per pixel (ray caster)."""
    mesh = trimesh.Trimesh(np.asarray(vertices, float), np.asarray(faces), process=False)
    origins, dirs = pixel_rays(view, proj, width, height)
    ids = mesh.ray.intersects_first(origins, dirs)
    hit = ids >= 0
    tri = mesh.vertices[mesh.faces[ids[hit]]]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    t = np.einsum("ij,ij->i", n, tri[:, 0] - origins[hit]) / np.einsum("ij,ij->i", n, dirs[hit])
    points = np.zeros((len(ids), 3))
    points[hit] = origins[hit] + t[:, None] * dirs[hit]
    depth = np.zeros(len(ids))
    depth[hit] = -(points[hit] @ view[2, :3] + view[2, 3])
    q = np.linalg.inv(proj) @ np.array([0.0, 0.0, 1.0, 1.0])  # far plane, on the axis
    far = -q[2] / q[3]
    beyond = hit & (depth > far)  # the rasterizer keeps only depth <= far
    ids[beyond] = -1
    depth[beyond] = 0.0
    return ids.reshape(height, width), depth.reshape(height, width), points.reshape(height, width, 3)


def assert_matches_ray_caster(frag: Fragments, vertices, faces, view, proj, width=W, height=H,
                              min_covered: int = 100) -> None:
    ids, depth, points = ray_cast(vertices, faces, view, proj, width, height)
    union = frag.coverage | (ids >= 0)
    assert union.sum() >= min_covered, "test scene covers too few pixels"
    agree = (frag.tri_id == ids) & union
    assert agree.sum() / union.sum() >= ID_AGREEMENT, (
        f"triangle ids agree on {agree.sum()}/{union.sum()} covered pixels")
    rel = np.abs(frag.depth[agree] - depth[agree]) / depth[agree]
    assert rel.max() <= DEPTH_RTOL, f"max relative depth error {rel.max():.3g}"
    # Barycentrics reproduce the hit points (vertex attribute interpolation).
    v = np.asarray(vertices, float)[np.asarray(faces)[frag.tri_id[agree]]]  # (n, 3, 3)
    p = np.einsum("nk,nkj->nj", frag.bary[agree].astype(np.float64), v)
    err = np.linalg.norm(p - points[agree], axis=1) / depth[agree]
    assert err.max() <= 1e-4, f"interpolated positions off by {err.max():.3g} (relative to depth)"


def assert_valid(frag: Fragments, width=W, height=H, near=NEAR, far=FAR) -> None:
    """Shape/dtype/emptiness invariants of any Fragments."""
    assert frag.tri_id.shape == (height, width) and frag.tri_id.dtype == np.int32
    assert frag.depth.shape == (height, width) and frag.depth.dtype == np.float32
    assert frag.bary.shape == (height, width, 3) and frag.bary.dtype == np.float32
    cov = frag.coverage
    assert cov.dtype == bool and np.array_equal(cov, frag.tri_id >= 0)
    assert np.isfinite(frag.depth).all() and np.isfinite(frag.bary).all()
    assert (frag.tri_id >= -1).all()
    assert (frag.depth[~cov] == 0).all() and (frag.bary[~cov] == 0).all()
    if cov.any():
        d = frag.depth[cov]
        assert d.min() >= near * (1 - 1e-5) and d.max() <= far * (1 + 1e-5)
        b = frag.bary[cov]
        assert b.min() >= -1e-6
        np.testing.assert_allclose(b.sum(axis=1), 1.0, atol=1e-5)


def render(vertices, faces, view, proj, width=W, height=H, **kw) -> Fragments:
    frag = rasterize(vertices, faces, view, proj, width, height, **kw)
    assert_valid(frag, width, height)
    return frag


def bunny_path() -> Path:
    """The Stanford bunny in ../shared/assets beside the checkout (skip if absent)."""
    path = ASSETS / "stanford-bunny" / "stanford-bunny.obj"
    if not path.is_file():
        pytest.skip(f"Stanford bunny not found at {path}: third-party assets live in ../shared/assets "
                    "beside the developers' checkout and are absent from a fresh clone")
    return path


def procedural_scene() -> trimesh.Trimesh:
    """A few overlapping primitives (intersecting surfaces, silhouettes, caps)."""
    parts = [
        trimesh.creation.icosphere(subdivisions=3, radius=1.0),
        trimesh.creation.box(extents=(1.5, 1.0, 2.5)),
        trimesh.creation.cylinder(radius=0.4, height=3.0, sections=24),
        trimesh.creation.icosphere(subdivisions=2, radius=0.6),
        trimesh.creation.capsule(height=1.0, radius=0.3),
    ]
    offsets = [(0, 0, 0), (0.9, -0.4, 0.3), (-0.8, 0.2, 0.5), (0.3, 0.9, 0.8), (-0.5, -0.9, -0.5)]
    for part, off in zip(parts, offsets):
        part.apply_translation(off)
    parts[2].apply_transform(trimesh.transformations.rotation_matrix(0.7, [1, 0.3, 0], [-0.8, 0.2, 0.5]))
    return trimesh.util.concatenate(parts)


# --------------------------------------------------------------------------
# Agreement with the ray caster
# --------------------------------------------------------------------------


@pytest.mark.parametrize("cull", [True, False])
def test_procedural_scene_matches_ray_caster(cull):
    mesh = procedural_scene()
    view = look_at((2.5, 1.8, 4.5), (0.0, 0.0, 0.0))
    proj = perspective(45.0, W / H)
    frag = render(mesh.vertices, mesh.faces, view, proj, cull_backfaces=cull)
    assert frag.coverage.mean() > 0.2
    assert_matches_ray_caster(frag, mesh.vertices, mesh.faces, view, proj)


def test_orthographic_projection_matches_ray_caster():
    """The general (non-perspective) depth path: clip w is not the view depth."""
    mesh = procedural_scene()
    view = look_at((2.0, 1.5, 4.0), (0.0, 0.0, 0.0))
    half_h, near, far = 2.2, 0.5, 20.0
    half_w = half_h * W / H
    proj = np.diag([1.0 / half_w, 1.0 / half_h, -2.0 / (far - near), 1.0])
    proj[2, 3] = -(far + near) / (far - near)
    frag = rasterize(mesh.vertices, mesh.faces, view, proj, W, H)
    assert_valid(frag, near=near, far=far)
    assert frag.coverage.mean() > 0.2
    assert_matches_ray_caster(frag, mesh.vertices, mesh.faces, view, proj)


def test_bunny_matches_ray_caster():
    mesh = trimesh.load(bunny_path(), process=False, force="mesh")
    centre = mesh.bounds.mean(axis=0)
    radius = np.linalg.norm(mesh.bounds[1] - mesh.bounds[0]) / 2
    view = look_at(centre + np.array([0.4, 0.3, 1.3]) * radius * 1.6, centre)
    proj = perspective(40.0, W / H, near=0.01, far=10.0)
    # The bunny has holes: keep back faces so both sides agree with the rays.
    frag = render(mesh.vertices, mesh.faces, view, proj, cull_backfaces=False)
    assert frag.coverage.mean() > 0.2
    assert_matches_ray_caster(frag, mesh.vertices, mesh.faces, view, proj)


# --------------------------------------------------------------------------
# Near plane, behind camera, far plane
# --------------------------------------------------------------------------


def test_triangles_crossing_near_plane_are_clipped():
    # Camera at the origin looking down -Z; near = 0.1.
    view = np.eye(4)
    proj = perspective(60.0, W / H)
    vertices = np.array([
        # one vertex behind the camera, two in front (clipped into 2 triangles);
        # its cut by the near plane crosses the middle of the image
        [-0.02, -0.02, 0.5], [0.5, -0.3, -2.0], [-0.3, 0.5, -2.0],
        # two vertices behind the camera (clipped into 1 triangle), on the left
        [-0.3, 0.0, 0.5], [-0.2, -0.1, 0.4], [-1.5, 0.2, -3.0],
    ])
    faces = np.array([[0, 1, 2], [3, 4, 5]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        frag = render(vertices, faces, view, proj, cull_backfaces=False)
    for f in (0, 1):
        assert (frag.tri_id == f).sum() > 200, f"face {f} should cover many pixels"
    assert frag.depth[frag.tri_id == 0].min() < 0.11  # reaches (clipped at) the near plane
    assert_matches_ray_caster(frag, vertices, faces, view, proj)


def test_clipped_barycentrics_interpolate_to_the_pixel_centre():
    """Near-plane clipped faces: the barycentrics (w.r.t. the ORIGINAL face, through the
    clipped triangles' folded coefficients) interpolate a camera-space point whose depth is
    the reported one and which projects back to the pixel centre."""
    view = np.eye(4)
    proj = perspective(60.0, W / H)
    vertices = np.array([
        [-0.02, -0.02, 0.5], [0.5, -0.3, -2.0], [-0.3, 0.5, -2.0],     # one vertex behind: 2 triangles
        [-0.3, 0.0, 0.5], [-0.2, -0.1, 0.4], [-1.5, 0.2, -3.0],        # two vertices behind: 1 triangle
    ])
    faces = np.array([[0, 1, 2], [3, 4, 5]])
    frag = render(vertices, faces, view, proj, cull_backfaces=False)
    cov = frag.coverage
    b = frag.bary[cov].astype(np.float64)
    np.testing.assert_allclose(b.sum(axis=1), 1.0, atol=1e-6)
    p = np.einsum("nk,nkj->nj", b, vertices[faces[frag.tri_id[cov]]])
    np.testing.assert_allclose(-p[:, 2], frag.depth[cov], rtol=1e-5)
    clip = np.c_[p, np.ones(len(p))] @ proj.T
    i, j = np.nonzero(cov)
    np.testing.assert_allclose(clip[:, 0] / clip[:, 3], (j + 0.5) / W * 2 - 1, atol=1e-5)
    np.testing.assert_allclose(clip[:, 1] / clip[:, 3], 1 - (i + 0.5) / H * 2, atol=1e-5)


def test_floor_crossing_near_plane_is_watertight():
    """A tessellated floor crossing the near plane: no pixel covered twice, no hole."""
    view = np.eye(4)
    near, far, h = 0.5, 40.0, 0.2
    proj = perspective(70.0, W / H, near=near, far=far)
    xs, zs = np.meshgrid(np.linspace(-60.0, 60.0, 9), np.linspace(-45.0, 10.0, 9))
    vertices = np.stack([xs.ravel(), np.full(xs.size, -h), zs.ravel()], axis=1)
    n = xs.shape[0]
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    frag = rasterize(vertices, faces, view, proj, W, H, cull_backfaces=False)
    assert_valid(frag, near=near, far=far)
    counts = np.zeros((H, W), int)
    for f in range(len(faces)):  # render each face alone (test-side loop only)
        counts += rasterize(vertices, faces[f:f + 1], view, proj, W, H, cull_backfaces=False).coverage
    assert counts.max() <= 1, "a pixel is covered by two triangles of the floor"
    np.testing.assert_array_equal(counts > 0, frag.coverage)
    # Analytic depth of the plane y = -h through each pixel centre.
    y_ndc = 1.0 - (np.arange(H)[:, None] + 0.5) / H * 2.0
    with np.errstate(divide="ignore"):
        depth = np.broadcast_to(-proj[1, 1] * h / y_ndc, (H, W))
    below = np.broadcast_to(y_ndc < 0, (H, W))
    inside = below & (depth > near * 1.01) & (depth < far * 0.99)
    outside = ~below | (depth < near * 0.99) | (depth > far * 1.01)
    assert inside.sum() > 0.2 * H * W and (below & (depth < near)).sum() > 0.1 * H * W
    assert frag.coverage[inside].all(), "hole in the floor"
    assert not frag.coverage[outside].any()
    np.testing.assert_allclose(frag.depth[inside], depth[inside], rtol=1e-5)
    assert_matches_ray_caster(frag, vertices, faces, view, proj)


def test_triangle_fully_behind_camera_is_dropped():
    view = np.eye(4)
    proj = perspective(60.0, W / H)
    # Behind the camera: w < 0 would project it (mirrored) into the image if
    # it were not rejected.
    vertices = np.array([[-1.0, -1.0, 2.0], [1.0, -1.0, 2.0], [0.0, 1.0, 2.0],
                         [-5.0, -5.0, 0.05], [5.0, -5.0, 0.05], [0.0, 5.0, 0.01]])
    faces = np.array([[0, 1, 2], [0, 2, 1], [3, 4, 5]])
    frag = render(vertices, faces, view, proj, cull_backfaces=False)
    assert not frag.coverage.any()


def test_fragments_beyond_far_plane_are_dropped():
    view = np.eye(4)
    proj = perspective(60.0, W / H, near=0.1, far=10.0)
    # A wall tilted away: from depth 5 (left) to depth 15 (right).
    vertices = np.array([[-3.0, -3.0, -5.0], [5.0, -3.0, -15.0], [5.0, 3.0, -15.0], [-3.0, 3.0, -5.0]])
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    frag = rasterize(vertices, faces, view, proj, W, H)
    assert_valid(frag, near=0.1, far=10.0)
    assert frag.coverage.any()
    assert frag.depth[frag.coverage].max() <= 10.0 * (1 + 1e-6)
    ids, depth, _ = ray_cast(vertices, faces, view, proj)
    assert ((ids >= 0) != frag.coverage).sum() <= 0.005 * frag.coverage.sum()


# --------------------------------------------------------------------------
# Degenerate input
# --------------------------------------------------------------------------


def test_zero_area_triangles_are_dropped():
    view = np.eye(4)
    proj = perspective(60.0, W / H)
    vertices = np.array([[0.0, 0.0, -5.0], [1.0, 1.0, -5.0], [2.0, 2.0, -5.0],
                         [-1.0, 0.5, -3.0], [0.5, -1.0, -3.0], [0.0, 0.0, -5.0]])
    faces = np.array([[0, 1, 2], [3, 3, 4], [5, 0, 1], [4, 4, 4]])  # collinear, repeated vertices
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        frag = render(vertices, faces, view, proj, cull_backfaces=False)
    assert not frag.coverage.any()


def test_non_finite_vertices_are_dropped():
    view = np.eye(4)
    proj = perspective(60.0, W / H)
    vertices = np.array([[-1.0, -1.0, -4.0], [1.0, -1.0, -4.0], [0.0, 1.0, -4.0],
                         [np.nan, 0.0, -3.0], [np.inf, 1.0, -3.0], [0.0, -np.inf, -3.0]])
    faces = np.array([[0, 1, 2], [0, 3, 1], [4, 0, 2], [5, 1, 2], [3, 4, 5]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        frag = render(vertices, faces, view, proj, cull_backfaces=False)
    assert set(np.unique(frag.tri_id)) == {-1, 0}
    np.testing.assert_allclose(frag.depth[frag.coverage], 4.0, rtol=1e-6)


def test_huge_coordinates():
    view = np.eye(4)
    proj = perspective(60.0, W / H)
    big = 1e6
    # A screen-filling wall at depth 10 and a huge floor crossing the near plane.
    vertices = np.array([[-big, -big, -10.0], [big, -big, -10.0], [0.0, big, -10.0],
                         [-big, -1.0, big], [big, -1.0, big], [0.0, -1.0, -big]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        wall = render(vertices, np.array([[0, 1, 2]]), view, proj)
        floor = render(vertices, np.array([[3, 4, 5]]), view, proj, cull_backfaces=False)
    assert wall.coverage.all()
    np.testing.assert_allclose(wall.depth, 10.0, rtol=1e-6)
    i = np.arange(H)[:, None] + 0.5
    y_ndc = 1.0 - i / H * 2.0
    depth = np.broadcast_to(-1.0 / (y_ndc / proj[1, 1]), (H, W))
    inside = (y_ndc < 0) & (depth < FAR * 0.99)
    assert floor.coverage[inside].all()
    np.testing.assert_allclose(floor.depth[inside], depth[inside], rtol=1e-5)


@settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(
    coords=st.lists(st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False), min_size=18, max_size=18),
    scale=st.sampled_from([1.0, 1e-3, 1e3]),
)
def test_random_triangles_never_produce_nan(coords, scale):
    vertices = np.array(coords).reshape(6, 3) * scale / 1e6 * np.array([[3.0, 3.0, 6.0]])
    vertices[:, 2] -= 2.0
    faces = np.array([[0, 1, 2], [3, 4, 5], [0, 4, 2]])
    view = np.eye(4)
    proj = perspective(60.0, 4 / 3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        frag = rasterize(vertices, faces, view, proj, 32, 24, cull_backfaces=False)
    assert_valid(frag, 32, 24)


def test_empty_mesh():
    view, proj = np.eye(4), perspective(60.0, W / H)
    for vertices, faces in [(np.zeros((0, 3)), np.zeros((0, 3), int)),
                            (np.random.default_rng(0).normal(size=(5, 3)), np.zeros((0, 3), np.int32))]:
        frag = render(vertices, faces, view, proj)
        assert not frag.coverage.any()


def test_invalid_arguments():
    view, proj = np.eye(4), perspective(60.0, 1.0)
    v = np.zeros((3, 3))
    with pytest.raises(ValueError):
        rasterize(v, np.array([[0, 1, 3]]), view, proj, 8, 8)
    with pytest.raises(ValueError):
        rasterize(v, np.array([[0, 1, 2]]), view, proj, 8, 8, cull_backfaces=np.array([True, False]))
    with pytest.raises(ValueError):
        rasterize(v, np.array([[0, 1, 2]]), view, proj, 0, 8)


# --------------------------------------------------------------------------
# Culling, camera inside a closed mesh
# --------------------------------------------------------------------------


def test_backface_culling_modes():
    view = np.eye(4)
    proj = perspective(60.0, W / H)
    vertices = np.array([[-2.0, -1.0, -5.0], [-0.5, -1.0, -5.0], [-1.0, 1.0, -5.0],
                         [0.5, -1.0, -5.0], [2.0, -1.0, -5.0], [1.0, 1.0, -5.0]])
    faces = np.array([[0, 1, 2],   # counter-clockwise in NDC: front
                      [3, 5, 4]])  # clockwise: back
    on = render(vertices, faces, view, proj, cull_backfaces=True)
    off = render(vertices, faces, view, proj, cull_backfaces=False)
    per_face = render(vertices, faces, view, proj, cull_backfaces=np.array([False, False]))
    cull_front_only = render(vertices, faces, view, proj, cull_backfaces=np.array([True, False]))
    cull_back_only = render(vertices, faces, view, proj, cull_backfaces=np.array([False, True]))
    assert set(np.unique(on.tri_id)) == {-1, 0}
    assert set(np.unique(off.tri_id)) == {-1, 0, 1}
    np.testing.assert_array_equal(per_face.tri_id, off.tri_id)
    np.testing.assert_array_equal(cull_front_only.tri_id, off.tri_id)  # face 0 is front: True is moot
    np.testing.assert_array_equal(cull_back_only.tri_id, on.tri_id)
    # A back face in front of a front face hides it only when not culled.
    vertices2 = np.concatenate([vertices, [[-3.0, -2.0, -3.0], [-3.0, 2.0, -3.0], [0.0, -2.0, -3.0]]])
    faces2 = np.concatenate([faces, [[6, 7, 8]]])  # clockwise, nearer than face 0
    hidden = render(vertices2, faces2, view, proj, cull_backfaces=False)
    shown = render(vertices2, faces2, view, proj, cull_backfaces=True)
    assert (hidden.tri_id == 2).sum() > 0 and (shown.tri_id == 2).sum() == 0
    assert (shown.tri_id == 0).sum() > (hidden.tri_id == 0).sum()


def test_camera_inside_closed_box():
    box = trimesh.creation.box(extents=(4.0, 3.0, 5.0))
    box.apply_translation((0.3, -0.2, 0.1))
    view = look_at((0.0, 0.0, 0.0), (0.3, 0.1, -1.0))
    proj = perspective(90.0, W / H)
    inside_view = render(box.vertices, box.faces, view, proj, cull_backfaces=False)
    assert inside_view.coverage.all()
    assert_matches_ray_caster(inside_view, box.vertices, box.faces, view, proj)
    culled = render(box.vertices, box.faces, view, proj, cull_backfaces=True)
    assert not culled.coverage.any()  # all faces point outwards: seen from behind


# --------------------------------------------------------------------------
# Tie rule / watertightness, barycentrics
# --------------------------------------------------------------------------


def test_shared_edge_through_pixel_centres_is_covered_once():
    n = 16
    view, proj = np.eye(4), unit_perspective()
    # Quad corners on pixel centres 4.5 and 11.5 (NDC multiples of 1/16, exact);
    # the diagonal passes through pixel centres too.
    lo, hi = 4.5 / n * 2 - 1, 11.5 / n * 2 - 1
    vertices = np.array([[lo, -hi, -1.0], [hi, -hi, -1.0], [hi, -lo, -1.0], [lo, -lo, -1.0]])
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    a = rasterize(vertices, faces[:1], view, proj, n, n).coverage
    b = rasterize(vertices, faces[1:], view, proj, n, n).coverage
    both = rasterize(vertices, faces, view, proj, n, n)
    assert not (a & b).any(), "a pixel centre on the shared edge is covered by both triangles"
    np.testing.assert_array_equal(a | b, both.coverage)
    # Top-left rule: 7 x 7 pixels of the 8 x 8 centres on the closed square.
    assert both.coverage.sum() == 49
    # Also with the diagonal the other way round and with reversed winding.
    for f in (np.array([[0, 1, 3], [1, 2, 3]]), np.array([[0, 2, 1], [0, 3, 2]])):
        c1 = rasterize(vertices, f[:1], view, proj, n, n, cull_backfaces=False).coverage
        c2 = rasterize(vertices, f[1:], view, proj, n, n, cull_backfaces=False).coverage
        assert not (c1 & c2).any() and (c1 | c2).sum() == 49


def test_jittered_grid_is_watertight():
    """Many edges through pixel centres: every pixel covered exactly once."""
    n = 48
    rng = np.random.default_rng(3)
    view, proj = np.eye(4), unit_perspective()
    k = 9
    g = np.arange(-(k // 2), k // 2 + 1) * (15 / n)  # 7.5 pixels: vertices on pixel centres
    xs, ys = np.meshgrid(g, g)
    pts = np.stack([xs.ravel(), ys.ravel()], 1)
    pts[:, :] += rng.integers(-6, 7, pts.shape) / (2 * n)  # on a 1/4-pixel lattice: many exact ties
    vertices = np.concatenate([pts, -np.ones((len(pts), 1))], axis=1)
    idx = np.arange(k * k).reshape(k, k)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    counts = np.zeros((n, n), int)
    for f in range(len(faces)):
        counts += rasterize(vertices, faces[f:f + 1], view, proj, n, n, cull_backfaces=False).coverage
    assert counts.min() == 1 and counts.max() == 1


def test_barycentrics_interpolate_vertex_attributes():
    mesh = procedural_scene()
    view = look_at((-3.0, 2.0, 3.5), (0.2, 0.0, 0.0))
    proj = perspective(50.0, W / H)
    frag = render(mesh.vertices, mesh.faces, view, proj)
    cov = frag.coverage
    b = frag.bary[cov].astype(np.float64)
    np.testing.assert_allclose(b.sum(axis=1), 1.0, atol=1e-6)
    assert b.min() >= 0.0
    # Interpolated camera-space position: its -z equals the reported depth,
    # and it projects back to the pixel centre.
    v = mesh.vertices[mesh.faces[frag.tri_id[cov]]]
    p = np.einsum("nk,nkj->nj", b, v)
    pc = np.c_[p, np.ones(len(p))] @ view.T
    np.testing.assert_allclose(-pc[:, 2], frag.depth[cov], rtol=1e-5)
    clip = pc @ proj.T
    i, j = np.nonzero(cov)
    np.testing.assert_allclose(clip[:, 0] / clip[:, 3], (j + 0.5) / W * 2 - 1, atol=1e-5)
    np.testing.assert_allclose(clip[:, 1] / clip[:, 3], 1 - (i + 0.5) / H * 2, atol=1e-5)


# --------------------------------------------------------------------------
# Chunking / batching must not change the result
# --------------------------------------------------------------------------


def test_small_chunks_and_batches_give_identical_result(monkeypatch):
    """Face batches, tile groups, grid chunks and winner chunks are invisible."""
    mesh = procedural_scene()
    mesh = trimesh.util.concatenate([mesh, trimesh.creation.box(extents=(30.0, 30.0, 0.1))])  # large tris
    view = look_at((2.5, 1.8, 4.5), (0.0, 0.0, 0.0))
    proj = perspective(45.0, W / H)
    ref = render(mesh.vertices, mesh.faces, view, proj, cull_backfaces=False)
    monkeypatch.setattr(batches, "FACE_BATCH", 257)
    monkeypatch.setattr(batches, "WINNER_CHUNK", 1000)
    monkeypatch.setattr(tiles, "TILE", 8)
    monkeypatch.setattr(tiles, "_TILE_LOG2", 3)
    monkeypatch.setattr(tiles, "MAX_TILES", 50)
    small = render(mesh.vertices, mesh.faces, view, proj, cull_backfaces=False, max_fragments=500)
    np.testing.assert_array_equal(small.tri_id, ref.tri_id)
    np.testing.assert_allclose(small.depth, ref.depth, rtol=1e-6)
    np.testing.assert_allclose(small.bary, ref.bary, atol=1e-6)

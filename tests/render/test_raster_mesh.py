"""RasterMesh: the rasterizer's input checked once, its faces' planes kept between views, and the
back-face pre-cull they drive (clshade.render.raster.mesh). The pre-cull must drop only faces that
triangle setup drops anyway: every test compares it bit for bit against the rasterizer with the
pre-cull off (BACKFACE_PRECULL_COS = inf), on cases chosen to sit at its edges."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from clshade.render import transforms
from clshade.render.raster import RasterMesh, mesh as raster_mesh, rasterize, rasterize_mesh
from clshade.render.raster.mesh import camera_centre
from clshade.render.transforms import look_at

W, H = 160, 120


def same(a, b) -> None:
    for name in ("pixels", "face", "face_depth", "face_bary"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), name


def both_ways(monkeypatch, mesh: RasterMesh, view, proj, width=W, height=H):
    """(pre-culled, not pre-culled) fragments of one view."""
    on = rasterize_mesh(mesh, view, proj, width, height)
    with monkeypatch.context() as m:
        m.setattr(raster_mesh, "BACKFACE_PRECULL_COS", np.inf)
        off = rasterize_mesh(mesh, view, proj, width, height)
    return on, off


def test_camera_centre_gives_the_sign_of_the_projected_area():
    rng = np.random.default_rng(7)
    for _ in range(50):
        mvp = rng.normal(size=(4, 4))
        a, b, c = rng.normal(size=(3, 3))
        x = np.vstack([np.stack([a, b, c], axis=1), np.ones(3)])
        n = np.cross(b - a, c - a)
        det = np.linalg.det(mvp[[0, 1, 3]] @ x)
        assert camera_centre(mvp) @ np.append(n, -n @ a) == pytest.approx(det, rel=1e-9, abs=1e-12)
    # A perspective camera's centre is its position (w = 1 after scaling).
    view = look_at((1.0, 2.0, 3.0), (0.0, 0.0, 0.0))
    c = camera_centre(transforms.perspective(50.0, 1.3, 0.1, 100.0) @ view)
    np.testing.assert_allclose(c[:3] / c[3], [1.0, 2.0, 3.0], rtol=1e-12)


def test_precull_drops_the_back_half_of_a_sphere_and_no_visible_face():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    mesh = RasterMesh(sphere.vertices, sphere.faces)
    view = look_at((0.0, 0.5, 4.0), (0.0, 0.0, 0.0))
    proj = transforms.perspective(45.0, W / H, 0.1, 100.0)
    kept = mesh.candidates(camera_centre(proj @ view), 0, len(mesh))
    assert 0.3 * len(mesh) < len(kept) < 0.6 * len(mesh)
    frags = rasterize_mesh(mesh, view, proj, W, H)
    assert np.isin(frags.face, kept).all()
    # Not culled (double-sided): nothing is pre-culled.
    assert len(RasterMesh(sphere.vertices, sphere.faces, False).candidates(camera_centre(proj @ view), 0,
                                                                            len(mesh))) == len(mesh)


def test_precull_keeps_faces_within_its_margin_of_edge_on():
    """Squares 5 units in front of the eye in planes y = -δ facing +y: seen from above (front)
    for δ > 0, from below (back) for δ < 0, at a cosine of about δ / 5 to edge-on."""
    deltas = np.array([5e-3, 5e-8, 5e-10, -5e-10, -5e-8, -4e-6, -6e-6, -5e-3])
    vertices, faces = [], []
    for k, d in enumerate(deltas):
        vertices += [[0.0, -d, -5.0], [1.0, -d, -5.0], [0.0, -d, -6.0]]   # normal (b - a) × (c - a) = +y
        faces.append([3 * k, 3 * k + 1, 3 * k + 2])
    proj = transforms.perspective(60.0, 1.0, 0.1, 100.0)
    eye = camera_centre(proj @ np.eye(4))
    kept = RasterMesh(vertices, faces).candidates(eye, 0, len(faces))
    np.testing.assert_array_equal(kept, [0, 1, 2, 3, 4, 5])       # cos ≥ -1e-6 kept, -1.2e-6 and -1e-3 dropped
    np.testing.assert_array_equal(RasterMesh(vertices, faces).candidates(eye, 2, 8), [2, 3, 4, 5])
    not_culled = np.ones(len(faces), bool)
    not_culled[7] = False
    np.testing.assert_array_equal(RasterMesh(vertices, faces, not_culled).candidates(eye, 0, 8), [0, 1, 2, 3, 4, 5, 7])


def test_precull_changes_no_pixel_near_edge_on(monkeypatch):
    """Floors a hair below and above the eye (front and back faces at cosines down to 1e-9 of
    edge-on; a face that near to edge-on covers a pixel centre only within a pixel of the eye's
    plane through it), random slivers and near-edge-on fans, in perspective, shifted, cropped
    and orthographic projections."""
    rng = np.random.default_rng(3)
    floor_v = np.array([[-50.0, 0.0, -50.0], [50.0, 0.0, -50.0], [50.0, 0.0, 50.0], [-50.0, 0.0, 50.0]])
    floor_f = np.array([[0, 2, 1], [0, 3, 2]])            # facing +y
    parts_v, parts_f = [], []
    for height in (-1e-7, -1e-9, 1e-9, 1e-7, -0.5):
        parts_f.append(floor_f + sum(len(v) for v in parts_v))
        parts_v.append(floor_v + [0.0, height, 0.0])
    # Thin fans of triangles about the view ray through (0, 0, -3): angles to edge-on of 1e-3 .. 1e-8.
    for tilt in (1e-3, 1e-5, 1e-6, 2e-6, 1e-7, 1e-8):
        for sign in (-1.0, 1.0):
            base = len(np.concatenate(parts_v)) if parts_v else 0
            c = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), -3.0])
            v = np.array([c, c + [0.3, 0.0, 0.0], c + [0.0, sign * tilt, -1.0]])
            parts_v.append(v)
            parts_f.append(np.array([[base, base + 1, base + 2]]))
    slivers = rng.normal(size=(300, 3)) * [1.0, 1.0, 0.5] + [0.0, 0.0, -4.0]
    base = len(np.concatenate(parts_v))
    parts_v.append(np.concatenate([slivers, slivers + rng.normal(size=(300, 3)) * 1e-4,
                                   slivers + rng.normal(size=(300, 3)) * 0.3]))
    parts_f.append(base + np.stack([np.arange(300), 300 + np.arange(300), 600 + np.arange(300)], axis=1))
    vertices, faces = np.concatenate(parts_v), np.concatenate(parts_f)
    mesh = RasterMesh(vertices, faces)
    assert mesh.planes_of(mesh.batch(0, len(faces))).shape == (5, len(faces))
    persp = transforms.perspective(60.0, W / H, 0.05, 200.0)
    shifted = persp.copy()
    shifted[0] -= 0.3 * persp[3]
    cropped = np.diag([1.0, 3.0, 1.0, 1.0]) @ persp
    ortho = np.array([[0.3, 0, 0, 0], [0, 0.4, 0, 0], [0, 0, -0.01, -1.0], [0, 0, 0, 1.0]])
    views = [look_at((0.0, 0.0, 0.0), (0.0, 0.0, -1.0)), look_at((0.1, 0.0, 0.3), (0.2, -0.001, -5.0)),
             look_at((0.0, 2.0, 5.0), (0.0, 0.0, -3.0))]
    covered = 0
    for view in views:
        for proj in (persp, shifted, cropped, ortho):
            on, off = both_ways(monkeypatch, mesh, view, proj)
            same(on, off)
            covered += len(on.pixels)
    assert covered > 4 * W * H      # the floor at -0.5 covers about half the frame in most views


def test_precull_changes_no_pixel_of_a_closed_scene_from_many_sides(monkeypatch):
    parts = [trimesh.creation.icosphere(subdivisions=2), trimesh.creation.box(extents=(1.5, 1.0, 2.5)),
             trimesh.creation.cylinder(radius=0.4, height=3.0, sections=24)]
    parts[1].apply_translation((0.9, -0.4, 0.3))
    scene = trimesh.util.concatenate(parts)
    mesh = RasterMesh(scene.vertices, scene.faces)
    proj = transforms.perspective(50.0, W / H, 0.1, 100.0)
    rng = np.random.default_rng(11)
    for eye in rng.normal(size=(8, 3)) * 3.0:
        on, off = both_ways(monkeypatch, mesh, look_at(eye, (0.0, 0.0, 0.0)), proj)
        same(on, off)
        assert len(on.pixels) > 100
    same(rasterize(scene.vertices, scene.faces, look_at((0.2, 0.1, 0.3), (2.0, 0.0, 0.0)), proj, W, H),
         rasterize_mesh(mesh, look_at((0.2, 0.1, 0.3), (2.0, 0.0, 0.0)), proj, W, H))   # camera inside


def test_mesh_keeps_its_own_copy_of_the_arrays():
    sphere = trimesh.creation.icosphere(subdivisions=2)
    vertices, faces = np.array(sphere.vertices), np.array(sphere.faces)
    mesh = RasterMesh(vertices, faces)
    view, proj = look_at((0.0, 0.0, 4.0), (0.0, 0.0, 0.0)), transforms.perspective(45.0, W / H, 0.1, 100.0)
    before = rasterize_mesh(mesh, view, proj, W, H)
    vertices *= -1.0                                      # the caller's arrays change afterwards
    faces[:, [1, 2]] = faces[:, [2, 1]]
    same(before, rasterize_mesh(mesh, view, proj, W, H))
    with pytest.raises(ValueError):
        mesh.vertices[0, 0] = 1.0


@pytest.mark.parametrize("args, message", [
    ((np.zeros((3, 2)), [[0, 1, 2]]), "vertices must have shape"),
    ((np.zeros((3, 3)), [[0, 1]]), "faces must have shape"),
    ((np.zeros((3, 3)), [[0.0, 1.0, 2.0]]), "faces must be integers"),
    ((np.zeros((3, 3)), [[0, 1, 3]]), "out of range"),
    ((np.zeros((3, 3)), [[0, 1, 2]], np.array([True, False])), "cull_backfaces array"),
])
def test_mesh_checks_its_input(args, message):
    with pytest.raises(ValueError, match=message):
        RasterMesh(*args)


def test_grid_grouping_and_depth_shortcut_change_no_pixel(monkeypatch):
    """The rare size classes merged into square grids (or none merged, or all), and the depth-range
    shortcut on (or off for every triangle), give the same fragments bit for bit: a scene with
    triangles of every box shape, a floor crossing the near plane and boxes straddling the far one."""
    import trimesh.creation as creation
    from clshade.render.raster import tiles
    rng = np.random.default_rng(5)
    parts = [creation.icosphere(subdivisions=3), creation.box(extents=(30.0, 0.1, 30.0)),
             creation.cylinder(radius=0.05, height=3.0, sections=7)]
    parts[1].apply_translation((0.0, -1.0, 0.0))
    far = creation.box(extents=(2.0, 2.0, 40.0))
    far.apply_translation((1.5, 0.0, -30.0))            # reaches beyond the far plane (25)
    sizes = rng.uniform(0.002, 0.3, size=(200, 3))       # thin, wide and tall slivers of every box class
    spots = rng.normal(size=(200, 3)) * [1.5, 1.0, 1.0]
    fans = [trimesh.Trimesh(np.array([p, p + [s[0], 0.0, 0.0], p + [0.0, s[1], s[2]]]), [[0, 1, 2]])
            for p, s in zip(spots, sizes)]
    scene = trimesh.util.concatenate(parts + [far] + fans)
    mesh = RasterMesh(scene.vertices, scene.faces, False)
    proj = transforms.perspective(60.0, W / H, 0.1, 25.0)
    views = [look_at((0.3, 0.2, 3.5), (0.0, 0.0, -2.0)), look_at((4.0, 1.0, 0.5), (0.0, -0.5, -10.0))]

    def frames():
        return [rasterize_mesh(mesh, v, proj, 2 * W, 2 * H) for v in views]

    reference = frames()
    assert all(len(f.pixels) > 1000 for f in reference)
    for merge in (0, 10 ** 9):
        monkeypatch.setattr(tiles, "MERGE_CLASS_BELOW", merge)
        for a, b in zip(frames(), reference):
            same(a, b)
    monkeypatch.undo()
    monkeypatch.setattr(tiles, "_box_depth_in_unit_range", lambda t: np.zeros(len(t.face), bool))
    for a, b in zip(frames(), reference):
        same(a, b)


def test_a_one_view_mesh_copies_and_keeps_nothing():
    """rasterize() (one view) wraps the caller's arrays without copying and keeps no batch: its
    memory stays that of a batch of faces (benchmarks/measure/raster_bench.py measures it)."""
    sphere = trimesh.creation.icosphere(subdivisions=2)
    vertices, faces = np.array(sphere.vertices), np.array(sphere.faces, dtype=np.int64)
    once = RasterMesh(vertices, faces, keep=False)
    assert np.shares_memory(once.vertices, vertices) and np.shares_memory(once.faces, faces)
    view, proj = look_at((0.0, 0.0, 4.0), (0.0, 0.0, 0.0)), transforms.perspective(45.0, W / H, 0.1, 100.0)
    same(rasterize_mesh(once, view, proj, W, H), rasterize_mesh(RasterMesh(vertices, faces), view, proj, W, H))
    assert not once._batches and vertices.flags.writeable


def test_kept_batches_serve_every_view(monkeypatch):
    """A kept mesh of many face batches: its per-batch corners and planes, made in the first
    view, give the next views the fragments a fresh one-view rasterize gives, bit for bit."""
    from clshade.render.raster import batches
    monkeypatch.setattr(batches, "FACE_BATCH", 257)
    sphere = trimesh.creation.icosphere(subdivisions=3)
    mesh = RasterMesh(sphere.vertices, sphere.faces)
    proj = transforms.perspective(45.0, W / H, 0.1, 100.0)
    for eye in ((0.0, 0.0, 4.0), (3.0, 1.0, -2.0), (0.5, 3.5, 0.5)):
        view = look_at(eye, (0.0, 0.0, 0.0))
        same(rasterize_mesh(mesh, view, proj, W, H), rasterize(sphere.vertices, sphere.faces, view, proj, W, H))
    assert len(mesh._batches) == -(-len(sphere.faces) // 257)

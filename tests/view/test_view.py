"""`clshade view` without a browser: control checks, the scene document, the G-buffer
patch, the device display transform, save ↔ `clshade render`, the server's guards and
its latest-state-wins loop."""
from __future__ import annotations

import asyncio
import dataclasses
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from clshade.cli import main
from clshade.device.display import PIXELS_PER_ITEM, Display, items, thresholds
from clshade.device.runtime import get_runtime
from clshade.device.variants import Variant
from clshade.errors import ClshadeError
from clshade.models.registry import Registry
from clshade.render.gbuffer import build_gbuffer
from clshade.render.image import read_image, to_display
from clshade.render.raster import rasterize
from clshade.resources import scenes_dir
from clshade.view.controls import ControlError, parse_controls, parse_message
from clshade.view.document import dumps
from clshade.view.session import DEVICE_GBUFFER_STAGE, ViewSession
from scene_toml import red_sphere

resolve = Registry().resolve          # the built-in lobes

ROBOT = scenes_dir() / "robot.toml"
W, H = 96, 64


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    return ViewSession(ROBOT, tmp_path_factory.mktemp("view-out"), W, H)


def controls(session, **changes):
    return dict(session.initial_controls(), **changes)


def host_fragments(session):
    """The last frame's fragments from the host rasterizer, made anew (not the session's kept raster,
    which is a visibility buffer where the device makes the G-buffer)."""
    g, camera = session._geometry.value, session.last["camera"]
    return rasterize(g.vertices, g.faces, camera.view_matrix(), camera.projection_matrix(), camera.width,
                     camera.height, cull_backfaces=g.cull)


# ---------------------------------------------------------------- controls


def test_initial_controls_pass(session):
    c = parse_controls(controls(session), session.limits)
    assert c.model_a == "ggx_correlated" and not c.split


BAD = [
    ("exposure", 65.0, "exposure"), ("exposure", "1", "must be a number"), ("elevation", 90.0, "elevation"),
    ("distance", 0.0, "distance"), ("model_a", "ggx_corelated", "did you mean 'ggx_correlated'"),
    ("model_b", "lambert+phong+blinn_phong", "two specular lobes"), ("model_a", "", "model name"),
    ("model_a", "ggx_correlated@schlik", "unknown Fresnel"),
    ("tonemap", "filmic", "tonemap"), ("samples", 0, "samples"), ("samples", True, "samples"),
    ("samples", 9, "samples"), ("split", 1, "true or false"),
    ("materials", {"chrome": {"roughness": 0.2}}, "no such material"),
    ("materials", {"steel": {"metalness": 0.2}}, "not a lobe parameter"),
    ("materials", {"steel": {"roughness": 1.5}}, "materials.steel.roughness"),
    ("materials", {"steel": {"roughness": None}}, "must be a number"),
    ("materials", {"steel": {"base_color": [0.1, 0.2]}}, "list of 3 numbers"),
    ("materials", {"steel": {"base_color": 0.5}}, "list of 3 numbers"),
    ("materials", {"steel": {"base_color": [0.1, 0.2, 1.5]}}, "materials.steel.base_color[2]"),
    ("materials", {"steel": {"metallic": -0.1}}, "materials.steel.metallic"),
    ("lights", {"3": {"scale": 1.0}}, "no such light"), ("lights", {"-1": {"scale": 1.0}}, "no such light"),
    ("lights", {"1": {"direction": [0, -1, 0]}}, "point light has no direction"),
    ("lights", {"0": {"direction": [0, 0, 0]}}, "zero vector"),
    ("lights", {"0": {"direction": [0, -1]}}, "3 numbers"),
    ("lights", {"0": {"scale": -1}}, "lights.0.scale"), ("lights", {"0": {"colour": 1}}, "unknown key"),
    ("zoom", 1.0, "unknown control"),
]


@pytest.mark.parametrize("key,value,why", BAD, ids=[f"{k}={v!r}"[:40] for k, v, _ in BAD])
def test_bad_controls_are_refused_with_the_key(session, key, value, why):
    with pytest.raises(ControlError, match=None) as info:
        parse_controls(controls(session, **{key: value}), session.limits)
    assert why in str(info.value)


def test_missing_control_is_refused(session):
    state = controls(session)
    del state["exposure"]
    with pytest.raises(ControlError, match="missing exposure"):
        parse_controls(state, session.limits)


@pytest.mark.parametrize("text,why", [
    ('{"type": "state", "controls": {"exposure": NaN}}', "NaN"),
    ('{"exposure": Infinity}', "Infinity"), ("{not json", "not JSON"), ("[1, 2]", "JSON object"),
    ("\"x\"" + " " * 70000, "longer than"),
])
def test_bad_messages_are_refused(text, why):
    with pytest.raises(ControlError, match=why):
        parse_message(text)


def test_good_values_pass_at_the_limits(session):
    lo, hi = session.limits.distance
    c = parse_controls(controls(session, distance=hi, elevation=-89.0, exposure=-64.0,
                                materials={"steel": {"roughness": 0.0, "shininess": 1e6}},
                                lights={"0": {"direction": [1, -1, 0], "scale": 0.0}}), session.limits)
    assert c.distance == hi and c.materials == (("steel", (("roughness", 0.0), ("shininess", 1e6))),)


# ---------------------------------------------------------------- the scene document


@pytest.mark.parametrize("path", sorted(scenes_dir().glob("*.toml")), ids=lambda p: p.name)
def test_document_round_trips(path):
    doc = tomllib.loads(path.read_text(encoding="utf-8"))
    assert tomllib.loads(dumps(doc)) == doc


def test_document_round_trips_awkward_values():
    doc = {"a b": {"c": [1e-300, 0.1, -0.0, 2 ** 62]}, "s": "q\"\\\n\t\u0001é",
           "objects": [{"material": {"roughness": 0.30000000000000004}, "name": "x"}, {"t": True}]}
    assert tomllib.loads(dumps(doc)) == doc
    with pytest.raises(ClshadeError):
        dumps({"x": float("nan")})


def test_controls_reach_the_scene(session):
    c = parse_controls(controls(session, azimuth=30.0, exposure=1.5, tonemap="reinhard", model_a="burley",
                                materials={"gold": {"roughness": 0.05}},
                                lights={"0": {"direction": [0.0, -1.0, 0.0], "scale": 2.0}}), session.limits)
    scene, _ = session.scene(c)
    base = session.base_scene
    assert scene.exposure == 1.5 and scene.tonemap == "reinhard" and scene.model == "burley"
    assert scene.materials["gold"].roughness == 0.05 and scene.materials["steel"] == base.materials["steel"]
    np.testing.assert_array_equal(scene.lights[0].direction, [0.0, -1.0, 0.0])
    np.testing.assert_array_equal(scene.lights[0].color, 2.0 * base.lights[0].color)
    np.testing.assert_array_equal(scene.lights[1].color, base.lights[1].color)
    # azimuth turns the camera about the target at the same distance and height
    offset, offset0 = scene.camera.position - scene.camera.target, base.camera.position - base.camera.target
    assert np.linalg.norm(offset) == pytest.approx(np.linalg.norm(offset0))
    assert offset[1] == pytest.approx(offset0[1])
    cos = offset[[0, 2]] @ offset0[[0, 2]] / np.linalg.norm(offset[[0, 2]]) / np.linalg.norm(offset0[[0, 2]])
    assert cos == pytest.approx(np.cos(np.radians(30.0)))


# ---------------------------------------------------------------- stages


def test_patched_gbuffer_equals_a_rebuilt_one(session):
    start = parse_controls(controls(session), session.limits)
    session.render(start)
    changed = parse_controls(controls(session, materials={"paint_red": {"roughness": 0.9},
                                                          "steel": {"roughness": 0.05, "metallic": 0.4},
                                                          "paint_cream": {"base_color": [0.1, 0.5, 0.9]},
                                                          "gold": {"ks": 0.2}}),
                             session.limits)
    frame = session.render(changed)
    assert frame.reshade_only and "g-buffer patch" in frame.stages and "rasterize" not in frame.stages
    last = session.last
    rebuilt = build_gbuffer(last["scene"], session._geometry.value, host_fragments(session), last["camera"])
    for name in rebuilt.channels:
        np.testing.assert_array_equal(last["gbuffer"].channels[name], rebuilt.channels[name], err_msg=name)
    np.testing.assert_array_equal(last["gbuffer"].materials, rebuilt.materials)
    assert (last["gbuffer"].channels["roughness"] == np.float32(0.05)).any()
    assert (last["gbuffer"].channels["metallic"] == np.float32(0.4)).any()
    assert (last["gbuffer"].plane("base")[2] == np.float32(0.9)).any()


def test_material_edits_survive_the_next_orbit(session):
    """After a patched material change (each per-pixel value alone) the camera moves: the G-buffer
    built from the new raster (with the kept face tables) has the changed value, as a G-buffer
    built from scratch."""
    for k, edit in enumerate(({"base_color": [0.2, 0.6, 0.3]}, {"metallic": 0.7}, {"roughness": 0.15})):
        materials = {"paint_cream": edit}
        session.render(parse_controls(controls(session, azimuth=10.0 * k), session.limits))
        patched = session.render(parse_controls(controls(session, materials=materials, azimuth=10.0 * k),
                                                session.limits))
        assert patched.reshade_only
        moved = session.render(parse_controls(controls(session, materials=materials, azimuth=10.0 * k + 5.0),
                                              session.limits))
        assert "rasterize" in moved.stages
        last = session.last
        fresh = build_gbuffer(last["scene"], session._geometry.value, host_fragments(session), last["camera"])
        for name in fresh.channels:
            np.testing.assert_array_equal(last["gbuffer"].channels[name], fresh.channels[name], err_msg=f"{edit} {name}")


def test_rebound_shader_equals_a_new_one(session):
    """The kept Shader, rebound to each new G-buffer (orbit: new planes and camera; a material
    edit: patched planes and table), shades what a Shader made for that G-buffer shades."""
    from clshade.device.shade import Shader
    first = session.render(parse_controls(controls(session, model_b="phong", split=True), session.limits))
    kept = session.last["shader"]
    for change in (dict(azimuth=25.0), dict(azimuth=25.0, materials={"steel": {"roughness": 0.1, "ks": 0.5}}),
                   dict(azimuth=-10.0, elevation=40.0)):
        frame = session.render(parse_controls(controls(session, model_b="phong", split=True, **change),
                                              session.limits))
        last = session.last
        assert last["shader"] is kept and (frame.views["a"] != first.views["a"]).any()
        fresh = Shader(session.runtime, last["gbuffer"], last["scene"], last["camera"], last["shadows"])
        for model in last["models"].values():
            np.testing.assert_array_equal(kept.render(model, last["features"]),
                                          fresh.render(model, last["features"]), err_msg=f"{change} {model.id}")


def test_base_document_is_not_changed_by_frames(session):
    """applied() copies only the tables it writes; nothing downstream writes into the scene file's."""
    import copy
    before = copy.deepcopy(session.base_doc)
    session.render(parse_controls(controls(session, azimuth=3.0, materials={"steel": {"base_color": [0.3, 0.3, 0.3]}},
                                           lights={"0": {"direction": [0.3, -1.0, 0.2], "scale": 1.5}}),
                                  session.limits))
    session.save(parse_controls(controls(session, materials={"gold": {"roughness": 0.2}}), session.limits), "doc")
    assert session.base_doc == before


def test_surface_params_are_the_scene_defaults():
    """The base colour and metallic sliders start from the scene format's own defaults."""
    from clshade.models.lobe import SURFACE_PARAMS
    from clshade.render.scene import Material
    fields = Material.__dataclass_fields__
    for p in SURFACE_PARAMS:
        default = fields[p.name].default
        assert (tuple(default) == (p.default,) * 3) if p.kind == "color" else default == p.default, p.name


def test_sliders_never_build_a_kernel(tmp_path, monkeypatch):
    """One material, so `clshade render` compiles its constants and its uniform roughness and
    metallic in (Variant.build); the viewer's kernels read them at run time: after the first
    frame of each model no slider builds or even looks up a program, and every slider moves
    the image."""
    (tmp_path / "one.toml").write_text(red_sphere(), encoding="utf-8")
    s = ViewSession(tmp_path / "one.toml", tmp_path, 48, 48)
    start = controls(s, model_a="ggx_correlated", model_b="phong", split=True)
    previous = s.render(parse_controls(start, s.limits)).views
    calls = []
    real = s.runtime.kernel
    monkeypatch.setattr(s.runtime, "kernel", lambda *a, **k: calls.append(a[1]) or real(*a, **k))
    edits = [("roughness", 0.7), ("metallic", 0.9), ("base_color", [0.1, 0.7, 0.2]), ("ks", 0.8), ("kd", 0.1),
             ("shininess", 400.0), ("ka", 0.2)]
    values = {}
    for name, value in edits:
        values[name] = value
        frame = s.render(parse_controls(dict(start, materials={"red": dict(values)}), s.limits))
        assert frame.reshade_only
        assert any((frame.views[v] != previous[v]).any() for v in "ab"), name
        previous = frame.views
    assert calls == []


@pytest.mark.parametrize("model", ["ggx_correlated", "phong"])
def test_runtime_material_equals_compiled_in(tmp_path, model):
    """The viewer's kernel (material table, roughness and metallic read per pixel) writes the
    same bits as the one `clshade render` compiles (constants and uniform channels as literals):
    the saved view reproduces bit for bit on one-material scenes too."""
    from clshade.device.shade import Shader, scene_features
    from clshade.pipeline import prepare_frame
    from clshade.render.scene import parse_scene
    frame = prepare_frame(parse_scene(red_sphere(), tmp_path / "one.toml"), 64, 48)
    features = scene_features(frame.scene, geometry=frame.geometry)
    shader = Shader(get_runtime(), frame.gbuffer, frame.scene, frame.camera, frame.shadows)
    m = resolve(model)
    compiled = shader.variant(m, features)
    assert compiled.baked_material is not None and dict(features.uniform)["roughness"] == pytest.approx(0.4)
    live = dataclasses.replace(features, runtime_material=True)
    read = set(shader.variant(m, live).channels)
    assert "material" in read and {c for c in ("roughness", "metallic") if c in m.uses} <= read
    a, b = shader.render(m, features), shader.render(m, live)
    assert np.array_equal(a.view(np.uint32), b.view(np.uint32))


def test_plane_pool_hands_out_only_blocks_nothing_uses():
    from clshade.render.arrays import PLANE_ALIGN, PlanePool
    pool = PlanePool()
    a = pool.zeros((2, 64), np.float32)
    a[:] = 7.0
    view = a[1]                     # a view alone keeps the block in use
    del a
    b = pool.zeros((2, 64), np.float32)
    assert (b == 0).all() and not np.shares_memory(b, view) and b.ctypes.data % PLANE_ALIGN == 0
    b[:] = 3.0
    del view, b
    c = pool.zeros((2, 64), np.float32)
    assert (c == 0).all() and len(pool._blocks) == 2


def test_orbit_rasterises_and_exposure_does_not(session):
    session.render(parse_controls(controls(session), session.limits))
    moved = session.render(parse_controls(controls(session, azimuth=5.0), session.limits))
    assert "rasterize" in moved.stages and not moved.reshade_only
    brighter = session.render(parse_controls(controls(session, azimuth=5.0, exposure=1.0), session.limits))
    assert brighter.reshade_only and "rasterize" not in brighter.stages
    assert brighter.views["a"][..., :3].astype(int).sum() > moved.views["a"][..., :3].astype(int).sum()


def test_split_and_difference_views(session):
    one = session.render(parse_controls(controls(session, model_b="lambert"), session.limits))
    assert list(one.views) == ["a"]
    split = session.render(parse_controls(controls(session, model_b="lambert", split=True), session.limits))
    assert list(split.views) == ["a", "b"] and split.diff_scale is None
    both = session.render(parse_controls(controls(session, model_b="lambert", split=True, diff=True),
                                         session.limits))
    assert list(both.views) == ["a", "b", "diff"] and both.models == {"a": "lambert+ggx_correlated", "b": "lambert"}
    a, b = both.views["a"][..., :3].astype(int), both.views["b"][..., :3].astype(int)
    assert (a != b).any()
    assert both.diff_scale == pytest.approx(np.abs(a - b).max() / 255.0)
    same = (a == b).all(axis=-1)
    np.testing.assert_array_equal(both.views["diff"][same], both.views["diff"][same][:1].repeat(same.sum(), 0))
    for model in both.models.values():
        assert both.stats[model]["frames"] >= 1 and both.stats[model]["mean_ms"] > 0
    # The server's frames: each view read in place (its own output, not the next view's), equal to the copies.
    state = parse_controls(controls(session, model_b="lambert", split=True, diff=True, azimuth=20.0), session.limits)
    copied = session.render(state)
    in_place = session.finish(session.prepare(state), copy=False)
    for view in ("a", "b", "diff"):
        np.testing.assert_array_equal(in_place.views[view], copied.views[view], err_msg=view)


def test_only_read_columns_are_baked():
    """A material constant the model does not read (shininess for GGX) does not make a new kernel."""
    from clshade.device.variants import Features
    table = np.zeros((1, 4, 4), np.float32)
    table[0, 0] = [0.7, 0.3, 1.0, 32.0]
    other = table.copy()
    other[0, 0, 3] = 900.0
    ggx, phong = resolve("ggx_correlated"), resolve("phong")
    assert Variant.build(ggx, Features(), table).key == Variant.build(ggx, Features(), other).key
    assert Variant.build(phong, Features(), table).key != Variant.build(phong, Features(), other).key


# ---------------------------------------------------------------- the display transform


@pytest.mark.parametrize("method,exposure", [("aces", 0.0), ("reinhard", 2.25), ("none", -3.5), ("aces", 64.0),
                                             ("none", -200.0)])
def test_device_display_equals_to_display(session, method, exposure):
    """kernels/display.cl (four pixels a work-item) on any device; a pixel count that leaves the last
    work-item partial."""
    rng = np.random.default_rng(7)
    special = [np.nan, np.inf, -np.inf, 0.0, -0.0, -1.0, 1e-45, 1e-38, 3.4e38, 1e30]
    values = np.concatenate([rng.exponential(0.6, 4 * 4000), rng.uniform(0, 50, 4 * 1000), special * 4])
    values = np.resize(values.astype(np.float32), 4 * 5010)
    # every level's threshold and the float just below it
    t = thresholds(method, exposure)
    edges = t[np.isfinite(t)]
    values = np.concatenate([values, edges, np.nextafter(edges, np.float32(0))]).astype(np.float32)
    values = np.concatenate([values, np.zeros(-len(values) % 4, np.float32)])
    image = values.astype(np.float32).reshape(-1, 1, 4)
    image = image[:len(image) - (len(image) % 4 == 0)]       # not a multiple of PIXELS_PER_ITEM
    assert len(image) % PIXELS_PER_ITEM
    padding = np.full((items(len(image)) * PIXELS_PER_ITEM - len(image), 1, 4), 7.0, np.float32)
    display = Display(session.runtime)
    buf = session.runtime.to_device(np.concatenate([image, padding]))
    event, out = display.enqueue(buf, len(image), method, exposure)
    event.wait()
    got = display.read(out, len(image), 1)
    np.testing.assert_array_equal(got[..., :3], to_display(image, method, exposure))
    assert (got[..., 3] == 255).all()


def test_device_display_refuses_a_short_radiance_buffer(session):
    """The kernel reads whole groups of PIXELS_PER_ITEM pixels: a buffer of exactly 5 pixels is refused,
    with the sizes in the message, rather than read past its end."""
    buf = session.runtime.to_device(np.ones((5, 4), np.float32))
    with pytest.raises(ClshadeError, match="holds 80 bytes, the kernel reads 128"):
        Display(session.runtime).enqueue(buf, 5, "aces", 0.0)


# ---------------------------------------------------------------- save ↔ clshade render


@pytest.mark.parametrize("samples,specular_aa", [(1, False), (2, True)])
def test_saved_view_renders_bit_for_bit(session, tmp_path, monkeypatch, samples, specular_aa):
    c = parse_controls(controls(session, azimuth=-40.0, elevation=35.0, distance=6.0, exposure=0.75,
                                samples=samples, specular_aa=specular_aa,
                                tonemap="reinhard", model_a="oren_nayar+ggx_correlated@conductor",
                                model_b="blinn_phong", split=True,
                                materials={"paint_red": {"roughness": 0.12, "ks": 0.5}},
                                lights={"0": {"direction": [0.3, -1.0, 0.2], "scale": 1.7}, "1": {"scale": 0.5}}),
                       session.limits)
    frame = session.render(c)
    result = session.save(c, "snap")
    out = session.out_dir
    assert {"snap.toml", "snap.png", "snap.exr", "snap_b.png"} <= set(result["files"])
    np.testing.assert_array_equal(np.round(read_image(out / "snap.png") * 255).astype(np.uint8),
                                  frame.views["a"][..., :3])
    monkeypatch.chdir(out)
    assert main(["render", "snap.toml", "-o", str(tmp_path / "again.png")]) == 0
    assert main(["render", "snap.toml", "-o", str(tmp_path / "again.exr")]) == 0
    assert main(["render", "snap.toml", "-m", "blinn_phong", "-o", str(tmp_path / "again_b.png")]) == 0
    for mine, theirs in (("snap.png", "again.png"), ("snap.exr", "again.exr"), ("snap_b.png", "again_b.png")):
        a, b = read_image(out / mine), read_image(tmp_path / theirs)
        assert a.shape == b.shape and np.array_equal(a, b, equal_nan=True), mine


@pytest.mark.parametrize("name", ["../up", "a/b", ".hidden", "", "x" * 65, "robot", None, "a\n", "view\n"])
def test_save_names_stay_in_the_output_folder(tmp_path, name):
    (tmp_path / "robot.toml").write_text(ROBOT.read_text(encoding="utf-8"), encoding="utf-8")
    s = ViewSession(tmp_path / "robot.toml", tmp_path, 16, 16)
    with pytest.raises(ClshadeError):
        s.save(parse_controls(s.initial_controls(), s.limits), name)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["robot.toml"]


# ---------------------------------------------------------------- the server


class FakeSocket:
    closed = False

    def __init__(self):
        self.sent: list = []

    async def send_str(self, text):
        self.sent.append(json.loads(text))

    async def send_bytes(self, data):
        self.sent.append(data)

    async def close(self):
        self.closed = True


class SlowSession:
    """Records what it renders; each frame takes a while, so states pile up meanwhile."""

    def __init__(self, real):
        self.limits, self.rendered = real.limits, []
        self.real = real

    def prepare(self, c):
        import time
        time.sleep(0.025)
        return c.exposure, self.real.prepare(dataclasses.replace(c, exposure=0.0))

    def finish(self, p, copy=True):
        import time
        time.sleep(0.025)
        exposure, prepared = p
        self.rendered.append(exposure)
        return self.real.finish(prepared, copy)

    def render(self, c):
        return self.finish(self.prepare(c))


def test_latest_state_wins(session):
    from clshade.view.server import Page, ViewServer
    slow = SlowSession(session)
    server = ViewServer(slow, log=lambda text: None)

    async def scenario():
        ws = FakeSocket()
        page = Page(server, ws)
        task = asyncio.create_task(page.run())
        for k in range(6):
            await page.receive(json.dumps(dict(type="state", seq=k + 1, controls=controls(session, exposure=float(k)))))
            await asyncio.sleep(0.01 if k else 0.0)
        await asyncio.sleep(0.4)
        ws.closed = True
        page.wake.set()
        await task
        return ws, page

    ws, page = asyncio.run(scenario())
    server.executor.shutdown()
    frames = [json.loads(m[4:4 + int.from_bytes(m[:4], "little")]) for m in ws.sent if isinstance(m, bytes)]
    assert slow.rendered[-1] == 5.0 and frames[-1]["seq"] == 6          # the newest state is shown
    assert len(slow.rendered) < 6 and page.skipped == 6 - len(slow.rendered)   # stale ones were dropped
    assert slow.rendered == sorted(slow.rendered)                       # never an older state after a newer


def test_bad_messages_answer_an_error_and_the_page_goes_on(session):
    from clshade.view.server import Page, ViewServer
    server = ViewServer(session, log=lambda text: None)

    async def scenario():
        ws = FakeSocket()
        page = Page(server, ws)
        for text in ["{oops", '{"type": "state", "seq": 3, "controls": {"exposure": NaN}}',
                     json.dumps(dict(type="state", seq=4, controls=controls(session, model_a="nope"))),
                     json.dumps(dict(type="state", seq=5, controls=controls(session, exposure=1e9))),
                     json.dumps(dict(type="state", seq=-1, controls=controls(session))),
                     json.dumps(dict(type="warp", seq=6))]:
            await page.receive(text)
        assert page.pending is None and not page.jobs
        await page.receive(json.dumps(dict(type="state", seq=7, controls=controls(session))))
        assert page.pending is not None and page.pending[0] == 7
        return ws

    ws = asyncio.run(scenario())
    server.executor.shutdown()
    errors = [m for m in ws.sent if isinstance(m, dict) and m["type"] == "error"]
    assert [e["seq"] for e in errors] == [None, None, 4, 5, -1, 6]
    assert "not JSON" in errors[0]["message"] and "NaN" in errors[1]["message"]
    assert "model_a" in errors[2]["message"] and "exposure" in errors[3]["message"]
    assert all("Traceback" not in e["message"] for e in errors)


def test_http_guards(session):
    """Loopback only by default; another Host (DNS rebinding) and another origin's WebSocket are refused;
    on another address the token is required."""
    from aiohttp.test_utils import TestClient, TestServer
    from clshade.view.server import ViewServer

    async def scenario():
        out = {}
        local = ViewServer(session, log=lambda text: None)
        async with TestClient(TestServer(local.app(), host="127.0.0.1")) as client:
            out["page"] = (await client.get("/")).status
            out["script"] = (await client.get("/view.js")).status
            out["other"] = (await client.get("/../pyproject.toml")).status
            out["rebinding"] = (await client.get("/", headers={"Host": "evil.example:80"})).status
            out["origin"] = (await client.get("/ws", headers={"Origin": "http://evil.example"})).status
            ws = await client.ws_connect("/ws")
            hello = await ws.receive_json(timeout=30)
            out["hello"] = hello["type"]
            await ws.close()
        remote = ViewServer(session, host="0.0.0.0", log=lambda text: None)
        assert remote.token and len(remote.token) >= 20
        async with TestClient(TestServer(remote.app(), host="127.0.0.1")) as client:
            out["no token"] = (await client.get("/")).status
            out["bad token"] = (await client.get("/?token=x")).status
            out["token"] = (await client.get(f"/?token={remote.token}")).status
        local.executor.shutdown()
        remote.executor.shutdown()
        return out

    out = asyncio.run(scenario())
    assert out == {"page": 200, "script": 200, "other": 404, "rebinding": 403, "origin": 403, "hello": "hello",
                   "no token": 403, "bad token": 403, "token": 200}


def test_closing_the_last_page_stops_the_server(session):
    import aiohttp
    from clshade.view.server import ServerThread
    running = ServerThread(session, linger=0.2)

    async def visit(url):
        async with aiohttp.ClientSession() as http:
            async with http.ws_connect(url + "ws") as ws:
                assert (await ws.receive_json(timeout=30))["type"] == "hello"

    with running as url:
        asyncio.run(visit(url))
        running.thread.join(timeout=20)
        assert not running.thread.is_alive()          # stopped by itself, 0.2 s after the page left


def test_ctrl_c_stops_the_command_cleanly(tmp_path):
    import signal
    import subprocess
    import sys
    proc = subprocess.Popen([sys.executable, "-m", "clshade", "view", str(ROBOT), "--no-browser", "--width", "32",
                             "--height", "32", "-o", str(tmp_path)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        line = proc.stdout.readline()
        assert line.startswith("clshade view: serving http://127.0.0.1:"), line + proc.stderr.read()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 0 and "stopped" in out and "Traceback" not in err


def test_raster_follows_a_new_geometry(session, monkeypatch):
    """When the geometry is built again (its key changed), the next raster is of the new one: the
    kept RasterMesh (checks and face planes) is made again, never reused for another geometry."""
    import clshade.view.session as view_session
    real_build, real_key = view_session.build_geometry, view_session._geometry_key

    def build(scene):                       # the geometry lifted by the exposure (a stand-in for a real edit)
        g = real_build(scene)
        return dataclasses.replace(g, vertices=g.vertices + [0.0, 0.3 * scene.exposure, 0.0])

    monkeypatch.setattr(view_session, "build_geometry", build)
    monkeypatch.setattr(view_session, "_geometry_key", lambda scene: (real_key(scene), scene.exposure))
    for exposure in (0.0, 1.0):
        frame = session.render(parse_controls(controls(session, azimuth=15.0, exposure=exposure), session.limits))
        assert "rasterize" in frame.stages
        g, camera = session._geometry.value, session.last["camera"]
        expected = rasterize(g.vertices, g.faces, camera.view_matrix(), camera.projection_matrix(), camera.width,
                             camera.height, cull_backfaces=g.cull)
        made = build_gbuffer(session.last["scene"], g, expected, camera)   # the kept raster's G-buffer is of it
        for name in ("depth", "normal"):
            np.testing.assert_array_equal(session.last["gbuffer"].plane(name), made.plane(name),
                                          err_msg=f"exposure {exposure} {name}")


def test_camera_only_changes_parse_only_the_camera_and_give_the_full_scene(session, monkeypatch):
    """Orbit and zoom reuse the last scene with the camera parsed anew; any other change parses
    everything: either way the scene equals the scene parser's of the same document."""
    import clshade.view.session as view_session
    from clshade.render.scene import scene_from_data
    full = []
    real = view_session.scene_from_data
    monkeypatch.setattr(view_session, "scene_from_data",
                        lambda doc, path, registry: full.append(1) or real(doc, path, registry))
    steel = {"steel": {"roughness": 0.2}}
    lights = {"0": {"scale": 2.0}}
    steps = [dict(azimuth=3.0), dict(azimuth=7.0, distance=session.orbit.distance * 1.3),
             dict(azimuth=7.0, materials=steel), dict(azimuth=9.0, elevation=20.0, materials=steel),
             dict(azimuth=9.0, elevation=20.0, materials=steel, exposure=0.5),
             dict(azimuth=9.0, elevation=20.0, materials=steel, exposure=0.5, lights=lights),
             dict(azimuth=11.0, elevation=20.0, materials=steel, exposure=0.5, lights=lights)]
    parsed = []
    for change in steps:
        count = len(full)
        scene, doc = session.scene(parse_controls(controls(session, **change), session.limits))
        parsed.append(len(full) > count)
        expected = scene_from_data(doc, session.path)
        for f in dataclasses.fields(expected):
            assert _same_value(getattr(scene, f.name), getattr(expected, f.name)), f"{change}: {f.name}"
    assert parsed[1] is False and parsed[3] is False and parsed[6] is False       # camera only
    assert parsed[2] and parsed[4] and parsed[5]                                  # material, exposure, light


def _same_value(a, b) -> bool:
    """Deep equality of parsed scene values (dataclasses, arrays, containers)."""
    if dataclasses.is_dataclass(a):
        return type(a) is type(b) and all(_same_value(getattr(a, f.name), getattr(b, f.name))
                                          for f in dataclasses.fields(a))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(a, b)
    if isinstance(a, (tuple, list)):
        return type(a) is type(b) and len(a) == len(b) and all(_same_value(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same_value(a[k], b[k]) for k in a)
    return a == b


@pytest.mark.parametrize("width, height", [(64, 2), (37, 5), (480, 270), (7, 3), (1, 1)])
def test_frame_messages_carry_every_pixel(width, height):
    """pack_frame's segment encoding is lossless at any size (a partial last run included): an
    object on a background, a background in one corner only, a frame with no background at all,
    pixels equal to the background in the middle of an object's runs, and a second view."""
    from clshade.view.server import SEGMENT, background_value, pack_frame, unpack_frame
    from clshade.view.session import ViewFrame
    rng = np.random.default_rng(width * height)
    background = np.array([24, 28, 35, 255], np.uint8)
    scene = np.broadcast_to(background, (height, width, 4)).copy()
    y0, x0 = height // 3, width // 4
    scene[y0:, x0:x0 + max(1, width // 2)] = rng.integers(0, 256, (height - y0, max(1, width // 2), 4), np.uint8)
    scene[-1, -1] = background                              # the object's last pixel is the background
    noise = rng.integers(0, 256, (height, width, 4), np.uint8)
    corner = noise.copy()
    corner[: max(1, height // 2), : max(1, width // 2)] = (9, 8, 7, 255)
    for views in ({"a": scene}, {"a": noise}, {"a": corner, "b": scene}):
        frame = ViewFrame(width, height, views, {}, {}, {k: "lambert" for k in views})
        header, decoded = unpack_frame(pack_frame(frame, 7, {}))
        assert header["seq"] == 7 and list(decoded) == list(views)
        for name, rgba in views.items():
            np.testing.assert_array_equal(decoded[name], rgba, err_msg=f"{name} of {width}x{height}")
    pixels = scene.reshape(-1).view("<u4").reshape(height, width)
    if width * height >= 4 * SEGMENT:
        assert background_value(pixels) == int(background.view("<u4")[0])
        corner_pixels = corner.reshape(-1).view("<u4").reshape(height, width)
        assert background_value(corner_pixels) == int(np.array([9, 8, 7, 255], np.uint8).view("<u4")[0])
        message = pack_frame(ViewFrame(width, height, {"a": scene}, {}, {}, {"a": "lambert"}), 1, {})
        assert len(message) < 0.8 * scene.nbytes              # the background does not travel


def test_pipelined_frames_show_their_own_state(session):
    """The raster thread prepares a state while the render thread finishes the one before: the
    stages overlap, yet every frame sent is of its own state (its pixels are a fresh render of
    that state's controls: never another state's camera), frames leave in order, the newest last."""
    import threading
    import time
    from clshade.view.server import Page, ViewServer, unpack_frame

    class Recorder:
        def __init__(self, real):
            self.limits, self.real, self.spans, self.lock = real.limits, real, [], threading.Lock()

        def _span(self, kind, fn, arg):
            start = time.perf_counter()
            time.sleep(0.005 if kind == "prepare" else 0.06)   # shading slower: states prepared meanwhile
            out = fn(arg)
            azimuth = (arg if kind == "prepare" else arg.controls).azimuth
            with self.lock:
                self.spans.append((kind, start, time.perf_counter(), azimuth))
            return out

        def prepare(self, c):
            return self._span("prepare", self.real.prepare, c)

        def finish(self, p, copy=True):
            return self._span("finish", lambda q: self.real.finish(q, copy), p)

    recorder = Recorder(session)
    server = ViewServer(recorder, log=lambda text: None)
    states = {k + 1: controls(session, azimuth=11.0 * k, elevation=15.0 + 2.0 * k) for k in range(8)}

    async def scenario():
        ws = FakeSocket()
        page = Page(server, ws)
        task = asyncio.create_task(page.run())
        for seq, c in states.items():
            await page.receive(json.dumps(dict(type="state", seq=seq, controls=c)))
            await asyncio.sleep(0.02)
        await asyncio.sleep(1.0)
        ws.closed = True
        page.wake.set()
        await task
        return ws

    ws = asyncio.run(scenario())
    server.executor.shutdown()
    server.raster_executor.shutdown()
    frames = []
    for m in ws.sent:
        if isinstance(m, bytes):
            header, views = unpack_frame(m)
            frames.append((header["seq"], views["a"].reshape(-1)))
    seqs = [seq for seq, _ in frames]
    assert len(frames) >= 2 and seqs == sorted(set(seqs)) and seqs[-1] == max(states)
    for seq, pixels in frames:
        fresh = session.render(parse_controls(states[seq], session.limits)).views["a"].reshape(-1)
        np.testing.assert_array_equal(pixels, fresh, err_msg=f"frame of state {seq}")
    prepares = [(a, b, az) for kind, a, b, az in recorder.spans if kind == "prepare"]
    finishes = [(a, b, az) for kind, a, b, az in recorder.spans if kind == "finish"]
    assert any(p0 < f1 and f0 < p1 for p0, p1, _ in prepares for f0, f1, _ in finishes)      # the stages overlapped
    # Latest wins: a finish takes the newest state prepared by then, never an older one while a newer one
    # had been waiting (by more than HANDOFF_S: the pick happens just before the finish span starts).
    HANDOFF_S = 0.005
    for f0, _, az in finishes:
        waiting = [p_az for _, p1, p_az in prepares if p1 < f0 - HANDOFF_S]
        assert not waiting or az >= max(waiting), f"finished azimuth {az} while {max(waiting)} was prepared"


# ---------------------------------------------------------------- the device's G-buffer or the host's


def _frames(s, states) -> list:
    return [s.render(parse_controls(controls(s, **state), s.limits)) for state in states]


ORBIT_STATES = [{}, dict(materials={"steel": {"roughness": 0.8}}), dict(azimuth=40.0), dict(azimuth=95.0, distance=3.0),
                dict(azimuth=95.0, distance=3.0, split=True)]


def test_the_host_path_shows_the_device_paths_frames(tmp_path):
    """A session that rasterizes on the host (device_gbuffer=False, the textured scenes' path)
    shows the frames of one whose device makes the visibility buffer and G-buffer: orbit, a
    slider (the G-buffer patch), a close view, a split."""
    device = ViewSession(ROBOT, tmp_path, W, H)
    host = ViewSession(ROBOT, tmp_path, W, H, device_gbuffer=False)
    device_frames, host_frames = _frames(device, ORBIT_STATES), _frames(host, ORBIT_STATES)
    for d, h in zip(device_frames, host_frames):
        assert d.views.keys() == h.views.keys()
        for view in d.views:
            np.testing.assert_array_equal(d.views[view], h.views[view])
        assert DEVICE_GBUFFER_STAGE not in h.stages
    assert all(DEVICE_GBUFFER_STAGE in device_frames[i].stages and "g-buffer" in host_frames[i].stages
               for i in (0, 2, 3))


@pytest.mark.parametrize("failure", ["differs", "build fails"])
def test_a_device_that_fails_its_check_leaves_the_host_path(tmp_path, monkeypatch, failure):
    """Where the device's first small frame differs from the host's (or its program fails to build),
    the session turns the device path off, says why in the notes, and shows the host's frames from
    that first frame on."""
    from clshade import diagnostics, pipeline

    monkeypatch.setattr(pipeline, "_VERIFIED", {})     # the process keeps earlier tests' verdicts
    if failure == "differs":
        monkeypatch.setattr(pipeline.device_visibility, "verify",
                            lambda *args: "3 of 5184 pixels differ from the host's in normal")
        why = "differ from the host's in normal"
    else:
        def broken(*args, **kwargs):    # as pip's PoCL 3.0 did with double8 (no kernels in the cached program)
            raise ClshadeError("visibility.cl: the program lists no kernel 'visibility'")
        monkeypatch.setattr(pipeline.device_visibility, "DeviceGBuffer", broken)
        why = "the program lists no kernel 'visibility'"
    monkeypatch.setattr(diagnostics, "NOTES", [])
    s = ViewSession(ROBOT, tmp_path, W, H)
    host = ViewSession(ROBOT, tmp_path, W, H, device_gbuffer=False)
    frames = _frames(s, ORBIT_STATES)
    assert why in (s.device_gbuffer_off or "") and not s.device_gbuffer
    assert any("visibility buffer is off" in n and why in n for n in diagnostics.NOTES)
    for f, h in zip(frames, _frames(host, ORBIT_STATES)):
        assert DEVICE_GBUFFER_STAGE not in f.stages
        for view in h.views:
            np.testing.assert_array_equal(f.views[view], h.views[view])


# ---------------------------------------------------------------- hostile messages and lobe paths


class StrictSocket(FakeSocket):
    """Reads what the server sends as the page's JSON.parse does: no NaN or Infinity."""

    async def send_str(self, text):
        self.sent.append(json.loads(text, parse_constant=lambda name: pytest.fail(f"{name} sent to the page")))


def _answers(session, texts: list[str]) -> tuple[list, object]:
    """What a page gets for these messages (every one is answered; none raises), and the Page."""
    from clshade.view.server import Page, ViewServer
    server = ViewServer(session, log=lambda text: None)

    async def scenario():
        ws = StrictSocket()
        page = Page(server, ws)
        for text in texts:
            await page.receive(text)
        return ws, page

    ws, page = asyncio.run(scenario())
    server.executor.shutdown()
    return ws.sent, page


@pytest.mark.parametrize("change, key", [
    (dict(azimuth=10 ** 400), "azimuth"), (dict(distance=-10 ** 400), "distance"),
    (dict(materials={"steel": {"roughness": 10 ** 400}}), "materials.steel.roughness"),
    (dict(materials={"steel": {"base_color": [0.5, 10 ** 400, 0.5]}}), "materials.steel.base_color[1]"),
    (dict(lights={"0": {"scale": 10 ** 400}}), "lights.0.scale"),
    (dict(lights={"²": {"scale": 1.0}}), "lights.²"), (dict(lights={"١": {"scale": 1.0}}), "lights.١"),
    (dict(lights={"9" * 5000: {"scale": 1.0}}), "no such light"),
])
def test_numbers_past_a_float_and_odd_light_indices_answer_an_error(session, change, key):
    """An int too large for a float, a light index of a superscript or 5000 digits: an error naming the key,
    and the page goes on (a good state after it is taken)."""
    sent, page = _answers(session, [json.dumps(dict(type="state", seq=8, controls=controls(session, **change))),
                                    json.dumps(dict(type="state", seq=9, controls=controls(session)))])
    assert [m["type"] for m in sent] == ["error"] and sent[0]["seq"] == 8
    assert key in sent[0]["message"] and "Traceback" not in sent[0]["message"]
    assert page.pending is not None and page.pending[0] == 9


def test_the_page_never_gets_nan(session):
    """A message holding NaN or Infinity is not JSON: the page gets an error naming it instead."""
    from clshade.view.server import Page, ViewServer
    server = ViewServer(session, log=lambda text: None)

    async def scenario():
        ws = StrictSocket()
        await Page(server, ws).send_json(dict(type="oracle", seq=3, max_rel_error=float("nan")))
        return ws.sent

    sent = asyncio.run(scenario())
    server.executor.shutdown()
    assert sent[0]["type"] == "error" and sent[0]["seq"] == 3 and "oracle message" in sent[0]["message"]


def _scene_folder(tmp_path):
    """tmp/scene/robot.toml with lobes/ward.brdf beside it, and tmp/outside/ holding ward.brdf and a .cl whose
    header line would be echoed in an error; scene/escape links to outside/."""
    scene, outside = tmp_path / "scene", tmp_path / "outside"
    (scene / "lobes").mkdir(parents=True)
    outside.mkdir()
    (scene / "robot.toml").write_text(ROBOT.read_text(encoding="utf-8"), encoding="utf-8")
    ward = (scenes_dir() / "lobes" / "ward.brdf").read_text(encoding="utf-8")
    for folder in (scene / "lobes", outside):
        (folder / "ward.brdf").write_text(ward, encoding="utf-8")
    (outside / "secret.cl").write_text("/*! clshade-model\n * SECRET LINE 42\n */\n", encoding="utf-8")
    (scene / "escape").symlink_to(outside)
    return scene, outside


def test_model_paths_are_confined_to_the_scenes_folder(tmp_path, monkeypatch):
    """The page may name lobe files and folders in the scene's folder (relative ones from there, whatever the
    current folder) and in lobe folders given to the command; elsewhere, through `..`, `~` or a link, it is
    refused before anything there is read."""
    scene, outside = _scene_folder(tmp_path)
    given = tmp_path / "given"
    given.mkdir()
    (given / "mine.brdf").write_text((scene / "lobes" / "ward.brdf").read_text(encoding="utf-8"), encoding="utf-8")
    monkeypatch.chdir(outside)
    s = ViewSession(scene / "robot.toml", tmp_path, 16, 16, registry=Registry().with_lobes(given))
    for spec in (str(outside / "ward.brdf"), str(outside / "secret.cl"), "../outside/ward.brdf",
                 "escape/ward.brdf", "escape/secret.cl", str(outside) + "/", "escape/", "~/ward.brdf"):
        with pytest.raises(ControlError) as info:
            parse_controls(controls(s, model_a=spec), s.limits)
        assert "outside the folders lobe files are read from here" in str(info.value), spec
        assert "SECRET" not in str(info.value)
    with pytest.raises(ControlError, match="no such lobe file"):    # the current folder's ward.brdf is not read
        parse_controls(controls(s, model_a="ward.brdf"), s.limits)
    for spec, path in (("lobes/ward.brdf", scene / "lobes" / "ward.brdf"),
                       (str(scene / "lobes" / "ward.brdf"), scene / "lobes" / "ward.brdf"),
                       (str(given / "mine.brdf"), given / "mine.brdf")):
        c = parse_controls(controls(s, model_a=spec, model_b="ggx_correlated/kdks"), s.limits)
        a, b = c.models(s.registry)
        assert a.specular_lobe.path == path and b.workflow == "kdks"
    chosen = parse_controls(controls(s, model_a="lobes/ward.brdf"), s.limits)
    assert s.render(chosen).models == {"a": "ward"}
    s.save(chosen, "saved")             # in tmp_path: the relative lobe path is rewritten for the saved scene
    from clshade.render.scene import load_scene
    assert Path(load_scene(tmp_path / "saved.toml").model).resolve() == scene / "lobes" / "ward.brdf"


def test_a_message_naming_a_broken_or_fifo_folder_leaves_the_server_answering(tmp_path):
    """A folder with a broken lobe, or with a FIFO named like one, is answered with an error; the registry
    stays as the command built it (a later page's hello and frame are as ever) and the server keeps
    answering (the FIFO is never opened, so nothing waits for a writer)."""
    import os
    import aiohttp
    from clshade.view.server import ServerThread
    from conftest import unblock_fifo
    scene, _ = _scene_folder(tmp_path)
    (scene / "bad").mkdir()
    (scene / "bad" / "broken.cl").write_text("/*! clshade-model\n * id: broken\n */\n", encoding="utf-8")
    (scene / "pipe").mkdir()
    fifo = scene / "pipe" / "x.cl"
    os.mkfifo(fifo)
    s = ViewSession(scene / "robot.toml", tmp_path, 16, 16)
    strict = dict(loads=lambda text: json.loads(text, parse_constant=lambda name: pytest.fail(name)))

    async def visit(url):
        got = []
        async with aiohttp.ClientSession() as http:
            async with http.ws_connect(url + "ws") as ws:
                hello = await ws.receive_json(timeout=60, **strict)
                for seq, folder in ((1, f"{scene}/bad/"), (2, f"{scene}/pipe/")):
                    await ws.send_str(json.dumps(dict(type="state", seq=seq,
                                                      controls=dict(hello["controls"], model_a=folder))))
                    got.append(await ws.receive_json(timeout=20, **strict))
            async with http.ws_connect(url + "ws") as ws:       # a later page
                hello = await ws.receive_json(timeout=60, **strict)
                await ws.send_str(json.dumps(dict(type="state", seq=3, controls=hello["controls"])))
                frame = await ws.receive(timeout=60)
        return got, hello, frame

    running = ServerThread(s)
    try:
        with running as url:
            got, hello, frame = asyncio.run(visit(url))
    finally:
        unblock_fifo(fifo)      # a server stuck opening the FIFO goes on (and the test has failed above)
    assert [(m["type"], m["seq"]) for m in got] == [("error", 1), ("error", 2)]
    assert "broken.cl:3: header lacks" in got[0]["message"] and "lobe file is a FIFO" in got[1]["message"]
    assert hello["type"] == "hello" and "broken" not in {l["id"] for l in hello["lobes"]}
    assert frame.type == aiohttp.WSMsgType.BINARY

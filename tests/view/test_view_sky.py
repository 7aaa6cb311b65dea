"""The viewer's environment and canvas controls without a browser: the sky picker and rung controls
checked and written into the scene, only what a control changes rebuilt, the canvas size capped and
followed, the sky error's steps equal to the environment oracle, the server's sky-error messages."""
from __future__ import annotations

import asyncio
import json
import shutil
import tomllib

import numpy as np
import pytest

from clshade.device.variants import ENV_RUNG_DEFINES
from clshade.render import environment as env
from clshade.render.scene import load_scene
from clshade.resources import scenes_dir
from clshade.verify import environment_oracle
from clshade.errors import ClshadeError
from clshade.view.controls import MAX_CANVAS, ControlError, canvas_cap, fit_canvas, parse_controls
from clshade.view.session import SKY_ERROR_STEP, ViewSession, cost_label

from sky_maps import write_map

SKY_SCENE = scenes_dir() / "environment.toml"
ROBOT = scenes_dir() / "robot.toml"
W, H = 48, 48


@pytest.fixture(scope="module")
def sky(tmp_path_factory):
    return ViewSession(SKY_SCENE, tmp_path_factory.mktemp("sky-out"), W, H, sky_error_pixels=20)


def state(session, environment=None, **changes):
    c = dict(session.initial_controls(), **changes)
    c["environment"] = {**c["environment"], "samples": 4, **(environment or {})}
    return c


def checked(session, environment=None, **changes):
    return parse_controls(state(session, environment, **changes), session.limits)


# ---------------------------------------------------------------- the controls


def test_the_picker_lists_the_scene_folders_maps(tmp_path):
    folder = tmp_path / "scene"
    (folder / "environments").mkdir(parents=True)
    shutil.copy(SKY_SCENE, folder / "sky.toml")
    for name in ("courtyard_128x64.exr", "second.hdr", "notes.txt"):
        shutil.copy(scenes_dir() / "environments" / "courtyard_128x64.exr", folder / "environments" / name)
    shutil.copy(scenes_dir() / "environments" / "courtyard_128x64.exr", folder / "top.exr")
    s = ViewSession(folder / "sky.toml", tmp_path, W, H)
    assert s.skies == ("none", "white", "environments/courtyard_128x64.exr", "top.exr", "environments/second.hdr")
    hello = s.hello()
    assert hello["rungs"] == dict(diffuse=list(env.DIFFUSE_RUNGS), specular=list(env.SPECULAR_RUNGS),
                                  max_samples=env.MAX_SAMPLES)
    assert hello["controls"]["environment"]["sky"] is None and "courtyard" in hello["scene_sky"]


@pytest.mark.parametrize("change, why", [
    (dict(sky="../../etc/passwd.exr"), "no such sky"), (dict(sky=3), "no such sky"),
    (dict(diffuse="sh3"), "environment.diffuse"), (dict(specular="mirror"), "environment.specular"),
    (dict(samples=0), "environment.samples"), (dict(samples=env.MAX_SAMPLES + 1), "environment.samples"),
    (dict(samples=True), "environment.samples"), (dict(rotation=400.0), "environment.rotation"),
    (dict(intensity=-1.0), "environment.intensity"), (dict(exposure=1.0), "environment.exposure"),
])
def test_bad_sky_controls_are_refused_with_the_key(sky, change, why):
    with pytest.raises(ControlError, match=why):
        checked(sky, change)


def test_every_rung_the_environment_module_lists_is_accepted(sky):
    for diffuse in env.DIFFUSE_RUNGS:
        for specular in env.SPECULAR_RUNGS:
            c = checked(sky, dict(diffuse=diffuse, specular=specular))
            assert (c.environment.diffuse, c.environment.specular) == (diffuse, specular)


def test_each_sky_control_reaches_its_own_key_of_the_scene(sky):
    """Each control lands in the [environment] key of its name (a control wired to another key fails)."""
    c = checked(sky, dict(diffuse="constant", specular="none", samples=7, rotation=33.0, intensity=0.25))
    scene, doc = sky.scene(c)
    spec = scene.environment
    assert (spec.diffuse, spec.specular, spec.samples, spec.rotation, spec.intensity) == \
        ("constant", "none", 7, 33.0, 0.25)
    assert spec.map.name == "courtyard_128x64.exr" and scene.environment_background
    white, _ = sky.scene(checked(sky, dict(sky="white")))
    assert white.environment.uniform == (1.0, 1.0, 1.0) and white.environment.map is None
    none, doc = sky.scene(checked(sky, dict(sky="none")))
    assert none.environment is None and "environment" not in doc and tuple(none.background) == (0.0, 0.0, 0.0)
    assert "map" in sky.base_doc["environment"]           # the scene's own tables are never changed


def test_a_sky_given_to_a_scene_without_one(tmp_path):
    robot = ViewSession(ROBOT, tmp_path, W, H)
    assert robot.initial_controls()["environment"]["sky"] == "none" and robot.base_scene.environment is None
    scene, _ = robot.scene(checked(robot, dict(sky="white", diffuse="sh9")))
    assert scene.environment.uniform == (1.0, 1.0, 1.0) and scene.environment.diffuse == "sh9"
    assert robot.scene(checked(robot))[0].environment is None


@pytest.mark.parametrize("size, cap, fitted", [
    ((3840, 2160), (1920, 1080), (1920, 1080)), ((1000, 2000), (1920, 1080), (540, 1080)),
    ((800, 600), (1920, 1080), (800, 600)), ((5000, 10), (1920, 1080), (1920, 4)), ((1, 1), (4, 4), (1, 1)),
])
def test_the_canvas_is_fitted_within_the_cap(size, cap, fitted):
    assert fit_canvas(*size, cap) == fitted


def test_the_canvas_size_is_checked_and_capped(sky):
    c = checked(sky, width=4000, height=2000)
    assert (c.width, c.height) == (1920, 960) and MAX_CANVAS == (1920, 1080)
    for change, why in ((dict(width=100), "width and height"), (dict(width=0, height=10), "width"),
                        (dict(width=10, height=1.5), "height"), (dict(width=3000, height=3000, samples=9), "samples")):
        with pytest.raises(ControlError, match=why):
            checked(sky, **change)


# ---------------------------------------------------------------- frames


def test_frames_follow_the_canvas_and_equal_a_session_of_that_size(sky, tmp_path):
    """A resize mid-orbit: the frame of the new size, equal to a fresh session's frame at that size."""
    first = sky.render(checked(sky, azimuth=10.0))
    assert (first.width, first.height) == (W, H)
    resized = sky.render(checked(sky, azimuth=20.0, width=64, height=40))
    assert (resized.width, resized.height) == (64, 40) and resized.views["a"].shape == (40, 64, 4)
    fresh = ViewSession(SKY_SCENE, tmp_path, 64, 40)
    same = fresh.render(checked(fresh, azimuth=20.0))
    np.testing.assert_array_equal(resized.views["a"], same.views["a"])
    back = sky.render(checked(sky, azimuth=20.0))
    assert (back.width, back.height) == (W, H)


def test_a_rung_change_builds_a_variant_and_uploads_nothing(sky):
    sky.render(checked(sky))
    shader = sky._shader.value
    for diffuse in env.DIFFUSE_RUNGS:
        frame = sky.render(checked(sky, dict(diffuse=diffuse)))
        assert sky._shader.value is shader and "upload" not in frame.stages and frame.reshade_only
        assert frame.environment["diffuse"] == diffuse
        assert f"ENV_DIFFUSE={ENV_RUNG_DEFINES[diffuse]} " in frame.environment["variant"] + " "
        assert frame.costs["a"] == cost_label(frame.models["a"], sky.last["scene"].environment)
        assert frame.stats[frame.costs["a"]]["frames"] >= 1
    assert {f"{frame.models['a']} [{d}|sampled ×4]" for d in env.DIFFUSE_RUNGS} <= set(frame.ladder)
    assert frame.environment["diffuse"] == "sampled" and frame.environment["samples"] == 4
    more = sky.render(checked(sky, dict(diffuse="sampled", samples=16)))    # an argument: bound again, not uploaded
    assert sky._shader.value is shader and "upload" not in more.stages and more.environment["samples"] == 16
    assert (more.views["a"] != frame.views["a"]).any()                      # the kernel took the new count
    turned = sky.render(checked(sky, dict(diffuse="sampled", samples=16, rotation=90.0)))   # turned: params rewritten
    assert sky._shader.value is shader and "upload" not in turned.stages
    assert (turned.views["a"] != more.views["a"]).any()
    brighter = sky.render(checked(sky, dict(diffuse="sampled", samples=16, rotation=90.0, intensity=2.0)))
    assert "upload" in brighter.stages                                      # new sky data: uploaded


def test_a_map_rewritten_on_disk_is_shown_turned_or_not(tmp_path):
    """The viewer's sky follows its file: rewritten three times brighter while the viewer runs, the next
    frames, turned or not, equal the old map's at intensity 3 (to a display level), not the old data
    rebound."""
    folder = tmp_path / "scene"
    shutil.copytree(SKY_SCENE.parent / "environments", folder / "environments")
    shutil.copy(SKY_SCENE, folder / "sky.toml")
    session = ViewSession(folder / "sky.toml", tmp_path, W, H)
    session.render(checked(session))
    rotations = (90.0, 0.0)                       # the slider moved after the rewrite, then back
    want = {r: session.render(checked(session, dict(rotation=r, intensity=3.0))).views["a"] for r in rotations}
    session.render(checked(session))
    path = folder / "environments" / "courtyard_128x64.exr"
    write_map(path, 3.0 * env.read_map(path))
    for r in rotations:
        got = session.render(checked(session, dict(rotation=r))).views["a"]
        assert np.abs(got.astype(np.int16) - want[r]).max() <= 1, r


def test_picking_a_sky_changes_the_image(sky):
    frames = {name: sky.render(checked(sky, dict(sky=name))).views["a"] for name in sky.skies}
    names = list(frames)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            assert (frames[a] != frames[b]).any(axis=-1).mean() > 0.05, (a, b)


def test_the_sky_errors_steps_equal_the_oracle(sky):
    c = checked(sky, dict(samples=8))
    job = sky.sky_error_job(c)
    steps = list(job.steps())
    assert steps[-1] == (job.total, job.total) and len(steps) == -(-job.total // SKY_ERROR_STEP)
    result = job.result()
    last = sky.last
    truth = environment_oracle.truth(last["gbuffer"], last["scene"], last["models"]["a"],
                                     env.prepare_spec(last["scene"].environment, last["scene"].path),
                                     camera=last["camera"], count=sky.sky_error_pixels)
    expected = environment_oracle.errors(job.image, truth)
    assert result["rel_rmse"] == expected["rel_rmse"] > 0 and result["max_rel"] == expected["max_rel"]
    assert result["pixels"] == 20 and result["label"] == cost_label(last["models"]["a"].id, last["scene"].environment)
    with pytest.raises(Exception, match="no environment"):
        sky.sky_error_job(checked(sky, dict(sky="none")))


def test_the_server_sends_the_sky_errors_progress_and_result(sky):
    from clshade.view.server import Page, ViewServer
    server = ViewServer(sky, log=lambda text: None)

    async def scenario():
        sent = []

        class Socket:
            closed = False

            async def send_str(self, text):
                sent.append(json.loads(text))

            async def send_bytes(self, data):
                pass

        page = Page(server, Socket())
        task = asyncio.create_task(page.run())
        await page.receive(json.dumps(dict(type="sky_error", seq=4, controls=state(sky))))
        await page.receive(json.dumps(dict(type="sky_error", seq=5, controls=state(sky))))
        for _ in range(600):
            await asyncio.sleep(0.1)
            if any(m["type"] in ("sky_error", "error") and m.get("seq") == 4 for m in sent):
                break
        Socket.closed = True
        page.wake.set()
        await task
        return sent

    sent = asyncio.run(scenario())
    for executor in (server.executor, server.raster_executor, server.oracle_executor):
        executor.shutdown()
    kinds = [(m["type"], m.get("seq")) for m in sent]
    progress = [m for m in sent if m["type"] == "sky_progress"]
    assert [m["done"] for m in progress] == [16, 20] and all(m["seq"] == 4 for m in progress), kinds
    result = next(m for m in sent if m["type"] == "sky_error")
    assert result["seq"] == 4 and result["pixels"] == 20 and result["rel_rmse"] > 0
    assert kinds.index(("sky_progress", 4)) < kinds.index(("sky_error", 4))


def test_a_saved_view_keeps_its_sky(sky, tmp_path):
    out = tmp_path / "saved"
    out.mkdir()
    s = ViewSession(SKY_SCENE, out, W, H)
    s.save(checked(s, dict(sky="white", diffuse="constant")), "white")
    doc = tomllib.loads((out / "white.toml").read_text())
    assert doc["environment"]["uniform"] == [1.0, 1.0, 1.0] and doc["environment"]["diffuse"] == "constant"
    s.save(checked(s, dict(sky="environments/courtyard_128x64.exr")), "map")
    scene = load_scene(out / "map.toml")
    assert scene.environment.map == (SKY_SCENE.parent / "environments" / "courtyard_128x64.exr").resolve()


@pytest.mark.parametrize("text, cap", [("1920x1080", (1920, 1080)), (" 640x360 ", (640, 360)), ("1x16384", (1, 16384))])
def test_the_canvas_cap_flag(text, cap):
    assert canvas_cap(text, "--max-canvas") == cap


@pytest.mark.parametrize("text", ["1920", "0x10", "1920x1080x2", "20000x10", "-5x5", "axb", ""])
def test_a_bad_canvas_cap_is_refused(text):
    with pytest.raises(ClshadeError, match="--max-canvas"):
        canvas_cap(text, "--max-canvas")


def test_the_view_command_refuses_a_bad_cap(tmp_path, capsys):
    from clshade.cli import main
    assert main(["view", str(SKY_SCENE), "--max-canvas", "big", "--no-browser", "-o", str(tmp_path)]) == 2
    assert "--max-canvas = 'big'" in capsys.readouterr().err


def test_a_smaller_cap_limits_the_frames(tmp_path):
    s = ViewSession(ROBOT, tmp_path, max_canvas=(320, 200))
    c = checked(s, width=1000, height=500)
    assert (c.width, c.height) == (320, 160) and s.hello()["max_canvas"] == [320, 200]
    frame = s.render(c)
    assert (frame.width, frame.height) == (320, 160)

"""`clshade view` end to end in headless Chromium (Debian's chromium + chromium-driver,
driven by Selenium): load, orbit, switch models, move a slider, split, difference, save;
the canvas equals `clshade render` of the saved scene; bad inputs show an error and the
page goes on. Skipped, with the reason, where no browser is installed (.ci/install-browser
installs one). CLSHADE_VIEW_SCREENSHOT=path also saves a screenshot of the page there.
The page under test is clshade.view.static.view.js (benchmarks/mutation/run.py runs this file first
for its mutants)."""
from __future__ import annotations

import base64
import hashlib
import io
import json
import os

import numpy as np
import pytest

from clshade.cli import main
from clshade.device.variants import ENV_RUNG_DEFINES
from clshade.render.image import read_image
from clshade.resources import scenes_dir
from clshade.view import headless
from clshade.view.controls import parse_controls
from clshade.view.server import SEGMENT, ServerThread
from clshade.view.session import ViewSession

W, H = 480, 270
WAIT_S = 60

reason = headless.missing()
if reason:
    pytest.skip(reason, allow_module_level=True)


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    driver = headless.chromium(tmp_path_factory.mktemp("chromium-profile"), 1240, 820, WAIT_S)
    yield driver
    driver.quit()


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    out = tmp_path_factory.mktemp("view-saved")
    session = ViewSession(scenes_dir() / "robot.toml", out, W, H)
    with ServerThread(session) as url:
        yield url, out


def js(driver, script, *args):
    return driver.execute_script(script, *args)


def until(driver, script):
    """Run an async script body (`done` is its callback) and return what it passes."""
    return driver.execute_async_script("const done = arguments[arguments.length - 1];\n" + script)


def next_frame(driver, seq=None):
    """Wait for the frame of `seq` (default: the newest state sent)."""
    return until(driver, f"window.clshadeView.frameFor({seq if seq is not None else 'window.clshadeView.lastSeq()'}).then(done);")


def canvas(driver) -> np.ndarray:
    url = js(driver, "return window.clshadeView.canvasPNG();")
    from PIL import Image
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(url.split(",", 1)[1]))).convert("RGB"))


def test_viewer_end_to_end(browser, served, tmp_path, monkeypatch):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    url, out = served
    browser.get(url)
    until(browser, "const wait = () => window.clshadeView && window.clshadeView.lastFrame ? done(true) "
                   ": setTimeout(wait, 20); wait();")
    first = js(browser, "return window.clshadeView.lastFrame;")
    assert first["width"] == W and first["height"] == H and first["views"] == ["a"]
    assert not first["reshade_only"]
    start = canvas(browser)
    assert start.shape == (H, W, 3) and start.std() > 5          # a picture, not a blank canvas

    # orbit: a real drag on the canvas re-rasterises
    frame_el = browser.find_element(By.ID, "frame")
    ActionChains(browser).move_to_element_with_offset(frame_el, -60, 0).click_and_hold() \
        .move_by_offset(40, 10).move_by_offset(40, 10).release().perform()
    orbited = next_frame(browser)
    header = js(browser, "return window.clshadeView.lastFrame;")
    assert js(browser, "return window.clshadeView.controls.azimuth;") < -20
    assert "rasterize" in header["stages"] and orbited["latency"] > 0
    moved = canvas(browser)
    assert (moved != start).any(axis=-1).mean() > 0.05

    # switch model A through its input
    box = browser.find_element(By.ID, "model_a")
    box.clear()
    box.send_keys("burley")
    js(browser, "document.getElementById('model_a').dispatchEvent(new Event('change'));")
    next_frame(browser)
    header = js(browser, "return window.clshadeView.lastFrame;")
    assert header["models"]["a"] == "burley" and header["reshade_only"]

    # a material slider (built from the lobes' declared parameters) re-shades only
    js(browser, "const m = document.getElementById('material'); m.value = 'paint_red';"
                "m.dispatchEvent(new Event('change'));")
    assert js(browser, "return !!document.getElementById('param_roughness');")
    js(browser, "const s = document.getElementById('param_roughness'); s.value = 150;"
                "s.dispatchEvent(new Event('input'));")
    next_frame(browser)
    header = js(browser, "return window.clshadeView.lastFrame;")
    assert header["reshade_only"] and "rasterize" not in header["stages"]
    assert 0.1 < js(browser, "return window.clshadeView.controls.materials.paint_red.roughness;") < 0.2

    # the surface inputs (clshade.models.lobe.SURFACE_PARAMS): base colour, one slider per channel, and
    # metallic; re-shade only, and the paint changes colour on the canvas
    before = canvas(browser)
    for slider, value in (("param_base_color_1", 900), ("param_metallic", 600)):
        js(browser, f"const s = document.getElementById('{slider}'); s.value = {value};"
                    "s.dispatchEvent(new Event('input'));")
        next_frame(browser)
        assert js(browser, "return window.clshadeView.lastFrame;")["reshade_only"]
    red = js(browser, "return window.clshadeView.controls.materials.paint_red;")
    assert red["base_color"] == pytest.approx([0.75, 0.9, 0.06]) and red["metallic"] == pytest.approx(0.6)
    after = canvas(browser)
    assert (after[..., 1].astype(int) - before[..., 1] > 20).mean() > 0.002     # greener where the paint is

    # split: A left of the divider, B right of it, both on the same G-buffer
    browser.find_element(By.ID, "split").click()
    next_frame(browser)
    header = js(browser, "return window.clshadeView.lastFrame;")
    assert header["views"] == ["a", "b"] and header["reshade_only"]
    assert set(header["stats"]) == {"burley", "lambert+phong"}
    js(browser, "window.clshadeView.setDivider(0.25);")
    split = canvas(browser)
    a, b = (js(browser, f"return Array.from(window.clshadeView.view('{v}'));") for v in "ab")
    a = np.array(a, np.uint8).reshape(H, W, 4)[..., :3]
    b = np.array(b, np.uint8).reshape(H, W, 4)[..., :3]
    x = round(0.25 * W)
    np.testing.assert_array_equal(split[:, :x], a[:, :x])
    np.testing.assert_array_equal(split[:, x + 1:], b[:, x + 1:])
    assert (split[:, x] == 255).all()                                   # the divider line

    # the difference view, one click away, with its scale
    browser.find_element(By.ID, "diff").click()
    next_frame(browser)
    header = js(browser, "return window.clshadeView.lastFrame;")
    assert header["views"] == ["a", "b", "diff"] and header["diff_scale"] > 0
    assert js(browser, "return !document.getElementById('legend').hidden;")
    if os.environ.get("CLSHADE_VIEW_SCREENSHOT"):
        browser.find_element(By.ID, "diff").click()
        next_frame(browser)
        browser.find_element(By.ID, "oracle").click()
        until(browser, "const wait = () => document.querySelectorAll('#truth tr').length > 2 ? done(true) "
                       ": setTimeout(wait, 50); wait();")
        js(browser, "window.scrollTo(0, 0);")
        browser.save_screenshot(os.environ["CLSHADE_VIEW_SCREENSHOT"])
        browser.find_element(By.ID, "diff").click()
        next_frame(browser)

    # bad inputs: an error in the page, and the page goes on
    bad = ["{not json", '{"type": "state", "seq": 900, "controls": {"exposure": NaN}}',
           json.dumps({"type": "state", "seq": 901, "controls": {"exposure": 1}})]
    for text in bad:
        js(browser, "window.clshadeView.sendRaw(arguments[0]);", text)
    js(browser, "window.clshadeView.set({model_b: 'no_such_model'});")
    until(browser, "const wait = () => /model_b/.test(window.clshadeView.error()) ? done(true) "
                   ": setTimeout(wait, 20); wait();")
    assert "did you mean" in js(browser, "return window.clshadeView.error();") or \
        "unknown" in js(browser, "return window.clshadeView.error();")
    js(browser, "window.clshadeView.set({model_b: 'phong', exposure: 1e9});")
    until(browser, "const wait = () => /exposure/.test(window.clshadeView.error()) ? done(true) "
                   ": setTimeout(wait, 20); wait();")
    # diff off, split on; save; the canvas left of the divider is model A of the saved scene
    js(browser, "window.clshadeView.set({exposure: 0.5, diff: false});")
    next_frame(browser)
    assert js(browser, "return window.clshadeView.error();") == ""
    js(browser, "window.clshadeView.setDivider(1.0);")
    shown = canvas(browser)
    js(browser, "document.getElementById('save_name').value = 'e2e';")
    browser.find_element(By.ID, "save").click()
    until(browser, "const wait = () => /e2e.toml/.test(document.getElementById('saved').textContent) ? done(true) "
                   ": setTimeout(wait, 20); wait();")
    monkeypatch.chdir(out)
    assert main(["render", "e2e.toml", "-o", str(tmp_path / "cli.png")]) == 0
    rendered = np.round(read_image(tmp_path / "cli.png") * 255).astype(np.uint8)
    np.testing.assert_array_equal(shown[:, :W - 1], rendered[:, :W - 1])     # the last column is the divider
    np.testing.assert_array_equal(read_image(out / "e2e.png"), read_image(tmp_path / "cli.png"))
    assert main(["render", "e2e.toml", "-m", "phong", "-o", str(tmp_path / "cli_b.png")]) == 0
    np.testing.assert_array_equal(read_image(out / "e2e_b.png"), read_image(tmp_path / "cli_b.png"))


def test_cost_readouts_follow_the_newest_frame(browser, served):
    """The cost table and stage line (redrawn a few times a second, not every frame) end on the
    newest frame's figures: a row per shown model with its shading time and rates, the stages
    of that frame. The page's clock is stopped during the burst, so that every frame arrives
    within the redraw interval of the last redraw however slowly this machine renders them
    (only the trailing update can show the last one)."""
    url, _ = served
    browser.get(url)
    until(browser, "const wait = () => window.clshadeView && window.clshadeView.lastFrame ? done(true) "
                   ": setTimeout(wait, 20); wait();")
    js(browser, "const now = performance.now(); window.clshadeClock = performance.now;"
                " performance.now = () => now;")
    for k in range(6):                       # a burst of frames, faster than the readouts are redrawn
        js(browser, f"window.clshadeView.set({{azimuth: {5 * (k + 1)}, model_a: 'lambert'}});")
    next_frame(browser)
    js(browser, "window.clshadeView.set({model_a: 'phong'});")
    last = next_frame(browser)
    header = js(browser, "return window.clshadeView.lastFrame;")
    model = header["models"]["a"]
    assert header["seq"] == last["seq"] and list(header["models"]) == ["a"] and "phong" in model
    shown = until(browser, "const t0 = Date.now(); const poll = () => {"
                           " const rows = [...document.querySelectorAll('#cost tbody tr')]"
                           "   .map((r) => [...r.cells].map((c) => c.textContent));"
                           " const stages = document.getElementById('stages').textContent;"
                           f" if ((rows.length && rows[0][0] === 'A {model}') || Date.now() - t0 > 3000)"
                           "   done({rows, stages}); else setTimeout(poll, 20); }; poll();")
    js(browser, "performance.now = window.clshadeClock;")
    assert [row[0] for row in shown["rows"]] == [f"A {model}"], shown
    ms, fps, low = (float(v) for v in shown["rows"][0][1:])
    stats = header["stats"][model]
    assert ms == pytest.approx(stats["mean_ms"], abs=0.006) and ms > 0
    assert fps == pytest.approx(stats["avg_fps"], abs=0.6) and low == pytest.approx(stats["low1_fps"], abs=0.6)
    assert shown["stages"].startswith("frame: ") and "shade" in shown["stages"]
    assert "rasterize" not in shown["stages"]        # the newest frame re-shaded only: not an older frame's stages


# ---------------------------------------------------------------- environment and canvas size

def wait_for(driver, condition: str, timeout_ms: int = WAIT_S * 1000):
    """Poll a JavaScript expression in the page until it is truthy; its value."""
    return until(driver, f"const t0 = performance.now(); const poll = () => {{ const v = ({condition});"
                         f" if (v || performance.now() - t0 > {timeout_ms}) done(v); else setTimeout(poll, 20); }};"
                         " poll();")


def choose(driver, select_id: str, value) -> dict:
    """Pick `value` in a <select> (or number input) of the page as a person does; the frame of it."""
    js(driver, f"const s = document.getElementById('{select_id}'); s.value = arguments[0];"
               "s.dispatchEvent(new Event('change'));", value)
    next_frame(driver)
    return js(driver, "return window.clshadeView.lastFrame;")


@pytest.fixture(scope="module")
def sky_served(tmp_path_factory):
    out = tmp_path_factory.mktemp("view-sky")
    # 96×96 and 24 truth pixels: the sampled rung and the float64 truth stay quick on a loaded machine.
    session = ViewSession(scenes_dir() / "environment.toml", out, 96, 96, sky_error_pixels=24)
    with ServerThread(session) as url:
        yield url


def test_environment_picker_rungs_and_error(browser, sky_served):
    """The sky picker changes the image; every rung control reaches the kernel variant the server
    reports (its cost row and its ENV line); the error button shows its progress and a number."""
    from selenium.webdriver.common.by import By
    browser.get(sky_served)
    wait_for(browser, "window.clshadeView && window.clshadeView.lastFrame")
    hello = js(browser, "return window.clshadeView.hello;")
    assert "environments/courtyard_128x64.exr" in hello["skies"] and {"none", "white"} <= set(hello["skies"])
    header = choose(browser, "env_samples", 4)
    assert header["environment"]["samples"] == 4 and header["costs"]["a"].endswith("×4]")
    scene_sky = canvas(browser)

    header = choose(browser, "sky", "white")
    assert header["environment"]["sky"] == "uniform 1, 1, 1"
    white = canvas(browser)
    assert (np.abs(white.astype(int) - scene_sky).max(axis=-1) > 8).mean() > 0.2
    header = choose(browser, "sky", "none")
    assert header["environment"] is None and js(browser, "return document.getElementById('rungs').textContent;") \
        == "no environment"
    assert (canvas(browser) != white).any(axis=-1).mean() > 0.2
    header = choose(browser, "sky", "environments/courtyard_128x64.exr")
    assert header["environment"]["sky"] == "courtyard_128x64.exr"
    np.testing.assert_array_equal(canvas(browser), scene_sky)      # the scene's own map, picked by name

    for key, rungs in (("diffuse", hello["rungs"]["diffuse"]), ("specular", hello["rungs"]["specular"])):
        for rung in rungs:
            header = choose(browser, f"env_{key}", rung)
            sky = header["environment"]
            define = f"ENV_{key.upper()}={ENV_RUNG_DEFINES[rung]}"
            assert sky[key] == rung and f"{define} " in sky["variant"] + " ", sky
            assert header["costs"]["a"] == f"{header['models']['a']} [{sky['rungs']}]"
            assert header["stats"][header["costs"]["a"]]["mean_ms"] > 0
            assert define in js(browser, "return document.getElementById('rungs').textContent;")
    ladder = js(browser, "return window.clshadeView.lastFrame.ladder;")
    assert len(ladder) >= len(hello["rungs"]["diffuse"]) + len(hello["rungs"]["specular"]) - 1
    for key, value, field in (("env_rotation", 90, "rotation"), ("env_intensity", 2, "intensity")):
        js(browser, f"const s = document.getElementById('{key}'); s.value = {value};"
                    "s.dispatchEvent(new Event('input'));")
        next_frame(browser)
        assert js(browser, "return window.clshadeView.lastFrame;")["environment"][field] == value

    browser.find_element(By.ID, "sky_error").click()
    text = wait_for(browser, "/rel RMSE/.test(document.getElementById('sky_error_out').textContent) && "
                             "document.getElementById('sky_error_out').textContent")
    assert text and text.startswith(js(browser, "return window.clshadeView.lastFrame.costs.a;")), text
    rmse = float(text.split("rel RMSE ")[1].split(",")[0])
    assert 0 < rmse < 10       # 4 samples per pixel: a rough estimate, but a finite, measured one
    assert js(browser, "return window.clshadeView.progress.length;") >= 2       # 24 pixels, 16 a step
    cells = js(browser, "return [...document.querySelectorAll('#ladder tbody tr')].map((r) => r.cells[2].textContent);")
    assert any(c and float(c) == pytest.approx(rmse, rel=0.01) for c in cells), cells


@pytest.fixture
def window_browser(tmp_path_factory):
    driver = headless.chromium(tmp_path_factory.mktemp("chromium-window"), 1000, 700, WAIT_S)
    yield driver
    driver.quit()


def window(driver, width: int, height: int, ratio: float) -> None:
    """Emulate a window of width × height CSS pixels at a device pixel ratio, and wait until the
    page has laid itself out for it: the browser fires "resize" at a later animation frame, so a
    state sent before that (an orbit step, `next_frame`'s newest seq) would still have the old
    size; the page's handler is run here once the window has its new size (it sends a state
    only where the canvas's pixels change, so a second run by the browser changes nothing)."""
    driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                           dict(width=width, height=height, deviceScaleFactor=ratio, mobile=False))
    wait_for(driver, f"window.innerWidth === {width} && window.innerHeight === {height} "
                     f"&& window.devicePixelRatio === {ratio}")
    js(driver, "window.dispatchEvent(new Event('resize'));")


def expected_size(driver, ratio: float, scale: float = 1.0) -> tuple[int, int]:
    """The frame a canvas of the page's CSS size should get: × ratio × scale, fitted in 1920×1080."""
    w, h = js(driver, "const c = document.getElementById('frame'); return [c.clientWidth, c.clientHeight];")
    w, h = round(w * ratio * scale), round(h * ratio * scale)
    k = min(1.0, 1920 / w, 1080 / h)
    return min(1920, round(w * k)), min(1080, round(h * k))


def test_canvas_follows_the_window(window_browser, tmp_path):
    """Without --width/--height the canvas fills the window: rendered at its CSS size × the device
    pixel ratio, capped at 1920×1080 (aspect kept), halved by the 50 % control; a resize mid-orbit
    gives frames of the new size."""
    driver = window_browser
    session = ViewSession(scenes_dir() / "robot.toml", tmp_path)
    with ServerThread(session) as url:
        window(driver, 1000, 700, 1)
        driver.get(url)
        wait_for(driver, "window.clshadeView && window.clshadeView.lastFrame")
        frame = js(driver, "return window.clshadeView.lastFrame;")
        assert (frame["width"], frame["height"]) == expected_size(driver, 1) and frame["width"] > 200
        assert canvas(driver).shape[:2] == (frame["height"], frame["width"])
        # Both views of a split frame whose pixels are not a multiple of the message's runs: the page
        # decodes each (the partial last run included) to the pixels the server rendered.
        js(driver, "window.clshadeView.set({split: true});")
        next_frame(driver)
        frame = js(driver, "return window.clshadeView.lastFrame;")
        assert frame["width"] * frame["height"] % SEGMENT, "the frame size should leave a partial run"
        digests = until(driver, "const v = window.clshadeView; Promise.all(['a', 'b'].map((n) => "
                                "crypto.subtle.digest('SHA-256', v.view(n)))).then((d) => done(d.map((x) => "
                                "[...new Uint8Array(x)].map((b) => b.toString(16).padStart(2, '0')).join(''))));")
        rendered = session.render(parse_controls(js(driver, "return window.clshadeView.controls;"), session.limits))
        assert digests == [hashlib.sha256(rendered.views[n].tobytes()).hexdigest() for n in "ab"]
        js(driver, "window.clshadeView.set({split: false});")

        for k in range(4):                                    # an orbit, resized half-way at twice the DPR
            if k == 2:
                window(driver, 900, 620, 2)
            js(driver, f"window.clshadeView.set({{azimuth: {10 * (k + 1)}}});")
        next_frame(driver)
        frame = js(driver, "return window.clshadeView.lastFrame;")
        assert (frame["width"], frame["height"]) == expected_size(driver, 2)
        css = js(driver, "return document.getElementById('frame').clientWidth;")
        assert frame["width"] == round(2 * css) and js(driver, "return window.clshadeView.controls.azimuth;") == 40

        window(driver, 1900, 1000, 2)                          # 2× a big window: over the cap
        next_frame(driver)
        frame = js(driver, "return window.clshadeView.lastFrame;")
        assert (frame["width"], frame["height"]) == expected_size(driver, 2)
        assert frame["width"] <= 1920 and frame["height"] == 1080

        header = choose(driver, "resolution", "0.5")
        assert (header["width"], header["height"]) == expected_size(driver, 2, 0.5)
        assert header["height"] < 1080

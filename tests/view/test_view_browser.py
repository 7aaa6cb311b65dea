"""`clshade view` end to end in headless Chromium (Debian's chromium + chromium-driver,
driven by Selenium): load, orbit, switch models, move a slider, split, difference, save;
the canvas equals `clshade render` of the saved scene; bad inputs show an error and the
page goes on. Skipped, with the reason, where no browser is installed (.ci/install-browser
installs one). CLSHADE_VIEW_SCREENSHOT=path also saves a screenshot of the page there.
The page under test is clshade.view.static.view.js (benchmarks/mutation/run.py runs this file first
for its mutants)."""
from __future__ import annotations

import base64
import io
import json
import os

import numpy as np
import pytest

from clshade.cli import main
from clshade.render.image import read_image
from clshade.resources import scenes_dir
from clshade.view import headless
from clshade.view.server import ServerThread
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
    of that frame."""
    url, _ = served
    browser.get(url)
    until(browser, "const wait = () => window.clshadeView && window.clshadeView.lastFrame ? done(true) "
                   ": setTimeout(wait, 20); wait();")
    for k in range(6):                       # a burst of frames, faster than the readouts are redrawn
        js(browser, f"window.clshadeView.set({{azimuth: {5 * (k + 1)}, model_a: 'lambert'}});")
    next_frame(browser)
    js(browser, "window.clshadeView.set({model_a: 'phong'});")
    last = next_frame(browser)
    header = js(browser, "return window.clshadeView.lastFrame;")
    model = header["models"]["a"]
    assert header["seq"] == last["seq"] and list(header["models"]) == ["a"] and "phong" in model
    shown = until(browser, "const t0 = performance.now(); const poll = () => {"
                           " const rows = [...document.querySelectorAll('#cost tbody tr')]"
                           "   .map((r) => [...r.cells].map((c) => c.textContent));"
                           " const stages = document.getElementById('stages').textContent;"
                           f" if ((rows.length && rows[0][0] === 'A {model}') || performance.now() - t0 > 3000)"
                           "   done({rows, stages}); else setTimeout(poll, 20); }; poll();")
    assert [row[0] for row in shown["rows"]] == [f"A {model}"], shown
    ms, fps, low = (float(v) for v in shown["rows"][0][1:])
    stats = header["stats"][model]
    assert ms == pytest.approx(stats["mean_ms"], abs=0.006) and ms > 0
    assert fps == pytest.approx(stats["avg_fps"], abs=0.6) and low == pytest.approx(stats["low1_fps"], abs=0.6)
    assert shown["stages"].startswith("frame: ") and "shade" in shown["stages"]
    assert "rasterize" not in shown["stages"]        # the newest frame re-shaded only: not an older frame's stages

"""How live `clshade view` feels: re-shade updates per second and orbit frames per second at
960×540 on scenes/robot.toml, and the time from input to the frame drawn on the page's canvas,
packing and transfer included, measured in a real browser (headless Chromium, as the
end-to-end tests drive it).

Usage::

    python -m benchmarks.measure.view_bench [--frames 60] [--repeats 3] [--out benchmarks/results/view.json]
        [--canvas-1080-only]

The page itself drives the viewer (window.clshadeView): each step changes the controls the way
a person does and waits until the frame of that change is drawn, then takes the next step
(closed loop: the rate is what the whole chain sustains, nothing queued). Two kinds of step:

- re-shade: the roughness slider of one material (G-buffer patch, material table, shading,
  display transform, read back, transfer, draw; no raster);
- orbit: the camera turned by 1° (rasterize, G-buffer, upload, shading, display, …).

And a drag as a person makes it: orbit inputs sent every 1/60 s whatever the frames do; the
server renders the newest state only (latest wins), and the frames drawn per second and the
states skipped are counted.

And the viewer filling a big window: a session without a fixed size, its canvas following a
window emulated so that the canvas is 1920×1080 device pixels (the default cap), orbited in
closed-loop blocks (`canvas_1080` in the JSON; target 30 frames/s).

Blocks of each kind are interleaved `repeats` times (a noisy spell of the shared machine falls
on all kinds); rates are medians over blocks, latencies percentiles over all frames. Per frame
the page records the latency (input → drawn), the server's time from receiving the state to
having sent the frame (server_ms: waiting, rendering, packing, sending) and its stages, the
packing and the draw time; the rest of the latency is transfer both ways and the browser's
message handling. `python -m benchmarks.publish` renders benchmarks/results/view.md from the JSON.
"""
from __future__ import annotations

import argparse
import os
import shlex
import statistics
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from benchmarks.publish.results_io import RESULTS, ROOT, measure_and_write

SCENE = ROOT / "scenes" / "robot.toml"
WIDTH, HEIGHT = 960, 540
TARGETS = {"reshade_per_s": 60.0, "orbit_fps": 30.0, "canvas_1080_orbit_fps": 30.0}
#: The big canvas: the viewer's default cap (clshade.view.controls.MAX_CANVAS).
CANVAS = (1920, 1080)
DRAG_HZ = 60.0
# One closed-loop block in the page: `steps` changes, each awaited until drawn.
CLOSED_LOOP = """
const [kind, steps, done] = arguments;
const v = window.clshadeView;
const start = performance.now(), first = v.records.length;
for (let k = 0; k < steps; k++) {
  const patch = kind === "orbit" ? {azimuth: v.controls.azimuth + 1}
    : {materials: {paint_red: {roughness: 0.2 + 0.3 * ((k % 10) / 10)}}};
  await v.frameFor(v.set(patch));
}
const seconds = (performance.now() - start) / 1000;
await new Promise((r) => setTimeout(r, 100));          // the last frame's "sent" timing
done({seconds, records: v.records.slice(first)});
"""
# A drag: orbit inputs every 1/DRAG_HZ s for `seconds`, frames counted as they are drawn.
OPEN_LOOP = """
const [seconds, hz, done] = arguments;
const v = window.clshadeView;
const first = v.records.length, sentFirst = v.lastSeq() + 1;
const start = performance.now();
let sent = 0;
await new Promise((resolve) => {
  const timer = setInterval(() => {
    if (performance.now() - start >= seconds * 1000) { clearInterval(timer); resolve(); return; }
    v.set({azimuth: v.controls.azimuth + 1}); sent++;
  }, 1000 / hz);
});
const last = v.lastSeq();
await v.frameFor(last);
const elapsed = (performance.now() - start) / 1000;
await new Promise((r) => setTimeout(r, 100));
done({seconds: elapsed, sent, records: v.records.slice(first)});
"""


def _run(driver, script: str, *args):
    return driver.execute_async_script(f"(async () => {{ {script} }})();", *args)


def _pct(values: list[float], q: float) -> float | None:
    return float(np.percentile(values, q)) if values else None


def _summary(records: list[dict]) -> dict:
    """Percentiles of the latency and medians of its parts over frames."""
    lat = [r["latency"] for r in records if r.get("latency") is not None]
    server = [r["server_ms"] for r in records if r.get("server_ms") is not None]
    stages: dict[str, list[float]] = {}
    for r in records:
        for k, v in r["stages"].items():
            stages.setdefault(k, []).append(v)
    paired = [r["latency"] - r["server_ms"] for r in records
              if r.get("latency") is not None and r.get("server_ms") is not None]
    return dict(frames=len(records), latency_ms=dict(median=_pct(lat, 50), p95=_pct(lat, 95), max=max(lat, default=None)),
                server_ms_median=_pct(server, 50),
                transfer_and_browser_ms_median=_pct(paired, 50),
                draw_ms_median=_pct([r["draw_ms"] for r in records], 50),
                pack_ms_median=_pct([r["pack_ms"] for r in records if r.get("pack_ms") is not None], 50),
                render_ms_median=_pct([r["render_ms"] for r in records if r.get("render_ms") is not None], 50),
                bytes_per_frame=int(statistics.median(r["bytes"] for r in records)) if records else None,
                stage_ms_median={k: float(np.median(v)) for k, v in stages.items()},
                stage_frames={k: len(v) for k, v in stages.items()})


def _fit_window(driver, size: tuple[int, int]) -> None:
    """Emulate a window (device pixel ratio 1) whose canvas, following it, is `size` CSS pixels: the
    window is grown by what the canvas lacks until the frame drawn has that size."""
    width, height = size[0] + 800, size[1] + 200
    for _ in range(4):
        driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                               dict(width=width, height=height, deviceScaleFactor=1, mobile=False))
        driver.execute_async_script("const [w, h, done] = arguments; const wait = () => window.innerWidth === w && "
                                    "window.innerHeight === h ? requestAnimationFrame(() => done()) : "
                                    "setTimeout(wait, 20); wait();", width, height)
        css = driver.execute_script("const c = document.getElementById('frame'); "
                                    "return [c.clientWidth, c.clientHeight];")
        if tuple(css) == size:
            break
        width, height = width + size[0] - css[0], height + size[1] - css[1]
    driver.execute_async_script("const done = arguments[0]; const v = window.clshadeView;"
                                "v.frameFor(v.lastSeq()).then(() => done());")
    frame = driver.execute_script("const f = window.clshadeView.lastFrame; return [f.width, f.height];")
    if tuple(frame) != size:
        raise RuntimeError(f"the canvas did not reach {size[0]}x{size[1]}: its frames are {frame[0]}x{frame[1]}")


@contextmanager
def _page(session, tmp: str):
    """Chromium on the session's viewer, its first frame shown; quit on the way out."""
    from clshade.view import headless
    from clshade.view.server import ServerThread
    with ServerThread(session) as url:
        driver = headless.chromium(Path(tmp) / "profile", 1700, 900, 600)
        try:
            driver.get(url)
            driver.execute_async_script("const done = arguments[0]; const wait = () => window.clshadeView "
                                        "&& window.clshadeView.lastFrame ? done() : setTimeout(wait, 20); wait();")
            yield driver
        finally:
            driver.quit()


def measure_canvas(frames: int, repeats: int) -> dict:
    """Orbit frames per second with the canvas following a window at CANVAS (closed-loop blocks)."""
    from clshade.view.session import ViewSession
    with tempfile.TemporaryDirectory(prefix="view-bench-1080-") as tmp:
        session = ViewSession(SCENE, tmp)                  # no size given: the page's canvas decides
        with _page(session, tmp) as driver:
            _fit_window(driver, CANVAS)
            _run(driver, CLOSED_LOOP, "orbit", 10)           # warm-up at the big size
            runs = [_run(driver, CLOSED_LOOP, "orbit", frames) for _ in range(repeats)]
    records = [r for b in runs for r in b["records"]]
    rates = [len(b["records"]) / b["seconds"] for b in runs]
    return dict(width=CANVAS[0], height=CANVAS[1], rate_per_s_median=float(np.median(rates)), rate_per_s_blocks=rates,
                **_summary(records))


def measure(frames: int, repeats: int, drag_seconds: float, canvas_only: bool = False) -> dict:
    from clshade.view import headless
    from clshade.view.server import FRAME_ENCODING
    from clshade.view.session import ViewSession
    if canvas_only:
        canvas = measure_canvas(frames, repeats)
        return dict(scene="scenes/robot.toml", frames_per_block=frames, repeats=repeats, targets=TARGETS,
                    browser=headless.CHROMIUM, frame_encoding=FRAME_ENCODING, canvas_1080=canvas,
                    met={"canvas_1080_orbit_fps": canvas["rate_per_s_median"] >= TARGETS["canvas_1080_orbit_fps"]})
    with tempfile.TemporaryDirectory(prefix="view-bench-") as tmp:
        session = ViewSession(SCENE, tmp, WIDTH, HEIGHT)
        with _page(session, tmp) as driver:
            for kind in ("reshade", "orbit"):                         # warm-up: kernels built, caches filled
                _run(driver, CLOSED_LOOP, kind, 10)
            blocks: dict[str, list[dict]] = {"reshade": [], "orbit": [], "drag": []}
            for _ in range(repeats):
                for kind in ("reshade", "orbit"):
                    blocks[kind].append(_run(driver, CLOSED_LOOP, kind, frames))
                blocks["drag"].append(_run(driver, OPEN_LOOP, drag_seconds, DRAG_HZ))
        device = session.runtime.info.description
    out: dict = dict(device=device, scene="scenes/robot.toml", width=WIDTH, height=HEIGHT,
                     frames_per_block=frames, repeats=repeats, drag_hz=DRAG_HZ, drag_seconds=drag_seconds,
                     targets=TARGETS, browser=headless.CHROMIUM, frame_encoding=FRAME_ENCODING, kinds={})
    for kind, runs in blocks.items():
        records = [r for b in runs for r in b["records"]]
        rates = [len(b["records"]) / b["seconds"] for b in runs]
        entry = dict(rate_per_s_median=float(np.median(rates)), rate_per_s_blocks=rates, **_summary(records))
        if kind == "drag":
            entry["inputs_sent"] = sum(b["sent"] for b in runs)
            entry["states_skipped"] = entry["inputs_sent"] - len(records)
        out["kinds"][kind] = entry
    out["canvas_1080"] = measure_canvas(frames, repeats)
    out["met"] = {"reshade_per_s": out["kinds"]["reshade"]["rate_per_s_median"] >= TARGETS["reshade_per_s"],
                  "orbit_fps": out["kinds"]["orbit"]["rate_per_s_median"] >= TARGETS["orbit_fps"],
                  "canvas_1080_orbit_fps": out["canvas_1080"]["rate_per_s_median"] >= TARGETS["canvas_1080_orbit_fps"]}
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60, help="closed-loop steps per block (default 60)")
    parser.add_argument("--repeats", type=int, default=3, help="interleaved blocks of each kind (default 3)")
    parser.add_argument("--drag-seconds", type=float, default=3.0, help="length of each drag block (default 3 s)")
    parser.add_argument("--out", type=Path, default=RESULTS / "view.json")
    parser.add_argument("--canvas-1080-only", action="store_true",
                        help="only the 1920x1080 canvas orbit (a quick look; not the published results)")
    args = parser.parse_args(argv)
    device = os.environ.get("CLSHADE_DEVICE")
    command = ((f"CLSHADE_DEVICE={shlex.quote(device)} " if device else "") + "python -m benchmarks.measure.view_bench"
               + "".join(f" {shlex.quote(a)}" for a in (sys.argv[1:] if argv is None else argv)))
    measure_and_write(args.out, lambda: dict(command=command, **measure(args.frames, args.repeats, args.drag_seconds,
                                                                             args.canvas_1080_only)))
    return 0


if __name__ == "__main__":
    sys.exit(main())

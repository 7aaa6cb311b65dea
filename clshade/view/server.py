"""The viewer's server (aiohttp): the page, its static files and one WebSocket per page.

Protocol. The page sends JSON text messages: `{"type": "state", "seq": n, "controls":
{...}}` with its whole control state at every change (its canvas size among them), `{"type": "save",
"name": ..., "controls": {...}}`, `{"type": "oracle", "controls": {...}}`, `{"type": "sky_error",
"controls": {...}}` and `{"type": "bye"}`. The server answers `hello` (registry, scene values,
skies, rungs, starting controls) once, `error` (a one-line message; nothing is rendered), `saved`,
`oracle`, `sky_progress` and `sky_error`, and frames as one binary message each: a little-endian
uint32 n, n bytes of JSON header (seq, size, views, timings, statistics per model and rung, the
sky's rungs and variant; padded with spaces to a multiple of 4 bytes), then each view's pixels in
segments (encode_view): for each run of SEGMENT pixels (in row-major order, the last run shorter
when the pixel count is not a multiple of SEGMENT) one flag byte, 1 when the run's RGBA8 pixels
follow and 0 when every one of them is the view's background value (the header's
`encoding.background`, a little-endian uint32 of R, G, B, A); the flags padded with zeros to a
multiple of 4 bytes, then the flagged runs' pixels one after the other. Lossless: the page's canvas
equals `clshade render`'s image; a frame's background (often half a window) does not travel.

Latest state wins: a state that arrives while a frame renders replaces any state still
waiting, so the next frame is always of the newest controls and frames never queue. Frames
render in two stages on two threads (rasterize; then G-buffer, shading, packing): the newest
state is rasterized while the previous one is shaded.
Save and oracle requests are never dropped; they run between frames. A sky error (the float64
truth under the environment, seconds to minutes) is taken from a frame between frames and integrated
on a thread of its own while frames go on, its progress sent after each step; one at a time per page.

Safety. Bound to 127.0.0.1 on a free port unless --host says otherwise; on any other
address every request needs the random token of the printed URL. Requests whose Host
is not the server's own address (DNS rebinding) and WebSockets opened by another
origin's page are refused. The server stops when its last page has been closed for
LINGER_S seconds, or on Ctrl-C / SIGTERM.
"""
from __future__ import annotations

import asyncio
import queue
import threading
import ipaddress
import json
import secrets
import signal
import struct
import sys
import time
import traceback
from concurrent.futures import ThreadPoolExecutor
from importlib import resources
from typing import Any, Callable

import numpy as np
from aiohttp import WSMsgType, web

from clshade.errors import ClshadeError
from clshade.view.controls import MAX_MESSAGE_BYTES, ControlError, parse_controls, parse_message
from clshade.view.session import ViewFrame, ViewSession

#: Seconds the server waits after its last page closed before it stops (a reload reconnects within it).
LINGER_S = 3.0
#: The files of the page (clshade/view/static), by URL path; nothing else is served.
STATIC = {"/": ("index.html", "text/html"), "/view.js": ("view.js", "text/javascript"),
          "/view.css": ("view.css", "text/css")}
LOOPBACK_NAMES = ("localhost",)


def is_loopback(host: str) -> bool:
    if host in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


#: Pixels per run of a frame message's segment encoding: runs of 64 RGBA8 pixels (256 bytes) keep
#: the flags at 1/256 of the pixels' bytes, follow an object's outline to within 64 pixels, and are
#: found with 64-bit compares of eight flags at a time (shorter runs send a little less and take
#: longer to find; the bytes per frame are in benchmarks/results/view.md).
SEGMENT = 64
#: How frames travel, in words (benchmarks/measure/view_bench.py records it beside the bytes per frame).
FRAME_ENCODING = f"runs of {SEGMENT} RGBA8 pixels, those all of the background left out"


def _pad4(n: int) -> int:
    return -n % 4


def background_value(pixels: np.ndarray) -> int:
    """The value (uint32 RGBA8) of the four corners' that begins the most runs: the background of a
    frame whose objects leave some corner uncovered (any value is lossless; this one sends least)."""
    h, w = pixels.shape
    firsts = pixels.reshape(-1)[::SEGMENT]
    corners = {int(v) for v in (pixels[0, 0], pixels[0, w - 1], pixels[h - 1, 0], pixels[h - 1, w - 1])}
    return max(sorted(corners), key=lambda v: int(np.count_nonzero(firsts == v)))


def encode_view(rgba: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """(background, flags, pixels) of one (h, w, 4) uint8 view: flags[k] = 1 where run k of SEGMENT
    pixels holds a pixel other than the background; pixels those of the flagged runs, uint32 one
    after the other (the partial last run, if any, always flagged)."""
    pixels = np.ascontiguousarray(rgba).reshape(rgba.shape[0], rgba.shape[1], 4).view("<u4")[..., 0]
    background = background_value(pixels)
    flat = pixels.reshape(-1)
    whole = flat.size // SEGMENT
    differs = flat[:whole * SEGMENT] != background
    flags = differs.view(np.uint64).reshape(whole, SEGMENT // 8).any(axis=1)
    sent = np.compress(flags, flat[:whole * SEGMENT].reshape(whole, SEGMENT), axis=0).reshape(-1)
    if whole * SEGMENT < flat.size:
        flags, sent = np.append(flags, True), np.concatenate([sent, flat[whole * SEGMENT:]])
    return background, flags.astype(np.uint8), sent


def pack_frame(frame: ViewFrame, seq: int, extra: dict[str, Any]) -> bytes:
    """One binary frame message (see the module docstring)."""
    names = list(frame.views)
    encoded = {n: encode_view(frame.views[n]) for n in names}
    header = dict(type="frame", seq=seq, width=frame.width, height=frame.height, views=names, models=frame.models,
                  stats=frame.stats, stages={k: v * 1e3 for k, v in frame.stages.items()},
                  diff_scale=frame.diff_scale, reshade_only=frame.reshade_only, costs=frame.costs,
                  environment=frame.environment, ladder=frame.ladder,
                  encoding=dict(segment=SEGMENT, background={n: encoded[n][0] for n in names}), **extra)
    text = json.dumps(header).encode()
    text += b" " * _pad4(4 + len(text))
    parts: list[bytes | np.ndarray] = [struct.pack("<I", len(text)), text]
    for n in names:
        _, flags, sent = encoded[n]
        parts += [flags, bytes(_pad4(len(flags))), sent]
    return b"".join(parts)


def unpack_frame(message: bytes) -> tuple[dict, dict[str, np.ndarray]]:
    """(header, {view: (h, w, 4) uint8}) of a message pack_frame made: the page's decoding
    (static/view.js, decodeView) in Python, for tests and tools."""
    n = int.from_bytes(message[:4], "little")
    header = json.loads(message[4:4 + n])
    w, h, segment = header["width"], header["height"], header["encoding"]["segment"]
    npix = w * h
    count = -(-npix // segment)
    offset, views = 4 + n, {}
    for name in header["views"]:
        flags = np.frombuffer(message, np.uint8, count, offset).astype(bool)
        offset += count + _pad4(count)
        out = np.full(count * segment, header["encoding"]["background"][name], "<u4")
        index = (np.flatnonzero(flags)[:, None] * segment + np.arange(segment)).reshape(-1)
        index = index[index < npix]                 # the partial last run's pixels only
        out[index] = np.frombuffer(message, "<u4", len(index), offset)
        offset += 4 * len(index)
        views[name] = out[:npix].view(np.uint8).reshape(h, w, 4)
    return header, views


class Page:
    """One connected page: its pending state (latest wins), its jobs and its render loop."""

    def __init__(self, server: "ViewServer", ws: web.WebSocketResponse) -> None:
        self.server, self.ws = server, ws
        self.pending: tuple[int, Any, float] | None = None
        self.jobs: list[tuple[str, int, Any, Any]] = []
        self.wake = asyncio.Event()
        self.skipped = 0
        self.sky_task: asyncio.Task | None = None     # the sky error being integrated
        self.sky_busy = False                         # a sky error asked for and not yet answered

    async def send_json(self, data: dict) -> None:
        """Send `data` as JSON, which has no NaN or Infinity: a message holding one is logged and
        replaced by an error naming it (the page's JSON.parse would refuse the whole message)."""
        try:
            text = json.dumps(data, allow_nan=False)
        except ValueError as exc:
            self.server.log(f"clshade view: internal error: a {data.get('type')} message is not JSON ({exc})")
            seq = data.get("seq")
            text = json.dumps(dict(type="error", seq=seq if isinstance(seq, int) else None,
                                   message=f"internal error: the {data.get('type')} message holds a number "
                                           f"JSON cannot carry ({exc})"))
        if not self.ws.closed:
            await self.ws.send_str(text)

    async def error(self, seq: Any, message: str) -> None:
        echoed = isinstance(seq, int) and not isinstance(seq, bool) and abs(seq) < 2 ** 53    # a number JS reads exactly
        await self.send_json(dict(type="error", seq=seq if echoed else None, message=message))

    async def receive(self, text: str) -> None:
        """Check one message; queue what it asks for, or answer with an error."""
        seq = None
        try:
            message = parse_message(text)
            seq = message.get("seq")
            if seq is not None and (isinstance(seq, bool) or not isinstance(seq, int) or not 0 <= seq < 2 ** 53):
                raise ControlError(f"seq = {json.dumps(seq)[:40]}: must be a non-negative integer")
            kind = message.get("type")
            limits = self.server.session.limits
            if kind == "state":
                controls = parse_controls(message.get("controls"), limits)
                if self.pending is not None:
                    self.skipped += 1               # superseded before it was rendered
                self.pending = (seq or 0, controls, time.perf_counter())
            elif kind in ("save", "oracle", "sky_error"):
                controls = parse_controls(message.get("controls"), limits)
                if kind == "sky_error":
                    if self.sky_busy:
                        raise ControlError("sky_error: a sky error is being measured; wait for its result")
                    self.sky_busy = True
                self.jobs.append((kind, seq or 0, controls, message.get("name")))
            elif kind == "bye":
                await self.ws.close()
                return
            else:
                raise ControlError(f"type = {json.dumps(kind)[:40]}: expected state, save, oracle, sky_error or bye")
            self.wake.set()
        except ClshadeError as exc:
            await self.error(seq, str(exc))
        except Exception as exc:  # noqa: BLE001 — a bug must not drop the page's connection
            self.server.log("clshade view: internal error\n" + traceback.format_exc())
            await self.error(seq, f"internal error: {type(exc).__name__}: {exc}"[:300])

    async def run(self) -> None:
        """Two stages on two threads, each taking the newest state it can: the raster thread
        prepares the newest state that arrived (scene, geometry, rasterize: ViewSession.prepare),
        the render thread finishes the newest prepared one (G-buffer, shading, display, packing),
        so the next state is rasterized while the previous one is shaded (a state that finds both
        idle is made whole on the render thread: no hand-over). Frames leave in order,
        each of its own state; a state superseded before a stage took it is skipped, never
        queued. Jobs (save, oracle) run when both stages are idle, between frames. A frame is
        sent by a task of its own, so the next one renders while it travels."""
        sending: asyncio.Task | None = None
        raster: tuple | None = None         # (task, seq, received, started): a state being prepared
        render: tuple | None = None         # (task, seq, received, started, prepare_ms): a state being finished
        prepared: tuple | None = None       # (seq, Prepared, received, prepare_ms): waiting for the render thread
        session = self.server.session
        try:
            while not self.ws.closed:
                await self.wake.wait()
                self.wake.clear()
                if raster is not None and raster[0].done():
                    task, seq, received, started = raster
                    raster, result = None, task.result()
                    if result is not None:
                        if prepared is not None:
                            self.skipped += 1       # prepared, then superseded before it was shaded
                        prepared = (seq, result, received, (time.perf_counter() - started) * 1e3)
                if render is not None and render[0].done():
                    task, seq, received, started, prepare_ms = render
                    render, packed = None, task.result()
                    if sending is not None:
                        await sending
                    if packed is not None and not self.ws.closed:
                        data, pack_ms = packed
                        render_ms = prepare_ms + (time.perf_counter() - started) * 1e3 - pack_ms
                        sending = asyncio.create_task(self._send(seq, data, pack_ms, render_ms, received))
                if self.jobs:
                    if raster is not None or render is not None:
                        continue                    # woken again when both stages are done
                    while self.jobs:
                        kind, seq, controls, name = self.jobs.pop(0)
                        call = {"save": lambda c=controls, n=name: session.save(c, n),
                                "oracle": lambda c=controls: session.oracle(c),
                                "sky_error": lambda c=controls: session.sky_error_job(c)}[kind]
                        result = await self.server.call(call, self, seq)
                        if sending is not None:
                            await sending
                        if kind == "sky_error":
                            if result is None:      # refused (no sky): the page has its error
                                self.sky_busy = False
                            else:
                                self.sky_task = asyncio.create_task(self._sky_error(seq, result))
                        elif result is not None:
                            await self.send_json(dict(result, seq=seq))
                if raster is None and self.pending is not None:
                    seq, controls, received = self.pending
                    self.pending = None
                    if render is None and prepared is None:     # both idle: the whole frame on the render thread
                        render = (self._start(lambda c=controls, s=seq: self._finished(session.prepare(c), s), seq,
                                              self.server.executor), seq, received, time.perf_counter(), 0.0)
                    else:                                       # rasterized while the render thread works
                        raster = (self._start(lambda c=controls: session.prepare(c), seq,
                                              self.server.raster_executor), seq, received, time.perf_counter())
                if render is None and prepared is not None:
                    seq, p, received, prepare_ms = prepared
                    prepared = None
                    render = (self._start(lambda p=p, s=seq: self._finished(p, s), seq, self.server.executor),
                              seq, received, time.perf_counter(), prepare_ms)
        finally:
            for stage in (raster, render, (sending,), (self.sky_task,)):
                if stage is not None and stage[0] is not None:
                    stage[0].cancel()

    async def _sky_error(self, seq: int, job) -> None:
        """Integrate a sky error's truth step by step on the oracle thread (frames go on), sending its
        progress after each step and its result at the end."""
        try:
            await self._sky_steps(seq, job)
        finally:
            self.sky_busy = False

    async def _sky_steps(self, seq: int, job) -> None:
        steps = job.steps()
        while True:
            done = await self.server.call(lambda: next(steps, "finished"), self, seq, self.server.oracle_executor)
            if done is None:            # the step failed: the page has its error
                return
            if done == "finished":
                break
            await self.send_json(dict(type="sky_progress", seq=seq, label=job.label, done=done[0], total=done[1]))
        result = await self.server.call(job.result, self, seq, self.server.oracle_executor)
        if result is not None:
            await self.send_json(dict(result, seq=seq))

    def _start(self, fn, seq: int, executor) -> asyncio.Task:
        """Run `fn` on `executor`; the loop is woken when it is done."""
        task = asyncio.ensure_future(self.server.call(fn, self, seq, executor))
        task.add_done_callback(lambda _: self.wake.set())
        return task

    def _finished(self, prepared, seq: int) -> tuple[bytes, float]:
        """Finish and pack one prepared frame (on the render thread); the packing time."""
        frame = self.server.session.finish(prepared, copy=False)       # packed before the next frame renders
        t0 = time.perf_counter()
        data = pack_frame(frame, seq, dict(skipped=self.skipped))
        return data, (time.perf_counter() - t0) * 1e3

    async def _send(self, seq: int, data: bytes, pack_ms: float, render_ms: float, received: float) -> None:
        try:
            await self.ws.send_bytes(data)
            # Timing of the frame just sent, for the page's stage split (known only after sending).
            await self.send_json(dict(type="sent", seq=seq, pack_ms=pack_ms, bytes=len(data), render_ms=render_ms,
                                      server_ms=(time.perf_counter() - received) * 1e3))
        except ConnectionError:        # the page went away while its frame was on the way
            pass


class ViewServer:
    def __init__(self, session: ViewSession, host: str = "127.0.0.1", port: int = 0, linger: float | None = LINGER_S,
                 log: Callable[[str], None] | None = None) -> None:
        self.session, self.host, self.port, self.linger = session, host, port, linger
        self.token = None if is_loopback(host) else secrets.token_urlsafe(16)
        self.executor = ThreadPoolExecutor(1, thread_name_prefix="clshade-view")          # the render thread
        self.raster_executor = ThreadPoolExecutor(1, thread_name_prefix="clshade-raster")  # prepares the next state
        self.oracle_executor = ThreadPoolExecutor(1, thread_name_prefix="clshade-oracle")  # sky errors' truths
        self.pages: set[Page] = set()
        self.stopped: asyncio.Event | None = None
        self.url = ""
        self.log = log or (lambda text: print(text, file=sys.stderr, flush=True))
        self._linger_task: asyncio.Task | None = None

    # ------------------------------------------------------------ rendering off the event loop

    async def call(self, fn, page: Page, seq: int, executor: ThreadPoolExecutor | None = None):
        """Run `fn` on the render thread (or `executor`); a ClshadeError goes to the page, anything
        else is logged here and reported to the page in one line."""
        try:
            return await asyncio.get_running_loop().run_in_executor(executor or self.executor, fn)
        except ClshadeError as exc:
            await page.error(seq, str(exc))
        except Exception as exc:  # noqa: BLE001 — a bug must not stop the server
            self.log("clshade view: internal error\n" + traceback.format_exc())
            await page.error(seq, f"internal error: {type(exc).__name__}: {exc}"[:300])
        return None

    # ------------------------------------------------------------ HTTP

    @web.middleware
    async def guard(self, request: web.Request, handler):
        host = request.host.rsplit(":", 1)[0].strip("[]") if request.host else ""
        if self.token is None and not is_loopback(host):
            return web.Response(status=403, text="clshade view: this server answers on its loopback address only")
        if self.token is not None and not secrets.compare_digest(request.query.get("token", ""), self.token):
            return web.Response(status=403, text="clshade view: the URL's token is missing or wrong")
        return await handler(request)

    async def static(self, request: web.Request) -> web.StreamResponse:
        name, content_type = STATIC[request.path]
        body = resources.files("clshade.view").joinpath("static", name).read_bytes()
        return web.Response(body=body, content_type=content_type, headers={"Cache-Control": "no-store"})

    async def websocket(self, request: web.Request) -> web.StreamResponse:
        origin = request.headers.get("Origin")
        if origin is not None and origin != f"{request.scheme}://{request.host}":
            return web.Response(status=403, text="clshade view: WebSocket from another origin")
        # No permessage-deflate: zlib over 2 MB of pixels per frame would cost more CPU time than the
        # render on a 2-core machine, and the loopback link does not need it.
        ws = web.WebSocketResponse(max_msg_size=MAX_MESSAGE_BYTES, compress=False)
        await ws.prepare(request)
        page = Page(self, ws)
        self.pages.add(page)
        if self._linger_task is not None:
            self._linger_task.cancel()
        task = asyncio.create_task(page.run())
        try:
            try:
                hello = self.session.hello()
            except ClshadeError as exc:     # the page shows it; its messages are answered as ever
                hello = dict(type="error", seq=None, message=str(exc))
            await page.send_json(hello)
            async for message in ws:
                if message.type == WSMsgType.TEXT:
                    await page.receive(message.data)
                elif message.type == WSMsgType.BINARY:
                    await page.error(None, "message: binary messages are not accepted; send JSON text")
        finally:
            task.cancel()
            page.wake.set()
            self.pages.discard(page)
            if not self.pages and self.linger is not None and self.stopped is not None:
                self._linger_task = asyncio.create_task(self._stop_after(self.linger))
        return ws

    async def _stop_after(self, seconds: float) -> None:
        await asyncio.sleep(seconds)
        if not self.pages:
            self.log("clshade view: the page was closed; stopping")
            self.stopped.set()

    def app(self) -> web.Application:
        app = web.Application(middlewares=[self.guard], client_max_size=MAX_MESSAGE_BYTES)
        for path in STATIC:
            app.router.add_get(path, self.static)
        app.router.add_get("/ws", self.websocket)
        return app

    # ------------------------------------------------------------ lifetime

    async def start(self) -> web.AppRunner:
        """Listen; sets self.url (with the token when there is one)."""
        self.stopped = asyncio.Event()
        runner = web.AppRunner(self.app(), access_log=None, handle_signals=False, shutdown_timeout=1.0)
        await runner.setup()
        site = web.TCPSite(runner, self.host, self.port)
        await site.start()
        port = runner.addresses[0][1]
        shown = f"[{self.host}]" if ":" in self.host else self.host
        self.url = f"http://{shown}:{port}/" + (f"?token={self.token}" if self.token else "")
        return runner

    async def serve(self, ready: Callable[[str], None] | None = None) -> None:
        """Serve until stopped (last page closed, Ctrl-C, SIGTERM), then close cleanly."""
        runner = await self.start()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            try:
                loop.add_signal_handler(sig, self.stopped.set)
            except (NotImplementedError, RuntimeError, ValueError):   # not the main thread, or no signals
                pass
        if ready is not None:
            ready(self.url)
        try:
            await self.stopped.wait()
        finally:
            for page in list(self.pages):
                await page.ws.close()
            await runner.cleanup()
            self.raster_executor.shutdown(wait=True, cancel_futures=True)
            self.oracle_executor.shutdown(wait=True, cancel_futures=True)
            self.executor.shutdown(wait=True, cancel_futures=True)


class ServerThread:
    """`with ServerThread(session) as url:` serves on a thread of its own (tests, benchmarks)."""

    def __init__(self, session: ViewSession, linger: float | None = None, host: str = "127.0.0.1") -> None:
        self.server = ViewServer(session, host=host, linger=linger, log=lambda text: None)
        self.loop: asyncio.AbstractEventLoop | None = None
        self.thread = threading.Thread(target=self._run, daemon=True)
        self._url: queue.Queue = queue.Queue()

    def _run(self) -> None:
        async def main() -> None:
            self.loop = asyncio.get_running_loop()
            await self.server.serve(self._url.put)
        asyncio.run(main())

    def __enter__(self) -> str:
        self.thread.start()
        return self._url.get(timeout=120)

    def __exit__(self, *exc) -> None:
        if self.loop is not None and self.thread.is_alive():
            self.loop.call_soon_threadsafe(self.server.stopped.set)
        self.thread.join(timeout=30)

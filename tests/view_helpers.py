"""Shared by the viewer's tests: a ViewServer running on its own thread."""
from __future__ import annotations

import asyncio
import queue
import threading

from clshade.view.server import ViewServer
from clshade.view.session import ViewSession


class Running:
    """`with Running(session) as url:` serves `session` on a free loopback port."""

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
        return self._url.get(timeout=60)

    def stop(self) -> None:
        if self.loop is not None and self.thread.is_alive():
            self.loop.call_soon_threadsafe(self.server.stopped.set)
        self.thread.join(timeout=30)

    def __exit__(self, *exc) -> None:
        self.stop()

"""`clshade view`: the live viewer in the browser."""
from __future__ import annotations

import argparse

from clshade.cli.common import check_size
from clshade.errors import ClshadeError


def cmd_view(args: argparse.Namespace) -> int:
    import asyncio
    import webbrowser
    from clshade.view.server import ViewServer
    from clshade.view.session import ViewSession
    if not 0 <= args.port <= 65535:
        raise ClshadeError(f"--port = {args.port}: must be within [0, 65535]")
    from clshade.view.controls import canvas_cap
    session = ViewSession(args.scene, args.output_dir, check_size(args.width, "width"),
                          check_size(args.height, "height"), device=args.device, registry=args.registry,
                          max_canvas=canvas_cap(args.max_canvas, "--max-canvas"))
    server = ViewServer(session, args.host, args.port, linger=None if args.keep_running else 3.0)

    def ready(url: str) -> None:
        print(f"clshade view: serving {url} (Ctrl-C to stop)", flush=True)
        if not args.no_browser:
            webbrowser.open(url)

    try:
        asyncio.run(server.serve(ready))
    except OSError as exc:
        raise ClshadeError(f"--host {args.host} --port {args.port}: cannot listen ({exc.strerror or exc})") from exc
    print("clshade view: stopped", flush=True)
    return 0

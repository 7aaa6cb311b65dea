"""The `clshade` command line: `run` (the process entry point) and `main` (one command).
Only this package prints; library code raises ClshadeError."""
from __future__ import annotations

import gc
import sys

from clshade.cli.parser import build_parser, lobe_registry
from clshade.cli.process import quiet_broken_pipe, resume_gc, start_process
from clshade.errors import ClshadeError, one_line


def run() -> int:
    """The process entry point (the `clshade` script, `python -m clshade`): `main()` with
    the cyclic garbage collector tuned for a process that ends with its command.

    - Paused while the modules are imported and the parser is built: that allocates tens of
      thousands of long-lived objects (functions, classes, module dicts) and no garbage,
      which the collector would otherwise traverse again and again.
    - Then `gc.freeze()`: the survivors go to the permanent generation, which later
      collections skip; collection is on again for the command itself.
    - `gc.freeze()` once more when the command returns (not after a reported error):
      interpreter shutdown then does not traverse every object in its final full collections.
      Shutdown is otherwise complete: atexit handlers run, streams are flushed, objects are
      released by reference count; only objects in reference cycles are left to the operating
      system.

    And the allocator tuned, NumPy's BLAS single-threaded (clshade.cli.process)."""
    start_process()
    status = 1
    try:
        status = main(after_parse=resume_gc)
        return status
    finally:
        if status != 2:
            # Not after a reported error (exit status 2): objects of OpenImageIO's bindings
            # held in a cycle by the error's traceback would be frozen too, and nanobind
            # reports them at exit ("leaked 269 instances") on stderr, after clshade's one line.
            gc.freeze()


def main(argv: list[str] | None = None, after_parse=None) -> int:
    """Run one command (argv: sys.argv[1:] by default); `after_parse()` is called once the
    arguments are parsed, before the command runs. Returns the exit status."""
    try:
        return _main(argv, after_parse)
    except BrokenPipeError:
        return quiet_broken_pipe()


def _main(argv: list[str] | None, after_parse=None) -> int:
    from clshade import diagnostics
    parser = build_parser()
    args = parser.parse_args(argv)
    if after_parse is not None:
        after_parse()
    try:
        with diagnostics.warnings_captured():
            args.registry = lobe_registry(args)
            status = int(args.func(args) or 0)
        sys.stdout.flush()      # a closed pipe shows here, inside the handler, not at exit
        return status
    except BrokenPipeError:
        raise
    except (ClshadeError, OSError, MemoryError) as exc:
        # OSError and MemoryError: the system refused (disk full, permissions, memory) where
        # no check could tell in advance; one line too, with the traceback under --debug.
        if args.debug:
            raise
        print(f"clshade: error: {_one_line_error(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("clshade: interrupted", file=sys.stderr)
        return 130
    finally:
        if args.debug:
            _print_debug(diagnostics.NOTES, sys.exc_info()[1])
        diagnostics.NOTES.clear()


def _one_line_error(exc: BaseException) -> str:
    if isinstance(exc, MemoryError):
        return f"out of memory ({exc or 'MemoryError'}); see the README's Resource limits"
    if isinstance(exc, OSError):
        where = f"{exc.filename}: " if exc.filename else ""
        return one_line(f"{where}{exc.strerror or exc}")
    return str(exc)


def _print_debug(notes: list[str], exc: BaseException | None) -> None:
    """--debug: the messages of other libraries captured during the run, and an error's detail
    (a build log), on stderr."""
    for text in notes:
        print(f"clshade: debug: {text}", file=sys.stderr)
    detail = getattr(exc, "detail", "")
    if detail:
        print(f"clshade: debug: detail of the error:\n{detail}", file=sys.stderr)

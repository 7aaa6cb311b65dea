"""Which test files can a mutant change? Per-test-file impact, recorded once on the snapshot.

The mutation runner (benchmarks/mutation/run.py) runs, for each mutant, the test files that could fail because of it,
instead of the whole suite: the technique Stryker calls per-test coverage analysis. Recording: every test file runs
alone, in a fresh pytest process, on an unmutated copy of the snapshot, with a recorder loaded into that process and
into every Python process it starts (a `sitecustomize` on PYTHONPATH): coverage of every Python line under the copy,
and an audit hook that notes every file opened under it (modules imported, kernel sources assembled, scripts and
pages served, sources read as text).

A test file is selected for a mutant when its recording
- executed a statement that the mutated lines belong to, where those lines lie in a function body (they run only
  when called, and coverage sees each call);
- imported the mutated module or executed any line of it, where a mutated line lies outside every function body
  (a constant, a default value, a class attribute: evaluated once at import and read from then on);
- read the mutated file other than by importing it: a kernel source assembled into a program, the viewer's page
  served, a source searched as text;
- opened the mutated file in a process that ended without saving its coverage (killed, or a forked child): every
  line of what such a process opened counts as executed;
- or ran abnormally while recording (pytest's exit status other than 0 or 1, or no line recorded at all): such a
  file is selected for every mutant.

Why that is enough: a test file whose recording reaches none of the mutated code runs the same on the mutant, as
long as the tests are deterministic (Hypothesis runs derandomized in this suite) and each test file runs in a fresh
process (a cache filled by one file and read by another is seen, because each file's recording starts cold in its
own process). What a file-per-process recording sees is a superset of what the one-process suite run sees.

    python -m benchmarks.mutation.impact [--json out.json]     # record on the committed HEAD, one line a file
"""
from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from benchmarks.mutation.snapshot import snapshot, suite_env

#: The recorder, written as `sitecustomize.py` into a folder that goes first on PYTHONPATH. It reads the folder to
#: write into from the `current` file beside it (so that a subprocess started with an environment of its own still
#: records into the test file's folder; test files are recorded one at a time).
RECORDER = r'''
"""clshade impact recorder (benchmarks/mutation/impact.py): Python lines run and files opened under the snapshot."""
import atexit
import os
import sys


def _start():
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        with open(os.path.join(here, "current"), encoding="utf-8") as f:
            out, root = f.read().split("\n")[:2]
    except (OSError, ValueError):
        return
    if not out:
        return
    prefix = root.rstrip(os.sep) + os.sep
    logs = {}

    def log():
        pid = os.getpid()
        if pid not in logs:
            logs[pid] = open(os.path.join(out, f"opened.{pid}"), "a", encoding="utf-8", buffering=1)
            with open(os.path.join(out, f"started.{pid}"), "w"):
                pass
        return logs[pid]

    def hook(event, args):
        if event != "open" or not args:
            return
        path = args[0]
        if isinstance(path, bytes):
            path = os.fsdecode(path)
        elif not isinstance(path, str):
            try:
                path = os.fspath(path)
            except TypeError:
                return          # a file descriptor
        path = os.path.abspath(path)
        if path.startswith(prefix):
            # an import (importlib's loader opens the module) or any other read (a kernel source, a page, a
            # source searched as text)
            frame, kind = sys._getframe(1), "r"
            for _ in range(8):
                if frame is None:
                    break
                if frame.f_code.co_filename.startswith("<frozen importlib"):
                    kind = "i"
                    break
                frame = frame.f_back
            log().write(f"{kind} {path[len(prefix):]}\n")

    log()
    sys.addaudithook(hook)
    import coverage
    cov = coverage.Coverage(data_file=os.path.join(out, "cov"), data_suffix=True, include=[prefix + "*"],
                            config_file=False)
    cov.start()
    owner = os.getpid()

    def save():
        if os.getpid() != owner:     # a forked child: no saved coverage, its opens count in full
            return
        cov.stop()
        cov.save()
        with open(os.path.join(out, f"saved.{owner}"), "w"):
            pass

    atexit.register(save)


_start()
'''


#: pytest's exit statuses of a recording that ran its tests: all passed, or some failed (a failing test still
#: reached what it reached; the baseline run lists it apart).
RECORDED_OK = (0, 1)


@dataclass
class FileImpact:
    """What one test file's run reached: Python lines per source file, modules imported, other files opened (read),
    and the files opened by a process that did not save its coverage (all their lines count)."""
    lines: dict[str, set[int]] = field(default_factory=dict)
    imported: set[str] = field(default_factory=set)
    read: set[str] = field(default_factory=set)
    whole: set[str] = field(default_factory=set)
    seconds: float = 0.0
    returncode: int | None = None


def _collect(folder: Path, root: Path) -> FileImpact:
    """Read one test file's recording folder."""
    import coverage
    out = FileImpact()
    saved = {p.name.split(".", 1)[1] for p in folder.glob("saved.*")}
    for p in folder.glob("opened.*"):
        entries = [line.split(" ", 1) for line in p.read_text(encoding="utf-8").splitlines() if line]
        out.imported |= {name for kind, name in entries if kind == "i"}
        out.read |= {name for kind, name in entries if kind == "r"}
        if p.name.split(".", 1)[1] not in saved:
            out.whole |= {name for _, name in entries}
    prefix = str(root.resolve()) + os.sep
    for p in folder.glob("cov.*"):
        data = coverage.CoverageData(basename=str(p))
        data.read()
        for measured in data.measured_files():
            if measured.startswith(prefix):
                rel = measured[len(prefix):]
                out.lines.setdefault(rel, set()).update(data.lines(measured) or ())
    return out


def record(copy: Path, python: str, env: dict[str, str], files: list[str] | None = None,
           progress=None) -> dict[str, FileImpact]:
    """Run each test file of `copy` alone with the recorder; test file (relative path) → what it reached."""
    files = files or sorted(str(p.relative_to(copy)) for p in (copy / "tests").rglob("test_*.py"))
    impact: dict[str, FileImpact] = {}
    with tempfile.TemporaryDirectory(prefix="clshade-impact-") as tmp:
        recorder = Path(tmp) / "recorder"
        recorder.mkdir()
        (recorder / "sitecustomize.py").write_text(RECORDER, encoding="utf-8")
        run_env = dict(env, PYTHONPATH=os.pathsep.join([str(recorder), env.get("PYTHONPATH", "")]))
        for name in files:
            folder = Path(tmp) / name.replace("/", "_")
            folder.mkdir()
            (recorder / "current").write_text(f"{folder}\n{copy.resolve()}\n", encoding="utf-8")
            start = time.perf_counter()
            proc = subprocess.run([python, "-m", "pytest", "-q", "-p", "no:cacheprovider", name], cwd=copy,
                                  env=run_env, capture_output=True, text=True)
            (recorder / "current").write_text("", encoding="utf-8")
            got = _collect(folder, copy)
            got.seconds, got.returncode = round(time.perf_counter() - start, 1), proc.returncode
            impact[name] = got
            if progress:
                progress(name, got)
    return impact


def mutated_lines(text: str, start: int, end: int) -> range:
    """The 1-based lines of `text` that the mutated span text[start:end] covers."""
    first = text.count("\n", 0, start) + 1
    return range(first, first + text.count("\n", start, end) + 1)


def statement_lines(source: str, lines: range) -> set[int] | None:
    """The lines of the innermost statements that hold `lines`, where each lies inside a function body (run only
    when the function is called); None where one lies outside every function body (run at import)."""
    tree = ast.parse(source)
    bodies: list[tuple[int, int]] = []
    statements: list[ast.stmt] = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            bodies.append((node.body[0].lineno, max(n.end_lineno or n.lineno for n in node.body)))
        elif isinstance(node, ast.Lambda):
            bodies.append((node.body.lineno, node.body.end_lineno or node.body.lineno))
        if isinstance(node, ast.stmt):
            statements.append(node)
    out: set[int] = set()
    for line in lines:
        if not any(a <= line <= b for a, b in bodies):
            return None
        holding = [s for s in statements if s.lineno <= line <= (s.end_lineno or s.lineno)]
        inner = min(holding, key=lambda s: (s.end_lineno or s.lineno) - s.lineno)
        out.update(range(inner.lineno, (inner.end_lineno or inner.lineno) + 1))
    return out


def select(impact: dict[str, FileImpact], file: str, text: str, mutated: range) -> list[str]:
    """The test files that a mutant of `file` (its unmutated `text`, the lines `mutated`) can change."""
    lines = statement_lines(text, mutated) if file.endswith(".py") else None
    chosen = []
    for test, got in impact.items():
        executed = got.lines.get(file, set())
        if got.returncode not in RECORDED_OK or not got.lines:      # what it reaches is unknown
            chosen.append(test)
        elif file in got.whole or file in got.read:          # all of it counts, or it is read (as text, as a kernel)
            chosen.append(test)
        elif not file.endswith(".py"):
            continue
        elif lines is None and (executed or file in got.imported):
            chosen.append(test)
        elif lines is not None and executed & lines:
            chosen.append(test)
    return chosen


def to_json(impact: dict[str, FileImpact]) -> dict:
    return {name: dict(lines={f: sorted(v) for f, v in sorted(got.lines.items())}, imported=sorted(got.imported),
                       read=sorted(got.read), whole=sorted(got.whole), seconds=got.seconds, returncode=got.returncode)
            for name, got in impact.items()}


def from_json(doc: dict) -> dict[str, FileImpact]:
    return {name: FileImpact({f: set(v) for f, v in d["lines"].items()}, set(d["imported"]), set(d["read"]),
                             set(d["whole"]), d["seconds"], d["returncode"]) for name, d in doc.items()}


def main(argv: list[str] | None = None) -> int:
    import argparse
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="write the map here")
    parser.add_argument("files", nargs="*", help="test files (default: every test_*.py under tests/)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="impact-base-") as tmp:
        copy = Path(tmp) / "repo"
        snapshot(copy)
        env = suite_env(copy)
        impact = record(copy, sys.executable, env, args.files or None,
                        progress=lambda n, g: print(f"{n:45s} {g.seconds:6.1f} s rc {g.returncode}  "
                                                    f"{len(g.lines)} modules, {len(g.read)} files read",
                                                    flush=True))
    if args.json:
        Path(args.json).write_text(json.dumps(to_json(impact)) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())

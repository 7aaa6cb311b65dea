"""Publish: render every published text from the results JSON. Measures nothing.

Generators (benchmarks/measure/, benchmarks/experiments/host_ab.py, the mutation runner, `clshade aa`,
`clshade check stability`) write JSON; this module turns each into what the results registry
(benchmarks/publish/registry.py) says it renders: whole Markdown files (benchmarks/REPORT.md, every
benchmarks/results/*.md, docs/accuracy.md) and the regions of README.md and docs/*.md between
`<!-- publish:NAME -->` and `<!-- /publish:NAME -->` markers, README's list of the commands included.
tests/contracts/test_publish.py re-renders and compares, so a number edited by hand in a published table fails the suite.

    python -m benchmarks.publish          # rewrite the files
    python -m benchmarks.publish --check  # exit 1 when a file differs from its rendering
"""
from __future__ import annotations

import argparse
import json
import re
from pathlib import Path
from typing import Callable

from benchmarks.publish.registry import RESULTS, Result

ROOT = Path(__file__).resolve().parents[2]
COMMANDS_REGION = ("README.md", "results-commands")     # README's list of the registry's commands


def load(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def replace_region(text: str, name: str, body: str, path: Path) -> str:
    pattern = re.compile(rf"(<!-- publish:{name} -->\n)(.*?)(\n<!-- /publish:{name} -->)", re.S)
    if not pattern.search(text):
        raise SystemExit(f"{path}: no <!-- publish:{name} --> … <!-- /publish:{name} --> region")
    return pattern.sub(lambda m: m.group(1) + body + m.group(3), text, count=1)


def commands_block(results: tuple[Result, ...] = RESULTS) -> str:
    """Every result's command under a comment naming the JSON it writes and what it measures, as a shell block."""
    lines = [line for r in results for line in (f"# {r.json}" + (f": {r.note}" if r.note else ""), r.command)]
    return "\n".join(["```sh", *lines, "```"])


def document(root: Path, result: Result) -> dict:
    """A result's JSON as the renderers read it: with the registry's command where the JSON records none."""
    return {"command": result.command, **load(root / result.json)}


def renderings(root: Path = ROOT, results: tuple[Result, ...] = RESULTS) -> dict[Path, Callable[[str], str]]:
    """Each published file → a function from its current text to its rendered text: every rendering of
    every result whose JSON exists, the regions of one file applied in turn, and README's command list."""
    steps: dict[Path, list[Callable[[str], str]]] = {}
    for result in results:
        source = root / result.json
        if not source.exists():
            continue
        for r in result.renderings:
            path = root / r.path
            if r.region is None:
                step = (lambda render, result: lambda text: render(document(root, result)))(r.render, result)
            else:
                step = (lambda render, result, region, path: lambda text: replace_region(
                    text, region, render(document(root, result)), path))(r.render, result, r.region, path)
            steps.setdefault(path, []).append(step)
    readme = root / COMMANDS_REGION[0]
    steps.setdefault(readme, []).append(lambda text: replace_region(text, COMMANDS_REGION[1], commands_block(results),
                                                                    readme))

    def chain(funcs: list[Callable[[str], str]]) -> Callable[[str], str]:
        def render(text: str) -> str:
            for f in funcs:
                text = f(text)
            return text
        return render
    return {path: chain(funcs) for path, funcs in steps.items()}


def stale(root: Path = ROOT, results: tuple[Result, ...] = RESULTS) -> list[Path]:
    """Published files whose text differs from their rendering."""
    bad = []
    for path, render in renderings(root, results).items():
        text = path.read_text(encoding="utf-8") if path.exists() else ""
        if render(text) != text:
            bad.append(path)
    return bad


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.publish", description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 when a file differs from its rendering")
    args = parser.parse_args(argv)
    if args.check:
        bad = stale()
        for path in bad:
            print(f"stale (differs from its JSON): {path.relative_to(ROOT)}")
        return 1 if bad else 0
    for path, render in renderings().items():
        text = path.read_text(encoding="utf-8") if path.exists() else ""
        new = render(text)
        if new != text:
            path.write_text(new, encoding="utf-8")
            print(f"wrote {path.relative_to(ROOT)}")
    return 0

"""Measure published results again with the commands the results registry names, then publish.

    python -m benchmarks.publish.regenerate                 # every stale or missing result, then publish
    python -m benchmarks.publish.regenerate aa.json view.json
    python -m benchmarks.publish.regenerate --all --skip mutants.json --dry-run

Each command runs from the repository root in a shell, one at a time (timings on a shared machine are
noisy enough without two benchmarks at once); a failing command is reported and the others still run.
A result on freshness's known-stale list (hours to measure) runs only when named or with --all.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import time

from benchmarks.publish.freshness import KNOWN_STALE, ROOT, staleness
from benchmarks.publish.registry import RESULTS, Result


def chosen(names: list[str], everything: bool, skip: list[str]) -> list[Result]:
    """The results to measure: those named (by file name), all, or the stale and missing ones (not the
    known-stale); less `skip`."""
    known = {r.name: r for r in RESULTS}
    unknown = [n for n in [*names, *skip] if n not in known]
    if unknown:
        raise SystemExit(f"regenerate: unknown result {unknown[0]!r}; the registry has {', '.join(known)}")
    if names:
        picked = [known[n] for n in names]
    elif everything:
        picked = list(RESULTS)
    else:
        stale = staleness()
        picked = [r for r in RESULTS if r.json not in KNOWN_STALE
                  and (stale.get(r.json) or not (ROOT / r.json).is_file())]
    return [r for r in picked if r.name not in skip]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="results by file name (default: the stale and missing ones)")
    parser.add_argument("--all", action="store_true", help="every result of the registry")
    parser.add_argument("--skip", action="append", default=[], metavar="NAME", help="leave this result out")
    parser.add_argument("--dry-run", action="store_true", help="print the commands only")
    args = parser.parse_args(argv)
    failed = []
    for result in chosen(args.names, args.all, args.skip):
        print(f"== {result.name}: {result.command}", flush=True)
        if args.dry_run:
            continue
        start = time.perf_counter()
        status = subprocess.run(result.command, shell=True, cwd=ROOT).returncode
        print(f"== {result.name}: exit {status} after {time.perf_counter() - start:.0f} s", flush=True)
        if status:
            failed.append(result.name)
    if not args.dry_run:
        subprocess.run([sys.executable, "-m", "benchmarks.publish"], cwd=ROOT, check=False)
    if failed:
        print(f"regenerate: failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())

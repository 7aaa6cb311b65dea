"""Mutation testing: does the test suite catch small semantic bugs?

Each mutant of the catalogue (benchmarks/mutation/catalogue.toml: file, anchor, original text, replacement,
description; benchmarks/mutation/catalogue.py resolves it) is one small semantic bug. For every mutant the script
copies the repository (its committed HEAD) to a temporary folder, applies the one edit, and runs the test suite there
(until the first behavioural failure of a test that passes on the unmutated tree: the kill class is then known,
and on this machine the rest of a suite is hours per catalogue; `--every-failure` runs every selected file and lists
every failing test), with PYTHONPATH pointing at the copy: the copy's Python code and the
copy's kernels are the ones used (the run checks that clshade.resources.kernels_dir() lies inside the copy; PoCL
caches binaries by source, so a mutated kernel is compiled afresh).

A mutant whose anchor is gone (its function, or its text inside the function, is no longer in the tree) is not run:
its row says "anchor gone" with the reason, on the console and in the JSON; a mutant whose anchor moved to another
file runs there and is listed as moved. `--check` only resolves the catalogue, in the working tree (a run resolves
it in the committed HEAD it runs on), and lists both. A text found more than once inside its anchor, or a malformed
catalogue, stops the run before any suite runs.

Each kill is classified (KILL_CLASSES) from its failing tests (benchmarks/mutation/plugin.py records them with
their markers): *behavioural* when some failing test checks behaviour; else *compile error* (the mutated kernel
does not build), *collection error*, *snapshot* (only tests marked `snapshot`: output compared with a committed
file the same code wrote), *text* (only tests marked `text`: a string searched in source, docs or binaries) or
*needs extra* (only tests marked `extra`, which run only where an optional package is installed). The headline
counts behavioural kills only. The unmutated snapshot runs first (the baseline): a test failing there kills
nothing, and is listed apart in each mutant's row.

    python -m benchmarks.mutation.run [--jobs 2] [--only NAME,...] [--json benchmarks/results/mutants.json]
    python -m benchmarks.mutation.run --every-failure               # no stop at the first behavioural kill
    python -m benchmarks.mutation.run --resume --impact-from MAP    # go on with a run stopped part way, same commit
    python -m benchmarks.mutation.run --check                       # resolve every mutant; list moved and gone ones
    python -m benchmarks.mutation.run --fix-moved                   # the same, and write the moved ones' files

Writes JSON only; `python -m benchmarks.publish` renders benchmarks/results/mutants.md from it.
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from benchmarks.mutation import impact
from benchmarks.mutation.plugin import KILL_CLASSES, kill_kind
from benchmarks.mutation.catalogue import (CATALOGUE_FILE, CatalogueError, Mutant, Site, apply, load, resolve_all,
                                           rewrite_files)
from benchmarks.mutation.snapshot import ROOT, code_commit, snapshot, suite_env
from clshade.provenance import stamp

OUT = ROOT / "benchmarks" / "results" / "mutants.json"
TEST_TIMEOUT_S = 1800     # the whole suite (no fail-fast), 2 at a time on 2 shared cores
GONE = "anchor gone"      # the status (and kill class) of a mutant whose anchor is not in the tree


def resolved(root: Path, catalogue: list[Mutant]) -> list[Site]:
    """Every mutant's site in the tree at `root`; a catalogue error stops the run (SystemExit, every error listed)."""
    try:
        return resolve_all(root, catalogue)
    except CatalogueError as err:
        raise SystemExit(f"the mutation catalogue does not match the tree:\n{err}") from None


def report_sites(sites: list[Site]) -> None:
    """Print the mutants that moved to another file and those whose anchor is gone."""
    for s in sites:
        if s.moved:
            print(f"moved            {s.mutant.name:28s} {s.mutant.anchor} is in {s.file}, not {s.mutant.file} "
                  "(update the catalogue)", flush=True)
        elif s.gone:
            print(f"{GONE:16s} {s.mutant.name:28s} {s.gone}", flush=True)


def check(sites: list[Site]) -> int:
    """--check: 0 where every mutant resolves (moved ones included), 1 where an anchor is gone."""
    report_sites(sites)
    gone = sum(bool(s.gone) for s in sites)
    moved = sum(s.moved for s in sites)
    print(f"{len(sites)} mutants: {len(sites) - gone} resolved ({moved} moved to another file), {gone} {GONE}")
    return 1 if gone else 0


def test_order(root: Path, file: str) -> list[str]:
    """Every test file, those that name the mutated module (or kernel file: `glsl.h`) first (the likeliest
    to fail), then the rest in the usual order."""
    files = sorted((root / "tests").rglob("test_*.py"))
    module = file.removesuffix(".py").replace("/", ".")       # clshade.render.image
    if file.startswith("kernels/"):
        module = file.removeprefix("kernels/")                 # glsl.h, models/phong.cl
    first = [f for f in files if module in f.read_text(encoding="utf-8")]
    return [str(f.relative_to(root)) for f in first + [f for f in files if f not in first]]


def classify(failures: list[dict], returncode: int | None) -> str:
    """The kill class of one mutant from its failing tests (benchmarks.mutation.plugin's records), or
    'survived' / 'timeout'."""
    if returncode == -1:
        return "timeout"
    if not failures:
        return "survived" if returncode in (0, 5) else "collection error"
    found = {kill_kind(f) for f in failures}
    return next(c for c in KILL_CLASSES if c in found)


def installed_extras(python: str) -> dict[str, bool]:
    """Which optional packages the suite's interpreter has (tests marked `extra` need them)."""
    code = ("import importlib.util, json; print(json.dumps({m: importlib.util.find_spec(m) is not None "
            "for m in ('matplotlib', 'numba', 'drjit')}))")
    proc = subprocess.run([python, "-c", code], capture_output=True, text=True)
    return json.loads(proc.stdout) if proc.returncode == 0 else {}


# The unmutated tree, run once like a mutant: tests failing there kill nothing.
BASELINE = Site(Mutant("(baseline)", "", "", "", "", "the snapshot itself, unmutated"), "")


def run_one(site: Site, python: str, base: Path, baseline: frozenset[str] = frozenset(),
            files: list[str] | None = None, every_failure: bool = True) -> dict:
    """Copy the snapshot `base`, apply the mutant (resolved there: `site`), run the suite there — the test files
    `files` that the mutant can change (benchmarks/mutation/impact.py), or the whole suite where `files` is None —
    up to its first behavioural failure of a test passing on the unmutated tree, or to its end with
    `every_failure`; the failing tests are recorded, and the kill classified on the tests that pass on the
    unmutated tree (`baseline`: the tests failing there, listed apart)."""
    mutant = site.mutant
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix=f"mutant-{mutant.name}-") as tmp:
        copy = Path(tmp) / "repo"
        shutil.copytree(base, copy)
        if site is not BASELINE:
            apply(copy, site)
        report = Path(tmp) / "failures.json"
        env = dict(suite_env(copy), CLSHADE_MUTANT=mutant.name, CLSHADE_MUTANT_REPORT=str(report))
        if not every_failure:
            env.update(CLSHADE_MUTANT_STOP="1", CLSHADE_MUTANT_BASELINE=json.dumps(sorted(baseline)))
        where = subprocess.run([python, "-c", "import clshade.resources as r; print(r.kernels_dir())"],
                               cwd=copy, env=env, capture_output=True, text=True)
        kernels = where.stdout.strip()
        if where.returncode or not Path(kernels).resolve().is_relative_to(copy.resolve()):
            raise SystemExit(f"mutant {mutant.name}: the copy's kernels are not the ones used ({kernels!r} "
                             f"{where.stderr.strip()})")
        every = test_order(copy, site.file or "")
        order = [f for f in every if files is None or f in files]
        if not order:          # no test file reaches the mutated code: nothing can fail
            rc, tail = 5, ["no test file reaches the mutated code"]
        else:
            try:
                proc = subprocess.run([python, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                                       "-p", "benchmarks.mutation.plugin", *order], cwd=copy, env=env,
                                      capture_output=True, text=True, timeout=TEST_TIMEOUT_S)
                rc, tail = proc.returncode, proc.stdout.strip().splitlines()
            except subprocess.TimeoutExpired:
                rc, tail = -1, ["timeout"]
        failures = json.loads(report.read_text(encoding="utf-8")) if report.exists() else []
    new = [f for f in failures if f["test"] not in baseline]
    kill = classify(new, 0 if failures and not new else rc)
    return dict(name=mutant.name, file=site.file, description=mutant.description,
                status="killed" if kill not in ("survived", "timeout") else kill, kill_class=kill, returncode=rc,
                failing_tests=[dict(test=f["test"], kind=kill_kind(f)) for f in new],
                failing_on_baseline_too=sorted({f["test"] for f in failures} - {f["test"] for f in new}),
                seconds=round(time.perf_counter() - start, 1), summary=tail[-1] if tail else "",
                test_files_run=len(order), test_files_total=len(every), every_failure=every_failure)


def gone_row(site: Site) -> dict:
    """The row of a mutant whose anchor is gone: not run, the reason in `summary`."""
    m = site.mutant
    return dict(name=m.name, file=m.file, description=m.description, status=GONE, returncode=None, kill_class=GONE,
                failing_tests=[], seconds=0.0, summary=site.gone)


def record_impact(base: Path, commit: str | None, keep: str | None = None) -> dict[str, impact.FileImpact]:
    """Record, on an unmutated copy of the snapshot, what each test file reaches (benchmarks/mutation/impact.py)."""
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="mutants-impact-") as tmp:
        copy = Path(tmp) / "repo"
        shutil.copytree(base, copy)
        got = impact.record(copy, sys.executable, suite_env(copy))
    if keep:
        Path(keep).write_text(json.dumps(dict(commit=commit, files=impact.to_json(got))) + "\n", encoding="utf-8")
    print(f"impact recorded for {len(got)} test files in {time.perf_counter() - start:.0f} s", flush=True)
    return got


MAX_IMPACT_BYTES = 256 << 20     # a kept map is a few MB; a larger file is not one


def _seconds(text: str) -> float:
    """--budget-s: a positive, finite number of seconds."""
    value = float(text)
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r}: not a positive, finite number of seconds")
    return value


def load_impact(path: str, commit: str | None) -> dict[str, impact.FileImpact]:
    """A map kept by --impact-json; it must name the commit the mutants run on."""
    file = Path(path)
    if not file.is_file() or file.stat().st_size > MAX_IMPACT_BYTES:
        raise SystemExit(f"{path}: --impact-from needs a map kept by --impact-json (a regular file of at most "
                         f"{MAX_IMPACT_BYTES >> 20} MB)")
    doc = json.loads(file.read_text(encoding="utf-8"))
    if not commit or doc.get("commit") != commit:
        raise SystemExit(f"{path}: impact map recorded on {doc.get('commit')!r}, the mutants run on {commit!r}; "
                         "record it again (--impact-json)")
    return impact.from_json(doc["files"])


def _run_within(chosen: list[Site], run, jobs: int, deadline: float | None):
    """Yield run(s) for the mutants in order, `jobs` at a time, starting none after `deadline` (perf_counter)."""
    from concurrent.futures import FIRST_COMPLETED, wait
    todo = list(chosen)
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        running = set()
        while todo or running:
            while todo and len(running) < jobs and (deadline is None or time.perf_counter() < deadline):
                running.add(pool.submit(run, todo.pop(0)))
            if not running:
                print(f"budget spent: {len(todo)} mutants not started", flush=True)
                return
            done, running = wait(running, return_when=FIRST_COMPLETED)
            for future in done:
                yield future.result()


def still_to_run(chosen: list[Mutant], previous: dict, commit: str | None) -> list[Mutant]:
    """--resume: the mutants without a measured row on `commit` in the previous results."""
    done = {r["name"] for r in previous["mutants"] if commit and r.get("commit") == commit
            and r["status"] != "not run"}
    return [m for m in chosen if m.name not in done]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2, help="mutants run at the same time (≤ 2 on the shared machine)")
    parser.add_argument("--only", default="", help="comma-separated mutant names")
    parser.add_argument("--every-failure", action="store_true", help="run every selected test file of each mutant "
                        "and list every failing test (by default a mutant's suite stops at its first behavioural kill)")
    parser.add_argument("--json", default=str(OUT))
    parser.add_argument("--check", action="store_true", help="only resolve every mutant in the working tree: list "
                        "the moved ones and those whose anchor is gone (exit status 1 if any is gone)")
    parser.add_argument("--fix-moved", action="store_true", help="--check, then write into catalogue.toml the file "
                        "each moved mutant resolved to")
    parser.add_argument("--whole-suite", action="store_true",
                        help="run every test file for every mutant (default: the files that can fail, "
                             "benchmarks/mutation/impact.py)")
    parser.add_argument("--impact-json", help="keep the recorded impact map here")
    parser.add_argument("--budget-s", type=_seconds, help="start no mutant after this many seconds (baseline and "
                        "recording included); the rows not reached keep the results file's previous rows")
    parser.add_argument("--impact-from", help="use a map kept by --impact-json on this same commit instead of "
                                              "recording one")
    parser.add_argument("--resume", action="store_true", help="run only the mutants whose row in the results file "
                        "was not measured on this commit (a run stopped part way goes on; rows of this commit are kept)")
    args = parser.parse_args(argv)
    try:
        catalogue = load()
    except CatalogueError as err:
        raise SystemExit(str(err)) from None
    if args.check or args.fix_moved:    # the working tree, edits to the catalogue or the code included
        sites = resolved(ROOT, catalogue)
        status = check(sites)
        if args.fix_moved:
            rewrite_files(CATALOGUE_FILE, {s.mutant.name: s.file for s in sites if s.moved})
            print(f"{CATALOGUE_FILE.relative_to(ROOT)}: the file of {sum(s.moved for s in sites)} moved mutants "
                  "updated")
        return status
    commit = code_commit()
    holder = tempfile.TemporaryDirectory(prefix="mutants-base-")
    base = Path(holder.name) / "repo"
    snapshot(base)                      # one snapshot for the whole run: later commits cannot leak in
    sites = resolved(base, catalogue)   # the catalogue resolves in the tree the mutants run on
    only = set(args.only.split(",")) if args.only else set()
    unknown = only - {m.name for m in catalogue}
    if unknown:
        raise SystemExit(f"--only: no mutant named {', '.join(sorted(unknown))} in the catalogue")
    kept = load_impact(args.impact_from, commit) if args.impact_from else None    # refused before hours of work
    chosen = [s for s in sites if not only or s.mutant.name in only]
    out = Path(args.json)
    previous = json.loads(out.read_text(encoding="utf-8")) if out.exists() and \
        (args.only or args.budget_s or args.resume) else None
    if args.resume and previous:
        todo = {m.name for m in still_to_run([s.mutant for s in chosen], previous, commit)}
        chosen = [s for s in chosen if s.mutant.name in todo]
        print(f"resume: {len(chosen)} mutants to run; the others were measured on {commit}", flush=True)
    report_sites(chosen)
    runnable = [s for s in chosen if not s.gone]
    start = time.perf_counter()
    results: list[dict] = [dict(gone_row(s), commit=commit) for s in chosen if s.gone]
    base_run = run_one(BASELINE, sys.executable, base)
    baseline = frozenset(f["test"] for f in base_run["failing_tests"])
    print(f"baseline (unmutated): {len(baseline)} failing {sorted(baseline)}", flush=True)
    selection = None if args.whole_suite else \
        kept if kept is not None else record_impact(base, commit, args.impact_json)
    selected: dict[str, list[str]] = {}
    if selection is not None:
        for s in runnable:
            text = (base / s.file).read_text(encoding="utf-8")
            selected[s.mutant.name] = impact.select(selection, s.file, text, impact.mutated_lines(text, s.start, s.end))
    def files(s: Site) -> list[str] | None:
        return selected[s.mutant.name] if selection is not None else None
    if selection is not None:      # the cheapest first (recorded seconds of the files each runs): a budget reaches most
        cost = {s.mutant.name: sum(selection[f].seconds for f in files(s)) for s in runnable}
        runnable = sorted(runnable, key=lambda s: cost[s.mutant.name])
        print(f"selected test files: {sum(len(files(s)) for s in runnable)} runs for {len(runnable)} mutants "
              f"(of {len(selection) * len(runnable)} in whole suites)", flush=True)
    mutants = [s.mutant for s in chosen]
    for res in _run_within(runnable, lambda s: run_one(s, sys.executable, base, baseline, files(s), args.every_failure),
                           jobs=max(1, min(args.jobs, 2)), deadline=start + args.budget_s if args.budget_s else None):
        res["commit"] = commit
        results.append(res)
        first = res["failing_tests"][0]["test"] if res["failing_tests"] else ""
        print(f"{res['kill_class']:16s} {res['name']:28s} {res['seconds']:6.1f} s  "
              f"{len(res['failing_tests'])} failing  {first}", flush=True)
        write_results(out, results, mutants, catalogue, previous, commit, time.perf_counter() - start,
                      sorted(baseline))
    doc = write_results(out, results, mutants, catalogue, previous, commit, time.perf_counter() - start,
                        sorted(baseline))
    print(f"{doc['behavioural']}/{doc['total']} killed by a behavioural test ({doc['killed']} killed in all: "
          f"{doc['kill_classes']}; {doc['anchor_gone']} {GONE}); wrote {out}")
    return 0


def write_results(out: Path, results: list[dict], chosen: list[Mutant], catalogue: list[Mutant],
                  previous: dict | None, commit: str | None, seconds: float, baseline: list[str] | None = None) -> dict:
    """Write the results so far (after every mutant: a stopped run leaves what it measured); mutants of the
    run not measured yet are listed as 'not run'. A partial --only run updates its rows of the previous file;
    the rows follow the catalogue's order."""
    done = {r["name"] for r in results}
    not_run = lambda m: dict(name=m.name, file=m.file, description=m.description, status="not run",  # noqa: E731
                             returncode=None, kill_class="not run", failing_tests=[], seconds=0.0, summary="",
                             commit=None)
    rows = results + [not_run(m) for m in chosen if m.name not in done]
    if previous:   # each row keeps its commit; a mutant new to the catalogue is listed as not run
        by_name = {r["name"]: {"commit": previous.get("commit"), **r} for r in previous["mutants"]}
        by_name.update({r["name"]: r for r in rows if r["status"] != "not run" or r["name"] not in by_name})
        rows = [by_name.get(m.name) or not_run(m) for m in catalogue]
    else:
        order = {m.name: i for i, m in enumerate(catalogue)}
        rows.sort(key=lambda r: order[r["name"]])
    doc = dict(schema=2, created=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
               machine=f"{platform.node()} {platform.machine()}", command="python -m benchmarks.mutation.run",
               commit=commit, commits=sorted({r.get("commit") or "" for r in rows if r.get("commit")}),
               seconds=round(seconds, 1), total=len(rows),
               killed=sum(r["status"] == "killed" for r in rows),
               survived=sum(r["status"] == "survived" for r in rows),
               timeouts=sum(r["status"] == "timeout" for r in rows),
               not_run=sum(r["status"] == "not run" for r in rows),
               anchor_gone=sum(r["status"] == GONE for r in rows),
               # the headline: kills by a test of behaviour; rows of schema-1 runs (first failing test only,
               # no class) are counted apart as unclassified
               behavioural=sum(r.get("kill_class") == "behavioural" for r in rows),
               kill_classes={c: sum(r.get("kill_class") == c for r in rows) for c in KILL_CLASSES},
               unclassified=sum(r["status"] == "killed" and "kill_class" not in r for r in rows),
               extras=installed_extras(sys.executable), baseline_failures=baseline, mutants=rows)
    # Provenance: the commit the suites ran on where every row ran there; else the previous file's, when rows of it are kept
    # (a partial run does not make the whole catalogue fresh); the snapshot is a clean `git archive`.
    on_commit = all(r.get("commit") == commit for r in rows)      # every row measured on this commit
    measured = commit if on_commit or not previous else \
        ((previous.get("provenance") or {}).get("commit") or previous.get("commit"))
    doc = stamp(doc, commit=measured)   # the suites ran on the host (PoCL CPU)
    out.write_text(json.dumps(doc, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    return doc

if __name__ == "__main__":
    sys.exit(main())

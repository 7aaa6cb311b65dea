"""The tree the mutants run on: a snapshot of the committed HEAD, the commit its results name, and the environment
of a test-suite run inside a copy of it (shared by the runner and the impact recorder)."""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

from benchmarks.publish import freshness
from benchmarks.publish.registry import RESULTS

ROOT = Path(__file__).resolve().parents[2]
# The code whose change makes mutants.json stale (its results-registry entry).
MUTANTS_PRODUCERS = next(r.producers for r in RESULTS if r.name == "mutants.json")
COPY_IGNORE = shutil.ignore_patterns(".venv", ".git", "__pycache__", "*.egg-info", "build", "dist",
                                     ".pytest_cache", ".hypothesis", "out")


def head_commit(root: Path = ROOT) -> str | None:
    return freshness.git(root, "rev-parse", "HEAD")


def code_commit(root: Path = ROOT) -> str | None:
    """The commit the results name: the last one up to HEAD that changed the catalogue's code
    (MUTANTS_PRODUCERS). HEAD's tree holds that code as it was there, so a run
    resumed after commits of results only names the same commit (and goes on where it stopped)."""
    head = freshness.git(root, "rev-parse", "HEAD")
    if not head:
        return None
    return freshness.git(root, "log", "-1", "--format=%H", "HEAD", "--", *MUTANTS_PRODUCERS) or head


def snapshot(dest: Path, root: Path = ROOT) -> None:
    """The tree under test: the committed HEAD (git archive), so that edits made while the catalogue runs
    cannot leak into a mutant; a plain copy of the working tree where there is no git checkout."""
    if head_commit(root):
        dest.mkdir(parents=True)
        archive = subprocess.run(["git", "-C", str(root), "archive", "--format=tar", "HEAD"], capture_output=True,
                                 check=True)
        subprocess.run(["tar", "-x", "-C", str(dest)], input=archive.stdout, check=True)
    else:
        shutil.copytree(root, dest, ignore=COPY_IGNORE)


def suite_env(copy: Path) -> dict[str, str]:
    """The environment of a suite run in `copy`: the copy's Python code and kernels are the ones used (and its
    benchmarks package, for the pytest plugin benchmarks.mutation.plugin)."""
    env = dict(os.environ, PYTHONPATH=str(copy),
               PYTHONDONTWRITEBYTECODE="1",
               CLSHADE_TEST_ONE_RUNTIME="1",          # tests/conftest.py: device_runtime tests on the default device
               CLSHADE_TEST_NO_LOCAL_CONSTANTS="1")   # and Hypothesis's examples independent of other modules
    env.pop("CLSHADE_EXPECT_INSTALLED", None)
    return env

"""Published results are measured on the code that produces them now (benchmarks/freshness.py):
a result older than the last change to its kernels or measuring module fails here. The
checker itself is tested on a synthetic repository: fresh, then stale after a change to
its code, and still fresh after a change elsewhere."""
from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

from clshade.provenance import provenance, stamp

@pytest.fixture(scope="module")
def freshness(bench_script):
    return bench_script("freshness")


def _git(root: Path, *args: str) -> str:
    return subprocess.run(["git", "-C", str(root), *args], check=True, capture_output=True, text=True).stdout.strip()


def _commit(root: Path, message: str) -> str:
    _git(root, "add", "-A")
    _git(root, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-q", "-m", message)
    return _git(root, "rev-parse", "HEAD")


def test_checker_on_a_synthetic_repository(freshness, tmp_path: Path) -> None:
    root = tmp_path
    _git(root, "init", "-q")
    (root / "kernels").mkdir()
    (root / "kernels" / "brdf.h").write_text("#define MIN_ALPHA 1e-4f\n")
    (root / "measure.py").write_text("x = 1\n")
    (root / "other.txt").write_text("a\n")
    measured = _commit(root, "code")
    results = Path("results")
    (root / results).mkdir()
    (root / results / "r.json").write_text(json.dumps({"provenance": {"commit": measured}, "value": 1}))
    (root / results / "old.json").write_text(json.dumps({"value": 2}))        # no provenance: its own commit
    _commit(root, "results")
    producers = {"r.json": ("kernels", "measure.py"), "old.json": ("kernels",)}
    assert freshness.staleness(root, producers, results) == {"r.json": [], "old.json": []}
    (root / "other.txt").write_text("b\n")
    _commit(root, "unrelated")
    assert freshness.staleness(root, producers, results) == {"r.json": [], "old.json": []}
    (root / "kernels" / "brdf.h").write_text("#define MIN_ALPHA 1e-3f\n")
    change = _commit(root, "kernel change")
    assert freshness.staleness(root, producers, results) == {"r.json": [change], "old.json": [change]}
    (root / "measure.py").write_text("x = 2\n")
    later = _commit(root, "measuring module change")
    (root / results / "old.json").write_text(json.dumps({"provenance": {"commit": later}, "value": 3}))
    _commit(root, "old.json measured again")
    assert freshness.staleness(root, producers, results) == {"r.json": [later, change], "old.json": []}
    # a commit the history does not hold (a shallow clone): unknown, not fresh
    (root / results / "r.json").write_text(json.dumps({"provenance": {"commit": "0" * 40}}))
    assert freshness.staleness(root, producers, results)["r.json"] is None


def test_every_results_json_has_a_producer(freshness, checkout) -> None:
    names = {p.name for p in (checkout / freshness.RESULTS).glob("*.json")}
    assert names <= set(freshness.PRODUCERS), f"results without a producer in benchmarks/freshness.py: " \
                                              f"{sorted(names - set(freshness.PRODUCERS))}"


def test_the_known_stale_list_is_no_result_s_code(freshness) -> None:
    """Taking a result off KNOWN_STALE must not change that result's code (else it is stale again at once)."""
    here = "benchmarks/freshness.py"
    for name, code in freshness.PRODUCERS.items():
        covering = [c for c in code if here == c or here.startswith(c.rstrip("/") + "/")]
        assert not covering, f"{name}'s producers {covering} include {here}, which holds KNOWN_STALE"
    assert set(freshness.KNOWN_STALE) <= set(freshness.PRODUCERS)


def test_provenance_names_commit_device_and_time() -> None:
    p = provenance("some device")
    assert p["device"] == "some device" and p["measured_at"].endswith("Z") and "dirty" in p
    assert stamp({"a": 1, "provenance": None}, "d")["provenance"]["device"] == "d"


def test_a_checkout_is_dirty_for_code_not_for_results_or_rendered_documents(tmp_path, scratch_repo) -> None:
    from clshade.provenance import checkout_commit
    git = scratch_repo
    files = ("clshade/a.py", "kernels/k.cl", "README.md", "docs/d.md", "benchmarks/results/r.json")
    for path in files:
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text("0\n")
    git("add", *files)
    git("commit", "-qm", "all")
    assert checkout_commit(tmp_path)[1] is False
    for path in ("README.md", "docs/d.md", "benchmarks/results/r.json"):      # what publish and benchmarks write
        (tmp_path / path).write_text("1\n")
    commit, dirty = checkout_commit(tmp_path)
    assert dirty is False and len(commit) == 40
    for path in ("clshade/a.py", "kernels/k.cl"):
        (tmp_path / path).write_text("1\n")
        assert checkout_commit(tmp_path)[1] is True, path
        git("checkout", "--", path)


def _results(checkout: Path) -> list:
    spec = importlib.util.spec_from_file_location("freshness_list", checkout / "benchmarks" / "freshness.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = []
    for name in module.PRODUCERS:
        marks = [pytest.mark.xfail(reason=f"stale, not yet regenerated: {module.KNOWN_STALE[name]}", strict=True)] \
            if name in module.KNOWN_STALE else []
        out.append(pytest.param(name, marks=marks))
    return out


@pytest.mark.parametrize("name", _results(Path(__file__).resolve().parents[1]))
def test_published_result_is_not_older_than_its_code(freshness, checkout, name: str) -> None:
    if not (checkout / freshness.RESULTS / name).exists():
        pytest.skip(f"no {name}")
    if freshness.git(checkout, "rev-parse", "HEAD") is None:
        pytest.skip("not a git checkout")
    since = freshness.staleness(checkout, {name: freshness.PRODUCERS[name]})[name]
    if since is None:
        pytest.skip(f"{name}: its commit is not in this checkout's history (shallow clone?)")
    assert not since, (f"{name} is older than its code: {len(since)} later commit(s) changed "
                       f"{', '.join(freshness.PRODUCERS[name])} (newest {since[0][:10]}); measure it again")

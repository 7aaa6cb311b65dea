"""pytest plugin of the mutation runner (benchmarks/mutation/run.py loads it as `-p benchmarks.mutation.plugin`):
records every failing test of a mutant's suite run (and every collection error) with its markers, as JSON at
$CLSHADE_MUTANT_REPORT."""
from __future__ import annotations

import json
import os

_FAILURES: list[dict] = []
# The tests' own kill classes (pyproject.toml registers the markers): a test so marked does
# not check behaviour, so a mutant killed only by such tests is not a behavioural kill.
CLASS_MARKERS = ("snapshot", "text", "extra")
BUILD_FAILED = "kernel build failed"      # clshade.device.runtime's message for a program that does not compile


def _text(report) -> str:
    return str(report.longrepr) if report.longrepr is not None else ""


def _crash(report) -> str:
    """The exception that ended the test ("AssertionError: …", "ClshadeError: …")."""
    crash = getattr(report.longrepr, "reprcrash", None)
    return crash.message if crash is not None else _text(report)


def pytest_runtest_logreport(report) -> None:
    if report.failed:
        text = _text(report)
        # A build that failed where the test wanted a program; not a test that checks a build error's
        # message and found it wrong (its assertion quotes the message).
        build_failed = BUILD_FAILED in text and not _crash(report).startswith("AssertionError")
        _FAILURES.append(dict(test=report.nodeid, when=report.when,
                              markers=[m for m in CLASS_MARKERS if m in report.keywords],
                              build_failed=build_failed, message=text.strip().splitlines()[-1][:300]
                              if text.strip() else ""))


def pytest_collectreport(report) -> None:
    if report.failed:
        _FAILURES.append(dict(test=report.nodeid, when="collect", markers=[], build_failed=False,
                              message=_text(report).strip().splitlines()[-1][:300] if _text(report).strip() else ""))


def pytest_sessionfinish(session) -> None:
    path = os.environ.get("CLSHADE_MUTANT_REPORT")
    if path:
        with open(path, "w", encoding="utf-8") as f:
            json.dump(_FAILURES, f)

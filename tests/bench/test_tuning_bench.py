"""The tuning benchmark's judgement of "within 5 % of the fastest choice" (clshade.bench.tuning): the fastest
of several noisy medians is biased low, so the target is judged on a held-out ratio."""
from __future__ import annotations

import math
import random
import statistics

import pytest

from clshade.bench.tuning import held_out_ratio


def _rounds(rng: random.Random, true_ms: dict[str, float], rounds: int, sigma: float) -> dict[str, list[float]]:
    """Per choice, `rounds` lognormal times about its true ms (a shared machine's per-round noise)."""
    return {c: [ms * math.exp(rng.gauss(0.0, sigma)) for _ in range(rounds)] for c, ms in true_ms.items()}


def test_equal_choices_are_not_judged_slower_than_the_fastest():
    """Seven equally fast choices, 30 rounds of 10 % noise: the plain ratio to the fastest median is biased
    above 1 (the winner's curse), the held-out ratio is not."""
    rng = random.Random(7)
    plain, held = [], []
    for _ in range(300):
        times = _rounds(rng, {f"c{i}": 3.0 for i in range(7)}, 30, 0.10)
        plain.append(math.log(statistics.median(times["c0"]) / min(statistics.median(t) for t in times.values())))
        held.append(math.log(held_out_ratio(times, "c0")))
    assert statistics.fmean(plain) > 0.02
    assert abs(statistics.fmean(held)) < 0.01


def test_a_truly_faster_choice_is_found_by_the_held_out_ratio():
    """One choice 10 % faster than the tuned one: the held-out ratio says ~1.10, and the fastest itself ~1."""
    rng = random.Random(11)
    true = {"tuned": 3.3, "fast": 3.0, **{f"c{i}": 3.3 for i in range(5)}}
    ratios = [held_out_ratio(_rounds(rng, true, 30, 0.05), "tuned") for _ in range(100)]
    assert abs(statistics.fmean(ratios) - 1.1) < 0.01
    assert abs(statistics.fmean(held_out_ratio(_rounds(rng, true, 30, 0.05), "fast") for _ in range(100)) - 1.0) < 0.01


def test_the_rounds_must_be_split():
    with pytest.raises(ValueError, match="two rounds"):
        held_out_ratio({"a": [1.0], "b": [1.0, 2.0]}, "a")

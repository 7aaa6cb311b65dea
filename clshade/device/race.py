"""The race between build choices (or devices): interleaved timed rounds, a paired comparison of each
candidate with the fastest, and a verdict that picks the preferred of those inside the noise band — no
device here, any timer (clshade/device/tune.py times the kernels; tests/device/test_tune.py fakes them).
The method is tune.py's docstring's."""
from __future__ import annotations

import math
import random
import statistics
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Hashable

#: No new candidate is built once this share of a race's budget is spent: the rest times rounds. A cold
#: build of one calibration kernel takes ~0.5 s on two busy cores, so of a family's third of the budget
#: about half the candidates of a PoCL device get built on a first run there (the most telling first).
BUILD_SHARE = 0.6
#: Rounds before any judgement: the median and spread of fewer move with a single preempted run.
MIN_ROUNDS = 5
#: A gap is real beyond this many standard errors of the paired log ratio: with about ten comparisons
#: a tuning, one-sided 3σ (0.13 % each) keeps a false pick to about one tuning in a hundred.
NOISE_Z = 3.0
#: Nothing under 2 % counts as faster: the target is the default within 5 % of the fastest choice, and
#: the rest of that is room for the calibration frame differing from the frames users shade.
NOISE_FLOOR = 0.02
MAD_SIGMA = 1.4826        # the median absolute deviation × this = σ for normally spread values
MEDIAN_SE = 1.2533        # √(π/2): the standard error of a median of n values is this × σ / √n
ROUND_SEED = 41           # the rounds' random orders (seeded: a rerun orders them alike)

Candidate = Hashable
#: Per candidate, per round: {model: ms}, or None for a round it did not run.
Rounds = dict[Candidate, list["dict[str, float] | None"]]


@dataclass(frozen=True)
class Gap:
    """Candidate b against a over the rounds both ran: the median of the per-round log time ratio
    (mean over the models), its standard error from the rounds' spread, and the rounds."""
    log_ratio: float
    se: float
    rounds: int

    @property
    def band(self) -> float:
        """The noise band in log units: NOISE_Z standard errors, at least NOISE_FLOOR."""
        return max(math.log1p(NOISE_FLOOR), NOISE_Z * self.se)

    @property
    def clearly_slower(self) -> bool:
        return self.log_ratio > self.band

    @property
    def clearly_faster(self) -> bool:
        return self.log_ratio < -self.band

    @property
    def equivalent(self) -> bool:
        """The whole band around the gap lies inside NOISE_FLOOR: more rounds cannot make it count."""
        return abs(self.log_ratio) + NOISE_Z * self.se <= math.log1p(NOISE_FLOOR)

    @property
    def ratio(self) -> float:
        return math.exp(self.log_ratio)


def gap(rounds: Rounds, a: Candidate, b: Candidate) -> Gap:
    """b against a (positive: b slower) from the rounds both ran."""
    diffs = [statistics.fmean(math.log(rb[m]) - math.log(ra[m]) for m in ra)
             for ra, rb in zip(rounds[a], rounds[b]) if ra and rb]
    if not diffs:
        return Gap(0.0, math.inf, 0)
    mid = statistics.median(diffs)
    mad = statistics.median(abs(d - mid) for d in diffs)
    return Gap(mid, MAD_SIGMA * mad * MEDIAN_SE / math.sqrt(len(diffs)), len(diffs))


@dataclass(frozen=True)
class Verdict:
    """What the rounds so far say: the `pick` (the preferred of those `tied` with the `best`), whether
    it is `settled`, the candidates clearly `slower` than the best, each one's gap to the best."""
    pick: Candidate
    settled: bool
    best: Candidate
    tied: tuple
    slower: tuple
    gaps: dict
    reason: str


def judge(rounds: Rounds, order: list) -> Verdict:
    """The verdict on the candidates of `order` (preference order: the default first) with at least
    MIN_ROUNDS rounds. The best is the fastest against the first of them (the reference, timed in every
    round); the pick is the reference where it is tied with the best, else the preferred of the tied that
    is clearly faster than the reference, else the best. Too few rounds: the first candidate, unsettled."""
    live = [c for c in order if sum(1 for r in rounds.get(c, ()) if r) >= MIN_ROUNDS]
    if not live:
        first = next((c for c in order if c in rounds), order[0])
        return Verdict(first, False, first, (first,), (), {}, f"fewer than {MIN_ROUNDS} rounds measured")
    ref = live[0]
    vs_ref = {c: gap(rounds, ref, c) for c in live}
    best = min(live, key=lambda c: (vs_ref[c].log_ratio if c != ref else 0.0, live.index(c)))
    gaps = {c: gap(rounds, best, c) for c in live if c != best}
    slower = tuple(c for c in live if c != best and gaps[c].clearly_slower)
    tied = tuple(c for c in live if c not in slower)
    if ref in tied:
        pick = ref
    else:
        pick = next((c for c in tied if vs_ref[c].clearly_faster), best)
    settled = all(gaps[c].equivalent for c in tied if c != best)
    if len(tied) == 1:
        reason = "clear: every other choice is slower by more than the noise band"
    elif settled:
        reason = (f"tied: {len(tied)} choices within {NOISE_FLOOR:.0%} of the fastest (inside the noise floor); "
                  "the preferred kept")
    else:
        reason = f"{len(tied)} choices inside the noise band of the fastest; the preferred kept"
    return Verdict(pick, settled, best, tied, slower, gaps, reason)


@dataclass
class Race:
    """A finished race: its candidates in preference order, the rounds, the last verdict, the
    candidates that failed to build (one-line reasons) and those the budget left unbuilt."""
    order: list
    rounds: Rounds
    verdict: Verdict
    failed: dict = field(default_factory=dict)
    unbuilt: list = field(default_factory=list)
    seconds: float = 0.0
    budget_spent: bool = False


def race(order: list, models: list[str], prepare: Callable[[Candidate], None],
         timer: Callable[[Candidate, str], float], budget_s: float, clock: Callable[[], float] = time.monotonic,
         seed: int = ROUND_SEED, progress: Callable[[str], None] | None = None,
         before_item: Callable[[], object] | None = None) -> Race:
    """Build each candidate of `order` (`prepare`; one that raises is left out with its reason) while
    BUILD_SHARE of the budget allows, then time rounds (`timer(candidate, model)` → ms; `before_item` runs before
    each) until `judge` settles or `budget_s` (from the call) is spent. The verdict's pick is the result."""
    start = clock()
    failed: dict = {}
    ready: list = []
    unbuilt: list = []
    builds: list[float] = []
    for c in order:
        spent = clock() - start
        if ready and spent + (statistics.fmean(builds) if builds else 0.0) > BUILD_SHARE * budget_s:
            unbuilt.append(c)
            continue
        if progress:
            progress(f"building {len(ready) + len(failed) + 1}/{len(order)}")
        t0 = clock()
        try:
            prepare(c)
        except Exception as exc:  # noqa: BLE001 - a choice the device cannot build is a result, not a stop
            failed[c] = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            continue
        builds.append(clock() - t0)
        ready.append(c)
    rounds: Rounds = {c: [] for c in ready}
    if len(ready) < 2:
        pick = ready[0] if ready else order[0]
        verdict = Verdict(pick, True, pick, (pick,), (), {},
                          "the only choice that builds here" if ready else "no choice builds here")
        return Race(order, rounds, verdict, failed, unbuilt, clock() - start, False)
    rng = random.Random(seed)
    live = list(ready)
    verdict = judge(rounds, ready)
    spent_out = False
    while True:
        if clock() - start > budget_s:
            spent_out = True
            break
        items = [(c, m) for c in live for m in models]
        rng.shuffle(items)
        row: dict = {c: {} for c in live}
        for c, m in items:
            if before_item:
                before_item()
            row[c][m] = timer(c, m)
        for c in ready:
            rounds[c].append(row.get(c))
        verdict = judge(rounds, ready)
        if progress:
            behind = verdict.gaps.get(verdict.pick)
            progress(f"round {len(rounds[ready[0]])}: {len(verdict.tied)} tied"
                     + (f", the fastest {1 - 1 / behind.ratio:.1%} ahead of the pick" if behind else ""))
        if verdict.settled:
            break
        # The reference stays in every round (every gap is paired with it); a new fastest can bring one back.
        live = [c for c in ready if c not in verdict.slower or c == ready[0]]
    if spent_out and not verdict.settled:
        verdict = replace(verdict, reason=f"budget ({budget_s:.0f} s) spent: " + verdict.reason)
    return Race(order, rounds, verdict, failed, unbuilt, clock() - start, spent_out)

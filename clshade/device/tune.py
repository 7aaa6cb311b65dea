"""Measure a device's build choices, and the order of the devices, once (clshade/device/tuned.py keeps them).

What is tuned (buildchoice.BuildChoice): the math builtins (the OpenCL library's or kernels/simd.h's inline
ones), the image rows' stores (streaming or plain), the G-buffer prefetch (on or off), the lanes per
work-item (4, 8 or 16, up to the device's native width; 1 lane is the scalar code PoCL does not
vectorise, simd.h) and the work-group size (LOCAL_SIZES beside buildchoice.LOCAL_SIZE). The prefetch has
one distance (gbuffer.h, PREFETCH_PIXELS), so it is on or off. A choice is a candidate only where it
changes the code on this device, as probed there: Intel's CPU compiler defines no __AVX__, so on its
runtime the math, stores and prefetch choices are one build each and only lanes and work-group size race.

The choice is made per model family (tuned.families(): the built-in lobes' `family` field, diffuse,
empirical and microfacet; a model's family is Model.family), since the fastest build differs between
them: each family races on its own CALIBRATION_MODELS, one after the other, within one device budget
(TUNE_BUDGET_S, builds included): each family gets an equal share of what the families before it left
(`family_budget`). The device's general choice, for a model of a family not measured (a user lobe of a
family of its own) and for kernels of no model, is the candidate fastest on average over the families
against today's rule where that is clear of the noise band (`general_choice`).

The candidates are today's rule (FIXED, the default) and each single change from it (`candidates`);
where two or more changes each beat the default clearly, their combination then races the best of them.
Each candidate shades a calibration frame (CALIBRATION_SCENE at CALIBRATION_SIZE) with its family's
CALIBRATION_MODELS in interleaved rounds: every candidate × model once a round, in a new random order,
each timed as the second of two back-to-back dispatches (the first loads the caches with the item's own
data, whatever ran before it). From MIN_ROUNDS rounds on, `judge` (clshade/device/race.py) compares every
candidate with the fastest by their paired ratio over the rounds; the noise band is NOISE_Z standard errors
of that ratio (from the rounds' spread), never under NOISE_FLOOR. A candidate outside the band is clearly slower (and
leaves the race); those inside are tied, and a tie goes to the preferred one: the default, then the one
with the fewest changes. The race ends when the pick is settled (every tie is a difference confidently
under NOISE_FLOOR) or when TUNE_BUDGET_S (builds included) is spent: then the preferred of the tied
stands, the default wherever it is still tied. On a noisy machine, or where nothing is clearly faster,
the default stays.

The default device is picked the same way (`rank_devices`): each healthy CPU device, built with its own
tuned choice, races on the same frame; a tie goes to the first in runtime.RUNTIME_PREFERENCE order.

    python -m clshade.device.tune device P:D [--key HASH]   # one device (runtime.py runs this on a cache miss)
    python -m clshade.device.tune rank                      # the order of the CPU devices (each one tuned first)
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from dataclasses import dataclass, replace
from typing import Callable, Iterable, TextIO

from clshade.device import tuned
from clshade.device.buildchoice import FIXED, SIMD_WIDTHS, BuildChoice
from clshade.device.race import MIN_ROUNDS, NOISE_FLOOR, NOISE_Z, Candidate, Gap, Race, gap, race
from clshade.device.runtime import RUNTIME_PREFERENCE, Runtime, device_key, healthy_devices, list_devices, preference
from clshade.device.shade import Shader, scene_features
from clshade.device.timing import settle, timed_dispatch
from clshade.device.variants import Features
from clshade.errors import ClshadeError
from clshade.models.registry import Registry
from clshade.render.gbuffer import GBuffer, build_gbuffer
from clshade.render.meshes import build_geometry
from clshade.render.raster import rasterize
from clshade.render.scene import Camera, Scene, load_scene
from clshade.resources import scenes_dir

#: Seconds one device's tuning may take, its builds included: the first run of clshade on a new
#: device, driver or kernel waits this long at most per device (once; then the cache answers).
TUNE_BUDGET_S = 10.0
#: The same for the race of the devices that picks the default one.
RANK_BUDGET_S = 10.0
#: The frame: the study's 25 balls (roughness 0 to 1, sky around them). At 1280×720 its G-buffer and
#: image (~48 B a pixel, ~44 MB) overflow the last-level cache of the CPUs we know (32 MiB on the EPYC),
#: as a full frame's traffic does, so the stores and prefetch choices meet memory; a round of a dozen
#: candidates × two models still takes well under 0.2 s.
CALIBRATION_SCENE = "sphere_grid.toml"
CALIBRATION_SIZE = (1280, 720)
#: Per family (tuned.families()), the models its race shades: one per kind of work its lobes spend time in
#: (memory, square roots and divisions, pow, exp), so that a choice faster for one of them is not missed;
#: docs/bench-notes.md says why (a race on GGX alone missed inline math's gain for Cook–Torrance).
CALIBRATION_MODELS = {"diffuse": ("lambert", "oren_nayar", "burley"), "empirical": ("lambert+blinn_phong",),
                      "microfacet": ("lambert+ggx_correlated", "lambert+cook_torrance")}
#: Work-group sizes raced beside buildchoice.LOCAL_SIZE (64): a quarter and four times it. PoCL runs a
#: work-group as one loop on one thread, so the size trades the loop's overhead against the balance
#: of the work over the cores.
LOCAL_SIZES = (16, 256)
class Progress:
    """One line on stderr, rewritten in place, only when stderr is a terminal."""

    def __init__(self, title: str, stream: TextIO | None = None) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.on = bool(getattr(self.stream, "isatty", lambda: False)())
        self.title = title
        self.width = 0

    def __call__(self, text: str) -> None:
        if self.on:
            line = f"clshade: {self.title}: {text}"
            self.stream.write("\r" + line.ljust(self.width))
            self.stream.flush()
            self.width = len(line)

    def done(self, text: str) -> None:
        if self.on:
            self(text)
            self.stream.write("\n")
            self.stream.flush()


@dataclass
class CalibrationFrame:
    """The frame every candidate shades: CALIBRATION_SCENE at a size (no shadows, one sample a pixel)."""
    scene: Scene
    camera: Camera
    gbuffer: GBuffer
    features: Features


def calibration_frame(size: tuple[int, int] = CALIBRATION_SIZE) -> CalibrationFrame:
    """Rasterise CALIBRATION_SCENE at `size` into its G-buffer."""
    scene = load_scene(scenes_dir() / CALIBRATION_SCENE)
    camera = scene.camera.with_size(*size)
    geometry = build_geometry(scene)
    fragments = rasterize(geometry.vertices, geometry.faces, camera.view_matrix(), camera.projection_matrix(),
                          camera.width, camera.height, cull_backfaces=geometry.cull)
    gbuffer = build_gbuffer(scene, geometry, fragments, camera)
    return CalibrationFrame(scene, camera, gbuffer, scene_features(scene, geometry=geometry))


def candidates(rt: Runtime) -> list[BuildChoice]:
    """FIXED, then each single change from it that makes other code on rt's device, most telling
    first (the budget may not build them all): math, stores, prefetch, lanes (widest first), work-group size."""
    base = rt.with_choice(FIXED)
    out = [FIXED]
    library, inline = rt.with_choice(BuildChoice(math="library")), rt.with_choice(BuildChoice(math="inline"))
    if library.inline_math != inline.inline_math:
        out.append(BuildChoice(math="library" if base.inline_math else "inline"))
    if base.streaming_stores:
        out.append(BuildChoice(stores="plain"))
    if base.prefetches:
        out.append(BuildChoice(prefetch=False))
    if "cpu" in rt.info.kind:
        widths = sorted((int(w) for w in SIMD_WIDTHS if 4 <= int(w) <= base.native_simd), reverse=True)
        out += [BuildChoice(lanes=w) for w in widths if w != base.simd]
    limit = int(rt.device.max_work_group_size)
    out += [BuildChoice(local=size) for size in LOCAL_SIZES if size <= limit and size != base.local_size]
    return out


def build_facts(rt: Runtime, choice: BuildChoice) -> dict:
    """What `choice` compiles on rt's device: lanes, work-group size and simd.h's x86 paths. The paths
    come from the probes `candidates` ran (today's rule, and each math choice): plain stores and no
    prefetch only undefine their own macro in simd.h, so they need no probe of their own."""
    crt, base = rt.with_choice(choice), rt.with_choice(BuildChoice(math=choice.math))
    return dict(simd=crt.simd, local_size=crt.local_size, inline_math=base.inline_math,
                streaming_stores=choice.stores == "streaming" and crt.simd >= 8 and base.streaming_stores,
                prefetch=choice.prefetch and base.prefetches)


def combined(winners: list[BuildChoice]) -> BuildChoice:
    """The changes of `winners` (fastest first) together; where two change one field, the faster's."""
    changes: dict[str, object] = {}
    for w in winners:
        for name in w.changes():
            changes.setdefault(name, getattr(w, name))
    return replace(FIXED, **changes)


class DeviceBench:
    """The calibration frame's dispatches on one device, a Shader per build choice (each its own
    programs and arguments) on one context."""

    def __init__(self, rt: Runtime, frame: CalibrationFrame, models: list) -> None:
        self.rt, self.frame, self.models = rt, frame, models
        self.dispatches: dict[tuple[Candidate, str], tuple[Shader, object]] = {}
        self.facts: dict[Candidate, dict] = {}

    def prepare(self, choice: BuildChoice) -> None:
        """Build choice's kernels and run each once (PoCL compiles a kernel per work-group size at
        its first launch), and record what the device then compiles; once per choice."""
        if choice in self.facts:
            return
        crt = self.rt.with_choice(choice)
        shader = Shader(crt, self.frame.gbuffer, self.frame.scene, self.frame.camera)
        for m in self.models:
            d = shader.prepare(m, self.frame.features)
            shader.enqueue(d).wait()
            self.dispatches[(choice, m.id)] = (shader, d)
        self.facts[choice] = build_facts(self.rt, choice)

    def time(self, choice: Candidate, model: str) -> float:
        """Device ms of the second of two back-to-back dispatches."""
        shader, d = self.dispatches[(choice, model)]
        shader.enqueue(d).wait()
        return timed_dispatch(shader, d)[0]


def _rows(result: Race, label: Callable[[Candidate], dict], models: list[str], reference: Candidate) -> list[dict]:
    """One table row per candidate: its median ms per model, rounds, ratio to `reference` and status."""
    v = result.verdict
    out = []
    for c in result.order:
        row = dict(label(c))
        runs = [r for r in result.rounds.get(c, ()) if r]
        if c in result.failed:
            row.update(status="failed", reason=result.failed[c])
        elif c in result.unbuilt:
            row.update(status="not measured (budget)")
        else:
            row.update(median_ms={m: statistics.median(r[m] for r in runs) for m in models} if runs else {},
                       rounds=len(runs),
                       status="picked" if c == v.pick else "tied" if c in v.tied else
                       "slower" if c in v.slower else "not judged")
            if c != reference and reference in result.rounds:
                g = gap(result.rounds, reference, c)
                if g.rounds:
                    row.update(vs_default=g.ratio, band=math.expm1(g.band))
        out.append(row)
    return out


@dataclass
class Tuning:
    """The outcome of `tune_choices`: the pick, why, the races run (the singles, then maybe the
    combination) and each candidate's gap to today's rule."""
    pick: BuildChoice
    decision: str
    stages: list
    vs_rule: dict


def tune_choices(order: list[BuildChoice], models: list[str], prepare: Callable[[BuildChoice], None],
                 timer: Callable[[BuildChoice, str], float], budget_s: float,
                 clock: Callable[[], float] = time.monotonic, progress: Callable[[str], None] | None = None) -> Tuning:
    """Race `order` (FIXED first, then single changes); where two or more changes each beat FIXED
    clearly and the race settled, race their combination against the pick with what is left of the budget
    (the pick keeps a tie)."""
    start = clock()
    first = race(order, models, prepare, timer, budget_s, clock, progress=progress)
    pick, decision, stages = first.verdict.pick, first.verdict.reason, [first]
    # Each candidate of the first race against today's rule (log ratio of times, < 0 faster).
    vs_rule = {c: gap(first.rounds, FIXED, c) for c in first.rounds if FIXED in first.rounds}
    winners = sorted((c for c, g in vs_rule.items() if g.clearly_faster), key=lambda c: vs_rule[c].log_ratio)
    combo = combined(winners)
    if len(winners) >= 2 and first.verdict.settled and combo not in order:
        second = race([pick, combo], models, prepare, timer, budget_s - (clock() - start), clock, progress=progress)
        stages.append(second)
        decision = (f"{decision}; then the {len(winners)} clear winners combined against the fastest: "
                    f"{second.verdict.reason}")
        if second.verdict.pick == combo:
            vs_rule[combo] = Gap(vs_rule[pick].log_ratio + gap(second.rounds, pick, combo).log_ratio, math.nan, 0)
            pick = combo
    if pick == FIXED:
        decision = f"kept today's rule ({decision})"
    elif pick in vs_rule:
        decision = f"{pick.label()}: {1 - vs_rule[pick].ratio:.1%} faster than today's rule ({decision})"
    else:
        decision = f"{pick.label()}: today's rule does not build here ({decision})"
    return Tuning(pick, decision, stages, vs_rule)


def calibration_models(registry: Registry) -> dict[str, list]:
    """Each family of tuned.families() with its CALIBRATION_MODELS resolved; a family without calibration
    models, or a calibration model of another family, is a one-line error naming it."""
    out = {}
    for family in tuned.families():
        if family not in CALIBRATION_MODELS:
            raise ClshadeError(f"clshade/device/tune.py: CALIBRATION_MODELS has no models for the {family} family")
        models = [registry.resolve(m) for m in CALIBRATION_MODELS[family]]
        for m in models:
            if m.family != family:
                raise ClshadeError(f"clshade/device/tune.py: CALIBRATION_MODELS[{family!r}]: {m.id} is a "
                                   f"{m.family} model")
        out[family] = models
    return out


def family_budget(budget_s: float, spent_s: float, families_left: int) -> float:
    """A family's share of the device budget: an equal part of what is left (what a family before it
    did not use goes to the rest)."""
    return max(0.0, budget_s - spent_s) / max(1, families_left)


def general_choice(tunings: dict[str, Tuning]) -> tuple[BuildChoice, str]:
    """The device's choice for kernels of no measured family: of the candidates every family timed, the
    one with the lowest mean (over the families) log ratio to today's rule, where that mean is clearly
    faster (its noise band: NOISE_Z standard errors of the mean, from each family's, at least NOISE_FLOOR);
    else today's rule."""
    common = set.intersection(*(set(t.vs_rule) for t in tunings.values())) if tunings else set()
    means = {}
    for c in common - {FIXED}:
        gaps = [t.vs_rule[c] for t in tunings.values()]
        if all(math.isfinite(g.se) for g in gaps):
            means[c] = Gap(statistics.fmean(g.log_ratio for g in gaps),
                           math.sqrt(sum(g.se ** 2 for g in gaps)) / len(gaps), min(g.rounds for g in gaps))
    best = min(means, key=lambda c: (means[c].log_ratio, len(c.changes())), default=None)
    if best is None or not means[best].clearly_faster:
        return FIXED, "kept today's rule (no choice is clearly faster over the families)"
    return best, f"{best.label()}: {1 - means[best].ratio:.1%} faster than today's rule over the families"


def tune_families(order: list[BuildChoice], families: dict[str, list[str]],
                  prepare: Callable[[BuildChoice, str], None], timer: Callable[[BuildChoice, str], float],
                  budget_s: float, clock: Callable[[], float] = time.monotonic,
                  progress: Callable[[str], None] | None = None) -> dict[str, tuple[Tuning, float]]:
    """`tune_choices` once per family ({family: its model ids}), in order, each with `family_budget`
    of `budget_s` (from the call); {family: (its Tuning, the budget it had)}."""
    start = clock()
    out: dict[str, tuple[Tuning, float]] = {}
    for i, (family, names) in enumerate(families.items()):
        share = family_budget(budget_s, clock() - start, len(families) - i)
        say = (lambda text, f=family: progress(f"{f}: {text}")) if progress else None
        out[family] = (tune_choices(order, names, lambda c, f=family: prepare(c, f), timer, share, clock, say),
                       share)
    return out


def tune_device(rt: Runtime, budget_s: float = TUNE_BUDGET_S, frame: CalibrationFrame | None = None,
                progress: Callable[[str], None] | None = None, clock: Callable[[], float] = time.monotonic) -> dict:
    """Race rt's device's build choices on the calibration frame per model family (`candidates`,
    `tune_families`); the cache entry's body (tuned.write adds the key)."""
    start = clock()
    frame = frame or calibration_frame()
    per_family = calibration_models(Registry())
    benches = {f: DeviceBench(rt, frame, models) for f, models in per_family.items()}
    family_of = {m.id: f for f, models in per_family.items() for m in models}
    order = candidates(rt)
    results = tune_families(order, {f: [m.id for m in ms] for f, ms in per_family.items()},
                            lambda c, f: benches[f].prepare(c), lambda c, m: benches[family_of[m]].time(c, m),
                            budget_s - (clock() - start), clock, progress)
    families = {}
    for family, (result, share) in results.items():
        bench, names = benches[family], [m.id for m in per_family[family]]

        def label(c: BuildChoice, bench: DeviceBench = bench) -> dict:
            return dict(choice=c.as_dict(), label=c.label(), changes=list(c.changes()), **bench.facts.get(c, {}))

        stages = result.stages
        rows = _rows(stages[0], label, names, FIXED)
        if len(stages) > 1:
            row = _rows(stages[1], label, names, stages[1].order[0])[1]   # the combination, against the first pick
            row["stage"] = 2
            row["vs_first_pick"] = row.pop("vs_default", None)
            row.pop("band", None)
            rows.append(row)
        families[family] = dict(choice=result.pick.as_dict(), label=result.pick.label(), decision=result.decision,
                                models=names, budget_s=round(share, 2),
                                seconds=round(sum(st.seconds for st in stages), 2),
                                budget_spent=any(st.budget_spent for st in stages),
                                rounds=[len(next(iter(st.rounds.values()), [])) for st in stages], candidates=rows)
    general, why = general_choice({f: r for f, (r, _) in results.items()})
    return dict(status=tuned.MEASURED, choice=general.as_dict(), label=general.label(), decision=why,
                families=families, device=rt.info.description, runtime=rt.info.runtime,
                seconds=round(clock() - start, 2), budget_s=budget_s,
                budget_split="each family in turn an equal share of what is left (builds included)",
                budget_spent=any(f["budget_spent"] for f in families.values()),
                calibration=dict(scene=CALIBRATION_SCENE, width=frame.camera.width, height=frame.camera.height,
                                 models={f: list(CALIBRATION_MODELS[f]) for f in per_family}),
                noise=dict(z=NOISE_Z, floor=NOISE_FLOOR, min_rounds=MIN_ROUNDS))


def measure_device(spec: str, expect: str | None = None, budget_s: float = TUNE_BUDGET_S,
                   frame: CalibrationFrame | None = None, stream: TextIO | None = None) -> dict:
    """Tune device `spec` and store its entry (a failure is stored too, with its reason); `expect`: the
    key hash the caller computed, checked against the device found at `spec`."""
    rt = Runtime(spec, choice=FIXED)
    key = device_key(rt.info, rt.device)
    if expect is not None and expect != tuned.key_hash(key):
        raise ClshadeError(f"device {spec} is {rt.info.description}, not the device asked for (key {expect})")
    progress = Progress(f"measuring the build choices of {rt.info.runtime} ({rt.info.device}, once; "
                        f"≤ {budget_s:.0f} s)", stream)
    try:
        body = tune_device(rt, budget_s, frame, progress)
    except Exception as exc:  # noqa: BLE001 - kept as a failed entry, so that it is not retried on every run
        body = dict(status=tuned.FAILED, reason=(str(exc).strip().splitlines() or [type(exc).__name__])[0],
                    device=rt.info.description)
    progress.done(body.get("label", body.get("reason", "")))
    return tuned.write(tuned.DEVICE, key, body)


def rank_devices(budget_s: float = RANK_BUDGET_S, retune: bool = False, stream: TextIO | None = None,
                 frame: CalibrationFrame | None = None) -> dict:
    """Tune every healthy CPU device that has no entry (every one with `retune`), then race them, each with
    its tuned choice, and store the order (the first is the default device)."""
    devices = healthy_devices("cpu")
    if not devices:
        raise ClshadeError("no healthy CPU device to rank (`clshade devices`)")
    frame = frame or calibration_frame()
    keys = [device_key(info, device) for info, device in devices]
    per_family = calibration_models(Registry())
    family_of = {m.id: f for f, models in per_family.items() for m in models}
    choices: dict[str, dict[str, BuildChoice]] = {}      # per device, per family: its tuned choice
    for (info, _), key in zip(devices, keys):
        entry = None if retune else tuned.read(tuned.DEVICE, key)
        if entry is None:
            entry = measure_device(info.spec, tuned.key_hash(key), frame=frame, stream=stream)
        try:
            choices[info.spec] = ({f: BuildChoice.from_dict(entry["families"][f]["choice"]) for f in per_family}
                                  if entry["status"] == tuned.MEASURED else dict.fromkeys(per_family, FIXED))
        except (KeyError, TypeError, ValueError):
            choices[info.spec] = dict.fromkeys(per_family, FIXED)
    all_cpus = [device_key(info, device) for info, device in _cpu_devices()]
    names = list(family_of)
    runtimes = {info.spec: Runtime(info.spec, choice=FIXED) for info, _ in devices}
    benches = {(spec, f): DeviceBench(rt, frame, models) for spec, rt in runtimes.items()
               for f, models in per_family.items()}

    def prepare(spec: str) -> None:
        for f in per_family:
            benches[(spec, f)].prepare(choices[spec][f])

    progress = Progress(f"measuring which of {len(devices)} CPU runtimes is fastest (once; ≤ {budget_s:.0f} s)",
                        stream)
    result = race([info.spec for info, _ in devices], names, prepare,
                  lambda s, m: benches[(s, family_of[m])].time(choices[s][family_of[m]], m), budget_s,
                  progress=progress, before_item=settle)
    v = result.verdict
    score = {s: gap(result.rounds, v.best, s).log_ratio for s in result.rounds if result.rounds[s]}
    rest = sorted((s for s in score if s != v.pick), key=lambda s: (score[s], result.order.index(s)))
    by_spec = {info.spec: (info, key) for (info, _), key in zip(devices, keys)}
    order = [tuned.key_hash(by_spec[s][1]) for s in [v.pick, *rest]]
    info0 = by_spec[v.pick][0]
    progress.done(f"{info0.runtime} ({v.reason})")

    def label(s: str) -> dict:
        info, key = by_spec[s]
        return dict(spec=s, runtime=info.runtime, device=info.description, key_hash=tuned.key_hash(key),
                    families={f: c.as_dict() for f, c in choices[s].items()},
                    label=", ".join(f"{f} {c.label()}" for f, c in choices[s].items()))

    body = dict(status=tuned.MEASURED, order=order, default=info0.runtime,
                decision=f"{info0.runtime} ({v.reason}; ties go to RUNTIME_PREFERENCE order: "
                         f"{', '.join(RUNTIME_PREFERENCE)})",
                seconds=round(result.seconds, 2), budget_s=budget_s, budget_spent=result.budget_spent,
                calibration=dict(scene=CALIBRATION_SCENE, width=frame.camera.width, height=frame.camera.height,
                                 models=names),
                devices=_rows(result, label, names, result.order[0]))
    return tuned.write(tuned.RANKING, tuned.ranking_key(all_cpus), body)


def _cpu_devices() -> list:
    """Every CPU device listed, healthy or not, in preference order: the ranking's key (runtime.measured_ranking)."""
    return [item for item in sorted(list_devices(), key=lambda item: preference(item[0])) if "cpu" in item[0].kind]


def retune_all(stream: TextIO | None = None, budget_s: float = TUNE_BUDGET_S) -> tuple[list[dict], dict | None]:
    """`clshade devices --tune`: every healthy device's build choices measured again, then the CPU
    devices' order; (the device entries, the ranking entry or None with fewer than two CPU devices)."""
    tuned.forget()
    frame = calibration_frame()
    entries = [measure_device(info.spec, frame=frame, stream=stream, budget_s=budget_s)
               for info, _ in healthy_devices(kind=None)]
    ranking = rank_devices(retune=False, stream=stream, frame=frame) if len(_cpu_devices()) >= 2 else None
    tuned.forget()
    return entries, ranking


def main(argv: Iterable[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m clshade.device.tune", description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    one = sub.add_parser("device", help="measure one device's build choices")
    one.add_argument("spec", help="P:D from `clshade devices`")
    one.add_argument("--key", help="the key hash the caller expects of that device")
    sub.add_parser("rank", help="measure the order of the CPU devices (each one's choices first, where missing)")
    args = ap.parse_args(list(argv) if argv is not None else None)
    try:
        if args.what == "device":
            entry = measure_device(args.spec, args.key)
        else:
            entry = rank_devices()
    except ClshadeError as exc:
        print(f"clshade: measuring the build choices failed: {exc}", file=sys.stderr)
        return 2
    return 0 if entry.get("status") == tuned.MEASURED else 1


if __name__ == "__main__":
    raise SystemExit(main())

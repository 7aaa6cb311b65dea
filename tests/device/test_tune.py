"""The tuner (clshade/device/tune.py, its race in clshade/device/race.py) and its cache
(clshade/device/tuned.py): fed fake timings, the race picks the fastest choice, keeps the default inside the
noise band (more rounds first, the default when the budget ends); the cache is read where its key matches
and measured again where the driver, the CPU or the kernels changed, or the file is damaged; the runtime
and the default device follow the cached entries; the environment's switches still force a choice. One
small race on the real device."""
from __future__ import annotations

import json
import math
import random
from dataclasses import replace

import pytest

from clshade.device import runtime as rtmod
from clshade.device import buildchoice, race, tune, tuned
from clshade.device.buildchoice import FIXED, BuildChoice
from clshade.errors import ClshadeError

MODELS = ["lambert+blinn_phong", "lambert+ggx_correlated"]
A, B, C = FIXED, BuildChoice(math="inline"), BuildChoice(stores="plain")


class FakeDevice:
    """Fake timings on a fake clock: each candidate's true ms per model, spread by `noise` (relative
    σ), every timing and build advancing the clock by its own duration."""

    def __init__(self, ms: dict, noise: float, build_s: float = 0.5, seed: int = 3, fail: tuple = ()) -> None:
        self.ms, self.noise, self.build_s, self.fail = ms, noise, build_s, fail
        self.rng = random.Random(seed)
        self.now = 0.0
        self.built: list = []

    def clock(self) -> float:
        return self.now

    def prepare(self, c) -> None:
        self.now += self.build_s
        if c in self.fail:
            raise RuntimeError(f"kernel build failed for {c.label()}\nthe rest of the log")
        self.built.append(c)

    def timer(self, c, model: str) -> float:
        ms = self.ms[c] * (1.3 if model == MODELS[0] else 1.0) * max(0.05, 1 + self.noise * self.rng.gauss(0, 1))
        self.now += 2 * ms / 1e3
        return ms

    def run(self, order: list, budget_s: float = 10.0) -> race.Race:
        return race.race(order, MODELS, self.prepare, self.timer, budget_s, clock=self.clock)


# ---------------------------------------------------------------- the race, on fake timings


@pytest.mark.parametrize("order", [[A, B, C], [A, C, B]])
def test_the_tuner_picks_the_fastest_choice(order):
    fake = FakeDevice({A: 10.0, B: 7.0, C: 9.0}, noise=0.01)
    result = fake.run(order)
    assert result.verdict.pick == B and result.verdict.best == B and result.verdict.settled
    assert result.verdict.reason.startswith("clear") and not result.budget_spent
    assert len(result.rounds[A]) >= race.MIN_ROUNDS


def test_a_gain_inside_the_noise_floor_keeps_the_default():
    """1 % faster, measured tightly: settled as a tie (inside NOISE_FLOOR), and a tie keeps today's rule."""
    fake = FakeDevice({A: 10.0, B: 9.9}, noise=0.002)
    result = fake.run([A, B])
    assert result.verdict.best == B and result.verdict.pick == A
    assert result.verdict.settled and not result.budget_spent and result.verdict.reason.startswith("tied")


def test_the_tuner_refuses_to_pick_inside_the_noise_band_without_more_repeats():
    """8 % faster under 15 % noise: not settled after MIN_ROUNDS (the default stands), settled for the
    faster one after more rounds; with a budget that ends first, the default."""
    ms = {A: 10.0, B: 9.2}
    early = FakeDevice(ms, noise=0.15)
    rounds = {c: [] for c in (A, B)}
    for _ in range(race.MIN_ROUNDS):
        for c in (A, B):
            rounds[c].append({m: early.timer(c, m) for m in MODELS})
    verdict = race.judge(rounds, [A, B])
    assert not verdict.settled and verdict.pick == A and set(verdict.tied) == {A, B}
    patient = FakeDevice(ms, noise=0.15).run([A, B], budget_s=120.0)
    assert patient.verdict.pick == B and patient.verdict.settled
    assert len(patient.rounds[A]) > race.MIN_ROUNDS
    hurried = FakeDevice(ms, noise=0.15, build_s=0.05).run([A, B], budget_s=1.0)
    assert hurried.budget_spent and not hurried.verdict.settled
    assert hurried.verdict.pick == A and hurried.verdict.reason.startswith("budget")


def test_the_noise_band_comes_from_the_spread_of_the_rounds():
    """The same 8 % gap: clear on steady rounds, not clear on rounds that spread 40 times wider."""
    def rounds(spread: float) -> dict:
        rng = random.Random(5)
        out = {A: [], B: []}
        for _ in range(12):
            for c, ms in ((A, 10.0), (B, 9.2)):
                out[c].append({m: ms * (1 + spread * rng.gauss(0, 1)) for m in MODELS})
        return out
    steady, noisy = race.gap(rounds(0.005), A, B), race.gap(rounds(0.2), A, B)
    assert steady.clearly_faster and not noisy.clearly_faster
    assert noisy.band > steady.band >= math.log1p(race.NOISE_FLOOR)


def test_a_choice_that_fails_to_build_is_left_out_with_its_reason():
    fake = FakeDevice({A: 10.0, B: 7.0, C: 8.0}, noise=0.01, fail=(B,))
    result = fake.run([A, B, C])
    assert result.failed == {B: "kernel build failed for math inline"}
    assert result.verdict.pick == C and B not in result.rounds


def test_the_budget_bounds_the_builds():
    """Builds stop once BUILD_SHARE of the budget is spent; the rest times rounds."""
    fake = FakeDevice({A: 10.0, B: 7.0, C: 9.0}, noise=0.01, build_s=3.0)
    result = fake.run([A, B, C], budget_s=10.0)
    assert fake.built == [A, B] and result.unbuilt == [C]
    assert result.verdict.pick == B


def _gain(decision: str, label: str) -> float:
    """The % faster than today's rule a decision states for `label`."""
    head, _, rest = decision.partition(": ")
    assert head == label, decision
    return float(rest.split("%", 1)[0])


def test_two_clear_winners_race_combined_against_the_best_of_them():
    """Inline math and plain stores each beat today's rule; both together beat either: the combination wins.
    Where together they are no faster than the best single change, that single change stays (it keeps a tie)."""
    both = BuildChoice(math="inline", stores="plain")
    fake = FakeDevice({A: 10.0, B: 8.0, C: 9.0, both: 7.0}, noise=0.005, build_s=0.05)
    result = tune.tune_choices([A, B, C], MODELS, fake.prepare, fake.timer, 10.0, clock=fake.clock)
    assert result.pick == both and len(result.stages) == 2 and fake.built == [A, B, C, B, both]
    assert _gain(result.decision, "math inline, plain stores") == pytest.approx(30, abs=2) and "combined" in result.decision
    fake = FakeDevice({A: 10.0, B: 8.0, C: 9.0, both: 8.0}, noise=0.005, build_s=0.05)
    result = tune.tune_choices([A, B, C], MODELS, fake.prepare, fake.timer, 10.0, clock=fake.clock)
    assert result.pick == B and len(result.stages) == 2
    single = FakeDevice({A: 10.0, B: 8.0, C: 10.0}, noise=0.005, build_s=0.05)
    result = tune.tune_choices([A, B, C], MODELS, single.prepare, single.timer, 10.0, clock=single.clock)
    assert result.pick == B and len(result.stages) == 1 and _gain(result.decision, "math inline") == pytest.approx(20, abs=2)


# ---------------------------------------------------------------- the cache and its key


class Info:
    """A device's identity as runtime.DeviceInfo has it."""
    platform, platform_version, device, kind, spec = "PoCL", "OpenCL 3.0 PoCL 3.1", "cpu0", "all | cpu", "0:0"
    runtime = "PoCL 3.1"


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """An empty cache folder, tuning on, no memo; the child process replaced by `calls`: each call stores
    the entry `result` says (None: stores nothing and fails)."""
    monkeypatch.setenv("CLSHADE_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("CLSHADE_NO_BINARY_CACHE", raising=False)
    monkeypatch.setenv(tuned.ENV_TUNE, "auto")
    tuned.forget()
    state = {"calls": [], "result": BuildChoice(math="inline")}

    def run_tuner(args):
        state["calls"].append(args)
        if state["result"] is None:
            return "the tuner exited with status 1"
        tuned.write(state["kind"], state["key"], {"status": tuned.MEASURED, "choice": state["result"].as_dict(),
                                                  "families": {f: {"choice": state["result"].as_dict()}
                                                               for f in tuned.families()}})
        return None
    monkeypatch.setattr(tuned, "run_tuner", run_tuner)
    yield state
    tuned.forget()


def _lookup(state, key, kind=tuned.DEVICE):
    state["kind"], state["key"] = kind, key
    return tuned.lookup(kind, key, ["device", "0:0"])


def test_the_cache_answers_where_the_key_matches_and_measures_again_where_it_changed(cache, monkeypatch):
    key = tuned.device_key(Info, "OpenCL 3.0 PoCL", "3.1")
    entry, _ = _lookup(cache, key)
    assert entry["status"] == tuned.MEASURED and len(cache["calls"]) == 1
    tuned.forget()                                  # a new process: from the disk, no measurement
    assert _lookup(cache, key)[0]["choice"] == B.as_dict() and len(cache["calls"]) == 1
    changed = [tuned.device_key(Info, "OpenCL 3.0 PoCL", "3.2")]                 # a new driver
    host_cpu = tuned.cpu_identity
    monkeypatch.setattr(tuned, "cpu_identity", lambda: ("Other CPU", "0123456789abcdef"))
    changed.append(tuned.device_key(Info, "OpenCL 3.0 PoCL", "3.1"))            # a new CPU (model or flags)
    monkeypatch.setattr(tuned, "cpu_identity", host_cpu)
    monkeypatch.setattr(tuned, "kernels_hash", lambda: "fedcba9876543210")
    changed.append(tuned.device_key(Info, "OpenCL 3.0 PoCL", "3.1"))            # edited kernels
    for n, other in enumerate(changed, start=2):
        assert tuned.key_hash(other) != tuned.key_hash(key)
        _lookup(cache, other)
        assert len(cache["calls"]) == n
    tuned.forget()
    for other in [key, *changed]:
        _lookup(cache, other)
    assert len(cache["calls"]) == 4


def test_the_key_names_driver_cpu_flags_and_kernels(monkeypatch):
    key = tuned.device_key(Info, "OpenCL 3.0 PoCL", "3.1")
    assert key["driver_version"] == "3.1" and key["runtime"] == "PoCL 3.1" and key["device"] == "cpu0"
    assert key["cpu_hash"] == tuned.cpu_identity()[1] and key["kernels"] == tuned.kernels_hash()
    flags = dict(tuned._cpuinfo())
    if "flags" not in flags:
        pytest.skip("no /proc/cpuinfo flags here")
    flags["flags"] += " avx512f"
    monkeypatch.setattr(tuned, "_cpuinfo", lambda: flags)
    assert tuned.cpu_identity.__wrapped__()[1] != tuned.cpu_identity()[1]


def test_a_damaged_cache_file_is_measured_again(cache):
    key = tuned.device_key(Info, "OpenCL 3.0 PoCL", "3.1")
    path = tuned.entry_path(tuned.DEVICE, key)
    path.parent.mkdir(parents=True, exist_ok=True)
    # An entry of another key, whole (every family's choice): only the key tells it from this device's.
    foreign = {"schema": tuned.SCHEMA, "kind": "device", "key": {"other": 1}, "status": "measured",
               "choice": FIXED.as_dict(), "families": {f: {"choice": FIXED.as_dict()} for f in tuned.families()}}
    for damaged in (b"{not json", b"\xff\xfe", json.dumps(foreign).encode()):
        path.write_bytes(damaged)
        tuned.forget()
        entry, _ = _lookup(cache, key)
        assert entry["status"] == tuned.MEASURED and entry["key"] == key
    assert len(cache["calls"]) == 3
    assert json.loads(path.read_text())["choice"] == B.as_dict()


def test_a_failed_measurement_is_kept_with_its_reason(cache):
    cache["result"] = None
    key = tuned.device_key(Info, "OpenCL 3.0 PoCL", "3.1")
    entry, _ = _lookup(cache, key)
    assert entry["status"] == tuned.FAILED and entry["reason"] == "the tuner exited with status 1"
    tuned.forget()
    assert _lookup(cache, key)[0]["status"] == tuned.FAILED and len(cache["calls"]) == 1


def test_without_a_cache_folder_nothing_is_measured(cache, monkeypatch):
    monkeypatch.setenv("CLSHADE_NO_BINARY_CACHE", "1")
    entry, why = _lookup(cache, tuned.device_key(Info, "OpenCL 3.0 PoCL", "3.1"))
    assert entry is None and "CLSHADE_NO_BINARY_CACHE" in why and not cache["calls"]


def test_the_tune_mode_is_auto_or_fixed(monkeypatch):
    for text, mode in (("", tuned.AUTO), ("auto", tuned.AUTO), ("1", tuned.AUTO), ("fixed", tuned.FIXED_MODE),
                       ("0", tuned.FIXED_MODE), ("FIXED", tuned.FIXED_MODE)):
        monkeypatch.setenv(tuned.ENV_TUNE, text)
        assert tuned.mode() == mode
    monkeypatch.setenv(tuned.ENV_TUNE, "sometimes")
    with pytest.raises(ClshadeError, match="CLSHADE_TUNE='sometimes': expected auto") as err:
        tuned.mode()
    assert "\n" not in str(err.value)


def test_the_suite_runs_the_fixed_choice():
    """tests/conftest.py sets CLSHADE_TUNE=fixed: no test waits on a measurement (CI's .ci/run too)."""
    import os
    assert os.environ.get(tuned.ENV_TUNE) == "fixed"


# ---------------------------------------------------------------- the choice on the runtime


def test_the_environment_still_forces_a_choice(monkeypatch):
    for name in ("CLSHADE_LIBRARY_MATH", "CLSHADE_INLINE_MATH", "CLSHADE_CACHED_STORES", "CLSHADE_NO_PREFETCH",
                 "CLSHADE_LOCAL_SIZE"):
        monkeypatch.delenv(name, raising=False)
    tuned_pick = BuildChoice(math="inline", stores="plain", lanes=4, local=256)
    assert buildchoice.forced(tuned_pick) == (tuned_pick, ())
    monkeypatch.setenv("CLSHADE_LIBRARY_MATH", "1")
    monkeypatch.setenv("CLSHADE_NO_PREFETCH", "1")
    assert buildchoice.forced(tuned_pick) == (replace(tuned_pick, math="library", prefetch=False),
                                          ("CLSHADE_LIBRARY_MATH", "CLSHADE_NO_PREFETCH"))
    monkeypatch.delenv("CLSHADE_LIBRARY_MATH")
    monkeypatch.setenv("CLSHADE_INLINE_MATH", "1")
    monkeypatch.setenv("CLSHADE_LOCAL_SIZE", "32")
    assert buildchoice.forced(FIXED)[0] == BuildChoice(math="inline", prefetch=False, local=32)
    monkeypatch.setenv("CLSHADE_LOCAL_SIZE", "lots")
    with pytest.raises(ClshadeError, match="CLSHADE_LOCAL_SIZE='lots'"):
        buildchoice.forced(FIXED)


def test_a_build_choice_is_validated_and_round_trips():
    choice = BuildChoice(math="library", prefetch=False, lanes=8, local=16)
    assert BuildChoice.from_dict(json.loads(json.dumps(choice.as_dict()))) == choice
    assert choice.options() == (buildchoice.LIBRARY_MATH, buildchoice.NO_PREFETCH) and FIXED.options() == ()
    assert choice.changes() == ("math", "prefetch", "lanes", "local") and FIXED.label() == "today's rule"
    for bad in ({"math": "fast"}, {"lanes": 3}, {"local": 0}, {"prefetch": "yes"}):
        with pytest.raises(ValueError):
            BuildChoice(**bad)
    with pytest.raises(ValueError):
        BuildChoice.from_dict({"math": "auto"})


@pytest.fixture
def tuned_device(runtime, cache, monkeypatch):
    """The test device with a cached entry: 4 lanes, work-group 16, plain stores."""
    for name in ("CLSHADE_LIBRARY_MATH", "CLSHADE_INLINE_MATH", "CLSHADE_CACHED_STORES", "CLSHADE_NO_PREFETCH",
                 "CLSHADE_LOCAL_SIZE", "CLSHADE_SIMD", "CLSHADE_DEVICE"):
        monkeypatch.delenv(name, raising=False)
    choice = BuildChoice(stores="plain", lanes=4, local=16)
    key = rtmod.device_key(runtime.info, runtime.device)
    tuned.write(tuned.DEVICE, key, {"status": tuned.MEASURED, "choice": choice.as_dict(), "decision": "fake"})
    cache["result"] = None
    return choice


def test_the_runtime_builds_with_the_cached_choice(tuned_device, runtime, cache, monkeypatch):
    from clshade.device.buildchoice import CACHED_STORES, INLINE_MATH
    from clshade.device.runtime import Runtime
    rt = Runtime(runtime.info.spec)
    assert rt.choice == tuned_device and rt.choice_source.startswith("measured") and not cache["calls"]
    assert rt.simd == 4 and rt.local_size == 16 and CACHED_STORES in rt.options
    record = rt.build_record()
    assert record["choice"] == tuned_device.as_dict() and record["simd"] == 4 and not record["streaming_stores"]
    monkeypatch.setenv("CLSHADE_INLINE_MATH", "1")
    monkeypatch.setenv("CLSHADE_SIMD", "8")
    forced = Runtime(runtime.info.spec)
    assert forced.choice == replace(tuned_device, math="inline") and INLINE_MATH in forced.options
    assert forced.simd == 8 and forced.build_record()["forced_by"] == ["CLSHADE_INLINE_MATH", "CLSHADE_SIMD"]
    monkeypatch.setenv(tuned.ENV_TUNE, "fixed")
    monkeypatch.delenv("CLSHADE_INLINE_MATH")
    monkeypatch.delenv("CLSHADE_SIMD")
    fixed = Runtime(runtime.info.spec)
    assert fixed.choice == FIXED and fixed.options == runtime.options
    assert fixed.local_size == min(buildchoice.LOCAL_SIZE, int(runtime.device.max_work_group_size))
    assert fixed.choice_source == "tuning off: CLSHADE_TUNE=fixed" and not cache["calls"]


def test_the_default_device_follows_the_measured_order(cache, monkeypatch):
    """A cached ranking that puts the last CPU device in preference order first makes it the default;
    with tuning off the preference order is back."""
    from clshade.device import health
    monkeypatch.delenv("CLSHADE_DEVICE", raising=False)
    monkeypatch.setattr(rtmod, "device_health", lambda info, device: health.Health(True))
    ordered = sorted(rtmod.list_devices(), key=lambda item: rtmod.preference(item[0]))
    cpus = [item for item in ordered if "cpu" in item[0].kind]
    if len(cpus) < 2:
        pytest.skip("one CPU device here: nothing to order")
    keys = [rtmod.device_key(*item) for item in cpus]
    ranking = tuned.ranking_key(keys)
    tuned.write(tuned.RANKING, ranking, {"status": tuned.MEASURED, "order": [tuned.key_hash(k) for k in keys[::-1]]})
    cache["result"] = None
    assert rtmod.choose_device(None).info == cpus[-1][0] and not cache["calls"]
    monkeypatch.setenv(tuned.ENV_TUNE, "fixed")
    assert rtmod.choose_device(None).info == cpus[0][0]


# ---------------------------------------------------------------- on the device


def test_a_small_race_on_the_device(runtime):
    """The real thing, briefly: the candidates start with today's rule, each is built and timed or
    named as not measured, and the entry names its pick among them."""
    rt = runtime.with_choice(FIXED)
    order = tune.candidates(rt)
    assert order[0] == FIXED and len(set(order)) == len(order)
    assert all(len(c.changes()) == 1 for c in order[1:])
    body = tune.tune_device(rt, budget_s=6.0, frame=tune.calibration_frame((128, 72)))
    assert body["status"] == tuned.MEASURED and tuple(body["families"]) == tuned.families()
    for family, entry in body["families"].items():
        assert entry["candidates"][0]["choice"] == FIXED.as_dict()
        assert [r["choice"] for r in entry["candidates"][:len(order)]] == [c.as_dict() for c in order]
        assert entry["choice"] in [r["choice"] for r in entry["candidates"]]
        measured = [r for r in entry["candidates"] if r.get("median_ms")]
        assert all(set(r["median_ms"]) == set(tune.CALIBRATION_MODELS[family]) for r in measured)
        assert {r["status"] for r in entry["candidates"]} <= {"picked", "tied", "slower", "failed", "not judged",
                                                              "not measured (budget)"}   # a third of 6 s: few rounds
    # (A family's share can go to its builds on a loaded machine: at least one family timed rounds.)
    assert any(e["rounds"][0] >= 1 for e in body["families"].values())
    # Each family may spend an equal part of what is left: the first a third (stored rounded to 0.01 s).
    shares = [e["budget_s"] for e in body["families"].values()]
    assert body["budget_s"] == 6.0 and shares[0] <= 6.0 / 3 + 0.005 and max(shares) <= 6.0
    assert BuildChoice.from_dict(body["choice"]) in [*order, *(BuildChoice.from_dict(r["choice"])
                                                             for e in body["families"].values()
                                                             for r in e["candidates"])]


# ---------------------------------------------------------------- what users see


def _entries(runtime) -> tuple[dict, dict]:
    """A device entry with a race of three candidates and a ranking entry, as tune.py writes them."""
    key = rtmod.device_key(runtime.info, runtime.device)
    families = {}
    for family, models in tune.CALIBRATION_MODELS.items():
        rows = [dict(choice=c.as_dict(), label=c.label(), changes=list(c.changes()), simd=8, local_size=64,
                     inline_math=c.math == "inline", streaming_stores=True, prefetch=True,
                     median_ms={m: ms for m in models}, rounds=9, status=status,
                     **({} if c == FIXED else {"vs_default": ms / 4.0, "band": 0.03}))
                for c, ms, status in ((A, 4.0, "slower"), (B, 3.0, "picked"), (C, 4.1, "slower"))]
        rows.append(dict(choice=BuildChoice(local=256).as_dict(), status="not measured (budget)"))
        families[family] = dict(choice=B.as_dict(), label=B.label(), decision="math inline: 25.0% faster than "
                                "today's rule", models=list(models), budget_s=3.3, seconds=3.1, budget_spent=False,
                                rounds=[9], candidates=rows)
    device = tuned.write(tuned.DEVICE, key, dict(
        status=tuned.MEASURED, choice=B.as_dict(), label=B.label(),
        decision="math inline: 25.0% faster than today's rule over the families", families=families,
        device=runtime.info.description, seconds=9.5, budget_s=10.0, budget_spent=False,
        budget_split="each family in turn an equal share of what is left (builds included)",
        calibration=dict(scene="sphere_grid.toml", width=1280, height=720,
                         models={f: list(m) for f, m in tune.CALIBRATION_MODELS.items()}),
        noise=dict(z=3.0, floor=0.02, min_rounds=5)))
    return key, device


def test_devices_shows_the_measured_choice_and_devices_tune_the_races(runtime, cache, monkeypatch, capsys):
    from clshade.cli import main
    from clshade.report.tuning import device_tuning_markdown
    monkeypatch.delenv("CLSHADE_DEVICE", raising=False)
    key, device = _entries(runtime)
    cache["result"] = None                      # other devices: their measurement fails (kept as failed)
    assert main(["devices"]) == 0
    out = capsys.readouterr().out
    assert f"build: math inline (measured on this device, key {tuned.key_hash(key)[:12]})" in out
    text = device_tuning_markdown(device)
    for needle in ("math inline: 25.0% faster", tuned.key_hash(key), "driver " + key["driver_version"],
                   "not measured (budget)", "| math inline ", "0.750", "picked"):
        assert needle in text, needle
    monkeypatch.setattr(tune, "retune_all", lambda: ([device], None))
    assert main(["devices", "--tune"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(text) and "build: math inline" in out
    monkeypatch.setenv(tuned.ENV_TUNE, "fixed")
    assert main(["devices"]) == 0
    out = capsys.readouterr().out
    assert "build: today's rule (tuning off: CLSHADE_TUNE=fixed)" in out and "RUNTIME_PREFERENCE" in out


def test_the_results_document_renders_default_against_the_fastest(runtime, cache):
    from clshade.report.tuning import tuning_markdown
    key, device = _entries(runtime)
    choices = [dict(choice=c.as_dict(), label=c.label(), is_rule=c == FIXED, tuned_for=["diffuse"] if c == B else [],
                    simd=8, local_size=64,
                    models={"lambert": dict(median_ms=ms, copy_ms=2.0, copy_ratio=ms / 2.0)})
               for c, ms in ((A, 3.0), (B, 2.4), (C, 2.2))]
    summary = {"lambert": dict(family="diffuse", tuned=B.label(), rule_ms=3.0, tuned_ms=2.4, best_ms=2.2, best=C.label(), rule_vs_best=3.0 / 2.2,
                               tuned_vs_best=2.4 / 2.2, tuned_within_target=False, tuned_copy_ratio=1.2)}
    doc = dict(provenance={"commit": "0" * 40, "dirty": False}, machine={"cpu": "cpu", "cores": 2},
               scene="sphere_grid.toml", width=1920, height=1080, rounds=30, created="now", command="cmd",
               target=0.05, models=["lambert"], ranking=None,
               runtimes=[dict(runtime="PoCL 3.1", device="dev", choices=choices, summary=summary, tuning=device),
                         dict(runtime="PoCL 3.0", device="dev2", error="the tuner failed: boom")])
    text = tuning_markdown(doc)
    assert "| math inline (**tuned: diffuse**) " in text and "| today's rule " in text
    row = next(line for line in text.splitlines() if line.startswith("| lambert "))
    assert "2.20 (plain stores)" in row and "1.364" in row and "1.091" in row and "**missed**" in row
    assert "Not measured: the tuner failed: boom" in text and tuned.key_hash(key) in text

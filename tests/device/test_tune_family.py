"""The build choice per model family (clshade/device/tune.py, tuned.py, runtime.py): fed fake timings, each
family's race picks that family's fastest choice within its share of one device budget; a model is built
with its family's choice (a family the tuner did not measure gets the general one); a cache entry that
lacks a family is measured again."""
from __future__ import annotations

import random
from types import SimpleNamespace

import pytest

from clshade.device import runtime as rtmod
from clshade.device import buildchoice, tune, tuned
from clshade.device.buildchoice import FIXED, BuildChoice
from clshade.models.registry import Registry

INLINE, NO_PREFETCH, WG256 = BuildChoice(math="inline"), BuildChoice(prefetch=False), BuildChoice(local=256)
ORDER = [FIXED, INLINE, NO_PREFETCH, WG256]
FAMILIES = {"diffuse": ["burley"], "empirical": ["lambert+blinn_phong"], "microfacet": ["lambert+ggx_correlated"]}
FAMILY_OF = {m: f for f, ms in FAMILIES.items() for m in ms}
#: Per family, each candidate's true ms: every family has another fastest (as measured on PoCL 3.1).
MS = {"diffuse": {FIXED: 3.1, INLINE: 3.1, NO_PREFETCH: 2.5, WG256: 2.9},
      "empirical": {FIXED: 4.5, INLINE: 3.6, NO_PREFETCH: 4.2, WG256: 4.3},
      "microfacet": {FIXED: 3.5, INLINE: 3.6, NO_PREFETCH: 3.4, WG256: 2.8}}


class FakeFamilies:
    """Fake timings on a fake clock, per family; builds and timings advance the clock."""

    def __init__(self, ms: dict = MS, noise: float = 0.01, build_s: float = 0.3, seed: int = 7) -> None:
        self.ms, self.noise, self.build_s = ms, noise, build_s
        self.rng = random.Random(seed)
        self.now = 0.0
        self.built: list = []

    def clock(self) -> float:
        return self.now

    def prepare(self, c, family: str) -> None:
        self.now += self.build_s
        self.built.append((family, c))

    def true_ms(self, c, family: str) -> float:
        """A candidate's ms; a combination of changes is as fast as the best change in it (no gain)."""
        table = self.ms[family]
        if c in table:
            return table[c]
        return min(table[single] for single in ORDER[1:]
                   if all(getattr(c, n) == getattr(single, n) for n in single.changes()))

    def timer(self, c, model: str) -> float:
        ms = self.true_ms(c, FAMILY_OF[model]) * max(0.05, 1 + self.noise * self.rng.gauss(0, 1))
        self.now += 2 * ms / 1e3
        return ms

    def tune(self, budget_s: float = 10.0) -> dict:
        return tune.tune_families(ORDER, FAMILIES, self.prepare, self.timer, budget_s, clock=self.clock)


def test_each_family_picks_its_own_fastest_choice():
    results = FakeFamilies().tune()
    assert list(results) == list(FAMILIES)
    assert {f: r.pick for f, (r, _) in results.items()} == {"diffuse": NO_PREFETCH, "empirical": INLINE,
                                                             "microfacet": WG256}
    general, why = tune.general_choice({f: r for f, (r, _) in results.items()})
    # Over the three families WG256 is on average the fastest against today's rule (-7 %, -4 %, -20 %).
    assert general == WG256 and "over the families" in why


def test_the_general_choice_keeps_todays_rule_where_nothing_wins_over_the_families():
    flat = {f: {c: 3.0 for c in ORDER} for f in FAMILIES}
    flat["diffuse"][INLINE] = 2.6          # one family 13 % faster, the others slower: a mean of -0.2 %
    flat["empirical"][INLINE] = 3.2
    flat["microfacet"][INLINE] = 3.2
    results = FakeFamilies(flat).tune()
    assert results["diffuse"][0].pick == INLINE and results["empirical"][0].pick == FIXED
    assert tune.general_choice({f: r for f, (r, _) in results.items()})[0] == FIXED


def test_the_budget_is_split_between_the_families_and_respected():
    """Each family gets an equal share of what is left: the first a third; one that settles early
    leaves its rest to the next; builds count; the whole stays within the budget (one round over at most)."""
    fake = FakeFamilies(build_s=0.3)
    results = fake.tune(budget_s=10.0)
    shares = [share for _, share in results.values()]
    assert shares[0] == pytest.approx(10.0 / 3)
    spent_first = sum(st.seconds for st in results["diffuse"][0].stages)
    assert shares[1] == pytest.approx((10.0 - spent_first) / 2, rel=1e-6) and shares[1] > 10.0 / 3
    for result, share in results.values():
        assert sum(st.seconds for st in result.stages) <= share + 0.1
    assert fake.now <= 10.0 + 0.1
    # Slow builds: a family's share stops its builds (BUILD_SHARE), the other families still get theirs.
    slow = FakeFamilies(build_s=1.5)
    results = slow.tune(budget_s=10.0)
    assert all(result.stages[0].unbuilt for result, _ in results.values())
    assert {f for f, _ in slow.built} == set(FAMILIES) and slow.now <= 10.0 + 0.1


def test_the_calibration_models_are_of_their_family_and_cover_the_registry():
    per_family = tune.calibration_models(Registry())
    assert tuple(per_family) == tuned.families() == ("diffuse", "empirical", "microfacet")
    assert all(m.family == f for f, ms in per_family.items() for m in ms)


# ---------------------------------------------------------------- the cache


class Info:
    platform, platform_version, device, kind, spec = "PoCL", "OpenCL 3.0 PoCL 3.1", "cpu0", "all | cpu", "0:0"
    runtime = "PoCL 3.1"


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """An empty cache folder, tuning on; the child process replaced: it counts its calls and stores a
    complete entry."""
    monkeypatch.setenv("CLSHADE_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("CLSHADE_NO_BINARY_CACHE", raising=False)
    monkeypatch.setenv(tuned.ENV_TUNE, "auto")
    tuned.forget()
    state = {"calls": [], "store": True}

    def run_tuner(args):
        state["calls"].append(args)
        if state["store"]:
            tuned.write(tuned.DEVICE, state["key"], _entry(tuned.families()))
            return None
        return "the tuner exited with status 1"
    monkeypatch.setattr(tuned, "run_tuner", run_tuner)
    yield state
    tuned.forget()


def _entry(families, choices: dict | None = None, general: BuildChoice = FIXED) -> dict:
    choices = choices or {}
    return {"status": tuned.MEASURED, "choice": general.as_dict(), "label": general.label(),
            "families": {f: {"choice": choices.get(f, INLINE).as_dict()} for f in families}}


def test_a_cache_entry_missing_a_family_measures_again(cache):
    key = tuned.device_key(Info, "OpenCL 3.0 PoCL", "3.1")
    cache["key"] = key
    tuned.write(tuned.DEVICE, key, _entry(tuned.families()[:-1]))     # measured before the last family existed
    tuned.forget()
    entry, _ = tuned.lookup(tuned.DEVICE, key, ["device", "0:0"])
    assert len(cache["calls"]) == 1 and set(entry["families"]) == set(tuned.families())
    tuned.forget()                                                     # complete now: read, not measured
    tuned.lookup(tuned.DEVICE, key, ["device", "0:0"])
    assert len(cache["calls"]) == 1
    tuned.write(tuned.DEVICE, key, {"status": tuned.MEASURED, "choice": FIXED.as_dict()})   # no families at all
    tuned.forget()
    tuned.lookup(tuned.DEVICE, key, ["device", "0:0"])
    assert len(cache["calls"]) == 2


# ---------------------------------------------------------------- the build


@pytest.fixture
def family_device(runtime, cache, monkeypatch):
    """The test device with a cached entry: diffuse 4 lanes + work-group 16, empirical plain stores,
    microfacet work-group 32; the general choice no prefetch."""
    for name in ("CLSHADE_LIBRARY_MATH", "CLSHADE_INLINE_MATH", "CLSHADE_CACHED_STORES", "CLSHADE_NO_PREFETCH",
                 "CLSHADE_LOCAL_SIZE", "CLSHADE_SIMD", "CLSHADE_DEVICE"):
        monkeypatch.delenv(name, raising=False)
    choices = {"diffuse": BuildChoice(lanes=4, local=16), "empirical": BuildChoice(stores="plain"),
               "microfacet": BuildChoice(local=32)}
    key = rtmod.device_key(runtime.info, runtime.device)
    tuned.write(tuned.DEVICE, key, _entry(tuned.families(), choices, general=NO_PREFETCH))
    cache["store"] = False
    return choices


def test_a_model_is_built_with_its_familys_choice(family_device, runtime, cache, monkeypatch):
    from clshade.device.shade import Shader, scene_features
    rt = rtmod.Runtime(runtime.info.spec)
    assert rt.choice == NO_PREFETCH and rt.family_choices == family_device and not cache["calls"]
    registry = Registry()
    frame = tune.calibration_frame((64, 36))
    shader = Shader(rt, frame.gbuffer, frame.scene, frame.camera)
    features = scene_features(frame.scene)
    seen = {}
    for name in ("burley", "lambert+blinn_phong", "lambert+ggx_correlated"):
        model = registry.resolve(name)
        built = rt.for_model(model)
        assert built.choice == family_device[model.family] and built.family == model.family
        d = shader.prepare(model, features)
        seen[model.family] = d
        assert d.local_size == built.local_size and d.global_size % d.local_size == 0
        shader.enqueue(d).wait()
    assert seen["diffuse"].local_size == 16 and rt.for_model(registry.resolve("burley")).simd == 4
    assert seen["microfacet"].local_size == min(32, int(runtime.device.max_work_group_size))
    assert buildchoice.CACHED_STORES in rt.for_model(registry.resolve("lambert+blinn_phong")).options
    assert buildchoice.CACHED_STORES not in rt.options and buildchoice.NO_PREFETCH in rt.options
    record = rt.for_model(registry.resolve("burley")).build_record()
    assert record["family"] == "diffuse" and record["families"]["empirical"] == "plain stores"
    # A model of a family the tuner did not measure (a user lobe's own): the general choice.
    assert rt.for_model(SimpleNamespace(family="velvet")) is rt
    # The environment's switches still force every family's choice.
    monkeypatch.setenv("CLSHADE_INLINE_MATH", "1")
    forced = rtmod.Runtime(runtime.info.spec)
    assert all(forced.for_model(registry.resolve(n)).choice.math == "inline" for n in ("burley", "lambert+phong"))
    # With tuning off every model gets today's rule.
    monkeypatch.delenv("CLSHADE_INLINE_MATH")
    monkeypatch.setenv(tuned.ENV_TUNE, "fixed")
    fixed = rtmod.Runtime(runtime.info.spec)
    assert fixed.for_model(registry.resolve("burley")) is fixed and fixed.choice == FIXED


def test_bench_and_devices_name_the_family_choices(family_device, runtime, cache, monkeypatch, capsys):
    from clshade.cli import main
    from clshade.cli.commands.bench import build_line
    rt = rtmod.Runtime(runtime.info.spec)
    line = build_line(rt.build_record())
    assert ("per model family (its kernels build with): diffuse 4 lanes, work-group 16, empirical plain stores, "
            "microfacet work-group 32") in line and line.startswith("build choices: no prefetch (measured")
    monkeypatch.delenv("CLSHADE_DEVICE", raising=False)
    assert main(["devices"]) == 0
    out = capsys.readouterr().out
    assert "per model family (the above for other families): diffuse 4 lanes, work-group 16, empirical plain stores, microfacet work-group 32" in out

"""The performance comparison on the runtimes users get: every healthy CPU runtime as its own
column, the kernels in each build (`default` and the variants a build option switches), their copy
kernels, the peers (Numba, Dr.Jit), the STREAM anchor and whole frames, in one document
(benchmarks/measure/perf.py writes it; clshade.report.perf renders it).

Timing: medians over interleaved rounds, every item in a new seeded random order each round, so
machine noise hits all alike; ratios are within one run. Each item starts with the process idle
(`settle`: the peers' worker threads keep spinning after a frame and slowed whatever ran next) and
is timed as the second of two back-to-back runs (`timed_after_itself`: what ran just before the
timed run is the item itself, whatever the order).

The bandwidth anchor is measured in the same rounds (STREAM triads per runtime with plain and
streaming stores, and Numba's): the fastest median, since a best-of taken at a quiet moment is no
yardstick for medians taken over a loaded run. Causes of misses come from the same run: each kernel
is also timed in cache (`CACHE_BAND_PIXELS` of the frame's most covered rows), its instructions
without the trip to memory. How the protocol came to be: docs/bench-notes.md.
"""
from __future__ import annotations

import importlib
import platform
import time
from typing import Callable

import numpy as np

from clshade import __version__
from clshade.bench import bandwidth, frame as whole, peers as peer_mod
from clshade.bench.run import frame_stats
from clshade.device.buildchoice import CACHED_STORES, INLINE_MATH, LIBRARY_MATH, NO_PREFETCH
from clshade.device.runtime import Runtime, healthy_devices
from clshade.device.shade import Shader, scene_features
from clshade.device.timing import settle
from clshade.models.registry import Registry
from clshade.pipeline import prepare_frame
from clshade.render.scene import load_scene
from clshade.report.perf import short_device

MODELS = ("lambert", "ggx_correlated", "phong")
# In-cache timing: a band of this many pixels (≈ 3 MB of G-buffer and output at ~50 B/px, inside the
# 32 MiB L3 of this EPYC) is shaded twice in a row and the second dispatch timed.
CACHE_BAND_PIXELS = 1920 * 32
ROUND_SEED = 15
# STREAM triads timed in the rounds (so that they see the same machine as the kernels; the anchor of
# the targets is their best median): three arrays of this many MiB, ≫ the 32 MiB L3.
ROUND_STREAM_MIB = 64
SCHEMA = "clshade-perf/1"
LAMBERT_BOUND = 1.3          # target: Lambert within 1.3× of its bytes at the STREAM rate
COPY_BOUND = 1.5             # every model ≤ 1.5× the copy kernel
FRAME_BOUND_S = 1.0 / 30.0   # the robot scene at 1920×1080, median whole frame (rasterize … read back): 30 FPS
LOW1_BOUND_FPS = 24.0        # and its whole frames' 1 % low (clshade.bench.run.frame_stats)


def _versions() -> dict[str, str]:
    out = {"python": platform.python_version(), "numpy": np.__version__, "clshade": __version__}
    for name in ("pyopencl", "numba", "drjit", "llvmlite"):
        try:
            out[name] = importlib.import_module(name).__version__
        except Exception as exc:  # noqa: BLE001 - a missing optional package is data here
            out[name] = f"not available ({type(exc).__name__})"
    return out


# What each round's items are timed by: the second of two back-to-back runs of the item (timed_after_itself).
TIMED_RUN = "the second of two back-to-back runs of each item"


def timed_after_itself(timed: Callable[[], float]) -> float:
    """Run a timed item twice back to back and return the second time: what ran just before it is then
    the item itself, not whichever item the round's random order put there. A STREAM triad leaves the
    cache full of its arrays, and the item after it paid for that, a memory-bound one (the copy kernel)
    more than a compute-bound one: the × copy ratios read lower than they are."""
    timed()
    return timed()


def active_items(coverage: np.ndarray, simd: int) -> np.ndarray:
    """Per work-item of `simd` pixels: whether any of its pixels is covered (the kernels
    read the full G-buffer only there)."""
    cov = np.zeros(-(-coverage.size // simd) * simd, bool)
    cov[:coverage.size] = coverage.ravel()
    return cov.reshape(-1, simd).any(axis=1)


def cache_band(active: np.ndarray, local: int, items: int) -> tuple[int, int]:
    """(first work-item, count) of the window of ≈ `items` work-items with the most covered
    ones (`active`), both multiples of the work-group size `local`."""
    items = max(local, min(len(active) // local * local, items // local * local))
    starts = np.arange(0, len(active) - items + 1, local)
    counts = np.concatenate(([0], np.cumsum(active, dtype=np.int64)))
    best = starts[int(np.argmax(counts[starts + items] - counts[starts]))]
    return int(best), items


def cpu_runtimes() -> list[str]:
    """One spec (`P:D`) per healthy CPU runtime (platform version), in the default's order: a
    runtime that cannot build here (clshade/device/health.py) is left out, not a stop."""
    seen, out = set(), []
    for info, _ in healthy_devices("cpu"):
        if info.platform_version not in seen:
            seen.add(info.platform_version)
            out.append(info.spec)
    return out


def compare(scene_path: str, models: list, width: int | None, height: int | None, rounds: int, warmup: int,
            peer_names: tuple[str, ...], devices: list[str] | None = None, library: bool = True,
            registry: Registry | None = None) -> dict:
    """Every runtime in `devices` (default: every healthy CPU runtime) × build (inline math,
    and with `library` the OpenCL library's builtins) × model, their copy kernels and
    the peers, in the same interleaved rounds; peers verified against the first runtime.
    The scene is read with `registry` (load_scene)."""
    frame = prepare_frame(load_scene(scene_path, registry), width, height)
    gb, scene, camera = frame.gbuffer, frame.scene, frame.camera
    feats = scene_features(scene, geometry=frame.geometry)
    builds = ((("default", ()), ("library", (LIBRARY_MATH,)), ("inline", (INLINE_MATH,)),
               ("plain stores", (CACHED_STORES,)), ("no prefetch", (NO_PREFETCH,)))
              if library else (("default", ()),))
    configs = []
    for spec in devices or cpu_runtimes():
        for build, opts in builds:
            rt = Runtime(spec, options=opts)
            try:
                sh = Shader(rt, gb, scene, camera)
                ds = {m.id: sh.prepare(m, feats) for m in models}
                # Each model's own copy kernel: the channels its variant reads, the same output.
                ds.update({f"copy:{m.id}": sh.prepare(m, feats, entry="copy") for m in models})
                images = {m.id: sh.render(m, feats) for m in models}
            except Exception as exc:  # noqa: BLE001 - a build the runtime cannot do is a result
                configs.append(dict(device=rt.info.description, build=build, error=str(exc).splitlines()[0]))
                continue
            configs.append(dict(device=rt.info.description, device_name=rt.info.device,
                                platform_version=rt.info.platform_version, build=build, simd=rt.simd,
                                inline_math=rt.inline_math, streaming_stores=rt.streaming_stores,
                                prefetch=rt.prefetches, local_size=rt.local_size, choice=rt.choice.label(),
                                choice_source=rt.choice_source, shader=sh, dispatches=ds, images=images, ms={k: [] for k in ds}))
    ok = [c for c in configs if "error" not in c]
    ref_images = ok[0]["images"]
    covered = np.flatnonzero(gb.channels["depth"] > 0)
    peer_rows, peers = [], []
    for name in peer_names:
        for m in models:
            try:
                p = peer_mod.PEERS[name](m, gb, scene, camera, uniform=dict(feats.uniform))
            except (RuntimeError, KeyError) as exc:
                peer_rows.append(dict(peer=name, model=m.id, skipped=str(exc)))
                continue
            image = p.run()
            good = peer_mod.well_conditioned(m, gb, covered)
            diff = peer_mod.verify(image, ref_images[m.id], covered)
            diff_good = peer_mod.verify(image, ref_images[m.id], covered[good])
            row = dict(peer=name, version=p.version, model=m.id, max_rel_diff=diff,
                       well_conditioned_pixels=int(good.sum()), ill_conditioned_pixels=int((~good).sum()),
                       ill_conditioned_why=peer_mod.ill_conditioned_note(m),
                       max_rel_diff_well_conditioned=diff_good,
                       verified=diff_good <= peer_mod.VERIFY_RTOL, ms=[])
            peer_rows.append(row)
            peers.append((p, row))
    stream_before = bandwidth.stream()
    devices_seen: dict[str, object] = {}
    for c in ok:
        devices_seen.setdefault(c["device"], c["shader"].rt)
    ocl_before = {d: bandwidth.opencl_stream(rt) for d, rt in devices_seen.items()}
    fills = {d: bandwidth.opencl_fill(rt) for d, rt in devices_seen.items()}
    def dispatch(c: dict, k: str, d) -> float:
        ev = c["shader"].enqueue(d)
        ev.wait()
        return (ev.profile.end - ev.profile.start) * 1e-6

    def in_cache(c: dict, k: str, d) -> float:
        """The band dispatched once; timed_after_itself runs it twice, so the timed run finds
        its data in cache."""
        rt = c["shader"].rt
        first, count = c["band"]
        ev = rt.cl.enqueue_nd_range_kernel(rt.queue, d.kernel, (count,), (d.local_size,),
                                           global_work_offset=(first,))
        ev.wait()
        return (ev.profile.end - ev.profile.start) * 1e-6

    for c in ok:
        c["band"] = cache_band(active_items(gb.coverage, c["simd"]), c["shader"].rt.local_size,
                               CACHE_BAND_PIXELS // c["simd"])
        c["cache_ms"] = {k: [] for k in c["dispatches"]}
    items = [(c["ms"][k], lambda c=c, k=k, d=d: dispatch(c, k, d)) for c in ok for k, d in c["dispatches"].items()]
    items += [(c["cache_ms"][k], lambda c=c, k=k, d=d: in_cache(c, k, d))
              for c in ok for k, d in c["dispatches"].items()]
    items += [(row["ms"], lambda p=p: peer_mod.time_once(p)) for p, row in peers]
    round_stream: dict[str, list[float]] = {}
    for d, rt in devices_seen.items():
        st = bandwidth.OpenCLStream(rt, ROUND_STREAM_MIB)
        for kind in bandwidth.STORE_KINDS:
            times = round_stream[round_triad_key(d, kind)] = []
            items.append((times, lambda st=st, kind=kind: st.triad(kind) * 1e3))
    numba_triad = bandwidth.numba_triad(ROUND_STREAM_MIB)
    if numba_triad is not None:
        round_stream[f"{numba_triad[1]} triad"] = []
        items.append((round_stream[f"{numba_triad[1]} triad"], lambda f=numba_triad[0]: f() * 1e3))
    rng = np.random.default_rng(ROUND_SEED)
    for r in range(warmup + rounds):
        for j in rng.permutation(len(items)):
            out, timed = items[j]
            settle()
            t = timed_after_itself(timed)
            if r >= warmup:
                out.append(t)
    stream_after = bandwidth.stream()
    ocl_after = {d: bandwidth.opencl_stream(rt) for d, rt in devices_seen.items()}
    # The anchor is the fastest STREAM measured by any method: Numba's loops or a runtime's own
    # OpenCL STREAM kernels (which can stream faster than Numba).
    ocl_best = {d: max(ocl_before[d]["best_gbs"], ocl_after[d]["best_gbs"]) for d in devices_seen}
    best_anchor = max(stream_before["anchor_gbs"], stream_after["anchor_gbs"], *ocl_best.values())
    triad_bytes = bandwidth.STREAM_BYTES["triad"] * (ROUND_STREAM_MIB * 2 ** 20 // 4)
    in_rounds = {k: dict(median_gbs=triad_bytes / (float(np.median(v)) * 1e-3) / 1e9,
                         best_gbs=triad_bytes / (min(v) * 1e-3) / 1e9) for k, v in round_stream.items() if v}
    # The targets' anchor: the fastest STREAM median of the same rounds (medians against medians, the
    # same machine load); the best-of figures before / after are shown beside it.
    anchor = max(v["median_gbs"] for v in in_rounds.values()) if in_rounds else best_anchor
    bpp = {m.id: gb.mean_bytes_per_pixel(ok[0]["shader"].variant(m, feats).channels, False, ok[0]["simd"], 16)
           for m in models}
    runtimes = []
    for c in configs:
        if "error" in c:
            runtimes.append(c)
            continue
        rows = []
        active = active_items(gb.coverage, c["simd"])
        first, count = c["band"]
        # In-cache times scaled to the frame by covered work-items (an empty one reads only depth).
        scale = float(active.sum()) / max(1, int(active[first:first + count].sum()))
        for m in models:
            ms = float(np.median(c["ms"][m.id]))
            copy_ms = float(np.median(c["ms"][f"copy:{m.id}"]))
            moved = bpp[m.id] * gb.pixels
            cache = dict(cache_band_pixels=count * c["simd"], cache_ms=float(np.median(c["cache_ms"][m.id])),
                         copy_cache_ms=float(np.median(c["cache_ms"][f"copy:{m.id}"])))
            cache.update(cache_frame_ms=cache["cache_ms"] * scale, copy_cache_frame_ms=cache["copy_cache_ms"] * scale)
            rows.append(dict(model=m.id, name=m.label, median_ms=ms, copy_ms=copy_ms, copy_ratio=ms / copy_ms, **cache,
                             bytes=moved, gbs=moved / ms / 1e6, copy_gbs=moved / copy_ms / 1e6,
                             stream_ratio=ms / (moved / anchor / 1e6), copy_stream_ratio=copy_ms / (moved / anchor / 1e6),
                             max_rel_diff_vs_first=peer_mod.verify(c["images"][m.id], ref_images[m.id], covered)))
        runtimes.append(dict(device=c["device"], device_name=c["device_name"], platform_version=c["platform_version"],
                             build=c["build"], simd=c["simd"], inline_math=c["inline_math"],
                             streaming_stores=c["streaming_stores"], prefetch=c["prefetch"],
                             local_size=c["local_size"], choice=c["choice"], choice_source=c["choice_source"],
                             opencl_stream_gbs=max((in_rounds[k]["median_gbs"] for k in
                                                    (round_triad_key(c["device"], kind) for kind in bandwidth.STORE_KINDS)
                                                    if k in in_rounds), default=ocl_best[c["device"]]),
                             models=rows))
    for row in peer_rows:
        if "ms" in row:
            row["median_ms"] = float(np.median(row.pop("ms")))
    return dict(schema=SCHEMA, created=time.strftime("%Y-%m-%dT%H:%M:%S%z"), versions=_versions(), libllvm_drjit=peer_mod.drjit_libllvm(), scene=scene_path,
                width=frame.camera.width, height=frame.camera.height, pixels=gb.pixels,
                covered_pixels=int(len(covered)), rounds=rounds, warmup=warmup, timed_run=TIMED_RUN,
                cache_band_pixels=CACHE_BAND_PIXELS,
                stream=dict(before=stream_before, after=stream_after, anchor_gbs=anchor, best_anchor_gbs=best_anchor,
                            in_rounds=in_rounds, round_array_mib=ROUND_STREAM_MIB,
                            opencl={d: dict(before=ocl_before[d], after=ocl_after[d]) for d in devices_seen},
                            fill=fills),
                runtimes=runtimes, peers=peer_rows)


def round_triad_key(device: str, stores: str) -> str:
    """The in-rounds STREAM key of `device`'s OpenCL triad with `stores` (bandwidth.STORE_KINDS)."""
    return f"OpenCL triad ({stores} stores) on {short_device(device)}"


def run(scene_path: str, width: int, height: int, rounds: int, warmup: int, frame_scene: str,
        frame_frames: int, peer_names: tuple[str, ...]) -> dict:
    """The whole document: `compare` on MODELS, whole frames, the targets."""
    runtimes = [Runtime(spec) for spec in cpu_runtimes()]

    def frames_block() -> list[dict]:
        return whole.whole_frames_on(load_scene(frame_scene), Registry().resolve("ggx_correlated"), runtimes, 1920, 1080,
                                     -(-frame_frames // 2))

    before = frames_block()      # half the whole frames before the kernel rounds, half after
    doc = compare(scene_path, [Registry().resolve(m) for m in MODELS], width, height, rounds, warmup, peer_names)
    frames = whole.merge_blocks([before, frames_block()])
    for f in frames:
        ms = np.array([t["frame"] for t in f.pop("frames_s")]) * 1e3
        f["low1_fps"] = frame_stats(ms, ms)["low1_fps"]
    doc["whole_frames"] = frames
    doc["targets"] = targets(doc)
    return doc


def targets(doc: dict) -> list[dict]:
    """The targets, met or missed, per runtime (default build), each miss with
    the evidence for its cause, computed from the same run."""
    out = []
    peer_ms = {(p["peer"], p["model"]): p.get("median_ms") for p in doc["peers"] if p.get("verified")}
    anchor = doc["stream"]["anchor_gbs"]
    for rt in doc["runtimes"]:
        if "error" in rt or rt["build"] != "default":
            continue
        for r in rt["models"]:
            out.append(dict(runtime=rt["device"], target=f"{r['name']} ≤ {COPY_BOUND}× copy",
                            value=r["copy_ratio"], met=r["copy_ratio"] <= COPY_BOUND,
                            cause="" if r["copy_ratio"] <= COPY_BOUND else copy_miss_cause(r)))
            for (peer, model), ms in peer_ms.items():
                if model == r["model"]:
                    why = "" if r["median_ms"] < ms else (
                        f"{r['median_ms']:.2f} vs {ms:.2f} ms" + (f"; in cache (no memory traffic) the kernel takes "
                                                                   f"{r['cache_frame_ms']:.2f} ms"
                                                                   if "cache_frame_ms" in r else ""))
                    out.append(dict(runtime=rt["device"], target=f"{r['name']} faster than {peer} (× peer time)",
                                    value=r["median_ms"] / ms, met=r["median_ms"] < ms, cause=why))
            if r["model"] == "lambert":
                out.append(dict(runtime=rt["device"], target=f"Lambert ≤ {LAMBERT_BOUND}× its bytes at the STREAM rate",
                                value=r["stream_ratio"], met=r["stream_ratio"] <= LAMBERT_BOUND,
                                cause="" if r["stream_ratio"] <= LAMBERT_BOUND else
                                stream_miss_cause(r, anchor, rt.get("opencl_stream_gbs"))))
    for wf in doc.get("whole_frames", []):
        m = wf["median_s"]
        out.append(dict(runtime=wf["device"], target=f"robot 1920×1080 whole frame ≤ {FRAME_BOUND_S * 1e3:.1f} ms (ms)",
                        value=m["frame"] * 1e3, met=m["frame"] <= FRAME_BOUND_S,
                        cause="" if m["frame"] <= FRAME_BOUND_S else frame_miss_cause(wf)))
        if "low1_fps" in wf:            # results measured since the 1 % low is kept
            low = wf["low1_fps"]
            out.append(dict(runtime=wf["device"], target=f"robot 1920×1080 whole frames' 1 % low ≥ {LOW1_BOUND_FPS:.0f} FPS",
                            value=low, met=low >= LOW1_BOUND_FPS,
                            cause="" if low >= LOW1_BOUND_FPS else
                            f"the slowest 1 % of {wf['frames']} frames took {1e3 / low:.0f} ms each on average "
                            f"(median {m['frame'] * 1e3:.0f} ms)"))
    return out


def frame_miss_cause(wf: dict) -> str:
    """Why a whole frame misses FRAME_BOUND_S, from its stages: the host stages' share and time
    against what the device stages leave of the budget (and each block's median, when there are blocks)."""
    m = wf["median_s"]
    host = m["rasterize"] + m["g-buffer"]
    threads = f" on {wf['host_threads']} threads" if "host_threads" in wf else ""
    on_device = wf.get("gbuffer", {}).get("path") == "device"
    stages = ("the host's triangle setup and the device's visibility + G-buffer (clshade/device/visibility.py)"
              if on_device else f"the NumPy host stages{threads} (clshade/render/raster/, gbuffer.py)")
    why = (f"rasterize {m['rasterize'] / m['frame']:.0%} + G-buffer {m['g-buffer'] / m['frame']:.0%} of the frame: "
           f"{stages} take {host * 1e3:.0f} ms where "
           f"{(FRAME_BOUND_S - (m['frame'] - host)) * 1e3:.0f} ms are left beside the device stages; shading "
           f"{m['shade'] / m['frame']:.0%}")
    if "block_frame_s" in wf:
        why += "; medians of the blocks " + " / ".join(f"{b * 1e3:.0f}" for b in wf["block_frame_s"]) + " ms"
    return why


def copy_miss_cause(r: dict) -> str:
    """Why a model misses ≤ COPY_BOUND× copy, from its row of the same run: the copy kernel moves the
    same bytes, so the excess is instructions; the in-cache times say how much of it they explain."""
    excess = r["median_ms"] - r["copy_ms"]
    if "cache_frame_ms" not in r:
        return f"its copy kernel moves the same {r['bytes'] / 1e6:.1f} MB in {r['copy_ms']:.2f} ms (no in-cache timing)"
    arith = r["cache_frame_ms"] - r["copy_cache_frame_ms"]
    return (f"instructions: in cache (a {r['cache_band_pixels']} px band, scaled to the frame) the model takes "
            f"{r['cache_frame_ms']:.2f} ms, its copy kernel {r['copy_cache_frame_ms']:.2f} ms; those {arith:.2f} ms of "
            f"arithmetic are {arith / excess:.0%} of its {excess:.2f} ms over the copy kernel at full size, and "
            f"{r['cache_frame_ms'] / r['median_ms']:.0%} of its frame time is spent even with no memory traffic")


def stream_miss_cause(r: dict, anchor: float, runtime_stream: float | None = None) -> str:
    """Why Lambert misses ≤ LAMBERT_BOUND× the STREAM bound: the copy kernel's own distance from STREAM
    (the runtime's own OpenCL STREAM rate, and how much of the copy kernel is instructions), then
    Lambert's over the copy kernel."""
    text = (f"the copy kernel moving the same bytes runs at {r['copy_stream_ratio']:.2f}× the STREAM bound "
            f"({r['copy_gbs']:.1f} vs {anchor:.1f} GB/s)")
    if runtime_stream:
        text += (f"; this runtime's own OpenCL STREAM triad (the faster of its store kinds) reaches {runtime_stream:.1f} GB/s in the same rounds, so "
                 f"the copy kernel's G-buffer traffic (several planes read, float4 rows written) streams at "
                 f"{r['copy_gbs'] / runtime_stream:.0%} of what the runtime can")
    if "copy_cache_frame_ms" in r:
        text += (f"; in cache its loads, transposes and stores alone take {r['copy_cache_frame_ms']:.2f} of its "
                 f"{r['copy_ms']:.2f} ms")
    return text + f"; Lambert adds {r['median_ms'] - r['copy_ms']:.2f} ms ({r['copy_ratio']:.2f}× copy)"

"""The results registry: every published result, one entry each.

An entry names the results JSON, the command that makes it (run from the repository root), the
code whose change makes it stale (files or folders: benchmarks/publish/freshness.py) and what
`python -m benchmarks.publish` renders from it: whole files and the regions between
`<!-- publish:NAME -->` and `<!-- /publish:NAME -->` of README.md and docs/*.md. The renderers
are clshade.report's. Adding a result is adding an entry here.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from clshade.report.aa import aa_markdown
from clshade.report.accuracy import accuracy_markdown
from clshade.report.brdf_explorer import brdf_explorer_markdown
from clshade.report.bench import bench_1080p_markdown, readme_table, targets_table
from clshade.report.effects import effects_markdown
from clshade.report.environment import (environment_answer_markdown, environment_cost_markdown,
                                        environment_results_markdown)
from clshade.report.frame_scale import frame_scale_markdown
from clshade.report.glsl_oracle import glsl_oracle_markdown
from clshade.report.host import host_ab_markdown, memory_markdown, startup_markdown
from clshade.report.mitsuba import mitsuba_envmap_markdown
from clshade.report.mutants import mutants_markdown
from clshade.report.perf import perf_markdown
from clshade.report.raster import raster_markdown
from clshade.report.runtimes import runtimes_markdown
from clshade.report.stability import floor_bias_table, stability_tables
from clshade.report.study import report_markdown
from clshade.report.tuning import tuning_markdown
from clshade.report.user_lobes import user_lobes_example, user_lobes_markdown, user_lobes_table
from clshade.report.view import view_markdown, view_table


@dataclass(frozen=True)
class Rendering:
    """A text publish makes from a result: the whole file at `path`, or its `region`."""
    path: str                                   # relative to the repository root
    render: Callable[[dict], str]               # the results document → the text
    region: str | None = None


@dataclass(frozen=True)
class Result:
    """One published result."""
    json: str                                   # the results JSON, relative to the repository root
    command: str                                # what makes it, run from the repository root
    producers: tuple[str, ...]                  # the code whose change makes it stale (files or folders)
    renderings: tuple[Rendering, ...] = ()
    note: str = ""                              # what the command measures, in a few words

    @property
    def name(self) -> str:
        return self.json.rsplit("/", 1)[-1]


def _region(path: str, region: str, render: Callable[[dict], str]) -> Rendering:
    return Rendering(path, render, region)


OUT = "benchmarks/results/"
# The live viewer's code: what view_bench measures besides its own file.
VIEWER = ("kernels", "clshade/view", "clshade/render", "clshade/device/display.py", "clshade/device/shade.py",
          "clshade/device/variants.py", "clshade/device/visibility.py", "clshade/device/runtime.py",
          "clshade/device/buildchoice.py",
          "clshade/device/buffers.py",
          "clshade/device/timing.py", "benchmarks/measure/view_bench.py")

RESULTS: tuple[Result, ...] = (
    Result(OUT + "bench_1080p.json", "CLSHADE_DEVICE='PoCL 3.0' python -m benchmarks.measure.run_bench",
           ("kernels", "clshade/bench/run.py", "clshade/bench/numpy_baseline.py", "clshade/device/timing.py",
            "benchmarks/measure/run_bench.py"),
           (Rendering(OUT + "bench_1080p.md", bench_1080p_markdown),
            _region("README.md", "bench-table", readme_table), _region("README.md", "bench-targets", targets_table)),
           "with the CSV and plots; 1000 frames per model on the README install's runtime"),
    Result("benchmarks/report/report.json", "CLSHADE_DEVICE='PoCL 3.0' python -m benchmarks.measure.make_report",
           ("kernels", "clshade/bench/run.py", "clshade/bench/numpy_baseline.py", "clshade/verify/plausibility.py",
            "clshade/compare.py", "benchmarks/measure/make_report.py", "benchmarks/experiments/kernels"),
           (Rendering("benchmarks/REPORT.md", report_markdown),),
           "with its images: the study's claims; 1000 frames per model, GGX timed 3 times (the noise band)"),
    Result(OUT + "perf_1080p.json", "python -m benchmarks.measure.perf",
           ("kernels", "clshade/bench/perf.py", "clshade/bench/bandwidth.py", "clshade/bench/frame.py",
            "clshade/bench/peers.py", "clshade/pipeline.py", "clshade/device/visibility.py",
            "clshade/device/buffers.py", "clshade/device/shade.py", "benchmarks/measure/perf.py"),
           (Rendering(OUT + "perf_1080p.md", perf_markdown),),
           "every CPU runtime and build, the peers, STREAM, whole frames; needs '.[peers]' and a quiet machine"),
    Result(OUT + "runtimes.json", "python -m benchmarks.measure.runtimes",
           ("kernels", "clshade/bench/runtimes.py", "clshade/device/health.py", "benchmarks/measure/runtimes.py"),
           (Rendering(OUT + "runtimes.md", runtimes_markdown),),
           "every OpenCL runtime: health, times, error against float64"),
    Result(OUT + "tuning.json", "python -m benchmarks.measure.tuning",
           ("kernels", "clshade/device/tune.py", "clshade/device/race.py", "clshade/device/tuned.py",
            "clshade/device/runtime.py", "clshade/device/buildchoice.py",
            "clshade/bench/tuning.py", "benchmarks/measure/tuning.py"),
           (Rendering(OUT + "tuning.md", tuning_markdown),),
           "every CPU runtime: the tuner's pick and every build choice per model on a full frame; a quiet machine"),
    Result(OUT + "effects.json", "python -m benchmarks.measure.effects_bench",
           ("kernels", "benchmarks/measure/effects_bench.py"),
           (Rendering(OUT + "effects.md", effects_markdown),), "what each scene effect costs per model"),
    Result(OUT + "environment.json", "python -m benchmarks.measure.environment",
           ("kernels", "clshade/render/environment.py", "clshade/render/prefilter.py", "clshade/bench/environment.py",
            "clshade/verify/environment_oracle.py", "clshade/verify/environment_rungs.py",
            "benchmarks/measure/environment.py"),
           (Rendering(OUT + "environment.md", environment_results_markdown),
            _region("benchmarks/REPORT.md", "environment-answer", environment_answer_markdown)),
           "with its plot: the environment ladder (model × rung × N), error against the truth beside time"),
    Result(OUT + "environment_cost.json", "python -m benchmarks.measure.environment_cost",
           ("kernels", "clshade/render/environment.py", "clshade/render/prefilter.py", "clshade/device/shade.py",
            "clshade/device/variants.py", "benchmarks/measure/environment_cost.py"),
           (Rendering(OUT + "environment_cost.md", environment_cost_markdown),),
           "each sky rung's time at 1920×1080 against one directional light; the precompute per map"),
    Result(OUT + "environment_cost_intel.json", "python -m benchmarks.measure.environment_cost --device Intel "
                                             "--out benchmarks/results/environment_cost_intel.json",
           ("kernels", "clshade/render/environment.py", "clshade/render/prefilter.py", "clshade/device/shade.py",
            "clshade/device/variants.py", "benchmarks/measure/environment_cost.py"),
           (Rendering(OUT + "environment_cost_intel.md", environment_cost_markdown),),
           "the same on Intel's CPU runtime, the install's runtime where pip's PoCL 3.0 builds nothing"),
    Result(OUT + "frame_scale.json", "python -m benchmarks.measure.frame_scale",
           ("kernels", "clshade/pipeline.py", "clshade/bench/frame.py", "clshade/device/visibility.py",
            "clshade/device/buffers.py", "clshade/render", "benchmarks/measure/frame_scale.py"),
           (Rendering(OUT + "frame_scale.md", frame_scale_markdown),),
           "with its plot: whole frames against resolution (540p … 4K) and triangles (up to 1.3 M)"),
    Result(OUT + "aa.json", "clshade aa -o benchmarks/results/aa", ("kernels", "clshade/bench/aa.py"),
           (Rendering(OUT + "aa.md", aa_markdown),), "with its plots and crops: the anti-aliasing ladder"),
    Result(OUT + "raster.json", "python -m benchmarks.measure.raster_bench",
           ("clshade/render/raster", "benchmarks/measure/raster_bench.py"),
           (Rendering(OUT + "raster.md", raster_markdown),), "the rasterizer against Embree"),
    Result(OUT + "memory.json", "python -m benchmarks.measure.memory_bench", ("benchmarks/measure/memory_bench.py",),
           (Rendering(OUT + "memory.md", memory_markdown),), "peak host memory of `clshade render` by frame size"),
    Result(OUT + "startup.json", "python -m benchmarks.measure.startup_bench", ("benchmarks/measure/startup_bench.py",),
           (Rendering(OUT + "startup.md", startup_markdown),), "warm robot render, stage by stage"),
    Result(OUT + "view.json", "python -m benchmarks.measure.view_bench --repeats 5", VIEWER,
           (Rendering(OUT + "view.md", view_markdown),
            _region("README.md", "view-table", lambda doc: view_table(doc, "view.json"))),
           "the live viewer's frames/s and latency in headless Chromium"),
    Result(OUT + "view_pocl30.json", "CLSHADE_DEVICE='PoCL 3.0' python -m benchmarks.measure.view_bench --repeats 5 "
                                   "--out benchmarks/results/view_pocl30.json", VIEWER,
           (Rendering(OUT + "view_pocl30.md", view_markdown),
            _region("README.md", "view-pocl30-table", lambda doc: view_table(doc, "view_pocl30.json"))),
           "the same on pip's PoCL 3.0, the PoCL a fresh install gives"),
    Result(OUT + "view_intel.json", "CLSHADE_DEVICE=Intel python -m benchmarks.measure.view_bench --repeats 5 "
                                   "--out benchmarks/results/view_intel.json", VIEWER,
           (Rendering(OUT + "view_intel.md", view_markdown),
            _region("README.md", "view-intel-table", lambda doc: view_table(doc, "view_intel.json"))),
           "the same on Intel's CPU runtime, the install's runtime where pip's PoCL 3.0 builds nothing"),
    Result(OUT + "host_ab.json", "python -m benchmarks.experiments.host_ab", ("benchmarks/experiments/host_ab.py",),
           (Rendering(OUT + "host_ab.md", host_ab_markdown),),
           "host stages and the warm render against main (A/B), whole 1080p frame"),
    Result(OUT + "accuracy.json", "python -m benchmarks.measure.accuracy_table",
           ("kernels", "clshade/verify/accuracy.py", "benchmarks/measure/accuracy_table.py"),
           (Rendering("docs/accuracy.md", accuracy_markdown),), "every term and model against float64"),
    Result(OUT + "floor_bias.json", "python -m benchmarks.measure.floor_bias",
           ("kernels", "clshade/verify/bias.py", "benchmarks/measure/floor_bias.py"),
           (_region("docs/stability.md", "floor-bias", floor_bias_table),
            _region("docs/models.md", "floor-bias", floor_bias_table)), "the bias of every named floor"),
    Result(OUT + "stability.json", "clshade check stability --json > benchmarks/results/stability.json.part && "
           "mv benchmarks/results/stability.json.part benchmarks/results/stability.json",
           ("kernels", "clshade/verify/stability.py", "clshade/verify/torture.py", "clshade/verify/bias.py",
            "clshade/device/evaluate.py", "clshade/device/counts.py"),
           (_region("docs/stability.md", "stability", stability_tables),), "the torture grid, both builds"),
    Result(OUT + "user_lobes.json", "python -m benchmarks.measure.user_lobes",
           ("kernels", "clshade/models/glsl", "clshade/models/brdf_file.py", "benchmarks/measure/user_lobes.py"),
           (Rendering(OUT + "user_lobes.md", user_lobes_markdown),
            _region("docs/user-lobes.md", "user-lobes-example", user_lobes_example),
            _region("docs/user-lobes.md", "user-lobes-table", user_lobes_table)),
           "the sample user lobes beside built-ins"),
    Result(OUT + "glsl_oracle.json", "python -m benchmarks.measure.glsl_oracle",
           ("kernels", "clshade/models/glsl", "clshade/models/brdf_file.py", "clshade/verify/glsl_oracle.py",
            "benchmarks/measure/glsl_oracle.py"),
           (Rendering(OUT + "glsl_oracle.md", glsl_oracle_markdown),),
           "every .brdf file (scenes/lobes, BRDF Explorer's collection) against Mesa's GLSL"),
    Result(OUT + "brdf_explorer.json", "python -m benchmarks.measure.brdf_explorer",
           ("kernels", "clshade/models", "clshade/cli", "clshade/bench/run.py", "clshade/verify/stability.py",
            "clshade/compare.py", "scenes/white_sphere.toml", "benchmarks/measure/brdf_explorer.py"),
           (Rendering(OUT + "brdf_explorer.md", brdf_explorer_markdown),),
           "BRDF Explorer's collection through models, render, bench, check stability and compare"),
    Result(OUT + "mitsuba_envmap.json", "python -m benchmarks.measure.mitsuba_envmap",
           ("clshade/render/environment.py", "clshade/verify/environment_oracle.py", "scenes/environment.toml",
            "scenes/environments", "benchmarks/measure/mitsuba_envmap.py"),
           (Rendering(OUT + "mitsuba_envmap.md", mitsuba_envmap_markdown),),
           "clshade's truth under a sky against Mitsuba 3's envmap emitter (needs pip install mitsuba)"),
    Result(OUT + "mutants.json", "python -m benchmarks.mutation.run",
           ("benchmarks/mutation", "kernels", "clshade", "tests", "scenes", "pyproject.toml"),
           (Rendering(OUT + "mutants.md", mutants_markdown),),
           "the mutation catalogue: the kill class of each mutant and the tests that failed up to its first behavioural kill"),
)

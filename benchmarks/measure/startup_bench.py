"""Warm wall time of `clshade render scenes/robot.toml` end to end, and where it goes
(the target: ≤ 0.6 s on the 2-core development machine).

Usage::

    python -m benchmarks.measure.startup_bench [--repeats 9] [--out benchmarks/results/startup.json]

"Warm": one untimed run first fills PoCL's kernel cache (~/.cache/pocl), clshade's
program-binary and tessellation caches (~/.cache/clshade) and Python's bytecode caches
(the child runs without PYTHONDONTWRITEBYTECODE, as an installed package has its .pyc
files). Then, in interleaved rounds (machine noise hits all alike), three
fresh processes: the interpreter alone (`python -c pass`), the CLI's start-up
(`clshade.cli.process.start_process()`, `import clshade.pipeline` and the argument parser) and the whole render to
a PNG; medians and minima over the rounds. The render's own `stages:` line gives the
per-stage split (median per stage). The machine's load average is recorded: the cores
are shared, so compare runs only with similar load.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.publish.results_io import RESULTS, ROOT, measure_and_write

TARGET_S = 0.6


def timed(cmd: list[str], env: dict[str, str]) -> tuple[float, float, str]:
    """(wall seconds, CPU seconds — user + system, all threads — of the process, stdout).
    CPU time is what a busy shared machine inflates least."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=ROOT)
    stdout, stderr = proc.stdout.read(), proc.stderr.read()     # small outputs: no pipe can fill
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed: {stderr.decode().strip()}")
    return wall, usage.ru_utime + usage.ru_stime, stdout.decode()


def parse_stages(stdout: str) -> dict[str, float]:
    line = next(l for l in stdout.splitlines() if l.startswith("stages:"))
    out = {}
    for part in line.removeprefix("stages: ").split(", "):
        name, value, _ = part.rsplit(" ", 2)
        out[name] = float(value)
    return out


def measure(repeats: int) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    py = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        png = str(Path(tmp) / "robot.png")
        commands = {
            "interpreter": [py, "-c", "pass"],
            # the render process's start-up (clshade.cli.run): its process settings, then the parser
            "imports": [py, "-c", "from clshade.cli import parser, process; process.start_process(); "
                                  "import clshade.pipeline; parser.build_parser()"],
            "render": [py, "-m", "clshade", "render", "scenes/robot.toml", "-o", png],
        }
        for cmd in commands.values():      # warm-up: bytecode and kernel caches
            timed(cmd, env)
        walls: dict[str, list[float]] = {k: [] for k in commands}
        cpus: dict[str, list[float]] = {k: [] for k in commands}
        stages: list[dict[str, float]] = []
        load = [os.getloadavg()[0]]
        for _ in range(repeats):
            for name, cmd in commands.items():
                wall, cpu, stdout = timed(cmd, env)
                walls[name].append(wall)
                cpus[name].append(cpu)
                if name == "render":
                    stages.append(parse_stages(stdout))
            load.append(os.getloadavg()[0])
    names = list(dict.fromkeys(k for s in stages for k in s))
    return {
        "wall_s": {k: {"median": statistics.median(v), "min": min(v), "all": [round(x, 4) for x in v]}
                   for k, v in walls.items()},
        "cpu_s": {k: {"median": statistics.median(v), "min": min(v)} for k, v in cpus.items()},
        "render_stages_ms": {k: statistics.median(s.get(k, 0.0) for s in stages) for k in names},
        "load_average_1min": {"min": min(load), "max": max(load)},
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=9)
    parser.add_argument("--out", default=str(RESULTS / "startup.json"))
    args = parser.parse_args()
    measure_and_write(args.out, lambda: {"repeats": args.repeats, "target_s": TARGET_S, **measure(args.repeats)})
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Regenerate docs/models.md from the kernel headers (clshade.models), with the accuracy
table, the plausibility table and the named clamps with their measured bias.

    python benchmarks/models_doc.py [--out docs/models.md]

Nothing here repeats model metadata: the lobe sections come from the
`/*! clshade-model` headers of kernels/models/*.cl, the clamps from the commented
#defines of kernels/brdf.h.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from accuracy_table import accuracy_lines  # noqa: E402
from clshade.verify import accuracy as A  # noqa: E402
from clshade.verify import plausibility as P
from clshade.verify import reference as R
from clshade.device.evaluate import Samples, constant_materials, eval_brdf  # noqa: E402
from clshade.models import GROUPS, Model, lobes, presets  # noqa: E402


def lobe_sections() -> list[str]:
    out: list[str] = []
    for kind in ("diffuse", "specular"):
        out += [f"## {kind.capitalize()} lobes", ""]
        for lobe in (l for l in lobes().values() if l.kind == kind):
            out += [f"### {lobe.name} (`{lobe.id}`, {lobe.family})", "",
                    "| | |", "|---|---|", f"| formula | {lobe.formula} |", f"| source | {lobe.source} |",
                    f"| inputs | {', '.join(sorted(lobe.uses)) or '–'} |",
                    f"| file | kernels/models/{lobe.path.name} |", ""]
            if lobe.params:
                out += ["| parameter | min | max | default | meaning |", "|---|---|---|---|---|"]
                out += [f"| {p.name} | {p.low:g} | {p.high:g} | {p.default:g} | {p.description} |" for p in lobe.params]
                out.append("")
            out += [f"- Deviation from the study's appendix: {d}" for d in lobe.deviations]
            out += [f"- Note: {n}" for n in lobe.notes]
            out.append("")
    return out


def _ggx_f1(count: int, n_dot_v: float, rng: np.random.Generator):
    """Kernel and reference GGX-correlated lobe (F = 1) with v at the given cosine."""
    mu = rng.uniform(A.MIN_COSINE, 1.0, count)
    phi = rng.uniform(0.0, 2.0 * math.pi, count)
    s = np.sqrt(1.0 - mu * mu)
    l = A.f32(np.stack([s * np.cos(phi), s * np.sin(phi), mu], axis=1))
    v = A.f32(np.broadcast_to([math.sqrt(1.0 - n_dot_v ** 2), 0.0, n_dot_v], (count, 3)))
    n = np.broadcast_to([0.0, 0.0, 1.0], (count, 3))
    r = A.f32(rng.uniform(A.MIN_ROUGHNESS, 1.0, count))
    samples = Samples(n, l, v, np.ones((count, 3)), r, np.ones(count), constant_materials(count))
    f = eval_brdf(Model("none", "ggx_correlated"), samples)[:, 0]
    g = R.brdf("none", "ggx_correlated", n, l, v, base_color=1.0, roughness=r, metallic=1.0,
               alpha_floor=A.constant("MIN_ALPHA"))[:, 0]
    return f, g


def clamp_bias() -> dict[str, str]:
    """Measured bias of each named clamp, where it acts."""
    rng = np.random.default_rng(3)
    out: dict[str, str] = {}
    f, g = _ggx_f1(20000, 1e-6, rng)
    ratio = np.max(np.abs(f - g) / np.maximum(g, 1e-30))
    out["MIN_N_DOT_V"] = (f"none for n·v ≥ 1e-4; at n·v = 1e-6 the GGX-correlated lobe (F = 1) differs from the "
                          f"reference by at most {ratio:.1e} relative (V stays finite as n·v → 0)")
    out["MIN_N_DOT_L"] = "as MIN_N_DOT_V by reciprocity (the same floor value on both cosines keeps f reciprocal)"
    a, err = P.albedo(Model("none", "ggx_correlated"), P.Setting(roughness=0.0, metallic=1.0), levels=16)
    out["MIN_ALPHA"] = (f"r < 0.01 renders as r = 0.01; albedo of GGX-correlated (F = 1, v = n) at the floor "
                        f"= {a:.6f} (quadrature error {err:.0e}) against 1 for the ideal mirror: energy bias "
                        f"{1.0 - a:.1e}")
    nh = A.f32(rng.uniform(0.0, A.constant("MIN_N_DOT_H_BECKMANN"), 20000))
    m = A.f32(rng.uniform(A.constant("MIN_ALPHA"), 1.0, 20000))
    x = np.zeros((20000, 4), np.float32)
    x[:, 0], x[:, 1], x[:, 2] = nh, (1.0 - nh) * (1.0 + nh), m
    d = A.eval_term("D_Beckmann", x, np.zeros_like(x), np.zeros_like(x))[:, 0]
    bias = np.max(np.abs(d - R.d_beckmann(nh, m)) * math.pi * m * m)
    out["MIN_N_DOT_H_BECKMANN"] = f"max |ΔD| / D_peak = {bias:.1e} for n·h < 1e-3, m ≤ 1"
    exps = np.array([0.0, 0.01, 0.1, 0.5, 1.0, 2.0], np.float32)
    x = np.zeros((len(exps), 4), np.float32)
    x[:, 1] = exps
    p = A.eval_term("Fs_Phong", x, np.zeros_like(x), np.zeros_like(x))[:, 0]
    bias = np.abs(p - R.phong(np.zeros(len(exps)), exps))
    out["MIN_POW_BASE"] = ("|kernel 0ⁿ − exact| at n = " + ", ".join(f"{e:g}: {b:.1e}" for e, b in zip(exps, bias))
                           + " (the header's ≤ 1e-15 holds for n ≥ 0.5 only; exponents below 1 are "
                             "degenerate materials)")
    out["MIN_HALF_LEN2"] = ("acts only when n·l and n·v are both below 1e-15; "
                            "no sample of the accuracy tests reaches it (bias 0 there)")
    return out


def clamp_lines() -> list[str]:
    bias = clamp_bias()
    lines = ["| constant | value | file | why (from the header) | measured bias |", "|---|---|---|---|---|"]
    for c in A.kernel_constants().values():
        if c.name.startswith("MIN_"):
            lines.append(f"| {c.name} | {c.value:g} | kernels/{c.file} | {c.comment} | {bias.get(c.name, '–')} |")
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "models.md"))
    args = parser.parse_args()
    start = time.perf_counter()
    preset_lines = ["| preset | name | diffuse | specular | family | workflow |", "|---|---|---|---|---|---|"]
    preset_lines += [f"| {m.id} | {m.label} | {m.diffuse} | {m.specular} | {m.family} | {m.workflow} |"
                     for m in presets()]
    verdicts = P.evaluate_presets()
    lines = ["# Lighting models", "",
             "Generated by `python benchmarks/models_doc.py` from the `/*! clshade-model` headers of "
             "kernels/models/*.cl; do not edit by hand.", "",
             "## Presets (the study's shaders)", "", *preset_lines, "",
             "Groups: " + "; ".join(f"{k}: {', '.join(v)}" for k, v in GROUPS.items()), "",
             *lobe_sections(),
             "## Accuracy against the float64 reference", "", *accuracy_lines(), "",
             "## Physical plausibility (measured on the device: `clshade check plausibility`)", "",
             *P.table(verdicts), "", *[f"- {x}" for x in P.describe_method()], "",
             "## Named clamps and their measured bias", "", *clamp_lines(), ""]
    Path(args.out).write_text("\n".join(lines), encoding="utf-8")
    print(f"wrote {args.out} in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

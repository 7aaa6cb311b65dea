"""Stability and bias as text: what `clshade check stability` prints for a Report, and the tables
docs/stability.md and docs/models.md publish from stability.json and floor_bias.json."""
from __future__ import annotations

from clshade.report.tables import MISSING, cell, escape, markdown
from clshade.verify.stability import DEVIATION_COSINE, DEVIATION_FLOOR, Report


def stability_text(rep: Report) -> str:
    """What `clshade check stability` prints for a clshade.verify.stability.Report."""
    d = rep.as_dict()
    raw = d["raw_radiance"]
    per_build = ", ".join(f"{k} {v}" for k, v in d["distinct_inputs"].items())
    lines = [f"device: {rep.device}",
             f"evaluations: {rep.cases} over {len(d['builds'])} builds ({', '.join(d['builds'])}); "
             f"distinct inputs per build: {per_build}",
             f"BRDF NaN/Inf: {sum(r.nonfinite for r in rep.results)}, negative: {sum(r.negative for r in rep.results)} "
             "(must be 0)",
             f"shaded pixels, raw radiance (no MAX_RADIANCE clamp): NaN {raw['nan']}, Inf {raw['inf']}, "
             f"negative {raw['negative']}; saturated (≥ MAX_RADIANCE {raw['max_radiance_clamp']:.3g}) "
             f"{raw['saturated_pixels']}; largest finite {raw['max_radiance']:.3g}; shipped build NaN/Inf "
             f"{raw['clamped_build_nonfinite']}", "",
             f"largest deviation from the float64 reference, |f32 − f64| / max(|f64|, {DEVIATION_FLOOR:g}):"]
    rows = []
    for r in rep.results:
        at = r.max_deviation_at
        where = ", ".join(f"{k}={at[k]}" for k in ("n.l", "n.v", "azimuth", "normal", "roughness_label", "base",
                                                    "metallic", "f90", "ior", "eta_label", "shininess") if k in at)
        rows.append([r.model, "fast" if r.fast_math else "precise", r.cases, r.distinct_inputs,
                     f"{r.max_deviation:.2e}", f"{r.max_deviation_unclamped:.2e}", where])
    lines.append(markdown(["model", "build", "cases", "distinct", "all", "cos ≥ 1e-4", "where (all)"], rows))
    bad = [f"  BAD {r.model} ({'fast' if r.fast_math else 'precise'}): {r.first_bad}" for r in rep.results if r.first_bad]
    lines += bad
    if rep.shading:
        lines += ["", "shading pass, raw radiance (lights 0, 1e-30, 1e30: 4 directional, a point light on the "
                  f"surface, a point, a spot; ambient); deviation vs the frame oracle at unit lights, "
                  f"n·l and n·v ≥ {DEVIATION_COSINE:g}:",
                  markdown(["model", "build", "pixels", "distinct", "NaN", "Inf", "negative", "saturated",
                            "shipped NaN/Inf", "max radiance", "vs oracle", "compared"],
                           [[s.model, "fast" if s.fast_math else "precise", s.pixels, s.distinct_inputs, s.nan, s.inf,
                             s.negative, s.saturated, s.clamped_nonfinite, f"{s.max_radiance:.3g}",
                             f"{s.max_deviation:.2e}", s.deviation_pixels] for s in rep.shading])]
    if rep.clamps:
        lines += ["", "clamp bias (precise build, against the unclamped float64 reference):",
                  markdown(["clamp", "value", "active when", "bias", "measure", "worst"],
                           [[c["clamp"], f"{c['value']:g}", c["active"], f"{c['bias']:.3g}", c["measure"], c["worst"]]
                            for c in rep.clamps])]
    if rep.continuity:
        lines += ["", "continuity near the limits:",
                  markdown(["model", "check", "max relative step", "where"],
                           [[c["model"], c["check"], f"{c['max_relative_step']:.3g}", c["where"]]
                            for c in rep.continuity])]
    if rep.environment:
        from clshade.verify.environment_stability import summary
        env = summary(rep.environment)
        lines += ["", f"environment (precise build, raw radiance): NaN {env['nan']}, Inf {env['inf']}, negative "
                  f"{env['negative']} (must be 0); shipped build NaN/Inf {env['clamped_nonfinite']}; fireflies "
                  f"{env['fireflies']} of {env['firefly_pixels']} pixels ({env['firefly_definition']}); pixels above "
                  f"the sky's peak {env['above_peak']}:",
                  markdown(["model", "sky", "rung", "N", "pixels", "NaN", "Inf", "negative", "shipped NaN/Inf",
                            "max radiance", "fireflies", "above peak"],
                           [[e.model, e.sky, e.rung, "—" if e.samples is None else e.samples, e.pixels, e.nan, e.inf,
                             e.negative, e.clamped_nonfinite, f"{e.max_radiance:.3g}",
                             "—" if e.fireflies is None else f"{e.fireflies}/{e.firefly_pixels}", e.above_peak]
                            for e in rep.environment])]
    terms = rep.terms()
    if terms:
        lines += ["", "raw terms in the counting build (kernels/count.h), before any clamp; every model and build:",
                  markdown(["term", *next(iter(terms.values()))], [[t, *c.values()] for t, c in terms.items()])]
    failures = rep.failures()
    lines += [""] + [f"  FAIL {f}" for f in failures]
    lines += [f"{'OK' if not failures else 'FAILED'} in {rep.seconds:.1f} s"]
    return "\n".join(lines)


def floor_bias_table(doc: dict) -> str:
    """The measured bias of every named floor (floor_bias.json), and where it comes from."""
    table = markdown(["floor", "value", "active when", "cases", "measured bias", "measure", "worst case"],
                     [[f"`{r['clamp']}`", f"{r['value']:g}", r["active"], r["cases"], f"{r['bias']:.3g}", r["measure"],
                       r["worst"]] for r in doc["floors"]])
    return "\n".join([table, "", f"*From benchmarks/results/floor_bias.json (measured {doc['created']} by "
                                 f"`{doc['command']}`, device `{doc['device']}`).*"])


def stability_tables(doc: dict) -> str:
    """docs/stability.md's results region from `clshade check stability --json` (stability.json)."""
    raw = doc["raw_radiance"]
    builds = ", ".join(f"{b}: {n:,}" for b, n in doc["distinct_inputs"].items())
    prov = doc.get("provenance") or {}
    verdict = ("**Passed**" if doc["ok"] else "**Failed**: " + "; ".join(escape(f) for f in doc.get("failures", []))) \
        + (f" (tolerance of the precise build: {doc['precise_tolerance']:g})" if "precise_tolerance" in doc else "")
    out = [f"Device `{doc['device']}`; commit {(prov.get('commit') or '')[:10] or 'not recorded'}"
           f"{' (uncommitted changes)' if prov.get('dirty') else ''}; {doc['cases']:,} evaluations and shaded "
           f"pixels over the builds ({', '.join(doc['builds'])}); distinct inputs per build: {builds}. {verdict}.", "",
           markdown(["count (raw radiance, before the MAX_RADIANCE clamp)", "value"], [
               ["NaN", raw["nan"]], ["Inf", raw["inf"]], ["negative", raw["negative"]],
               [f"pixels reaching MAX_RADIANCE ({raw['max_radiance_clamp']:g})", raw["saturated_pixels"]],
               ["largest finite raw radiance", f"{raw['max_radiance']:.3g}"],
               ["NaN/Inf in the shipped (clamped) build", raw["clamped_build_nonfinite"]],
               ["BRDF evaluations: NaN/Inf, negative", f"{doc['nonfinite']}, {doc['negative']}"]]), ""]
    if doc.get("raw_terms"):
        checks = list(next(iter(doc["raw_terms"].values())))
        out += ["Raw terms in the counting build (kernels/count.h: each value checked where it is computed, "
                "before any clamp), every model, build and pass:", "",
                markdown(["term", *checks], [[t, *(f"{c[k]:,}" for k in checks)] for t, c in doc["raw_terms"].items()]),
                ""]
    shaded = {(s["model"], s["fast_math"]): s for s in doc["shading"]}
    rows = []
    for m in doc["models"]:
        s = shaded.get((m["model"], m["fast_math"]), {})
        rows.append([m["model"], "fast" if m["fast_math"] else "precise", f"{m['cases']:,}",
                     f"{m['distinct_inputs']:,}", cell(m["max_deviation"], ".2e"), cell(m.get("max_deviation_unclamped"), ".2e"),
                     s.get("pixels", MISSING), cell(s.get("max_deviation"), ".2e")])
    out += ["Largest deviation from the float64 reference, |f32 − f64| / max(|f64|, 0.001): BRDF evaluations "
            "(all inputs; cosines ≥ 1e-4 and no floor active) and shaded pixels against the frame oracle:", "",
            markdown(["model", "build", "evaluations", "distinct", "max dev (all)", "max dev (no floor)",
                      "shaded pixels", "max dev (shaded)"], rows)]
    out += ["", "Continuity:", ""] + [f"- {c['model']}, {escape(c['check'])}: largest relative step "
                                       f"{c['max_relative_step']:.3g} ({escape(c['where'])})" for c in doc["continuity"]]
    out += ["", f"*From benchmarks/results/stability.json (measured {doc['created']} by "
                f"`clshade check stability --json`, {doc['seconds']:.0f} s).*"]
    return "\n".join(out)

"""`clshade check plausibility` verdicts (clshade.verify.plausibility.Verdict) as a Markdown table."""
from __future__ import annotations

from dataclasses import fields

from clshade.report.tables import markdown
from clshade.verify.plausibility import Verdict

HEADER = ("preset", "family", "min f", "max reciprocity err", "max albedo per lobe (at)", "composed albedo (at)",
          "quadrature err", "non-neg", "reciprocal", "energy", "physically based")


def plausibility_table(verdicts: list[Verdict]) -> str:
    """The plausibility table, physically based models first."""
    yes = lambda b: "yes" if b else "**no**"   # noqa: E731
    return markdown(HEADER, [
        [v.preset, v.family, f"{v.min_f:.3g}", f"{v.max_reciprocity_error:.1e}",
         "; ".join(f"{k} {a:.5f} ({at})" for k, (a, at) in v.lobes.items()),
         f"{v.composed_albedo:.5f} ({v.composed_albedo_at})", f"{v.quadrature_error:.1e}", yes(v.non_negative),
         yes(v.reciprocal), yes(v.energy_conserving), yes(v.physically_based)]
        for v in sorted(verdicts, key=lambda v: (not v.physically_based, v.family, v.preset))])


def verdicts_of(rows: list[dict]) -> list[Verdict]:
    """Verdicts back from their JSON rows (Verdict.as_dict)."""
    names = {f.name for f in fields(Verdict)}
    return [Verdict(**{k: (v if k != "lobes" else {a: tuple(b) for a, b in v.items()})
                       for k, v in row.items() if k in names}) for row in rows]

"""`clshade check stability` must see a bad term even where a clamp would hide it: a NaN,
an Inf and a negative value forced into one term of a patched copy of the kernels
(F_Dielectric's reflectance before its saturate, the conductor's before its clamp) each
fail the check, counted on that term."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import clshade.device.variants as variants
from clshade.models import resolve
from clshade.resources import kernels_dir
from clshade.verify import stability

# (file, original text, replacement, model whose shading reaches it, term, what is counted)
INJECTIONS = {
    "nan": ("brdf.h", "real f = 0.5f * a * a * (1.0f + b * b);", "real f = NAN;",
            "ggx_correlated@dielectric", "F", "nan"),
    "inf": ("brdf.h", "return clamp(0.5f * (rp + rs), 0.0f, 1.0f);", "return clamp(INFINITY, 0.0f, 1.0f);",
            "ggx_correlated@conductor", "F", "inf"),
    "negative": ("brdf.h", "real f = 0.5f * a * a * (1.0f + b * b);", "real f = -0.5f * a * a * (1.0f + b * b);",
                 "cook_torrance@dielectric", "F", "negative"),
}


def patched_kernels(tmp_path: Path, monkeypatch, file: str, old: str, new: str) -> None:
    """A copy of kernels/ with one edit, used by every program built from now on."""
    root = tmp_path / "kernels"
    shutil.copytree(kernels_dir(), root)
    text = (root / file).read_text(encoding="utf-8")
    assert text.count(old) == 1, f"{file}: the injection site {old!r} is gone"
    (root / file).write_text(text.replace(old, new), encoding="utf-8")
    monkeypatch.setattr(variants, "kernels_dir", lambda: root)


@pytest.mark.parametrize("kind", sorted(INJECTIONS))
def test_injected_term_fails_check_stability(kind: str, tmp_path: Path, monkeypatch) -> None:
    file, old, new, spec, term, count = INJECTIONS[kind]
    patched_kernels(tmp_path, monkeypatch, file, old, new)
    rep = stability.run([resolve(spec)], fast_math=(False,), extras=False)
    assert not rep.ok, f"a {kind} {term} term passed `check stability`"
    shaded = rep.shading[0].terms[term]
    assert shaded[count] > 0, f"shading pass: {term} {count} not counted: {shaded}"

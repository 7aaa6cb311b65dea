"""`clshade check stability` must see a bad term even where a clamp would hide it: a NaN,
an Inf and a negative value forced into one term of a patched copy of the kernels
(F_Dielectric's reflectance before its saturate, the conductor's before its clamp) each
fail the check, counted on that term in the counting build of the shading kernel
(kernels/count.h); a finite, in-range but wrong term fails it by its deviation from float64."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import clshade.device.variants as variants
from clshade.device import counts
from clshade.models.registry import Registry
from clshade.resources import kernels_dir
from clshade.verify import stability

resolve = Registry().resolve          # the built-in lobes

# (file, original text, replacement, model whose shading reaches it, term, what is counted)
INJECTIONS = {
    "nan": ("brdf.h", "real f = 0.5f * a * a * (1.0f + b * b);", "real f = NAN;",
            "ggx_correlated@dielectric", "F", "nan"),
    "inf": ("brdf.h", "return 0.5f * (rp + rs);", "return INFINITY;",
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
    rep = stability.run([resolve(spec)], fast_math=(False,), extras=False, brdf=False)
    assert not rep.ok, f"a {kind} {term} term passed `check stability`"
    shaded = rep.shading[0].terms[term]
    assert shaded[count] > 0, f"shading pass: {term} {count} not counted: {shaded}"
    assert any(f"raw {term} " in f and count in f for f in rep.failures()), rep.failures()


def test_wrong_but_finite_term_fails_by_its_deviation(tmp_path: Path, monkeypatch) -> None:
    """Half the dielectric reflectance: finite, in [0, 1], so no counter sees it; the
    shaded pixels' deviation from the float64 oracle fails the check."""
    patched_kernels(tmp_path, monkeypatch, "brdf.h", "real f = 0.5f * a * a * (1.0f + b * b);",
                    "real f = 0.25f * a * a * (1.0f + b * b);")
    rep = stability.run([resolve("ggx_correlated@dielectric")], fast_math=(False,), extras=False, brdf=False)
    assert not counts.failures(rep.terms()), counts.failures(rep.terms())
    assert any("deviation from float64" in f for f in rep.failures()), rep.failures()


def test_raw_inf_radiance_alone_fails_the_report() -> None:
    """A raw +Inf pixel (overflow of the sum) fails the check as a NaN would: docs/stability.md
    promises no Inf."""
    shaded = stability.ShadeResult("lambert", False, pixels=10, inf=1, deviation_pixels=10)
    rep = stability.Report([], [shaded], [], [], "device", 0.0)
    assert not rep.ok and any("NaN/Inf" in f for f in rep.failures())
    assert stability.Report([], [stability.ShadeResult("lambert", False, pixels=10)], [], [], "device", 0.0).ok


def test_raw_term_counts_alone_fail_the_report() -> None:
    """A term counted NaN in the counting build fails the check even when every output is
    finite and accurate (a clamp downstream hid it)."""
    hidden = stability.ShadeResult("lambert", False, pixels=10, deviation_pixels=10,
                                   terms={"F": {"evaluated": 10, "nan": 1, "inf": 0, "negative": 0, "above": 0}})
    rep = stability.Report([], [hidden], [], [], "device", 0.0)
    assert not rep.ok and rep.failures() == ["lambert (precise, shaded): raw F nan 1"]


def test_above_bound_fails_the_precise_build_only() -> None:
    """A term above its bound fails the precise build; in a fast-math build (approximate rsqrt
    and division) it is reported, not failed — NaN, Inf and negative fail both."""
    def shaded(fast: bool, check: str):
        row = {"evaluated": 10, "nan": 0, "inf": 0, "negative": 0, "above": 0, check: 1}
        return stability.ShadeResult("lambert", fast, pixels=10, deviation_pixels=10, terms={"D": row})
    report = lambda r: stability.Report([], [r], [], [], "device", 0.0)  # noqa: E731
    assert not report(shaded(False, "above")).ok and report(shaded(True, "above")).ok
    assert not report(shaded(True, "nan")).ok and not report(shaded(True, "negative")).ok


def test_a_fast_build_nonzero_where_the_reference_is_zero_fails() -> None:
    """Fast math's deviation is reported, not bounded, but a fast build that takes another branch
    (NVIDIA's flushed denormal shininess: Phong's 0ⁿ as 1 where the reference is 0, as on an
    H100) fails the check: here the fast build of a patched brdf.h reads every shininess as 0."""
    import tempfile

    with tempfile.TemporaryDirectory() as folder, pytest.MonkeyPatch.context() as monkeypatch:
        patched_kernels(Path(folder), monkeypatch, "brdf.h", "{ return fabs(n) < MIN_SHININESS; }",
                        "{ return fabs(n) < (FAST_FLUSHES_ALL ? INFINITY : MIN_SHININESS); }")
        text = (Path(folder) / "kernels" / "brdf.h").read_text(encoding="utf-8")
        (Path(folder) / "kernels" / "brdf.h").write_text(text.replace(
            "#define CLSHADE_BRDF_H\n", "#define CLSHADE_BRDF_H\n#ifdef __FAST_RELAXED_MATH__\n"
            "#define FAST_FLUSHES_ALL 1\n#else\n#define FAST_FLUSHES_ALL 0\n#endif\n", 1), encoding="utf-8")
        rep = stability.run([resolve("phong")], extras=False, shading=False)
    precise, fast = sorted(rep.results, key=lambda r: r.fast_math)
    assert precise.nonzero_where_zero == 0 and fast.nonzero_where_zero > 0, (precise, fast)
    assert any("(fast, BRDF)" in f and "reference is exactly 0" in f for f in rep.failures()), rep.failures()

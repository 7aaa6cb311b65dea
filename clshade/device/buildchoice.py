"""The image kernels' build choices: the lanes, math builtins, stores, prefetch and work-group
size a kernel is built with (BuildChoice), today's fixed rule (FIXED), and the environment's
switches over a choice (`forced`). The tuner (clshade/device/tune.py) measures choices; the
runtime (clshade/device/runtime.py) builds with them."""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, fields, replace

from clshade.errors import ClshadeError

# Lanes per work-item the kernels support (kernels/simd.h); buffers are padded to a multiple of
# the largest (clshade.render.arrays.PIXEL_PAD, shared with the G-buffer's planes).
SIMD_WIDTHS = ("1", "4", "8", "16")
ENV_SIMD = "CLSHADE_SIMD"
# kernels/simd.h writes the hot builtins inline where PoCL's AVX-512 builtin library meets a
# compiler target without AVX-512 (see there). Switches: CLSHADE_LIBRARY_MATH=1 never,
# CLSHADE_INLINE_MATH=1 always.
ENV_LIBRARY_MATH = "CLSHADE_LIBRARY_MATH"
ENV_INLINE_MATH = "CLSHADE_INLINE_MATH"
LIBRARY_MATH = "-DCLSHADE_LIBRARY_MATH"
INLINE_MATH = "-DCLSHADE_INLINE_MATH_FORCE"
# kernels/simd.h writes the image rows with streaming (non-temporal) stores on x86 with AVX (see
# STORE_ROW8 there). CLSHADE_CACHED_STORES=1 keeps plain stores.
ENV_CACHED_STORES = "CLSHADE_CACHED_STORES"
CACHED_STORES = "-DCLSHADE_CACHED_STORES"
# shade.cl and copy.cl prefetch the G-buffer lines of the work-items ahead on x86 (kernels/gbuffer.h,
# PREFETCH_AHEAD). CLSHADE_NO_PREFETCH=1 leaves the hint out.
ENV_NO_PREFETCH = "CLSHADE_NO_PREFETCH"
NO_PREFETCH = "-DCLSHADE_NO_PREFETCH"
# kernels/simd.h gathers with AVX2's vgatherdps where the kernel compiles for AVX2 (PoCL on x86), one
# instruction per 8 lanes. CLSHADE_SCALAR_GATHER=1 loads lane by lane instead (for a CPU whose gathers
# are slow, as under Intel's Gather Data Sampling mitigation).
ENV_SCALAR_GATHER = "CLSHADE_SCALAR_GATHER"
SCALAR_GATHER = "-DCLSHADE_SCALAR_GATHER"
# The work-group size of every dispatch (the kernels use no local memory and guard the tail of a
# padded global size, so any size runs them). CLSHADE_LOCAL_SIZE=N forces one.
LOCAL_SIZE = 64
ENV_LOCAL_SIZE = "CLSHADE_LOCAL_SIZE"
MATH_CHOICES = ("auto", "library", "inline")
STORE_CHOICES = ("streaming", "plain")


@dataclass(frozen=True)
class BuildChoice:
    """The image kernels' build choices on a device. The defaults are today's rule (FIXED): `math`
    "auto" (simd.h writes the builtins inline only where PoCL's AVX-512 builtin library meets a
    target without AVX-512; "library" / "inline" force either way), streaming `stores` and the
    G-buffer `prefetch` where the compiler targets x86 (simd.h; "plain" / False leave them out),
    `lanes` per work-item None = the device's rule (`Runtime.native_simd` on CPUs, 1 on GPUs) and
    `local` work-group size None = LOCAL_SIZE (at most the device's maximum)."""
    math: str = "auto"
    stores: str = "streaming"
    prefetch: bool = True
    lanes: int | None = None
    local: int | None = None

    def __post_init__(self) -> None:
        if self.math not in MATH_CHOICES or self.stores not in STORE_CHOICES or not isinstance(self.prefetch, bool):
            raise ValueError(f"build choice {self!r}: math one of {MATH_CHOICES}, stores one of {STORE_CHOICES}")
        if self.lanes is not None and str(self.lanes) not in SIMD_WIDTHS:
            raise ValueError(f"build choice lanes={self.lanes!r}: expected one of {', '.join(SIMD_WIDTHS)}")
        if self.local is not None and not (isinstance(self.local, int) and self.local >= 1):
            raise ValueError(f"build choice local={self.local!r}: expected a positive work-group size")

    def options(self) -> tuple[str, ...]:
        """The build options that make this choice (none for FIXED)."""
        return (((LIBRARY_MATH,) if self.math == "library" else (INLINE_MATH,) if self.math == "inline" else ())
                + ((CACHED_STORES,) if self.stores == "plain" else ())
                + ((NO_PREFETCH,) if not self.prefetch else ()))

    def changes(self, other: "BuildChoice | None" = None) -> tuple[str, ...]:
        """The fields that differ from `other` (default FIXED), in field order."""
        other = FIXED if other is None else other
        return tuple(f.name for f in fields(self) if getattr(self, f.name) != getattr(other, f.name))

    def label(self) -> str:
        """What the choice changes from today's rule (`math inline, plain stores, 16 lanes`), or "today's rule"."""
        names = {"math": f"math {self.math}", "stores": f"{self.stores} stores",
                 "prefetch": "prefetch" if self.prefetch else "no prefetch",
                 "lanes": f"{self.lanes} lanes", "local": f"work-group {self.local}"}
        return ", ".join(names[k] for k in self.changes()) or "today's rule"

    def as_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, doc: dict) -> "BuildChoice":
        """The choice a cache entry or results file holds; ValueError / TypeError when it is not one."""
        if not isinstance(doc, dict) or set(doc) != {f.name for f in fields(cls)}:
            raise ValueError(f"not a build choice: {doc!r}")
        return cls(**doc)


#: Today's rule: what every device gets with tuning off, and the default the tuner must beat.
FIXED = BuildChoice()


def forced(choice: BuildChoice) -> tuple[BuildChoice, tuple[str, ...]]:
    """`choice` with the environment's switches applied over it, and the switches that changed
    it: CLSHADE_LIBRARY_MATH=1 / CLSHADE_INLINE_MATH=1 (library wins where both are set, as in
    simd.h), CLSHADE_CACHED_STORES=1, CLSHADE_NO_PREFETCH=1, CLSHADE_LOCAL_SIZE=N. CLSHADE_SIMD is
    read where the lanes are (`Runtime.simd`), as before."""
    changes: dict[str, object] = {}
    if flag(ENV_LIBRARY_MATH):
        changes["math"] = "library"
    elif flag(ENV_INLINE_MATH):
        changes["math"] = "inline"
    if flag(ENV_CACHED_STORES):
        changes["stores"] = "plain"
    if flag(ENV_NO_PREFETCH):
        changes["prefetch"] = False
    text = os.environ.get(ENV_LOCAL_SIZE, "").strip()
    if text:
        if not text.isdigit() or int(text) < 1:
            raise ClshadeError(f"{ENV_LOCAL_SIZE}={text!r}: expected a positive work-group size")
        changes["local"] = int(text)
    names = {"math": ENV_LIBRARY_MATH if flag(ENV_LIBRARY_MATH) else ENV_INLINE_MATH, "stores": ENV_CACHED_STORES,
             "prefetch": ENV_NO_PREFETCH, "local": ENV_LOCAL_SIZE}
    return replace(choice, **changes), tuple(names[k] for k in changes)


def flag(name: str) -> bool:
    """Whether the environment switch `name` is on (set, and not "0")."""
    return os.environ.get(name, "").strip() not in ("", "0")

"""What the float64 oracle states on its own: its epsilons, the kernels' documented constants and the
lobe families, written here and never read from kernels/ (tests/verify/test_oracle_constants.py compares
each with the kernels' and the model registry's)."""
from __future__ import annotations

import math

from clshade.models.model import NONE

# A vector shorter than this is treated as zero length: its squared length
# (<= 1e-300) is at the bottom of the normal float64 range (~2.2e-308), so its
# direction cannot be recovered reliably.  Unit l + v shorter than this means
# l == -v to rounding.
EPS_LENGTH: float = 1e-150

# Oren-Nayar: if the tangent-plane projection of l or v (= sin(theta)) is
# shorter than this, the azimuth is undefined and the B term is set to 0.  The
# dropped term is <= B * sin(alpha) * tan(beta) <= ~1e-12, so this is
# continuous to that level.
EPS_TANGENT: float = 1e-12

# Schlick F0 of a generic dielectric (IOR ~1.5) in the metallic workflow.
DIELECTRIC_F0: float = 0.04

INV_PI: float = 1.0 / math.pi

# ---- what the oracle states on its own (never read from kernels/) ----------
# The kernels' documented constants and model composition (the lobe families here, uses_fresnel
# in compose.py), written here so that a
# wrong value on the kernel side is not inherited by the truth it is checked against;
# tests/verify/test_oracle_constants.py compares each with the kernels' (and the model
# registry's) and fails on any difference, so a change on one side shows.

# shade.cl MIN_LIGHT_DIST2: a point or spot light's squared distance is floored here
# (a light on the surface shades finitely).
MIN_LIGHT_DIST2: float = 1e-8
# brdf.h MIN_ALPHA: the documented floor of α = r² (roughness below 0.01 renders as
# 0.01); radiance() applies it unless given another alpha_floor.
MIN_ALPHA: float = 1e-4
# brdf.h MIN_SHININESS: FLT_MIN. A shininess below it reads as 0 (0⁰ = 1 behind Phong's mirror),
# as it must in a build that flushes denormals; surface_args() applies it (kernel_shininess).
MIN_SHININESS: float = 1.17549435e-38
# shadow.h: the shadow lookup moves the point (PCF radius + SHADOW_NORMAL_OFFSET_TEXELS)
# texels along its normal and compares its depth less SHADOW_BIAS_TEXELS texels.
SHADOW_NORMAL_OFFSET_TEXELS: float = 1.0
SHADOW_BIAS_TEXELS: float = 0.5

# The lobes with a float64 formula here, by family (kernels/models/*.cl declare kind and
# family), and the lobes whose f_s carries a Fresnel factor (their `uses: fresnel`).
DIFFUSE_MODELS: tuple[str, ...] = ("burley", "lambert", "oren_nayar", NONE)
MICROFACET_MODELS: tuple[str, ...] = ("cook_torrance", "ggx_correlated", "ggx_smith_schlick", "walter_ggx")
EMPIRICAL_MODELS: tuple[str, ...] = ("blinn_phong", "blinn_phong_normalized", "phong", "phong_normalized")
SPECULAR_MODELS: tuple[str, ...] = EMPIRICAL_MODELS + MICROFACET_MODELS + ("none",)
FRESNEL_LOBES: frozenset[str] = frozenset(MICROFACET_MODELS)

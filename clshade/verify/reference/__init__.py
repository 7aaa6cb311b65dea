"""Independent float64 NumPy reference of every BRDF term and model in clshade.

Written from the papers, not from the OpenCL kernels, so that the float32
kernels can be checked against it (target: 1e-4 relative).  Everything is
vectorised over leading array dimensions and evaluated in float64.

Conventions
-----------
* Directions ``n``, ``l``, ``v`` are ``(..., 3)`` arrays pointing *away* from
  the surface; they need not be normalised (they are normalised here).  A
  zero-length vector (length <= :data:`EPS_LENGTH`) makes the result 0, never
  NaN.  All cosines are dot products of the normalised vectors.
* ``l`` or ``v`` below the surface (``n.l <= 0`` or ``n.v <= 0``) gives f = 0.
* Half vector ``h = normalize(l + v)``; if ``|l + v| = 0`` the specular terms
  are 0.
* ``roughness`` r in [0, 1] is perceptual; ``alpha = r**2``.  The reference
  evaluates alpha *as given*; the only floor is the ``alpha_floor`` argument,
  applied in one place, :func:`alpha_from_roughness` (``max(r**2, floor)``,
  default 0 = no floor).  Callers comparing with kernels pass the kernels'
  floor (e.g. ``MIN_ALPHA``).  The floored alpha is used by every alpha-based
  term (D, G, Burley's F90).  Oren-Nayar uses ``sigma = r`` (radians, not
  squared, not floored).
* ``shininess`` n is used as given (``0**0 = 1``); :func:`surface_args`, the kernels'
  reading of a material, takes ``|n| < MIN_SHININESS`` (FLT_MIN) as 0, as a build
  that flushes denormals must.
* f is the BRDF *without* the cosine: outgoing radiance for one light is
  ``L = f * (n.l) * E``.
* At alpha = 0 the microfacet lobes are a Dirac delta: D (and so the lobe) is
  0 everywhere except exactly at the mirror configuration (``n.h == 1``),
  where it is ``+inf``.  Products are formed so that ``0 * inf = 0`` (e.g. a
  zero Fresnel or ``ks = 0``), never NaN.
* Colour-valued arguments (``f0``, ``f90``, ``eta``, ``k``, ``fresnel``,
  ``base_color``) are scalars or arrays whose **last axis is the channel axis**
  (length 3, or 1 to broadcast).  Scalar-valued per-point arguments (cosines,
  ``alpha``, ``roughness``, ``metallic``, ``kd``, ``ks``, ``shininess``,
  ``ior`` in :func:`brdf`) broadcast over the leading dimensions.  A term fed
  a non-scalar colour argument returns ``(..., C)``.

Terms (one pure function per term)
----------------------------------
========================  ====================================================
``d_ggx``                 Walter et al. 2007 / Trowbridge-Reitz 1975
``d_beckmann``            Beckmann; Cook & Torrance 1982 (m = alpha)
``g_cook_torrance``       Cook & Torrance 1982 V-cavity
``g1_smith_ggx``          Walter et al. 2007 eq. 34 (separable: G1(l)G1(v))
``g_smith_ggx_correlated``  Heitz 2014, height-correlated, via Lambda
``g_smith_schlick``       Schlick 1994 with k = alpha/2
``f_schlick``             Schlick 1994
``f_dielectric``          exact unpolarised Fresnel (s/p amplitudes)
``f_conductor``           exact unpolarised Fresnel, complex IOR eta + i k
``fd_lambert``            1/pi
``fd_burley``             Burley 2012 (Disney)
``fd_oren_nayar``         Oren & Nayar 1994, qualitative model, explicit angles
``phong`` ...             Phong 1975 / Blinn 1977 and the energy-normalised
                          variants (n+2)/(2pi), (n+8)/(8pi)
========================  ====================================================

Models are composed in one place, :func:`brdf`.  :func:`directional_albedo`
integrates ``f cos(theta)`` over the hemisphere with a graded composite
Gauss-Legendre rule and reports an error estimate.

Layout (the data flow, lowest first)
------------------------------------
========================  ====================================================
``constants``             what the oracle states on its own: epsilons, the
                          kernels' documented constants, the lobe families
``vectors``               precision, 0 * inf = 0 products, normalised
                          vectors, the shading geometry, alpha
``terms``                 the term functions above
``compose``               the microfacet lobes and :func:`brdf`
``albedo``                :func:`directional_albedo`
``frame``                 the frame oracle: pixels, lights, shadow lookup,
                          ambient, :func:`radiance`
========================  ====================================================

Everything is imported from this package (``clshade.verify.reference``).
"""

from __future__ import annotations

from clshade.verify.reference.constants import (DIELECTRIC_F0, DIFFUSE_MODELS, EMPIRICAL_MODELS, EPS_LENGTH,
                                                EPS_TANGENT, FRESNEL_LOBES, INV_PI, MICROFACET_MODELS, MIN_ALPHA,
                                                MIN_LIGHT_DIST2, MIN_SHININESS, SHADOW_BIAS_TEXELS, SHADOW_NORMAL_OFFSET_TEXELS,
                                                SPECULAR_MODELS)
from clshade.verify.reference.vectors import (Geometry, alpha_from_roughness, geometry, normalize, precision,
                                              reflect)
from clshade.verify.reference.terms import (blinn_phong, blinn_phong_normalized, d_beckmann, d_ggx, f_conductor,
                                            f_dielectric, f_schlick, fd_burley, fd_lambert, fd_oren_nayar,
                                            g1_smith_ggx, g_cook_torrance, g_smith_ggx_correlated,
                                            g_smith_ggx_separable, g_smith_schlick, lambda_ggx, phong,
                                            phong_normalized)
from clshade.verify.reference.compose import (brdf, check_model, cook_torrance, ggx_correlated, ggx_smith_schlick,
                                              uses_fresnel, walter_ggx)
from clshade.verify.reference.albedo import directional_albedo
from clshade.verify.reference.frame import (Pixels, ambient, device_f64, light_rays, normal_reflectance, pixels,
                                            radiance, spot_cone, surface_args, visibility)

__all__ = [
    "EPS_LENGTH",
    "EPS_TANGENT",
    "DIELECTRIC_F0",
    "DIFFUSE_MODELS",
    "SPECULAR_MODELS",
    "MICROFACET_MODELS",
    "EMPIRICAL_MODELS",
    "Geometry",
    "normalize",
    "reflect",
    "geometry",
    "alpha_from_roughness",
    "d_ggx",
    "d_beckmann",
    "g_cook_torrance",
    "g1_smith_ggx",
    "lambda_ggx",
    "g_smith_ggx_separable",
    "g_smith_ggx_correlated",
    "g_smith_schlick",
    "f_schlick",
    "f_dielectric",
    "f_conductor",
    "fd_lambert",
    "fd_burley",
    "fd_oren_nayar",
    "phong",
    "blinn_phong",
    "phong_normalized",
    "blinn_phong_normalized",
    "cook_torrance",
    "walter_ggx",
    "ggx_correlated",
    "ggx_smith_schlick",
    "brdf",
    "directional_albedo",
    "FRESNEL_LOBES",
    "INV_PI",
    "MIN_ALPHA",
    "MIN_LIGHT_DIST2",
    "MIN_SHININESS",
    "SHADOW_BIAS_TEXELS",
    "SHADOW_NORMAL_OFFSET_TEXELS",
    "precision",
    "uses_fresnel",
    "check_model",
    "Pixels",
    "pixels",
    "spot_cone",
    "light_rays",
    "surface_args",
    "normal_reflectance",
    "ambient",
    "device_f64",
    "radiance",
    "visibility",
]

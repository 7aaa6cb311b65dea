/* brdf.h — BRDF term functions shared by every lighting model.
 *
 * Filament-style: every term is a tiny pure function named for the term and
 * its author. The lobes in the model files compose these; compose.h combines
 * a diffuse and a specular lobe in exactly one place.
 *
 * Written in `real` and `vec3` (simd.h): one lane per pixel, the same source
 * for the scalar evaluation kernels and the SIMD shading kernels.
 *
 * Conventions (stated once):
 *   - `roughness` r is perceptual, in [0, 1]; the term functions take
 *     α = r² ("alpha"), floored at MIN_ALPHA.
 *   - f excludes the cosine: outgoing radiance for one light = f · (n·l) · E.
 *   - All direction vectors are unit length; cosines arrive clamped by
 *     make_geometry() in compose.h.
 *
 * Every clamp below is named, with the reason for its value and its bias
 * against the float64 reference (measured by `clshade check stability`).
 */
#ifndef CLSHADE_BRDF_H
#define CLSHADE_BRDF_H

#define CLSHADE_PI     3.14159265358979f
#define CLSHADE_INV_PI 0.318309886183791f

/* Smallest α the microfacet terms see. Below it GGX/Beckmann become a delta
 * that float32 cannot sample: D peaks at 1/(π α²), and α⁴ (the squared GGX
 * denominator at the peak) must stay a normal float32 (> 1.2e-38) even with
 * denormals flushed. 1e-4 keeps α⁴ = 1e-16 and the peak D = 3.2e7; roughness
 * r < 0.01 (α < 1e-4) renders as r = 0.01. */
#define MIN_ALPHA 1.0e-4f

/* Floor on n·v. Interpolated normals can face slightly away from the viewer;
 * the specular denominators 4(n·l)(n·v) need a positive value. Filament uses
 * the same 1e-4 (MIN_N_DOT_V). Bias: none for n·v ≥ 1e-4. */
#define MIN_N_DOT_V 1.0e-4f

/* Floor on n·l inside the lobes only (the light itself is dropped when
 * n·l ≤ 0, and the irradiance uses the true cosine, compose.h). Same reason and
 * value as MIN_N_DOT_V: the V terms divide by 4(n·l)(n·v). */
#define MIN_N_DOT_L 1.0e-4f

/* |l + v|² below which the half vector is undefined (l = −v; make_geometry() then takes it as
 * perpendicular to n): keeps rsqrt ≤ 1e15, and is below the 4e-14 of valid mirror pairs at
 * n·l = n·v = 1e-7. Bias: acts only where both cosines are below 1e-15 (radiance ≤ 1e-15 · f · E). */
#define MIN_HALF_LEN2 1.0e-30f

/* Beckmann D below this n·h is exactly 0 in float32 for m ≤ 1:
 * exp(−tan²θ/m²) < exp(−1e6). Flooring avoids 0/0 from cos⁴θ underflow. */
#define MIN_N_DOT_H_BECKMANN 1.0e-3f

/* Base of exp2(n·log2(x)) powers: keeps log2 finite (x = 0 would give
 * 0·(−∞) = NaN for n = 0). 1e-30ⁿ underflows to 0 for n ≥ 4.2 but is 1e-3 at
 * n = 0.1, so a lobe whose base can be exactly 0 (Phong's saturated r·v) selects
 * 0ⁿ itself: 1 for n = 0, else 0 (Fs_Phong). */
#define MIN_POW_BASE 1.0e-30f

/* Shininess below which the empirical lobes read n as 0 (0⁰ = 1 behind Phong's mirror): FLT_MIN,
 * so that builds flushing denormals and builds keeping them agree on a denormal n. Bias: for
 * 0 < n < FLT_MIN the lobe is 1 behind the mirror, not 0 (as n = 0; the float64 reference too). */
#define MIN_SHININESS 1.17549435e-38f

/* Whether shininess n reads as 0 (|n| < MIN_SHININESS; a NaN n does not). */
INLINE mask shininess_is_zero(real n) { return fabs(n) < MIN_SHININESS; }

/* ---- small math helpers -------------------------------------------------- */

INLINE real sq(real x) { return x * x; }
INLINE real pow5(real x) { real x2 = x * x; return x2 * x2 * x; }
INLINE real saturate(real x) { return clamp(x, 0.0f, 1.0f); }
INLINE real safe_sqrt(real x) { return sqrt(fmax(x, 0.0f)); }

/* log2 x for normal x > 0 in straight-line lane-wise code (PoCL's float8 log2 is not vectorised):
 * x = m·2^e, m in [√½, √2), ln m = f − f²/2 + f³·P(f), f = m − 1, P the minimax polynomial of
 * Cephes logf (S. Moshier): ≤ 2 ulp of ln m against float64 (tests/device/test_terms.py). */
INLINE real log2_lanes(real x) {
#ifdef REAL_DOUBLE
    return log2(x);     /* the double build: the library's, to double precision */
#else
    mask bits = as_mask(x);
    mask e = ((bits >> 23) & 0xff) - 127;
    real m = as_real((bits & 0x007fffff) | 0x3f800000);
    mask high = m > 1.41421356f;
    m = high ? m * 0.5f : m;
    e = high ? e + 1 : e;
    real f = m - 1.0f;
    real z = f * f, z2 = z * z;
    /* P(f) = Σ c_k f^k, k = 0..8, evaluated by Estrin's scheme: 4 dependent
     * steps instead of Horner's 9. */
    real c01 = 3.3333331174e-1f - 2.4999993993e-1f * f;
    real c23 = 2.0000714765e-1f - 1.6668057665e-1f * f;
    real c45 = 1.4249322787e-1f - 1.2420140846e-1f * f;
    real c67 = 1.1676998740e-1f - 1.1514610310e-1f * f;
    real p = (c01 + c23 * z) + (c45 + c67 * z) * z2 + 7.0376836292e-2f * (z2 * z2);
    real ln_m = f + (p * f * z - 0.5f * z);
    return ln_m * 1.44269504089f + convert_real(e);
#endif
}

/* ln FLT_MIN: down to it eˣ is a normal float (k = −126 below, r ≥ 0); below it eˣ would be
 * subnormal and exp_lanes() returns 0 (absolute bias ≤ 1.2e-38). */
#define MIN_EXP_ARG -87.3365f

/* eˣ in straight-line lane-wise code (PoCL's precise float8 exp is slow), x ≤ 88, 0 below MIN_EXP_ARG:
 * x = k ln 2 + r (Cody–Waite, ln 2 in two parts), eʳ by Cephes expf's minimax polynomial
 * (S. Moshier), 2ᵏ built in the exponent bits: ≤ 2 ulp against float64 (tests/device/test_terms.py). */
INLINE real exp_lanes(real x) {
#ifdef REAL_DOUBLE
    return exp(x);
#else
    real c = clamp(x, MIN_EXP_ARG, 88.0f);
    mask k = convert_mask_rte(c * 1.44269504089f);
    real kf = convert_real(k);
    real r = (c - kf * 0.693359375f) + kf * 2.12194440e-4f;
    real z = r * r;
    real p = (5.0000001201e-1f + 1.6666665459e-1f * r) + (4.1665795894e-2f + 8.3334519073e-3f * r) * z
           + (1.3981999507e-3f + 1.9875691500e-4f * r) * (z * z);
    real y = (p * z + r) + 1.0f;
    return x < MIN_EXP_ARG ? (real)(0.0f) : y * as_real((k + 127) << 23);
#endif
}

/* Smallest exponent exp2_lanes() returns 2ˣ for: below it 2ˣ < 2⁻¹²⁶ (FLT_MIN)
 * would be subnormal, and exp2_lanes() returns 0 (absolute bias ≤ 1.2e-38). */
#define MIN_EXP2_ARG -126.0f

/* 2ˣ in straight-line lane-wise code (pip's PoCL 3.0 calls its float8 exp2 out of line: simd.h),
 * x ≤ 127: x = k + r, k = rint(x), |r| ≤ ½; 2ʳ = 1 + r·P(r), P Cephes exp2f's minimax polynomial
 * (S. Moshier), 2ᵏ built in the exponent bits: ≤ 2 ulp against float64 (tests/device/test_terms.py). */
INLINE real exp2_lanes(real x) {
#ifdef REAL_DOUBLE
    return exp2(x);
#else
    real c = clamp(x, MIN_EXP2_ARG, 127.0f);
    mask k = convert_mask_rte(c);
    real r = c - convert_real(k);
    real z = r * r;
    real p = (6.931472028550421e-1f + 2.402264791363012e-1f * r)
           + (5.550332471162809e-2f + 9.618437357674640e-3f * r) * z
           + (1.339887440266574e-3f + 1.535336188319500e-4f * r) * (z * z);
    real y = r * p + 1.0f;
    return x < MIN_EXP2_ARG ? (real)(0.0f) : y * as_real((k + 127) << 23);
#endif
}

/* xⁿ for a runtime exponent, without pow() (≈190 ns per call on PoCL):
 * exp2(n·log2 x). x ≥ 0, n ≥ 0; 0⁰ = 1. */
INLINE real pow_runtime(real x, real n) {
    return exp2_lanes(n * log2_lanes(fmax(x, MIN_POW_BASE)));
}

/* ---- normal distribution functions D ------------------------------------ */

/* A term as numerator / denominator, so that a lobe that multiplies two terms
 * divides once (dv_product): a division costs as much as ~10 multiplies on these
 * CPUs. Each term documents its denominator's range, which dv_product's callers
 * need to rule out overflow and underflow. */
typedef struct { real num, den; } quotient;

INLINE real quotient_value(quotient q) { return q.num / q.den; }

/* D·V with one division. For GGX's D and the GGX visibilities below, num ≤ 1 and
 * π·MIN_ALPHA⁴ · (MIN_ALPHA/2)² ≈ 8e-25 ≤ den ≤ 16π (each term's comment; the
 * smallest V denominator is Schlick's): no product overflows or leaves float32's
 * normal range. */
INLINE real dv_product(quotient d, quotient v) { return (d.num * v.num) / (d.den * v.den); }

/* GGX / Trowbridge–Reitz (Walter et al. 2007, eq. 33).
 * D = α² / (π ((n·h)²(α²−1) + 1)²); 1 − (n·h)² is passed in as sin2_nh,
 * computed from |n × h|² to keep precision near the peak (Filament).
 * den = π d², d = 1 − (n·h)²(1 − α²) in [α², 1 + α²] (make_geometry keeps sin² and
 * the clamped n·h consistent): den ≥ π·MIN_ALPHA⁴ = 3e-16. */
INLINE quotient D_GGX_q(real nh, real sin2_nh, real alpha) {
    real a2 = alpha * alpha;
    real d = sin2_nh + nh * nh * a2;          /* = (n·h)²(α²−1) + 1 */
    quotient q = {a2, CLSHADE_PI * d * d};
    return q;
}
INLINE real D_GGX(real nh, real sin2_nh, real alpha) { return quotient_value(D_GGX_q(nh, sin2_nh, alpha)); }

/* Beckmann (Cook & Torrance 1982): D = exp(−tan²θh/m²) / (π m² cos⁴θh). */
INLINE real D_Beckmann(real nh, real sin2_nh, real m) {
    real c = fmax(nh, MIN_N_DOT_H_BECKMANN);
    real m2 = m * m;
    /* One division: t = 1/(m² cos²θh), 1/(π m² cos⁴θh) = t² m²/π. t ≤ 1e14 at
     * the floors (MIN_ALPHA, MIN_N_DOT_H_BECKMANN), so t² stays finite. */
    real t = 1.0f / (c * c * m2);
    return exp_lanes(-sin2_nh * t) * (t * t * m2 * CLSHADE_INV_PI);
}

/* ---- visibility V = G / (4 (n·l)(n·v)) ----------------------------------- */

/* Height-correlated Smith for GGX (Heitz 2014, eq. 99), as Filament writes it:
 * V = 0.5 / (n·l √((n·v)²(1−α²)+α²) + n·v √((n·l)²(1−α²)+α²)).
 * den ≥ 2·MIN_N_DOT_L·α (each root ≥ α, each cosine ≥ its floor). */
INLINE quotient V_SmithGGXCorrelated_q(real nl, real nv, real alpha) {
    real a2 = alpha * alpha;
    real gv = nl * sqrt(nv * nv * (1.0f - a2) + a2);
    real gl = nv * sqrt(nl * nl * (1.0f - a2) + a2);
    quotient q = {(real)(0.5f), gv + gl};
    return q;
}
INLINE real V_SmithGGXCorrelated(real nl, real nv, real alpha) { return quotient_value(V_SmithGGXCorrelated_q(nl, nv, alpha)); }

/* Separable Smith for GGX (Walter et al. 2007, eq. 34): G = G1(l)·G1(v),
 * G1(x) = 2(n·x) / (n·x + √(α² + (1−α²)(n·x)²)). Divided by 4(n·l)(n·v)
 * in closed form so that no cosine is divided by. Each factor ≥ MIN_N_DOT_L + α
 * (the root ≥ α): den ≥ (MIN_N_DOT_L + MIN_ALPHA)² = 4e-8. */
INLINE quotient V_SmithGGXSeparable_q(real nl, real nv, real alpha) {
    real a2 = alpha * alpha;
    real sl = nl + sqrt(a2 + (1.0f - a2) * nl * nl);
    real sv = nv + sqrt(a2 + (1.0f - a2) * nv * nv);
    quotient q = {(real)(1.0f), sl * sv};
    return q;
}
INLINE real V_SmithGGXSeparable(real nl, real nv, real alpha) { return quotient_value(V_SmithGGXSeparable_q(nl, nv, alpha)); }

/* Smith with Schlick's approximation, k = α/2 (the study's shader):
 * G1(x) = n·x / (n·x(1−k) + k), divided by 4(n·l)(n·v) in closed form.
 * den ≥ (MIN_ALPHA/2)² = 2.5e-9 (each factor ≥ k). */
INLINE quotient V_SmithSchlickGGX_q(real nl, real nv, real alpha) {
    real k = 0.5f * alpha;
    quotient q = {(real)(0.25f), (nl * (1.0f - k) + k) * (nv * (1.0f - k) + k)};
    return q;
}
INLINE real V_SmithSchlickGGX(real nl, real nv, real alpha) { return quotient_value(V_SmithSchlickGGX_q(nl, nv, alpha)); }

/* Cook–Torrance V-cavity G (Cook & Torrance 1982, Torrance–Sparrow):
 * G = min(1, 2(n·h)(n·v)/(v·h), 2(n·h)(n·l)/(v·h)), over 4(n·l)(n·v). */
INLINE real V_CookTorrance(real nl, real nv, real nh, real vh) {
    /* min(1, a/b) = min(b, a)/b with b = v·h > 0: one division for G and V. */
    real b = fmax(vh, MIN_N_DOT_V);
    return fmin(2.0f * nh * fmin(nv, nl), b) / (4.0f * nl * nv * b);
}

/* ---- Fresnel F ----------------------------------------------------------- */

/* Schlick 1994: F = f0 + (f90 − f0)(1 − v·h)⁵. */
INLINE vec3 F_Schlick(real vh, vec3 f0, real f90) {
    real w = pow5(1.0f - vh);
    return v3(f0.x + (f90 - f0.x) * w, f0.y + (f90 - f0.y) * w, f0.z + (f90 - f0.z) * w);
}

/* Exact unpolarised Fresnel reflectance of a dielectric with relative IOR η
 * (Cook & Torrance 1982; Walter et al. 2007, eq. 22):
 * g = √(η² − 1 + c²), F = ½ ((g−c)/(g+c))² (1 + ((c(g+c)−1)/(c(g−c)+1))²),
 * total internal reflection (g² < 0) → 1. Unclamped: rounding may leave [0, 1] by
 * a few ulp; F_Dielectric saturates (the counting build checks the value before). */
INLINE real F_Dielectric_unclamped(real c, real eta) {
    real g2 = eta * eta - 1.0f + c * c;
    real g = safe_sqrt(g2);
    real a = (g - c) / (g + c + 1.0e-30f);
    real b = (c * (g + c) - 1.0f) / (c * (g - c) + 1.0f);
    real f = 0.5f * a * a * (1.0f + b * b);
    return g2 < 0.0f ? (real)(1.0f) : f;
}
INLINE real F_Dielectric(real c, real eta) { return saturate(F_Dielectric_unclamped(c, eta)); }

/* Exact unpolarised Fresnel reflectance of a conductor with complex IOR
 * η + ik, one channel (Lagarde 2013, "Memo on Fresnel equations"; pbrt).
 * a² + b² = √((η²−k²−s²)² + 4η²k²), s² = 1 − c². Unclamped, as F_Dielectric_unclamped. */
INLINE real fresnel_conductor_channel_unclamped(real c, real eta, real k) {
    real c2 = c * c;
    real s2 = 1.0f - c2;
    /* t0 = η² − k² − s², summed as (η² − k² − 1) + c² so that an index-matched
     * interface (η = 1, k = 0) gives t0 = c² exactly instead of cancelling. */
    real t0 = (eta * eta - k * k - 1.0f) + c2;
    real a2b2 = sqrt(t0 * t0 + 4.0f * eta * eta * k * k);
    real t1 = a2b2 + c2;
    /* a² = (a2b2 + t0)/2 and b² = (a2b2 − t0)/2, each from whichever form does
     * not cancel, using (a2b2 + t0)(a2b2 − t0) = 4η²k²: the difference form lost
     * 4.5e-4 relative in F for η < 1 and k → 0 (measured, tests/device/test_terms.py). */
    real big = 0.5f * (a2b2 + fabs(t0));
    real small = (2.0f * eta * eta * k * k) / fmax(a2b2 + fabs(t0), FLT_MIN);
    real a = sqrt(t0 >= 0.0f ? big : small);
    real b2 = t0 >= 0.0f ? small : big;
    real t2 = 2.0f * c * a;
    /* t1 − t2 = (a − c)² + b²: no cancellation when F → 0
     * (the grazing mirror lobe, D·V ≈ 1e13, multiplies F's absolute error).
     * t1 + t2 = 0 only for η = 1, k = 0 at c = 0 (l = −v), where rs is 0, not 0/0. */
    real rs = ((a - c) * (a - c) + b2) / fmax(t1 + t2, FLT_MIN);
    real t3 = c2 * a2b2 + s2 * s2;
    real t4 = t2 * s2;
    real rp = rs * (t3 - t4) / (t3 + t4);
    return 0.5f * (rp + rs);
}

/* The conductor per RGB channel, unclamped and clamped to [0, 1]. */
INLINE vec3 F_Conductor_unclamped(real c, vec3 eta, vec3 k) {
    return v3(fresnel_conductor_channel_unclamped(c, eta.x, k.x), fresnel_conductor_channel_unclamped(c, eta.y, k.y),
              fresnel_conductor_channel_unclamped(c, eta.z, k.z));
}
INLINE vec3 v3saturate(vec3 x) { return v3(saturate(x.x), saturate(x.y), saturate(x.z)); }
INLINE vec3 F_Conductor(real c, vec3 eta, vec3 k) { return v3saturate(F_Conductor_unclamped(c, eta, k)); }

/* ---- diffuse ------------------------------------------------------------- */

/* Lambert: f = 1/π (times the diffuse colour in compose.h). */
INLINE real Fd_Lambert(void) { return (real)(CLSHADE_INV_PI); }

/* Disney / Burley 2012: (1/π)(1 + (F90−1)(1−n·l)⁵)(1 + (F90−1)(1−n·v)⁵),
 * F90 = 0.5 + 2 α (l·h)². */
INLINE real Fd_Burley(real nl, real nv, real lh, real alpha) {
    real f90 = 0.5f + 2.0f * alpha * lh * lh;
    real light = 1.0f + (f90 - 1.0f) * pow5(1.0f - nl);
    real view = 1.0f + (f90 - 1.0f) * pow5(1.0f - nv);
    return light * view * CLSHADE_INV_PI;
}

/* Oren–Nayar 1994, qualitative model: (1/π)(A + B max(0, cos(φi−φo)) sin α tan β),
 * A = 1 − 0.5σ²/(σ²+0.33), B = 0.45σ²/(σ²+0.09). Without trigonometry:
 * cos(φi−φo) sin θi sin θo = l·v − (n·l)(n·v) and tan β = sin β / cos β with
 * cos β = max(n·l, n·v), so the bracket is A + B max(0, l·v − nl·nv)/max(nl, nv). */
INLINE real Fd_OrenNayar(real nl, real nv, real lv, real sigma) {
    real s2 = sigma * sigma;
    real A = 1.0f - 0.5f * s2 / (s2 + 0.33f);
    real B = 0.45f * s2 / (s2 + 0.09f);
    real t = fmax(lv - nl * nv, 0.0f) / fmax(fmax(nl, nv), MIN_N_DOT_V);
    return (A + B * t) * CLSHADE_INV_PI;
}

/* ---- empirical lobes ----------------------------------------------------- */

/* Phong 1975, as a BRDF ("modified Phong", Lewis 1994): (r·v)ⁿ, r = 2(n·l)n − l.
 * r·v = 2(n·l)(n·v) − l·v of unit vectors rounds up to 1 + 1.1e-6 in float32;
 * (r·v)ⁿ would then exceed the lobe's peak by n·1.1e-6, so r·v is capped at 1.
 * Where r·v ≤ 0 the lobe is 0ⁿ exactly (1 for n = 0, else 0), not MIN_POW_BASEⁿ; n below
 * MIN_SHININESS counts as 0 (flushed or not). */
INLINE real Fs_Phong(real rv, real n) {
    real zero_pow = shininess_is_zero(n) ? (real)(1.0f) : (real)(0.0f);
    return rv > 0.0f ? pow_runtime(fmin(rv, 1.0f), n) : zero_pow;
}

/* Bound below which pow_runtime(x, n) is exactly 0: when n·(x − 1)·log2 e is below it,
 * so is n·log2 x (ln x ≤ x − 1), and exp2_lanes returns 0 below MIN_EXP2_ARG; the 2 of
 * margin covers log2_lanes' few ulp and the rounding of the bound's own products. */
#define POW_ZERO_BOUND (MIN_EXP2_ARG - 2.0f)

/* Lanes whose pow_runtime(x, n) is exactly 0 for want of float32 range: a shiny lobe
 * away from its peak (n = 1000: every x below 0.91). Two multiplies instead of
 * a log2 and an exp2. A NaN n is not claimed; a NaN x is where n > 88.7 (fmax drops
 * it), and pow_runtime returns 0 there as well. */
INLINE mask power_underflows(real x, real n) {
    return n * (fmin(fmax(x, MIN_POW_BASE), 1.0f) - 1.0f) * 1.44269504089f < POW_ZERO_BOUND;
}

/* Whether Fs_Phong is exactly 0 in every lane of a work-item: r·v ≤ 0 with n ≥ MIN_SHININESS (the
 * mirror direction points away from the viewer, about half the lit pixels of a glossy
 * surface) or (r·v)ⁿ underflows. The Phong models then skip the power's log2 and exp2. */
INLINE int phong_lobe_is_zero(real rv, real n) {
    return ALL((!(rv > 0.0f) & !shininess_is_zero(n)) | power_underflows(rv, n));
}

/* Whether Fs_BlinnPhong is exactly 0 in every lane (its power underflows there). */
INLINE int blinn_phong_lobe_is_zero(real nh, real n) { return ALL(power_underflows(nh, n)); }

/* Blinn 1977: (n·h)ⁿ. */
INLINE real Fs_BlinnPhong(real nh, real n) { return pow_runtime(nh, n); }

#endif

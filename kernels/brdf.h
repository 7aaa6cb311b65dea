/* brdf.h — BRDF term functions shared by every lighting model.
 *
 * Filament-style: every term is a tiny pure function named for the term and
 * its author. The lobes in the model files compose these; compose.h combines
 * a diffuse and a specular lobe in exactly one place.
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

/* Floor on n·l inside the lobes (the light itself is dropped when n·l ≤ 0).
 * Same reason and value as MIN_N_DOT_V: the V terms divide by 4(n·l)(n·v). */
#define MIN_N_DOT_L 1.0e-4f

/* |l + v|² below which the half vector is undefined (l = −v). The floor keeps
 * rsqrt finite (≤ 1e15, a normal float32 even with denormals flushed) and is
 * this small because valid pairs reach it: n·l = n·v = 1e-7 at the mirror has
 * |l + v|² = 4e-14 (a floor of 1e-12 shortened h there and made D_GGX 600×
 * too large at α = 1). With n·l, n·v > 0, |l + v| ≥ n·l + n·v, so the floor
 * acts only when both cosines are below 1e-15 (radiance ≤ 1e-15 · f · E).
 * make_geometry() treats a half vector below it as perpendicular to n. */
#define MIN_HALF_LEN2 1.0e-30f

/* Beckmann D below this n·h is exactly 0 in float32 for m ≤ 1:
 * exp(−tan²θ/m²) < exp(−1e6). Flooring avoids 0/0 from cos⁴θ underflow. */
#define MIN_N_DOT_H_BECKMANN 1.0e-3f

/* Base of exp2(n·log2(x)) powers: keeps log2 finite so that 0⁰ = 1 and
 * 0ⁿ ≈ 0 (1e-30ⁿ underflows to 0 for n ≥ 2; for n < 2 the bias is ≤ 1e-15). */
#define MIN_POW_BASE 1.0e-30f

/* ---- small math helpers -------------------------------------------------- */

inline float sq(float x) { return x * x; }
inline float pow5(float x) { float x2 = x * x; return x2 * x2 * x; }
inline float saturate(float x) { return clamp(x, 0.0f, 1.0f); }
inline float safe_sqrt(float x) { return sqrt(fmax(x, 0.0f)); }

/* xⁿ for a runtime exponent, without pow() (≈190 ns per call on PoCL):
 * exp2(n·log2 x). x ≥ 0, n ≥ 0; 0⁰ = 1. */
inline float pow_runtime(float x, float n) {
    return exp2(n * log2(fmax(x, MIN_POW_BASE)));
}

/* ---- normal distribution functions D ------------------------------------ */

/* GGX / Trowbridge–Reitz (Walter et al. 2007, eq. 33).
 * D = α² / (π ((n·h)²(α²−1) + 1)²); 1 − (n·h)² is passed in as sin2_nh,
 * computed from |n × h|² to keep precision near the peak (Filament). */
inline float D_GGX(float nh, float sin2_nh, float alpha) {
    float a2 = alpha * alpha;
    float d = sin2_nh + nh * nh * a2;          /* = (n·h)²(α²−1) + 1 */
    return a2 / (CLSHADE_PI * d * d);
}

/* Beckmann (Cook & Torrance 1982): D = exp(−tan²θh/m²) / (π m² cos⁴θh). */
inline float D_Beckmann(float nh, float sin2_nh, float m) {
    float c = fmax(nh, MIN_N_DOT_H_BECKMANN);
    float c2 = c * c;
    float m2 = m * m;
    return exp(-sin2_nh / (c2 * m2)) / (CLSHADE_PI * m2 * c2 * c2);
}

/* ---- visibility V = G / (4 (n·l)(n·v)) ----------------------------------- */

/* Height-correlated Smith for GGX (Heitz 2014, eq. 99), as Filament writes it:
 * V = 0.5 / (n·l √((n·v)²(1−α²)+α²) + n·v √((n·l)²(1−α²)+α²)). */
inline float V_SmithGGXCorrelated(float nl, float nv, float alpha) {
    float a2 = alpha * alpha;
    float gv = nl * sqrt(nv * nv * (1.0f - a2) + a2);
    float gl = nv * sqrt(nl * nl * (1.0f - a2) + a2);
    return 0.5f / (gv + gl);
}

/* Separable Smith for GGX (Walter et al. 2007, eq. 34): G = G1(l)·G1(v),
 * G1(x) = 2(n·x) / (n·x + √(α² + (1−α²)(n·x)²)). Divided by 4(n·l)(n·v)
 * in closed form so that no cosine is divided by. */
inline float V_SmithGGXSeparable(float nl, float nv, float alpha) {
    float a2 = alpha * alpha;
    float sl = nl + sqrt(a2 + (1.0f - a2) * nl * nl);
    float sv = nv + sqrt(a2 + (1.0f - a2) * nv * nv);
    return 1.0f / (sl * sv);
}

/* Smith with Schlick's approximation, k = α/2 (the study's shader):
 * G1(x) = n·x / (n·x(1−k) + k), divided by 4(n·l)(n·v) in closed form. */
inline float V_SmithSchlickGGX(float nl, float nv, float alpha) {
    float k = 0.5f * alpha;
    return 0.25f / ((nl * (1.0f - k) + k) * (nv * (1.0f - k) + k));
}

/* Cook–Torrance V-cavity G (Cook & Torrance 1982, Torrance–Sparrow):
 * G = min(1, 2(n·h)(n·v)/(v·h), 2(n·h)(n·l)/(v·h)), over 4(n·l)(n·v). */
inline float V_CookTorrance(float nl, float nv, float nh, float vh) {
    float g = fmin(1.0f, 2.0f * nh * fmin(nv, nl) / fmax(vh, MIN_N_DOT_V));
    return g / (4.0f * nl * nv);
}

/* ---- Fresnel F ----------------------------------------------------------- */

/* Schlick 1994: F = f0 + (f90 − f0)(1 − v·h)⁵. */
inline float3 F_Schlick(float vh, float3 f0, float f90) {
    return f0 + (f90 - f0) * pow5(1.0f - vh);
}

/* Exact unpolarised Fresnel reflectance of a dielectric with relative IOR η
 * (Cook & Torrance 1982; Walter et al. 2007, eq. 22):
 * g = √(η² − 1 + c²), F = ½ ((g−c)/(g+c))² (1 + ((c(g+c)−1)/(c(g−c)+1))²),
 * total internal reflection (g² < 0) → 1. */
inline float F_Dielectric(float c, float eta) {
    float g2 = eta * eta - 1.0f + c * c;
    float g = safe_sqrt(g2);
    float a = (g - c) / (g + c + 1.0e-30f);
    float b = (c * (g + c) - 1.0f) / (c * (g - c) + 1.0f);
    float f = 0.5f * a * a * (1.0f + b * b);
    return g2 < 0.0f ? 1.0f : saturate(f);
}

/* Exact unpolarised Fresnel reflectance of a conductor with complex IOR
 * η + ik, per channel (Lagarde 2013, "Memo on Fresnel equations"; pbrt).
 * a² + b² = √((η²−k²−s²)² + 4η²k²), s² = 1 − c². */
inline float3 F_Conductor(float c, float3 eta, float3 k) {
    float c2 = c * c;
    float s2 = 1.0f - c2;
    /* t0 = η² − k² − s², summed as (η² − k² − 1) + c² so that an index-matched
     * interface (η = 1, k = 0) gives t0 = c² exactly instead of cancelling. */
    float3 t0 = (eta * eta - k * k - 1.0f) + c2;
    float3 a2b2 = sqrt(t0 * t0 + 4.0f * eta * eta * k * k);
    float3 t1 = a2b2 + c2;
    /* a² = (a2b2 + t0)/2 and b² = (a2b2 − t0)/2, each from whichever form does
     * not cancel, using (a2b2 + t0)(a2b2 − t0) = 4η²k²: the difference form lost
     * 4.5e-4 relative in F for η < 1 and k → 0 (measured, tests/test_terms.py). */
    float3 big = 0.5f * (a2b2 + fabs(t0));
    float3 small = (2.0f * eta * eta * k * k) / fmax(a2b2 + fabs(t0), FLT_MIN);
    float3 a = sqrt(select(small, big, t0 >= 0.0f));
    float3 b2 = select(big, small, t0 >= 0.0f);
    float3 t2 = 2.0f * c * a;
    /* t1 − t2 = (a − c)² + b²: no cancellation when F → 0
     * (the grazing mirror lobe, D·V ≈ 1e13, multiplies F's absolute error).
     * t1 + t2 = 0 only for η = 1, k = 0 at c = 0 (l = −v), where rs is 0, not 0/0. */
    float3 rs = ((a - c) * (a - c) + b2) / fmax(t1 + t2, FLT_MIN);
    float3 t3 = c2 * a2b2 + s2 * s2;
    float3 t4 = t2 * s2;
    float3 rp = rs * (t3 - t4) / (t3 + t4);
    return clamp(0.5f * (rp + rs), 0.0f, 1.0f);
}

/* ---- diffuse ------------------------------------------------------------- */

/* Lambert: f = 1/π (times the diffuse colour in compose.h). */
inline float Fd_Lambert(void) { return CLSHADE_INV_PI; }

/* Disney / Burley 2012: (1/π)(1 + (F90−1)(1−n·l)⁵)(1 + (F90−1)(1−n·v)⁵),
 * F90 = 0.5 + 2 α (l·h)². */
inline float Fd_Burley(float nl, float nv, float lh, float alpha) {
    float f90 = 0.5f + 2.0f * alpha * lh * lh;
    float light = 1.0f + (f90 - 1.0f) * pow5(1.0f - nl);
    float view = 1.0f + (f90 - 1.0f) * pow5(1.0f - nv);
    return light * view * CLSHADE_INV_PI;
}

/* Oren–Nayar 1994, qualitative model: (1/π)(A + B max(0, cos(φi−φo)) sin α tan β),
 * A = 1 − 0.5σ²/(σ²+0.33), B = 0.45σ²/(σ²+0.09). Without trigonometry:
 * cos(φi−φo) sin θi sin θo = l·v − (n·l)(n·v) and tan β = sin β / cos β with
 * cos β = max(n·l, n·v), so the bracket is A + B max(0, l·v − nl·nv)/max(nl, nv). */
inline float Fd_OrenNayar(float nl, float nv, float lv, float sigma) {
    float s2 = sigma * sigma;
    float A = 1.0f - 0.5f * s2 / (s2 + 0.33f);
    float B = 0.45f * s2 / (s2 + 0.09f);
    float t = fmax(0.0f, lv - nl * nv) / fmax(fmax(nl, nv), MIN_N_DOT_V);
    return (A + B * t) * CLSHADE_INV_PI;
}

/* ---- empirical lobes ----------------------------------------------------- */

/* Phong 1975, as a BRDF ("modified Phong", Lewis 1994): (r·v)ⁿ, r = 2(n·l)n − l. */
inline float Fs_Phong(float rv, float n) { return pow_runtime(fmax(rv, 0.0f), n); }

/* Blinn 1977: (n·h)ⁿ. */
inline float Fs_BlinnPhong(float nh, float n) { return pow_runtime(nh, n); }

#endif

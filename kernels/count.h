/* count.h — the counting build of `clshade check stability` (-D COUNT_TERMS).
 *
 * Every term's raw value — D, V, F, the diffuse and empirical terms, the lobes,
 * their sum, the radiance of each light, the ambient term and the pixel's
 * radiance — passes through RAW() where it is computed, before any clamp,
 * saturate, fmax/fmin or select can turn a NaN or an Inf into a number. In the
 * counting build RAW() checks the value and counts, per term, atomically in a
 * buffer of TERMS × CHECKS uint (the kernel's last argument, `term_counts`):
 * evaluations, NaN, ±Inf, negative (finite and < 0) and above the term's bound.
 * In every other build RAW(s, term, x, bound) is x: no code, no cost.
 *
 * The tests are on the bits (fast-math builds may assume that no NaN or Inf
 * exists and fold isnan/isinf away). One pixel per work-item (SIMD 1): sky
 * work-items return before any term, so only covered pixels are counted.
 * clshade/device/counts.py reads the term and check names from this file.
 */
#ifndef CLSHADE_COUNT_H
#define CLSHADE_COUNT_H

#define TERM_D        0   /* normal distribution D                                  */
#define TERM_V        1   /* visibility V = G / (4 (n·l)(n·v))                       */
#define TERM_F        2   /* every Fresnel evaluation (lobe's F, metallic k_d's F)   */
#define TERM_FD       3   /* the diffuse term f_d (before colour and k_d)            */
#define TERM_FS       4   /* the empirical specular power (r·v)ⁿ or (n·h)ⁿ            */
#define TERM_SPECULAR 5   /* the specular lobe f_s                                   */
#define TERM_BRDF     6   /* the lobe sum f                                          */
#define TERM_LIGHT    7   /* radiance from one light f·(n·l)·E, before the horizon select */
#define TERM_AMBIENT  8   /* the ambient term                                        */
#define TERM_RADIANCE 9   /* a pixel's radiance, before the MAX_RADIANCE clamp       */
#define TERMS         10

#define CHECK_EVALUATED 0
#define CHECK_NAN       1
#define CHECK_INF       2
#define CHECK_NEGATIVE  3
#define CHECK_ABOVE     4
#define CHECKS          5

/* Relative slack of every bound: the term and its bound are each rounded to
 * float32 (a few ulp, 2⁻²³ ≈ 1.2e-7 each); 1e-5 is far above that and far below
 * any real excess (a reflectance of 1.00001). */
#define BOUND_ROUNDING 1.0e-5f

/* A term without an upper bound of its own (finiteness and sign are checked). */
#define UNBOUNDED INFINITY

/* Bounds of the terms (used only as RAW()'s last argument, so absent from
 * normal builds):
 * D_GGX ≤ 1/(π α²): d = 1 − (n·h)²(1 − α²) ≥ α².
 * D_Beckmann ≤ 1.5/(π m²): with u = tan²θ, D = (1+u)² e^(−u/m²)/(π m²), whose
 *   maximum over u ≥ 0 is 1/(π m²) for m² ≤ ½ and 4m⁴e^(1/m² − 2)/(π m²) ≤ 1.48/(π m²) for m ≤ 1.
 * V ≤ 1/(4 (n·l)(n·v)): every masking-shadowing G here is ≤ 1 (Smith G1 ≤ 1,
 *   Schlick's G1 = x/(x(1−k)+k) ≤ 1, the V-cavity min(1, …)).
 * F ∈ [0, 1]; Phong's and Blinn–Phong's power of a cosine ≤ 1.
 * Lambert 1/π; Burley ≤ 2.5²/π (F90 ≤ 2.5, each factor ≤ 2.5); Oren–Nayar
 *   ≤ (1 + 0.45/max(n·l, n·v))/π (A ≤ 1, B ≤ 0.45, sin α tan β ≤ 1/cos β). */
#define D_GGX_BOUND(alpha)      (CLSHADE_INV_PI / ((alpha) * (alpha)))
#define D_BECKMANN_BOUND(m)     (1.5f * CLSHADE_INV_PI / ((m) * (m)))
#define V_BOUND(nl, nv)         (0.25f / ((nl) * (nv)))
#define FD_BURLEY_BOUND         (6.25f * CLSHADE_INV_PI)
#define FD_OREN_NAYAR_BOUND(nl, nv) ((1.0f + 0.45f / fmax(fmax(nl, nv), MIN_N_DOT_V)) * CLSHADE_INV_PI)

#ifdef COUNT_TERMS
#if SIMD != 1
#error "COUNT_TERMS: the counting build shades one pixel per work-item (SIMD 1)"
#endif
#ifdef REAL_DOUBLE
#error "COUNT_TERMS: the counting build checks the float32 terms (not the double build)"
#endif

/* The counters' field of Surface (surface.h) and its assignment in the kernels. */
#define COUNTERS_FIELD __global uint* counts;
#define COUNT_INTO(s, buffer) ((s).counts = (buffer))

INLINE real raw_count(__global uint* c, int term, real x, real bound) {
    __global uint* t = c + term * CHECKS;
    uint bits = as_uint(x) & 0x7fffffffu;
    atomic_inc(t + CHECK_EVALUATED);
    if (bits > 0x7f800000u)
        atomic_inc(t + CHECK_NAN);
    else if (bits == 0x7f800000u)
        atomic_inc(t + CHECK_INF);
    else if ((as_uint(x) >> 31) && bits != 0u)
        atomic_inc(t + CHECK_NEGATIVE);
    else if (x > bound * (1.0f + BOUND_ROUNDING))
        atomic_inc(t + CHECK_ABOVE);
    return x;
}

INLINE vec3 raw_count3(__global uint* c, int term, vec3 x, real bound) {
    return v3(raw_count(c, term, x.x, bound), raw_count(c, term, x.y, bound), raw_count(c, term, x.z, bound));
}

INLINE quotient raw_count_q(__global uint* c, int term, quotient q, real bound) {
    raw_count(c, term, quotient_value(q), bound);
    return q;
}

#define RAW(s, term, x, bound)   raw_count((s).counts, term, x, bound)
#define RAW3(s, term, x, bound)  raw_count3((s).counts, term, x, bound)
#define RAW_Q(s, term, q, bound) raw_count_q((s).counts, term, q, bound)
#else
#define COUNTERS_FIELD
#define COUNT_INTO(s, buffer) ((void)0)
#define RAW(s, term, x, bound)   (x)
#define RAW3(s, term, x, bound)  (x)
#define RAW_Q(s, term, q, bound) (q)
#endif

#endif

/* glsl.h — the GLSL built-ins a translated BRDF Explorer shader calls
 * (clshade/models/glsl/emitter.py emits calls to these; nothing else includes this file).
 *
 * GLSL's float is `real` and its vec3 clshade's `vec3` (simd.h): one lane per
 * pixel, so a translated shader shades SIMD pixels at once like a built-in
 * lobe. vec2 is the two-component counterpart. Booleans are `mask`s (lane-wise
 * comparison results: 1 or −1 for true, 0 for false); G_TRUE and G_FALSE are
 * masks of the right width for every SIMD.
 *
 * Names: g1_* act on real, g2_* on vec2, g3_* on vec3. A function of GLSL
 * that OpenCL C has under the same name and meaning (sqrt, exp, sin …) is
 * called directly on reals and mapped over components here.
 */
#ifndef CLSHADE_GLSL_H
#define CLSHADE_GLSL_H

#define G_TRUE  ((real)(0.0f) == (real)(0.0f))
#define G_FALSE ((real)(0.0f) != (real)(0.0f))

typedef struct { real x, y; } vec2;

INLINE vec2 v2(real x, real y) { vec2 r; r.x = x; r.y = y; return r; }
INLINE vec2 v2s(real s) { return v2(s, s); }

/* ---- transcendental functions, lane by lane ------------------------------
 * exp, exp2, log, log2 are brdf.h's straight-line lane-wise versions (≤ 2 ulp; exp
 * saturates at e^88 instead of overflowing, log of x ≤ 0 is finite where GLSL
 * leaves it undefined); the double build calls the library. The others call the
 * library's scalar function once per lane: a vector argument to a library call
 * is what pip's PoCL 3.0 cannot pass at SIMD 16 (simd.h), and these are rare in
 * BRDFs. */
#ifdef REAL_DOUBLE
INLINE real g1_exp(real x) { return exp(x); }
INLINE real g1_exp2(real x) { return exp2(x); }
INLINE real g1_log(real x) { return log(x); }
INLINE real g1_log2(real x) { return log2(x); }
#else
INLINE real g1_exp(real x) { return exp_lanes(x); }
INLINE real g1_exp2(real x) { return exp2_lanes(x); }
INLINE real g1_log(real x) { return log2_lanes(x) * 0.693147180559945f; }
INLINE real g1_log2(real x) { return log2_lanes(x); }
#endif

#if SIMD == 1
#define G_PER_LANE1(NAME, F) INLINE real g1_##NAME(real x) { return F(x); }
#define G_PER_LANE2(NAME, F) INLINE real g1_##NAME(real x, real y) { return F(x, y); }
#else
#define G_PER_LANE1(NAME, F) INLINE real g1_##NAME(real x) { \
        real_lanes a = {x}; \
        for (int j = 0; j < SIMD; ++j) a.s[j] = F(a.s[j]); \
        return a.v; }
#define G_PER_LANE2(NAME, F) INLINE real g1_##NAME(real x, real y) { \
        real_lanes a = {x}, b = {y}; \
        for (int j = 0; j < SIMD; ++j) a.s[j] = F(a.s[j], b.s[j]); \
        return a.v; }
#endif
G_PER_LANE1(sin, sin)
G_PER_LANE1(cos, cos)
G_PER_LANE1(tan, tan)
/* asin and acos of |x| > 1 (undefined in GLSL) are their value at ±1, as in Mesa: n·h of a
 * mirror direction rounds to 1 + 1 ulp, where acos would otherwise be NaN at the lobe's peak. */
#define G_UNIT(x) ((x) < -1.0f ? -1.0f : ((x) > 1.0f ? 1.0f : (x)))
#define G_ASIN(x) asin(G_UNIT(x))
#define G_ACOS(x) acos(G_UNIT(x))
G_PER_LANE1(asin, G_ASIN)
G_PER_LANE1(acos, G_ACOS)
G_PER_LANE1(atan, atan)
G_PER_LANE1(sinh, sinh)
G_PER_LANE1(cosh, cosh)
G_PER_LANE1(tanh, tanh)
G_PER_LANE2(atan2, atan2)

/* ---- scalar built-ins without an OpenCL namesake ------------------------ */

INLINE real g1_floor(real x) { return floor(x); }
INLINE real g1_ceil(real x) { return -floor(-x); }
INLINE real g1_sqrt(real x) { return sqrt(x); }

INLINE real g1_fract(real x) { return x - floor(x); }
INLINE real g1_mod(real x, real y) { return x - y * floor(x / y); }
INLINE real g1_mix(real a, real b, real t) { return a + (b - a) * t; }
INLINE real g1_step(real edge, real x) { return x < edge ? (real)(0.0f) : (real)(1.0f); }
INLINE real g1_smoothstep(real e0, real e1, real x) {
    real t = clamp((x - e0) / (e1 - e0), (real)(0.0f), (real)(1.0f));
    return t * t * (3.0f - 2.0f * t);
}
INLINE real g1_sign(real x) { return x > 0.0f ? (real)(1.0f) : (x < 0.0f ? (real)(-1.0f) : (real)(0.0f)); }
INLINE real g1_radians(real x) { return x * (real)(0.0174532925199433); }
INLINE real g1_degrees(real x) { return x * (real)(57.2957795130823); }
INLINE real g1_inversesqrt(real x) { return rsqrt(x); }
INLINE real g1_abs(real x) { return fabs(x); }
INLINE real g1_min(real a, real b) { return fmin(a, b); }
INLINE real g1_max(real a, real b) { return fmax(a, b); }
INLINE real g1_clamp(real x, real lo, real hi) { return fmin(fmax(x, lo), hi); }
/* Integer powers as products (pow() costs ≈190 ns per call on PoCL). */
INLINE real g1_pow3(real x) { return x * x * x; }
INLINE real g1_pow4(real x) { real x2 = x * x; return x2 * x2; }

/* A literal of the shader: float, or double in the double build. */
#ifdef REAL_DOUBLE
#define G_LIT(x) ((real)(x))
#else
#define G_LIT(x) ((real)(x##f))
#endif

/* GLSL pow(x, y): x^y for x > 0, and 0 for x = 0 < y (undefined for x < 0 and for x = 0,
 * y ≤ 0 in GLSL). exp2(y·log2 x) without pow() (≈190 ns per call on PoCL, brdf.h
 * pow_runtime), whose floor MIN_POW_BASE would make 0^y MIN_POW_BASE^y (1e-3 at y = 0.1);
 * the double build (REAL_DOUBLE) calls pow itself. */
INLINE real g1_pow(real x, real y) {
#ifdef REAL_DOUBLE
    return pow(x, y);
#else
    real p = pow_runtime(x, y);
    return (x == 0.0f) & (y > 0.0f) ? (real)(0.0f) : p;
#endif
}

/* ---- component-wise maps ------------------------------------------------ */

#define G_MAP1(NAME, F) \
    INLINE vec2 g2_##NAME(vec2 a) { return v2(F(a.x), F(a.y)); } \
    INLINE vec3 g3_##NAME(vec3 a) { return v3(F(a.x), F(a.y), F(a.z)); }
#define G_MAP2(NAME, F) \
    INLINE vec2 g2_##NAME(vec2 a, vec2 b) { return v2(F(a.x, b.x), F(a.y, b.y)); } \
    INLINE vec3 g3_##NAME(vec3 a, vec3 b) { return v3(F(a.x, b.x), F(a.y, b.y), F(a.z, b.z)); }
#define G_MAP3(NAME, F) \
    INLINE vec2 g2_##NAME(vec2 a, vec2 b, vec2 c) { return v2(F(a.x, b.x, c.x), F(a.y, b.y, c.y)); } \
    INLINE vec3 g3_##NAME(vec3 a, vec3 b, vec3 c) { return v3(F(a.x, b.x, c.x), F(a.y, b.y, c.y), F(a.z, b.z, c.z)); }

#define G_ADD(a, b) ((a) + (b))
#define G_SUB(a, b) ((a) - (b))
#define G_MUL(a, b) ((a) * (b))
#define G_DIV(a, b) ((a) / (b))
#define G_NEG(a) (-(a))
G_MAP2(add, G_ADD)
G_MAP2(sub, G_SUB)
G_MAP2(mul, G_MUL)
G_MAP2(div, G_DIV)
G_MAP1(neg, G_NEG)

G_MAP1(abs, g1_abs)
G_MAP1(sign, g1_sign)
G_MAP1(floor, g1_floor)
G_MAP1(ceil, g1_ceil)
G_MAP1(fract, g1_fract)
G_MAP1(sqrt, g1_sqrt)
G_MAP1(inversesqrt, g1_inversesqrt)
G_MAP1(exp, g1_exp)
G_MAP1(exp2, g1_exp2)
G_MAP1(log, g1_log)
G_MAP1(log2, g1_log2)
G_MAP1(sin, g1_sin)
G_MAP1(cos, g1_cos)
G_MAP1(tan, g1_tan)
G_MAP1(asin, g1_asin)
G_MAP1(acos, g1_acos)
G_MAP1(atan, g1_atan)
G_MAP1(sinh, g1_sinh)
G_MAP1(cosh, g1_cosh)
G_MAP1(tanh, g1_tanh)
G_MAP1(radians, g1_radians)
G_MAP1(degrees, g1_degrees)
G_MAP2(mod, g1_mod)
G_MAP2(min, g1_min)
G_MAP2(max, g1_max)
G_MAP2(pow, g1_pow)
G_MAP2(step, g1_step)
G_MAP2(atan2, g1_atan2)
G_MAP3(clamp, g1_clamp)
G_MAP3(mix, g1_mix)
G_MAP3(smoothstep, g1_smoothstep)

/* ---- geometric ---------------------------------------------------------- */

INLINE real g2_dot(vec2 a, vec2 b) { return a.x * b.x + a.y * b.y; }
INLINE real g3_dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
INLINE real g2_length(vec2 a) { return sqrt(g2_dot(a, a)); }
INLINE real g3_length(vec3 a) { return sqrt(g3_dot(a, a)); }
INLINE real g1_length(real a) { return fabs(a); }
INLINE real g2_distance(vec2 a, vec2 b) { return g2_length(g2_sub(a, b)); }
INLINE real g3_distance(vec3 a, vec3 b) { return g3_length(g3_sub(a, b)); }
INLINE real g1_distance(real a, real b) { return fabs(a - b); }
INLINE vec2 g2_normalize(vec2 a) { real k = rsqrt(g2_dot(a, a)); return v2(a.x * k, a.y * k); }
INLINE vec3 g3_normalize(vec3 a) { real k = rsqrt(g3_dot(a, a)); return v3(a.x * k, a.y * k, a.z * k); }
INLINE real g1_normalize(real a) { return g1_sign(a); }
INLINE vec3 g3_cross(vec3 a, vec3 b) { return v3cross(a, b); }
/* GLSL reflect(I, N) = I − 2 (N·I) N. */
INLINE vec3 g3_reflect(vec3 i, vec3 n) { return g3_sub(i, v3scale(n, 2.0f * g3_dot(n, i))); }
/* Constructors mixing sizes: vec3(vec2, z), vec3(x, vec2), vec2(vec3). */
INLINE vec3 g3_from21(vec2 a, real z) { return v3(a.x, a.y, z); }
INLINE vec3 g3_from12(real x, vec2 a) { return v3(x, a.x, a.y); }
INLINE vec2 g2_from3(vec3 a) { return v2(a.x, a.y); }
INLINE vec2 g2_select(mask c, vec2 a, vec2 b) { return v2(c ? a.x : b.x, c ? a.y : b.y); }

#endif

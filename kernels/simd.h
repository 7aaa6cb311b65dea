/* simd.h — explicit SIMD across pixels: every work-item shades SIMD adjacent
 * pixels, one per lane of a `real` (float, float4 or float8).
 *
 * Why: PoCL compiles a work-group as a loop over work-items and leaves its
 * vectorisation to LLVM's loop vectoriser, which gives up on any instruction
 * of vector type — float3 arithmetic, or the <2 x float> pairs that PoCL's SLP
 * pass makes of per-channel colour code ("loop not vectorized: instruction
 * return type cannot be vectorized", POCL_VECTORIZER_REMARKS=1). Scalar code
 * per pixel then runs one pixel at a time. Written with `real` lanes, the
 * kernels are vector code by construction: a float8 Lambert pass runs at the
 * copy kernel's speed on AVX2 (measured, benchmarks/results).
 *
 * Every term function is written once in `real`, `vec3` (a struct of three
 * reals: a direction or an RGB colour) and `mask` (a lane-wise comparison
 * result), so the same source builds for SIMD = 1 (the evaluation kernels:
 * eval.cl, terms.cl) and SIMD = 4 or 8 (shade.cl, copy.cl on CPUs). Lane-wise
 * choices are `c ? a : b` on reals (OpenCL's vector select), never branches;
 * the only branches are per work-item, on ANY/ALL of a mask (skip the sky, a
 * light below every lane's horizon, a material shared by every lane).
 *
 * SIMD is a compile-time constant chosen by the host (clshade/device/runtime.py,
 * CLSHADE_SIMD); G-buffer and output buffers are padded to a multiple of it.
 */
#ifndef CLSHADE_SIMD_H
#define CLSHADE_SIMD_H

#ifndef SIMD
#define SIMD 1
#endif

/* Every helper is inlined into the kernel. PoCL's inliner gave up on
 * shade_light() once a lobe grew (Cook–Torrance), and a call spills every live
 * vector register around it: 5 % of a 4-light Cook–Torrance frame, 4–6 % of
 * Phong with material_gather (A/B in one process, 2026-11-23). */
#define INLINE __attribute__((always_inline)) inline

#if SIMD == 1
typedef float real;
typedef int mask;
typedef uint uindex;
#define as_real as_float
#define as_mask as_int
#define convert_real convert_float
#define convert_uindex convert_uint
#define convert_mask_rte convert_int_rte
#define convert_mask_sat convert_int_sat
#define LANE_IOTA 0u
#define VLOAD(i, p) ((p)[i])
#define VLOAD_HALF(i, p) vload_half((i), (p))
#define VLOAD_UCHAR(i, p) ((uint)(p)[i])
#elif SIMD == 4
typedef float4 real;
typedef int4 mask;
typedef uint4 uindex;
#define as_real as_float4
#define as_mask as_int4
#define convert_real convert_float4
#define convert_uindex convert_uint4
#define convert_mask_rte convert_int4_rte
#define convert_mask_sat convert_int4_sat
#define LANE_IOTA ((uint4)(0u, 1u, 2u, 3u))
#define VLOAD(i, p) vload4((i), (p))
#define VLOAD_HALF(i, p) vload_half4((i), (p))
#define VLOAD_UCHAR(i, p) convert_uint4(vload4((i), (p)))
#elif SIMD == 8
typedef float8 real;
typedef int8 mask;
typedef uint8 uindex;
#define as_real as_float8
#define as_mask as_int8
#define convert_real convert_float8
#define convert_uindex convert_uint8
#define convert_mask_rte convert_int8_rte
#define convert_mask_sat convert_int8_sat
#define LANE_IOTA ((uint8)(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u))
#define VLOAD(i, p) vload8((i), (p))
#define VLOAD_HALF(i, p) vload_half8((i), (p))
#define VLOAD_UCHAR(i, p) convert_uint8(vload8((i), (p)))
#else
#error "SIMD must be 1, 4 or 8"
#endif

/* Whether any / every lane of a mask is set. OpenCL's any()/all() test the
 * sign bit, which a scalar comparison (1, not −1) does not set. */
#if SIMD == 1
#define ANY(m) ((m) != 0)
#define ALL(m) ((m) != 0)
#else
#define ANY(m) any(m)
#define ALL(m) all(m)
#endif

/* One lane of a real, for the per-pixel work that stays scalar (material
 * table gathers, shadow-map taps). */
typedef union { real v; float s[SIMD]; } real_lanes;
typedef union { uindex v; uint s[SIMD]; } uindex_lanes;
typedef union { mask v; int s[SIMD]; } mask_lanes;

/* p[idx] per lane: a gather, one scalar load per lane (AVX2 has vgatherdps,
 * but PoCL's LLVM does not emit it from this). */
INLINE real gather(__global const float* p, mask idx) {
    mask_lanes k = {idx};
    real_lanes r;
    for (int j = 0; j < SIMD; ++j)
        r.s[j] = p[k.s[j]];
    return r.v;
}

/* A direction or an RGB colour, one per lane. */
typedef struct { real x, y, z; } vec3;

INLINE vec3 v3(real x, real y, real z) { vec3 r; r.x = x; r.y = y; r.z = z; return r; }
INLINE vec3 v3s(real s) { return v3(s, s, s); }
INLINE vec3 v3c(float3 c) { return v3((real)(c.x), (real)(c.y), (real)(c.z)); }
INLINE vec3 v3add(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
INLINE vec3 v3sub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
INLINE vec3 v3mul(vec3 a, vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
INLINE vec3 v3scale(vec3 a, real s) { return v3(a.x * s, a.y * s, a.z * s); }
INLINE vec3 v3neg(vec3 a) { return v3(-a.x, -a.y, -a.z); }
INLINE vec3 v3max(vec3 a, float m) { return v3(fmax(a.x, m), fmax(a.y, m), fmax(a.z, m)); }
INLINE vec3 v3min(vec3 a, float m) { return v3(fmin(a.x, m), fmin(a.y, m), fmin(a.z, m)); }
INLINE real v3dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
INLINE vec3 v3cross(vec3 a, vec3 b) {
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
/* Lane-wise choice: c ? a : b. */
INLINE vec3 v3select(mask c, vec3 a, vec3 b) {
    return v3(c ? a.x : b.x, c ? a.y : b.y, c ? a.z : b.z);
}
/* a + t (b − a), lane-wise t. */
INLINE vec3 v3mix(vec3 a, vec3 b, real t) {
    return v3(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, a.z + (b.z - a.z) * t);
}

#endif

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
 * eval.cl, terms.cl) and SIMD = 4, 8 or 16 (shade.cl, copy.cl on CPUs). Lane-wise
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

/* Every helper is inlined into the kernel: PoCL's inliner gives up on shade_light() once a lobe
 * grows, and a call spills every live vector register around it. */
#define INLINE __attribute__((always_inline)) inline

/* REAL_DOUBLE (SIMD 1 only: the evaluation kernel eval.cl): real is double, the
 * double-precision build of a lobe that its float32 build is measured against
 * (clshade.device.evaluate, `double=True`; devices with cl_khr_fp64). */
#if defined(REAL_DOUBLE) && SIMD != 1
#error "REAL_DOUBLE needs SIMD 1"
#endif
#ifdef REAL_DOUBLE
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

#if SIMD == 1
#ifdef REAL_DOUBLE
typedef double real;     /* (no as_real: the float bit tricks of brdf.h are not built) */
#define convert_real convert_double
#else
typedef float real;
#define as_real as_float
#define convert_real convert_float
#endif
typedef int mask;
typedef uint uindex;
#define as_mask as_int
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
#elif SIMD == 16
typedef float16 real;
typedef int16 mask;
typedef uint16 uindex;
#define as_real as_float16
#define as_mask as_int16
#define convert_real convert_float16
#define convert_uindex convert_uint16
#define convert_mask_rte convert_int16_rte
#define convert_mask_sat convert_int16_sat
#define LANE_IOTA ((uint16)(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u, 9u, 10u, 11u, 12u, 13u, 14u, 15u))
#define VLOAD(i, p) vload16((i), (p))
#define VLOAD_HALF(i, p) vload_half16((i), (p))
#define VLOAD_UCHAR(i, p) convert_uint16(vload16((i), (p)))
#else
#error "SIMD must be 1, 4, 8 or 16"
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

/* ---- inline math (x86) ------------------------------------------------------
 * Where the host has AVX-512 (CLSHADE_HOST_AVX512F) but the kernel compiles without it (pip's
 * PoCL 3.0), the library's AVX-512 builtins cannot inline nor take float16: the hot ones are
 * written here as operators and x86 builtins, same results (docs/bench-notes.md, "Inline math"). */
#if defined(__x86_64__) && defined(__AVX__) && !defined(CLSHADE_LIBRARY_MATH) && \
    (defined(CLSHADE_INLINE_MATH_FORCE) || (defined(CLSHADE_HOST_AVX512F) && !defined(__AVX512F__)))
#define CLSHADE_INLINE_MATH 1
#define OVL __attribute__((overloadable, always_inline)) inline
#if SIMD == 16
/* float16 arguments without AVX-512 "change the ABI" (clang -Wpsabi): every
 * function here is inlined, so no call passes one; the warning would otherwise
 * print on every build (tests/render/test_meshes.py wants an empty stderr). */
#pragma clang diagnostic ignored "-Wpsabi"
#endif

/* Unaligned vector views of float / uchar memory (vloadN needs only element
 * alignment; SIMD 16 rows sit at multiples of 8 floats). */
typedef float float4u __attribute__((ext_vector_type(4), aligned(4)));
typedef float float8u __attribute__((ext_vector_type(8), aligned(4)));
typedef float float16u __attribute__((ext_vector_type(16), aligned(4)));
typedef uchar uchar4u __attribute__((ext_vector_type(4), aligned(1)));
typedef uchar uchar8u __attribute__((ext_vector_type(8), aligned(1)));
typedef uchar uchar16u __attribute__((ext_vector_type(16), aligned(1)));

/* fmax/fmin: the other operand when one is NaN (OpenCL 6.15.2). */
#define CLSHADE_MINMAX(T) \
    OVL T clshade_fmax(T a, T b) { return (a > b || b != b) ? a : b; } \
    OVL T clshade_fmin(T a, T b) { return (a < b || b != b) ? a : b; }
#define CLSHADE_MINMAX_S(T) \
    CLSHADE_MINMAX(T) \
    OVL T clshade_fmax(T a, float b) { return clshade_fmax(a, (T)(b)); } \
    OVL T clshade_fmin(T a, float b) { return clshade_fmin(a, (T)(b)); } \
    OVL T clshade_clamp(T x, float lo, float hi) { return clshade_fmin(clshade_fmax(x, lo), hi); } \
    OVL T clshade_clamp(T x, T lo, T hi) { return clshade_fmin(clshade_fmax(x, lo), hi); }
CLSHADE_MINMAX(float)
CLSHADE_MINMAX(double)
CLSHADE_MINMAX_S(float2)
CLSHADE_MINMAX_S(float3)
CLSHADE_MINMAX_S(float4)
CLSHADE_MINMAX_S(float8)
#if SIMD == 16     /* float16 arguments only where built (without AVX-512 they warn: ABI) */
CLSHADE_MINMAX_S(float16)
#endif
OVL float clshade_clamp(float x, float lo, float hi) { return clshade_fmin(clshade_fmax(x, lo), hi); }

OVL float clshade_sqrt(float x) { return __builtin_sqrtf(x); }
OVL double clshade_sqrt(double x) { return __builtin_sqrt(x); }
OVL float4 clshade_sqrt(float4 x) { return __builtin_ia32_sqrtps(x); }
OVL float8 clshade_sqrt(float8 x) { return __builtin_ia32_sqrtps256(x); }
#if SIMD == 16
OVL float16 clshade_sqrt(float16 x) {
    return (float16)(__builtin_ia32_sqrtps256(x.lo), __builtin_ia32_sqrtps256(x.hi));
}
#endif
#define CLSHADE_RSQRT(T) OVL T clshade_rsqrt(T x) { return 1.0f / clshade_sqrt(x); }
CLSHADE_RSQRT(float)
CLSHADE_RSQRT(float4)
CLSHADE_RSQRT(float8)
#if SIMD == 16
CLSHADE_RSQRT(float16)
#endif
OVL double clshade_rsqrt(double x) { return 1.0 / clshade_sqrt(x); }

/* |x| by the sign bit; floor by roundps (mode 9: towards −∞, no exception). */
#define CLSHADE_FABS_FLOOR(T, I, ROUND) \
    OVL T clshade_fabs(T x) { return CLSHADE_CAT2(as_, T)(CLSHADE_CAT2(as_, I)(x) & 0x7fffffff); } \
    OVL T clshade_floor(T x) { return ROUND; }
#define CLSHADE_CAT2_(a, b) a##b
#define CLSHADE_CAT2(a, b) CLSHADE_CAT2_(a, b)
CLSHADE_FABS_FLOOR(float, int, __builtin_floorf(x))
OVL double clshade_fabs(double x) { return __builtin_fabs(x); }
OVL double clshade_floor(double x) { return __builtin_floor(x); }
CLSHADE_FABS_FLOOR(float4, int4, __builtin_ia32_roundps(x, 9))
CLSHADE_FABS_FLOOR(float8, int8, __builtin_ia32_roundps256(x, 9))
#if SIMD == 16
CLSHADE_FABS_FLOOR(float16, int16, ((float16)(__builtin_ia32_roundps256(x.lo, 9), __builtin_ia32_roundps256(x.hi, 9))))
#endif

/* PoCL's headers define some builtins as macros (renames) already. */
#undef fmax
#undef fmin
#undef sqrt
#undef rsqrt
#undef fabs
#undef floor
#define fmax(a, b) clshade_fmax((a), (b))
#define fmin(a, b) clshade_fmin((a), (b))
#define sqrt(x) clshade_sqrt(x)
#define rsqrt(x) clshade_rsqrt(x)
#define fabs(x) clshade_fabs(x)
#define floor(x) clshade_floor(x)

#if SIMD == 1
#undef convert_real
#define convert_real(x) ((real)(x))
#elif SIMD == 4 || SIMD == 8 || SIMD == 16
#undef clamp
#define clamp(x, lo, hi) clshade_clamp((x), (lo), (hi))
#undef convert_real
#define convert_real(x) __builtin_convertvector((x), real)
/* Saturating float → int: NaN → 0, out-of-range to the nearest int (OpenCL 6.4.3). */
#undef convert_mask_sat
#define convert_mask_sat(x) __builtin_convertvector( \
    (x) != (x) ? (real)(0.0f) : clamp((x), -2147483648.0f, 2147483520.0f), mask)
#if defined(__F16C__) && SIMD >= 8
/* vload_halfN by vcvtph2ps (F16C), 8 halves at a time. */
typedef short short8u __attribute__((ext_vector_type(8), aligned(2)));
#define CLSHADE_HALF8(k, p) __builtin_ia32_vcvtph2ps256(*(__global const short8u*)((__global const half*)(p) + 8 * (size_t)(k)))
#undef VLOAD_HALF
#if SIMD == 8
#define VLOAD_HALF(i, p) CLSHADE_HALF8((i), (p))
#else
#define VLOAD_HALF(i, p) ((float16)(CLSHADE_HALF8(2 * (i), (p)), CLSHADE_HALF8(2 * (i) + 1, (p))))
#endif
#endif
#undef convert_mask_rte
#if SIMD == 4
#define convert_mask_rte(x) __builtin_ia32_cvtps2dq(x)
#elif SIMD == 8
#define convert_mask_rte(x) __builtin_ia32_cvtps2dq256(x)
#else
#define convert_mask_rte(x) ((int16)(__builtin_ia32_cvtps2dq256((x).lo), __builtin_ia32_cvtps2dq256((x).hi)))
#endif
#undef VLOAD
#undef VLOAD_UCHAR
#define VLOAD(i, p) (*(__global const CLSHADE_CAT3(float, SIMD, u)*)((p) + SIMD * (size_t)(i)))
#define VLOAD_UCHAR(i, p) __builtin_convertvector( \
    *(__global const CLSHADE_CAT3(uchar, SIMD, u)*)((p) + SIMD * (size_t)(i)), uindex)
#define CLSHADE_CAT3_(a, b, c) a##b##c
#define CLSHADE_CAT3(a, b, c) CLSHADE_CAT3_(a, b, c)
#endif
/* vstore8(v, k, p): gbuffer.h's interleaved float4 rows. */
#define VSTORE8(v, k, p) (*(__global float8u*)((p) + 8 * (size_t)(k)) = (v))
#else
#define VSTORE8(v, k, p) vstore8((v), (k), (p))
#endif

/* any()/all() of a lane mask from the sign bits (movmskps: one instruction per 8 lanes) on every
 * x86 build with AVX: PoCL 3.1 inlines its library's any(int16) as 8 ORs, each branched on. */
#if defined(__x86_64__) && defined(__AVX__) && SIMD > 1
#undef ANY
#undef ALL
#if SIMD == 4
#define MASK_BITS(m) __builtin_ia32_movmskps(as_float4(m))
#define MASK_FULL 0xf
#elif SIMD == 8
#define MASK_BITS(m) __builtin_ia32_movmskps256(as_float8(m))
#define MASK_FULL 0xff
#else
#define MASK_BITS(m) (__builtin_ia32_movmskps256(as_float8((m).lo)) | (__builtin_ia32_movmskps256(as_float8((m).hi)) << 8))
#define MASK_FULL 0xffff
#endif
#define ANY(m) (MASK_BITS(m) != 0)
#define ALL(m) (MASK_BITS(m) == MASK_FULL)
#endif

/* PREFETCH(p): prefetcht0 of the line at p on x86 (never faults: an address past the buffer is
 * harmless), else nothing; CLSHADE_NO_PREFETCH=1 on the host leaves it out. What is prefetched
 * and why: gbuffer.h's PREFETCH_AHEAD. */
#if defined(__x86_64__) && !defined(CLSHADE_NO_PREFETCH)
#define CLSHADE_PREFETCH 1
#define PREFETCH(p) __builtin_prefetch((p))
#else
#define PREFETCH(p) ((void)0)
#endif

/* STORE_ROW8(v, k, p): row k of 8 floats at 32-byte aligned p; on x86 with AVX a streaming store,
 * which skips the read for ownership of each output line. Weakly ordered: PoCL's locked
 * instructions at a work-group's end drain them (docs/bench-notes.md, "Streaming stores"). */
#if defined(__x86_64__) && defined(__AVX__) && !defined(CLSHADE_CACHED_STORES)
#define CLSHADE_STREAMING_STORES 1
#define STORE_ROW8(v, k, p) __builtin_nontemporal_store((v), (__global float8*)((p) + 8 * (size_t)(k)))
#else
#define STORE_ROW8(v, k, p) VSTORE8((v), (k), (p))
#endif

/* One lane of a real, for the per-pixel work that stays scalar (material
 * table gathers, shadow-map taps). */
typedef union { real v; float s[SIMD]; } real_lanes;
typedef union { uindex v; uint s[SIMD]; } uindex_lanes;
typedef union { mask v; int s[SIMD]; } mask_lanes;

/* p[idx] per lane: a gather. Where the kernel compiles for AVX2 (PoCL on x86), vgatherdps, one
 * instruction per 8 lanes (PoCL's LLVM does not emit it from a loop of loads), and per 16 where it compiles
 * for AVX-512 (PoCL 3.1 on Zen 5: the split sum a little faster in alternated runs than two 8-lane ones);
 * else one scalar load per lane (Intel's CPU compiler defines no __AVX2__; CLSHADE_SCALAR_GATHER forces it). */
#if defined(__x86_64__) && defined(__AVX2__) && SIMD >= 4 && !defined(CLSHADE_SCALAR_GATHER)
#define CLSHADE_HARDWARE_GATHER 1
#define CLSHADE_GATHER8(p, i) __builtin_ia32_gatherd_ps256((float8)(0.0f), (p), (i), as_float8((int8)(-1)), 4)
INLINE real gather(__global const float* p, mask idx) {
#if SIMD == 4
    return __builtin_ia32_gatherd_ps((float4)(0.0f), p, idx, as_float4((int4)(-1)), 4);
#elif SIMD == 8
    return CLSHADE_GATHER8(p, idx);
#elif defined(__AVX512F__)
    return __builtin_ia32_gathersiv16sf((float16)(0.0f), p, idx, (ushort)0xFFFF, 4);
#else
    return (float16)(CLSHADE_GATHER8(p, idx.lo), CLSHADE_GATHER8(p, idx.hi));
#endif
}
#else
INLINE real gather(__global const float* p, mask idx) {
    mask_lanes k = {idx};
    real_lanes r;
    for (int j = 0; j < SIMD; ++j)
        r.s[j] = p[k.s[j]];
    return r.v;
}
#endif

/* The double build: OpenCL's fmax(double, float) is ambiguous (the double and the
 * doublen-with-scalar overloads), and the kernels mix real operands with float
 * constants everywhere. One double overload each: float arguments convert. */
#ifdef REAL_DOUBLE
INLINE double clshade_dfmax(double a, double b) { return fmax(a, b); }
INLINE double clshade_dfmin(double a, double b) { return fmin(a, b); }
INLINE double clshade_dclamp(double x, double lo, double hi) { return fmin(fmax(x, lo), hi); }
#undef fmax
#undef fmin
#undef clamp
#define fmax(a, b) clshade_dfmax((a), (b))
#define fmin(a, b) clshade_dfmin((a), (b))
#define clamp(x, lo, hi) clshade_dclamp((x), (lo), (hi))
#endif

/* The start of a sum of vec3 terms: −0, the identity of IEEE addition (x + (−0) = x, −0 and NaN
 * included), so the compiler drops the first addition; from +0 it must keep it without fast math. */
#define SUM_START v3s((real)(-0.0f))

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

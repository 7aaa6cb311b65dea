/* gbuffer.h — G-buffer reads and image writes for SIMD pixels per work-item
 * (simd.h), shared by shade.cl and its bandwidth floor copy.cl so that both
 * move exactly the same bytes in the same pattern.
 *
 * One-component channels hold one value per pixel; normal and base colour
 * are three planes (x, y, z) of floats or, with HALF_GBUFFER, halves. The
 * output is one float4 per pixel, interleaved (the image the host reads).
 */
#ifndef CLSHADE_GBUFFER_H
#define CLSHADE_GBUFFER_H

#ifdef HALF_GBUFFER
#define GB3 half
#else
#define GB3 float
#endif

/* The variant's G-buffer channels as kernel parameters, in the host's argument order
 * (Variant.channels): shade.cl and copy.cl both declare them as GBUFFER_PARAMS, and the
 * prefetch below uses these names. The general kernel reads every channel. */
#if HAS_ROUGHNESS || GENERAL
#define GB_ROUGHNESS_PARAM , __global const float* roughness
#else
#define GB_ROUGHNESS_PARAM
#endif
#if HAS_METALLIC || GENERAL
#define GB_METALLIC_PARAM , __global const float* metallic
#else
#define GB_METALLIC_PARAM
#endif
#if HAS_EMISSIVE
#define GB_EMISSIVE_PARAM , __global const float* emissive
#else
#define GB_EMISSIVE_PARAM
#endif
#if HAS_OCCLUSION
#define GB_OCCLUSION_PARAM , __global const float* occlusion
#else
#define GB_OCCLUSION_PARAM
#endif
#if HAS_TANGENT
#define GB_TANGENT_PARAM , __global const float* tangent
#else
#define GB_TANGENT_PARAM
#endif
#if HAS_MATERIAL || GENERAL
#define GB_MATERIAL_PARAM , __global const uchar* material
#else
#define GB_MATERIAL_PARAM
#endif
#define GBUFFER_PARAMS __global const float* depth, __global const GB3* normal, __global const GB3* base \
    GB_ROUGHNESS_PARAM GB_METALLIC_PARAM GB_EMISSIVE_PARAM GB_OCCLUSION_PARAM GB_TANGENT_PARAM GB_MATERIAL_PARAM

/* The SIMD pixels' 3-channel values of work-item i from three planes (x, y, z), each
 * `plane` elements long (clshade/device/shade.py uploads them so): three aligned vector
 * loads, where an interleaved layout costs ~40 shuffles per channel to de-interleave. */
#ifdef HALF_GBUFFER
#define LOAD_PLANE(i, p) VLOAD_HALF((i), (p))
#else
#define LOAD_PLANE(i, p) VLOAD((i), (p))
#endif
INLINE vec3 load3(size_t i, __global const GB3* p, uint plane) {
    return v3(LOAD_PLANE(i, p), LOAD_PLANE(i, p + plane), LOAD_PLANE(i, p + 2 * plane));
}

/* A 3-channel float plane triple that is never stored as half (emission). */
INLINE vec3 load3f(size_t i, __global const float* p, uint plane) {
    return v3(VLOAD(i, p), VLOAD(i, p + plane), VLOAD(i, p + 2 * plane));
}

/* Prefetch, PREFETCH_PIXELS ahead, the channels a covered work-item reads: the hardware
 * prefetchers stop at every 4 KiB page. A sky work-item prefetches too when the one ahead is
 * covered; both kernels alike, so that copy.cl stays the floor of the same traffic. */
#define PREFETCH_PIXELS 128
#define PREFETCH_PLANE3(p, o) do { PREFETCH((p) + (o)); PREFETCH((p) + plane + (o)); \
                                   PREFETCH((p) + 2 * plane + (o)); } while (0)
#if HAS_ROUGHNESS
#define PREFETCH_ROUGHNESS(o) PREFETCH(roughness + (o))
#else
#define PREFETCH_ROUGHNESS(o) ((void)0)
#endif
#if HAS_METALLIC
#define PREFETCH_METALLIC(o) PREFETCH(metallic + (o))
#else
#define PREFETCH_METALLIC(o) ((void)0)
#endif
#if HAS_EMISSIVE
#define PREFETCH_EMISSIVE(o) PREFETCH_PLANE3(emissive, (o))
#else
#define PREFETCH_EMISSIVE(o) ((void)0)
#endif
#if HAS_OCCLUSION
#define PREFETCH_OCCLUSION(o) PREFETCH(occlusion + (o))
#else
#define PREFETCH_OCCLUSION(o) ((void)0)
#endif
#if HAS_MATERIAL
#define PREFETCH_MATERIAL(o) PREFETCH(material + (o))
#else
#define PREFETCH_MATERIAL(o) ((void)0)
#endif
#define PREFETCH_GBUFFER(first) do { \
        size_t o_ = (size_t)(first) + PREFETCH_PIXELS; \
        PREFETCH(depth + o_); PREFETCH_PLANE3(normal, o_); PREFETCH_PLANE3(base, o_); \
        PREFETCH_ROUGHNESS(o_); PREFETCH_METALLIC(o_); PREFETCH_EMISSIVE(o_); \
        PREFETCH_OCCLUSION(o_); PREFETCH_MATERIAL(o_); \
    } while (0)
#ifdef CLSHADE_PREFETCH
#define PREFETCH_AHEAD(i, z) do { \
        size_t ahead_ = (size_t)(i) + PREFETCH_PIXELS / SIMD; \
        if (!all_empty(z) || (SIMD * ahead_ < npix && !all_empty(VLOAD(ahead_, depth)))) \
            PREFETCH_GBUFFER(SIMD * (i)); \
    } while (0)
#else
#define PREFETCH_AHEAD(i, z) ((void)0)
#endif

/* None of the work-item's pixels is covered (depth ≤ 0 in every lane): the
 * shading kernel then reads only depth and writes the background, and the copy
 * kernel does the same so that the bandwidth floor moves the same bytes. */
INLINE int all_empty(real depth) { return !ANY(depth > 0.0f); }

/* Eight pixels' x, y, z and a (a float8 each) written interleaved, as 4 rows of 8 floats: the
 * textbook unpack / shuffle / 128-bit permute transpose (12 shuffles; built from elements, LLVM
 * made ~96). Rows go out by STORE_ROW8 (simd.h: streaming stores on x86). */
INLINE void store8_rows(__global float* o, float8 x, float8 y, float8 z, float8 a) {
    float8 t0 = __builtin_shufflevector(x, y, 0, 8, 1, 9, 4, 12, 5, 13);
    float8 t1 = __builtin_shufflevector(x, y, 2, 10, 3, 11, 6, 14, 7, 15);
    float8 t2 = __builtin_shufflevector(z, a, 0, 8, 1, 9, 4, 12, 5, 13);
    float8 t3 = __builtin_shufflevector(z, a, 2, 10, 3, 11, 6, 14, 7, 15);
    float8 u0 = __builtin_shufflevector(t0, t2, 0, 1, 8, 9, 4, 5, 12, 13);
    float8 u1 = __builtin_shufflevector(t0, t2, 2, 3, 10, 11, 6, 7, 14, 15);
    float8 u2 = __builtin_shufflevector(t1, t3, 0, 1, 8, 9, 4, 5, 12, 13);
    float8 u3 = __builtin_shufflevector(t1, t3, 2, 3, 10, 11, 6, 7, 14, 15);
    STORE_ROW8(__builtin_shufflevector(u0, u1, 0, 1, 2, 3, 8, 9, 10, 11), 0, o);
    STORE_ROW8(__builtin_shufflevector(u2, u3, 0, 1, 2, 3, 8, 9, 10, 11), 1, o);
    STORE_ROW8(__builtin_shufflevector(u0, u1, 4, 5, 6, 7, 12, 13, 14, 15), 2, o);
    STORE_ROW8(__builtin_shufflevector(u2, u3, 4, 5, 6, 7, 12, 13, 14, 15), 3, o);
}

/* Write the SIMD pixels of work-item i as float4 (r, g, b, a), from one call site per kernel:
 * LLVM merges two sites' last stores and drops their streaming mark, leaving every line half
 * cached (tests/device/test_specialisation.py checks there is one). */
INLINE void store4(size_t i, __global float4* out, vec3 c, real a) {
#if SIMD == 8
    store8_rows((__global float*)(out + 8 * i), c.x, c.y, c.z, a);
#elif SIMD == 16
    __global float* o = (__global float*)(out + 16 * i);
    store8_rows(o, c.x.lo, c.y.lo, c.z.lo, a.lo);
    store8_rows(o + 32, c.x.hi, c.y.hi, c.z.hi, a.hi);
#else
    real_lanes r = {c.x}, g = {c.y}, b = {c.z}, w = {a};
    for (int j = 0; j < SIMD; ++j)
        out[SIMD * i + j] = (float4)(r.s[j], g.s[j], b.s[j], w.s[j]);
#endif
}

#endif

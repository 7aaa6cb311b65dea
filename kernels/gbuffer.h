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

/* The SIMD pixels' 3-channel values of work-item i. On the device a
 * 3-component channel is planar: x of every pixel, then y, then z, each plane
 * `plane` elements long (the padded pixel count; clshade/device/shade.py uploads
 * it so). Three aligned vector loads per channel: the interleaved layout
 * needed ~40 shuffle instructions per channel per work-item to de-interleave
 * (objdump of PoCL's kernel), in the shading and the copy kernel alike. */
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

/* Software prefetch of the channels a covered work-item reads, PREFETCH_PIXELS
 * pixels (8 work-items at SIMD 16: 512 B of a float plane) ahead of pixel
 * `first`. The hardware prefetchers follow a stream only after a few misses
 * and stop at every 4 KiB page; a covered work-item reads one line from each
 * of up to 14 planes, so without the hint about a sixth of GGX's samples sat
 * on G-buffer loads (perf annotate of PoCL 3.0's binary). Distances of 4, 8,
 * 16 and 32 work-items were tried: 8 and 16 were fastest (A/B in one process,
 * docs/bench-notes.md 2026-11-25). Uses the kernel's parameter names (depth,
 * normal, base, …), as shade.cl and copy.cl declare them.
 * PREFETCH_AHEAD(i, z) is what both kernels do with it, the same in both so
 * that the copy kernel stays the floor of the same traffic: a covered
 * work-item prefetches; a sky work-item (which reads only depth) prefetches
 * too when the work-item PREFETCH_PIXELS ahead has a covered pixel, so that
 * the first covered work-items after a stretch of sky do not wait on every
 * plane (the copy kernel ran ~8 % faster with both, and ~1 % slower with the
 * covered half alone). Nothing where PREFETCH is nothing (simd.h). */
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

/* Write the SIMD pixels of work-item i as float4 (r, g, b, a). SIMD 8 and 16
 * build the interleaved float8 rows explicitly (8 pixels = 4 rows): the
 * per-lane loop through the unions made the copy kernel ≈ 1.4× slower at
 * 1080p (measured back to back). The 4 × 8 transpose is the textbook
 * unpack / shuffle / 128-bit permute sequence (12 shuffles) written as
 * __builtin_shufflevector: built from elements, (float8)(x.s0, y.s0, …), LLVM
 * made ~96 shuffles of it per work-item on PoCL 3.0 (objdump), and every
 * kernel was 5–8 % slower (A/B in one process, 2026-11-23). The rows are
 * written with STORE_ROW8 (simd.h: streaming stores on x86).
 * One store4 call per kernel: with two (the sky's early return and the end),
 * LLVM 14 sinks their common last store into one and drops its !nontemporal
 * mark, so every output line got one streaming and one cached half and the
 * copy kernel ran over ten times slower (objdump of PoCL 3.0's binary:
 * vmovntps ×3, vmovaps ×1 per row group; docs/bench-notes.md, 2026-11-25).
 * tests/test_specialisation.py checks that there is one site. */
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

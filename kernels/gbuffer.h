/* gbuffer.h — G-buffer reads and image writes for SIMD pixels per work-item
 * (simd.h), shared by shade.cl and its bandwidth floor copy.cl so that both
 * move exactly the same bytes in the same pattern.
 *
 * Channels are arrays of structs per pixel (normal and base colour: 3 floats
 * or, with HALF_GBUFFER, 3 halves); the output is one float4 per pixel.
 */
#ifndef CLSHADE_GBUFFER_H
#define CLSHADE_GBUFFER_H

#ifdef HALF_GBUFFER
#define GB3 half
#else
#define GB3 float
#endif

/* The SIMD pixels' 3-channel values of work-item i: SIMD × 3 consecutive
 * floats (or halves), de-interleaved into x, y, z lanes. */
#ifdef HALF_GBUFFER
#define LOAD_GB(n, i, p) vload_half##n((i), (p))
#else
#define LOAD_GB(n, i, p) vload##n((i), (p))
#endif
inline vec3 load3(size_t i, __global const GB3* p) {
#if SIMD == 1
    float3 t = LOAD_GB(3, i, p);
    return v3(t.x, t.y, t.z);
#elif SIMD == 4
    float4 a = LOAD_GB(4, 3 * i, p), b = LOAD_GB(4, 3 * i + 1, p), c = LOAD_GB(4, 3 * i + 2, p);
    return v3((float4)(a.s03, b.s2, c.s1), (float4)(a.s1, b.s03, c.s2), (float4)(a.s2, b.s1, c.s03));
#else
    float8 a = LOAD_GB(8, 3 * i, p), b = LOAD_GB(8, 3 * i + 1, p), c = LOAD_GB(8, 3 * i + 2, p);
    return v3((float8)(a.s036, b.s147, c.s25), (float8)(a.s147, b.s25, c.s036),
              (float8)(a.s25, b.s036, c.s147));
#endif
}

/* Write the SIMD pixels of work-item i as float4 (r, g, b, a). SIMD 8 builds
 * the four interleaved float8 rows explicitly: the per-lane loop through the
 * unions made the copy kernel ≈ 1.4× slower at 1080p (measured back to back). */
inline void store4(size_t i, __global float4* out, vec3 c, real a) {
#if SIMD == 8
    __global float* o = (__global float*)(out + 8 * i);
    vstore8((float8)(c.x.s0, c.y.s0, c.z.s0, a.s0, c.x.s1, c.y.s1, c.z.s1, a.s1), 0, o);
    vstore8((float8)(c.x.s2, c.y.s2, c.z.s2, a.s2, c.x.s3, c.y.s3, c.z.s3, a.s3), 1, o);
    vstore8((float8)(c.x.s4, c.y.s4, c.z.s4, a.s4, c.x.s5, c.y.s5, c.z.s5, a.s5), 2, o);
    vstore8((float8)(c.x.s6, c.y.s6, c.z.s6, a.s6, c.x.s7, c.y.s7, c.z.s7, a.s7), 3, o);
#else
    real_lanes r = {c.x}, g = {c.y}, b = {c.z}, w = {a};
    for (int j = 0; j < SIMD; ++j)
        out[SIMD * i + j] = (float4)(r.s[j], g.s[j], b.s[j], w.s[j]);
#endif
}

#endif

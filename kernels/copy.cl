/* copy.cl — the memory-bandwidth floor of a shading pass: reads exactly the
 * G-buffer channels a model variant reads (same defines as shade.cl, same
 * SIMD pixels per work-item, same loads and stores from gbuffer.h) and writes
 * the same float4 output, with no lighting arithmetic. Like shade.cl it
 * reads only the depth of a work-item whose pixels are all empty, and it
 * writes the background where shade.cl does. */
__kernel void copy(const uint npix, const uint plane, GBUFFER_PARAMS,   /* gbuffer.h, as shade.cl */
    const float4 background, __global float4* out)
{
    size_t i = get_global_id(0);
    if (SIMD * i >= npix) return;
    real w = VLOAD(i, depth);
    PREFETCH_AHEAD(i, w);   /* as shade.cl: the same prefetches (gbuffer.h) */
    /* The background wherever shade.cl writes it (a sky work-item reads only depth, as there),
     * not 0: lines of zeros can be written faster than other values, and the floor must store
     * what shade.cl stores (docs/bench-notes.md). One store4 site, as there (gbuffer.h). */
    vec3 color = v3c(background.xyz);
    real alpha = (real)(background.w);
    if (!all_empty(w)) {
        mask covered = w > 0.0f;
        vec3 acc = v3add(load3(i, normal, plane), load3(i, base, plane));
#if HAS_ROUGHNESS
        w += VLOAD(i, roughness);
#endif
#if HAS_METALLIC
        w += VLOAD(i, metallic);
#endif
#if HAS_EMISSIVE
        acc = v3add(acc, load3f(i, emissive, plane));
#endif
#if HAS_OCCLUSION
        w += VLOAD(i, occlusion);
#endif
#if HAS_TANGENT
        acc = v3add(acc, load3f(i, tangent, plane));
#endif
#if HAS_MATERIAL
        w += convert_real(VLOAD_UCHAR(i, material));
#endif
        color = v3select(covered, acc, color);
        alpha = covered ? w : alpha;
    }
    store4(i, out, color, alpha);
}

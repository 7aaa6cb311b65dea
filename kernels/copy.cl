/* copy.cl — the memory-bandwidth floor of a shading pass: reads exactly the
 * G-buffer channels a model variant reads (same defines as shade.cl, same
 * SIMD pixels per work-item, same loads and stores from gbuffer.h) and writes
 * the same float4 output, with no lighting arithmetic. Like shade.cl it
 * reads only the depth of a work-item whose pixels are all empty. */
__kernel void copy(const uint npix, const uint plane,
    __global const float* depth, __global const GB3* normal, __global const GB3* base
#if HAS_ROUGHNESS
    , __global const float* roughness
#endif
#if HAS_METALLIC
    , __global const float* metallic
#endif
#if HAS_EMISSIVE
    , __global const float* emissive
#endif
#if HAS_OCCLUSION
    , __global const float* occlusion
#endif
#if HAS_MATERIAL
    , __global const uchar* material
#endif
    , __global float4* out)
{
    size_t i = get_global_id(0);
    if (SIMD * i >= npix) return;
    real w = VLOAD(i, depth);
    PREFETCH_AHEAD(i, w);   /* as shade.cl: the same prefetches (gbuffer.h) */
    vec3 acc = v3s((real)(0.0f));
    /* shade.cl reads only the depth of a work-item with no covered pixel; one
     * store4 site, as there (gbuffer.h). */
    if (!all_empty(w)) {
        acc = v3add(load3(i, normal, plane), load3(i, base, plane));
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
#if HAS_MATERIAL
        w += convert_real(VLOAD_UCHAR(i, material));
#endif
    }
    store4(i, out, acc, w);
}

/* copy.cl — the memory-bandwidth floor of a shading pass: reads exactly the
 * G-buffer channels a model variant reads (same defines as shade.cl) and
 * writes the same float4 output, with no lighting arithmetic. */
#ifdef HALF_GBUFFER
#define LOAD3(i, p) vload_half3((i), (p))
#define GB3 half
#else
#define LOAD3(i, p) vload3((i), (p))
#define GB3 float
#endif

__kernel void copy(const uint npix,
    __global const float* depth, __global const GB3* normal, __global const GB3* base
#if HAS_ROUGHNESS
    , __global const float* roughness
#endif
#if HAS_METALLIC
    , __global const float* metallic
#endif
#if HAS_MATERIAL
    , __global const uchar* material
#endif
    , __global float4* out)
{
    uint i = get_global_id(0);
    if (i >= npix) return;
    float3 acc = LOAD3(i, normal) + LOAD3(i, base);
    float w = depth[i];
#if HAS_ROUGHNESS
    w += roughness[i];
#endif
#if HAS_METALLIC
    w += metallic[i];
#endif
#if HAS_MATERIAL
    w += (float)material[i];
#endif
    out[i] = (float4)(acc, w);
}

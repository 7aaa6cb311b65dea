/* fresnel_cost.cl — the arithmetic cost of one Fresnel term of brdf.h.
 * Each work-item evaluates the term at REPEAT cosines it computes itself and
 * writes one float, so the time is the term's arithmetic, not memory traffic.
 * TERM: 0 = F_Schlick, 1 = F_Dielectric, 2 = F_Conductor, 3 = the loop alone
 * (subtracted as the baseline). All three colour channels are consumed.
 * Assembled after kernels/simd.h (SIMD = 1) and kernels/brdf.h by benchmarks/measure/make_report.py.
 */
__kernel void fresnel_cost(const uint count, const float ior, const float4 eta, const float4 k,
                           const float4 f0, __global float* out)
{
    uint i = get_global_id(0);
    if (i >= count) return;
    float acc = 0.0f;
    for (int j = 0; j < REPEAT; ++j) {
        float c = ((float)((i * 131u + (uint)j * 7919u) & 1023u) + 0.5f) * (1.0f / 1024.0f);
#if TERM == 0
        vec3 F = F_Schlick(c, v3c(f0.xyz), 1.0f);
        acc += F.x + F.y + F.z;
#elif TERM == 1
        acc += F_Dielectric(c, ior);
#elif TERM == 2
        vec3 F = F_Conductor(c, v3c(eta.xyz), v3c(k.xyz));
        acc += F.x + F.y + F.z;
#else
        acc += c;
#endif
    }
    out[i] = acc;
}

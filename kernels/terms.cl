/* terms.cl — each term function of brdf.h on its own, for arrays of scalar
 * inputs: the device side of the per-term accuracy tests (tests/device/test_terms.py,
 * clshade/verify/accuracy.py), in the spirit of BRDF Explorer's single-term files.
 *
 * One kernel per term, named term_<function>; all share one signature:
 *   x[i]  float4  the scalar arguments in the function's order
 *   y[i]  float4  a colour argument (f0, or the conductor's η), rgb
 *   z[i]  float4  a second colour argument (the conductor's k), rgb
 *   out[i] float4 the term: scalar terms in .x, colour terms in .xyz
 * The Python side (clshade.accuracy.TERMS) says which slots each term reads.
 * Assembled after simd.h (SIMD = 1: real is float, vec3 a struct) and brdf.h (clshade.accuracy.term_source).
 */
#define TERM_KERNEL(NAME, EXPR)                                               \
__kernel void term_##NAME(const uint count, __global const float4* x,         \
                          __global const float4* y, __global const float4* z, \
                          __global float4* out)                               \
{                                                                             \
    uint i = get_global_id(0);                                                \
    if (i >= count) return;                                                   \
    float4 a = x[i];                                                          \
    vec3 b = v3c(y[i].xyz);                                                   \
    vec3 c = v3c(z[i].xyz);                                                   \
    out[i] = EXPR;                                                            \
}

#define SCALAR(value) (float4)((value), 0.0f, 0.0f, 0.0f)
INLINE float4 colour4(vec3 c) { return (float4)(c.x, c.y, c.z, 0.0f); }
#define COLOUR(value) colour4(value)

TERM_KERNEL(D_GGX,               SCALAR(D_GGX(a.x, a.y, a.z)))
TERM_KERNEL(D_Beckmann,          SCALAR(D_Beckmann(a.x, a.y, a.z)))
TERM_KERNEL(V_SmithGGXCorrelated, SCALAR(V_SmithGGXCorrelated(a.x, a.y, a.z)))
TERM_KERNEL(V_SmithGGXSeparable, SCALAR(V_SmithGGXSeparable(a.x, a.y, a.z)))
TERM_KERNEL(V_SmithSchlickGGX,   SCALAR(V_SmithSchlickGGX(a.x, a.y, a.z)))
TERM_KERNEL(V_CookTorrance,      SCALAR(V_CookTorrance(a.x, a.y, a.z, a.w)))
TERM_KERNEL(F_Schlick,           COLOUR(F_Schlick(a.x, b, a.y)))
TERM_KERNEL(F_Dielectric,        SCALAR(F_Dielectric(a.x, a.y)))
TERM_KERNEL(F_Dielectric_unclamped, SCALAR(F_Dielectric_unclamped(a.x, a.y)))
TERM_KERNEL(F_Conductor,         COLOUR(F_Conductor(a.x, b, c)))
TERM_KERNEL(F_Conductor_unclamped, COLOUR(F_Conductor_unclamped(a.x, b, c)))
TERM_KERNEL(Fd_Lambert,          SCALAR(Fd_Lambert()))
TERM_KERNEL(Fd_Burley,           SCALAR(Fd_Burley(a.x, a.y, a.z, a.w)))
TERM_KERNEL(Fd_OrenNayar,        SCALAR(Fd_OrenNayar(a.x, a.y, a.z, a.w)))
TERM_KERNEL(Fs_Phong,            SCALAR(Fs_Phong(a.x, a.y)))
TERM_KERNEL(Fs_BlinnPhong,       SCALAR(Fs_BlinnPhong(a.x, a.y)))

/* Not a term: the Phong powers' early-out (brdf.h power_underflows) beside the power
 * it claims is 0 — .x pow_runtime(x, n), .y 1 where the lane is claimed
 * (tests/device/test_terms.py, test_power_underflow_claims_only_exact_zeros). */
TERM_KERNEL(power_underflows,    (float4)(pow_runtime(a.x, a.y), power_underflows(a.x, a.y) ? 1.0f : 0.0f, 0.0f, 0.0f))

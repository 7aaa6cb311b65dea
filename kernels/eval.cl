/* eval.cl — evaluate one lighting model's f (without the cosine) for arrays of
 * (n, l, v) and parameters: the device side of accuracy tests, plausibility
 * (reciprocity, albedo) and the stability grid. Uses exactly the composition
 * of shade.cl (compose.h), so what is measured here is what renders.
 *
 * Per sample i:  n[i], l[i], v[i]  float4 (xyz used, need not be unit)
 *                base[i]           float4 (rgb)
 *                p[i]              float4 (roughness, metallic, -, -)
 *                m[4i .. 4i+3]     the material constants (see surface.h)
 *                t[i]              float4 (xyz: the surface's tangent, 0 = none; read by
 *                                  lobes that use the tangent frame, surface.h)
 * Built with SIMD = 1 (simd.h): one sample per work-item.
 * Output f[i] = (f.rgb, n·l > 0 ? 1 : 0): f is 0 when l is below the horizon
 * (the renderer's cut), unless built with EVAL_BELOW_HORIZON, which returns the
 * composed f there too (the GLSL oracle compares a translated .brdf file's BRDF
 * at every direction); double4 in the double build (REAL_DOUBLE, simd.h), float4
 * otherwise.
 */
#ifdef REAL_DOUBLE
typedef double4 out4;
#else
typedef float4 out4;
#endif

__kernel void eval_brdf(const uint count,
    __global const float4* n, __global const float4* l, __global const float4* v,
    __global const float4* base, __global const float4* p, __global const float4* m,
    __global const float4* t, __global out4* f
#ifdef COUNT_TERMS
    , __global uint* term_counts   /* count.h: TERMS × CHECKS counters */
#endif
    )
{
    uint i = get_global_id(0);
    if (i >= count) return;
    vec3 vv = unit_or(v3c(v[i].xyz), v3(0.0f, 0.0f, 1.0f));
    vec3 nn = unit_or(v3c(n[i].xyz), vv);
    vec3 ll = unit_or(v3c(l[i].xyz), v3s(0.0f));
    Surface s = make_surface(v3max(v3c(base[i].xyz), 0.0f), saturate(p[i].x), saturate(p[i].y),
                             material_uniform(m[4 * i], m[4 * i + 1], m[4 * i + 2], m[4 * i + 3]));
    COUNT_INTO(s, term_counts);
    Geometry g = make_geometry(nn, ll, vv);
#ifdef GEOMETRY_TANGENTS
    s.tangent = v3c(t[i].xyz);
    surface_frame(&g, nn, s);
#endif
    vec3 fr = brdf(g, s);
#ifdef EVAL_BELOW_HORIZON
    f[i] = (out4)(fr.x, fr.y, fr.z, g.nl_raw > 0.0f ? 1.0f : 0.0f);
#else
    f[i] = g.nl_raw > 0.0f ? (out4)(fr.x, fr.y, fr.z, 1.0f) : (out4)(0.0f);
#endif
}

/* compose.h — the one place where a lighting model is assembled:
 *   f = k_d · diffuse_color · f_d  +  k_s · f_s
 * f_d is the diffuse lobe (diffuse_lobe() from the diffuse model file),
 * f_s the specular lobe (specular_lobe(), Fresnel included for microfacet
 * lobes). Metallic workflow: k_d = (1 − F(n·l))(1 − F(n·v)) (1 without a
 * Fresnel-bearing specular lobe), k_s = 1, diffuse_color = base·(1−metallic).
 * k_d + k_s = 1 workflow (the study's): k_d, k_s from the material.
 * HAS_DIFFUSE / HAS_SPECULAR are 0 for a model without that lobe.
 */
#ifndef CLSHADE_COMPOSE_H
#define CLSHADE_COMPOSE_H

inline float3 brdf(const Geometry g, const Surface s) {
    float3 f = (float3)(0.0f);
#if HAS_DIFFUSE
#if HAS_SPECULAR && SPECULAR_FRESNEL && WORKFLOW == WORKFLOW_METALLIC
    /* Energy split of the metallic workflow: light the specular interface
     * reflects on the way in or out does not reach or leave the diffuse
     * substrate: k_d = (1 − F(n·l))(1 − F(n·v)), symmetric in l and v so f
     * stays reciprocal (Shirley et al. 1997; Ashikhmin & Shirley 2000). The
     * measured composed albedo is in `clshade check plausibility`. */
    float3 kd = (1.0f - fresnel_cos(g.nl, s)) * (1.0f - fresnel_cos(g.nv, s));
#else
    float3 kd = (float3)(s.kd);
#endif
    f += (kd * diffuse_lobe(g, s)) * s.diffuse_color;
#endif
#if HAS_SPECULAR
    f += s.ks * specular_lobe(g, s);
#endif
    return f;
}

/* Radiance reflected towards v from one light of irradiance E arriving from l
 * (unit, towards the light): f · (n·l) · E, and exactly 0 below the horizon.
 * E·(n·l) is formed first so that a huge E times a 0 lobe never makes NaN. */
inline float3 shade_light(float3 n, float3 v, float3 l, float3 E, const Surface s) {
    Geometry g = make_geometry(n, l, v);
    float3 e = E * g.nl;
    float3 lo = brdf(g, s) * e;
    return g.nl_raw > 0.0f ? lo : (float3)(0.0f);
}

/* The constant ambient term of the study's shaders, A = ambient radiance:
 * L_a = k_a · A · (k_d · diffuse_color + k_s · F0), k_d = 1 − F0 in the metallic workflow. The specular part uses F0 as
 * a crude hemispherical albedo of the specular lobe, so that metals (no diffuse
 * colour) are not black under ambient light. */
inline float3 ambient_term(float3 A, const Surface s) {
    float3 r = (float3)(0.0f);
#if HAS_DIFFUSE
#if HAS_SPECULAR && SPECULAR_FRESNEL && WORKFLOW == WORKFLOW_METALLIC
    r += (1.0f - s.f0) * s.diffuse_color;      /* k_d = 1 − F, F ≈ F0 */
#else
    r += s.kd * s.diffuse_color;
#endif
#endif
#if HAS_SPECULAR
    r += s.ks * s.f0;
#endif
    return (s.ka * A) * r;
}

#endif

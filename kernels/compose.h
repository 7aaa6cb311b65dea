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

INLINE vec3 brdf(const Geometry g, const Surface s) {
    vec3 f = SUM_START;
#if HAS_DIFFUSE
#if HAS_SPECULAR && SPECULAR_FRESNEL && WORKFLOW == WORKFLOW_METALLIC
    /* Energy split of the metallic workflow: light the specular interface
     * reflects on the way in or out does not reach or leave the diffuse
     * substrate: k_d = (1 − F(n·l))(1 − F(n·v)), symmetric in l and v so f
     * stays reciprocal (Shirley et al. 1997; Ashikhmin & Shirley 2000). The
     * measured composed albedo is in `clshade check plausibility`. */
    vec3 fl = fresnel_cos(g.nl, s), fv = fresnel_cos(g.nv, s);
    vec3 kd = v3((1.0f - fl.x) * (1.0f - fv.x), (1.0f - fl.y) * (1.0f - fv.y), (1.0f - fl.z) * (1.0f - fv.z));
#else
    vec3 kd = v3s(s.kd);
#endif
    f = v3add(f, v3mul(v3scale(kd, diffuse_lobe(g, s)), s.diffuse_color));
#endif
#if HAS_SPECULAR
    f = v3add(f, v3scale(RAW3(s, TERM_SPECULAR, specular_lobe(g, s), UNBOUNDED), s.ks));
#endif
    return RAW3(s, TERM_BRDF, f, UNBOUNDED);
}

/* Radiance reflected towards v from one light of irradiance E arriving from l
 * (unit, towards the light): f · (n·l) · E with the true cosine max(n·l, 0),
 * and exactly 0 below the horizon. The floor MIN_N_DOT_L acts only inside the
 * lobes' denominators (g.nl), never on the irradiance: a pixel at n·l = 1e-5
 * receives 1e-5 · E, not 1e-4 · E. E·(n·l) is formed first so that a huge E
 * times a 0 lobe never makes NaN. */
INLINE vec3 shade_light_lit(vec3 n, vec3 v, vec3 l, vec3 E, const Surface s) {
    /* Every lane below the horizon: the sum below would add exactly 0, so skip
     * the BRDF. One branch per work-item (lanes are neighbouring pixels, mostly
     * alike); about half the covered work-items face away from a given light. */
    if (!ANY(faces_light(n, l)))
        return v3s((real)(0.0f));
    Geometry g = make_geometry(n, l, v);
#ifdef GEOMETRY_TANGENTS
    surface_frame(&g, n, s);
#endif
    vec3 e = v3scale(E, fmax(g.nl_raw, 0.0f));
    vec3 lo = RAW3(s, TERM_LIGHT, v3mul(brdf(g, s), e), UNBOUNDED);
    return v3select(g.nl_raw > 0.0f, lo, v3s((real)(0.0f)));
}

/* shade_light_lit, first skipping a work-item none of whose facing lanes receives
 * light (E = 0: outside a spot cone, in a shadow, a black light). A directional
 * light without shadows has one E for every lane: shade.cl tests it once, on
 * scalars, and calls shade_light_lit. */
INLINE vec3 shade_light(vec3 n, vec3 v, vec3 l, vec3 E, const Surface s) {
    real e_max = fmax(fmax(E.x, E.y), E.z);
    if (!ANY(faces_light(n, l) & (e_max > 0.0f)))
        return v3s((real)(0.0f));
    return shade_light_lit(n, v, l, E, s);
}

/* The constant ambient term of the study's shaders, A = ambient radiance:
 * L_a = k_a · A · (k_d · diffuse_color + k_s · F0), k_d = 1 − F0 in the metallic workflow. The specular part uses F0 as
 * a crude hemispherical albedo of the specular lobe, so that metals (no diffuse
 * colour) are not black under ambient light. */
INLINE vec3 ambient_term(vec3 A, const Surface s) {
    vec3 r = SUM_START;
#if HAS_DIFFUSE
#if HAS_SPECULAR && SPECULAR_FRESNEL && WORKFLOW == WORKFLOW_METALLIC
    r = v3add(r, v3mul(v3sub(v3s((real)(1.0f)), s.f0), s.diffuse_color));   /* k_d = 1 − F, F ≈ F0 */
#else
    r = v3add(r, v3scale(s.diffuse_color, s.kd));
#endif
#endif
#if HAS_SPECULAR
    r = v3add(r, v3scale(s.f0, s.ks));
#endif
    return RAW3(s, TERM_AMBIENT, v3mul(v3scale(A, s.ka), r), UNBOUNDED);
}

#endif

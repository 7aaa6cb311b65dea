/*! clshade-model
 * id: ggx_smith_schlick
 * name: GGX with Smith–Schlick (k = α/2)
 * kind: specular
 * family: microfacet
 * formula: f_s = D_GGX(α) · G1(l) G1(v) · F / (4 (n·l)(n·v)), G1(x) = n·x / (n·x (1−k) + k), k = α/2
 * source: C. Schlick, "An Inexpensive BRDF Model for Physically-based Rendering", CGF 13(3), 1994; k = α/2 as in B. Karis, "Real Shading in Unreal Engine 4", 2013
 * param: roughness | 0 | 1 | 0.5 | perceptual roughness r; α = r²
 * uses: roughness, fresnel
 * note: the study's shader shortcut, kept as a rung of the approximation ladder against walter_ggx and ggx_correlated.
 */
INLINE vec3 specular_lobe(const Geometry g, const Surface s) {
    quotient D = RAW_Q(s, TERM_D, D_GGX_q(g.nh, g.sin2_nh, s.alpha), D_GGX_BOUND(s.alpha));
    quotient V = RAW_Q(s, TERM_V, V_SmithSchlickGGX_q(g.nl, g.nv, s.alpha), V_BOUND(g.nl, g.nv));
    return v3scale(fresnel(g, s), dv_product(D, V));
}

/*! clshade-model
 * id: walter_ggx
 * name: Walter GGX (separable Smith)
 * kind: specular
 * family: microfacet
 * formula: f_s = D_GGX(α) · G1(l) G1(v) · F / (4 (n·l)(n·v)), G1(x) = 2(n·x)/(n·x + √(α² + (1−α²)(n·x)²))
 * source: B. Walter, S. Marschner, H. Li, K. Torrance, "Microfacet Models for Refraction through Rough Surfaces", EGSR 2007
 * param: roughness | 0 | 1 | 0.5 | perceptual roughness r; α = r²
 * uses: roughness, fresnel
 * deviation: the study's appendix uses Schlick's G1 with k = α/2 and the same k as the metallic blend; here G1 is Walter's exact Smith G1 (the k = α/2 shortcut is the separate model ggx_smith_schlick).
 */
INLINE vec3 specular_lobe(const Geometry g, const Surface s) {
    quotient D = RAW_Q(s, TERM_D, D_GGX_q(g.nh, g.sin2_nh, s.alpha), D_GGX_BOUND(s.alpha));
    quotient V = RAW_Q(s, TERM_V, V_SmithGGXSeparable_q(g.nl, g.nv, s.alpha), V_BOUND(g.nl, g.nv));
    return v3scale(fresnel(g, s), dv_product(D, V));
}

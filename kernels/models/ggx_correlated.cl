/*! clshade-model
 * id: ggx_correlated
 * name: GGX height-correlated
 * kind: specular
 * family: microfacet
 * formula: f_s = D_GGX(α) · G2 · F / (4 (n·l)(n·v)), G2 = 1/(1 + Λ(l) + Λ(v)), Λ(x) = (√(1 + α² tan²θx) − 1)/2
 * source: E. Heitz, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs", JCGT 3(2), 2014; written as Filament's V_SmithGGXCorrelated
 * param: roughness | 0 | 1 | 0.5 | perceptual roughness r; α = r²
 * uses: roughness, fresnel
 * note: with F = 1 and α = 1 the albedo at normal incidence is 1 − ln 2.
 */
INLINE vec3 specular_lobe(const Geometry g, const Surface s) {
    quotient D = RAW_Q(s, TERM_D, D_GGX_q(g.nh, g.sin2_nh, s.alpha), D_GGX_BOUND(s.alpha));
    quotient V = RAW_Q(s, TERM_V, V_SmithGGXCorrelated_q(g.nl, g.nv, s.alpha), V_BOUND(g.nl, g.nv));
    return v3scale(fresnel(g, s), dv_product(D, V));
}

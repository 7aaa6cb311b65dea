/*! clshade-model
 * id: cook_torrance
 * name: Cook–Torrance
 * kind: specular
 * family: microfacet
 * formula: f_s = D_Beckmann(m) · G_CT · F / (4 (n·l)(n·v)), m = α = r²
 * source: R. L. Cook and K. E. Torrance, "A Reflectance Model for Computer Graphics", ACM TOG 1(1), 1982
 * param: roughness | 0 | 1 | 0.5 | perceptual roughness r; Beckmann slope m = α = r²
 * uses: roughness, fresnel
 * deviation: the Beckmann normalisation is 1/(π m² cos⁴θ) as in the paper's text; the study's appendix writes 1/(4m²cos⁴θ). The lobe divides by 4(n·l)(n·v); the appendix's `(F*G*D)/4*NdotL*NdotV` multiplies by them through operator precedence.
 */
INLINE vec3 specular_lobe(const Geometry g, const Surface s) {
    real D = RAW(s, TERM_D, D_Beckmann(g.nh, g.sin2_nh, s.alpha), D_BECKMANN_BOUND(s.alpha));
    real V = RAW(s, TERM_V, V_CookTorrance(g.nl, g.nv, g.nh, g.vh), V_BOUND(g.nl, g.nv));
    return v3scale(fresnel(g, s), D * V);
}

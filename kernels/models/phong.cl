/*! clshade-model
 * id: phong
 * name: Phong
 * kind: specular
 * family: empirical
 * formula: f_s = (r·v)ⁿ, r = 2(n·l)n − l
 * source: B. T. Phong, "Illumination for Computer Generated Pictures", CACM 18(6), 1975; as a BRDF: E. Lafortune and Y. Willems, "Using the modified Phong reflectance model for physically based rendering", 1994
 * param: shininess | 0 | 1e6 | 32 | exponent n
 * param: kd | 0 | 1 | 0.7 | diffuse weight (k_d + k_s = 1 rule)
 * param: ks | 0 | 1 | 0.3 | specular weight
 * param: ka | 0 | 1 | 1 | ambient weight
 * uses: shininess, kd, ks, ka
 * deviation: the lobe is the reciprocal "modified Phong" BRDF, multiplied by n·l like every BRDF here; the study's shader adds the specular term without n·l and adds ambient and diffuse outside the k_d + k_s = 1 rule.
 */
INLINE vec3 specular_lobe(const Geometry g, const Surface s) {
    if (phong_lobe_is_zero(g.rv, s.shininess))      /* every lane exactly 0: skip the power */
        return v3s((real)(0.0f));
    return v3s(RAW(s, TERM_FS, Fs_Phong(g.rv, s.shininess), 1.0f));
}

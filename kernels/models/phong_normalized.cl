/*! clshade-model
 * id: phong_normalized
 * name: Normalized Phong
 * kind: specular
 * family: empirical
 * formula: f_s = (n+2)/(2π) · (r·v)ⁿ, r = 2(n·l)n − l
 * source: E. Lafortune and Y. Willems, "Using the modified Phong reflectance model for physically based rendering", 1994
 * param: shininess | 0 | 1e6 | 32 | exponent n
 * param: kd | 0 | 1 | 0.7 | diffuse weight (k_d + k_s = 1 rule)
 * param: ks | 0 | 1 | 0.3 | specular weight
 * param: ka | 0 | 1 | 1 | ambient weight
 * uses: shininess, kd, ks, ka
 * note: albedo of the lobe is exactly 1 at normal incidence and below 1 elsewhere.
 */
INLINE vec3 specular_lobe(const Geometry g, const Surface s) {
    if (phong_lobe_is_zero(g.rv, s.shininess))      /* every lane exactly 0: skip the power */
        return v3s((real)(0.0f));
    real norm = (s.shininess + 2.0f) * (0.5f * CLSHADE_INV_PI);
    return v3s(norm * RAW(s, TERM_FS, Fs_Phong(g.rv, s.shininess), 1.0f));
}

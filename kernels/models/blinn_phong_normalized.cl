/*! clshade-model
 * id: blinn_phong_normalized
 * name: Normalized Blinn–Phong
 * kind: specular
 * family: empirical
 * formula: f_s = (n+8)/(8π) · (n·h)ⁿ
 * source: F. Giesen, "The Blinn–Phong normalization zoo", 2009; T. Akenine-Möller et al., Real-Time Rendering, 3rd ed., 2008
 * param: shininess | 0 | 1e6 | 32 | exponent n
 * param: kd | 0 | 1 | 0.7 | diffuse weight (k_d + k_s = 1 rule)
 * param: ks | 0 | 1 | 0.3 | specular weight
 * param: ka | 0 | 1 | 1 | ambient weight
 * uses: shininess, kd, ks, ka
 * note: (n+8)/(8π) is an approximate normalisation: the albedo is close to, not exactly, 1.
 */
INLINE vec3 specular_lobe(const Geometry g, const Surface s) {
    if (blinn_phong_lobe_is_zero(g.nh, s.shininess))  /* every lane's power underflows: skip it */
        return v3s((real)(0.0f));
    real norm = (s.shininess + 8.0f) * (0.125f * CLSHADE_INV_PI);
    return v3s(norm * RAW(s, TERM_FS, Fs_BlinnPhong(g.nh, s.shininess), 1.0f));
}

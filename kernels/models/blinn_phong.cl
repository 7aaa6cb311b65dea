/*! clshade-model
 * id: blinn_phong
 * name: Blinn–Phong
 * kind: specular
 * family: empirical
 * formula: f_s = (n·h)ⁿ
 * source: J. F. Blinn, "Models of Light Reflection for Computer Synthesized Pictures", SIGGRAPH 1977
 * param: shininess | 0 | 1e6 | 32 | exponent n
 * param: kd | 0 | 1 | 0.7 | diffuse weight (k_d + k_s = 1 rule)
 * param: ks | 0 | 1 | 0.3 | specular weight
 * param: ka | 0 | 1 | 1 | ambient weight
 * uses: shininess, kd, ks, ka
 * deviation: multiplied by n·l like every BRDF here; the study's shader adds the specular term without n·l and adds ambient and diffuse outside the k_d + k_s = 1 rule.
 */
INLINE vec3 specular_lobe(const Geometry g, const Surface s) {
    if (blinn_phong_lobe_is_zero(g.nh, s.shininess))  /* every lane's power underflows: skip it */
        return v3s((real)(0.0f));
    return v3s(RAW(s, TERM_FS, Fs_BlinnPhong(g.nh, s.shininess), 1.0f));
}

/*! clshade-model
 * id: burley
 * name: Disney/Burley diffuse
 * kind: diffuse
 * family: diffuse
 * formula: f_d = (1/π)(1 + (F90−1)(1−n·l)⁵)(1 + (F90−1)(1−n·v)⁵), F90 = 0.5 + 2α(l·h)²
 * source: B. Burley, "Physically-Based Shading at Disney", SIGGRAPH 2012 course notes
 * param: roughness | 0 | 1 | 0.5 | perceptual roughness r; F90 uses α = r² as the study and Filament do (Burley's notes use r)
 * uses: roughness
 * note: Not energy conserving by design: albedo 1 − 1/42 at r = 0 and above 1 at r = 1 (retro-reflection).
 */
INLINE real diffuse_lobe(const Geometry g, const Surface s) {
    return RAW(s, TERM_FD, Fd_Burley(g.nl, g.nv, g.vh, s.alpha), FD_BURLEY_BOUND);
}

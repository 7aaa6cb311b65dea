/*! clshade-model
 * id: oren_nayar
 * name: Oren–Nayar
 * kind: diffuse
 * family: diffuse
 * formula: f_d = (1/π)(A + B·max(0, cos(φi−φo))·sin α·tan β), A = 1 − 0.5σ²/(σ²+0.33), B = 0.45σ²/(σ²+0.09), α = max(θi,θo), β = min(θi,θo)
 * source: M. Oren and S. K. Nayar, "Generalization of Lambert's Reflectance Model", SIGGRAPH 1994 (qualitative model)
 * param: roughness | 0 | 1 | 0.5 | σ, the standard deviation of facet slopes in radians (σ = material roughness r, not squared)
 * uses: roughness
 * deviation: none from the study's A/B approximation; evaluated without trigonometry (see Fd_OrenNayar in brdf.h). σ = 0 is exactly Lambert.
 */
INLINE real diffuse_lobe(const Geometry g, const Surface s) {
    return RAW(s, TERM_FD, Fd_OrenNayar(g.nl, g.nv, g.lv, s.roughness), FD_OREN_NAYAR_BOUND(g.nl, g.nv));
}

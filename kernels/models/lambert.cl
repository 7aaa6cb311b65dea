/*! clshade-model
 * id: lambert
 * name: Lambert
 * kind: diffuse
 * family: diffuse
 * formula: f_d = 1/π
 * source: J. H. Lambert, Photometria, 1760
 * uses: -
 * note: Energy conserving with albedo exactly 1 for a white surface.
 */
INLINE real diffuse_lobe(const Geometry g, const Surface s) {
    return RAW(s, TERM_FD, Fd_Lambert(), CLSHADE_INV_PI);
}

/*! clshade-model
 * id: compile_error
 * name: A lobe that does not compile
 * kind: diffuse
 * family: diffuse
 * formula: f_d = 1/π
 * source: clshade's tests
 * uses: -
 */
INLINE real diffuse_lobe(const Geometry g, const Surface s) {
    return CLSHADE_INV_PI * g.no_such_member;
}

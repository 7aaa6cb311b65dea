/*! clshade-model
 * id: lommel_seeliger
 * name: Lommel–Seeliger
 * kind: diffuse
 * family: diffuse
 * formula: f_d = 1 / (4π (n·l + n·v))
 * source: H. Seeliger, "Zur Photometrie des Saturnringes", Astron. Nachr. 109, 1884 (single scattering in a particulate layer)
 * uses: -
 * note: a user lobe in clshade's own format (docs/user-lobes.md); brightens towards grazing view, as the Moon does.
 */
INLINE real diffuse_lobe(const Geometry g, const Surface s) {
    return (0.25f * CLSHADE_INV_PI) / (g.nl + g.nv);
}

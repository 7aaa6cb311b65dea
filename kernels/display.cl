/* display.cl — the display transform of clshade/render/image.py (exposure, tone map,
 * sRGB OETF, 8-bit rounding) on the device, bit for bit, for the live viewer.
 *
 * That transform maps each channel on its own, and it is monotone in the radiance:
 * the 8-bit level of a float32 value x is the number of thresholds t[k] ≤ x, where
 * t[k] is the least float32 that to_display maps to level k + 1 (k = 0 … 254).
 * clshade/device/display.py finds the thresholds by bisection over float32 bit
 * patterns with to_display itself and checks the steps around each one, so the
 * device compares floats and never evaluates a tone map: no rounding of its own.
 *
 * NaN and negative radiance show as 0 and +∞ as the largest float32, as image.tonemap
 * treats them.
 * Alpha is 255 (an opaque canvas); the background is in the radiance already.
 */
/* The count, per bucket of float32 values (the top 17 bits of a positive float: its
 * exponent and 8 mantissa bits, a 0.4 % wide range), is base[b] plus one when the value is
 * at or above the one threshold inside the bucket, cross[b] (+INFINITY when the bucket holds
 * none). display.py checks that no bucket holds two thresholds: the transform's steepest
 * level per log-radiance (the sRGB curve, 0.42 levels per bucket) keeps them apart. Two
 * table reads per channel instead of a search.
 *
 * The tables hold only the buckets from the first threshold's (`first`) to the last's
 * (`first + last`; 3–6 thousand for the tone maps): a value below them has no threshold at
 * or below it (level base[0] = 0), one above them has all (base[last] plus its crossing,
 * which it is past), so the bucket is clamped into them. Every read is then in range, for
 * negative and NaN inputs too: the lookup runs before the select that gives them 0, with no
 * branch, so that the compiler vectorises it. */
#define BUCKET_SHIFT 15

/* Four pixels a work-item, read as one float16 and written as four packed RGBA8 words: the
 * implicit vectoriser of both CPU compilers (PoCL's, Intel's) then loads whole vectors; one pixel
 * a work-item (a float4 load, one uchar4 store) became per-lane loads, slow on Intel's CPU runtime
 * above all (docs/bench-notes.md). The radiance and output buffers hold the pixel count rounded up
 * to PIXELS_PER_ITEM (clshade/device/display.py defines it, 4, and checks the radiance buffer's
 * size; the float16 load and the four stores below are written for four). */
#if PIXELS_PER_ITEM != 4
#error "display.cl transforms four pixels a work-item: build it with -DPIXELS_PER_ITEM=4"
#endif

/* The 8-bit levels of four values of one channel. */
inline uint4 display_levels(float4 x, __global const uchar* base, __global const float* cross, uint first, uint last)
{
    uint4 b = min(max(as_uint4(x) >> BUCKET_SHIFT, (uint4)first) - first, (uint4)last);  /* +∞: the last bucket */
    uint4 level = (uint4)(base[b.x], base[b.y], base[b.z], base[b.w]);
    level += select((uint4)0, (uint4)1, x >= (float4)(cross[b.x], cross[b.y], cross[b.z], cross[b.w]));
    return select((uint4)0, level, x > 0.0f);   /* NaN, negatives and zeros: level 0 (no branch: vectorised) */
}

__kernel void display(const uint npix, __global const float* radiance, __global const uchar* base,
                      __global const float* cross, const uint first, const uint last, __global uint* out)
{
    uint i = get_global_id(0);
    if (i >= (npix + PIXELS_PER_ITEM - 1) / PIXELS_PER_ITEM) return;
    float16 c = vload16(i, radiance);           /* RGBA of four pixels */
    uint4 r = display_levels(c.s048c, base, cross, first, last);
    uint4 g = display_levels(c.s159d, base, cross, first, last);
    uint4 b = display_levels(c.s26ae, base, cross, first, last);
    vstore4(r | g << 8 | b << 16 | 0xFF000000u, i, out);    /* R, G, B, A in memory (little-endian) */
}

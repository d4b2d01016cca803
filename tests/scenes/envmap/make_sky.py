"""Writes sky.exr, the 64x32 latitude-longitude map of tests/scenes/envmap.

Run with Mitsuba 3's Python: `python make_sky.py`.
A gradient sky (deep blue at the zenith to pale at the horizon), a dim
brownish ground below the horizon and a bright 2x2-texel "sun" about 40
degrees above the horizon. Row 0 is the zenith (+y in Mitsuba's envmap
frame), column x is at u = (x + 1/2)/64, phi = 2 pi u from -z towards +x.
"""
import mitsuba as mi

mi.set_variant("scalar_rgb")

W, H = 64, 32


def texel(x, y):
    if 9 <= y <= 10 and 20 <= x <= 21:
        # Sun: theta about 50 degrees from the zenith.
        return (300.0, 260.0, 200.0)
    t = y / (H - 1)  # 0 at the zenith, 1 at the nadir
    if t < 0.5:
        s = t / 0.5  # 0 at the zenith, 1 at the horizon
        return (0.15 + 0.6 * s, 0.3 + 0.5 * s, 0.9 + 0.1 * s)
    return (0.12, 0.09, 0.06)


flat = [c for y in range(H) for x in range(W) for c in texel(x, y)]
mi.Bitmap(mi.TensorXf(flat, (H, W, 3))).write("sky.exr")

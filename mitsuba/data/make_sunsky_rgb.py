#!/usr/bin/env python3
"""Writes sunsky_rgb.bin, the RGB Hosek-Wilkie data cmlt's `sunsky` needs,
from the datasets that ship with the Mitsuba 3 pip package
(mitsuba/data/sunsky/, 3-clause BSD, Hosek & Wilkie; LICENSE-hosek-wilkie.txt
here is that licence).

Usage: python3 make_sunsky_rgb.py [OUT]   (default: sunsky_rgb.bin beside it)

Layout (little-endian; see mitsuba/src/sunsky.rs, which reads it):
  8 bytes  magic b"CMLTSKY2"
  f32 sky_params[10 turbidity][2 albedo][6 control points][3 RGB][9]
      the sky model's A B C D E F G I H per channel (the paper's order)
  f32 sky_radiance[10][2][6][3]  the channels' mean radiance
  f32 sun_irradiance[10 turbidity][30 elevation 2°, 5°, …, 89°][3]
      the sun's linear-sRGB irradiance (W/m² per channel, Mitsuba's RGB
      units): Mitsuba's spectral sun irradiance at 320, 360, …, 720 nm
      reduced to RGB as its RGB mode does (the mean over the 11 samples of
      the CIE-based linear sRGB response times the irradiance), times its
      spectral-to-RGB sun constant 467.069280386 and MI_CIE_Y_NORMALIZATION.
      The disc's radiance is this over its solid angle 2π (1 − cos α).
  f32 sun_radiance[10 turbidity][45 segments][3 RGB][4 k][6 j]
      the complex sun (`complex_sun`, Hosek & Wilkie 2013 with its limb
      darkening baked in, as Mitsuba's RGB mode reads it): Mitsuba's
      `sun_rad_rgb` as it is, the coefficients of x^k cos(psi)^j, x the
      view direction's elevation above the start of its segment; before
      Mitsuba's 467.069280386 and MI_CIE_Y_NORMALIZATION.
"""
import os
import re
import struct
import sys

import mitsuba as mi

mi.set_variant("scalar_rgb")

SPEC_TO_RGB_SUN_CONV = 467.069280386
WAVELENGTHS = [320 + 40 * i for i in range(11)]


def flat(path, name, shape):
    """The field `name` of Mitsuba's tensor file at `path`, as float64 of
    `shape`: the binding has no field accessor, so its description (name,
    dtype, byte offset, shape) is read from the object's text form and the
    values from the file at that offset."""
    import numpy as np

    desc = str(mi.TensorFile(path))
    m = re.search(r'"%s" => \[\s*dtype = (\w+),\s*offset = (\d+),\s*shape = \[([\d, ]+)\]'
                  % re.escape(name), desc)
    assert m, (name, desc)
    dtype = {"float64": "<f8", "float32": "<f4"}[m.group(1)]
    got = [int(v) for v in m.group(3).split(",")]
    assert got == shape, (name, got)
    n = int(np.prod(shape))
    with open(path, "rb") as f:
        f.seek(int(m.group(2)))
        a = np.frombuffer(f.read(n * np.dtype(dtype).itemsize), dtype=dtype)
    return a.astype(np.float64).reshape(shape)


def main():
    import numpy as np

    d = os.path.join(os.path.dirname(mi.__file__), "data", "sunsky")
    ds = os.path.join(d, "sunsky_datasets.bin")
    smp = os.path.join(d, "sampling_data.bin")
    params = flat(ds, "sky_params_rgb", [10, 2, 6, 3, 9])
    rad = flat(ds, "sky_rad_rgb", [10, 2, 6, 3])
    sun_spec = flat(smp, "sun_irradiance", [10, 30, 11])
    sun_rad = flat(ds, "sun_rad_rgb", [10, 45, 3, 4, 6])
    # Linear sRGB response at the 11 wavelengths.
    rec = np.array([list(mi.linear_rgb_rec(mi.ScalarFloat(w))) for w in WAVELENGTHS])
    rec = rec.reshape(11, 3)
    sun_rgb = np.einsum("tel,lc->tec", sun_spec, rec) / 11.0
    sun_rgb *= SPEC_TO_RGB_SUN_CONV * mi.MI_CIE_Y_NORMALIZATION
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "sunsky_rgb.bin")
    with open(out, "wb") as f:
        f.write(b"CMLTSKY2")
        for a in (params, rad, sun_rgb, sun_rad):
            f.write(struct.pack("<%df" % a.size, *a.ravel()))
    print(out, os.path.getsize(out), "bytes")


if __name__ == "__main__":
    main()

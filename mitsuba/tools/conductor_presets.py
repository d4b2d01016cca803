#!/usr/bin/env python3
"""Writes mitsuba/src/conductor_presets.rs: the RGB complex index of
refraction (eta, k) that Mitsuba 3's RGB variants give each named conductor
preset (`<string name="material" value="Au"/>`), read from Mitsuba itself.

Mitsuba reduces each preset's spectral data (data/ior/NAME.{eta,k}.spd) to
RGB when it loads the BSDF; this script asks it for the result, so the
table is Mitsuba's own numbers, not a re-derivation:

    python3 -m venv /tmp/mi && /tmp/mi/bin/pip install mitsuba numpy
    /tmp/mi/bin/python mitsuba/tools/conductor_presets.py > mitsuba/src/conductor_presets.rs
"""
import os

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
# Mitsuba logs (e.g. its gamut clamps) go to stdout, which is the table.
mi.set_log_level(mi.LogLevel.Error)
ior_dir = os.path.join(os.path.dirname(mi.__file__), "data", "ior")
names = sorted(
    f[: -len(".eta.spd")]
    for f in os.listdir(ior_dir)
    if f.endswith(".eta.spd") and os.path.exists(os.path.join(ior_dir, f[:-8] + ".k.spd"))
)


def rgb(v):
    # The shortest decimal that reads back as the same f32.
    return "[" + ", ".join(str(np.float32(c)) for c in v) + "]"


print(f"""//! Mitsuba 3's named conductor presets (`material` of `conductor` and
//! `roughconductor`) as the RGB (η, k) its RGB variants use: written by
//! `mitsuba/tools/conductor_presets.py` from Mitsuba {mi.__version__} itself
//! (it reduces each preset's spectral data to RGB when it loads the BSDF).
//! Do not edit by hand.

/// (name, η, k) per preset, sorted by name.
#[rustfmt::skip]
pub(crate) const CONDUCTOR_PRESETS: &[(&str, [f32; 3], [f32; 3])] = &[""")
for name in names:
    p = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
    print(f'    ("{name}", {rgb(p["eta.value"])}, {rgb(p["k.value"])}),')
print("];")

"""Mitsuba 3 (scalar_rgb) values of `principled` for `principled.rs`'s
`principled_matches_mitsuba`. Run with the bench venv's Python:

    /work/main/bench/.venv/bin/python core/src/bsdf/tests/principled_mitsuba.py

Prints, per parameter set and direction pair, Mitsuba's eval (f·|cos θ| of
the light-side direction, RGB) and pdf. `wo` is the viewer's direction
(Mitsuba's si.wi), `wi` the light's (Mitsuba's wo)."""
import math
import mitsuba as mi

mi.set_variant("scalar_rgb")

SETS = {
    "opaque": {
        "type": "principled",
        "base_color": {"type": "rgb", "value": [0.8, 0.3, 0.2]},
        "roughness": 0.4, "anisotropic": 0.5, "metallic": 0.3,
        "specular": 0.6, "spec_tint": 0.5, "sheen": 0.7, "sheen_tint": 0.5,
        "clearcoat": 0.8, "clearcoat_gloss": 0.6, "flatness": 0.3,
    },
    "glass": {
        "type": "principled",
        "base_color": {"type": "rgb", "value": [0.9, 0.8, 0.7]},
        "roughness": 0.3, "metallic": 0.1, "spec_trans": 0.7, "eta": 1.4,
    },
}


def d(cos_theta, phi):
    s = math.sqrt(max(0.0, 1.0 - cos_theta * cos_theta))
    return [s * math.cos(phi), s * math.sin(phi), cos_theta]


PAIRS = [
    (d(0.8, 0.7), d(0.6, 0.7 + math.pi)),   # near mirror
    (d(0.8, 0.7), d(0.3, 2.0)),             # off-specular reflection
    (d(0.3, 0.2), d(0.9, 3.0)),             # grazing view
    (d(0.8, 0.7), d(-0.7, 0.7 + math.pi)),  # refraction from outside
    (d(-0.6, 1.0), d(0.5, 1.0 + math.pi)),  # refraction from inside
    (d(-0.6, 1.0), d(-0.5, 1.0 + math.pi)), # reflection inside
]

for name, props in SETS.items():
    bsdf = mi.load_dict(props)
    ctx = mi.BSDFContext()
    for wo, wi in PAIRS:
        si = mi.SurfaceInteraction3f()
        si.p = [0, 0, 0]
        si.n = [0, 0, 1]
        si.sh_frame = mi.Frame3f(si.n)
        si.wi = mi.Vector3f(wo)
        v = bsdf.eval(ctx, si, mi.Vector3f(wi))
        p = bsdf.pdf(ctx, si, mi.Vector3f(wi))
        print(f"{name}: wo={[round(x, 6) for x in wo]} wi={[round(x, 6) for x in wi]} "
              f"eval=[{v[0]:.7e}, {v[1]:.7e}, {v[2]:.7e}] pdf={p:.7e}")

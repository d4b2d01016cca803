"""Renders this scene's Mitsuba 3 reference: two independent halves
(seeds 0 and 1) and their mean, and prints the halves' relMSE.

    /work/main/bench/.venv/bin/python render_reference.py SPP_PER_HALF
"""
import sys
import time

import drjit as dr
import mitsuba as mi

mi.set_variant("scalar_rgb")
spp = int(sys.argv[1])
scene = mi.load_file("scene.xml", spp=spp)
halves = []
for seed in (0, 1):
    t = time.time()
    img = mi.render(scene, seed=seed)
    print(f"half {seed}: {time.time() - t:.1f} s", flush=True)
    mi.Bitmap(img).write(f"reference_half{seed}.exr")
    halves.append(img)
ref = 0.5 * (halves[0] + halves[1])
mi.Bitmap(ref).write("reference.exr")
rel = dr.mean(dr.square(halves[0] - halves[1]) / (dr.square(ref) + 0.01), axis=None)
rel = float(rel.array[0])
print(f"relMSE between halves = {rel:.3e} -> estimated relMSE of reference = {rel / 4:.3e}")
means = [float(dr.mean(ref[:, :, c], axis=None).array[0]) for c in range(3)]
print("channel means:", " ".join(f"{m:.5f}" for m in means))

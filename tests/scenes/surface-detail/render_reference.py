"""Renders reference_half{0,1}.exr and their mean reference.exr with
Mitsuba 3 scalar_rgb (seeds 0/1); prints the halves' relMSE."""
import sys
import time

import mitsuba as mi

mi.set_variant("scalar_rgb")
spp = int(sys.argv[1]) if len(sys.argv) > 1 else 1024
scene = mi.load_file("scene.xml", spp=spp)
halves = []
for seed in (0, 1):
    t = time.time()
    img = mi.render(scene, spp=spp, seed=seed)
    mi.Bitmap(img).write(f"reference_half{seed}.exr")
    print(f"half {seed}: {spp} spp, {time.time() - t:.1f} s", flush=True)
    halves.append(mi.TensorXf(img))
a, b = halves
mean = (a + b) * 0.5
mi.Bitmap(mean).write("reference.exr")
import drjit as dr
rel = dr.mean(dr.square(a - b) / (dr.square(mean) + 0.01))
print("relMSE between halves", rel, "-> reference", rel / 4)
for c in range(3):
    print("channel", c, "mean", dr.mean(mean[:, :, c]))

"""Renders a scene's Mitsuba 3 reference as two independent halves.

    python render_reference.py SCENE_DIR SPP_PER_HALF

Writes SCENE_DIR/reference_half0.exr, reference_half1.exr (seeds 0 and 1)
and reference.exr (their mean) with Mitsuba 3 scalar_rgb, and prints the
render times, the halves' relMSE (mean over pixels and channels of
(a - b)^2 / (ref^2 + 0.01)), its quarter (the estimated relMSE of the
mean) and the reference's channel means, for SOURCE.txt.
"""
import sys
import time

import mitsuba as mi

mi.set_variant("scalar_rgb")
folder, spp = sys.argv[1], int(sys.argv[2])
scene = mi.load_file(f"{folder}/scene.xml", spp=spp)
halves = []
for seed in (0, 1):
    t = time.time()
    img = mi.render(scene, seed=seed, spp=spp)
    print(f"half {seed}: {time.time() - t:.1f} s", flush=True)
    mi.Bitmap(img).write(f"{folder}/reference_half{seed}.exr")
    halves.append(img)
a, b = halves
mean = (a + b) * 0.5
mi.Bitmap(mean).write(f"{folder}/reference.exr")
h, w, c = a.shape
fa, fb, fm = (list(map(float, t.array)) for t in (a, b, mean))
rel, sums = 0.0, [0.0, 0.0, 0.0]
for i, (x, y, r) in enumerate(zip(fa, fb, fm)):
    rel += (x - y) ** 2 / (r * r + 0.01)
    sums[i % c] += r
rel /= len(fm)
print(f"relMSE between halves = {rel:.3g} -> estimated relMSE of reference = {rel / 4:.3g}")
print("channel means of reference.exr: " + " ".join(f"{s / (h * w):.5f}" for s in sums))

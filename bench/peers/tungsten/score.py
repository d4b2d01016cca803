"""score.py SCENE IMAGE... : relMSE of each image against scenes/SCENE/reference.exr, and mean/ref."""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import imgtools as it  # noqa: E402  (from the peer folder)

scene = sys.argv[1]
ref = it.read_image(os.path.join(HERE, "scenes", scene, "reference.exr"))
for p in sys.argv[2:]:
    img = it.read_image(p)
    print("%-60s relMSE %.3e  mean/ref %.4f" % (os.path.basename(p), it.relmse(img, ref), img.mean() / ref.mean()))

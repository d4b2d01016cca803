"""Writes water.ply: the wavy water surface of the caustic-pool scene.

A height field over [-1, 1]^2 (x, z) at y = 0 with two crossed sine waves,
N x N quads split into triangles, counter-clockwise seen from above so the
face normals point up (+y: air above, water below). ASCII PLY, no normals
(the scene asks for face normals). Deterministic; run from this folder:
    python3 make_water.py
"""
import math

N = 24
AMP = 0.035


def height(x, z):
    return AMP * (math.sin(7.0 * x + 1.3 * z) + 0.7 * math.sin(5.0 * z - 2.1 * x + 0.5))


verts = []
for j in range(N + 1):
    for i in range(N + 1):
        x = -1.0 + 2.0 * i / N
        z = -1.0 + 2.0 * j / N
        verts.append((x, height(x, z), z))
faces = []
for j in range(N):
    for i in range(N):
        a = j * (N + 1) + i
        b = a + 1
        c = a + (N + 1)
        d = c + 1
        # (a, c, b): seen from +y, x right and z down the page, this turns
        # counter-clockwise, so the normal (c - a) x (b - a) points to +y.
        faces.append((a, c, b))
        faces.append((b, c, d))
with open("water.ply", "w") as f:
    f.write("ply\nformat ascii 1.0\n")
    f.write(f"element vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n")
    f.write(f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    for v in verts:
        f.write("%.6f %.6f %.6f\n" % v)
    for t in faces:
        f.write("3 %d %d %d\n" % t)

"""Writes the voxel grids of the volume-texture scene (Mitsuba's .vol
format, version 3, float32, little-endian), deterministically.

    python3 make_grids.py

- colours.vol: 4x4x4 voxels, 3 channels: a red ramp along x, green along
  y, blue along z, plus a fixed pseudo-random offset, all in [0.05, 0.95].
- stripes.vol: 3x1x2 voxels, 1 channel: 0.15 / 0.8 / 0.45 along x,
  the z layers swapped.
"""
import struct


def write(path, res, channels, values, bbox=(0, 0, 0, 1, 1, 1)):
    with open(path, "wb") as f:
        f.write(b"VOL" + bytes([3]))
        f.write(struct.pack("<5i", 1, *res, channels))
        f.write(struct.pack("<6f", *bbox))
        f.write(struct.pack(f"<{len(values)}f", *values))


vals = []
seed = 12345
for z in range(4):
    for y in range(4):
        for x in range(4):
            for c, t in enumerate((x, y, z)):
                seed = (seed * 1103515245 + 12345) % (1 << 31)
                jitter = (seed / (1 << 31) - 0.5) * 0.3
                vals.append(min(0.95, max(0.05, 0.1 + 0.8 * t / 3 + jitter)))
write("colours.vol", (4, 4, 4), 3, vals)
write("stripes.vol", (3, 1, 2), 1, [0.15, 0.8, 0.45, 0.8, 0.45, 0.15])

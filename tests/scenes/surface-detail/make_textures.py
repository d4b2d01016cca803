"""Writes the procedural 8-bit PNG textures of the surface-detail scene
(pure Python: zlib + struct). Run from this folder; deterministic."""
import math
import struct
import zlib


def write_png(path, w, h, rows, channels):
    """rows: h lists of w*channels ints in 0..255 (row 0 = top)."""
    kind = {1: 0, 3: 2}[channels]
    raw = b"".join(b"\x00" + bytes(r) for r in rows)

    def chunk(t, data):
        c = struct.pack(">I", len(data)) + t + data
        return c + struct.pack(">I", zlib.crc32(t + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n"
    png += chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, kind, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9))
    png += chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def q(v):
    return max(0, min(255, int(round(v * 255.0))))


# Normal map (tangent space, raw): bumps n ∝ (−∂h/∂x, −∂h/∂y, 1) of
# h = 0.25·sin(2πx·2)·sin(2πy·2) over the texture, tilts up to ~35°.
N = 32
rows = []
for j in range(N):
    y = (j + 0.5) / N
    row = []
    for i in range(N):
        x = (i + 0.5) / N
        k = 2 * math.pi * 2
        hx = 0.25 * k * math.cos(k * x) * math.sin(k * y) / 2.2
        hy = 0.25 * k * math.sin(k * x) * math.cos(k * y) / 2.2
        n = (-hx, -hy, 1.0)
        l = math.sqrt(sum(c * c for c in n))
        row += [q(0.5 * (c / l) + 0.5) for c in n]
    rows.append(row)
write_png("textures/normalmap.png", N, N, rows, 3)

# Height map (grey, raw): stripes along u, h = 0.5 + 0.5·sin(2π·3u).
rows = []
for j in range(N):
    row = []
    for i in range(N):
        u = (i + 0.5) / N
        row.append(q(0.5 + 0.5 * math.sin(2 * math.pi * 3 * u)))
    rows.append(row)
write_png("textures/height.png", N, N, rows, 1)

# Opacity (grey, raw): a 4×4 grid of square holes (0) in an opaque plate
# (1), and the right quarter half-transparent (0.5).
M = 16
rows = []
for j in range(M):
    row = []
    for i in range(M):
        if i >= 12:
            v = 0.5
        elif (i % 4 in (1, 2)) and (j % 4 in (1, 2)):
            v = 0.0
        else:
            v = 1.0
        row.append(q(v))
    rows.append(row)
write_png("textures/opacity.png", M, M, rows, 1)

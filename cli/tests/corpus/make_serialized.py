#!/usr/bin/env python3
"""Writes the corpus's Mitsuba .serialized files (run from this folder).

The format (Mitsuba 3's src/shapes/serialized.cpp): per shape a u16 0x041C,
a u16 version (3 or 4) and a zlib stream of u32 flags, the name (version 4,
NUL-terminated), u64 vertex and triangle counts, positions, normals, uv,
colours (f32, or f64 with flag 0x2000) and u32 index triples; then each
shape's offset (u64, or u32 in version 3) and the u32 shape count.
"""
import struct
import zlib

HAS_NORMALS, HAS_TEXCOORDS, HAS_COLORS, DOUBLE = 0x1, 0x2, 0x8, 0x2000


def shape(version, name, positions, triangles, normals=None, uvs=None,
          colors=None, double=False, counts=None):
    flags = (HAS_NORMALS if normals else 0) | (HAS_TEXCOORDS if uvs else 0) \
        | (HAS_COLORS if colors else 0) | (DOUBLE if double else 0x1000)
    f = "<d" if double else "<f"
    body = struct.pack("<I", flags)
    if version == 4:
        body += name.encode() + b"\0"
    nv, nt = counts or (len(positions), len(triangles))
    body += struct.pack("<QQ", nv, nt)
    for attr in (positions, normals, uvs, colors):
        for v in attr or []:
            body += b"".join(struct.pack(f, x) for x in v)
    for t in triangles:
        body += struct.pack("<III", *t)
    return struct.pack("<HH", 0x041C, version) + zlib.compress(body)


def file(version, shapes):
    out, offsets = b"", []
    for s in shapes:
        offsets.append(len(out))
        out += s
    word = "<Q" if version == 4 else "<I"
    out += b"".join(struct.pack(word, o) for o in offsets)
    return out + struct.pack("<I", len(shapes))


QUAD = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
QUAD_TRIS = [(0, 1, 2), (0, 2, 3)]
TRI = [(0, 0, 2), (2, 0, 2), (0, 3, 2)]

quad = shape(4, "quad", QUAD, QUAD_TRIS, normals=[(0, 0, 1)] * 4,
             uvs=[(0, 0), (1, 0), (1, 1), (0, 1)], colors=[(1, 0, 0)] * 4)
tri = shape(4, "triangle", TRI, [(0, 1, 2)], double=True)
open("valid/two_shapes.serialized", "wb").write(file(4, [quad, tri]))
open("valid/triangle_v3.serialized", "wb").write(
    file(3, [shape(3, "", QUAD, QUAD_TRIS), shape(3, "", TRI, [(0, 1, 2)])]))

# Malformed: the stream cut in half; counts no stream of its size holds;
# an index past the vertices; not the format's magic number.
whole = file(4, [quad])
open("malformed/data/truncated.serialized", "wb").write(whole[:len(whole) // 2])
open("malformed/data/huge_count.serialized", "wb").write(
    file(4, [shape(4, "big", TRI, [(0, 1, 2)], counts=(1 << 31, 1))]))
open("malformed/data/bad_index.serialized", "wb").write(
    file(4, [shape(4, "bad", TRI, [(0, 1, 7)])]))
open("malformed/data/not_serialized.serialized", "wb").write(b"ply\nformat ascii 1.0\n")
# A valid file of one shape, asked for its second.
open("malformed/data/one_shape.serialized", "wb").write(whole)

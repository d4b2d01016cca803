//! Mitsuba's `.serialized` mesh files (the `serialized` shape plugin).
//!
//! A file is a sequence of shapes, each an uncompressed header (u16
//! `0x041C`, u16 version 3 or 4) followed by a zlib stream: u32 flags, the
//! shape's name (version 4: UTF-8, NUL-terminated), u64 vertex and
//! triangle counts, positions, then normals, texture coordinates and
//! colours when the flags say so (f32, or f64 with the double-precision
//! flag), then the triangles as u32 index triples. The file ends with a
//! dictionary: each shape's byte offset (u64 in version 4, u32 in version
//! 3) and the u32 number of shapes. All little-endian. Mitsuba 3's
//! `src/shapes/serialized.cpp` is the reference for what is read and
//! skipped (colours are skipped, as there).
//!
//! Hostile input: the counts a stream declares are checked against what
//! its compressed bytes can hold before anything is allocated (deflate
//! expands at most 1032:1), every read is exact, and a short or corrupt
//! stream is an error naming what was being read.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use flate2::read::ZlibDecoder;
use glam::{DVec2, DVec3};

use crate::input;
use crate::mesh_io::RawMesh;

/// The format's magic number, the first u16 of every shape.
const MAGIC: u16 = 0x041C;

/// Flag: the shape has per-vertex normals.
const HAS_NORMALS: u32 = 0x0001;
/// Flag: the shape has per-vertex texture coordinates.
const HAS_TEXCOORDS: u32 = 0x0002;
/// Flag: the shape has per-vertex colours (skipped, as Mitsuba does).
const HAS_COLORS: u32 = 0x0008;
/// Flag: vertex data is f64 rather than f32.
const DOUBLE_PRECISION: u32 = 0x2000;

/// Deflate's largest expansion: one compressed byte yields at most this
/// many output bytes (zlib's technical details), so a stream of n bytes
/// cannot hold more than 1032·n bytes of mesh data.
const MAX_DEFLATE_RATIO: u64 = 1032;

/// Most mesh data one shape may declare, uncompressed: 4 GiB, twice what
/// the largest OBJ or PLY file read holds ([`input::MAX_MESH_BYTES`]).
const MAX_SHAPE_BYTES: u64 = 4 << 30;

/// Longest shape name read (version 4); real names are short.
const MAX_NAME_BYTES: usize = 4096;

/// Reads shape `shape_index` of the `.serialized` file at `path`
/// (positions, normals and uv, in object space).
pub(crate) fn read_serialized(path: &Path, shape_index: u32) -> Result<RawMesh, String> {
    let (mut file, len) = input::open_bounded(path, input::MAX_MESH_BYTES, "mesh file")?;
    let version = read_header(&mut file, "the file header")?;
    let start = if shape_index == 0 {
        4
    } else {
        let offset = shape_offset(&mut file, len, version, shape_index)?;
        file.seek(SeekFrom::Start(offset))
            .map_err(|e| format!("cannot seek to shape {shape_index}: {e}"))?;
        let v = read_header(&mut file, &format!("the header of shape {shape_index}"))?;
        if v != version {
            return Err(format!(
                "shape {shape_index} has format version {v}, the file {version}"
            ));
        }
        offset + 4
    };
    file.seek(SeekFrom::Start(start))
        .map_err(|e| format!("cannot seek to shape {shape_index}: {e}"))?;
    // The stream can use at most the rest of the file.
    let compressed = len.saturating_sub(start);
    let mut z = ZlibDecoder::new(file.take(compressed));
    read_shape(&mut z, version, compressed).map_err(|e| format!("shape {shape_index}: {e}"))
}

/// Reads and checks one shape's uncompressed header; returns its version.
fn read_header(r: &mut impl Read, what: &str) -> Result<u16, String> {
    let mut b = [0u8; 4];
    r.read_exact(&mut b)
        .map_err(|_| format!("{what} is cut short (not a .serialized file?)"))?;
    let (magic, version) = (
        u16::from_le_bytes([b[0], b[1]]),
        u16::from_le_bytes([b[2], b[3]]),
    );
    if magic != MAGIC {
        return Err(format!(
            "{what} starts with 0x{magic:04X}, not 0x{MAGIC:04X} (not a .serialized file)"
        ));
    }
    if version != 3 && version != 4 {
        return Err(format!(
            "format version {version} is not supported (Mitsuba writes 3 and 4)"
        ));
    }
    Ok(version)
}

/// The byte offset of shape `index` from the end-of-file dictionary.
fn shape_offset(file: &mut File, len: u64, version: u16, index: u32) -> Result<u64, String> {
    let word = if version == 4 { 8 } else { 4 };
    if len < 4 {
        return Err("the file is too short for its shape dictionary".into());
    }
    let count = {
        file.seek(SeekFrom::Start(len - 4))
            .map_err(|e| format!("cannot read the shape dictionary: {e}"))?;
        let mut b = [0u8; 4];
        file.read_exact(&mut b)
            .map_err(|e| format!("cannot read the shape dictionary: {e}"))?;
        u32::from_le_bytes(b)
    };
    if index >= count {
        return Err(format!(
            "shape_index {index} is out of range: the file holds {count} shape(s)"
        ));
    }
    // The dictionary: `count` offsets, then the count itself.
    let table = u64::from(count) * word + 4;
    if table > len {
        return Err(format!(
            "the shape dictionary ({count} entries) is longer than the file"
        ));
    }
    let at = len - table + u64::from(index) * word;
    file.seek(SeekFrom::Start(at))
        .map_err(|e| format!("cannot read the shape dictionary: {e}"))?;
    let mut b = [0u8; 8];
    file.read_exact(&mut b[..word as usize])
        .map_err(|e| format!("cannot read the shape dictionary: {e}"))?;
    let offset = u64::from_le_bytes(b);
    if offset >= len - table {
        return Err(format!(
            "shape {index}'s offset {offset} lies outside the file's shapes"
        ));
    }
    Ok(offset)
}

/// Reads one shape's decompressed stream. `compressed` is the number of
/// compressed bytes the stream can have used, which bounds what it can
/// declare.
fn read_shape(z: &mut impl Read, version: u16, compressed: u64) -> Result<RawMesh, String> {
    let flags = u32::from_le_bytes(read_array(z, "the flags")?);
    if version == 4 {
        skip_name(z)?;
    }
    let vertices = u64::from_le_bytes(read_array(z, "the vertex count")?);
    let triangles = u64::from_le_bytes(read_array(z, "the triangle count")?);
    if vertices > u64::from(u32::MAX) {
        return Err(format!(
            "{vertices} vertices: more than 32-bit indices address"
        ));
    }
    let scalar = if flags & DOUBLE_PRECISION != 0 { 8 } else { 4 };
    let per_vertex = 3
        + 3 * u64::from(flags & HAS_NORMALS != 0)
        + 2 * u64::from(flags & HAS_TEXCOORDS != 0)
        + 3 * u64::from(flags & HAS_COLORS != 0);
    let declared = vertices
        .checked_mul(per_vertex * scalar)
        .and_then(|v| triangles.checked_mul(12).and_then(|t| v.checked_add(t)));
    match declared {
        Some(d)
            if d <= compressed
                .saturating_mul(MAX_DEFLATE_RATIO)
                .min(MAX_SHAPE_BYTES) => {}
        _ => {
            return Err(format!(
                "it declares {vertices} vertices and {triangles} triangles, more than its \
                 {compressed} compressed bytes can hold or more than {MAX_SHAPE_BYTES} bytes"
            ));
        }
    }
    let n = usize::try_from(vertices)
        .ok()
        .filter(|n| n.checked_mul(8 * per_vertex as usize).is_some())
        .ok_or_else(|| format!("{vertices} vertices do not fit this machine's memory"))?;
    let double = scalar == 8;
    let mut out = RawMesh {
        positions: read_vec3s(z, n, double, "the positions")?,
        ..RawMesh::default()
    };
    if flags & HAS_NORMALS != 0 {
        out.normals = read_vec3s(z, n, double, "the normals")?;
    }
    if flags & HAS_TEXCOORDS != 0 {
        let uv = read_scalars(z, 2 * n, double, "the texture coordinates")?;
        out.uvs = uv.chunks_exact(2).map(|c| DVec2::new(c[0], c[1])).collect();
    }
    if flags & HAS_COLORS != 0 {
        read_scalars(z, 3 * n, double, "the vertex colours")?;
    }
    // Within MAX_SHAPE_BYTES (checked above), but a 32-bit host's usize
    // is narrower.
    let index_bytes = usize::try_from(triangles * 12)
        .map_err(|_| format!("{triangles} triangles do not fit this machine's memory"))?;
    let mut bytes = vec![0u8; index_bytes];
    z.read_exact(&mut bytes)
        .map_err(|e| cut_short("the triangles", e))?;
    out.indices = bytes
        .chunks_exact(12)
        .map(|t| {
            core::array::from_fn(|k| u32::from_le_bytes(t[4 * k..4 * k + 4].try_into().unwrap()))
        })
        .collect();
    out.check()?;
    Ok(out)
}

/// Skips a version-4 shape name (NUL-terminated).
fn skip_name(z: &mut impl Read) -> Result<(), String> {
    for _ in 0..MAX_NAME_BYTES {
        let [c] = read_array::<1>(z, "the shape name")?;
        if c == 0 {
            return Ok(());
        }
    }
    Err(format!(
        "the shape name is longer than {MAX_NAME_BYTES} bytes (corrupt stream?)"
    ))
}

fn cut_short(what: &str, e: std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::UnexpectedEof => format!("the stream ends inside {what}"),
        _ => format!("cannot decompress {what}: {e}"),
    }
}

fn read_array<const N: usize>(z: &mut impl Read, what: &str) -> Result<[u8; N], String> {
    let mut b = [0u8; N];
    z.read_exact(&mut b).map_err(|e| cut_short(what, e))?;
    Ok(b)
}

/// `n` f32 or f64 values, widened to f64.
fn read_scalars(z: &mut impl Read, n: usize, double: bool, what: &str) -> Result<Vec<f64>, String> {
    let size = if double { 8 } else { 4 };
    let mut bytes = vec![0u8; n * size];
    z.read_exact(&mut bytes).map_err(|e| cut_short(what, e))?;
    Ok(if double {
        bytes
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect()
    } else {
        bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()) as f64)
            .collect()
    })
}

fn read_vec3s(z: &mut impl Read, n: usize, double: bool, what: &str) -> Result<Vec<DVec3>, String> {
    let v = read_scalars(z, 3 * n, double, what)?;
    Ok(v.chunks_exact(3)
        .map(|c| DVec3::new(c[0], c[1], c[2]))
        .collect())
}

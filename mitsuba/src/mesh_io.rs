//! Reading OBJ (tobj) and PLY (ply-rs) files into object-space triangles,
//! with Mitsuba's conventions for each format.
//!
//! Errors are plain strings that do not name the file; the caller prefixes
//! the file name and reports them at the `<shape>` that names it. The
//! third-party parsers run under `catch_unwind`: a malformed file must give
//! an error, never take the process down.

use std::io::BufReader;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use glam::{DVec2, DVec3};
use ply_rs::parser::Parser;
use ply_rs::ply::{Property, PropertyAccess};

use crate::input;

/// Triangles in object space, before `to_world`.
#[derive(Clone, Debug, Default)]
pub(crate) struct RawMesh {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Per-vertex normals, empty when the file has none.
    pub normals: Vec<DVec3>,
    /// Per-vertex uv, empty when the file has none.
    pub uvs: Vec<DVec2>,
    /// Triangles (counter-clockwise = front, as the file gives them).
    pub indices: Vec<[u32; 3]>,
}

impl RawMesh {
    /// Checks index ranges and attribute counts of file data.
    pub fn check(&self) -> Result<(), String> {
        let n = self.positions.len();
        if n > u32::MAX as usize {
            return Err("too many vertices".into());
        }
        if let Some((t, tri)) = self
            .indices
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&i| i as usize >= n))
        {
            return Err(format!(
                "triangle {t} refers to vertex {} but there are only {n} vertices",
                tri.iter().max().unwrap_or(&0)
            ));
        }
        if !self.normals.is_empty() && self.normals.len() != n
            || !self.uvs.is_empty() && self.uvs.len() != n
        {
            return Err("normals/uvs do not match the vertex count".into());
        }
        if let Some(v) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(format!("vertex {v} has a non-finite position"));
        }
        if let Some(v) = self.normals.iter().position(|p| !p.is_finite()) {
            return Err(format!("vertex {v} has a non-finite normal"));
        }
        if let Some(v) = self.uvs.iter().position(|p| !p.is_finite()) {
            return Err(format!("vertex {v} has non-finite texture coordinates"));
        }
        if self.indices.is_empty() {
            return Err("contains no triangles (is it a mesh file of the right format?)".into());
        }
        Ok(())
    }
}

/// A parser's message on one line, at most 200 characters (ply-rs quotes
/// whole input lines and its own grammar in its errors).
fn tidy(msg: &str) -> String {
    let one_line = msg.split_whitespace().collect::<Vec<_>>().join(" ");
    match one_line.char_indices().nth(200) {
        Some((i, _)) => format!("{}…", &one_line[..i]),
        None => one_line,
    }
}

/// Runs a third-party parser, turning a panic into an error.
fn guarded<T>(what: &str, f: impl FnOnce() -> Result<T, String>) -> Result<T, String> {
    catch_unwind(AssertUnwindSafe(f))
        .unwrap_or_else(|_| Err(format!("the {what} parser failed on malformed data")))
}

/// Reads a Wavefront OBJ file like Mitsuba's `obj` plugin: polygons become
/// triangle fans, a vertex is each distinct `v/vt/vn` triple, `l`/`p`
/// elements and materials are ignored, and `vt`'s v is flipped (v → 1 − v)
/// when `flip_tex_coords` is set (Mitsuba's default), because OBJ puts v = 0
/// at the bottom of the image while Mitsuba's bitmaps put row 0 at v = 0.
/// `o`/`g` groups are concatenated; unlike Mitsuba, a vertex is not shared
/// across groups, which only matters for smooth normals computed at group
/// borders of files without `vn`.
pub(crate) fn read_obj(path: &Path, flip_tex_coords: bool) -> Result<RawMesh, String> {
    let (file, _) = input::open_bounded(path, input::MAX_MESH_BYTES, "mesh file")?;
    let mut reader = BufReader::new(file);
    // Cargo features of tobj (merging, reordering) add fields; keep the
    // struct update so that feature unification cannot break the build.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let (models, _) = guarded("OBJ", || {
        tobj::load_obj_buf(&mut reader, &options, |_| {
            Err(tobj::LoadError::OpenFileFailed)
        })
        .map_err(|e| match e {
            tobj::LoadError::ReadError => "cannot read it as text (binary data?)".to_string(),
            e => format!("invalid OBJ data: {e}"),
        })
    })?;

    let mut out = RawMesh::default();
    let with_normals = models.iter().filter(|m| !m.mesh.normals.is_empty()).count();
    if with_normals != 0 && with_normals != models.len() {
        return Err("some objects have vertex normals (vn) and others do not".into());
    }
    let any_uv = models.iter().any(|m| !m.mesh.texcoords.is_empty());
    for model in &models {
        let m = &model.mesh;
        let n = m.positions.len() / 3;
        let base = out.positions.len() as u64;
        if m.positions.len() % 3 != 0 || m.indices.len() % 3 != 0 {
            return Err("inconsistent vertex data".into());
        }
        // tobj stores normals/uvs only for corners that have them; a
        // partial set cannot be matched to the vertices.
        if !m.normals.is_empty() && m.normals.len() != 3 * n {
            return Err("some faces have vertex normals (vn) and others do not".into());
        }
        if !m.texcoords.is_empty() && m.texcoords.len() != 2 * n {
            return Err("some faces have texture coordinates (vt) and others do not".into());
        }
        out.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)),
        );
        out.normals.extend(
            m.normals
                .chunks_exact(3)
                .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)),
        );
        if any_uv {
            if m.texcoords.is_empty() {
                // Mitsuba leaves uv at zero for vertices without `vt`.
                out.uvs.extend(std::iter::repeat_n(DVec2::ZERO, n));
            } else {
                out.uvs.extend(m.texcoords.chunks_exact(2).map(|t| {
                    let v = t[1] as f64;
                    DVec2::new(t[0] as f64, if flip_tex_coords { 1.0 - v } else { v })
                }));
            }
        }
        for t in m.indices.chunks_exact(3) {
            let tri = [t[0] as u64 + base, t[1] as u64 + base, t[2] as u64 + base];
            if tri.iter().any(|&i| i > u32::MAX as u64) {
                return Err("too many vertices".into());
            }
            out.indices.push(tri.map(|i| i as u32));
        }
    }
    out.check()?;
    Ok(out)
}

/// One PLY vertex; all known attribute names are kept until the header
/// tells which uv naming the file uses.
#[derive(Default)]
struct PlyVertex {
    /// x, y, z, nx, ny, nz.
    xyz_n: [f32; 6],
    /// u, v, texture_u, texture_v, s, t, texture_s, texture_t.
    uv: [f32; 8],
}

/// Widens any scalar PLY property; lists are not scalars.
fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => v as f64,
        Property::UChar(v) => v as f64,
        Property::Short(v) => v as f64,
        Property::UShort(v) => v as f64,
        Property::Int(v) => v as f64,
        Property::UInt(v) => v as f64,
        Property::Float(v) => v as f64,
        Property::Double(v) => v,
        _ => return None,
    })
}

const XYZ_N: [&str; 6] = ["x", "y", "z", "nx", "ny", "nz"];
const UV_NAMES: [&str; 8] = [
    "u",
    "v",
    "texture_u",
    "texture_v",
    "s",
    "t",
    "texture_s",
    "texture_t",
];

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: String, p: Property) {
        let Some(v) = scalar(&p) else { return };
        if let Some(i) = XYZ_N.iter().position(|n| *n == name) {
            self.xyz_n[i] = v as f32;
        } else if let Some(i) = UV_NAMES.iter().position(|n| *n == name) {
            self.uv[i] = v as f32;
        }
    }
}

/// One PLY face: its vertex list under either name Mitsuba accepts.
#[derive(Default)]
struct PlyFace {
    vertex_index: Vec<i64>,
    vertex_indices: Vec<i64>,
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: String, p: Property) {
        let list: Vec<i64> = match p {
            Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUInt(v) => v.into_iter().map(i64::from).collect(),
            _ => return,
        };
        match name.as_str() {
            "vertex_index" => self.vertex_index = list,
            "vertex_indices" => self.vertex_indices = list,
            _ => {}
        }
    }
}

/// Payload of elements we do not use (read to skip them).
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// Longest PLY header line accepted; real ones are under 100 bytes.
const MAX_PLY_HEADER_LINE: u64 = 4096;
/// Most PLY header lines accepted (comments included).
const MAX_PLY_HEADER_LINES: usize = 10_000;

/// Checks a PLY header before ply-rs reads it: the header must end within
/// [`MAX_PLY_HEADER_LINES`] lines of at most [`MAX_PLY_HEADER_LINE`] bytes
/// (ply-rs reads a line until its newline, however long), and element
/// counts must be numbers ply-rs will not panic on (it unwraps the parse of
/// any digit string) that fit the file: every element takes at least one
/// byte, so a count beyond the file's size is a lie that would make the
/// parser reserve memory for it.
fn check_ply_header(path: &Path) -> Result<(), String> {
    use std::io::{BufRead, Read};
    let (file, file_len) = input::open_bounded(path, input::MAX_MESH_BYTES, "mesh file")?;
    let mut reader = BufReader::new(file);
    let mut line = Vec::new();
    for _ in 0..MAX_PLY_HEADER_LINES {
        line.clear();
        let n = (&mut reader)
            .take(MAX_PLY_HEADER_LINE + 1)
            .read_until(b'\n', &mut line)
            .map_err(|e| format!("cannot read: {e}"))?;
        if n == 0 {
            return Err("invalid PLY data: the file ends before 'end_header'".into());
        }
        if line.len() as u64 > MAX_PLY_HEADER_LINE {
            return Err(format!(
                "invalid PLY data: a header line longer than {MAX_PLY_HEADER_LINE} bytes"
            ));
        }
        let text = String::from_utf8_lossy(&line);
        let mut words = text.split_whitespace();
        match words.next() {
            Some("end_header") => return Ok(()),
            Some("element") => {
                let count = words.nth(1).unwrap_or("");
                match count.parse::<u64>() {
                    Ok(c) if c <= u32::MAX as u64 && c <= file_len => {}
                    Ok(c) if c <= u32::MAX as u64 => {
                        return Err(format!(
                            "invalid PLY data: element count {c} exceeds the file's {file_len} bytes"
                        ));
                    }
                    _ => return Err(format!("invalid PLY header: bad element count '{count}'")),
                }
            }
            _ => {}
        }
    }
    Err(format!(
        "invalid PLY data: no 'end_header' within {MAX_PLY_HEADER_LINES} lines"
    ))
}

/// Reads a PLY file (ascii or binary) like Mitsuba's `ply` plugin: vertex
/// `x y z`, optional `nx ny nz` and uv as `u v`, `texture_u texture_v` or
/// `s t` (plus `texture_s texture_t`), faces from `vertex_index` or
/// `vertex_indices`. Mitsuba accepts triangles only; polygons are
/// triangulated as fans here. uv is not flipped (Mitsuba does not either).
pub(crate) fn read_ply(path: &Path) -> Result<RawMesh, String> {
    check_ply_header(path)?;
    let (file, _) = input::open_bounded(path, input::MAX_MESH_BYTES, "mesh file")?;
    let mut reader = BufReader::new(file);
    guarded("PLY", move || {
        let io = |e: std::io::Error| format!("invalid PLY data: {}", tidy(&e.to_string()));
        let header = Parser::<Skip>::new().read_header(&mut reader).map_err(io)?;
        let mut vertices: Option<(Vec<PlyVertex>, Vec<String>)> = None;
        let mut faces: Option<(Vec<PlyFace>, bool)> = None;
        for (name, el) in &header.elements {
            match name.as_str() {
                "vertex" => {
                    let v = Parser::<PlyVertex>::new()
                        .read_payload_for_element(&mut reader, el, &header)
                        .map_err(io)?;
                    vertices = Some((v, el.properties.keys().cloned().collect()));
                }
                "face" => {
                    let by_index = el.properties.contains_key("vertex_index");
                    if !by_index && !el.properties.contains_key("vertex_indices") {
                        return Err(
                            "the face element has no vertex_index/vertex_indices list".into()
                        );
                    }
                    let f = Parser::<PlyFace>::new()
                        .read_payload_for_element(&mut reader, el, &header)
                        .map_err(io)?;
                    faces = Some((f, by_index));
                }
                _ => {
                    Parser::<Skip>::new()
                        .read_payload_for_element(&mut reader, el, &header)
                        .map_err(io)?;
                }
            }
        }
        let (verts, props) = vertices.ok_or("the file has no vertex element")?;
        let has = |n: &str| props.iter().any(|p| p == n);
        if !(has("x") && has("y") && has("z")) {
            return Err("vertices lack x, y, z".into());
        }
        let mut out = RawMesh {
            positions: verts
                .iter()
                .map(|v| DVec3::new(v.xyz_n[0] as f64, v.xyz_n[1] as f64, v.xyz_n[2] as f64))
                .collect(),
            ..RawMesh::default()
        };
        if has("nx") && has("ny") && has("nz") {
            out.normals = verts
                .iter()
                .map(|v| DVec3::new(v.xyz_n[3] as f64, v.xyz_n[4] as f64, v.xyz_n[5] as f64))
                .collect();
        }
        // Mitsuba's preference order for the uv names.
        if let Some(k) = (0..4).find(|&k| has(UV_NAMES[2 * k]) && has(UV_NAMES[2 * k + 1])) {
            out.uvs = verts
                .iter()
                .map(|v| DVec2::new(v.uv[2 * k] as f64, v.uv[2 * k + 1] as f64))
                .collect();
        }
        let n = out.positions.len() as i64;
        if let Some((faces, by_index)) = faces {
            for (fi, f) in faces.iter().enumerate() {
                let list = if by_index {
                    &f.vertex_index
                } else {
                    &f.vertex_indices
                };
                if list.len() < 3 {
                    return Err(format!(
                        "face {fi} has {} vertices (at least 3 needed)",
                        list.len()
                    ));
                }
                if let Some(&bad) = list.iter().find(|&&i| i < 0 || i >= n) {
                    return Err(format!(
                        "face {fi} refers to vertex {bad} but there are only {n} vertices"
                    ));
                }
                for k in 1..list.len() - 1 {
                    out.indices
                        .push([list[0] as u32, list[k] as u32, list[k + 1] as u32]);
                }
            }
        }
        out.check()?;
        Ok(out)
    })
}

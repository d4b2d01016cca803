//! Bounds on what the loader reads, so that no input file can make it
//! allocate without limit or read forever.
//!
//! A scene names its own mesh and image files, so a hostile or careless
//! scene can point at `/dev/zero`, a FIFO or a multi-gigabyte file. Every
//! file the loader reads is opened here: it must be a regular file (a
//! device or pipe has no end to trust) no larger than the limit for its
//! kind, checked before a byte is read. Parsers then work on input whose
//! size is known, so their allocations are bounded by it.

use std::fs::File;
use std::io::Read;
use std::path::Path;

/// Largest scene XML file read: far beyond any real scene description
/// (Bitterli's largest is under 100 KiB; geometry lives in mesh files).
pub const MAX_SCENE_BYTES: u64 = 64 << 20;

/// Largest mesh file (OBJ or PLY) read: 2 GiB, about 40 M triangles of
/// binary PLY. The parsed mesh needs a small multiple of its file's size.
pub const MAX_MESH_BYTES: u64 = 2 << 30;

/// Largest attribute value after `$name` substitution. A value references
/// defaults that reference others, so substitution can grow a value
/// exponentially with the nesting depth (ten copies of ten copies …); the
/// longest real value, a 4×4 matrix, is a few hundred bytes.
pub const MAX_SUBSTITUTED_BYTES: usize = 1 << 20;

/// Largest image file (JPEG, PNG, OpenEXR, Radiance HDR) read: 1 GiB, well
/// beyond a 16k × 8k float environment map.
pub const MAX_IMAGE_BYTES: u64 = 1 << 30;

/// Largest image side decoded, checked against the header before any
/// pixel memory is taken (Mitsuba has no bound; real environment maps are
/// at most 16k wide).
pub const MAX_IMAGE_SIDE: u32 = 1 << 15;

/// Most memory an image decoder may take (`image::Limits::max_alloc`): an
/// 8k × 4k RGBA float image is 512 MiB.
pub const MAX_IMAGE_ALLOC: u64 = 1 << 30;

/// Largest voxel grid file (`.vol`) read: 1 GiB, 256 M float voxels, as
/// large as the largest image.
pub const MAX_GRID_BYTES: u64 = 1 << 30;

/// Opens `path` for reading if it is a regular file of at most `max_bytes`
/// bytes; returns the file and its size. `what` names the kind of file in
/// the message ("scene file", "mesh file").
pub(crate) fn open_bounded(path: &Path, max_bytes: u64, what: &str) -> Result<(File, u64), String> {
    let file = File::open(path).map_err(|e| format!("cannot open: {e}"))?;
    let meta = file.metadata().map_err(|e| format!("cannot read: {e}"))?;
    if !meta.is_file() {
        return Err(format!(
            "not a regular file (a device, pipe or directory cannot be a {what})"
        ));
    }
    if meta.len() > max_bytes {
        return Err(format!(
            "the {what} is {} bytes, more than the limit of {max_bytes} bytes",
            meta.len()
        ));
    }
    Ok((file, meta.len()))
}

/// Reads a whole file opened by [`open_bounded`]-style checks: at most
/// `max_bytes` bytes, even if the file grows while it is read.
pub(crate) fn read_bounded(path: &Path, max_bytes: u64, what: &str) -> Result<Vec<u8>, String> {
    let (file, len) = open_bounded(path, max_bytes, what)?;
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(len as usize)
        .map_err(|_| format!("out of memory reading the {what} ({len} bytes)"))?;
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("cannot read: {e}"))?;
    if bytes.len() as u64 > max_bytes {
        return Err(format!(
            "the {what} grew beyond the limit of {max_bytes} bytes while it was read"
        ));
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_directories_are_refused_before_reading() {
        let e = read_bounded(Path::new("/dev/zero"), MAX_SCENE_BYTES, "scene file").unwrap_err();
        assert!(e.contains("not a regular file"), "{e}");
        let e = read_bounded(Path::new("/"), MAX_SCENE_BYTES, "scene file").unwrap_err();
        assert!(e.contains("not a regular file"), "{e}");
    }

    #[test]
    fn files_over_the_limit_are_refused() {
        let dir = std::env::temp_dir().join(format!("cmlt-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("eleven.txt");
        std::fs::write(&p, b"01234567890").unwrap();
        let e = read_bounded(&p, 10, "mesh file").unwrap_err();
        assert!(e.contains("11 bytes, more than the limit of 10"), "{e}");
        assert_eq!(read_bounded(&p, 11, "mesh file").unwrap().len(), 11);
        std::fs::remove_dir_all(&dir).ok();
    }
}

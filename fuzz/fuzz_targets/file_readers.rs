//! The loader's binary file readers on arbitrary bytes: the first byte
//! picks what the bytes are read as (OBJ, PLY, `serialized` with a shape
//! index from the second byte, an image texture — PNG, OpenEXR, Radiance
//! HDR or PFM by name and content —, an environment map, a `.vol` grid),
//! the rest is written to that file, and a scene that reads it is loaded
//! through the public entry point. It must return a scene or an error,
//! never panic, and never allocate beyond the bounds libFuzzer sets
//! (`fuzz/Cargo.toml`): every reader checks sizes against the file before
//! it allocates.
#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;

/// This process's scratch directory (RAM-backed where there is one).
fn scratch() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let shm = PathBuf::from("/dev/shm");
        let base = if shm.is_dir() {
            shm
        } else {
            std::env::temp_dir()
        };
        let d = base.join(format!("cmlt-fuzz-files-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("scratch directory");
        d
    })
}

/// The file name and the scene elements that read it, for kind `k`.
fn scene_for(k: u8, index: u8) -> (&'static str, String) {
    let texture = |file: &str| {
        format!(
            r#"<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
               <string name="filename" value="{file}"/></texture></bsdf></shape>"#
        )
    };
    match k % 9 {
        0 => ("f.obj", r#"<shape type="obj"><string name="filename" value="f.obj"/></shape>"#.into()),
        1 => ("f.ply", r#"<shape type="ply"><string name="filename" value="f.ply"/></shape>"#.into()),
        2 => (
            "f.serialized",
            format!(
                r#"<shape type="serialized"><string name="filename" value="f.serialized"/>
                   <integer name="shape_index" value="{}"/></shape>"#,
                index % 4
            ),
        ),
        3 => ("f.png", texture("f.png")),
        4 => ("f.exr", texture("f.exr")),
        5 => ("f.hdr", texture("f.hdr")),
        6 => ("f.pfm", texture("f.pfm")),
        7 => (
            "g.exr",
            r#"<emitter type="envmap"><string name="filename" value="g.exr"/></emitter>"#.into(),
        ),
        _ => (
            "f.vol",
            r#"<shape type="rectangle"><bsdf type="diffuse"><texture type="volume" name="reflectance">
               <volume type="gridvolume" name="volume"><string name="filename" value="f.vol"/></volume>
               </texture></bsdf></shape>"#
                .into(),
        ),
    }
}

fuzz_target!(|data: &[u8]| {
    let [k, index, bytes @ ..] = data else {
        return;
    };
    let (file, elements) = scene_for(*k, *index);
    let dir = scratch();
    if std::fs::write(dir.join(file), bytes).is_err() {
        return;
    }
    let xml = format!(
        r#"<scene version="3.0.0">
  <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/>
    <integer name="height" value="4"/></film></sensor>
  <emitter type="constant"/>
  {elements}
</scene>"#
    );
    let _ = cmlt_mitsuba::load_scene_str(&xml, dir, "fuzz.xml", &[]);
});

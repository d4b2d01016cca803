//! Bitterli's 25 Mitsuba scenes (<https://benedikt-bitterli.me/resources/>)
//! through the normal loader: which load and render, and what blocks the
//! rest.
//!
//! The scenes live in `tests/corpus/bitterli/<scene>/` (Mitsuba 3 XML,
//! `LICENSE.txt`, `SOURCE.txt`; meshes and textures only where they fit the
//! repository's size budget) and, for the four with references, in
//! `tests/scenes/<scene>/`. [`EXPECTED`] says what each one does today; the
//! test fails when reality differs in either direction, so a feature that
//! lands (or breaks) shows up as a line to change in that one table. A
//! failure lists every mismatch with the loader's own message.
//!
//! - A scene with all its files is loaded at 16×16 (`-D resx/resy`
//!   overrides) and rendered with PT at 2 spp; it `Renders` when the image
//!   is finite and non-negative.
//! - A scene committed as XML only (its meshes are too large or missing from
//!   every public snapshot) cannot render. To still learn whether cmlt
//!   supports all its plugins, it is loaded from a temporary copy in which
//!   each absent OBJ mesh is replaced by a one-triangle OBJ and each absent
//!   image by a 1×1 grey image of the same format (PNG for JPEG/PNG names,
//!   OpenEXR, Radiance HDR, PFM). Stand-ins are written by this test only,
//!   so the loader's code path is the normal one (no test-only loader
//!   option), and they cannot hide an unsupported plugin or property: those
//!   are rejected from the XML alone. Files of other kinds (`serialized`
//!   meshes) get no stand-in, so the loader's error for them is reported as
//!   what it is. Such a scene is `PluginsOk` when it loads; it is not
//!   rendered (the image of stand-in geometry means nothing).
//! - Otherwise the scene is `Blocked` by the loader's first error; the
//!   table holds a phrase of that message, e.g. the unsupported plugin.
//!   The loader stops at the first error, so one blocker is listed per
//!   scene (`tests/corpus/README.md` has the full census by hand).
//! - `Unavailable`: no Mitsuba version of the scene was found in any
//!   repository snapshot; the test checks that none was committed.

use std::path::{Path, PathBuf};

use cmlt::math::Rgb;
use cmlt::renderer::Estimator;
use cmlt_cli::image_io::{Image, read_exr, write_exr};
use cmlt_cli::mitsuba::load_scene;

use crate::common::render_scene;

/// What a scene of the corpus does today.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Expect {
    /// All files present; loads, and PT renders a finite, non-negative image.
    Renders,
    /// Files missing, but every plugin and property is supported (loads
    /// with stand-ins for the missing meshes and images).
    PluginsOk,
    /// The loader's first error contains this phrase.
    Blocked(&'static str),
    /// No Mitsuba version available; nothing committed.
    Unavailable,
}

use Expect::{Blocked, PluginsOk, Renders, Unavailable};

/// The expectation table: every one of Bitterli's 25 Mitsuba scenes, in
/// the order of his resources page. Update it when a feature lands.
const EXPECTED: &[(&str, Expect)] = &[
    ("bathroom", PluginsOk),
    ("bathroom2", Blocked("unsupported BSDF plugin 'phong'")),
    // Mitsuba 0.6's sun_color/sky_color, which Mitsuba 3's sunsky lacks.
    ("bedroom", Blocked("unsupported property 'sun_color'")),
    ("car", PluginsOk),
    ("car2", PluginsOk),
    ("classroom", PluginsOk),
    ("coffee", PluginsOk),
    ("cornell-box", Renders),
    ("dining-room", PluginsOk),
    ("glass-of-water", PluginsOk),
    ("house", PluginsOk),
    ("kitchen", PluginsOk),
    ("lamp", PluginsOk),
    ("living-room", Renders),
    ("living-room-2", PluginsOk),
    ("living-room-3", Blocked("unsupported shape plugin 'hair'")),
    ("material-testball", Unavailable),
    ("spaceship", PluginsOk),
    ("staircase", PluginsOk),
    ("staircase2", Renders),
    ("teapot", PluginsOk),
    ("teapot-full", PluginsOk),
    ("veach-ajar", Renders),
    ("veach-bidir", Renders),
    ("veach-mis", Renders),
];

/// What the loader did with a scene.
#[derive(Debug)]
enum Outcome {
    Renders,
    PluginsOk { stand_ins: usize },
    Blocked(String),
    Unavailable,
}

fn repo_dir(sub: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(sub)
}

/// The scene's folder: the shared test scenes first, then the corpus.
fn scene_dir(name: &str) -> Option<PathBuf> {
    [
        repo_dir("tests/scenes").join(name),
        repo_dir("tests/corpus/bitterli").join(name),
    ]
    .into_iter()
    .find(|d| d.join("scene.xml").is_file())
}

/// Every `<string name="filename" value="…"/>` outside XML comments (the
/// corpus puts the name before the value, as Mitsuba's exporter does).
fn referenced_files(xml: &str) -> Vec<String> {
    let mut text = String::with_capacity(xml.len());
    let mut rest = xml;
    while let Some(i) = rest.find("<!--") {
        text.push_str(&rest[..i]);
        rest = rest[i..].find("-->").map_or("", |j| &rest[i + j + 3..]);
    }
    text.push_str(rest);
    let mut files = Vec::new();
    for element in text.split('<').filter(|e| e.starts_with("string")) {
        let element = element.split('>').next().unwrap_or("");
        if !element.contains(r#"name="filename""#) {
            continue;
        }
        if let Some(v) = element.split(r#"value=""#).nth(1)
            && let Some(v) = v.split('"').next()
            && !files.iter().any(|f| f == v)
        {
            files.push(v.to_string());
        }
    }
    files
}

/// A one-triangle OBJ with uvs and a normal, standing in for a mesh.
const TRIANGLE_OBJ: &str =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1\n";

/// A one-triangle Mitsuba `.serialized` file (version 4, one shape): its
/// zlib stream is a single stored deflate block, which needs no
/// compressor.
fn serialized_triangle() -> Vec<u8> {
    let mut body = 0x1000u32.to_le_bytes().to_vec(); // single precision
    body.push(0); // empty name
    body.extend(3u64.to_le_bytes());
    body.extend(1u64.to_le_bytes());
    for x in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        body.extend(x.to_le_bytes());
    }
    for i in [0u32, 1, 2] {
        body.extend(i.to_le_bytes());
    }
    let len = body.len() as u16;
    let (mut a, mut b) = (1u32, 0u32);
    for &byte in &body {
        a = (a + byte as u32) % 65521;
        b = (b + a) % 65521;
    }
    let mut file = vec![0x1C, 0x04, 4, 0, 0x78, 0x01, 0x01];
    file.extend(len.to_le_bytes());
    file.extend((!len).to_le_bytes());
    file.extend(&body);
    file.extend(((b << 16) | a).to_be_bytes());
    file.extend(0u64.to_le_bytes());
    file.extend(1u32.to_le_bytes());
    file
}

/// Writes a stand-in for `file` (relative to `dir`) if its kind has one;
/// returns whether it did.
fn write_stand_in(dir: &Path, file: &str) -> bool {
    let path = dir.join(file);
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let ext = file.rsplit('.').next().unwrap_or("").to_ascii_lowercase();
    match ext.as_str() {
        "obj" => std::fs::write(&path, TRIANGLE_OBJ).unwrap(),
        "serialized" => std::fs::write(&path, serialized_triangle()).unwrap(),
        // The loader sniffs the format from the bytes, so a PNG named
        // `.jpg` decodes.
        "jpg" | "jpeg" | "png" => image::RgbImage::from_pixel(1, 1, image::Rgb([128, 128, 128]))
            .save_with_format(&path, image::ImageFormat::Png)
            .unwrap(),
        "exr" => {
            let grey = Image {
                width: 1,
                height: 1,
                pixels: vec![Rgb::splat(0.5)],
            };
            write_exr(&path, &grey).unwrap();
        }
        // Radiance RGBE: mantissas 128 with exponent 128 are 128·2^(128−136) = 0.5.
        "hdr" => {
            let mut bytes = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 1\n".to_vec();
            bytes.extend_from_slice(&[128, 128, 128, 128]);
            std::fs::write(&path, bytes).unwrap();
        }
        // PFM: colour, 1×1, negative scale = little-endian floats.
        "pfm" => {
            let mut bytes = b"PF\n1 1\n-1.0\n".to_vec();
            for _ in 0..3 {
                bytes.extend_from_slice(&0.5f32.to_le_bytes());
            }
            std::fs::write(&path, bytes).unwrap();
        }
        _ => return false,
    }
    true
}

/// Loads (and if complete, renders) one scene.
fn run(name: &str) -> Outcome {
    let Some(dir) = scene_dir(name) else {
        return Outcome::Unavailable;
    };
    let xml_path = dir.join("scene.xml");
    let xml = std::fs::read_to_string(&xml_path).unwrap();
    let missing: Vec<String> = referenced_files(&xml)
        .into_iter()
        .filter(|f| !dir.join(f).is_file())
        .collect();
    let tiny = [
        ("resx".to_string(), "16".to_string()),
        ("resy".to_string(), "16".to_string()),
    ];
    if missing.is_empty() {
        return match load_scene(&xml_path, &tiny) {
            Err(e) => Outcome::Blocked(e.to_string()),
            Ok(loaded) => {
                let (img, _) = render_scene(&loaded, Estimator::Path, 2, 1);
                let bad = img
                    .pixels
                    .iter()
                    .flat_map(|p| [p.r, p.g, p.b])
                    .filter(|v| !(v.is_finite() && *v >= 0.0))
                    .count();
                assert_eq!(bad, 0, "{name}: {bad} non-finite or negative pixel values");
                Outcome::Renders
            }
        };
    }
    // XML only: a temporary copy with stand-ins for what is missing (and
    // the present files copied alongside).
    let tmp = std::env::temp_dir().join(format!("cmlt-corpus-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).unwrap();
    let mut stand_ins = 0;
    for f in referenced_files(&xml) {
        if missing.contains(&f) {
            stand_ins += write_stand_in(&tmp, &f) as usize;
        } else {
            let to = tmp.join(&f);
            std::fs::create_dir_all(to.parent().unwrap()).unwrap();
            std::fs::copy(dir.join(&f), to).unwrap();
        }
    }
    let tmp_xml = tmp.join("scene.xml");
    std::fs::write(&tmp_xml, &xml).unwrap();
    let outcome = match load_scene(&tmp_xml, &tiny) {
        Ok(_) => Outcome::PluginsOk { stand_ins },
        // Name the committed file, not the temporary copy.
        Err(e) => Outcome::Blocked(e.to_string().replace(
            &tmp_xml.display().to_string(),
            &xml_path.display().to_string(),
        )),
    };
    std::fs::remove_dir_all(&tmp).unwrap();
    outcome
}

fn matches(expect: Expect, outcome: &Outcome) -> bool {
    match (expect, outcome) {
        (Renders, Outcome::Renders) | (Unavailable, Outcome::Unavailable) => true,
        (PluginsOk, Outcome::PluginsOk { .. }) => true,
        (Blocked(phrase), Outcome::Blocked(msg)) => msg.contains(phrase),
        _ => false,
    }
}

/// Every scene of [`EXPECTED`] does what the table says.
#[test]
fn bitterli_scenes_match_the_table() {
    assert_eq!(EXPECTED.len(), 25, "Bitterli has 25 Mitsuba scenes");
    let mut mismatches = Vec::new();
    let mut renders = 0;
    for &(name, expect) in EXPECTED {
        let outcome = run(name);
        renders += matches!(outcome, Outcome::Renders) as usize;
        match &outcome {
            Outcome::PluginsOk { stand_ins } => {
                eprintln!("{name:18} PluginsOk ({stand_ins} files replaced by stand-ins)")
            }
            other => eprintln!("{name:18} {other:?}"),
        }
        if !matches(expect, &outcome) {
            mismatches.push(format!("{name}: expected {expect:?}, got {outcome:?}"));
        }
    }
    eprintln!("{renders} of {} render", EXPECTED.len());
    assert!(
        mismatches.is_empty(),
        "update EXPECTED in cli/tests/suite/corpus.rs:\n{}",
        mismatches.join("\n")
    );
}

/// The stand-in machinery itself: references inside comments are not
/// files, a missing mesh becomes a triangle the loader accepts, and a scene
/// whose only problem is a missing mesh is `PluginsOk`, not `Blocked`.
#[test]
fn stand_ins_only_replace_missing_files() {
    let xml = r#"<scene version="3.0.0">
        <!-- <shape type="obj"><string name="filename" value="gone.obj"/></shape> -->
        <shape type="obj"><string name="filename" value="models/m.obj"/></shape>
        <texture type="bitmap" id="t"><string name="filename" value="textures/a b.jpg"/></texture>
    </scene>"#;
    assert_eq!(
        referenced_files(xml),
        ["models/m.obj".to_string(), "textures/a b.jpg".to_string()]
    );
    let tmp = std::env::temp_dir().join(format!("cmlt-corpus-standin-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    assert!(write_stand_in(&tmp, "models/m.obj"));
    assert!(write_stand_in(&tmp, "textures/a b.jpg"));
    assert!(write_stand_in(&tmp, "textures/sky.exr"));
    assert_eq!(
        read_exr(&tmp.join("textures/sky.exr")).unwrap().pixels,
        [Rgb::splat(0.5)]
    );
    assert!(write_stand_in(&tmp, "textures/sky.hdr"));
    assert!(write_stand_in(&tmp, "textures/sky.pfm"));
    assert!(write_stand_in(&tmp, "meshes/m.serialized"));
    assert!(!write_stand_in(&tmp, "meshes/m.stl"));
    let scene = r#"<scene version="3.0.0">
        <default name="resx" value="4"/><default name="resy" value="4"/>
        <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="$resx"/>
          <integer name="height" value="$resy"/><rfilter type="box"/></film></sensor>
        <shape type="obj"><string name="filename" value="models/m.obj"/>
          <bsdf type="diffuse"><texture type="bitmap" name="reflectance">
            <string name="filename" value="textures/a b.jpg"/></texture></bsdf></shape>
        <shape type="serialized"><string name="filename" value="meshes/m.serialized"/></shape>
    </scene>"#;
    std::fs::write(tmp.join("scene.xml"), scene).unwrap();
    let loaded = load_scene(&tmp.join("scene.xml"), &[]).unwrap();
    assert_eq!(loaded.scene.triangles().count(), 2);
    std::fs::remove_dir_all(&tmp).unwrap();
}

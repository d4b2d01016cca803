//! `volume` textures (Mitsuba 3's `constvolume` and `gridvolume` read at
//! a surface's world position): `.vol` files written by the test and read
//! back through the loader, looked up where Mitsuba 3.9.1's `gridvolume`
//! was evaluated for the same bytes and properties; bad input is refused
//! with the scene's file:line and the reason. The rendered scene against
//! Mitsuba's reference is `references::volume_texture_*`.

use std::path::{Path, PathBuf};

use cmlt::math::{Rgb, Vec3};
use cmlt::scene::{MaterialKind, Texture};
use cmlt_mitsuba::{LoadError, LoadedScene, load_scene_str};

/// A fresh directory for one test's files.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cmlt-vol-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A `.vol` file (version 3, float32) of `res` voxels and `channels`
/// channels with bounding box `bbox`.
fn vol(res: [u32; 3], channels: u32, bbox: [f32; 6], values: &[f32]) -> Vec<u8> {
    let mut b = b"VOL\x03".to_vec();
    for v in [1, res[0], res[1], res[2], channels] {
        b.extend(v.to_le_bytes());
    }
    for v in bbox.iter().chain(values) {
        b.extend(v.to_le_bytes());
    }
    b
}

/// The 4×3×2 grid of (x/3, y/2, z) Mitsuba was asked about, with the
/// bounding box (−1, −1, −1)–(3, 3, 3).
fn ramp() -> Vec<u8> {
    let mut v = Vec::new();
    for z in 0..2 {
        for y in 0..3 {
            for x in 0..4 {
                v.extend([x as f32 / 3.0, y as f32 / 2.0, z as f32]);
            }
        }
    }
    vol([4, 3, 2], 3, [-1.0, -1.0, -1.0, 3.0, 3.0, 3.0], &v)
}

/// Loads a rectangle whose diffuse reflectance is the `volume` given.
fn load(d: &Path, volume: &str) -> Result<LoadedScene, LoadError> {
    let xml = format!(
        r#"<scene version="3.0.0">
  <sensor type="perspective"><film type="hdrfilm"/></sensor>
  <shape type="rectangle"><bsdf type="diffuse">
    <texture type="volume" name="reflectance">
      {volume}
    </texture>
  </bsdf></shape>
</scene>"#
    );
    load_scene_str(&xml, d, "vol.xml", &[])
}

fn grid_value(l: &LoadedScene, p: [f32; 3]) -> Rgb {
    let MaterialKind::Diffuse {
        reflectance: Texture::Grid(id),
    } = l.scene.materials[0].kind
    else {
        panic!("{:?}", l.scene.materials[0].kind);
    };
    l.scene.grids[id.0 as usize].eval(Vec3::from(p))
}

fn close(a: Rgb, b: [f32; 3]) -> bool {
    (a.r - b[0]).abs() < 1e-4 && (a.g - b[1]).abs() < 1e-4 && (a.b - b[2]).abs() < 1e-4
}

/// Mitsuba 3.9.1 (`mi.load_dict` of a `gridvolume` over the same bytes,
/// `eval` at these points): the file's box ignored unless
/// `use_grid_bbox`, `to_world` placing the unit cube, trilinear at voxel
/// centres, clamp and mirror wrapping.
#[test]
fn grids_read_as_mitsubas_gridvolume() {
    let d = dir("ok");
    std::fs::write(d.join("ramp.vol"), ramp()).unwrap();
    let cases: [(&str, [f32; 3], [f32; 3]); 6] = [
        ("", [0.3, 0.7, 0.9], [0.233333, 0.8, 1.0]),
        ("", [0.5, 0.5, 0.5], [0.5, 0.5, 0.5]),
        (
            r#"<boolean name="use_grid_bbox" value="true"/><transform name="to_world"><translate x="1"/></transform>"#,
            [1.0, 0.0, 0.0],
            [0.166667, 0.125, 0.0],
        ),
        (
            r#"<boolean name="use_grid_bbox" value="true"/><transform name="to_world"><translate x="1"/></transform>"#,
            [1.2, 0.8, 1.6],
            [0.233333, 0.425, 0.8],
        ),
        (
            r#"<transform name="to_world"><translate x="1"/><scale value="2"/></transform>"#,
            [2.6, 1.4, 1.8],
            [0.233333, 0.8, 1.0],
        ),
        (
            r#"<string name="wrap_mode" value="mirror"/><transform name="to_world"><translate x="1"/><scale value="2"/></transform>"#,
            [-0.3, 0.5, 2.5],
            [0.966667, 0.125, 1.0],
        ),
    ];
    for (props, p, want) in cases {
        let v = format!(
            r#"<volume type="gridvolume" name="volume"><string name="filename" value="ramp.vol"/>{props}</volume>"#
        );
        let l = load(&d, &v).unwrap_or_else(|e| panic!("{e}"));
        let got = grid_value(&l, p);
        assert!(
            close(got, want),
            "{props} at {p:?}: {got:?}, Mitsuba {want:?}"
        );
    }
    // A constvolume is a constant texture.
    let l = load(
        &d,
        r#"<volume type="constvolume" name="volume"><rgb name="value" value="0.2, 0.3, 0.4"/></volume>"#,
    )
    .unwrap();
    assert!(matches!(
        l.scene.materials[0].kind,
        MaterialKind::Diffuse { reflectance: Texture::Constant(c) } if c == Rgb::new(0.2, 0.3, 0.4)
    ));
    std::fs::remove_dir_all(&d).ok();
}

/// Each bad input fails with vol.xml's line and the reason; the scene is
/// not loaded.
#[test]
fn bad_volume_textures_are_refused_with_the_reason() {
    let d = dir("bad");
    std::fs::write(d.join("ramp.vol"), ramp()).unwrap();
    let bright = vol([1, 1, 1], 1, [0.0, 0.0, 0.0, 1.0, 1.0, 1.0], &[1.5]);
    std::fs::write(d.join("bright.vol"), bright).unwrap();
    let mut cut = ramp();
    cut.truncate(100);
    std::fs::write(d.join("cut.vol"), cut).unwrap();
    let grid = |extra: &str| {
        format!(
            r#"<volume type="gridvolume" name="volume"><string name="filename" value="ramp.vol"/>{extra}</volume>"#
        )
    };
    let cases = [
        (
            r#"<volume type="gridvolume" name="volume"/>"#.to_string(),
            "lacks the 'filename' property",
        ),
        (
            r#"<volume type="gridvolume" name="volume"><string name="filename" value="none.vol"/></volume>"#.to_string(),
            "volume file 'none.vol': cannot open",
        ),
        (
            r#"<volume type="gridvolume" name="volume"><string name="filename" value="cut.vol"/></volume>"#.to_string(),
            "does not match the file's 100 bytes",
        ),
        (grid(r#"<string name="filter_type" value="cubic"/>"#), "invalid filter_type 'cubic'"),
        (grid(r#"<string name="wrap_mode" value="tile"/>"#), "invalid wrap_mode 'tile'"),
        (
            grid(r#"<transform name="to_world"><scale value="0"/></transform>"#),
            "must be an invertible affine transform",
        ),
        (grid(r#"<float name="density" value="2"/>"#), "'density'"),
        (
            r#"<volume type="gridvolume" name="volume"><string name="filename" value="bright.vol"/></volume>"#.to_string(),
            "voxels must lie in [0, 1]",
        ),
        (r#"<volume type="perlin" name="volume"/>"#.to_string(), "unsupported volume plugin 'perlin'"),
        (r#"<rgb name="volume" value="0.5"/>"#.to_string(), "must be a <volume> object"),
        (
            format!(r#"{}<transform name="to_uv"><scale value="2"/></transform>"#, grid("")),
            "takes no 'to_uv'",
        ),
    ];
    for (volume, want) in cases {
        let e = match load(&d, &volume) {
            Ok(_) => panic!("loaded with {volume}"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains("vol.xml:"), "{volume}: no file:line in '{e}'");
        assert!(e.contains(want), "{volume}: '{e}' does not say '{want}'");
    }
    // A grid has no uv gradient: it cannot be a bump map.
    let xml = r#"<scene version="3.0.0">
  <sensor type="perspective"><film type="hdrfilm"/></sensor>
  <shape type="rectangle"><bsdf type="bumpmap">
    <texture type="volume"><volume type="gridvolume" name="volume"><string name="filename" value="ramp.vol"/></volume></texture>
    <bsdf type="diffuse"/>
  </bsdf></shape>
</scene>"#;
    let e = load_scene_str(xml, &d, "vol.xml", &[])
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("cannot be a normal or bump map"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}

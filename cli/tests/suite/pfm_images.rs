//! PFM images named by scenes (`envmap` and `bitmap` textures), written by
//! the test and read back through the loader, against what Mitsuba 3.9.1's
//! `mi.Bitmap` reads from the same bytes; malformed files are refused with
//! the scene's file:line, the image's name and the reason.

use std::path::{Path, PathBuf};

use cmlt::math::{Rgb, Vec2};
use cmlt::scene::{Bitmap, Light};
use cmlt_mitsuba::{LoadError, LoadedScene, load_scene_str};

/// A fresh directory for one test's files.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cmlt-pfm-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A PFM file: `header`, then `values` as 32-bit floats in the byte order
/// `little` says.
fn pfm(header: &str, values: &[f32], little: bool) -> Vec<u8> {
    let mut bytes = header.as_bytes().to_vec();
    for v in values {
        bytes.extend(if little {
            v.to_le_bytes()
        } else {
            v.to_be_bytes()
        });
    }
    bytes
}

/// Loads a scene whose envmap (line 3) and diffuse texture (line 5) read
/// `sky.pfm` and `grey.pfm` in `d`.
fn load(d: &Path) -> Result<LoadedScene, LoadError> {
    let xml = r#"<scene version="3.0.0">
  <sensor type="perspective"><film type="hdrfilm"/></sensor>
  <emitter type="envmap"><string name="filename" value="sky.pfm"/></emitter>
  <shape type="rectangle"><bsdf type="diffuse">
    <texture type="bitmap" name="reflectance"><string name="filename" value="grey.pfm"/></texture>
  </bsdf></shape>
</scene>"#;
    load_scene_str(xml, d, "pfm.xml", &[])
}

/// The texel at column `x`, row `y` (row 0 at the top) of `b`.
fn texel(b: &Bitmap, x: u32, y: u32) -> Rgb {
    b.eval(Vec2::new(
        (x as f32 + 0.5) / b.width() as f32,
        (y as f32 + 0.5) / b.height() as f32,
    ))
}

/// A little-endian colour file (scale −1) and a big-endian grey one
/// (scale 0.5) come back as Mitsuba reads them: rows from the bottom up,
/// grey replicated, values times |scale|. Mitsuba 3.9.1 read the colour
/// bytes as top row (1, 0, 0), (0.5, 0.25, 2), bottom row (0, 0, 1),
/// (0, 1, 0), and scales 2 and −0.5 as multiplying by 2 and 0.5.
#[test]
fn pfm_envmap_and_texture_read_as_mitsuba_reads_them() {
    let d = dir("ok");
    #[rustfmt::skip]
    let sky = [0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.25, 2.0];
    std::fs::write(d.join("sky.pfm"), pfm("PF\n2 2\n-1.0\n", &sky, true)).unwrap();
    let grey = [0.25, 1.0, 1.5];
    std::fs::write(d.join("grey.pfm"), pfm("Pf 3 1 0.5\n", &grey, false)).unwrap();
    let l = load(&d).unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_dir_all(&d).ok();
    let s = &l.scene;
    let lights: Vec<Light> = s.lights.others().copied().collect();
    let Light::Envmap { bitmap, .. } = lights[0] else {
        panic!("{:?}", lights[0]);
    };
    let b = &s.bitmaps[bitmap.0 as usize];
    assert_eq!((b.width(), b.height()), (2, 2));
    assert_eq!(texel(b, 0, 0), Rgb::new(1.0, 0.0, 0.0));
    assert_eq!(texel(b, 1, 0), Rgb::new(0.5, 0.25, 2.0));
    assert_eq!(texel(b, 0, 1), Rgb::new(0.0, 0.0, 1.0));
    assert_eq!(texel(b, 1, 1), Rgb::new(0.0, 1.0, 0.0));
    let t = s
        .bitmaps
        .iter()
        .find(|b| (b.width(), b.height()) == (3, 1))
        .expect("the texture's bitmap");
    for (x, v) in [0.125, 0.5, 0.75].into_iter().enumerate() {
        assert_eq!(texel(t, x as u32, 0), Rgb::splat(v));
    }
}

/// Every malformed file is refused at the element that names it, with the
/// file's name and what is wrong; a good sky beside it changes nothing.
#[test]
fn malformed_pfm_files_are_refused_with_their_reason() {
    let good_sky = pfm("PF\n1 1\n-1\n", &[1.0, 1.0, 1.0], true);
    let cases: [(Vec<u8>, &str); 9] = [
        (pfm("Pf\n2 2\n-1\n", &[0.5; 3], true), "cut short"),
        (b"Pf\n2 2\n".to_vec(), "no scale"),
        (b"Pf\n0 2\n-1\n".to_vec(), "width is 0"),
        (b"Pf\n1 40000\n-1\n".to_vec(), "outside 1..=32768"),
        (b"Pf\n1 x\n-1\n".to_vec(), "bad height 'x'"),
        (b"Pf\n1 1\nnan\n\0\0\0\0".to_vec(), "bad scale 'nan'"),
        (
            pfm("Pf\n2 1\n-1\n", &[0.5, f32::INFINITY], true),
            "texel (1, 0) is not finite",
        ),
        (
            pfm("Pf\n1 2\n1\n", &[0.5, -1.0], false),
            "texel (0, 0) is negative",
        ),
        (b"PF".to_vec(), "cannot decode"),
    ];
    for (i, (bytes, reason)) in cases.into_iter().enumerate() {
        let d = dir(&format!("bad{i}"));
        std::fs::write(d.join("sky.pfm"), &good_sky).unwrap();
        std::fs::write(d.join("grey.pfm"), &bytes).unwrap();
        let e = load(&d).unwrap_err();
        std::fs::remove_dir_all(&d).ok();
        assert_eq!(
            (e.file.as_str(), e.line),
            ("pfm.xml", Some(5)),
            "case {i}: {e}"
        );
        assert!(e.message.contains("grey.pfm"), "case {i}: {e}");
        assert!(e.message.contains(reason), "case {i}: {e}");
    }
}

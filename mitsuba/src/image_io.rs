//! Decoding the images a scene names (`bitmap` textures, `envmap`
//! emitters) into linear RGB, within bounds.
//!
//! Formats: JPEG and PNG (8 or 16 bits per channel) and the float formats
//! OpenEXR, Radiance HDR (RGBE) and PFM (`pfm.rs`). Mitsuba's colour rules: integer data is
//! sRGB-encoded and decoded to linear unless the texture is `raw`; float
//! data is linear already and taken as it is. Alpha is dropped.
//!
//! A hostile file cannot make the decoder allocate without bound: the file
//! is read through [`input::read_bounded`], an OpenEXR file's headers are
//! checked first (the data window a header declares sizes the decoder's
//! buffers, and it need not match the display window the `image` crate
//! checks), and the `image` crate's [`image::Limits`] bound the sides and
//! the memory of every decode. Negative and non-finite texels are refused:
//! they are neither radiance nor reflectance, and clamping them would
//! render a different image than the file describes.

use std::io::Cursor;
use std::path::Path;

use cmlt::math::Rgb;
use cmlt::math::spectrum::srgb_to_linear;
use cmlt::scene::Bitmap;

use super::input::{self, MAX_IMAGE_ALLOC, MAX_IMAGE_BYTES, MAX_IMAGE_SIDE};
use super::pfm;

/// The `image` crate's limits for our decodes.
fn limits() -> image::Limits {
    let mut l = image::Limits::no_limits();
    l.max_image_width = Some(MAX_IMAGE_SIDE);
    l.max_image_height = Some(MAX_IMAGE_SIDE);
    l.max_alloc = Some(MAX_IMAGE_ALLOC);
    l
}

/// Refuses an OpenEXR file any of whose layers declares a data or display
/// window with a side over [`MAX_IMAGE_SIDE`].
fn check_exr_headers(bytes: &[u8]) -> Result<(), String> {
    let meta = exr::meta::MetaData::read_from_buffered(bytes, false)
        .map_err(|e| format!("cannot decode: OpenEXR header: {e}"))?;
    for h in &meta.headers {
        let data = h.layer_size;
        let display = h.shared_attributes.display_window.size;
        for (what, w, h) in [
            ("data", data.width(), data.height()),
            ("display", display.width(), display.height()),
        ] {
            if w > MAX_IMAGE_SIDE as usize || h > MAX_IMAGE_SIDE as usize {
                return Err(format!(
                    "the OpenEXR {what} window is {w}×{h}, more than the limit of \
                     {MAX_IMAGE_SIDE} texels a side"
                ));
            }
        }
    }
    Ok(())
}

/// Decodes an image file into linear RGB (row 0 at the top). Integer
/// images are sRGB-encoded unless `raw` (Mitsuba decodes 8-bit data with
/// the sRGB curve and treats 16-bit PNGs the same way); float images
/// (OpenEXR, Radiance HDR) are linear. The error says what is wrong,
/// without the file name (the caller adds it).
pub(crate) fn decode_bitmap(path: &Path, raw: bool) -> Result<Bitmap, String> {
    let bytes = input::read_bounded(path, MAX_IMAGE_BYTES, "image file")?;
    if pfm::is_pfm(&bytes) {
        let (w, _, texels) = pfm::decode_pfm(&bytes)?;
        check_texels(w, &texels)?;
        return Bitmap::new(w, texels.len() as u32 / w, texels)
            .ok_or_else(|| "the image is empty".to_string());
    }
    let bytes = radiance_magic(bytes);
    let mut reader = image::ImageReader::new(Cursor::new(bytes.as_slice()))
        .with_guessed_format()
        .map_err(|e| format!("cannot read: {e}"))?;
    if reader.format() == Some(image::ImageFormat::OpenExr) {
        check_exr_headers(&bytes)?;
    }
    if reader.format() == Some(image::ImageFormat::Jpeg) && !jpeg_is_whole(&bytes) {
        return Err("truncated JPEG: the file ends before its end-of-image marker".into());
    }
    reader.limits(limits());
    let img = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| reader.decode()))
        .map_err(|_| "the image decoder failed on malformed data".to_string())?
        .map_err(|e| format!("cannot decode: {e}"))?;
    let (w, h) = (img.width(), img.height());
    let ct = img.color();
    let float = matches!(ct, image::ColorType::Rgb32F | image::ColorType::Rgba32F);
    let bytes_per_channel = ct.bytes_per_pixel() as usize / ct.channel_count().max(1) as usize;
    let decode = |v: f32| if raw { v } else { srgb_to_linear(v) };
    let texels: Vec<Rgb> = if float {
        // Floating-point images are linear already.
        img.to_rgb32f()
            .pixels()
            .map(|p| Rgb::new(p[0], p[1], p[2]))
            .collect()
    } else if bytes_per_channel == 1 {
        let lut: Vec<f32> = (0..256).map(|i| decode(i as f32 / 255.0)).collect();
        img.to_rgb8()
            .pixels()
            .map(|p| Rgb::new(lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]))
            .collect()
    } else {
        img.to_rgb16()
            .pixels()
            .map(|p| {
                Rgb::new(
                    decode(p[0] as f32 / 65535.0),
                    decode(p[1] as f32 / 65535.0),
                    decode(p[2] as f32 / 65535.0),
                )
            })
            .collect()
    };
    check_texels(w, &texels)?;
    Bitmap::new(w, h, texels).ok_or_else(|| "the image is empty".to_string())
}

/// A Radiance HDR file starts with `#?` and the name of the program
/// that wrote it: `#?RADIANCE` by convention, but Mitsuba (and others)
/// write `#?RGBE`. The `image` crate recognises only the first, so any
/// other first line of that form is read as it.
fn radiance_magic(mut bytes: Vec<u8>) -> Vec<u8> {
    const MAGIC: &[u8] = b"#?RADIANCE";
    let Some(end) = bytes.iter().take(64).position(|&b| b == b'\n') else {
        return bytes;
    };
    let line = &bytes[..end];
    let program = line.strip_prefix(b"#?").unwrap_or(&[]);
    if line == MAGIC || program.is_empty() || !program.iter().all(u8::is_ascii_alphanumeric) {
        return bytes;
    }
    bytes.splice(..end, MAGIC.iter().copied());
    bytes
}

/// Refuses the first negative or non-finite texel, naming its column and
/// row.
fn check_texels(width: u32, texels: &[Rgb]) -> Result<(), String> {
    let bad = |t: &Rgb| !(t.is_finite() && t.r >= 0.0 && t.g >= 0.0 && t.b >= 0.0);
    if let Some(i) = texels.iter().position(bad) {
        let t = texels[i];
        let (x, y) = (i % width.max(1) as usize, i / width.max(1) as usize);
        let what = if t.is_finite() {
            "negative"
        } else {
            "not finite"
        };
        return Err(format!(
            "texel ({x}, {y}) is {what} ({}, {}, {}): texels must be finite and non-negative",
            t.r, t.g, t.b
        ));
    }
    Ok(())
}

/// Whether a JPEG file is whole: an end-of-image marker (FF D9) follows
/// its last start-of-scan (FF DA). Inside entropy-coded data an FF byte
/// is always followed by 00 or a restart marker, so the first FF D9 after
/// the last scan is the image's end. The decoder accepts a file cut inside
/// its last scan and fills the missing blocks with grey, silently.
fn jpeg_is_whole(bytes: &[u8]) -> bool {
    let last_scan = bytes.windows(2).rposition(|w| w == [0xFF, 0xDA]);
    last_scan.is_some_and(|i| bytes[i..].windows(2).any(|w| w == [0xFF, 0xD9]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, bytes: &[u8]) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("cmlt-image-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    /// A Radiance HDR file of the given texels (flat, no RLE).
    fn hdr(w: u32, h: u32, texels: &[[f32; 3]]) -> Vec<u8> {
        let mut out = Vec::new();
        let pixels: Vec<image::Rgb<f32>> = texels.iter().map(|t| image::Rgb(*t)).collect();
        image::codecs::hdr::HdrEncoder::new(&mut out)
            .encode(&pixels, w as usize, h as usize)
            .unwrap();
        out
    }

    /// A Radiance file whose first line names another program than
    /// RADIANCE (`#?RGBE`, as Mitsuba 3 writes it: this pixel is the
    /// first of a 2×2 image Mitsuba 3.9.1 wrote, value (0.1, 0.2, 0.3))
    /// reads like one that says `#?RADIANCE`.
    #[test]
    fn radiance_files_from_other_programs_are_read() {
        let body = b"FORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 1\n\x33\x66\x99\x7f";
        for first in [&b"#?RGBE\n"[..], b"#?RADIANCE\n"] {
            let p = write("rgbe.hdr", &[first, &body[..]].concat());
            let b = decode_bitmap(&p, false).unwrap();
            let t = b.texels()[0];
            for (got, want) in [(t.r, 0.1), (t.g, 0.2), (t.b, 0.3)] {
                assert!((got / want - 1.0).abs() < 0.02, "{t:?}");
            }
        }
        // Not a program name: left alone, and refused as no known format.
        let p = write("odd.hdr", &[&b"#?R GBE\n"[..], &body[..]].concat());
        assert!(decode_bitmap(&p, false).is_err());
    }

    fn exr(w: usize, h: usize, f: impl Fn(usize, usize) -> (f32, f32, f32) + Sync) -> Vec<u8> {
        use exr::prelude::*;
        let mut out = Cursor::new(Vec::new());
        let img = Image::from_channels(
            (w, h),
            SpecificChannels::rgb(|p: Vec2<usize>| f(p.x(), p.y())),
        );
        img.write().to_buffered(&mut out).unwrap();
        out.into_inner()
    }

    /// Float images come back linear and unchanged (not sRGB-decoded,
    /// `raw` or not), row 0 at the top; RGBE keeps its 8-bit mantissas.
    #[test]
    fn float_images_are_linear() {
        let p = write(
            "a.exr",
            &exr(3, 2, |x, y| (x as f32 * 0.25, y as f32 * 2.0, 7.5)),
        );
        for raw in [false, true] {
            let b = decode_bitmap(&p, raw).unwrap();
            assert_eq!((b.width(), b.height()), (3, 2));
            // Texel centres: uv = ((x + ½)/w, (y + ½)/h).
            let t = b.eval(glam::Vec2::new(2.5 / 3.0, 1.5 / 2.0));
            assert_eq!(t, Rgb::new(0.5, 2.0, 7.5));
            let t = b.eval(glam::Vec2::new(0.5 / 3.0, 0.5 / 2.0));
            assert_eq!(t, Rgb::new(0.0, 0.0, 7.5));
        }
        let p = write("a.hdr", &hdr(2, 1, &[[0.5, 1.0, 4.0], [3.0, 0.25, 0.0]]));
        let b = decode_bitmap(&p, false).unwrap();
        assert_eq!(b.eval(glam::Vec2::new(0.25, 0.5)), Rgb::new(0.5, 1.0, 4.0));
        assert_eq!(b.eval(glam::Vec2::new(0.75, 0.5)), Rgb::new(3.0, 0.25, 0.0));
    }

    /// A PFM file: `PF` little-endian (scale −1) comes back row 0 at the
    /// top (the file stores the bottom row first); `Pf` big-endian with
    /// scale 2 is grey, replicated and doubled, as Mitsuba reads them.
    #[test]
    fn pfm_rows_byte_order_and_scale() {
        // 2×2 RGB; file rows: bottom (y = 1) then top (y = 0).
        let mut f = b"PF\n2 2\n-1.0\n".to_vec();
        for v in [
            [0.0f32, 0.0, 1.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 0.25, 2.0],
        ] {
            for c in v {
                f.extend(c.to_le_bytes());
            }
        }
        let b = decode_bitmap(&write("a.pfm", &f), false).unwrap();
        assert_eq!((b.width(), b.height()), (2, 2));
        let at = |x: f32, y: f32| b.eval(glam::Vec2::new((x + 0.5) / 2.0, (y + 0.5) / 2.0));
        assert_eq!(at(0.0, 0.0), Rgb::new(1.0, 0.0, 0.0));
        assert_eq!(at(1.0, 0.0), Rgb::new(0.5, 0.25, 2.0));
        assert_eq!(at(0.0, 1.0), Rgb::new(0.0, 0.0, 1.0));
        let mut g = b"Pf 3 1 2\n".to_vec();
        for v in [0.25f32, 1.0, 3.0] {
            g.extend(v.to_be_bytes());
        }
        let b = decode_bitmap(&write("grey.pfm", &g), true).unwrap();
        assert_eq!((b.width(), b.height()), (3, 1));
        assert_eq!(b.eval(glam::Vec2::new(0.5, 0.5)), Rgb::splat(2.0));
        assert_eq!(b.eval(glam::Vec2::new(5.0 / 6.0, 0.5)), Rgb::splat(6.0));
    }

    /// Malformed PFM files are refused with what is wrong: cut-short data,
    /// a bad or oversized header, a zero scale, a NaN texel.
    #[test]
    fn malformed_pfm_is_refused() {
        let cases: [(&[u8], &str); 6] = [
            (b"PF\n2 2\n-1\n\0\0\0\0", "cut short"),
            (b"PF\n2\n", "no height"),
            (b"PF\nwide 2\n-1\n", "bad width 'wide'"),
            (b"PF\n99999 1\n-1\n", "outside 1..=32768"),
            (b"Pf\n1 1\n0\n\0\0\0\0", "bad scale '0'"),
            (b"Pf\n1 1\n-1\n\0\0\xc0\x7f", "texel (0, 0) is not finite"),
        ];
        for (i, (bytes, want)) in cases.into_iter().enumerate() {
            let e = decode_bitmap(&write(&format!("bad{i}.pfm"), bytes), false).unwrap_err();
            assert!(e.contains(want), "case {i}: {e}");
        }
    }

    /// Negative and non-finite texels are refused, naming the texel.
    #[test]
    fn bad_texels_are_refused() {
        let p = write(
            "neg.exr",
            &exr(4, 3, |x, y| {
                if (x, y) == (2, 1) {
                    (1.0, -0.5, 0.0)
                } else {
                    (1.0, 1.0, 1.0)
                }
            }),
        );
        let e = decode_bitmap(&p, false).unwrap_err();
        assert!(e.contains("texel (2, 1) is negative"), "{e}");
        let p = write(
            "nan.exr",
            &exr(2, 2, |x, _| {
                if x == 1 {
                    (f32::NAN, 0.0, 0.0)
                } else {
                    (0.0, 0.0, 0.0)
                }
            }),
        );
        let e = decode_bitmap(&p, false).unwrap_err();
        assert!(e.contains("texel (1, 0) is not finite"), "{e}");
        let p = write("inf.exr", &exr(1, 1, |_, _| (f32::INFINITY, 0.0, 0.0)));
        assert!(decode_bitmap(&p, false).unwrap_err().contains("not finite"));
    }

    /// A header declaring a huge image is refused before pixel memory is
    /// taken; a truncated file is an error, not a panic.
    #[test]
    fn hostile_headers_are_refused() {
        let side = MAX_IMAGE_SIDE as usize + 1;
        // Radiance HDR: the size line says 1 × (limit + 1), no pixels.
        let mut bytes = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n".to_vec();
        bytes.extend_from_slice(format!("-Y {side} +X 1\n").as_bytes());
        let e = decode_bitmap(&write("huge.hdr", &bytes), false).unwrap_err();
        assert!(e.contains("exceeds limit"), "{e}");
        // OpenEXR: patch the data and display windows of a 1×1 file.
        let good = exr(1, 1, |_, _| (1.0, 1.0, 1.0));
        let mut bad = good.clone();
        for name in [&b"dataWindow\0box2i\0"[..], &b"displayWindow\0box2i\0"[..]] {
            let at = bad.windows(name.len()).position(|w| w == name).unwrap() + name.len();
            // size (4 bytes), then x_min, y_min, x_max, y_max.
            let x_max = at + 4 + 8;
            bad[x_max..x_max + 4].copy_from_slice(&(side as i32).to_le_bytes());
        }
        let e = decode_bitmap(&write("huge.exr", &bad), false).unwrap_err();
        assert!(e.contains("more than the limit"), "{e}");
        let e = decode_bitmap(&write("cut.exr", &good[..good.len() / 2]), false).unwrap_err();
        assert!(e.contains("cannot decode"), "{e}");
    }
}

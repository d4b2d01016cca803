//! Image files: linear OpenEXR (exr crate) and sRGB PNG (image crate).
//!
//! Outputs are written atomically: encoded in memory, written to a
//! temporary file in the target's directory, flushed to disk and checked,
//! then renamed over the target. A failure at any step (a full disk, a
//! missing directory) leaves the previous file as it was and removes the
//! temporary one; the error names the file.

use std::io::Write;
use std::path::{Path, PathBuf};

use cmlt::math::Rgb;
use cmlt::math::spectrum::linear_to_srgb;

/// A linear RGB image, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Pixels.
    pub pixels: Vec<Rgb>,
}

impl Image {
    /// Averages `factor × factor` blocks: the exact box-filtered image at
    /// 1/factor the resolution (how tests compare small renders with the
    /// full-size references).
    pub fn downsample(&self, factor: usize) -> Image {
        let (w, h) = (self.width / factor, self.height / factor);
        let mut pixels = vec![Rgb::ZERO; w * h];
        let inv = 1.0 / (factor * factor) as f64;
        for y in 0..h {
            for x in 0..w {
                let mut s = [0.0f64; 3];
                for dy in 0..factor {
                    for dx in 0..factor {
                        let p = self.pixels[(y * factor + dy) * self.width + x * factor + dx];
                        s[0] += p.r as f64;
                        s[1] += p.g as f64;
                        s[2] += p.b as f64;
                    }
                }
                pixels[y * w + x] = Rgb::new(
                    (s[0] * inv) as f32,
                    (s[1] * inv) as f32,
                    (s[2] * inv) as f32,
                );
            }
        }
        Image {
            width: w,
            height: h,
            pixels,
        }
    }

    /// Mean of each channel.
    pub fn mean(&self) -> Rgb {
        let mut s = [0.0f64; 3];
        for p in &self.pixels {
            s[0] += p.r as f64;
            s[1] += p.g as f64;
            s[2] += p.b as f64;
        }
        let n = self.pixels.len().max(1) as f64;
        Rgb::new((s[0] / n) as f32, (s[1] / n) as f32, (s[2] / n) as f32)
    }
}

/// Writes a linear float32 RGB OpenEXR file (atomically).
pub fn write_exr(path: &Path, img: &Image) -> Result<(), String> {
    use exr::prelude::{Image as ExrImage, SpecificChannels, Vec2, WritableImage};
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = img.pixels[y * img.width + x];
        (p.r, p.g, p.b)
    });
    let mut bytes = std::io::Cursor::new(Vec::new());
    ExrImage::from_channels((img.width, img.height), channels)
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| format!("{}: cannot write OpenEXR: {e}", path.display()))?;
    write_atomically(path, bytes.get_ref())
}

/// Reads the first RGB(A) layer of an OpenEXR file as linear RGB.
pub fn read_exr(path: &Path) -> Result<Image, String> {
    use exr::prelude::read_first_rgba_layer_from_file;
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| Image {
            width: res.width(),
            height: res.height(),
            pixels: vec![Rgb::ZERO; res.width() * res.height()],
        },
        |img: &mut Image, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            img.pixels[pos.y() * img.width + pos.x()] = Rgb::new(r, g, b);
        },
    )
    .map_err(|e| format!("{}: cannot read OpenEXR: {e}", path.display()))?;
    Ok(image.layer_data.channel_data.pixels)
}

/// Writes an 8-bit sRGB PNG (values clipped to [0, 1] after encoding;
/// atomically).
pub fn write_png(path: &Path, img: &Image) -> Result<(), String> {
    use image::ImageEncoder;
    let mut buf = Vec::with_capacity(img.width * img.height * 3);
    for p in &img.pixels {
        for c in p.to_array() {
            let v = linear_to_srgb(c.max(0.0)).clamp(0.0, 1.0);
            buf.push((v * 255.0 + 0.5) as u8);
        }
    }
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(
            &buf,
            img.width as u32,
            img.height as u32,
            image::ExtendedColorType::Rgb8,
        )
        .map_err(|e| format!("{}: cannot write PNG: {e}", path.display()))?;
    write_atomically(path, &bytes)
}

/// The temporary file an output is written to before it is renamed over
/// `path`: in the same directory (a rename across file systems is a copy),
/// hidden, and named after the process so concurrent renders do not meet.
fn temporary_path(path: &Path) -> Result<PathBuf, String> {
    let name = path
        .file_name()
        .ok_or_else(|| format!("{}: not a file name", path.display()))?;
    let tmp = format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id());
    Ok(path.with_file_name(tmp))
}

/// Writes `bytes` to `path` through a temporary file, flushed to disk and
/// renamed over `path` only when every step succeeded.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), String> {
    refuse_non_regular(path)?;
    let tmp = temporary_path(path)?;
    let written = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        // Without sync a full disk can surface only when the file is
        // closed, where the error is lost.
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    written.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        format!("{}: cannot write: {e}", path.display())
    })
}

/// Refuses a `path` that exists and is not a regular file: renaming over a
/// device (`/dev/full`) or a directory would replace it, not write into it.
fn refuse_non_regular(path: &Path) -> Result<(), String> {
    if path.exists() && !path.is_file() {
        return Err(format!(
            "{}: exists and is not a regular file",
            path.display()
        ));
    }
    Ok(())
}

/// True when `path` ends in `.png` (any case).
pub fn is_png(path: &Path) -> bool {
    extension(path).as_deref() == Some("png")
}

fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
}

/// Checks before a render that `path` can be written as
/// [`write_image`] will: a `.exr` or `.png` name in an existing directory
/// where a file can be created (tried with the temporary file, which is
/// removed again). The target itself is not touched.
pub fn check_output(path: &Path) -> Result<(), String> {
    if !matches!(extension(path).as_deref(), Some("exr" | "png")) {
        return Err(format!(
            "{}: output must end in .exr or .png",
            path.display()
        ));
    }
    check_writable(path)
}

/// Checks before a render that [`write_atomically`] can write `path`, of
/// any name: an existing directory where a file can be created (tried with
/// the temporary file, which is removed again). The target is not touched.
pub fn check_writable(path: &Path) -> Result<(), String> {
    refuse_non_regular(path)?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.exists() {
        return Err(format!(
            "{}: the directory {} does not exist",
            path.display(),
            dir.display()
        ));
    }
    if !dir.is_dir() {
        return Err(format!(
            "{}: {} is not a directory",
            path.display(),
            dir.display()
        ));
    }
    let tmp = temporary_path(path)?;
    std::fs::File::create(&tmp)
        .and_then(|_| std::fs::remove_file(&tmp))
        .map_err(|e| format!("{}: cannot write there: {e}", path.display()))
}

/// Writes `img` in the format the extension names (`.exr` or `.png`).
pub fn write_image(path: &Path, img: &Image) -> Result<(), String> {
    match extension(path).as_deref() {
        Some("exr") => write_exr(path, img),
        Some("png") => write_png(path, img),
        _ => Err(format!(
            "{}: output must end in .exr or .png",
            path.display()
        )),
    }
}

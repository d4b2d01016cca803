//! Image files: linear OpenEXR (exr crate) and sRGB PNG (image crate).

use std::path::Path;

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

/// Writes a linear float32 RGB OpenEXR file.
pub fn write_exr(path: &Path, img: &Image) -> Result<(), String> {
    exr::prelude::write_rgb_file(path, img.width, img.height, |x, y| {
        let p = img.pixels[y * img.width + x];
        (p.r, p.g, p.b)
    })
    .map_err(|e| format!("{}: cannot write OpenEXR: {e}", path.display()))
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

/// Writes an 8-bit sRGB PNG (values clipped to [0, 1] after encoding).
pub fn write_png(path: &Path, img: &Image) -> Result<(), String> {
    let mut buf = Vec::with_capacity(img.width * img.height * 3);
    for p in &img.pixels {
        for c in p.to_array() {
            let v = linear_to_srgb(c.max(0.0)).clamp(0.0, 1.0);
            buf.push((v * 255.0 + 0.5) as u8);
        }
    }
    image::save_buffer(
        path,
        &buf,
        img.width as u32,
        img.height as u32,
        image::ColorType::Rgb8,
    )
    .map_err(|e| format!("{}: cannot write PNG: {e}", path.display()))
}

/// Writes `img` in the format the extension names (`.exr` or `.png`).
pub fn write_image(path: &Path, img: &Image) -> Result<(), String> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .as_deref()
    {
        Some("exr") => write_exr(path, img),
        Some("png") => write_png(path, img),
        _ => Err(format!(
            "{}: output must end in .exr or .png",
            path.display()
        )),
    }
}

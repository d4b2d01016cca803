//! Error metrics against reference images.

use std::path::Path;

use crate::image_io::Image;

/// Mean over pixels and channels of `err(value, reference)`.
///
/// # Panics
/// When the image sizes differ.
fn mean_channel_error(img: &Image, reference: &Image, err: impl Fn(f64, f64) -> f64) -> f64 {
    assert_eq!(
        (img.width, img.height),
        (reference.width, reference.height),
        "image sizes differ"
    );
    let mut s = 0.0f64;
    for (a, r) in img.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            s += err(a[c] as f64, r[c] as f64);
        }
    }
    s / (img.pixels.len() * 3) as f64
}

/// Relative MSE as the shared scenes' README defines it: the mean over
/// pixels and channels of (a − r)² / (r² + 0.01).
pub fn rel_mse(img: &Image, reference: &Image) -> f64 {
    mean_channel_error(img, reference, |a, r| (a - r) * (a - r) / (r * r + 0.01))
}

/// Root-mean-square error over pixels and channels.
pub fn rmse(img: &Image, reference: &Image) -> f64 {
    mean_channel_error(img, reference, |a, r| (a - r) * (a - r)).sqrt()
}

/// Reads the reference OpenEXR at `path` for an image of `width × height`
/// pixels. A reference n times larger in both axes is box-filtered down:
/// the exact reference of the same scene at 1/n resolution (how `-D resx=…`
/// renders are compared with the full-size shared references).
pub fn load_reference(path: &Path, width: usize, height: usize) -> Result<Image, String> {
    let mut reference = crate::image_io::read_exr(path)?;
    if width > 0 && reference.width % width == 0 {
        let n = reference.width / width;
        if n > 1 && reference.height == height * n {
            reference = reference.downsample(n);
        }
    }
    if (reference.width, reference.height) != (width, height) {
        return Err(format!(
            "reference {} is {}x{}, image is {width}x{height}",
            path.display(),
            reference.width,
            reference.height,
        ));
    }
    Ok(reference)
}

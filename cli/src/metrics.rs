//! Error metrics against reference images.

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

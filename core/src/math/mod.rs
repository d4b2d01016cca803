//! Small math toolkit: colour, orthonormal frames, sample warps.
//!
//! Vectors are glam's `Vec3` (f32, with `libm` so the crate stays `no_std`).

#[cfg(feature = "alloc")]
pub mod distribution;
pub mod frame;
pub mod spectrum;
pub mod warp;

pub use frame::Frame;
pub use glam::{Affine2, Affine3A, Mat3, Mat4, Vec2, Vec3};
pub use spectrum::Rgb;

/// π as f32.
pub const PI: f32 = core::f32::consts::PI;
/// 1/π as f32.
pub const INV_PI: f32 = core::f32::consts::FRAC_1_PI;

/// `sqrt(max(x, 0))`: square roots of quantities that are non-negative in
/// exact arithmetic but may round to tiny negatives (e.g. 1 - cos²).
#[inline]
pub fn safe_sqrt(x: f32) -> f32 {
    libm::sqrtf(x.max(0.0))
}

/// Converts a density with respect to solid angle at `from` into one with
/// respect to area at a point `dist2` away whose surface cosine is `cos_to`
/// (Veach 1997, eq. 8.10: dω = |cos θ'| dA / d²).
#[inline]
pub fn solid_angle_to_area(pdf_solid_angle: f32, dist2: f32, cos_to: f32) -> f32 {
    pdf_solid_angle * cos_to.abs() / dist2
}

/// Balance-free power heuristic with β = 2 (Veach 1997, §9.2.4) for two
/// strategies with densities `a` (the one used) and `b`.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let a2 = a * a;
    let b2 = b * b;
    if a2 + b2 == 0.0 { 0.0 } else { a2 / (a2 + b2) }
}

//! Linear RGB radiometric quantities.
//!
//! The renderer works in linear sRGB primaries, as Mitsuba 3's `scalar_rgb`
//! variant does, so that our images and the references agree channel by
//! channel. `Rgb` is used for radiance, importance, throughput and
//! reflectance alike; the quantity is named by the variable, not the type.

use core::ops::{Add, AddAssign, Div, DivAssign, Index, Mul, MulAssign, Sub};

/// A linear RGB triple. NaN policy: constructors do not check; callers that
/// accept host data validate with [`Rgb::is_finite`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct Rgb {
    /// Red channel.
    pub r: f32,
    /// Green channel.
    pub g: f32,
    /// Blue channel.
    pub b: f32,
}

impl Rgb {
    /// All channels zero.
    pub const ZERO: Rgb = Rgb::splat(0.0);
    /// All channels one.
    pub const ONE: Rgb = Rgb::splat(1.0);

    /// A colour from its three channels.
    #[inline]
    pub const fn new(r: f32, g: f32, b: f32) -> Self {
        Rgb { r, g, b }
    }

    /// The same value in every channel.
    #[inline]
    pub const fn splat(v: f32) -> Self {
        Rgb { r: v, g: v, b: v }
    }

    /// Luminance Y of linear sRGB (Rec. 709 weights). This is the scalar
    /// target density p(x̄) of the Metropolis chains.
    #[inline]
    pub fn luminance(self) -> f32 {
        0.212_671 * self.r + 0.715_160 * self.g + 0.072_169 * self.b
    }

    /// Largest channel; used for Russian roulette like Mitsuba.
    #[inline]
    pub fn max_component(self) -> f32 {
        self.r.max(self.g).max(self.b)
    }

    /// Arithmetic mean of the channels.
    #[inline]
    pub fn average(self) -> f32 {
        (self.r + self.g + self.b) * (1.0 / 3.0)
    }

    /// True when every channel is exactly zero.
    #[inline]
    pub fn is_black(self) -> bool {
        self.r == 0.0 && self.g == 0.0 && self.b == 0.0
    }

    /// True when no channel is NaN or infinite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.r.is_finite() && self.g.is_finite() && self.b.is_finite()
    }

    /// Channel-wise map.
    #[inline]
    pub fn map(self, f: impl Fn(f32) -> f32) -> Self {
        Rgb::new(f(self.r), f(self.g), f(self.b))
    }

    /// Channel-wise combination of two colours.
    #[inline]
    pub fn zip(self, o: Rgb, f: impl Fn(f32, f32) -> f32) -> Self {
        Rgb::new(f(self.r, o.r), f(self.g, o.g), f(self.b, o.b))
    }

    /// The channels as an array.
    #[inline]
    pub const fn to_array(self) -> [f32; 3] {
        [self.r, self.g, self.b]
    }

    /// A colour from an array of channels.
    #[inline]
    pub const fn from_array(a: [f32; 3]) -> Self {
        Rgb::new(a[0], a[1], a[2])
    }
}

impl Index<usize> for Rgb {
    type Output = f32;
    #[inline]
    fn index(&self, i: usize) -> &f32 {
        match i {
            0 => &self.r,
            1 => &self.g,
            _ => &self.b,
        }
    }
}

impl Add for Rgb {
    type Output = Rgb;
    #[inline]
    fn add(self, o: Rgb) -> Rgb {
        Rgb::new(self.r + o.r, self.g + o.g, self.b + o.b)
    }
}
impl Sub for Rgb {
    type Output = Rgb;
    #[inline]
    fn sub(self, o: Rgb) -> Rgb {
        Rgb::new(self.r - o.r, self.g - o.g, self.b - o.b)
    }
}
impl AddAssign for Rgb {
    #[inline]
    fn add_assign(&mut self, o: Rgb) {
        *self = *self + o;
    }
}
impl Mul for Rgb {
    type Output = Rgb;
    #[inline]
    fn mul(self, o: Rgb) -> Rgb {
        Rgb::new(self.r * o.r, self.g * o.g, self.b * o.b)
    }
}
impl MulAssign for Rgb {
    #[inline]
    fn mul_assign(&mut self, o: Rgb) {
        *self = *self * o;
    }
}
impl Mul<f32> for Rgb {
    type Output = Rgb;
    #[inline]
    fn mul(self, s: f32) -> Rgb {
        Rgb::new(self.r * s, self.g * s, self.b * s)
    }
}
impl Mul<Rgb> for f32 {
    type Output = Rgb;
    #[inline]
    fn mul(self, c: Rgb) -> Rgb {
        c * self
    }
}
impl MulAssign<f32> for Rgb {
    #[inline]
    fn mul_assign(&mut self, s: f32) {
        *self = *self * s;
    }
}
impl Div<f32> for Rgb {
    type Output = Rgb;
    #[inline]
    fn div(self, s: f32) -> Rgb {
        let inv = 1.0 / s;
        self * inv
    }
}
impl DivAssign<f32> for Rgb {
    #[inline]
    fn div_assign(&mut self, s: f32) {
        *self = *self / s;
    }
}
impl Div for Rgb {
    type Output = Rgb;
    #[inline]
    fn div(self, o: Rgb) -> Rgb {
        Rgb::new(self.r / o.r, self.g / o.g, self.b / o.b)
    }
}

/// Decode one 8-bit-per-channel sRGB value (0..=1) to linear, the IEC 61966-2-1
/// transfer function, as Mitsuba does for 8-bit bitmaps.
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        libm::powf((v + 0.055) / 1.055, 2.4)
    }
}

/// Encode one linear value to sRGB (0..=1), the inverse of [`srgb_to_linear`].
#[inline]
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * libm::powf(v, 1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trip() {
        for i in 0..=255 {
            let v = i as f32 / 255.0;
            assert!((linear_to_srgb(srgb_to_linear(v)) - v).abs() < 1e-5);
        }
    }

    #[test]
    fn luminance_of_white_is_one() {
        assert!((Rgb::ONE.luminance() - 1.0).abs() < 1e-5);
    }
}

//! The pixel formats a resolve writes ([`PixelFormat`]) and how one pixel
//! is written in each.

use super::half::f16_bits;
use super::srgb::linear_to_srgb8;
use crate::math::Rgb;

/// How a resolve writes a pixel into the host's bytes. Floats are written
/// in the machine's byte order, with no alignment asked of the buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PixelFormat {
    /// Linear RGB, three `f32` (12 bytes).
    Rgb32F,
    /// Linear RGBA, four `f32`, alpha 1 (16 bytes).
    Rgba32F,
    /// Linear RGBA, four IEEE binary16 rounded to nearest even
    /// ([`super::half::f16_bits`]), alpha 1 (8 bytes): a GPU's
    /// `R16G16B16A16_FLOAT`. Values past 65504 become +∞.
    Rgba16F,
    /// sRGB-encoded RGBA, four `u8`, alpha 255 (4 bytes): each channel
    /// clamped to [0, 1], encoded with the sRGB curve and rounded
    /// ([`super::srgb::linear_to_srgb8`]).
    Rgba8Srgb,
}

impl PixelFormat {
    /// Bytes of one pixel.
    pub const fn bytes(self) -> usize {
        match self {
            PixelFormat::Rgb32F => 12,
            PixelFormat::Rgba32F => 16,
            PixelFormat::Rgba16F => 8,
            PixelFormat::Rgba8Srgb => 4,
        }
    }

    /// Writes `c` as one pixel of this format into `out[..self.bytes()]`.
    ///
    /// # Panics
    /// When `out` is shorter than a pixel.
    #[inline(always)]
    pub fn write(self, c: Rgb, out: &mut [u8]) {
        match self {
            PixelFormat::Rgb32F => {
                out[0..4].copy_from_slice(&c.r.to_ne_bytes());
                out[4..8].copy_from_slice(&c.g.to_ne_bytes());
                out[8..12].copy_from_slice(&c.b.to_ne_bytes());
            }
            PixelFormat::Rgba32F => {
                out[0..4].copy_from_slice(&c.r.to_ne_bytes());
                out[4..8].copy_from_slice(&c.g.to_ne_bytes());
                out[8..12].copy_from_slice(&c.b.to_ne_bytes());
                out[12..16].copy_from_slice(&1.0f32.to_ne_bytes());
            }
            PixelFormat::Rgba16F => {
                out[0..2].copy_from_slice(&f16_bits(c.r).to_ne_bytes());
                out[2..4].copy_from_slice(&f16_bits(c.g).to_ne_bytes());
                out[4..6].copy_from_slice(&f16_bits(c.b).to_ne_bytes());
                // 1.0 in binary16.
                out[6..8].copy_from_slice(&0x3c00u16.to_ne_bytes());
            }
            PixelFormat::Rgba8Srgb => {
                out[..4].copy_from_slice(&[
                    linear_to_srgb8(c.r),
                    linear_to_srgb8(c.g),
                    linear_to_srgb8(c.b),
                    255,
                ]);
            }
        }
    }
}

//! Deterministic random streams.
//!
//! Every sample of every pixel and pass gets its own PCG32 stream derived
//! from (seed, pass, pixel), so images do not depend on which thread
//! rendered what, and a single sample can be replayed in isolation.

use glam::Vec2;
use rand_core::Rng;
use rand_pcg::Pcg32;

/// A random stream for one sample path.
#[derive(Clone, Debug)]
pub struct SampleStream {
    rng: Pcg32,
}

/// SplitMix64 finaliser: decorrelates nearby integers into seeds.
#[inline]
pub const fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl SampleStream {
    /// The stream of sample `index` in `pass` for a render seeded by `seed`.
    pub fn new(seed: u64, pass: u64, index: u64) -> Self {
        let state = mix64(seed ^ mix64(pass.wrapping_mul(0x1000_0000_01B3)));
        let stream = mix64(index ^ state.rotate_left(17));
        SampleStream {
            rng: Pcg32::new(state ^ index, stream),
        }
    }

    /// A uniform float in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        // 24 random mantissa bits: every value is exactly representable and
        // strictly below 1.
        (self.rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniform floats in [0, 1)².
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_f32();
        Vec2::new(x, self.next_f32())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: [f32; 4] = core::array::from_fn({
            let mut s = SampleStream::new(1, 2, 3);
            move |_| s.next_f32()
        });
        let b: [f32; 4] = core::array::from_fn({
            let mut s = SampleStream::new(1, 2, 3);
            move |_| s.next_f32()
        });
        let c: [f32; 4] = core::array::from_fn({
            let mut s = SampleStream::new(1, 2, 4);
            move |_| s.next_f32()
        });
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert!(a.iter().all(|&x| (0.0..1.0).contains(&x)));
    }
}

//! Deterministic random streams and the [`Sampler`] seam the estimators
//! draw their random numbers through.
//!
//! Every sample of every pixel and pass gets its own PCG32 stream derived
//! from (seed, pass, pixel), so images do not depend on which thread
//! rendered what, and a single sample can be replayed in isolation.
//!
//! Metropolis light transport replaces that stream by a point of *primary
//! sample space* that a Markov chain mutates (Kelemen et al. 2002; the
//! sampler is `crate::mlt::PrimarySampler`). The estimators do not know the
//! difference: they are generic over [`Sampler`].

use glam::Vec2;
use rand_core::Rng;
use rand_pcg::Pcg32;

/// Where an estimator gets its uniform random numbers.
///
/// A sampler hands out an infinite sequence of numbers in [0, 1), split into
/// numbered *streams*: [`Sampler::start_stream`] switches to the start of
/// stream `index`, and the following calls draw that stream's dimensions in
/// order. Bidirectional estimators draw the camera subpath, the light
/// subpath and the connection from three streams ([`CAMERA_STREAM`],
/// [`LIGHT_STREAM`], [`CONNECTION_STREAM`]) so that, in primary sample
/// space, the camera subpath keeps its coordinates when the light subpath
/// changes length (pbrt-v4's `MLTSampler`, §13.4.4 of pbrt-v3). Samplers that
/// are plain random streams ([`SampleStream`]) may ignore streams: their
/// numbers are independent either way.
///
/// Contract: every value is in [0, 1) (never 1.0, so `(u * n) as usize < n`),
/// and the numbers depend only on the sampler's state and the call sequence
/// (no global state), which keeps renders deterministic.
pub trait Sampler {
    /// The next uniform number of the current stream, in [0, 1).
    fn next_f32(&mut self) -> f32;

    /// The next two numbers of the current stream, in this order (x first).
    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        let x = self.next_f32();
        Vec2::new(x, self.next_f32())
    }

    /// Restarts drawing at dimension 0 of stream `index` (< [`STREAM_COUNT`]
    /// for samplers that keep streams apart).
    fn start_stream(&mut self, index: u32);
}

/// Stream of the camera subpath (raster position, lens, camera bounces).
pub const CAMERA_STREAM: u32 = 0;
/// Stream of the light subpath (light choice, position, direction, bounces).
pub const LIGHT_STREAM: u32 = 1;
/// Stream of the connection step (lens or light sample of t = 1 / s = 1).
pub const CONNECTION_STREAM: u32 = 2;
/// Number of streams the estimators use.
pub const STREAM_COUNT: u32 = 3;

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

impl Sampler for SampleStream {
    #[inline]
    fn next_f32(&mut self) -> f32 {
        SampleStream::next_f32(self)
    }

    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        SampleStream::next_2d(self)
    }

    /// Streams are ignored: a PCG stream's numbers are independent whatever
    /// the estimator uses them for, and ignoring the call keeps the existing
    /// images bit-identical.
    #[inline]
    fn start_stream(&mut self, _index: u32) {}
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

//! What PT and BDPT carry from one frame into the next: their films,
//! kept, decayed or cleared ([`Accumulation`]), and the per-pixel sample
//! weights that normalise them ([`Weights`]).
//!
//! A worker renders its passes in pieces (a few pixels each, so that a
//! time budget can stop it within about a millisecond), so a frame may end
//! inside a pass: the pixels the open pass reached have one sample more
//! than the others. Each worker therefore counts its samples per pixel, and
//! the image is, per pixel,
//!
//! ```text
//!   Σ_w samples_w(i) / Σ_w weight_w(i)  +  Σ_w splats_w(i) / (Σ_w n_w / P)
//! ```
//!
//! with n_w the worker's samples over the whole image (its light subpaths,
//! whose t = 1 splats land anywhere: each is one sample of a whole-image
//! estimate) and P the pixel count. After whole passes both denominators
//! are the pass count, and the image is (samples + splats) / passes as
//! before, bit for bit. Decay multiplies sums and weights by the same
//! factor at every frame start: an exponentially weighted mean of the
//! samples, each frame's weighted `factor^age`.

use alloc::vec::Vec;

use crate::film::Film;

/// How a PT or BDPT worker's accumulation carries into the next frame
/// ([`super::Renderer::set_accumulation`]); Metropolis estimators always
/// reset (their chains carry over instead: [`super::Temporal`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Accumulation {
    /// Every frame starts black: an unbiased image of its own camera and
    /// scene (the default).
    #[default]
    Reset,
    /// Frames add to the earlier ones: converges for a still camera and
    /// scene, smears (biased towards older views) when they move.
    Keep,
    /// Earlier frames' samples weigh `factor` per frame of age (0 <
    /// factor < 1): an exponential moving average, with roughly
    /// 1 / (1 − factor) frames of memory.
    Decay(f32),
}

impl Accumulation {
    /// Checks the decay factor: in (0, 1).
    pub fn validate(&self) -> Result<(), &'static str> {
        match *self {
            Accumulation::Decay(f) if !(f > 0.0 && f < 1.0) => {
                Err("the decay factor must be in (0, 1)")
            }
            _ => Ok(()),
        }
    }
}

/// A worker's sample weight per pixel and over the whole image (see the
/// module docs), sized when the worker is made.
pub(crate) struct Weights {
    per_pixel: Vec<f32>,
    /// Σ of the per-pixel weights: the (decayed) count of samples, whose
    /// light subpaths splat anywhere.
    total: f64,
}

impl Weights {
    /// Zero weights for `pixels` pixels (none for a Metropolis worker,
    /// which normalises by b).
    pub(crate) fn new(pixels: usize) -> Self {
        Weights {
            per_pixel: alloc::vec![0.0; pixels],
            total: 0.0,
        }
    }

    /// Counts one sample in pixel `i`.
    #[inline]
    pub(crate) fn add(&mut self, i: usize) {
        self.per_pixel[i] += 1.0;
        self.total += 1.0;
    }

    /// Pixel `i`'s weight (0 for a worker without weights).
    #[inline]
    pub(crate) fn at(&self, i: usize) -> f64 {
        self.per_pixel.get(i).map_or(0.0, |&w| w as f64)
    }

    /// The weight of the whole image's samples.
    pub(crate) fn total(&self) -> f64 {
        self.total
    }

    /// Starts a frame: `film` and the weights cleared, kept or decayed.
    pub(crate) fn next_frame(&mut self, film: &mut Film, mode: Accumulation) {
        match mode {
            Accumulation::Reset => {
                film.clear();
                self.per_pixel.fill(0.0);
                self.total = 0.0;
            }
            Accumulation::Keep => {}
            Accumulation::Decay(f) => {
                film.scale(f as f64);
                for w in &mut self.per_pixel {
                    *w *= f;
                }
                self.total *= f as f64;
            }
        }
    }
}

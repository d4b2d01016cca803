//! What a worker carries from one frame into the next, kept, decayed or
//! cleared ([`Accumulation`]): for PT and BDPT its film and the per-pixel
//! sample weights that normalise it ([`Weights`]); for MLT and CMLT the
//! earlier frames' images, each normalised by its own b ([`Kept`]).
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
//! before, bit for bit. A sample of a coarser pass (`pixel_block.rs`)
//! counts 1 / m in each of the m pixels of its block (its value spread
//! the same way; its splats count in n_w, once), so n_w stays the sum of
//! the per-pixel weights; a guard pass's samples (and their splats) count
//! 10⁻³ each. Decay multiplies sums and weights by the same
//! factor at every frame start: an exponentially weighted mean of the
//! samples, each frame's weighted `factor^age`.
//!
//! A Metropolis frame's film is normalised by that frame's b and records
//! (b · P / records, `mlt::image_scale`), and b may change from frame to
//! frame, so its film cannot simply be kept: at a frame's start each
//! worker folds the ended frame into [`Kept`] as `b_f · P · film_f` (its
//! image times its records) and adds its records to the kept weight.
//! The merged image is then, per pixel,
//!
//! ```text
//!   (Σ_w kept_w(i) + b · P · Σ_w film_w(i)) / (Σ_w kept records_w + Σ_w records_w)
//! ```
//!
//! the records-weighted mean of the frames' images. Each frame's image is
//! its own estimate of the image (its b, its chains' splats; the records
//! of a frame depend on the clock, not on the image), so the mean
//! estimates the same image with the error of all the frames together, and
//! with a still camera and one b it is the image of one long render of
//! all the frames' mutations. Decay multiplies the kept sums and records
//! by the factor at every frame start, as for PT and BDPT.
//!
//! With kept chains a frame's normalisation-pass image (`mlt/pass_image.rs`)
//! goes straight into the kept sums as `ρ(1 + s) · P · Σ contributions`,
//! its records counted in the frame's: the term `b · P · film` its share
//! of a film would fold in, without b, so its weight does not move when a
//! b refresh is joined within the frame.

use alloc::vec::Vec;
use core::ops::Range;

use crate::film::Film;

/// How a worker's accumulation carries into the next frame
/// ([`super::Renderer::set_accumulation`]): PT and BDPT keep or decay their
/// samples, MLT and CMLT their frames' images, each normalised by its own
/// b (their chains carry over apart from this: [`super::Temporal`]).
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

    /// Counts one sample of weight `weight` spread over the pixels `xs ×
    /// ys` of an image `width` wide, `w` (weight / m) to each of the m
    /// pixels: a sample of a coarser pass (`renderer/pixel_block.rs`).
    pub(crate) fn add_area(
        &mut self,
        xs: Range<u32>,
        ys: Range<u32>,
        width: u32,
        w: f32,
        weight: f32,
    ) {
        for y in ys {
            let row = y as usize * width as usize;
            for p in &mut self.per_pixel[row + xs.start as usize..row + xs.end as usize] {
                *p += w;
            }
        }
        self.total += weight as f64;
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

/// A Metropolis worker's earlier frames (see the module docs): per pixel
/// Σ_f factor^age · b_f · P · film_f(i), and Σ_f factor^age · records_f,
/// sized when the worker is made (empty for PT and BDPT workers, which
/// keep their films instead). With kept chains the current frame's
/// normalisation-pass image is added here too ([`Kept::add_pass_image`]).
pub(crate) struct Kept {
    sums: Vec<[f64; 3]>,
    records: f64,
    /// Whether `sums` may be nonzero.
    holds: bool,
}

impl Kept {
    /// Nothing kept, room for `pixels` pixels.
    pub(crate) fn new(pixels: usize) -> Self {
        Kept {
            sums: alloc::vec![[0.0; 3]; pixels],
            records: 0.0,
            holds: false,
        }
    }

    /// Whether nothing is kept: the image is the current frame's film
    /// alone.
    pub(crate) fn is_empty(&self) -> bool {
        !self.holds && self.records == 0.0
    }

    /// Pixel `i`'s kept sum (0 for a worker without kept frames).
    #[inline]
    pub(crate) fn at(&self, i: usize) -> [f64; 3] {
        self.sums.get(i).copied().unwrap_or([0.0; 3])
    }

    /// The kept frames' records (their weight).
    pub(crate) fn records(&self) -> f64 {
        self.records
    }

    /// Starts a frame: the ended frame (`film`, whose `records` records are
    /// normalised by `b_pixels` = b · P) folded in, then everything kept
    /// cleared, kept or decayed by `mode`. The film itself is left alone
    /// (the caller clears it for the new frame).
    pub(crate) fn next_frame(
        &mut self,
        film: &Film,
        b_pixels: f64,
        records: u64,
        mode: Accumulation,
    ) {
        let factor = match mode {
            Accumulation::Reset => {
                if self.holds {
                    self.sums.fill([0.0; 3]);
                    self.holds = false;
                }
                self.records = 0.0;
                return;
            }
            Accumulation::Keep => 1.0,
            Accumulation::Decay(f) => f as f64,
        };
        // A frame that recorded nothing (or had no b) adds nothing.
        let add = records > 0 && b_pixels > 0.0;
        if add {
            for (i, k) in self.sums.iter_mut().enumerate() {
                let t = film.pixel_total(i);
                for c in 0..3 {
                    k[c] = (k[c] + t[c] * b_pixels) * factor;
                }
            }
            self.records += records as f64;
            self.holds = true;
        } else if factor != 1.0 {
            for k in &mut self.sums {
                for v in k {
                    *v *= factor;
                }
            }
        }
        self.records *= factor;
    }

    /// Adds the current frame's normalisation-pass image `image` (its
    /// samples' contributions, unscaled: `samples` samples over the whole
    /// image), whose `records` records the frame's chains count
    /// (`WorkerChains::count_pass_records`): as `records · P / samples ·
    /// image(i)`, the term `b · P · film(i)` a film holding the image
    /// scaled by records / (samples · b) would fold in
    /// (`mlt/pass_image.rs`) — without b, so that the weight stays exact
    /// when b changes while chains are kept. It then ages with the frame
    /// whose records hold its weight.
    pub(crate) fn add_pass_image(&mut self, image: &Film, samples: u64, records: u64, pixels: u64) {
        if samples == 0 || records == 0 {
            return;
        }
        let scale = records as f64 * pixels as f64 / samples as f64;
        for (i, k) in self.sums.iter_mut().enumerate() {
            let t = image.pixel_total(i);
            for c in 0..3 {
                k[c] += t[c] * scale;
            }
        }
        self.holds = true;
    }
}

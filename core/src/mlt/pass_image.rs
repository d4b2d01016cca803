//! The normalisation passes' image added to the chains' image
//! ([`super::MltSettings::pass_records`]).
//!
//! The normalisation passes (`bootstrap::evaluate_pass`) are full BDPT
//! passes, one sample per pixel with every strategy MIS-weighted (depth 1
//! from a stratified 2×2 grid of camera rays); besides b they give an
//! unbiased image Î_p = (1/n_p) Σ_passes of the pixel's contributions. The
//! chains give Î_c = b̂ · P · h / R_c (h the splatted records, R_c their
//! count, P the pixels). Any w · Î_p + (1 − w) · Î_c with a weight w fixed
//! before either is drawn has the expectation of the two (Î_c's b̂ comes
//! from the same passes whether or not Î_p is added).
//!
//! The weight is a fixed number of level-1 mutations' records per pass
//! sample, ρ (ρ·(1 + s) records with CMLT's level-2 share s, so that CMLT
//! without side chains stays MLT): worker by worker the pass image enters
//! the film times ρ(1 + s) / b̂ and its n_p·P samples add ρ(1 + s)·n_p·P
//! records, so the resolve (b̂ · P / R with R = R_c + ρ(1 + s)·n_p·P,
//! `super::image_scale`) gives w = ρ(1 + s)·n_p·P / R. With ρ the cost of
//! a pass sample in mutations, each estimator weighs its share of the
//! work: the inverse-variance weights when both are equally efficient per
//! unit of work (on Tungsten's Cornell box our BDPT is about twice as
//! efficient as our MLT, so ρ = the cost errs on the chains' side). Weights per pixel from the pixel's own samples (inverse
//! sample variances) would follow the noise: a pixel whose samples came
//! out low also looks less noisy and gets more weight — a bias. Global
//! fixed weights are what the references do with independent samples:
//! Kelemen et al. 2002 (§4.1) weigh the large steps against the chain by
//! their densities (`chain.rs`); pbrt-v4 discards its bootstrap, and
//! Mitsuba 0.6's MLT and PSSMLT discard their `luminanceSamples` and add a
//! separately rendered direct illumination (`directSamples`, a split by
//! path class rather than a weighting).

use super::WorkerChains;
use crate::film::Film;

/// The records `samples` pass samples add at `pass_records` records each,
/// rounded to a whole record (an image's samples are many: the rounding
/// moves the weight by less than 1/samples).
pub(crate) fn records_for(pass_records: f32, samples: u64) -> u64 {
    libm::round(f64::from(pass_records) * samples as f64) as u64
}

impl WorkerChains {
    /// Adds the pass image `image` (the contributions of this worker's
    /// `samples` normalisation-pass samples, unscaled) into `film`, whose
    /// records are normalised by `b`, at `pass_records` mutations' records
    /// per sample (times 1 + s with level 2): scales `image` by records /
    /// (samples · b) in place and counts the records
    /// ([`WorkerChains::count_pass_records`]).
    /// Nothing when there is nothing to weigh (b = 0, no sample, ρ = 0).
    /// Allocates nothing.
    pub(crate) fn add_pass_image(
        &mut self,
        film: &mut Film,
        image: &mut Film,
        samples: u64,
        pass_records: f32,
        b: f64,
    ) {
        if !(b > 0.0) || samples == 0 {
            return;
        }
        let records = self.count_pass_records(samples, pass_records);
        if records == 0 {
            return;
        }
        image.scale(records as f64 / (samples as f64 * b));
        film.merge(image);
    }

    /// Counts the records of `samples` pass samples at `pass_records`
    /// mutations' records each (times 1 + s with level 2) in
    /// [`super::MltStats::records`] and `pass_records`, and returns them:
    /// the weight of a pass image that the caller adds itself (the
    /// renderer's kept frames, whose sums need no b).
    pub(crate) fn count_pass_records(&mut self, samples: u64, pass_records: f32) -> u64 {
        let per_mutation = 1 + self.level2.as_ref().map_or(0, |l2| l2.share());
        let records = records_for(pass_records * per_mutation as f32, samples);
        self.stats.records += records;
        self.stats.pass_records += records;
        records
    }
}

//! Metropolis light transport. Level 1: Kelemen-style primary-sample-space
//! MLT (PSSMLT) over bidirectional path tracing with MIS, as pbrt-v4's
//! `MLTIntegrator` does it. Level 2 (CMLT, Segovia 2007): side chains of
//! perturbations from each level-1 state.
//!
//! The public surface is what a host configures and reads: the settings
//! ([`MltSettings`] for level 1, [`Level2Settings`] for CMLT's level 2,
//! [`CmltSettings`] for both; with [`Candidates`] and [`Splatting`]),
//! [`MltStats`], [`Bootstrap`], [`LargeStepTally`] and the functions below. The parts, private
//! to the crate (the renderer drives a worker's chains, `WorkerChains`):
//!
//! - `primary`: the primary-sample vector X, its lazy large/small-step
//!   mutations and three interleaved streams;
//! - `chain`: one level-1 Markov chain (Metropolis–Hastings) with
//!   expected-value splatting;
//! - `target`: the target a chain of depth d samples, Y(f_d(u));
//! - `bootstrap`: the normalisation b and the chains' starting points;
//! - `large_steps`: b by depth from the large steps of a render
//!   ([`LargeStepTally`]);
//! - `pass_image`: the normalisation passes' image added to the chains'
//!   by fixed weights ([`MltSettings::pass_records`]);
//! - `level2`: the side chain run from a level-1 state, by its class;
//! - `multiple_try` and `lanes`: the two ways a side chain steps (k
//!   candidates per step, or n parallel one-proposal lanes);
//! - `path_space`: the path-space level 1 ([`Level1::PathSpace`]: Veach's
//!   path states, start-up, bidirectional and lens subpath mutations, its
//!   chains);
//! - `perturbation`: which perturbation applies to a path and the
//!   specular-chain retracing they share; `perturbation::{lens, caustic,
//!   multi_chain}`: the three perturbations;
//! - this module: a worker running many chains into a film.
//!
//! ## Units and invariants
//!
//! The target of a chain of depth d is Y(f_d(u)), the luminance of
//! [`crate::integrator::bdpt::sample_strategy`]'s contribution (one
//! strategy, times the strategy count). Over all depths, E_u[f(u)·1{raster ∈
//! pixel}] = I_pixel / P, P = width·height, and b = Σ_d E[Y(f_d)] is the
//! image's mean luminance.
//!
//! Each mutation adds records of total luminance 1 (colour f/Y weighted
//! a and 1 − a) to the film's splat layer; with
//! [`MltSettings::large_step_mis`], records whose luminance is 1 in
//! expectation instead (`chain`'s module docs). Chains are spread over depths in
//! proportion to b_d / b and each chain of a worker makes the same number
//! of mutations, so after N mutations over all workers, splat·(b·P/N)
//! estimates the image: [`image_scale`] is that factor, for
//! [`Film::resolve_scaled`]. This is the same as recording
//! f/Y·b/(N/P), i.e. b / mutations-per-pixel per record, but keeps the
//! histogram independent of b and of N, so films of workers with different
//! mutation counts (time budgets) merge by plain addition and b can be
//! combined or smoothed afterwards.
//!
//! Determinism: everything is a function of the seed, the worker index,
//! the number of workers and the number of rounds; chains are stepped in a
//! fixed order. A scene where nothing contributes (b = 0) starts no chain
//! and resolves to exact black.

pub(crate) mod bootstrap;
mod chain;
mod lanes;
mod large_steps;
mod level2;
mod multiple_try;
mod pass_image;
mod path_space;
mod perturbation;
mod primary;
mod target;

#[cfg(all(test, feature = "std"))]
pub(crate) mod tests;

pub use bootstrap::Bootstrap;
pub use large_steps::LargeStepTally;
pub use multiple_try::{Candidates, Splatting};
pub(crate) use primary::PrimarySampler;

use chain::{Chain, Splat, Step};
use level2::Level2;
use path_space::worker::PathChains;
use perturbation::Applicable;

use alloc::vec::Vec;

use rand_core::Rng;
use rand_pcg::Pcg32;

use crate::accel::Intersector;
use crate::film::Film;
use crate::integrator::bdpt::PathVertex;
use crate::integrator::{Settings, Tracer, bdpt};
use crate::sampler::{SampleStream, mix64};
use crate::scene::Camera;

/// Parameters of level-1 MLT, read by [`crate::renderer::Estimator::Mlt`]
/// and, as CMLT's level 1, by [`crate::renderer::Estimator::Cmlt`].
/// Defaults are pbrt-v4's where it has one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MltSettings {
    /// The space level 1's chains mutate in.
    pub level1: Level1,
    /// Bootstrap samples per path depth (pbrt: `bootstrapsamples`, 100 000):
    /// the points chains start from, and pbrt's estimate of b when
    /// `b_passes` is 0.
    pub n_bootstrap: u32,
    /// BDPT passes (one sample per pixel, all strategies with MIS) that
    /// estimate b by depth; 0 = estimate b from the bootstrap samples as pbrt
    /// does (much noisier: see `mlt/bootstrap.rs`).
    pub b_passes: u32,
    /// Least number of normalisation samples (passes × pixels): a small
    /// image gets more than `b_passes` passes, up to
    /// [`MAX_FLOOR_PASSES`], so that b's error does not grow as the image
    /// shrinks ([`MltSettings::normalisation_passes`]); 0 = exactly
    /// `b_passes`. Ignored when `b_passes` is 0. At most
    /// [`MAX_B_MIN_SAMPLES`].
    pub b_min_samples: u32,
    /// Independent chains per worker (pbrt: 1000 in total).
    pub n_chains: u32,
    /// Probability of a large step (pbrt: 0.3; Tungsten's multiplexed
    /// MLT: 0.1).
    pub large_step_prob: f32,
    /// Small-step width σ in primary sample space (pbrt: 0.01).
    pub sigma: f32,
    /// The least factor on the chains of paths of one segment (emitters
    /// seen directly) against their share of b, in (0, 1]. Depth 1 gets
    /// chains for the image area that sees an emitter rather than for its
    /// luminance, but no fewer than this factor times its b-proportional
    /// share (`mlt/bootstrap.rs`); 1 = chains in proportion to b_d at
    /// every depth (pbrt, Tungsten). The image's expectation is the same
    /// either way (each depth's chains are weighted to give its b_d).
    pub direct_allocation: f32,
    /// Whether the large steps' proposals are also recorded as independent
    /// samples, combined with the chain's records by MIS (Kelemen et al.
    /// 2002, §4.1: weights (a + 1{large})/(Y/b_d + p) and (1 − a)/(Y/b_d +
    /// p), b_d the chain's depth's normalisation; `mlt/chain.rs`). Same
    /// expectation; pixels the chains seldom visit get the large steps'
    /// BDPT samples. false = the records a and 1 − a only. On by default:
    /// 1.00–1.15× less relMSE per mutation on all twelve test scenes at
    /// the same cost per mutation (`docs/accuracy.md`, "Level 1 against
    /// Tungsten's MMLT").
    pub large_step_mis: bool,
    /// The weight of each normalisation-pass sample's contribution to the
    /// image, in level-1 mutations (their records, [`MltStats::records`]:
    /// 1 + s each with CMLT's level-2 share s): the passes' BDPT image is
    /// combined with the chains' by these fixed weights
    /// (`mlt/pass_image.rs`); 0 = the passes only estimate b. With kept
    /// chains ([`crate::renderer::Temporal::keep_chains`], whose bootstrap
    /// may span several views) a bootstrap's passes join only a frame of
    /// the camera and scene it ran under. Ignored without passes. At most
    /// [`MAX_PASS_RECORDS`]; default [`DEFAULT_PASS_RECORDS`].
    pub pass_records: f32,
    /// The path-space level 1's mutations: how often each is chosen and
    /// how far the perturbations move. Ignored by the primary-sample level
    /// 1.
    pub path_mutations: PathMutations,
}

/// The path-space level 1's mutation selection (Veach 1997, §11.4; read
/// only with [`Level1::PathSpace`]). At a path x̄ each mutation that
/// applies to it is chosen with probability its weight over the sum of the
/// weights of those that apply: the bidirectional mutation applies to
/// every path, the lens subpath mutation to paths E S* D (D | L), and of
/// the three perturbations the one the path's pattern of specular
/// vertices admits (`mlt/perturbation/mod.rs`). The acceptance ratio has
/// the chosen mutation's probabilities at both paths
/// (`mlt/path_space/chain.rs`), so any weights keep the chain unbiased; 0
/// turns a mutation off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathMutations {
    /// Weight of the bidirectional mutation (> 0: it is the one mutation
    /// that reaches every path).
    pub bidirectional: f32,
    /// Weight of the lens subpath mutation.
    pub lens_subpath: f32,
    /// Weight of the lens perturbation.
    pub lens: f32,
    /// Weight of the caustic perturbation.
    pub caustic: f32,
    /// Weight of the multi-chain perturbation.
    pub multi_chain: f32,
    /// Standard deviation of the perturbations' image-plane offset, in
    /// pixels (the lens and multi-chain perturbations).
    pub sigma: f32,
    /// The caustic and multi-chain perturbations' angular σ is `sigma`
    /// pixel angles times this factor.
    pub caustic_scale: f32,
}

impl Default for PathMutations {
    /// Every mutation weight 1; offsets of σ = 2 pixels, angles of σ = 2
    /// pixel angles.
    fn default() -> Self {
        PathMutations {
            bidirectional: 1.0,
            lens_subpath: 1.0,
            lens: 1.0,
            caustic: 1.0,
            multi_chain: 1.0,
            sigma: 2.0,
            caustic_scale: 1.0,
        }
    }
}

impl PathMutations {
    /// The settings of the five mutation weights in the order
    /// bidirectional, lens subpath, lens, caustic, multi-chain (the order
    /// of the CLI's `--path-mutations` and the C config's
    /// `path_mutations`), the perturbations' σ in pixels and their caustic
    /// scale; unchecked ([`PathMutations::validate`]).
    pub fn new(weights: [f32; 5], sigma: f32, caustic_scale: f32) -> Self {
        let [bidirectional, lens_subpath, lens, caustic, multi_chain] = weights;
        PathMutations {
            bidirectional,
            lens_subpath,
            lens,
            caustic,
            multi_chain,
            sigma,
            caustic_scale,
        }
    }

    /// The five mutation weights in [`PathMutations::new`]'s order.
    pub fn weights(&self) -> [f32; 5] {
        [
            self.bidirectional,
            self.lens_subpath,
            self.lens,
            self.caustic,
            self.multi_chain,
        ]
    }

    /// Checks the weights and offsets.
    pub fn validate(&self) -> Result<(), &'static str> {
        if !(self.bidirectional > 0.0 && self.bidirectional.is_finite()) {
            return Err("the bidirectional mutation's weight must be positive and finite");
        }
        let others = [self.lens_subpath, self.lens, self.caustic, self.multi_chain];
        if !others.iter().all(|w| *w >= 0.0 && w.is_finite()) {
            return Err("mutation weights must be non-negative and finite");
        }
        if !(self.sigma > 0.0 && self.sigma.is_finite()) {
            return Err("the perturbations' σ must be a positive number of pixels");
        }
        if !(self.caustic_scale > 0.0 && self.caustic_scale.is_finite()) {
            return Err("the perturbations' caustic scale must be positive and finite");
        }
        Ok(())
    }
}

/// The space the level-1 chains mutate in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub enum Level1 {
    /// Kelemen et al.'s primary sample space: a chain mutates the random
    /// numbers X that `target::evaluate` turns into a BDPT strategy's
    /// path (`mlt/primary.rs`).
    #[default]
    PrimarySample,
    /// Veach's path space: a chain's state is a path's vertices, mutated
    /// by the bidirectional and lens subpath mutations and the lens,
    /// caustic and multi-chain perturbations, chosen by
    /// [`MltSettings::path_mutations`] (`mlt/path_space/`); CMLT's level 2
    /// runs from its states as from primary-sample ones. Its paths end
    /// on every kind of emitter: area, point, spot, directional and
    /// environment lights.
    PathSpace,
}

impl Default for MltSettings {
    /// Primary-sample level 1, 2 000 bootstrap samples per depth, 2
    /// normalisation passes and at least 65 536 normalisation samples, 256
    /// chains per worker, large steps 0.3 combined with the chains by MIS,
    /// σ = 0.01, at least a tenth of the b-proportional chains for
    /// emitters seen directly, the passes' image added at 5 mutations per
    /// pass sample; the path-space mutations of [`PathMutations::default`].
    fn default() -> Self {
        MltSettings {
            level1: Level1::PrimarySample,
            n_bootstrap: 2_000,
            b_passes: 2,
            b_min_samples: DEFAULT_B_MIN_SAMPLES,
            n_chains: 256,
            large_step_prob: primary::DEFAULT_LARGE_STEP_PROB,
            sigma: primary::DEFAULT_SIGMA,
            direct_allocation: DEFAULT_DIRECT_ALLOCATION,
            large_step_mis: true,
            pass_records: DEFAULT_PASS_RECORDS,
            path_mutations: PathMutations::default(),
        }
    }
}

impl MltSettings {
    /// The normalisation passes a bootstrap over `pixels` pixels runs:
    /// `b_passes`, or more on a small image, ⌈`b_min_samples` / pixels⌉
    /// but at most [`MAX_FLOOR_PASSES`]; 0 when `b_passes` is 0.
    ///
    /// Why a floor: b scales the whole image, and its relative error falls
    /// with the number of BDPT samples behind it, not with the image's
    /// size. Four passes over caustic-pool's 48×48 pixels (9 216 samples)
    /// left b between 0.50× and 1.13× of its converged value over 8
    /// seeds — an image up to twice too dark, an error no number of
    /// mutations removes; 32 passes (73 728 samples) 0.88–1.04×, at
    /// 0.1 s of bootstrap (docs/accuracy.md, "The normalisation floor").
    pub fn normalisation_passes(&self, pixels: u64) -> u32 {
        if self.b_passes == 0 {
            return 0;
        }
        let floor = u64::from(self.b_min_samples)
            .div_ceil(pixels.max(1))
            .min(u64::from(MAX_FLOOR_PASSES)) as u32;
        self.b_passes.max(floor)
    }

    /// Checks every parameter's range; the message names the first bad one.
    pub fn validate(&self) -> Result<(), &'static str> {
        if !(self.large_step_prob >= 0.0 && self.large_step_prob <= 1.0) {
            return Err("large-step probability must be in [0, 1]");
        }
        if !(self.sigma > 0.0 && self.sigma <= 1.0) {
            return Err("primary-sample σ must be in (0, 1]");
        }
        // Chains start from bootstrap samples: with none, b > 0 from the
        // normalisation passes left every chain without a start (the C API
        // already refused 0; the Rust API let it through).
        if self.n_bootstrap == 0 {
            return Err("at least one bootstrap sample per depth is needed");
        }
        if self.b_min_samples > MAX_B_MIN_SAMPLES {
            return Err("the normalisation floor must be at most 16 777 216 samples");
        }
        if self.n_chains == 0 {
            return Err("at least one chain per worker is needed");
        }
        if !(self.direct_allocation > 0.0 && self.direct_allocation <= 1.0) {
            return Err("the direct-view chain allocation must be in (0, 1]");
        }
        if !(self.pass_records >= 0.0 && self.pass_records <= MAX_PASS_RECORDS) {
            return Err("the pass records must be in [0, 1024]");
        }
        self.path_mutations.validate()
    }
}

/// Parameters of CMLT's level 2 (Segovia 2007: side chains of lens,
/// caustic and multi-chain perturbations after each level-1 mutation),
/// read by [`crate::renderer::Estimator::Cmlt`] only. See `mlt/level2.rs`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Level2Settings {
    /// The side-chain length m(c) of the classes that get a side chain
    /// (lens, caustic and multi-chain paths of at least
    /// `side_chain_min_depth` segments), ≥ 1.
    pub m: u32,
    /// Candidates per multiple-try step, 1 ≤ k ≤ 64.
    pub k: u32,
    /// Standard deviation of the lens perturbation's image-plane offset,
    /// in pixels.
    pub lens_sigma: f32,
    /// The caustic perturbation's angular σ is `lens_sigma` pixel angles
    /// times this factor.
    pub caustic_scale: f32,
    /// How the k candidates are drawn.
    pub candidates: Candidates,
    /// What a multiple-try step records ([`Splatting::Recycled`] or
    /// [`Splatting::ExpectedValue`]; [`Splatting::AllCandidates`], Segovia
    /// 2007's eq. 36, is biased and refused by
    /// [`Level2Settings::validate`]).
    pub splatting: Splatting,
    /// Parallel one-proposal side chains (lanes) per level-1 state, traced
    /// together as packets, 1 ≤ lanes ≤ 64; more than one
    /// needs k = 1. See `mlt/lanes.rs`.
    pub lanes: u32,
    /// Paths of fewer segments get no side chain (their level-1 records
    /// carry the level-2 share); 0 or 1 = every lens, caustic and
    /// multi-chain path gets one.
    pub side_chain_min_depth: u32,
    /// The level-2 share s, the weight (in records of one mutation) each
    /// level-1 mutation's side chain adds beyond its own record, or
    /// carries in its level-1 record when its state gets no side chain;
    /// 0 = m. Changes the variance, not the mean. See `mlt/level2.rs`.
    pub share: u32,
}

impl Default for Level2Settings {
    /// The measured CMLT defaults: m = 1, k = 1, lens σ = 8 px, caustic
    /// scale 1, stratified candidates, recycled splatting, one lane, side
    /// chains from 6 segments, share = m.
    ///
    /// k, m and σ come from equal-time studies (`cmlt-bench params`,
    /// σ ∈ {2, 8} px × k ∈ {1, 4, 8, 16} × m ∈ {1, 4}, 8 s on 2 threads;
    /// `docs/accuracy.md`): relMSE rises with k on veach-bidir and
    /// veach-ajar because a step costs 2k − 1 path evaluations while k
    /// candidates around one image point lower the error little more than
    /// one does (equal-mutation measurements in `docs/accuracy.md`).
    /// k = 1, m = 1 was best; σ = 2 and 8 px were within one render's
    /// noise of each other. The level-2 study
    /// (`docs/accuracy/level2-study.sh`: lanes, share, minimum depth, σ on
    /// veach-ajar, veach-bidir, caustic-pool and cornell-box) found one
    /// lane and a share equal to m best, and side chains only for paths of
    /// at least 6 segments best or within noise of the best on all four:
    /// short paths are cheap for level 1 to find again, so a side chain
    /// there costs more than it saves.
    fn default() -> Self {
        Level2Settings {
            m: 1,
            k: 1,
            lens_sigma: 8.0,
            caustic_scale: 1.0,
            candidates: Candidates::Stratified,
            splatting: Splatting::default(),
            lanes: 1,
            side_chain_min_depth: 6,
            share: 0,
        }
    }
}

impl Level2Settings {
    /// The level-2 share s: `share`, or m when `share` is 0.
    pub fn share(&self) -> u32 {
        if self.share == 0 { self.m } else { self.share }
    }

    /// Checks every parameter's range; the message names the first bad one.
    pub fn validate(&self) -> Result<(), &'static str> {
        if self.m == 0 {
            return Err("CMLT needs m ≥ 1 side-chain steps");
        }
        if !(1..=level2::MAX_K as u32).contains(&self.k) {
            return Err("k must be in 1..=64");
        }
        if !(self.lens_sigma > 0.0 && self.lens_sigma.is_finite()) {
            return Err("lens σ must be a positive number of pixels");
        }
        if !(self.caustic_scale > 0.0 && self.caustic_scale.is_finite()) {
            return Err("caustic scale must be positive and finite");
        }
        if !(1..=level2::MAX_K as u32).contains(&self.lanes) {
            return Err("lanes must be in 1..=64");
        }
        if self.lanes > 1 && self.k > 1 {
            return Err("parallel lanes need k = 1 (one proposal per lane)");
        }
        if self.splatting == Splatting::AllCandidates {
            return Err("eq. 36 splatting is biased; use recycled or expected-value splatting");
        }
        Ok(())
    }
}

/// The settings of CMLT: level 1 (as MLT's) and level 2.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CmltSettings {
    /// Level 1: the Metropolis chains, bootstrap and normalisation.
    pub mlt: MltSettings,
    /// Level 2: the side chains.
    pub level2: Level2Settings,
}

impl CmltSettings {
    /// Checks both levels; the message names the first bad parameter.
    pub fn validate(&self) -> Result<(), &'static str> {
        self.mlt.validate()?;
        self.level2.validate()
    }
}

/// Default of [`MltSettings::b_min_samples`]: 2¹⁶ samples, four passes
/// over a 128 × 128 image; smaller images get more passes.
pub const DEFAULT_B_MIN_SAMPLES: u32 = 1 << 16;

/// Default of [`MltSettings::direct_allocation`].
/// On Tungsten's Cornell box, where depth 1 is a small bright lamp, 0.1
/// gave 1.6× less error per mutation than 1 (0.03 no better):
/// `docs/accuracy.md`, "Level 1 against Tungsten's MMLT".
pub const DEFAULT_DIRECT_ALLOCATION: f32 = 0.1;

/// Default of [`MltSettings::pass_records`]: a pass sample's cost in
/// level-1 mutations on Tungsten's Cornell box (7–10 µs of CPU against
/// 1.4 µs), so that the passes and the chains weigh the work each did. At
/// equal time it cut relMSE × CPU s by 1.10–1.16× there and relMSE by
/// 1.03–1.7× on caustic-pool and veach-bidir (`docs/accuracy.md`, "Level 1
/// against Tungsten's MMLT").
pub const DEFAULT_PASS_RECORDS: f32 = 5.0;

/// Largest [`MltSettings::pass_records`].
pub const MAX_PASS_RECORDS: f32 = 1024.0;

/// Largest [`MltSettings::b_min_samples`].
pub const MAX_B_MIN_SAMPLES: u32 = 1 << 24;

/// Most passes the floor of [`MltSettings::normalisation_passes`] adds: the
/// passes' per-depth sums are kept pass by pass (so that a split across
/// workers adds them in the same order), which bounds their memory on a
/// tiny image.
pub const MAX_FLOOR_PASSES: u32 = 1024;

/// The path depths 1 ..= D the Metropolis estimators sample:
/// `settings.max_depth`, which the renderer bounds before any of them
/// runs ([`crate::renderer::RendererConfig::max_depth`]: the one depth
/// limit of every estimator); unbounded settings have no depths.
pub(crate) fn depths(settings: &Settings) -> u32 {
    settings.max_depth.unwrap_or(0)
}

/// The factor turning the splat layer into radiance: b · pixels / N for
/// N records ([`MltStats::records`]: level-1 mutations times 1 + s, the
/// level-2 share; 0 when N = 0).
pub fn image_scale(b: f64, pixels: u64, records: u64) -> f64 {
    if records == 0 {
        0.0
    } else {
        b * pixels as f64 / records as f64
    }
}

/// Counters of one worker's chains; summed across workers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MltStats {
    /// Chains started.
    pub chains: u64,
    /// Mutations (proposals evaluated), excluding chain starts.
    pub mutations: u64,
    /// Small-step proposals.
    pub small_proposed: u64,
    /// Small-step proposals accepted.
    pub small_accepted: u64,
    /// Small-step proposals whose strategy (s, t) differs from the current
    /// state's (part of `small_proposed`; primary-sample level 1).
    pub technique_proposed: u64,
    /// Technique-changing small steps accepted.
    pub technique_accepted: u64,
    /// Large-step proposals.
    pub large_proposed: u64,
    /// Large-step proposals accepted.
    pub large_accepted: u64,
    /// Proposals with zero (or non-finite) contribution (path space: also
    /// moves that made no path).
    pub zero_proposals: u64,
    /// Path-space level 1: bidirectional mutations proposed.
    pub bidirectional_proposed: u64,
    /// Path-space level 1: bidirectional mutations accepted.
    pub bidirectional_accepted: u64,
    /// Path-space level 1: lens subpath mutations proposed.
    pub lens_subpath_proposed: u64,
    /// Path-space level 1: lens subpath mutations accepted.
    pub lens_subpath_accepted: u64,
    /// Path-space level 1: lens, caustic and multi-chain perturbations
    /// proposed (level-1 mutations, not level 2's side-chain steps).
    pub perturbations_proposed: [u64; 3],
    /// Path-space level 1: lens, caustic and multi-chain perturbations
    /// accepted.
    pub perturbations_accepted: [u64; 3],
    /// Records splatted, in units of one mutation's total weight: level-1
    /// mutations times 1 + s, s the level-2 share (what [`image_scale`]
    /// divides by), the normalisation passes' records included.
    pub records: u64,
    /// The part of `records` that weighs the normalisation passes' image
    /// ([`MltSettings::pass_records`] per pass sample).
    pub pass_records: u64,
    /// Level 2: lens-perturbation steps (lane steps, or multiple-try steps
    /// when k > 1).
    pub lens_steps: u64,
    /// Level 2: lens-perturbation steps accepted.
    pub lens_accepted: u64,
    /// Level 2: caustic-perturbation steps (as `lens_steps`).
    pub caustic_steps: u64,
    /// Level 2: caustic-perturbation steps accepted.
    pub caustic_accepted: u64,
    /// Level 2: multi-chain-perturbation steps (as `lens_steps`).
    pub multi_chain_steps: u64,
    /// Level 2: multi-chain-perturbation steps accepted.
    pub multi_chain_accepted: u64,
    /// Level 2: share records (units of one mutation's weight) carried by
    /// level-1 records of states without a side chain (no perturbation
    /// applies, or too shallow), or recorded where a side chain could not
    /// start.
    pub identity_steps: u64,
    /// Level 2: candidates evaluated (k per step, reference points not
    /// counted).
    pub l2_candidates: u64,
    /// Level 2: candidates with zero contribution or a failed retrace.
    pub l2_zero_candidates: u64,
}

impl MltStats {
    /// Adds another worker's counters.
    pub fn merge(&mut self, o: &MltStats) {
        self.chains += o.chains;
        self.mutations += o.mutations;
        self.pass_records += o.pass_records;
        self.small_proposed += o.small_proposed;
        self.small_accepted += o.small_accepted;
        self.technique_proposed += o.technique_proposed;
        self.technique_accepted += o.technique_accepted;
        self.large_proposed += o.large_proposed;
        self.large_accepted += o.large_accepted;
        self.zero_proposals += o.zero_proposals;
        self.bidirectional_proposed += o.bidirectional_proposed;
        self.bidirectional_accepted += o.bidirectional_accepted;
        self.lens_subpath_proposed += o.lens_subpath_proposed;
        self.lens_subpath_accepted += o.lens_subpath_accepted;
        for i in 0..3 {
            self.perturbations_proposed[i] += o.perturbations_proposed[i];
            self.perturbations_accepted[i] += o.perturbations_accepted[i];
        }
        self.records += o.records;
        self.lens_steps += o.lens_steps;
        self.lens_accepted += o.lens_accepted;
        self.caustic_steps += o.caustic_steps;
        self.caustic_accepted += o.caustic_accepted;
        self.multi_chain_steps += o.multi_chain_steps;
        self.multi_chain_accepted += o.multi_chain_accepted;
        self.identity_steps += o.identity_steps;
        self.l2_candidates += o.l2_candidates;
        self.l2_zero_candidates += o.l2_zero_candidates;
    }

    /// Fraction of lens-perturbation steps accepted (0 when none).
    pub fn lens_acceptance(&self) -> f64 {
        ratio(self.lens_accepted, self.lens_steps)
    }

    /// Fraction of caustic-perturbation steps accepted (0 when none).
    pub fn caustic_acceptance(&self) -> f64 {
        ratio(self.caustic_accepted, self.caustic_steps)
    }

    /// Fraction of multi-chain-perturbation steps accepted (0 when none).
    pub fn multi_chain_acceptance(&self) -> f64 {
        ratio(self.multi_chain_accepted, self.multi_chain_steps)
    }

    /// Fraction of level-1 proposals with zero contribution.
    pub fn zero_fraction(&self) -> f64 {
        ratio(self.zero_proposals, self.mutations)
    }

    /// Fraction of level-2 candidates with zero contribution.
    pub fn l2_zero_fraction(&self) -> f64 {
        ratio(self.l2_zero_candidates, self.l2_candidates)
    }

    /// Fraction of small steps accepted (0 when none).
    pub fn small_acceptance(&self) -> f64 {
        ratio(self.small_accepted, self.small_proposed)
    }

    /// Fraction of small steps that proposed another strategy (s, t)
    /// (0 when none).
    pub fn technique_fraction(&self) -> f64 {
        ratio(self.technique_proposed, self.small_proposed)
    }

    /// Fraction of technique-changing small steps accepted (0 when none).
    pub fn technique_acceptance(&self) -> f64 {
        ratio(self.technique_accepted, self.technique_proposed)
    }

    /// Fraction of bidirectional mutations accepted (0 when none).
    pub fn bidirectional_acceptance(&self) -> f64 {
        ratio(self.bidirectional_accepted, self.bidirectional_proposed)
    }

    /// Fraction of lens subpath mutations accepted (0 when none).
    pub fn lens_subpath_acceptance(&self) -> f64 {
        ratio(self.lens_subpath_accepted, self.lens_subpath_proposed)
    }

    /// Fractions of the path-space level 1's lens, caustic and
    /// multi-chain perturbations accepted (0 when none).
    pub fn perturbation_acceptance(&self) -> [f64; 3] {
        core::array::from_fn(|i| {
            ratio(
                self.perturbations_accepted[i],
                self.perturbations_proposed[i],
            )
        })
    }

    /// Fraction of large steps accepted (0 when none).
    pub fn large_acceptance(&self) -> f64 {
        ratio(self.large_accepted, self.large_proposed)
    }

    fn record(&mut self, st: &Step) {
        self.mutations += 1;
        self.records += 1;
        if st.large {
            self.large_proposed += 1;
            self.large_accepted += st.accepted as u64;
        } else {
            self.small_proposed += 1;
            self.small_accepted += st.accepted as u64;
            if st.technique_change {
                self.technique_proposed += 1;
                self.technique_accepted += st.accepted as u64;
            }
        }
        self.zero_proposals += st.zero as u64;
    }
}

fn ratio(a: u64, b: u64) -> f64 {
    if b == 0 { 0.0 } else { a as f64 / b as f64 }
}

/// Seed of chain `chain` of worker `worker`.
#[inline]
fn chain_seed(seed: u64, worker: u64, chain: u64) -> u64 {
    mix64(mix64(mix64(seed ^ 0x3C7A_1200_0000_0000) ^ worker) ^ chain)
}

/// Samples a chain searches for a start, per bootstrap sample per depth
/// (`MltSettings::n_bootstrap`), when none of its depth's bootstrap samples
/// contributes (see [`start_sample`]), and at least [`START_SEARCH_MIN`].
const START_SEARCH: u64 = 4;

/// Least number of samples a chain searches for a start.
const START_SEARCH_MIN: u64 = 8192;

/// Bootstrap samples a kept chain whose state a new view left dark picks,
/// ∝ Y, before it stays dark ([`WorkerChains::reevaluate`]).
const RESTART_PICKS: u32 = 8;

/// The bootstrap sample a chain of `depth` starts from, `u` uniform in [0, 1).
///
/// Normally one of the bootstrap's, drawn ∝ Y by [`Bootstrap::pick`]. When
/// none of them contributes although b_d > 0 (a light that is rare among
/// the depth's paths, or few bootstrap samples), a chain started on a zero path
/// would record nothing until a proposal finds light, and its depth's
/// share of the image would be missing meanwhile: on the Cornell box with
/// 100 bootstrap samples per depth, often none of which hit the directly
/// seen light, the image came out 30% dark at 64 mutations per pixel. Such a
/// chain instead takes the first contributing one of up to `tries`
/// further samples of its depth ([`Bootstrap::extra_sample`]), in an order
/// drawn from `rng` so that chains start apart. `contributes(index)`
/// evaluates one. That start is uniform over the target's support rather
/// than ∝ Y, a burn-in the chain's mutations remove rather than a lasting
/// bias (and exact for a uniform emitter seen directly). If the search
/// fails the chain starts on a zero path as before.
fn start_sample(
    bootstrap: &Bootstrap,
    depth: u32,
    u: f64,
    tries: u64,
    rng: &mut Pcg32,
    mut contributes: impl FnMut(u64) -> bool,
) -> Option<u64> {
    let lit = depth
        .checked_sub(1)
        .and_then(|d| bootstrap.depth_b().get(d as usize))
        .is_some_and(|&b| b > 0.0);
    if lit && !bootstrap.has_contributing_sample(depth) {
        // 40 bits, so that `first + j` stays far below 2⁴⁸.
        let first = rng.next_u64() >> 24;
        if let Some(index) = (0..tries)
            .map(|j| bootstrap.extra_sample(depth, first + j))
            .find(|&i| contributes(i))
        {
            return Some(index);
        }
    }
    bootstrap.pick(depth, u)
}

/// A uniform f64 in [0, 1) from 53 random bits.
fn uniform_f64(rng: &mut Pcg32) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// One worker's chains and the reusable BDPT storage they evaluate with.
///
/// The chains of all `workers` workers together are one systematic sample
/// of the depths by b_d / b (see `mlt/bootstrap.rs`); worker `w` holds the
/// global chains w, w + W, w + 2W, …, itself a systematic sample, so each
/// worker's film alone is an estimate of the image and workers that run
/// different numbers of rounds (time budgets) still merge correctly.
/// Mutations run in *rounds*, one per chain, so that every chain of a
/// worker has made the same number of mutations: chains of different
/// depths must be weighted equally for the normalisation to hold.
pub(crate) struct WorkerChains {
    chains: Vec<(Chain, u32)>,
    /// Splat weight of each chain: its depth's share of b over its share
    /// of the chains ([`depth_weights`]).
    weights: Vec<f32>,
    /// With large steps combined by MIS, p·b_d of each chain's depth (the
    /// large steps' density in the records' units, `mlt/chain.rs`); empty
    /// without.
    large_step_offsets: Vec<f32>,
    /// The large-step probability p when large steps are combined by MIS.
    large_step_mis: Option<f32>,
    /// Size of the systematic sample the chains were drawn as.
    n_chains: u32,
    /// Samples a chain searches for a start (see [`start_sample`]).
    start_tries: u64,
    /// Samplers of dropped chains, whose buffers new chains reuse.
    spare: Vec<PrimarySampler>,
    /// Seed of each chain (its level-2 random streams derive from it).
    seeds: Vec<u64>,
    ws: bdpt::PathStorage,
    stats: MltStats,
    /// The large steps' targets by depth since the counters were last
    /// zeroed.
    large_steps: LargeStepTally,
    /// Level 2 (CMLT), with each chain's current path (copied from
    /// the path storage when a proposal is accepted).
    level2: Option<Level2>,
    paths: Vec<Vec<PathVertex>>,
    /// Level 2: the class of each chain's current path and its side-chain
    /// length ([`Level2::classify`]).
    classes: Vec<(Applicable, u32)>,
    /// Level 2: the path of the latest proposal, classified for its
    /// level-1 record's weight and swapped in when it is accepted.
    proposal_path: Vec<PathVertex>,
    /// The position of the next mutation in the open round (0 between
    /// rounds) and whether that round visits the chains in a strided
    /// order ([`WorkerChains::advance`]).
    next: usize,
    strided: bool,
    /// The path-space level 1's chains, in place of `chains`
    /// ([`Level1::PathSpace`]), with the worker they were started for.
    path_space: Option<(PathChains, u64, u64)>,
}

/// Stream index of level 2's random numbers (per chain and iteration).
pub(crate) const LEVEL2_STREAM: u64 = 0x4C32;

impl WorkerChains {
    /// A worker without chains holding all the storage its chains will
    /// need for `settings`, level 1 `mlt` and, for CMLT, `level2` with
    /// `camera`'s resolution: after this, [`WorkerChains::restart`] and
    /// [`WorkerChains::run`] allocate nothing.
    pub(crate) fn with_capacity(
        settings: &Settings,
        mlt: &MltSettings,
        level2: Option<&Level2Settings>,
        camera: &Camera,
    ) -> Self {
        let path_space = mlt.level1 == Level1::PathSpace;
        // The primary-sample chains' storage, unused by path-space ones.
        let n = if path_space { 0 } else { mlt.n_chains as usize };
        let depth = depths(settings);
        let max_vertices = depth as usize + 1;
        let level2 = level2
            .and_then(|l2| Level2::new(l2, camera.width(), camera.height(), camera.pixel_angle()));
        let l2 = level2.is_some();
        let paths = if l2 {
            (0..n).map(|_| Vec::with_capacity(max_vertices)).collect()
        } else {
            Vec::new()
        };
        WorkerChains {
            chains: Vec::with_capacity(n),
            weights: Vec::with_capacity(n),
            large_step_offsets: Vec::with_capacity(if mlt.large_step_mis { n } else { 0 }),
            large_step_mis: mlt.large_step_mis.then_some(mlt.large_step_prob),
            n_chains: mlt.n_chains,
            start_tries: (START_SEARCH * mlt.n_bootstrap as u64).max(START_SEARCH_MIN),
            spare: (0..n)
                .map(|_| PrimarySampler::with_capacity(0, mlt.sigma, mlt.large_step_prob, depth))
                .collect(),
            seeds: Vec::with_capacity(n),
            ws: bdpt::PathStorage::with_capacity(depth),
            stats: MltStats::default(),
            large_steps: LargeStepTally::with_depths(depth),
            level2,
            paths,
            classes: Vec::with_capacity(if l2 { n } else { 0 }),
            proposal_path: Vec::with_capacity(if l2 { max_vertices } else { 0 }),
            next: 0,
            strided: false,
            path_space: (mlt.level1 == Level1::PathSpace)
                .then(|| (PathChains::with_capacity(settings, mlt, l2, camera), 0, 1)),
        }
    }

    /// Drops every chain and starts `mlt.n_chains` new ones for worker
    /// `worker` of `workers` in a render seeded by `seed`, reusing their
    /// storage: each gets its depth from the systematic sample, starts at
    /// a bootstrap sample of that depth in `bootstrap` picked with
    /// probability ∝ its luminance (replayed from its seed), and continues
    /// with its own random stream. No chain is started when b = 0. With
    /// level 2 every chain also keeps its current path. The counters start
    /// again from zero. What a renderer calls when the camera or the scene
    /// changed; the same arguments give the same chains. `tracer`'s camera
    /// must have the resolution the worker was made for.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn restart<I: Intersector>(
        &mut self,
        tracer: &mut Tracer<'_, I>,
        settings: &Settings,
        mlt: &MltSettings,
        bootstrap: &Bootstrap,
        seed: u64,
        worker: u64,
        workers: u64,
    ) {
        if self.restart_path_space(tracer, settings, bootstrap, seed, worker, workers) {
            return;
        }
        let WorkerChains {
            chains,
            spare,
            seeds,
            ws,
            stats,
            large_steps,
            level2,
            paths,
            classes,
            start_tries,
            ..
        } = self;
        spare.extend(chains.drain(..).map(|(c, _)| c.into_sampler()));
        self.next = 0;
        seeds.clear();
        classes.clear();
        *stats = MltStats::default();
        large_steps.clear();
        let workers = workers.max(1);
        let total = mlt.n_chains as u64 * workers;
        // The systematic sample's single random offset, shared by all
        // workers.
        let offset = uniform_f64(&mut Pcg32::new(mix64(seed ^ 0x0FF5_E700), 7));
        for c in 0..mlt.n_chains as u64 {
            let global = worker + workers * c;
            let Some(depth) = bootstrap.chain_depth_at((global as f64 + offset) / total as f64)
            else {
                break;
            };
            let cs = chain_seed(seed, worker, c);
            let mut rng = Pcg32::new(cs, mix64(cs ^ 1));
            let Some(mut sampler) = spare.pop() else {
                break;
            };
            let u = uniform_f64(&mut rng);
            let start = start_sample(bootstrap, depth, u, *start_tries, &mut rng, |i| {
                sampler.restart(bootstrap.seed_of(i));
                target::evaluate(tracer, settings, ws, depth, &mut sampler).target() > 0.0
            });
            let Some(index) = start else {
                spare.push(sampler);
                continue;
            };
            sampler.restart(bootstrap.seed_of(index));
            let initial = target::evaluate(tracer, settings, ws, depth, &mut sampler);
            if let Some(l2) = level2 {
                classes.push(l2.classify_stored(tracer, ws, depth, &mut paths[chains.len()]));
            }
            // Chains replaying the same sample diverge from here on.
            sampler.reseed(mix64(cs ^ 2));
            chains.push((Chain::new(sampler, initial, cs), depth));
            seeds.push(cs);
            stats.chains += 1;
        }
        depth_weights(chains, bootstrap, mlt.n_chains, &mut self.weights);
        self.set_large_step_offsets(bootstrap);
    }

    /// [`WorkerChains::restart`] for the path-space level 1: false (and
    /// nothing done) for the primary-sample one.
    fn restart_path_space<I: Intersector>(
        &mut self,
        tracer: &mut Tracer<'_, I>,
        settings: &Settings,
        bootstrap: &Bootstrap,
        seed: u64,
        worker: u64,
        workers: u64,
    ) -> bool {
        let Some((ps, w, w_count)) = &mut self.path_space else {
            return false;
        };
        (*w, *w_count) = (worker, workers);
        self.next = 0;
        self.stats = MltStats::default();
        self.large_steps.clear();
        ps.restart(
            tracer,
            settings,
            &mut self.ws,
            bootstrap,
            self.start_tries,
            seed,
            worker,
            workers,
            &mut self.stats,
            self.level2.as_ref(),
        );
        true
    }

    /// Keeps every chain and evaluates its current state again through
    /// `tracer` (a new camera or scene): the temporal alternative to
    /// [`WorkerChains::restart`] (the chains keep their depths and random
    /// streams). A chain whose state no longer contributes restarts from a
    /// bootstrap sample of its depth in `bootstrap` (seeded by `seed`; see
    /// `start_sample`), the first of up to [`RESTART_PICKS`] picks that
    /// contributes under the new view (a bootstrap carried from earlier
    /// frames weighs its samples by their old luminance): left at zero it
    /// would record nothing until a proposal hits, and those records would
    /// darken the image.
    /// Counters start again from zero. Allocates nothing.
    pub(crate) fn reevaluate<I: Intersector>(
        &mut self,
        tracer: &mut Tracer<'_, I>,
        settings: &Settings,
        bootstrap: &Bootstrap,
        seed: u64,
    ) {
        if let Some((_, worker, workers)) = self.path_space {
            // A path's lens point is the old camera's: the chains start
            // afresh from the bootstrap under the new view.
            self.restart_path_space(tracer, settings, bootstrap, seed, worker, workers);
            return;
        }
        let WorkerChains {
            chains,
            seeds,
            ws,
            stats,
            large_steps,
            level2,
            paths,
            classes,
            start_tries,
            ..
        } = self;
        *stats = MltStats {
            chains: chains.len() as u64,
            ..MltStats::default()
        };
        large_steps.clear();
        for (ci, (chain, depth)) in chains.iter_mut().enumerate() {
            let depth = *depth;
            chain.reevaluate(|s| target::evaluate(tracer, settings, ws, depth, s));
            let cs = mix64(seeds[ci] ^ seed);
            let mut rng = Pcg32::new(cs, mix64(cs ^ 1));
            let mut evaluate =
                |s: &mut PrimarySampler| target::evaluate(tracer, settings, ws, depth, s);
            // The bootstrap's luminances may be of earlier views (a
            // bootstrap carried while the next one is evaluated): a sample
            // picked ∝ Y can be dark under this one, so a few more picks.
            for _ in 0..RESTART_PICKS {
                if chain.current().target() > 0.0 {
                    break;
                }
                let u = uniform_f64(&mut rng);
                let start = start_sample(bootstrap, depth, u, *start_tries, &mut rng, |i| {
                    chain.restart(bootstrap.seed_of(i), cs, &mut evaluate);
                    chain.current().target() > 0.0
                });
                if let Some(index) = start {
                    chain.restart(bootstrap.seed_of(index), cs, &mut evaluate);
                }
            }
            if let Some(l2) = level2 {
                // A chain left on a dead path has no path to perturb (the
                // path storage holds none): no side chain until it moves.
                classes[ci] = if chain.current().target() > 0.0 {
                    l2.classify_stored(tracer, ws, depth, &mut paths[ci])
                } else {
                    paths[ci].clear();
                    (Applicable::Neither, 0)
                };
            }
        }
        depth_weights(chains, bootstrap, self.n_chains, &mut self.weights);
        self.set_large_step_offsets(bootstrap);
    }

    /// With large steps combined by MIS, sets each chain's p·b_d from
    /// `bootstrap` (the b_d its depth's weight gives it).
    fn set_large_step_offsets(&mut self, bootstrap: &Bootstrap) {
        self.large_step_offsets.clear();
        let Some(p) = self.large_step_mis else {
            return;
        };
        for &(_, depth) in &self.chains {
            let b_d = bootstrap
                .depth_b()
                .get(depth as usize - 1)
                .copied()
                .unwrap_or(0.0);
            self.large_step_offsets.push((f64::from(p) * b_d) as f32);
        }
    }

    /// Zeroes the counters, keeping the chains as they are (a new frame
    /// through the same camera).
    pub(crate) fn reset_stats(&mut self) {
        self.stats = MltStats {
            chains: self.chain_count() as u64,
            ..MltStats::default()
        };
        self.large_steps.clear();
    }

    /// Number of chains (mutations per round).
    pub(crate) fn chain_count(&self) -> usize {
        match &self.path_space {
            Some((ps, ..)) => ps.len(),
            None => self.chains.len(),
        }
    }

    /// Runs `rounds` rounds — one mutation of every chain, in chain order,
    /// each followed by its level-2 side chain (CMLT) — splatting every
    /// record into `film`; a round left open by [`WorkerChains::advance`]
    /// is finished first and counts as one. Returns the number of level-1
    /// mutations (0 when there are no chains: b = 0);
    /// [`MltStats::records`] counts the records.
    pub fn run<I: Intersector>(
        &mut self,
        tracer: &mut Tracer<'_, I>,
        settings: &Settings,
        film: &mut Film,
        rounds: u64,
    ) -> u64 {
        let mut done = 0;
        for _ in 0..rounds {
            let left = self.chain_count() - self.next;
            done += self.advance(tracer, settings, film, left, false);
        }
        done
    }

    /// Makes the next `count` mutations of the open round (at most to its
    /// end; a round begun here visits the chains in chain order, or with
    /// `strided` in the order k · s mod n, s coprime with the chain count
    /// n and near n·(√5 − 1)/2), each followed by its side chain; returns
    /// how many.
    ///
    /// Why strided: the chains are ordered by depth (the systematic sample
    /// of b_d / b), and the image is normalised by the records of all of
    /// them, so a round cut short in chain order would over-weigh the
    /// shallow depths by up to one mutation per chain — 50 % when a frame
    /// holds two rounds. Golden-ratio steps spread any prefix of the round
    /// over the depths in proportion within a few chains, so a frame that
    /// ends inside a round is off by a few mutations' worth per depth.
    pub(crate) fn advance<I: Intersector>(
        &mut self,
        tracer: &mut Tracer<'_, I>,
        settings: &Settings,
        film: &mut Film,
        count: usize,
        strided: bool,
    ) -> u64 {
        let n = self.chain_count();
        if n == 0 {
            return 0;
        }
        if self.next == 0 {
            self.strided = strided;
        }
        let stride = if self.strided { coprime_stride(n) } else { 1 };
        let end = (self.next + count).min(n);
        if let Some((ps, ..)) = &mut self.path_space {
            for k in self.next..end {
                let ci = k * stride % n;
                let st = ps.step(ci, tracer, &mut self.stats);
                ps.record(ci, &st, tracer, self.level2.as_mut(), &mut self.stats, film);
            }
            let done = end - self.next;
            self.next = if end == n { 0 } else { end };
            return done as u64;
        }
        let WorkerChains {
            chains,
            weights,
            large_step_offsets,
            seeds,
            ws,
            stats,
            large_steps,
            level2,
            paths,
            classes,
            proposal_path,
            ..
        } = self;
        // Level 1 alone: each mutation's records are splatted after the
        // next mutation's evaluation, their pixels prefetched meanwhile (a
        // large step's proposal lands on a random pixel, a cache miss that
        // cost about 6 % of a mutation's CPU on Tungsten's box). The film
        // receives the same additions in the same order, so the image is
        // bit for bit the same.
        let mut pending: [Option<Splat>; 2] = [None, None];
        for k in self.next..end {
            let ci = k * stride % n;
            let (chain, depth) = &mut chains[ci];
            let depth = *depth;
            let w = weights[ci];
            let offset = large_step_offsets.get(ci).copied();
            let st = chain.step(|s| target::evaluate(tracer, settings, ws, depth, s), offset);
            stats.record(&st);
            if st.large {
                large_steps.add(depth, st.proposal_target);
            }
            let Some(l2) = level2 else {
                for (slot, sp) in pending.iter_mut().zip([st.proposal, st.current]) {
                    if let Some(sp) = slot.take() {
                        film.add_splat(sp.raster, sp.value);
                    }
                    *slot = sp.map(|sp| {
                        film.prefetch_splat(sp.raster);
                        Splat {
                            raster: sp.raster,
                            value: sp.value * w,
                        }
                    });
                }
                continue;
            };
            // A state of a class without side chain carries the
            // level-2 share in its level-1 record (see `level2`): the
            // proposal's class is needed whenever it is recorded. The
            // path storage still holds its subpaths (nothing traced
            // since).
            let share = l2.share() as f32;
            let carry = |length: u32| if length == 0 { 1.0 + share } else { 1.0 };
            let mut y_class = (Applicable::Neither, 0);
            if let Some(sp) = st.proposal {
                y_class = l2.classify_stored(tracer, ws, depth, proposal_path);
                film.add_splat(sp.raster, sp.value * (w * carry(y_class.1)));
            }
            if let Some(sp) = st.current {
                film.add_splat(sp.raster, sp.value * (w * carry(classes[ci].1)));
            }
            // Accepted implies a > 0, so the proposal was classified
            // (and its path copied, if it can have a side chain).
            if st.accepted {
                core::mem::swap(&mut paths[ci], proposal_path);
                classes[ci] = y_class;
            }
            let (class, length) = &classes[ci];
            if *length > 0 {
                let mut rng =
                    SampleStream::new(seeds[ci], chain.sampler().iteration(), LEVEL2_STREAM);
                l2.side_chain(
                    tracer,
                    &paths[ci],
                    class,
                    *length,
                    &chain.current(),
                    &mut rng,
                    stats,
                    &mut |r, v| film.add_splat(r, v * w),
                );
            } else {
                stats.identity_steps += l2.share() as u64;
            }
            stats.records += l2.share() as u64;
        }
        for sp in pending.into_iter().flatten() {
            film.add_splat(sp.raster, sp.value);
        }
        let done = end - self.next;
        self.next = if end == n { 0 } else { end };
        done as u64
    }

    /// This worker's counters.
    pub fn stats(&self) -> &MltStats {
        &self.stats
    }

    /// This worker's large steps by depth since its counters were last
    /// zeroed (chains started or re-evaluated, or a new frame).
    pub fn large_steps(&self) -> &LargeStepTally {
        &self.large_steps
    }

    /// The path depth of each chain, in chain order.
    #[cfg(test)]
    pub fn chain_depths(&self) -> impl Iterator<Item = u32> + '_ {
        self.chains.iter().map(|&(_, d)| d)
    }
}

/// Sets `weights[c]` to the splat weight of chain `c` of a worker whose
/// chains were a systematic sample of `n` points over the depths by the
/// allocation q_d / Q ([`Bootstrap::chain_share`]; see [`bootstrap`]).
///
/// A depth d expects e_d = n·q_d/Q chains and gets n_d ∈ {⌊e_d⌋, ⌈e_d⌉};
/// its share of the image must be b_d/b. Unweighted, with q = b, it is
/// n_d/n instead: an error of up to one chain in e_d that more mutations
/// never average out (a sphere lit only at depth 2 rendered 15% dark with
/// 32 chains, still 8% at 4096 mutations per pixel). Where e_d ≥ 1,
/// weighting its chains by n·(b_d/b)/n_d gives the depth exactly b_d.
/// Where e_d < 1, n_d is 0 or 1 with probability e_d of 1, so weight
/// (b_d/b)/(q_d/Q) is right in expectation (1 when q = b), and no weight
/// could restore a depth that got no chain. The weights sum to about n,
/// so the image's scale ([`image_scale`]) is unchanged. Chains kept from
/// another frame ([`WorkerChains::reevaluate`]) get the weights of the new
/// b_d for the depths they have.
fn depth_weights(chains: &[(Chain, u32)], bootstrap: &Bootstrap, n: u32, weights: &mut Vec<f32>) {
    weights.clear();
    let b = bootstrap.b();
    for &(_, depth) in chains {
        let n_d = chains.iter().filter(|&&(_, d)| d == depth).count() as f64;
        let b_d = bootstrap
            .depth_b()
            .get(depth as usize - 1)
            .copied()
            .unwrap_or(0.0);
        let share = if b > 0.0 { b_d / b } else { 0.0 };
        let q = bootstrap.chain_share(depth);
        let e_d = n as f64 * q;
        let w = if e_d >= 1.0 {
            n as f64 * share / n_d
        } else if q > 0.0 {
            share / q
        } else {
            1.0
        };
        weights.push(w as f32);
    }
}

/// The step of a strided visit of `n` items: the odd number nearest
/// n·(√5 − 1)/2 that is coprime with n, reduced mod n (a permutation;
/// golden-ratio steps spread every prefix evenly, Weyl's sequence).
pub(crate) fn coprime_stride(n: usize) -> usize {
    let gcd = |mut a: usize, mut b: usize| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    let mut s = ((n as f64 * 0.618_033_988_749_894_9) as usize) | 1;
    while gcd(s, n) != 1 {
        s += 2;
    }
    s % n.max(1)
}

/// Rounds that give at least `mutations_per_pixel · pixels` mutations over
/// `workers` workers of `chains` chains each (at least one round).
pub fn rounds_for(mutations_per_pixel: u64, pixels: u64, workers: u64, chains: u64) -> u64 {
    let per_round = (workers * chains).max(1);
    mutations_per_pixel
        .saturating_mul(pixels)
        .div_ceil(per_round)
        .max(1)
}

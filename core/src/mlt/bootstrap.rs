//! The bootstrap phase: the normalisation b and the chains' starting
//! points (Veach 1997, §11.3.1; Segovia 2007's eq. 28; pbrt-v4's
//! `MLTIntegrator::Render`).
//!
//! Two kinds of independent samples:
//!
//! - **Bootstrap samples** (pbrt's bootstrap): sample `i` evaluates the
//!   Metropolis target at depth `1 + i mod D` (D = the largest path depth)
//!   at the uniform primary point of [`sample_seed`]`(seed, i)`. With n per
//!   depth, b_d = (1/n) Σ_{i of depth d} Y_i estimates ∫ Y(f_d(u)) du, and a
//!   chain of depth d starts at sample `i` with probability
//!   Y_i / Σ_{depth d} Y: a resampled approximation of the target, so chains
//!   start (close to) stationary. A sample is replayed from its seed, so
//!   only its luminance is stored.
//! - **Normalisation passes** (optional, `MltSettings::b_passes`, more on a
//!   small image: [`MltSettings::normalisation_passes`]): passes of
//!   ordinary BDPT, one sample per pixel, stratified over the image, with
//!   every strategy MIS-weighted; the luminance of each contribution is
//!   tallied by its depth s + t − 1. These estimate the same b_d (both are
//!   the depth-d part of the image's mean luminance) with far less noise:
//!   the single-strategy estimate multiplies one strategy by the strategy
//!   count, and its uniform raster coordinates are not stratified. On the
//!   Cornell box at 64×64, a directly seen light covering 0.4% of the image
//!   gives the pbrt estimate of b_1 a 10% standard error at 20 000 samples
//!   per depth; one stratified pass has almost none.
//!
//! b = Σ_d b_d is the image's mean luminance and scales the whole image, so
//! its error is a floor under the image's error that more mutations do not
//! lower.
//!
//! Chains are assigned depths by *systematic* sampling of an allocation
//! q_d / Q ([`Bootstrap::chain_depth_at`] with evenly spaced points and one
//! random offset): every depth gets ⌊C·q_d/Q⌋ or ⌈C·q_d/Q⌉ of C chains.
//! q_d = b_d (pbrt, Tungsten), except for depth 1, the emitters seen
//! directly: q_1 = c · b_1 with c = A_1 · b / b_1, A_1 the share of the
//! image that sees an emitter (depth-1 bootstrap samples with a
//! contribution), clamped to [[`MltSettings::direct_allocation`], 1]. An
//! emitter seen directly far brighter than the image's mean (a small lamp:
//! A_1 · b ≪ b_1) is a flat bright patch whose pixels' relative error
//! b-proportional chains drive far below the rest's; depth 1 then gets
//! chains for its area, not its luminance, down to the floor. On
//! Tungsten's Cornell box depth 1 is 43 % of b on 0.3 % of the pixels (c
//! is the floor, 0.1); an environment or emitting walls seen behind the
//! scene are no brighter than its mean and keep c = 1 (at c = 0.1 the
//! envmap test scene's error rose 4×: `docs/accuracy.md`, "Level 1
//! against Tungsten's MMLT"). Each chain is
//! then weighted so that its depth contributes exactly b_d
//! (`depth_weights` in the parent module), which also removes the rounding
//! of C·q_d/Q to whole chains; every chain of a worker runs the same
//! number of mutations, so the weighted histogram of all chains is one
//! estimate normalised by b. (pbrt draws each chain's depth
//! independently, which adds multinomial noise to the split between
//! depths.)
//!
//! Everything can be evaluated in any split across workers (index ranges of
//! bootstrap samples, pass numbers) and combined in index order: the result does
//! not depend on the split.

use alloc::vec::Vec;
use core::ops::Range;

use glam::Vec2;

use super::primary::PrimarySampler;
use super::{MltSettings, depths, target};
use crate::accel::Intersector;
use crate::film::Film;
use crate::integrator::{Settings, Tracer, bdpt};
use crate::sampler::{SampleStream, mix64};

/// Seed of bootstrap sample `index` of a render seeded by `seed`: the primary
/// sample it evaluates is `PrimarySampler::new(sample_seed(…))`'s first
/// (large-step) point.
#[inline]
fn sample_seed(seed: u64, index: u64) -> u64 {
    mix64(mix64(seed ^ 0xB007_57A9_0000_0000) ^ index)
}

/// Evaluates bootstrap samples `range` (indices into 0 … n·D) and appends
/// their target values Y_i to `out`, in index order, with caller-owned
/// storage: allocates nothing when `out` has room and `ws` and `sampler`
/// are large enough for the deepest path (a renderer's worker re-running
/// its share of the bootstrap every frame).
pub fn evaluate_samples<I: Intersector>(
    tracer: &mut Tracer<'_, I>,
    settings: &Settings,
    seed: u64,
    range: Range<u64>,
    ws: &mut bdpt::PathStorage,
    sampler: &mut PrimarySampler,
    out: &mut Vec<f32>,
) {
    let depths = depths(settings) as u64;
    if depths == 0 {
        return;
    }
    for i in range {
        sampler.restart(sample_seed(seed, i));
        let depth = 1 + (i % depths) as u32;
        let y = target::evaluate(tracer, settings, ws, depth, sampler).target();
        out.push(y);
    }
}

/// Camera rays per pixel and pass that estimate b_1 (a
/// [`DIRECT_GRID`]² stratified grid), instead of the pass's one BDPT
/// sample: see [`evaluate_pass`].
const DIRECT_GRID: u32 = 2;

/// Renders the pixels `pixels` (row-major indices) of normalisation pass
/// `pass` — one BDPT sample per pixel, depths 1 … D, all strategies with
/// MIS — and adds the luminance of every contribution to `sums[depth − 1]`
/// (`sums.len()` ≥ D). A pass evaluated in consecutive pieces into the
/// same `sums` adds in the same order as in one go: the same sums, bit for
/// bit (how a frame loop spreads its set-up over calls).
///
/// Depth 1 (emitters seen directly) is tallied from its own
/// [`DIRECT_GRID`]² camera rays per pixel, stratified over the pixel,
/// instead of the BDPT sample's one ray: b_1's error is the coverage noise
/// of the pixels on an emitter's outline, which one jittered ray per pixel
/// leaves large (on Tungsten's Cornell box, 0.46 % of b over 4 passes —
/// an error of the whole image that no mutation removes) and a stratified
/// grid shrinks faster than its cost (one ray and a light sample each, a
/// few per cent of a BDPT sample). Both estimate the same integral: a
/// depth-1 path is the (s = 0, t = 2) strategy alone, BDPT having no
/// (1, 1).
///
/// With `image`, every contribution tallied is also added to it (camera
/// samples at their pixel, light-tracing ones splatted, the grid's at
/// 1/4 each): the pass's BDPT image, which `pass_image` adds to the
/// chains' image.
#[allow(clippy::too_many_arguments)]
pub(crate) fn evaluate_pass<I: Intersector>(
    tracer: &mut Tracer<'_, I>,
    settings: &Settings,
    ws: &mut bdpt::PathStorage,
    seed: u64,
    pass: u64,
    pixels: Range<u64>,
    sums: &mut [f64],
    mut image: Option<&mut Film>,
) {
    let depths = depths(settings);
    if depths == 0 {
        return;
    }
    let capped = Settings {
        max_depth: Some(depths),
        ..*settings
    };
    let direct = Settings {
        max_depth: Some(1),
        ..*settings
    };
    let camera = tracer.camera;
    let w = camera.width() as u64;
    let pass_seed = mix64(seed ^ 0x0B5E_ED00_0000_0000);
    let direct_seed = mix64(seed ^ 0xD1EC_7000_0000_0000);
    let cell = 1.0 / DIRECT_GRID as f32;
    let direct_weight = 1.0 / f64::from(DIRECT_GRID * DIRECT_GRID);
    for pixel in pixels.start..pixels.end.min(camera.pixel_count()) {
        let (x, y_pixel) = ((pixel % w) as u32, (pixel / w) as u32);
        let corner = Vec2::new(x as f32, y_pixel as f32);
        let mut rng = SampleStream::new(pass_seed, pass, pixel);
        let raster = corner + rng.next_2d();
        bdpt::sample_each(tracer, &capped, ws, raster, &mut rng, |s, t, l, splat| {
            let y = l.luminance();
            if s + t > 2 && y.is_finite() && y > 0.0 {
                sums[s + t - 2] += y as f64;
                if let Some(film) = image.as_deref_mut() {
                    match splat {
                        Some(r) => film.add_splat(r, l),
                        None => film.add_sample(x, y_pixel, l),
                    }
                }
            }
        });
        let mut rng = SampleStream::new(direct_seed, pass, pixel);
        for k in 0..DIRECT_GRID * DIRECT_GRID {
            let stratum = Vec2::new((k % DIRECT_GRID) as f32, (k / DIRECT_GRID) as f32);
            let raster = corner + (stratum + rng.next_2d()) * cell;
            bdpt::sample_each(tracer, &direct, ws, raster, &mut rng, |_, _, l, _| {
                let y = l.luminance();
                if y.is_finite() && y > 0.0 {
                    sums[0] += y as f64 * direct_weight;
                    if let Some(film) = image.as_deref_mut() {
                        film.add_sample(x, y_pixel, l * direct_weight as f32);
                    }
                }
            });
        }
    }
}

/// Adds one normalisation pass's per-depth sums to the running `sums`.
/// Passes evaluated apart (one per worker) and added in pass order give
/// the bootstrap bit for bit whatever the split.
pub(crate) fn add_pass(sums: &mut [f64], pass: &[f64]) {
    for (a, b) in sums.iter_mut().zip(pass) {
        *a += b;
    }
}

/// The bootstrap's result: b by depth and the bootstrap samples chains start
/// from.
#[derive(Clone, Debug, PartialEq)]
pub struct Bootstrap {
    seed: u64,
    depths: u32,
    per_depth: u32,
    /// Per depth, prefix sums of Y over that depth's bootstrap samples
    /// (depth-major: `cdf[(d − 1)·n + k]` for sample k·D + d − 1).
    cdf: Vec<f64>,
    /// b_d used for the image (from the passes, else from the bootstrap
    /// samples).
    depth_b: Vec<f64>,
    /// b_d as the bootstrap samples estimate it (pbrt's estimate).
    sample_depth_b: Vec<f64>,
    /// Prefix sums of the chain allocation q_d: b_d, times depth 1's
    /// factor for depth 1 (for [`Bootstrap::chain_depth_at`]).
    chain_cdf: Vec<f64>,
    b: f64,
}

impl Bootstrap {
    /// Number of bootstrap samples: `n_bootstrap` per path depth.
    pub fn sample_count(settings: &Settings, mlt: &MltSettings) -> u64 {
        mlt.n_bootstrap as u64 * depths(settings) as u64
    }

    /// An empty bootstrap (b = 0, no bootstrap samples) with room for the
    /// bootstrap of `settings` and `mlt`, so that [`Bootstrap::fill`]
    /// allocates nothing.
    pub fn with_capacity(settings: &Settings, mlt: &MltSettings) -> Self {
        let depths = depths(settings) as usize;
        Bootstrap {
            seed: 0,
            depths: depths as u32,
            per_depth: 0,
            cdf: Vec::with_capacity(Self::sample_count(settings, mlt) as usize),
            depth_b: Vec::with_capacity(depths),
            sample_depth_b: Vec::with_capacity(depths),
            chain_cdf: Vec::with_capacity(depths),
            b: 0.0,
        }
    }

    /// Builds the bootstrap, in this bootstrap's storage, from the target
    /// values of all bootstrap samples in index order (as
    /// `evaluate_samples` produces them, possibly in pieces) and the
    /// per-depth luminance sums of all
    /// [`MltSettings::normalisation_passes`] passes over `pixels` pixels
    /// (ignored when `b_passes` is 0: then b_d comes from the bootstrap
    /// samples, as in pbrt).
    ///
    /// # Panics
    /// When `values` does not hold [`Bootstrap::sample_count`] values or
    /// `pass_sums` has fewer than D entries while passes are used.
    pub fn fill(
        &mut self,
        settings: &Settings,
        mlt: &MltSettings,
        seed: u64,
        values: &[f32],
        pass_sums: &[f64],
        pixels: u64,
    ) {
        let depths = depths(settings) as usize;
        let n = mlt.n_bootstrap as usize;
        assert_eq!(
            values.len() as u64,
            Self::sample_count(settings, mlt),
            "bootstrap values missing"
        );
        // Regroup by depth: sample k·D + (d − 1) is the k-th of depth d.
        let Bootstrap {
            cdf,
            depth_b,
            sample_depth_b,
            chain_cdf,
            ..
        } = self;
        cdf.clear();
        cdf.resize(values.len(), 0.0);
        sample_depth_b.clear();
        sample_depth_b.resize(depths, 0.0);
        for d in 0..depths {
            let mut acc = 0.0f64;
            for k in 0..n {
                let y = values[k * depths + d];
                // `target()` never yields negative or NaN values; guard
                // host input all the same.
                acc += if y.is_finite() && y > 0.0 {
                    y as f64
                } else {
                    0.0
                };
                cdf[d * n + k] = acc;
            }
            sample_depth_b[d] = if n > 0 { acc / n as f64 } else { 0.0 };
        }
        depth_b.clear();
        let passes = mlt.normalisation_passes(pixels);
        if passes > 0 {
            assert!(pass_sums.len() >= depths, "pass sums missing");
            let norm = 1.0 / (passes as f64 * pixels.max(1) as f64);
            depth_b.extend(pass_sums[..depths].iter().map(|s| s * norm));
        } else {
            depth_b.extend_from_slice(sample_depth_b);
        }
        chain_cdf.clear();
        let b: f64 = depth_b.iter().sum();
        // Depth 1's factor (see the module docs): its share of the image
        // area (the bootstrap samples of depth 1 that see an emitter) over
        // its share of b, at least `direct_allocation`, at most 1.
        let seen = (0..n).filter(|&k| values[k * depths] > 0.0).count() as f64;
        let area = if n > 0 { seen / n as f64 } else { 1.0 };
        let b1 = depth_b.first().copied().unwrap_or(0.0);
        let direct = if b1 > 0.0 {
            (area * b / b1).clamp(f64::from(mlt.direct_allocation), 1.0)
        } else {
            1.0
        };
        let mut q = 0.0;
        for (d, &bd) in depth_b.iter().enumerate() {
            q += if d == 0 { bd * direct } else { bd };
            chain_cdf.push(q);
        }
        self.seed = seed;
        self.depths = depths as u32;
        self.per_depth = n as u32;
        self.b = b;
    }

    /// Estimated normalisation b = Σ_d b_d: the mean luminance of the
    /// image. 0 when nothing contributes (black scene).
    pub fn b(&self) -> f64 {
        self.b
    }

    /// b by path depth: `depth_b()[d − 1]` for depth d.
    pub fn depth_b(&self) -> &[f64] {
        &self.depth_b
    }

    /// b by path depth as the bootstrap samples estimate it (pbrt's estimate;
    /// equal to [`Bootstrap::depth_b`] without normalisation passes).
    pub fn sample_depth_b(&self) -> &[f64] {
        &self.sample_depth_b
    }

    /// The depth at position `u` ∈ [0, 1) of the chain allocation q_d / Q:
    /// q_d = b_d, except q_1 = [`MltSettings::direct_allocation`] · b_1
    /// (`None` when b = 0). The chains' systematic sample draws from this;
    /// `depth_weights` (parent module) then gives each depth its b_d.
    pub(crate) fn chain_depth_at(&self, u: f64) -> Option<u32> {
        let total = self.chain_cdf.last().copied().unwrap_or(0.0);
        if !(self.b > 0.0 && total > 0.0) {
            return None;
        }
        let i = self.chain_cdf.partition_point(|&c| c <= u * total);
        let i = if i < self.depths as usize {
            i
        } else {
            self.depth_b.iter().rposition(|&b| b > 0.0)?
        };
        Some(i as u32 + 1)
    }

    /// The share q_d / Q of the chains that depth `depth` is allocated
    /// ([`Bootstrap::chain_depth_at`]); 0 for a depth out of range or
    /// when nothing contributes.
    pub(crate) fn chain_share(&self, depth: u32) -> f64 {
        let total = self.chain_cdf.last().copied().unwrap_or(0.0);
        let d = depth as usize;
        if d == 0 || d > self.chain_cdf.len() || !(total > 0.0) {
            return 0.0;
        }
        let below = if d >= 2 { self.chain_cdf[d - 2] } else { 0.0 };
        (self.chain_cdf[d - 1] - below) / total
    }

    /// The bootstrap sample a chain of `depth` starts from, with probability
    /// Y_i / Σ_{depth} Y for a uniform `u` ∈ [0, 1); uniformly among the
    /// depth's samples when all of them are zero (the chain then starts on
    /// a zero-contribution path and takes the first proposal that is not).
    /// `None` without bootstrap samples.
    pub(crate) fn pick(&self, depth: u32, u: f64) -> Option<u64> {
        let n = self.per_depth as usize;
        if n == 0 || depth == 0 || depth > self.depths {
            return None;
        }
        let d = depth as usize - 1;
        let cdf = &self.cdf[d * n..(d + 1) * n];
        let total = cdf[n - 1];
        let k = if total > 0.0 {
            // First k with cdf[k] > u·total: zero-weight samples (cdf equal
            // to their predecessor's) are never chosen.
            cdf.partition_point(|&c| c <= u * total).min(n - 1)
        } else {
            ((u * n as f64) as usize).min(n - 1)
        };
        Some(k as u64 * self.depths as u64 + d as u64)
    }

    /// Whether some bootstrap sample of `depth` contributes, so that a
    /// chain of that depth starts from one of them on the target's
    /// support.
    pub fn has_contributing_sample(&self, depth: u32) -> bool {
        let n = self.per_depth as usize;
        n > 0 && depth >= 1 && depth <= self.depths && self.cdf[depth as usize * n - 1] > 0.0
    }

    /// Index of the `j`-th sample of `depth` past the bootstrap's own: a
    /// bootstrap sample of that depth by the index layout (sample i has
    /// depth 1 + i mod D) and for [`Bootstrap::seed_of`]. Chains search these when none of their
    /// depth's bootstrap samples contributes. Distinct for distinct `j` below
    /// 2⁴⁸ (indices wrap beyond).
    pub(crate) fn extra_sample(&self, depth: u32, j: u64) -> u64 {
        let d = self.depths.max(1) as u64;
        (self.per_depth as u64).wrapping_add(j).wrapping_mul(d) + (depth.max(1) as u64 - 1) % d
    }

    /// Seed of bootstrap sample `index` (see [`sample_seed`]).
    pub(crate) fn seed_of(&self, index: u64) -> u64 {
        sample_seed(self.seed, index)
    }
}

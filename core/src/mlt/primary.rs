//! The primary-sample-space state of one Metropolis chain (Kelemen,
//! Szirmay-Kalos, Antal, Csonka 2002), laid out like pbrt-v4's `MLTSampler`.
//!
//! A path is a deterministic function of an infinite vector X of numbers in
//! [0, 1). The chain proposes a new X either by a *large step* (every
//! coordinate redrawn uniformly: an independent sample, which keeps the
//! chain ergodic) or a *small step* (every coordinate moved by a Gaussian of
//! width σ, wrapped around [0, 1)). Both proposals are symmetric, so the
//! Metropolis–Hastings acceptance is min(1, Y(new)/Y(current)).
//!
//! Laziness: only the coordinates an evaluation reads exist. Each remembers
//! the iteration it was last brought up to date; when it is read again `n`
//! accepted iterations later, the `n` skipped small steps are applied at
//! once as one Gaussian of width σ·√n (a sum of n independent N(0, σ²) is
//! N(0, nσ²), and wrapping commutes with addition mod 1); if a large step
//! was accepted in the meantime it is first redrawn uniformly. Rejected
//! iterations do not count: [`PrimarySampler::reject`] restores the touched
//! coordinates and steps the iteration counter back.
//!
//! Streams: coordinate `i` of stream `k` is X[k + 3 i] ([`STREAM_COUNT`]
//! interleaved streams), so the camera subpath's coordinates stay where
//! they are when the light subpath grows or shrinks.
//!
//! Memory: X and the backups of the coordinates touched in the current
//! iteration grow to the largest dimension ever read and are then reused:
//! a mutation allocates nothing once the chain has warmed up. A coordinate
//! of X is 16 bytes (its value and iteration); the backups live only in
//! the touched list (Tungsten's `MetropolisSampler` keeps them on a stack
//! the same way), which halved X against backups kept in every coordinate:
//! X is what a round of mutations over hundreds of chains reads from
//! beyond the L1 and L2 caches.

use alloc::vec::Vec;

use rand_core::Rng;
use rand_pcg::Pcg32;

use crate::math::PI;
use crate::sampler::{STREAM_COUNT, Sampler, mix64};

/// pbrt's default small-step width σ (in units of the unit interval).
pub(crate) const DEFAULT_SIGMA: f32 = 0.01;
/// pbrt's default probability of a large step. Tungsten's multiplexed
/// MLT uses 0.1, which gave 1.2× less error per mutation on its Cornell
/// box but 1.3× more on veach-ajar, whose light is found by large steps
/// (`docs/accuracy.md`, "Level 1 against Tungsten's MMLT").
pub(crate) const DEFAULT_LARGE_STEP_PROB: f32 = 0.3;

/// One coordinate of X with what is needed to bring it up to date lazily.
#[derive(Clone, Copy, Debug, Default)]
struct Coord {
    value: f32,
    /// Iteration whose state `value` represents; 0 = never drawn (which is
    /// older than any large step, so the first read draws it uniformly).
    modified: u64,
}

/// A coordinate's state before the current iteration changed it: what
/// [`PrimarySampler::reject`] restores.
#[derive(Clone, Copy, Debug)]
struct Backup {
    index: u32,
    coord: Coord,
}

/// Primary-sample-space state of one chain: the vector X, its mutation
/// random stream and the iteration bookkeeping.
///
/// Life cycle: after [`PrimarySampler::new`] the sampler is in iteration 1,
/// a large step, so the first evaluation reads an independent uniform X.
/// A chain then calls [`PrimarySampler::accept`] to make that its current
/// state, and for every mutation [`PrimarySampler::start_iteration`],
/// evaluates through the [`Sampler`] methods, and ends the iteration with
/// [`PrimarySampler::accept`] or [`PrimarySampler::reject`].
#[derive(Clone, Debug)]
pub(crate) struct PrimarySampler {
    x: Vec<Coord>,
    /// The coordinates of X brought up to date in the current iteration,
    /// with their states before (what `reject` restores), reused across
    /// iterations.
    touched: Vec<Backup>,
    rng: Pcg32,
    sigma: f32,
    large_step_prob: f32,
    /// Current iteration (≥ 1).
    iteration: u64,
    /// Last iteration whose large step was accepted (0: none yet).
    last_large_step: u64,
    large_step: bool,
    stream: u32,
    stream_index: u32,
    /// Second normal deviate of the last Box–Muller pair, if unused.
    spare_normal: Option<f32>,
    /// Between `begin_replay` and `end_replay`: reads return the current
    /// state instead of mutating it.
    replaying: bool,
}

impl PrimarySampler {
    /// A sampler whose X and mutations come from the PCG stream of `seed`,
    /// with small-step width `sigma` and large-step probability
    /// `large_step_prob` (both clamped to sensible ranges: σ ∈ (0, 1],
    /// p ∈ [0, 1]). It starts in iteration 1, a large step.
    pub fn new(seed: u64, sigma: f32, large_step_prob: f32) -> Self {
        let sigma = if sigma > 0.0 {
            sigma.min(1.0)
        } else {
            DEFAULT_SIGMA
        };
        let large_step_prob = if large_step_prob >= 0.0 {
            large_step_prob.min(1.0)
        } else {
            DEFAULT_LARGE_STEP_PROB
        };
        PrimarySampler {
            x: Vec::new(),
            touched: Vec::new(),
            rng: pcg(seed),
            sigma,
            large_step_prob,
            iteration: 1,
            last_large_step: 0,
            large_step: true,
            stream: 0,
            stream_index: 0,
            spare_normal: None,
            replaying: false,
        }
    }

    /// [`PrimarySampler::new`] with room for every coordinate a BDPT
    /// strategy of path depth up to `depth` reads
    /// ([`PrimarySampler::dimensions_for_depth`]): mutations and restarts
    /// then never allocate.
    pub fn with_capacity(seed: u64, sigma: f32, large_step_prob: f32, depth: u32) -> Self {
        let mut s = Self::new(seed, sigma, large_step_prob);
        let n = Self::dimensions_for_depth(depth);
        s.x.reserve_exact(n);
        s.touched.reserve_exact(n);
        s
    }

    /// An upper bound of the coordinates of X that one evaluation of
    /// `bdpt::sample_strategy` at path depth ≤ `depth` reads: per stream,
    /// at most 4 per vertex (lobe, 2-D direction, roulette) plus the
    /// subpath's start (raster, strategy, lens: 5; light: 5; connection:
    /// 3), interleaved over the three streams.
    pub fn dimensions_for_depth(depth: u32) -> usize {
        STREAM_COUNT as usize * (4 * (depth as usize + 1) + 8)
    }

    /// Returns to the state of [`PrimarySampler::new`]`(seed, …)` with the
    /// same σ and large-step probability, keeping the buffers (the
    /// bootstrap evaluates many independent samples with one sampler).
    pub fn restart(&mut self, seed: u64) {
        self.x.clear();
        self.touched.clear();
        self.rng = pcg(seed);
        self.iteration = 1;
        self.last_large_step = 0;
        self.large_step = true;
        self.stream = 0;
        self.stream_index = 0;
        self.spare_normal = None;
    }

    /// Replaces the mutation random stream, keeping X. Chains started from
    /// the same bootstrap sample (which reproduce its X from its seed)
    /// diverge after this.
    pub fn reseed(&mut self, seed: u64) {
        self.rng = pcg(seed);
        self.spare_normal = None;
    }

    /// Whether the current iteration is a large step.
    pub fn is_large_step(&self) -> bool {
        self.large_step
    }

    /// Current iteration number (counts accepted iterations plus the
    /// current one).
    pub fn iteration(&self) -> u64 {
        self.iteration
    }

    /// Starts re-reading the current state X, for evaluating the target at
    /// it again after the camera or scene changed (a kept chain across
    /// frames). Until [`PrimarySampler::end_replay`], every read brings its
    /// coordinate up to the current state — the pending small steps of
    /// accepted iterations, or a fresh uniform after an accepted large
    /// step, drawn now exactly as a later read would draw them — and
    /// returns it without proposing a mutation.
    pub fn begin_replay(&mut self) {
        self.replaying = true;
        self.touched.clear();
        self.stream = 0;
        self.stream_index = 0;
    }

    /// Ends [`PrimarySampler::begin_replay`]; the chain continues from the
    /// same state.
    pub fn end_replay(&mut self) {
        self.replaying = false;
    }

    /// Begins a mutation: decides large or small step with the large-step
    /// probability.
    pub fn start_iteration(&mut self) {
        let large_step = self.uniform() < self.large_step_prob;
        self.start_iteration_with(large_step);
    }

    /// Begins a mutation of the given kind (what the tests schedule).
    fn start_iteration_with(&mut self, large_step: bool) {
        self.iteration += 1;
        self.touched.clear();
        self.large_step = large_step;
    }

    /// Keeps the proposal as the current state.
    pub fn accept(&mut self) {
        if self.large_step {
            self.last_large_step = self.iteration;
        }
        self.touched.clear();
    }

    /// Discards the proposal: restores every coordinate read in this
    /// iteration and forgets the iteration, so that lazily skipped
    /// iterations count accepted states only.
    pub fn reject(&mut self) {
        for b in &self.touched {
            self.x[b.index as usize] = b.coord;
        }
        self.touched.clear();
        self.iteration -= 1;
    }

    /// A uniform number in [0, 1) from the mutation stream (24 bits, like
    /// [`crate::sampler::SampleStream`]).
    #[inline]
    fn uniform(&mut self) -> f32 {
        (self.rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// A standard normal deviate (Box–Muller; the pair's second value is
    /// kept for the next call). Marsaglia's polar method (no sine or
    /// cosine) was tried: it converged measurably slower on the
    /// lights-punctual test scene at 12×12 (relMSE 0.0226 against 0.0185
    /// at 1024 mutations per pixel, seeds 1–4), not understood; Box–Muller
    /// stays until that is.
    fn normal(&mut self) -> f32 {
        if let Some(z) = self.spare_normal.take() {
            return z;
        }
        // 1 − u ∈ (0, 1]: the logarithm stays finite.
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        let r = libm::sqrtf(-2.0 * libm::logf(u1));
        let (s, c) = libm::sincosf(2.0 * PI * u2);
        self.spare_normal = Some(r * s);
        r * c
    }

    /// σ·√n: the width of n small steps applied at once.
    #[inline]
    fn width(&self, n: u64) -> f32 {
        if n == 1 {
            self.sigma
        } else {
            self.sigma * libm::sqrtf(n as f32)
        }
    }

    /// Brings coordinate `index` up to date for the current iteration
    /// (pbrt-v4's `EnsureReady`) and returns it.
    fn coordinate(&mut self, index: usize) -> f32 {
        if index >= self.x.len() {
            self.x.resize(index + 1, Coord::default());
        }
        let c = self.x[index];
        if c.modified == self.iteration {
            // Already read in this iteration (a stream restarted): the same
            // number again, not a second mutation.
            return c.value;
        }
        let mut c = c;
        // A large step was accepted since this coordinate was last drawn:
        // in the accepted state it is a fresh uniform number.
        if c.modified < self.last_large_step {
            c.value = self.uniform();
            c.modified = self.last_large_step;
        }
        if self.replaying {
            // The current state is iteration `self.iteration` (no
            // iteration is open): apply the small steps of the accepted
            // iterations since the coordinate was drawn, and nothing more.
            let n = self.iteration - c.modified;
            if n > 0 {
                let v = c.value + self.normal() * self.width(n);
                c.value = wrap01(v);
                c.modified = self.iteration;
            }
            self.x[index] = c;
            return c.value;
        }
        self.touched.push(Backup {
            index: index as u32,
            coord: c,
        });
        if self.large_step {
            c.value = self.uniform();
        } else {
            // The small steps of all accepted iterations since the last
            // update, at once: N(0, σ²·n), wrapped into [0, 1).
            let n = self.iteration - c.modified;
            let v = c.value + self.normal() * self.width(n);
            c.value = wrap01(v);
        }
        c.modified = self.iteration;
        self.x[index] = c;
        c.value
    }
}

/// `v` mod 1 in [0, 1). `v − floor(v)` can round up to exactly 1 for tiny
/// negative `v`; that point is 0 on the circle.
#[inline]
pub(crate) fn wrap01(v: f32) -> f32 {
    let w = v - libm::floorf(v);
    if w < 1.0 { w } else { 0.0 }
}

fn pcg(seed: u64) -> Pcg32 {
    Pcg32::new(mix64(seed), mix64(seed ^ 0x5851_F42D_4C95_7F2D))
}

impl Sampler for PrimarySampler {
    #[inline]
    fn next_f32(&mut self) -> f32 {
        let index = self.stream + STREAM_COUNT * self.stream_index;
        self.stream_index += 1;
        self.coordinate(index as usize)
    }

    #[inline]
    fn start_stream(&mut self, index: u32) {
        debug_assert!(index < STREAM_COUNT, "stream {index} out of range");
        self.stream = index.min(STREAM_COUNT - 1);
        self.stream_index = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::{CAMERA_STREAM, LIGHT_STREAM};

    /// Wrapped displacement b − a mapped to [−½, ½).
    fn delta(a: f32, b: f32) -> f32 {
        let d = wrap01(b - a + 0.5);
        d - 0.5
    }

    /// Two-sample Kolmogorov–Smirnov statistic.
    fn ks(mut a: Vec<f32>, mut b: Vec<f32>) -> f64 {
        a.sort_by(f32::total_cmp);
        b.sort_by(f32::total_cmp);
        let (mut i, mut j, mut d) = (0usize, 0usize, 0.0f64);
        while i < a.len() && j < b.len() {
            let x = a[i].min(b[j]);
            while i < a.len() && a[i] <= x {
                i += 1;
            }
            while j < b.len() && b[j] <= x {
                j += 1;
            }
            let fa = i as f64 / a.len() as f64;
            let fb = j as f64 / b.len() as f64;
            d = d.max((fa - fb).abs());
        }
        d
    }

    /// KS critical value at α ≈ 10⁻⁴ (c(α) = 2.15) for samples of n and m.
    fn ks_crit(n: usize, m: usize) -> f64 {
        2.15 * ((n + m) as f64 / (n * m) as f64).sqrt()
    }

    /// One small step of a single coordinate starting at `x0`: the wrapped
    /// displacement.
    fn small_step_from(x0: f32, seed: u64, sigma: f32) -> f32 {
        let mut s = PrimarySampler::new(seed, sigma, 0.0);
        s.x.push(Coord {
            value: x0,
            modified: 1,
        });
        s.accept();
        s.start_iteration_with(false);
        s.start_stream(CAMERA_STREAM);
        let y = s.next_f32();
        assert!((0.0..1.0).contains(&y));
        delta(x0, y)
    }

    #[test]
    fn small_step_is_symmetric_and_translation_invariant() {
        // T(x→y) = T(y→x) for a kernel that depends on the wrapped
        // difference y − x only and is even in it. Check both: the
        // displacement has the same law at the boundary as in the middle
        // (a clamping or reflecting kernel fails here) and d ~ −d.
        let n = 20_000;
        let sigma = 0.05;
        let mid: Vec<f32> = (0..n).map(|i| small_step_from(0.5, i, sigma)).collect();
        let edge: Vec<f32> = (0..n)
            .map(|i| small_step_from(0.002, 1_000_000 + i, sigma))
            .collect();
        let neg: Vec<f32> = mid.iter().map(|d| -d).collect();
        let crit = ks_crit(n as usize, n as usize);
        assert!(ks(mid.clone(), edge.clone()) < crit, "edge differs");
        assert!(ks(mid.clone(), neg) < crit, "not even");
        let mean = mid.iter().map(|&d| d as f64).sum::<f64>() / n as f64;
        let var = mid.iter().map(|&d| (d as f64).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 4.0 * sigma as f64 / (n as f64).sqrt());
        assert!(
            (var.sqrt() / sigma as f64 - 1.0).abs() < 0.03,
            "sd {}",
            var.sqrt()
        );
        // Power check: a clamped kernel at the edge is detectably different.
        let clamped: Vec<f32> = edge
            .iter()
            .map(|&d| (0.002 + d).clamp(0.0, 0.999_999) - 0.002)
            .collect();
        assert!(ks(mid, clamped) > crit, "the test cannot see clamping");
    }

    /// Value of coordinate 1 (camera stream, dimension 1) after `k` accepted
    /// small-step iterations, read lazily (only at the end) or stepwise
    /// (every iteration). Coordinate 0 is read every iteration in both.
    fn after_k_steps(seed: u64, k: u32, stepwise: bool) -> f32 {
        let mut s = PrimarySampler::new(seed, 0.03, 0.0);
        s.start_stream(CAMERA_STREAM);
        let _ = s.next_f32();
        let x0 = s.next_f32();
        s.accept();
        let mut last = x0;
        for it in 0..k {
            s.start_iteration_with(false);
            s.start_stream(CAMERA_STREAM);
            let _ = s.next_f32();
            if stepwise || it + 1 == k {
                last = s.next_f32();
            }
            // Interleave rejections: they must not count as steps.
            if it % 3 == 1 {
                s.accept();
                s.start_iteration_with(false);
                s.start_stream(CAMERA_STREAM);
                let _ = s.next_f32();
                let _ = s.next_f32();
                s.reject();
            } else {
                s.accept();
            }
        }
        delta(x0, last)
    }

    #[test]
    fn lazy_catch_up_matches_stepwise_mutation() {
        let n = 20_000;
        let k = 9;
        let lazy: Vec<f32> = (0..n).map(|i| after_k_steps(i, k, false)).collect();
        let step: Vec<f32> = (0..n)
            .map(|i| after_k_steps(500_000 + i, k, true))
            .collect();
        let crit = ks_crit(n as usize, n as usize);
        let d = ks(lazy.clone(), step.clone());
        assert!(d < crit, "lazy vs stepwise KS {d} >= {crit}");
        // Both have standard deviation σ√k (σ√9 = 0.09, far from wrapping).
        for v in [&lazy, &step] {
            let var = v.iter().map(|&d| (d as f64).powi(2)).sum::<f64>() / n as f64;
            assert!((var.sqrt() / 0.09 - 1.0).abs() < 0.03, "sd {}", var.sqrt());
        }
        // Power check: catching up with σ·n instead of σ·√n is detected.
        let wrong: Vec<f32> = lazy.iter().map(|d| d * 3.0).collect();
        assert!(ks(wrong, step) > crit);
    }

    #[test]
    fn reject_restores_bits() {
        let mut s = PrimarySampler::new(3, 0.01, 0.0);
        let read = |s: &mut PrimarySampler| -> [f32; 4] {
            s.start_stream(CAMERA_STREAM);
            let a = s.next_f32();
            let b = s.next_f32();
            s.start_stream(LIGHT_STREAM);
            [a, b, s.next_f32(), s.next_f32()]
        };
        let x = read(&mut s);
        s.accept();
        s.start_iteration_with(false);
        let y = read(&mut s);
        assert_ne!(x, y);
        assert!(x.iter().zip(&y).all(|(a, b)| delta(*a, *b).abs() < 0.1));
        s.reject();
        s.start_iteration_with(true);
        let _ = read(&mut s);
        s.reject();
        // Camera k lives at 3k, light k at 3k + 1.
        assert_eq!(s.x.len(), 5);
        let stored = [s.x[0].value, s.x[3].value, s.x[1].value, s.x[4].value];
        assert_eq!(stored.map(f32::to_bits), x.map(f32::to_bits));
        assert_eq!(s.iteration(), 1);
    }

    #[test]
    fn accepted_large_step_refreshes_unread_coordinates() {
        // Coordinate light 0 is not read in the accepted large step; read
        // afterwards it must be a fresh uniform number, not a small step
        // away from its old value.
        let mut far = 0;
        for seed in 0..400 {
            let mut s = PrimarySampler::new(seed, 0.001, 0.0);
            s.start_stream(LIGHT_STREAM);
            let old = s.next_f32();
            s.accept();
            s.start_iteration_with(true);
            s.start_stream(CAMERA_STREAM);
            let _ = s.next_f32();
            s.accept();
            s.start_iteration_with(false);
            s.start_stream(LIGHT_STREAM);
            let new = s.next_f32();
            far += (delta(old, new).abs() > 0.05) as u32;
        }
        // Uniform: P(|Δ| > 0.05) = 0.9; without the refresh it is 0.
        assert!(far > 300, "{far}/400");
    }

    #[test]
    fn streams_keep_camera_dimensions_in_place() {
        // A small step in which the light subpath reads more dimensions
        // (and reads them first) leaves every camera dimension a small step
        // from where it was: nothing shifted.
        let mut s = PrimarySampler::new(9, 0.001, 0.0);
        let read = |s: &mut PrimarySampler, light_dims: usize| -> [f32; 4] {
            s.start_stream(LIGHT_STREAM);
            for _ in 0..light_dims {
                let _ = s.next_f32();
            }
            s.start_stream(CAMERA_STREAM);
            [(); 4].map(|_| s.next_f32())
        };
        let before = read(&mut s, 2);
        s.accept();
        for (k, &v) in before.iter().enumerate() {
            assert_eq!(s.x[3 * k].value, v);
        }
        s.start_iteration_with(false);
        let after = read(&mut s, 7);
        for (k, (&b, &a)) in before.iter().zip(&after).enumerate() {
            assert!(delta(b, a).abs() < 0.01, "camera {k} moved");
        }
    }

    #[test]
    fn no_allocation_after_warm_up() {
        let mut s = PrimarySampler::new(1, 0.01, 0.3);
        let run = |s: &mut PrimarySampler| {
            for st in 0..3 {
                s.start_stream(st);
                for _ in 0..20 {
                    let _ = s.next_f32();
                }
            }
        };
        run(&mut s);
        s.accept();
        let caps = (s.x.capacity(), s.touched.capacity());
        for i in 0..1000 {
            s.start_iteration();
            run(&mut s);
            if i % 2 == 0 { s.accept() } else { s.reject() }
        }
        assert_eq!(caps, (s.x.capacity(), s.touched.capacity()));
    }
}

//! The level-1 Metropolis–Hastings chain in primary sample space (Kelemen
//! et al. 2002; Veach 1997, §11.3), with expected-value splatting.
//!
//! The chain's target density is p(u) = Y(f(u)), the luminance of the
//! contribution of primary sample u. Proposals come from the chain's
//! [`PrimarySampler`] (large or small step, both symmetric), so a proposal
//! u′ is accepted with probability a = min(1, Y(u′)/Y(u)).
//!
//! Splatting: instead of recording only the state after accept/reject, each
//! mutation records both candidates with their expected weights — the
//! proposal with a, the current state with 1 − a (Veach 1997, §11.3.4;
//! pbrt's MLT). Each is recorded as f/Y, the colour scaled to unit
//! luminance, so one mutation adds exactly one unit of luminance to the
//! image. The histogram of N mutations therefore estimates (N/b)·I, and the
//! caller multiplies by b/N (times the pixel count, see
//! [`super::image_scale`]).
//!
//! Large steps combined by multiple importance sampling (Kelemen et al.
//! 2002, §4.1; Mitsuba 0.6's PSSMLT `kelemenStyleWeights`), optional: a
//! large step's proposal is also an independent uniform sample of f, drawn
//! with probability p per mutation, so the records form two estimators of
//! the image: the chain's (density Y/b per mutation) and the large steps'
//! (density p). Balance-heuristic weights over both give the proposal
//! f·(a + [large])/(Y(y) + p·b) and the current state f·(1 − a)/(Y(x) +
//! p·b), in the same units as f·a/Y (records times b/N). Per point z, the
//! chain's expected records (Y/b)·f/(Y + p·b) and the large steps' p·f/(Y +
//! p·b) add to f/b, what the plain records give: the expectation is the
//! same, and pixels the chain rarely visits get the large steps' samples.
//! A record's luminance is then no longer its weight.
//!
//! The chain is independent of what it samples: the target is any function
//! of the sampler ([`Chain::step`] takes it as a closure), so tests can run
//! it on toy densities and level 2 can build on it.

use glam::Vec2;
use rand_core::Rng;
use rand_pcg::Pcg32;

use super::primary::PrimarySampler;
use crate::math::Rgb;
use crate::sampler::mix64;

/// A path as the chain sees it: contribution f and where it lands.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct PathSample {
    /// Contribution f(u) (radiance-like, already divided by the sampling
    /// probabilities of the estimator that produced it).
    pub l: Rgb,
    /// Continuous raster position of the contribution.
    pub raster: Vec2,
    /// The strategy's light-subpath vertex count s (0 where the target
    /// has no strategies): what tells a small step that changed the
    /// technique ([`Step::technique_change`]).
    pub strategy: u32,
}

impl PathSample {
    /// The target density Y(f) = luminance of the contribution; 0 for
    /// non-finite or non-positive values, which the chain never accepts.
    #[inline]
    pub fn target(&self) -> f32 {
        let y = self.l.luminance();
        if y.is_finite() && y > 0.0 && self.l.is_finite() {
            y
        } else {
            0.0
        }
    }
}

/// A weighted record for the film: `value` (colour of unit luminance times
/// the splat weight) at `raster`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Splat {
    /// Continuous raster position.
    pub raster: Vec2,
    /// w · f / Y(f), luminance exactly w; with large steps combined by
    /// MIS, w · f / (Y(f) + p·b).
    pub value: Rgb,
}

/// What one mutation did and what it records.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Step {
    /// The proposal with weight a (absent when a = 0).
    pub proposal: Option<Splat>,
    /// The current state with weight 1 − a (absent when a = 1, or when the
    /// current state has zero contribution).
    pub current: Option<Splat>,
    /// Acceptance probability a = min(1, Y(proposal) / Y(current)).
    pub acceptance: f32,
    /// Whether the proposal became the current state.
    pub accepted: bool,
    /// Whether the proposal was a large step.
    pub large: bool,
    /// Whether the proposal was a small step to another strategy (s, t)
    /// than the current state's.
    pub technique_change: bool,
    /// Whether the proposal had zero (or non-finite) contribution.
    pub zero: bool,
    /// The proposal's target value Y (0 when `zero`): for a large step,
    /// an independent sample of the chain's normalisation
    /// (`mlt/large_steps.rs`).
    pub proposal_target: f32,
}

/// One Metropolis–Hastings chain: its primary-sample state, the current
/// path and the random stream of its accept/reject decisions.
///
/// Invariant: `current` is the evaluation of the sampler's current
/// (accepted) state and `current_y` its target value; `current_y > 0`
/// except for a chain started on a zero-contribution path, which then
/// accepts its first proposal unconditionally (a = 1).
#[derive(Clone, Debug)]
pub(crate) struct Chain {
    sampler: PrimarySampler,
    rng: Pcg32,
    current: PathSample,
    current_y: f32,
}

impl Chain {
    /// Starts a chain at the state `sampler` has just been evaluated at
    /// (`initial`, read in its current iteration), which it accepts. The
    /// accept/reject decisions use the PCG stream of `seed`.
    pub fn new(mut sampler: PrimarySampler, initial: PathSample, seed: u64) -> Self {
        sampler.accept();
        Chain {
            sampler,
            rng: Pcg32::new(mix64(seed ^ 0xC4A1_0000), mix64(seed)),
            current: initial,
            current_y: initial.target(),
        }
    }

    /// Evaluates the target again at the current state (after the camera or
    /// the scene changed) and makes that the current path: the chain goes
    /// on from the same primary-sample point, under the new target. A state
    /// whose contribution became zero moves to the next proposal that has
    /// one.
    pub fn reevaluate(&mut self, eval: impl FnOnce(&mut PrimarySampler) -> PathSample) {
        self.sampler.begin_replay();
        let s = eval(&mut self.sampler);
        self.sampler.end_replay();
        self.current = s;
        self.current_y = s.target();
    }

    /// Starts the chain afresh, as [`Chain::new`] with a sampler restarted
    /// at the primary point of `start_seed` and then reseeded, evaluated by
    /// `eval`; the accept/reject stream comes from `seed`. Keeps the
    /// sampler's storage.
    pub fn restart(
        &mut self,
        start_seed: u64,
        seed: u64,
        eval: impl FnOnce(&mut PrimarySampler) -> PathSample,
    ) {
        self.sampler.restart(start_seed);
        let initial = eval(&mut self.sampler);
        self.sampler.reseed(mix64(seed ^ 2));
        self.sampler.accept();
        self.rng = Pcg32::new(mix64(seed ^ 0xC4A1_0000), mix64(seed));
        self.current = initial;
        self.current_y = initial.target();
    }

    /// Ends the chain, handing back its sampler (whose buffers a new chain
    /// can reuse after [`PrimarySampler::restart`]).
    pub fn into_sampler(self) -> PrimarySampler {
        self.sampler
    }

    /// The current path.
    pub fn current(&self) -> PathSample {
        self.current
    }

    /// The primary-sample state.
    pub fn sampler(&self) -> &PrimarySampler {
        &self.sampler
    }

    /// The accept/reject stream, from which every step draws once
    /// (accepted or not): how tests tell a chain that was stepped.
    #[cfg(test)]
    pub fn decision_stream(&self) -> &Pcg32 {
        &self.rng
    }

    /// One mutation: proposes (large or small step), evaluates the proposal
    /// with `eval`, accepts it with probability a = min(1, Y′/Y) and
    /// returns both weighted records (expected-value splatting). With
    /// `large_step_offset` = Some(p·b) (p the large-step probability, b
    /// the chain's normalisation), the records combine the large steps by
    /// MIS (module docs); `None` gives the plain records a and 1 − a.
    pub fn step(
        &mut self,
        eval: impl FnOnce(&mut PrimarySampler) -> PathSample,
        large_step_offset: Option<f32>,
    ) -> Step {
        self.sampler.start_iteration();
        let large = self.sampler.is_large_step();
        let proposal = eval(&mut self.sampler);
        let y_new = proposal.target();
        let technique_change = !large && proposal.strategy != self.current.strategy;
        let a = if y_new <= 0.0 {
            0.0
        } else if self.current_y <= 0.0 {
            // A zero-contribution current state (a chain started where
            // nothing is seen) moves to any proposal with contribution.
            1.0
        } else {
            (y_new / self.current_y).min(1.0)
        };
        let (proposal_weight, current_weight) = match large_step_offset {
            None => (a / y_new, (1.0 - a) / self.current_y),
            Some(pb) => (
                (a + if large { 1.0 } else { 0.0 }) / (y_new + pb),
                (1.0 - a) / (self.current_y + pb),
            ),
        };
        // A large step's proposal is recorded even if a = 0 by underflow.
        let proposal_splat = (y_new > 0.0 && (a > 0.0 || large && large_step_offset.is_some()))
            .then(|| Splat {
                raster: proposal.raster,
                value: proposal.l * proposal_weight,
            });
        let current_splat = (a < 1.0 && self.current_y > 0.0).then(|| Splat {
            raster: self.current.raster,
            value: self.current.l * current_weight,
        });
        // a = 1 always accepts (u < 1), a = 0 never does.
        let u = (self.rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0);
        let accepted = u < a;
        if accepted {
            self.sampler.accept();
            self.current = proposal;
            self.current_y = y_new;
        } else {
            self.sampler.reject();
        }
        Step {
            proposal: proposal_splat,
            current: current_splat,
            acceptance: a,
            accepted,
            large,
            technique_change,
            zero: y_new <= 0.0,
            proposal_target: y_new,
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::sampler::{CAMERA_STREAM, Sampler};

    /// A toy target on the unit square with a known density (∝ 1 + 3x +
    /// 8·[y > 0.75]) and colour that changes across it; the chain's
    /// splatted histogram, normalised by the exact b, must match it. Also
    /// the large-step tally's test target (`large_steps.rs`).
    pub(in crate::mlt) fn toy(s: &mut PrimarySampler) -> PathSample {
        s.start_stream(CAMERA_STREAM);
        let u = s.next_2d();
        let y = 1.0 + 3.0 * u.x + if u.y > 0.75 { 8.0 } else { 0.0 };
        // Luminance of (1, 1, 1) is 1 up to rounding: scale to exactly y.
        let l = Rgb::new(2.0, 1.0, 0.5);
        PathSample {
            l: l * (y / l.luminance()),
            raster: u * 4.0,
            strategy: 0,
        }
    }

    /// The toy's normalisation b = ∫Y = 1 + 1.5 + 2.
    const TOY_B: f64 = 4.5;
    /// The toy chains' large-step probability.
    const TOY_LARGE: f32 = 0.2;

    /// The splatted histogram of 64 toy chains of 20 000 mutations, each
    /// stepped with `large_step_offset`, normalised by the exact b;
    /// `drop_current` leaves out the current states' records.
    fn run_toy(drop_current: bool, large_step_offset: Option<f32>) -> [f64; 16] {
        let n_chains = 64;
        let steps = 20_000;
        let mut hist = [0.0f64; 16];
        for c in 0..n_chains {
            let mut s = PrimarySampler::new(c, 0.05, TOY_LARGE);
            let init = toy(&mut s);
            let mut chain = Chain::new(s, init, 1000 + c);
            for _ in 0..steps {
                let st = chain.step(toy, large_step_offset);
                let rec: &[Option<Splat>] = if drop_current {
                    &[st.proposal]
                } else {
                    &[st.proposal, st.current]
                };
                for sp in rec.iter().flatten() {
                    let (i, j) = (sp.raster.x as usize, sp.raster.y as usize);
                    hist[j * 4 + i] += sp.value.luminance() as f64;
                }
            }
        }
        let n = (n_chains * steps) as f64;
        hist.map(|h| h * TOY_B / n * 16.0)
    }

    /// Cell (i, j) of the 4×4 grid: mean of 1 + 3x + 8[y > ¾] over it.
    fn toy_cell(i: usize, j: usize) -> f64 {
        1.0 + 3.0 * (i as f64 + 0.5) / 4.0 + if j == 3 { 8.0 } else { 0.0 }
    }

    fn assert_matches_toy(hist: &[f64; 16], what: &str) {
        for j in 0..4 {
            for i in 0..4 {
                let (h, e) = (hist[j * 4 + i], toy_cell(i, j));
                assert!(
                    (h - e).abs() / e < 0.03,
                    "{what}: cell ({i},{j}): {h} vs {e}"
                );
            }
        }
    }

    #[test]
    fn toy_target_histogram_matches_density() {
        assert_matches_toy(&run_toy(false, None), "expected values");
        // Negative control: without the (1 − a) records the total is short.
        let short = run_toy(true, None);
        let total: f64 = short.iter().sum::<f64>() / 16.0;
        assert!(
            total < 0.9 * TOY_B,
            "dropping current-state splats went unnoticed: {total}"
        );
    }

    #[test]
    fn large_steps_combined_by_mis_match_the_density() {
        let offset = TOY_LARGE * TOY_B as f32;
        assert_matches_toy(&run_toy(false, Some(offset)), "large steps by MIS");
        // Negative controls: the large steps' records counted without
        // their density p·b in the denominator add p·b to every cell's
        // mean (1 + p in total); an offset from a b twice too large scales
        // a cell by (Y + p·b)/(Y + 2p·b), −28 % in cell (0, 0), Y ≈ 1.4.
        let bright = run_toy(false, Some(0.0));
        let total: f64 = bright.iter().sum::<f64>() / 16.0;
        assert!(
            total > 1.1 * TOY_B,
            "large steps without their density went unnoticed: {total}"
        );
        let dark = run_toy(false, Some(2.0 * offset))[0];
        assert!(
            dark < 0.85 * toy_cell(0, 0),
            "an offset from the wrong b went unnoticed: {dark}"
        );
    }

    #[test]
    fn technique_changes_are_small_steps_to_another_strategy() {
        // The toy with four "strategies" across x: a small step changes
        // the strategy when it crosses one of the four quarter boundaries
        // of the circle, each with probability ≈ E|Δ| = σ·√(2/π) ≈ 0.04
        // times the density there (≈ 1): about 16 % of small steps; a
        // large step never counts. A flag never set (rate 0) or set for
        // large steps fails.
        let with_strategy = |s: &mut PrimarySampler| {
            let p = toy(s);
            PathSample {
                strategy: (p.raster.x as u32).min(3),
                ..p
            }
        };
        let mut s = PrimarySampler::new(3, 0.05, TOY_LARGE);
        let init = with_strategy(&mut s);
        let mut chain = Chain::new(s, init, 77);
        let (mut changes, mut small) = (0, 0);
        for _ in 0..20_000 {
            let before = chain.current().strategy;
            let mut proposed = 0;
            let st = chain.step(
                |s| {
                    let p = with_strategy(s);
                    proposed = p.strategy;
                    p
                },
                None,
            );
            assert_eq!(st.technique_change, !st.large && proposed != before);
            small += !st.large as u32;
            changes += st.technique_change as u32;
        }
        let rate = changes as f64 / small as f64;
        assert!(rate > 0.05 && rate < 0.3, "technique change rate {rate}");
    }

    #[test]
    fn zero_start_moves_on_and_never_divides_by_zero() {
        let s = PrimarySampler::new(1, 0.01, 0.3);
        let mut chain = Chain::new(s, PathSample::default(), 5);
        let st = chain.step(|_| PathSample::default(), None);
        assert_eq!((st.proposal, st.current, st.accepted), (None, None, false));
        let st = chain.step(toy, None);
        assert!(st.accepted && st.acceptance == 1.0 && st.current.is_none());
        let v = st.proposal.unwrap().value;
        assert!(v.is_finite() && (v.luminance() - 1.0).abs() < 1e-5);
        // NaN proposals are never accepted nor recorded.
        let st = chain.step(
            |_| PathSample {
                l: Rgb::splat(f32::NAN),
                raster: Vec2::ZERO,
                strategy: 0,
            },
            None,
        );
        assert!(!st.accepted && st.zero && st.proposal.is_none());
        assert!(st.current.unwrap().value.is_finite());
    }
}

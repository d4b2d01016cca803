//! The path-space level-1 chain: Metropolis–Hastings over paths with
//! Veach's mutations, a = min(1, Y(f(ȳ))T(ȳ→x̄) / (Y(f(x̄))T(x̄→ȳ))), and
//! expected-value splatting (Veach 1997, §11.3.4): the proposal
//! recorded with a, the current path with 1 − a, each as f/Y at its raster
//! position, one unit of luminance per mutation — the records of the
//! primary-sample chain (`mlt/chain.rs`), normalised the same way by b.
//!
//! Mutation selection: the lens subpath mutation with probability ½ when
//! it applies to the current path (`lens_subpath.rs`), else the
//! bidirectional one. The lens subpath mutation applies to all or none of
//! a path and its proposals, so its ratio is its densities'; the
//! bidirectional mutation may join a path it applies to with one it does
//! not, so its ratio also has the selection probabilities p_b(ȳ)/p_b(x̄)
//! (T(x̄→ȳ) includes choosing the mutation).

use rand_core::Rng;
use rand_pcg::Pcg32;

use super::bidirectional::{Bidirectional, Proposal};
use super::lens_subpath::{self, LensSubpath};
use super::state::PathState;
use crate::accel::Intersector;
use crate::integrator::Tracer;
use crate::mlt::chain::Splat;
use crate::sampler::{SampleStream, mix64};

/// What one mutation did and records.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PathStep {
    /// The proposal with weight a (absent when a = 0).
    pub proposal: Option<Splat>,
    /// The current path with weight 1 − a (absent when a = 1).
    pub current: Option<Splat>,
    /// Acceptance probability.
    pub acceptance: f32,
    /// Whether the proposal became the current path.
    pub accepted: bool,
    /// The proposal's depth (0 when none was made: ȳ = x̄, or the move
    /// failed).
    pub proposal_depth: usize,
    /// Whether the lens subpath mutation (rather than the bidirectional
    /// one) made the proposal.
    pub lens_subpath: bool,
}

/// The probability of the lens subpath mutation at `path`.
fn lens_probability(path: &[crate::integrator::bdpt::PathVertex]) -> f32 {
    if lens_subpath::applies(path).is_some() {
        0.5
    } else {
        0.0
    }
}

/// One path-space chain: its current path, the proposal's storage and its
/// random streams.
///
/// Invariant: `current.target() > 0` (chains start on contributing paths
/// and never accept a zero one).
#[derive(Clone, Debug)]
pub(crate) struct PathChain {
    current: PathState,
    proposal: PathState,
    seed: u64,
    iteration: u64,
    rng: Pcg32,
}

/// Stream index of a path-space mutation's random numbers.
const MUTATION_STREAM: u64 = 0x5041;

impl PathChain {
    /// A chain with room for paths of `max_depth` segments, to be started
    /// by filling [`PathChain::current_mut`] and calling
    /// [`PathChain::start`].
    pub fn with_capacity(max_depth: u32) -> Self {
        PathChain {
            current: PathState::with_capacity(max_depth),
            proposal: PathState::with_capacity(max_depth),
            seed: 0,
            iteration: 0,
            rng: Pcg32::new(0, 0),
        }
    }

    /// Starts the chain at its current path (which must contribute), its
    /// random numbers from `seed`.
    pub fn start(&mut self, seed: u64) {
        self.seed = seed;
        self.iteration = 0;
        self.rng = Pcg32::new(mix64(seed ^ 0x9A7B_0000), mix64(seed));
    }

    /// The current path.
    pub fn current(&self) -> &PathState {
        &self.current
    }

    /// The latest proposal's path when it was not accepted; the path it
    /// replaced when it was (the two swap on acceptance).
    pub fn other(&self) -> &PathState {
        &self.proposal
    }

    /// The chain's seed and its mutations so far: the key of its level-2
    /// random stream for the latest mutation.
    pub fn stream_key(&self) -> (u64, u64) {
        (self.seed, self.iteration)
    }

    /// The current path, for a start.
    pub fn current_mut(&mut self) -> &mut PathState {
        &mut self.current
    }

    /// One mutation (lens subpath or bidirectional, see the module docs)
    /// with its expected-value records.
    pub fn step<I: Intersector>(
        &mut self,
        tr: &mut Tracer<'_, I>,
        bidirectional: &mut Bidirectional,
        lens: &mut LensSubpath,
    ) -> PathStep {
        self.iteration += 1;
        let mut stream = SampleStream::new(self.seed, self.iteration, MUTATION_STREAM);
        let p_lens = lens_probability(&self.current.path);
        let use_lens = stream.next_f32() < p_lens;
        let outcome = if use_lens {
            let t = lens_subpath::applies(&self.current.path).unwrap_or(0);
            lens.propose(tr, &self.current, t, &mut self.proposal, &mut stream)
        } else {
            let (_, o) = bidirectional.propose(tr, &self.current, &mut self.proposal, &mut stream);
            match o {
                Proposal::Made { ratio } => {
                    let selection = (1.0 - lens_probability(&self.proposal.path)) / (1.0 - p_lens);
                    #[cfg(test)]
                    let selection = if bidirectional.broken
                        == Some(super::bidirectional::Broken::NoSelection)
                    {
                        1.0
                    } else {
                        selection
                    };
                    Proposal::Made {
                        ratio: ratio * selection,
                    }
                }
                other => other,
            }
        };
        let y_x = self.current.target();
        let (a, y_y) = match outcome {
            Proposal::Made { ratio } => {
                let y_y = self.proposal.target();
                let r = y_y * ratio / y_x;
                (if r.is_finite() { r.min(1.0) } else { 0.0 }, y_y)
            }
            // ȳ = x̄: accepting or not records the same path.
            Proposal::Identity | Proposal::Failed => (0.0, 0.0),
        };
        let record = |s: &PathState, w: f32, y: f32| Splat {
            raster: s.raster,
            value: s.f * (w / y),
        };
        let proposal = (a > 0.0).then(|| record(&self.proposal, a, y_y));
        let current = (a < 1.0).then(|| record(&self.current, 1.0 - a, y_x));
        let u = (self.rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0);
        let accepted = u < a;
        let proposal_depth = if matches!(outcome, Proposal::Made { .. }) {
            self.proposal.depth()
        } else {
            0
        };
        if accepted {
            core::mem::swap(&mut self.current, &mut self.proposal);
        }
        PathStep {
            proposal,
            current,
            acceptance: a,
            accepted,
            proposal_depth,
            lens_subpath: use_lens,
        }
    }
}

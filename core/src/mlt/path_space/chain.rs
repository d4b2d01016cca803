//! The path-space level-1 chain: Metropolis–Hastings over paths with the
//! bidirectional mutation, a = min(1, Y(f(ȳ))T(ȳ→x̄) / (Y(f(x̄))T(x̄→ȳ))),
//! and expected-value splatting (Veach 1997, §11.3.4): the proposal
//! recorded with a, the current path with 1 − a, each as f/Y at its raster
//! position, one unit of luminance per mutation — the records of the
//! primary-sample chain (`mlt/chain.rs`), normalised the same way by b.

use rand_core::Rng;
use rand_pcg::Pcg32;

use super::bidirectional::{Bidirectional, Proposal};
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
    #[cfg(test)]
    pub fn current(&self) -> &PathState {
        &self.current
    }

    /// The current path, for a start.
    pub fn current_mut(&mut self) -> &mut PathState {
        &mut self.current
    }

    /// One bidirectional mutation with its expected-value records.
    pub fn step<I: Intersector>(
        &mut self,
        tr: &mut Tracer<'_, I>,
        mutation: &mut Bidirectional,
    ) -> PathStep {
        self.iteration += 1;
        let mut stream = SampleStream::new(self.seed, self.iteration, MUTATION_STREAM);
        let (_, outcome) = mutation.propose(tr, &self.current, &mut self.proposal, &mut stream);
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
        }
    }
}

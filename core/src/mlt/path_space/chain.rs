//! The path-space level-1 chain: Metropolis–Hastings over paths with
//! Veach's mutations, a = min(1, Y(f(ȳ))T(ȳ→x̄) / (Y(f(x̄))T(x̄→ȳ))), and
//! expected-value splatting (Veach 1997, §11.3.4): the proposal
//! recorded with a, the current path with 1 − a, each as f/Y at its raster
//! position, one unit of luminance per mutation — the records of the
//! primary-sample chain (`mlt/chain.rs`), normalised the same way by b.
//!
//! Mutation selection (`selection.rs`): at x̄, each mutation m that
//! applies with probability p_m(x̄) — the bidirectional and lens subpath
//! mutations and the perturbation the path's class admits
//! (`perturbations.rs`). T(x̄→ȳ) includes choosing m, so the ratio of
//! every mutation has p_m(ȳ)/p_m(x̄) besides its densities' ratio: 1 when
//! ȳ admits the same mutations as x̄, as the lens subpath mutation's and
//! the perturbations' proposals always do (they keep the part of the path
//! that decides it), not always for the bidirectional mutation.

use rand_core::Rng;
use rand_pcg::Pcg32;

use super::bidirectional::{Bidirectional, Proposal};
use super::lens_subpath::{self, LensSubpath};
use super::perturbations::Perturbations;
use super::selection::{Mutation, Probabilities};
use super::state::PathState;
use crate::accel::Intersector;
use crate::integrator::Tracer;
use crate::mlt::PathMutations;
use crate::mlt::chain::Splat;
use crate::mlt::perturbation::{Applicable, Proposals, classify};
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
    /// The mutation that made the proposal.
    pub mutation: Mutation,
}

/// The mutations a worker's path-space chains share, with their scratch
/// storage, and how often each is chosen.
#[derive(Clone, Debug)]
pub(crate) struct Mutations {
    /// The bidirectional mutation.
    pub bidirectional: Bidirectional,
    /// The lens subpath mutation.
    pub lens_subpath: LensSubpath,
    /// The lens, caustic and multi-chain perturbations.
    pub perturbations: Perturbations,
    /// The mutations' weights.
    pub weights: PathMutations,
}

impl Mutations {
    /// The mutations of `weights` for paths of up to `max_depth` segments
    /// on a `width` × `height` image whose pixels subtend `pixel_angle`
    /// radians. Perturbations whose offsets are invalid are never chosen.
    pub fn new(
        weights: &PathMutations,
        max_depth: u32,
        width: u32,
        height: u32,
        pixel_angle: f32,
    ) -> Self {
        let mut weights = *weights;
        let proposals = Proposals::new(
            weights.sigma,
            weights.caustic_scale,
            width,
            height,
            pixel_angle,
        );
        if proposals.is_none() {
            weights.lens = 0.0;
            weights.caustic = 0.0;
            weights.multi_chain = 0.0;
        }
        Mutations {
            bidirectional: Bidirectional::new(max_depth),
            lens_subpath: LensSubpath::new(max_depth),
            perturbations: Perturbations::new(proposals, max_depth),
            weights,
        }
    }

    /// Whether any perturbation can be chosen.
    fn perturbing(&self) -> bool {
        self.weights.lens + self.weights.caustic + self.weights.multi_chain > 0.0
    }

    /// The class of `path` when a perturbation can be chosen, else
    /// `Neither` (no look at the path). In a scene with media the class is
    /// completed with what its perturbation keeps through them (the
    /// free-flight distance of a medium vertex it moves, the media its
    /// rays start in: [`Applicable::complete_media`], as level 2 does);
    /// a path whose own segments cannot be measured is `Neither`. Both
    /// are functions of the path alone, so the selection stays symmetric
    /// (`selection.rs`).
    pub(crate) fn class<I: Intersector>(
        &self,
        tr: &mut Tracer<'_, I>,
        path: &[crate::integrator::bdpt::PathVertex],
    ) -> Applicable {
        if !self.perturbing() {
            return Applicable::Neither;
        }
        #[allow(unused_mut)]
        let mut class = classify(tr, path);
        #[cfg(feature = "media")]
        if tr.has_media() && !class.complete_media(tr, path) {
            class = Applicable::Neither;
        }
        class
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
    /// The current path's class ([`Mutations::class`]) once found: it
    /// changes only when a proposal is accepted, whose class is found
    /// for its ratio.
    class: Option<Applicable>,
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
            class: None,
        }
    }

    /// Starts the chain at its current path (which must contribute), its
    /// random numbers from `seed`.
    pub fn start(&mut self, seed: u64) {
        self.seed = seed;
        self.iteration = 0;
        self.rng = Pcg32::new(mix64(seed ^ 0x9A7B_0000), mix64(seed));
        self.class = None;
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

    /// One mutation (chosen as the module docs say) with its
    /// expected-value records.
    pub fn step<I: Intersector>(&mut self, tr: &mut Tracer<'_, I>, m: &mut Mutations) -> PathStep {
        self.iteration += 1;
        let mut stream = SampleStream::new(self.seed, self.iteration, MUTATION_STREAM);
        let class = match self.class {
            Some(c) => c,
            None => m.class(tr, &self.current.path),
        };
        self.class = Some(class);
        let mut y_class = None;
        let p_x = Probabilities::at(&m.weights, &self.current.path, &class);
        let mutation = p_x.pick(stream.next_f32());
        let outcome = match mutation {
            Mutation::Bidirectional => {
                let x = &self.current;
                m.bidirectional
                    .propose(tr, x, &mut self.proposal, &mut stream)
                    .1
            }
            Mutation::LensSubpath => {
                let t = lens_subpath::applies(&self.current.path).unwrap_or(0);
                m.lens_subpath
                    .propose(tr, &self.current, t, &mut self.proposal, &mut stream)
            }
            _ => {
                m.perturbations
                    .propose(tr, &self.current, &class, &mut self.proposal, &mut stream)
            }
        };
        let outcome = match outcome {
            Proposal::Made { ratio } => {
                let c = m.class(tr, &self.proposal.path);
                y_class = Some(c);
                let p_y = Probabilities::at(&m.weights, &self.proposal.path, &c);
                let selection = p_y.of(mutation) / p_x.of(mutation);
                #[cfg(test)]
                let selection =
                    if m.bidirectional.broken == Some(super::bidirectional::Broken::NoSelection) {
                        1.0
                    } else {
                        selection
                    };
                Proposal::Made {
                    ratio: ratio * selection,
                }
            }
            other => other,
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
            self.class = y_class;
        }
        PathStep {
            proposal,
            current,
            acceptance: a,
            accepted,
            proposal_depth,
            mutation,
        }
    }
}

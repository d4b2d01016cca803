//! Level 2 of CMLT (Segovia 2007, Algorithm 4, step 1, with the typos of
//! its acceptance corrected as [`super::multiple_try`] says): from a
//! level-1 state, a side chain of m(c) steps with the perturbation its
//! path admits ([`super::perturbation`]): n parallel one-proposal lanes
//! ([`super::lanes`]) when k = 1, else multiple-try steps of k candidates;
//! either way the candidates of a step are traced together as packets.
//!
//! ## Side chains only where they pay: the level-2 share
//!
//! Every level-1 mutation adds records of total luminance 1 + s, where s
//! (the level-2 share, [`super::Level2Settings::share`]) is fixed: the image
//! scale counts 1 + s records per mutation ([`super::MltStats::records`]).
//! The share goes to the *class* c of the level-1 state — the perturbation
//! that applies to its path (lens, caustic, multi-chain or none) and its
//! depth — in one of two ways:
//! - a class with side-chain length m(c) > 0 runs a side chain of m(c)
//!   steps (n lanes each) whose records weigh s / (m(c)·n) each, s in all;
//! - a class with m(c) = 0 (no perturbation applies, or a path too shallow
//!   for a side chain to pay, [`super::Level2Settings::side_chain_min_depth`])
//!   runs none: its level-1 records carry the share themselves, the
//!   proposal y weighing a·(1 + s) and the current state x
//!   (1 − a)·(1 + s) when their class has m = 0 (else a and 1 − a).
//!
//! Why this is unbiased. Let π be level 1's stationary distribution over
//! paths and g(z) = 1 when m(class(z)) = 0. Level 1's expected-value
//! record a·δ_y + (1 − a)·δ_x is the conditional expectation of δ_{x′}
//! (x′ the state after the step) given x and y, for any weight that is a
//! function of the state; so with x ~ π the level-1 records have mean
//! π + s·g·π. The side chain starts from x′ ~ π; given its class c, x′ is
//! distributed as π_c, π restricted to c and normalised. The lens,
//! caustic and multi-chain perturbations keep the path's depth and its
//! pattern of specular vertices and lobes, a candidate that breaks the
//! pattern fails (zero target: its retrace fails), and the fixed
//! vertices stay fixed: every state a side chain can reach has its start's
//! class, so its target is π_c (up to a constant) and every lane step is
//! π_c-invariant ([`super::lanes`], [`super::multiple_try`]). Its records
//! therefore have mean s·π_c, and over the classes with m(c) > 0, weighted
//! by their probabilities π(c), s·(1 − g)·π. In all: π + s·g·π + s·(1 − g)·π =
//! (1 + s)·π per mutation, which the image scale divides by. The lengths
//! m(c) are free: they change only the variance and the cost. A negative
//! control in `lanes/tests.rs` shows that weight 1 per record (instead of
//! s/m(c)) with lengths that differ between classes, or a side chain that
//! leaves its class, is biased.
//!
//! The lens perturbation's start is valued from the level-1 path's
//! vertices ([`LensTarget::evaluate_path`]), not retraced. A start that
//! fails (a camera that cannot see x₁, or a retrace of the caustic chain
//! that fails by rounding) records its share where it is: the identity
//! kernel, also π_c-invariant.

use alloc::vec::Vec;

use glam::{Vec2, Vec3};

use super::chain::PathSample;
use super::lanes::{LaneCounts, Lanes};
use super::multiple_try::{ChainState, MultipleTry, Proposal, Target};
use super::perturbation::{
    Applicable, CausticProposal, CausticState, CausticTarget, LensProposal, LensState, LensTarget,
    MultiChainProposal, MultiChainState, MultiChainTarget, Proposals, classify,
};
use super::{Level2Settings, MltStats};
use crate::accel::Intersector;
use crate::integrator::Tracer;
use crate::integrator::bdpt::{self, PathVertex};
use crate::math::Rgb;
use crate::sampler::Sampler;

/// Largest k (candidates per multiple-try step) and largest number of
/// lanes.
pub(crate) const MAX_K: usize = 64;

/// A worker's level-2 machinery: the lanes and the multiple-try steppers
/// (scratch for up to [`MAX_K`] candidates each, no allocation per step)
/// and the perturbations' parameters.
pub(crate) struct Level2 {
    share: u32,
    length: u32,
    min_depth: u32,
    k: usize,
    lens: MultipleTry<LensState, MAX_K>,
    caustic: MultipleTry<CausticState, MAX_K>,
    multi: MultipleTry<MultiChainState, MAX_K>,
    lens_lanes: Lanes<LensState, MAX_K>,
    caustic_lanes: Lanes<CausticState, MAX_K>,
    multi_lanes: Lanes<MultiChainState, MAX_K>,
    lens_proposal: LensProposal,
    caustic_proposal: CausticProposal,
    multi_proposal: MultiChainProposal,
}

impl Level2 {
    /// Level 2 of `l2` on a `width` × `height` image whose pixels subtend
    /// `pixel_angle` radians; `None` when the parameters are invalid (see
    /// [`Level2Settings::validate`]).
    pub fn new(l2: &Level2Settings, width: u32, height: u32, pixel_angle: f32) -> Option<Self> {
        if l2.validate().is_err() {
            return None;
        }
        let k = l2.k as usize;
        let proposals =
            Proposals::new(l2.lens_sigma, l2.caustic_scale, width, height, pixel_angle)?;
        let lanes = l2.lanes as usize;
        Some(Level2 {
            share: l2.share(),
            length: l2.m,
            min_depth: l2.side_chain_min_depth,
            k,
            lens: MultipleTry::new(k, l2.splatting)
                .with_candidates(l2.candidates, LensProposal::DIM),
            caustic: MultipleTry::new(k, l2.splatting)
                .with_candidates(l2.candidates, CausticProposal::DIM),
            multi: MultipleTry::new(k, l2.splatting)
                .with_candidates(l2.candidates, MultiChainProposal::DIM),
            lens_lanes: Lanes::new(lanes, LensProposal::DIM),
            caustic_lanes: Lanes::new(lanes, CausticProposal::DIM),
            multi_lanes: Lanes::new(lanes, MultiChainProposal::DIM),
            lens_proposal: proposals.lens,
            caustic_proposal: proposals.caustic,
            multi_proposal: proposals.multi_chain,
        })
    }

    /// The level-2 share s: records each level-1 mutation adds beyond its
    /// own one (see the module docs).
    pub fn share(&self) -> u32 {
        self.share
    }

    /// The class of the complete path `path`: the perturbation that applies
    /// to it, and its side-chain length m(c) — [`Level2Settings::m`] for a
    /// lens, caustic or multi-chain path of at least the minimum depth, 0
    /// otherwise (then the path's level-1 records carry the share).
    pub fn classify<I: Intersector>(
        &self,
        tracer: &Tracer<'_, I>,
        path: &[PathVertex],
    ) -> (Applicable, u32) {
        let depth = path.len().saturating_sub(1) as u32;
        if depth < self.min_depth {
            return (Applicable::Neither, 0);
        }
        match classify(tracer, path) {
            Applicable::Neither => (Applicable::Neither, 0),
            class => (class, self.length),
        }
    }

    /// [`Level2::classify`] of the path of depth `depth` (segments) that
    /// `ws` holds from the latest target evaluation, copied into `path`
    /// only when a side chain could run on it: a path shallower than the
    /// minimum depth is classless without a look (what most level-1
    /// mutations are, so they skip the copy and the classification).
    pub fn classify_stored<I: Intersector>(
        &self,
        tracer: &Tracer<'_, I>,
        ws: &bdpt::PathStorage,
        depth: u32,
        path: &mut Vec<PathVertex>,
    ) -> (Applicable, u32) {
        if depth < self.min_depth {
            return (Applicable::Neither, 0);
        }
        bdpt::strategy_path(ws, path);
        debug_assert_eq!(
            path.len(),
            depth as usize + 1,
            "a depth-d path has d + 1 vertices"
        );
        self.classify(tracer, path)
    }

    /// Runs the side chain of length `length` (> 0, from
    /// [`Level2::classify`]) of the level-1 state `current`, whose complete
    /// path is `path` and whose class is `class`, recording through
    /// `splat(raster, value)` values of total luminance s (the share).
    /// Level 1 is left alone.
    #[allow(clippy::too_many_arguments)]
    pub fn side_chain<I: Intersector, R: Sampler>(
        &mut self,
        tracer: &mut Tracer<'_, I>,
        path: &[PathVertex],
        class: &Applicable,
        length: u32,
        current: &PathSample,
        rng: &mut R,
        stats: &mut MltStats,
        splat: &mut impl FnMut(Vec2, Rgb),
    ) {
        let share = self.share as f32;
        let identity = |stats: &mut MltStats, splat: &mut dyn FnMut(Vec2, Rgb)| {
            stats.identity_steps += share as u64;
            let y = current.target();
            if y > 0.0 {
                splat(current.raster, current.l * (share / y));
            }
        };
        if length == 0 {
            return identity(stats, splat);
        }
        // Through media the anchor needs the media along the path (rays;
        // nothing in a scene without media, where it stays as classified).
        let mut class = *class;
        if !class.complete_media(tracer, path) {
            return identity(stats, splat);
        }
        match &class {
            Applicable::Neither => identity(stats, splat),
            Applicable::Lens(anchor) => {
                let Some(raster) = start_raster(tracer, anchor.p_lens, path) else {
                    return identity(stats, splat);
                };
                let mut target = LensTarget { tracer, anchor };
                // The start is the level-1 path itself: its value comes
                // from its vertices, without retracing (one path
                // evaluation fewer per side chain).
                let Some(start) = target
                    .evaluate_path(path, raster)
                    .and_then(|s| positive_state(s.value.luminance(), s))
                else {
                    return identity(stats, splat);
                };
                let out = run(
                    self.k,
                    &mut self.lens,
                    &mut self.lens_lanes,
                    &self.lens_proposal,
                    &mut target,
                    start,
                    length,
                    share,
                    rng,
                    &mut |s: &LensState, w| splat(s.raster, s.value * (w / s.value.luminance())),
                );
                stats.lens_steps += out.steps;
                stats.lens_accepted += out.accepted;
                stats.l2_candidates += out.steps * self.k as u64;
                stats.l2_zero_candidates += out.zero;
            }
            Applicable::Caustic(anchor) => {
                let dir = (anchor.toward - anchor.origin.sp.p).normalize();
                let mut target = CausticTarget { tracer, anchor };
                let start = CausticState {
                    dir,
                    ..CausticState::default()
                };
                let Some(start) = evaluate_start(&mut target, start) else {
                    return identity(stats, splat);
                };
                let out = run(
                    self.k,
                    &mut self.caustic,
                    &mut self.caustic_lanes,
                    &self.caustic_proposal,
                    &mut target,
                    start,
                    length,
                    share,
                    rng,
                    &mut |s: &CausticState, w| splat(s.raster, s.value * (w / s.value.luminance())),
                );
                stats.caustic_steps += out.steps;
                stats.caustic_accepted += out.accepted;
                stats.l2_candidates += out.steps * self.k as u64;
                stats.l2_zero_candidates += out.zero;
            }
            Applicable::MultiChain(anchor) => {
                let t = anchor.first.len() + 1;
                let (Some(raster), Some(x_t), Some(x_next)) = (
                    start_raster(tracer, anchor.p_lens, path),
                    path.get(t),
                    path.get(t + 1),
                ) else {
                    return identity(stats, splat);
                };
                let mut target = MultiChainTarget { tracer, anchor };
                // Retraced, not valued from the vertices: the direction
                // leaving x_t is a coordinate of the state, and the start
                // must be valued in the same measure as the candidates.
                let start = MultiChainState {
                    raster,
                    dir: (x_next.sp.p - x_t.sp.p).normalize(),
                    value: Rgb::ZERO,
                };
                let Some(start) = evaluate_start(&mut target, start) else {
                    return identity(stats, splat);
                };
                let out = run(
                    self.k,
                    &mut self.multi,
                    &mut self.multi_lanes,
                    &self.multi_proposal,
                    &mut target,
                    start,
                    length,
                    share,
                    rng,
                    &mut |s: &MultiChainState, w| {
                        splat(s.raster, s.value * (w / s.value.luminance()))
                    },
                );
                stats.multi_chain_steps += out.steps;
                stats.multi_chain_accepted += out.accepted;
                stats.l2_candidates += out.steps * self.k as u64;
                stats.l2_zero_candidates += out.zero;
            }
        }
    }
}

/// Where the level-1 path `path` crosses the image, seen from the lens
/// point `p_lens` (`None` when the camera cannot see x₁).
fn start_raster<I: Intersector>(
    tracer: &Tracer<'_, I>,
    p_lens: Vec3,
    path: &[PathVertex],
) -> Option<Vec2> {
    let x1 = path.get(1)?;
    let (_, raster) = tracer
        .camera
        .importance(p_lens, (x1.sp.p - p_lens).normalize())?;
    Some(raster)
}

/// The side chain's starting state evaluated by the same target as its
/// candidates (so that every p of the chain is in one measure); `None`
/// when the retrace of the level-1 path itself fails (rounding at an edge).
fn evaluate_start<S: Clone, T: Target<S>>(target: &mut T, s: S) -> Option<ChainState<S>> {
    let mut one = [Some(s)];
    let mut p = [0.0f32];
    target.evaluate(&mut one, &mut p);
    positive_state(p[0], one[0].take()?)
}

/// `s` with target value `p` as a chain state, if p is positive (after
/// [`super::multiple_try::sanitize_target`]).
fn positive_state<S>(p: f32, s: S) -> Option<ChainState<S>> {
    let st = ChainState::new(s, p);
    (st.p > 0.0).then_some(st)
}

/// Runs a side chain of `m` steps carrying `share` from the evaluated
/// start `state`: the lanes when k = 1, else multiple-try steps (each of
/// which records total weight 1, scaled here to share/m). A multiple-try
/// step counts as one step (of k candidates).
#[allow(clippy::too_many_arguments)]
fn run<S: Clone + Default, P: Proposal<S>, T: Target<S>, R: Sampler>(
    k: usize,
    mtm: &mut MultipleTry<S, MAX_K>,
    lanes: &mut Lanes<S, MAX_K>,
    proposal: &P,
    target: &mut T,
    state: ChainState<S>,
    m: u32,
    share: f32,
    rng: &mut R,
    splat: &mut impl FnMut(&S, f32),
) -> LaneCounts {
    if k == 1 {
        return lanes.run(proposal, target, &state, m, share, rng, splat);
    }
    let scale = share / m as f32;
    let out = mtm.side_chain(proposal, target, &state, m, rng, &mut |s: &S, w| {
        splat(s, w * scale)
    });
    LaneCounts {
        steps: out.steps as u64,
        accepted: out.accepted as u64,
        zero: out.zero as u64,
    }
}

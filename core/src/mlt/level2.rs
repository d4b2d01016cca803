//! Level 2 of CMLT (Segovia 2007, Algorithm 4, step 1, with the typos of
//! its acceptance corrected as [`super::multiple_try`] says): from a
//! level-1 state, a side chain of m multiple-try steps with the
//! perturbation its path admits ([`super::path`]), the k candidates of
//! each step traced together as packets.
//!
//! Every side-chain step records total luminance 1 (expected-value
//! splatting, [`super::multiple_try`]), like a level-1 mutation, so a
//! level-1 mutation followed by its side chain adds 1 + m records and the
//! image scale counts them all ([`super::MltStats::records`]). A path no
//! perturbation applies to (or, for the caustic perturbation, whose
//! retrace fails numerically at the start) is recorded m times where it
//! is: the identity kernel, which keeps every path's share of the records
//! right. The lens perturbation's start is valued from the level-1 path's
//! vertices ([`LensTarget::evaluate_path`]), not retraced.

use glam::Vec2;

use super::caustic::{CausticProposal, CausticState, CausticTarget};
use super::lens::{LensProposal, LensState, LensTarget};
use super::multiple_try::{Candidates, ChainState, MultipleTry, Proposal, Target};
use super::path::{Applicable, classify};
use super::{MltSettings, MltStats, PathSample};
use crate::accel::Intersector;
use crate::integrator::Tracer;
use crate::integrator::bdpt::PathVertex;
use crate::math::Rgb;
use crate::sampler::Sampler;

/// Largest k (candidates per multiple-try step).
pub const MAX_K: usize = 64;

/// A worker's level-2 machinery: the two multiple-try steppers (scratch
/// for up to [`MAX_K`] candidates each, no allocation per step) and the
/// perturbations' parameters.
pub struct Level2 {
    m: u32,
    lens: MultipleTry<LensState, MAX_K>,
    caustic: MultipleTry<CausticState, MAX_K>,
    lens_proposal: LensProposal,
    caustic_proposal: CausticProposal,
}

/// Truncation radius of the perturbation offsets, in standard deviations:
/// the disk holds 1 − e^{−8} of the Gaussian.
const R_MAX_SIGMAS: f32 = 4.0;

impl Level2 {
    /// Level 2 for `mlt` on a `width` × `height` image whose pixels subtend
    /// `pixel_angle` radians; `None` when `mlt.m` is 0 (plain MLT) or the
    /// parameters are invalid (see [`MltSettings::validate`]).
    pub fn new(mlt: &MltSettings, width: u32, height: u32, pixel_angle: f32) -> Option<Self> {
        if mlt.m == 0 || mlt.validate().is_err() {
            return None;
        }
        let k = mlt.k as usize;
        let sigma = mlt.lens_sigma;
        let lens_proposal = LensProposal::new(sigma, R_MAX_SIGMAS * sigma, width, height)?;
        // The caustic offset is an angle at x_j: the lens width in pixels
        // times a pixel's angle, scaled (the specular chain magnifies or
        // compresses it on its way to the image).
        let s = sigma * pixel_angle * mlt.caustic_scale;
        let caustic_proposal =
            CausticProposal::new(s, (R_MAX_SIGMAS * s).min(0.99 * core::f32::consts::PI))?;
        Some(Level2 {
            m: mlt.m,
            lens: MultipleTry::new(k, mlt.splatting)
                .with_candidates(mlt.candidates, LensProposal::DIM),
            caustic: MultipleTry::new(k, mlt.splatting)
                .with_candidates(mlt.candidates, CausticProposal::DIM),
            lens_proposal,
            caustic_proposal,
        })
    }

    /// Side-chain length m.
    pub fn m(&self) -> u32 {
        self.m
    }

    /// Runs the side chain of the level-1 state `current` (whose complete
    /// path is `path`), recording through `splat(raster, value)` with
    /// values of luminance equal to the record's weight. Level 1 is left
    /// alone.
    #[allow(clippy::too_many_arguments)]
    pub fn side_chain<I: Intersector, R: Sampler>(
        &mut self,
        tracer: &mut Tracer<'_, I>,
        path: &[PathVertex],
        current: &PathSample,
        rng: &mut R,
        stats: &mut MltStats,
        splat: &mut impl FnMut(Vec2, Rgb),
    ) {
        let m = self.m;
        let identity = |stats: &mut MltStats, splat: &mut dyn FnMut(Vec2, Rgb)| {
            stats.identity_steps += m as u64;
            let y = current.target();
            if y > 0.0 {
                splat(current.raster, current.l * (m as f32 / y));
            }
        };
        match classify(tracer, path) {
            Applicable::Neither => identity(stats, splat),
            Applicable::Lens(anchor) => {
                let camera = tracer.camera;
                let Some(raster) = path
                    .get(1)
                    .and_then(|x1| {
                        camera.importance(anchor.p_lens, (x1.sp.p - anchor.p_lens).normalize())
                    })
                    .map(|(_, r)| r)
                else {
                    return identity(stats, splat);
                };
                let mut target = LensTarget {
                    tracer,
                    anchor: &anchor,
                };
                // The start is the level-1 path itself: its value comes
                // from its vertices, without retracing (one path
                // evaluation fewer per side chain).
                let Some(start) = target
                    .evaluate_path(path, raster)
                    .and_then(|s| positive_state(s.value.luminance(), s))
                else {
                    return identity(stats, splat);
                };
                let out = side_chain(
                    &mut self.lens,
                    &self.lens_proposal,
                    &mut target,
                    start,
                    m,
                    rng,
                    &mut |s: &LensState, w| splat(s.raster, s.value * (w / s.value.luminance())),
                );
                stats.lens_steps += m as u64;
                stats.lens_accepted += out.accepted;
                stats.l2_candidates += out.candidates;
                stats.l2_zero_candidates += out.zero;
            }
            Applicable::Caustic(anchor) => {
                let dir = (anchor.toward - anchor.origin.sp.p).normalize();
                let mut target = CausticTarget {
                    tracer,
                    anchor: &anchor,
                };
                let start = CausticState {
                    dir,
                    ..CausticState::default()
                };
                let Some(start) = evaluate_start(&mut target, start) else {
                    return identity(stats, splat);
                };
                let out = side_chain(
                    &mut self.caustic,
                    &self.caustic_proposal,
                    &mut target,
                    start,
                    m,
                    rng,
                    &mut |s: &CausticState, w| splat(s.raster, s.value * (w / s.value.luminance())),
                );
                stats.caustic_steps += m as u64;
                stats.caustic_accepted += out.accepted;
                stats.l2_candidates += out.candidates;
                stats.l2_zero_candidates += out.zero;
            }
        }
    }
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

/// Counters of one side chain.
struct SideChainCounts {
    accepted: u64,
    candidates: u64,
    zero: u64,
}

/// Runs m multiple-try steps from the evaluated start `state`.
fn side_chain<S: Clone, P: Proposal<S>, T: Target<S>, R: Sampler>(
    mtm: &mut MultipleTry<S, MAX_K>,
    proposal: &P,
    target: &mut T,
    mut state: ChainState<S>,
    m: u32,
    rng: &mut R,
    splat: &mut impl FnMut(&S, f32),
) -> SideChainCounts {
    let k = mtm.k() as u64;
    let mut c = SideChainCounts {
        accepted: 0,
        candidates: 0,
        zero: 0,
    };
    for _ in 0..m {
        let st = mtm.step(proposal, target, &mut state, rng, splat);
        c.accepted += st.accepted as u64;
        c.candidates += k;
        c.zero += k - st.nonzero as u64;
    }
    c
}

/// The candidates mode level 2 uses by default.
pub const DEFAULT_CANDIDATES: Candidates = Candidates::Stratified;

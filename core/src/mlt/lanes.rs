//! Level 2's coherent parallel side chains: n lanes started from the same
//! level-1 state, each an ordinary one-proposal Metropolis–Hastings chain,
//! whose candidates are traced together as one packet per step.
//!
//! ## One step
//!
//! Every lane i at its own state x_i draws one candidate y_i ~ T(x_i→·);
//! the n candidates go through the target as one batch ([`Target`], which
//! a path-space target traces as ray packets); lane i accepts y_i with
//! a_i = min(1, p(y_i) T(y_i→x_i) / (p(x_i) T(x_i→y_i))) — for a
//! [`Proposal::SYMMETRIC`] proposal (the lens perturbation)
//! a_i = min(1, p(y_i)/p(x_i)) — by its own uniform, and records y_i with
//! weight a_i·w and x_i with (1 − a_i)·w (expected-value splatting, Veach
//! 1997, §11.3.4), w = s / (m·n) for a side chain of m steps carrying the
//! level-2 share s.
//!
//! The lanes' offsets are stratified: the uniforms of lane i are point i of
//! a rank-1 lattice of n points shifted by one uniform toroidal offset per
//! step ([`Lattice`]), so that the lanes spread around a shared start
//! instead of clumping. With n = 1 this is exactly
//! [`super::multiple_try::MultipleTry::step`] at k = 1, random number for
//! random number.
//!
//! ## Why the records are unbiased
//!
//! Let π be the target normalised, and let the start x₀ be distributed as
//! π (level 1 in equilibrium, restricted to the class its side chain
//! cannot leave, see [`super::level2`]). Look at one lane alone. Its
//! uniforms at step j — lattice point i plus the step's fresh shift, and
//! its own accept uniform — are uniform and independent of everything the
//! lane did before step j, whatever the other lanes do with the same
//! shift. So lane i, on its own, is an ordinary Metropolis–Hastings chain
//! with proposal T and acceptance a: its kernel K is in detailed balance
//! with π, so πK = π and every state x_i^(j) of the lane is π-distributed.
//! The expected-value record of step j, a δ_y + (1 − a) δ_x, is the
//! conditional expectation of δ_{x^(j+1)} given the proposal, so its mean
//! is π too. The side chain's records are the average of n·m such records
//! times s: by linearity their mean is s·π, however strongly the lanes are
//! correlated (they share the start and the shifts). Correlation only
//! changes the variance, which is what the measurements in
//! `docs/accuracy.md` weigh against the cheaper packets.
//!
//! What would break it: a lane whose acceptance depends on another lane's
//! state (one decision for all lanes), or an acceptance ratio taken against
//! the shared start instead of the lane's current state. The χ² tests below
//! run both as negative controls.

use super::multiple_try::{
    ChainState, Lattice, MAX_PROPOSAL_DIM, Proposal, Target, reference_weight, sanitize_target,
    weight,
};
use crate::sampler::Sampler;

/// Deliberately wrong lane rules, for the negative controls only: they
/// exist in test builds alone, so the library's side chains carry no
/// branch for them.
#[cfg(test)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum LaneVariant {
    /// Every lane its own Metropolis–Hastings step.
    Correct,
    /// Every lane accepts and records with lane 0's acceptance a_0 and
    /// lane 0's uniform: one decision for the packet.
    OneDecision,
    /// a_i taken against the side chain's start p(x₀) instead of the
    /// lane's current p(x_i).
    StartReference,
}

/// What the lanes of one side chain did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct LaneCounts {
    /// Lane steps (lanes × m).
    pub steps: u64,
    /// Lane steps accepted.
    pub accepted: u64,
    /// Candidates with zero target (or a failed perturbation).
    pub zero: u64,
}

/// The parallel side chains with scratch for up to `K` lanes (n ≤ K chosen
/// at construction). Reuse one per thread: a side chain allocates nothing.
#[derive(Clone, Debug)]
pub(crate) struct Lanes<S, const K: usize> {
    n: usize,
    lattice: Lattice,
    #[cfg(test)]
    variant: LaneVariant,
    x: [S; K],
    px: [f32; K],
    y: [Option<S>; K],
    py: [f32; K],
    a: [f32; K],
}

impl<S: Clone + Default, const K: usize> Lanes<S, K> {
    /// `n` lanes for a proposal of `dim` uniforms. Panics unless
    /// 1 ≤ n ≤ K and dim ≤ [`MAX_PROPOSAL_DIM`].
    pub fn new(n: usize, dim: usize) -> Self {
        assert!(n >= 1 && n <= K, "lanes = {n} outside 1..={K}");
        assert!(dim <= MAX_PROPOSAL_DIM);
        Lanes {
            n,
            lattice: Lattice::new(n, dim),
            #[cfg(test)]
            variant: LaneVariant::Correct,
            x: core::array::from_fn(|_| S::default()),
            px: [0.0; K],
            y: core::array::from_fn(|_| None),
            py: [0.0; K],
            a: [0.0; K],
        }
    }

    /// Selects a deliberately wrong rule (negative controls only).
    #[cfg(test)]
    pub(crate) fn with_variant(mut self, variant: LaneVariant) -> Self {
        self.variant = variant;
        self
    }

    /// Which negative control runs, as (acceptance against the start, one
    /// decision for the packet): both false outside test builds.
    #[inline(always)]
    fn negative_controls(&self) -> (bool, bool) {
        #[cfg(test)]
        return (
            self.variant == LaneVariant::StartReference,
            self.variant == LaneVariant::OneDecision,
        );
        #[cfg(not(test))]
        (false, false)
    }

    /// Runs every lane `m` steps from `start` and records through
    /// `splat(state, weight)`; the weights of the whole side chain sum to
    /// `share` (when the start's p is positive). `start` is not modified:
    /// level 1 continues from it. Random numbers per step: `DIM` for the
    /// shared shift, then one accept uniform per lane whose candidate has
    /// positive weight, in lane order.
    #[allow(clippy::too_many_arguments)]
    pub fn run<P, T, R>(
        &mut self,
        proposal: &P,
        target: &mut T,
        start: &ChainState<S>,
        m: u32,
        share: f32,
        rng: &mut R,
        splat: &mut impl FnMut(&S, f32),
    ) -> LaneCounts
    where
        P: Proposal<S>,
        T: Target<S> + ?Sized,
        R: Sampler + ?Sized,
    {
        const { assert!(P::DIM <= MAX_PROPOSAL_DIM) };
        let n = self.n;
        let mut counts = LaneCounts::default();
        if m == 0 {
            return counts;
        }
        let w = share / (m as f32 * n as f32);
        let (start_reference, one_decision) = self.negative_controls();
        let Lanes {
            lattice,
            x,
            px,
            y,
            py,
            a,
            ..
        } = self;
        for i in 0..n {
            x[i] = start.x.clone();
            px[i] = start.p;
        }
        for _ in 0..m {
            // One shift for the packet; lane i takes lattice point i.
            let mut shift = [0.0f32; MAX_PROPOSAL_DIM];
            for v in &mut shift[..P::DIM] {
                *v = rng.next_f32();
            }
            for i in 0..n {
                let mut u = [0.0f32; MAX_PROPOSAL_DIM];
                for d in 0..P::DIM {
                    u[d] = lattice.point(i, d, shift[d]);
                }
                y[i] = proposal.sample(&x[i], &u[..P::DIM]);
            }
            // The candidates of all lanes as one batch (one packet).
            py[..n].fill(0.0);
            target.evaluate(&mut y[..n], &mut py[..n]);
            for i in 0..n {
                let p_ref = if start_reference { start.p } else { px[i] };
                // NaN: the candidate has no weight, and its lane draws no
                // accept uniform (as the single step does).
                a[i] = match &y[i] {
                    Some(c) => {
                        py[i] = sanitize_target(py[i]);
                        acceptance(proposal, &x[i], c, p_ref, py[i]).unwrap_or(f32::NAN)
                    }
                    None => {
                        py[i] = 0.0;
                        f32::NAN
                    }
                };
                counts.zero += a[i].is_nan() as u64;
            }
            if one_decision {
                let a0 = a[0];
                for ai in &mut a[..n] {
                    if ai.is_finite() {
                        *ai = if a0.is_finite() { a0 } else { 0.0 };
                    }
                }
            }
            let mut u_first = 0.0;
            for i in 0..n {
                let (ai, mut u) = if a[i].is_nan() {
                    (0.0, 1.0)
                } else {
                    (a[i], rng.next_f32())
                };
                if i == 0 {
                    u_first = u;
                } else if one_decision {
                    u = u_first;
                }
                // Record both with their expected weights, then move.
                if ai > 0.0
                    && let Some(c) = &y[i]
                {
                    splat(c, ai * w);
                }
                if ai < 1.0 && px[i] > 0.0 {
                    splat(&x[i], (1.0 - ai) * w);
                }
                // a = 1 always accepts (u < 1), a = 0 never does.
                if u < ai
                    && let Some(c) = y[i].take()
                {
                    x[i] = c;
                    px[i] = py[i];
                    counts.accepted += 1;
                }
            }
            counts.steps += n as u64;
        }
        counts
    }
}

/// a = min(1, p(y)T(y→x) / (p(x)T(x→y))) of a drawn candidate y of target
/// `p_y` from x of target `p_x`, with the conventions of the multiple-try
/// step at k = 1: `None` when y has no weight p(y)/T(x→y) (nothing to
/// decide), 0 when its reverse move is (numerically) impossible, 1 when
/// p(x) = 0 < p(y); T is not evaluated for a [`Proposal::SYMMETRIC`]
/// proposal.
#[inline]
fn acceptance<S, P: Proposal<S>>(proposal: &P, x: &S, y: &S, p_x: f32, p_y: f32) -> Option<f32> {
    let t_xy = if P::SYMMETRIC {
        1.0
    } else {
        proposal.density(x, y)
    };
    let wy = weight(p_y, t_xy);
    if !(wy > 0.0) {
        return None;
    }
    let t_yx = if P::SYMMETRIC {
        t_xy
    } else {
        proposal.density(y, x)
    };
    Some(match reference_weight(p_x, t_yx) {
        None => 0.0,
        Some(wx) if wx > 0.0 => (wy / wx).min(1.0) as f32,
        // Only when p(x) = 0: move on.
        Some(_) => 1.0,
    })
}

#[cfg(test)]
mod tests;

//! Level 2 of CMLT: the multiple-try Metropolis step (Liu, Liang, Wong
//! 2000) as Segovia, Iehl and Péroche (2007) use it, the side chain of m
//! such steps run from a level-1 state, and its two splatting rules.
//!
//! The module is generic over the state type `S` and the perturbation
//! ([`Proposal`]); the target p is a closure returning the luminance of a
//! state (≥ 0). Path-space lens, caustic and multi-chain perturbations implement
//! [`Proposal`] later; the tests here run it on 2-D toy targets.
//!
//! ## One step (Segovia 2007, Algorithm 3; Algorithm 4, steps b–g, corrected)
//!
//! From the current state x:
//! - b) draw y₁…y_k ~ T(x→·);
//! - c) weigh them with w(x, y) = p(y) T(y→x) λ(x, y) (eq. 32/34) and
//!   Segovia's λ(x, y) = 1 / (T(x→y) T(y→x)) (eq. 35), i.e.
//!   w(x, y) = p(y) / T(x→y), an importance weight; pick x* = y_l* with
//!   probability w(x, y_l) / Σ w(x, y);
//! - d) draw the reference set z₁…z_{k−1} ~ T(x*→·) **from x\*** and set
//!   z_k = x (Algorithm 3, step 4; Algorithm 4, step d, prints T(x→·), a
//!   typo that breaks detailed balance);
//! - e) accept x* with probability a = min(1, Σ w(x, y_l) / Σ w(x*, z_l)),
//!   the reference set weighed **as seen from x\*** (Algorithm 4, step e,
//!   prints w(x, z_l): the same typo); on rejection keep x.
//!
//! Eq. 33's remark that a symmetric T with λ = 1/T gives w = p(x) is
//! another typo: it gives w(x, y) = p(y).
//!
//! λ only needs to be symmetric and positive where T is (eq. 31); with
//! eq. 35 the reverse density T(y→x) cancels, so a step evaluates T(x→y)
//! once per candidate and T(x*→z) once per reference point. This relies on
//! the proposal honouring eq. 31 (T(x→y) > 0 ⇔ T(y→x) > 0); see
//! [`Proposal`].
//!
//! ## Zeros
//!
//! A candidate the proposal cannot produce (`None`, e.g. a perturbed path
//! that fails to retrace), with zero or non-finite target, or with zero or
//! non-finite density gets weight 0: it is never selected and adds nothing
//! to the sums. If every candidate has weight 0 the step rejects (a = 0)
//! without drawing a reference set, so nothing divides by zero. If the
//! reference sum is 0 (only when p(x) = 0, e.g. a chain started on a black
//! path) the step accepts (a = 1), as the level-1 chain does. If the
//! reverse density T(x*→x) of a state with p(x) > 0 underflows to 0, the
//! weight w(x*, x) is infinite and the step rejects (a = 0), the limit of
//! the exact ratio; treating it as weight 0 would accept exactly the moves
//! whose reverse is (numerically) impossible. This arises with a
//! state-dependent σ (a narrow perturbation at x* far from x). Weights and
//! their sums are f64, so p/T cannot overflow.
//!
//! ## The side chain (Algorithm 4, step 1, corrected)
//!
//! [`MultipleTry::side_chain`] runs m steps from a copy of a level-1 state
//! x_i. On rejection it keeps its *own* current state x_i^(j) (step e-ii
//! prints x_i, wrong for j > 0), and it never writes back: the level-1
//! chain continues from x_i (step 2), whatever the side chain ended on. The
//! level-1 acceptance stays the ordinary Metropolis–Hastings ratio.
//!
//! ## Splatting
//!
//! Every step reports records (state, weight) through a callback; the
//! weights of one step sum to 1 (unless p(x) = 0), and the caller records
//! each state's colour scaled to unit luminance, f/|f|, times the weight —
//! the convention of the level-1 chain ([`super::chain`]).
//! - [`Splatting::ExpectedValue`] (default): x* with a and x with 1 − a
//!   (Veach 1997, §11.3.4). This is the conditional expectation of the next
//!   state's indicator given everything but the accept/reject uniform, so a
//!   chain in equilibrium records p exactly in expectation.
//! - [`Splatting::Recycled`]: every candidate y_l with a₁(x, y_l)/k and x
//!   with 1 − Σ_l a₁(x, y_l)/k, where a₁(x, y) = min(1, p(y)T(y→x) /
//!   (p(x)T(x→y))) is the acceptance of an ordinary one-proposal
//!   Metropolis–Hastings step. This is the aim of Segovia 2007's eq. 36 (use the samples a
//!   step has traced anyway) with a weighting that is provably right: let
//!   P_l be the Metropolis–Hastings kernel that proposes y_l ~ T(x→·) and
//!   accepts with a₁. Its expected-value record, a₁δ_{y_l} + (1 − a₁)δ_x,
//!   has mean πP_l = π when x ~ π (P_l is in detailed balance with π). The
//!   recycled record is the average of the k such records, so its mean is
//!   π too, by linearity. The argument asks only that x ~ π, which the
//!   multiple-try chain guarantees, and that each y_l is marginally
//!   T(x→·)-distributed, which stratified candidates are; it does not
//!   involve x*, the reference set or the accept decision, so the chain
//!   may move by any π-invariant rule. For k = 1 it is expected-value
//!   splatting of a plain Metropolis–Hastings step. The test
//!   `recycled_splatting_matches_target` checks it against the toy targets.
//! - [`Splatting::AllCandidates`] (Segovia 2007, eq. 36): every y_l with
//!   a · p(y_l) / F_y and every z_l with (1 − a) · p(z_l) / F_z, where
//!   F_y = Σ_{l=1}^{k} p(y_l), F_z = Σ_{l=1}^{k} p(z_l) (z_k = x included),
//!   and p is the luminance — Segovia 2007's f "with colours scaled to
//!   luminance |f| = 1". For k = 1 it coincides with expected-value
//!   splatting. For k > 1 it is **biased**: the y are distributed by
//!   T(x→·), so weighing them by p alone records ∝ p·T rather than p, and
//!   the z are drawn around x*, not x; the test `eq36_splatting_is_biased`
//!   measures 3–24 % errors in a region's share on the toy target, far
//!   beyond noise. Do not use it for
//!   images; [`Splatting::Recycled`] is the corrected rule.
//!
//! ## Allocation, batches and random numbers
//!
//! [`MultipleTry`] keeps the 2k candidates in fixed arrays of capacity
//! `K` (const generic), so a step allocates nothing; k ≤ K is chosen at
//! run time. The target is a [`Target`] evaluated one batch at a time — the
//! k candidates, then the k − 1 reference points — so that a path-space
//! target traces each batch as ray packets (the "coherent" in CMLT).
//! Random numbers come from a [`Sampler`]. With [`Candidates::Independent`]
//! a step draws k·DIM for the candidates, one for the selection (only when
//! k > 1), (k − 1)·DIM for the reference set and one for the accept test,
//! in that order. With [`Candidates::Stratified`] (the default for paths)
//! the candidates are one randomly shifted lattice (DIM numbers), one per
//! stratum, and the reference set is the same lattice through x (no random
//! numbers); the detailed-balance argument is on [`Candidates::Stratified`]
//! and the χ² test `stratified_mtm_keeps_target` checks it.

use super::primary::wrap01;
use crate::sampler::Sampler;

/// Largest number of uniforms one candidate may consume
/// ([`Proposal::DIM`]).
pub(crate) const MAX_PROPOSAL_DIM: usize = 8;

/// A perturbation T(x→·) over states `S`.
///
/// Contract:
/// - `sample(from, u)` maps `DIM` uniforms in [0, 1) to a state whose
///   density is `density(from, ·)`, or `None` when the perturbation fails
///   (that probability mass counts as a zero-target candidate);
/// - `density` is a normalised density with respect to one fixed measure on
///   `S` (per unit area, solid angle… — the same for all `from`), exact:
///   it enters the weights;
/// - eq. 31: `density(x, y) > 0` ⇔ `density(y, x) > 0`. A proposal that
///   violates it (e.g. a truncation radius that depends on the state) is
///   not reversible and no weighting repairs it;
/// - `invert(from, to, u)` writes the uniforms that `sample(from, ·)` maps
///   to `to` and returns true; it is needed only for
///   [`Candidates::Stratified`] and may return false (the default) where
///   the map is not invertible, which makes stratified steps reject.
pub(crate) trait Proposal<S> {
    /// Uniform numbers one candidate consumes (≤ [`MAX_PROPOSAL_DIM`]).
    const DIM: usize;

    /// Whether T(x→y) = T(y→x) holds bit for bit (e.g. a density of the
    /// offset's length only): then a one-candidate step takes the reverse
    /// density from the forward one instead of evaluating it again.
    const SYMMETRIC: bool = false;
    /// A candidate perturbed from `from`, using `u` (`DIM` uniforms).
    fn sample(&self, from: &S, u: &[f32]) -> Option<S>;

    /// T(from→to): the density of `sample(from, ·)` at `to`.
    fn density(&self, from: &S, to: &S) -> f32;

    /// The uniforms `u` (`DIM` of them) with `sample(from, u) = to`.
    fn invert(&self, from: &S, to: &S, u: &mut [f32]) -> bool {
        let _ = (from, to, u);
        false
    }
}

/// The target p over states `S`, evaluated a batch at a time so that an
/// implementation can trace the candidates of one step as ray packets.
///
/// `evaluate(states, p)` writes `p(states[i])` (luminance, any non-negative
/// value; [`sanitize_target`] is applied afterwards) into `p[i]` for every
/// `Some` state and may complete the states in place (a path-space target
/// stores the traced contribution there). `None` entries are skipped; their
/// `p` is ignored. Any `FnMut(&S) -> f32` is a target evaluated one state
/// at a time.
pub(crate) trait Target<S> {
    /// Evaluates p for a batch of states.
    fn evaluate(&mut self, states: &mut [Option<S>], p: &mut [f32]);
}

impl<S, F: FnMut(&S) -> f32> Target<S> for F {
    fn evaluate(&mut self, states: &mut [Option<S>], p: &mut [f32]) {
        for (s, p) in states.iter().zip(p) {
            if let Some(s) = s {
                *p = self(s);
            }
        }
    }
}

/// How the k candidates of a step are drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Candidates {
    /// k independent draws from T(x→·), the reference set k − 1 independent
    /// draws from T(x*→·) (Liu et al. 2000).
    Independent,
    /// Stratified (the jittered grid of Segovia 2007, fig. 13): the k uniforms
    /// are a rank-1 lattice shifted by one uniform toroidal offset Δ
    /// (Cranley–Patterson rotation), so every stratum of [0, 1)^DIM holds
    /// one point and each point alone is uniform, i.e. each candidate is
    /// T(x→·)-distributed. The reference set is the same lattice through
    /// x as seen from x*: shift Δ′ such that point j (the selected one)
    /// falls on the uniforms of x; it costs no random numbers.
    ///
    /// Why this is still in detailed balance (after Craiu & Lemieux 2007):
    /// given index j, Δ ↦ x* = sample(x, g_j + Δ) has density T(x→x*)
    /// (a shift of a uniform), and Δ is recovered from (x, x*, j). The
    /// probability flux of x → x* via j is therefore
    /// π(x) T(x→x*) · w(x, x*)/W_y · min(1, W_y/W_z) =
    /// π(x) π(x*) T(x→x*) T(x*→x) λ(x, x*) · min(1/W_y, 1/W_z),
    /// and the reverse move x* → x via j sees exactly the swapped sets
    /// (its candidates are our reference set and vice versa), so the flux
    /// is symmetric. The test `stratified_mtm_keeps_target` checks it.
    #[default]
    Stratified,
}

/// A rank-1 lattice of k points in [0, 1)^dim (Korobov generator
/// (1, a, a², …) mod k), with `a` coprime to k chosen to maximise the
/// smallest toroidal distance between points: a stratification of the
/// unit cube for any k, one point per stratum in every coordinate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Lattice {
    k: usize,
    generator: [u32; MAX_PROPOSAL_DIM],
}

impl Lattice {
    /// The best Korobov lattice of `k` ≥ 1 points in `dim` ≤
    /// [`MAX_PROPOSAL_DIM`] dimensions (a search over all generators, O(k³),
    /// done once per configuration).
    pub fn new(k: usize, dim: usize) -> Self {
        assert!(k >= 1 && dim <= MAX_PROPOSAL_DIM);
        let gen_of = |a: u64| {
            let mut g = [0u32; MAX_PROPOSAL_DIM];
            let mut c = 1u64;
            for gi in g.iter_mut().take(dim) {
                *gi = (c % k as u64) as u32;
                c = c * a % k as u64;
            }
            g
        };
        let mut best = (gen_of(1), -1.0f64);
        // Generators coprime with k: each coordinate alone is then a
        // permutation of the k strata (a Latin-hypercube property).
        for a in (1..k.max(2) as u64).filter(|&a| gcd(a, k as u64) == 1) {
            let g = gen_of(a);
            let mut dmin = f64::INFINITY;
            for l in 1..k {
                let mut d2 = 0.0;
                for gi in g.iter().take(dim) {
                    let x = (l as u64 * *gi as u64 % k as u64) as f64 / k as f64;
                    let x = x.min(1.0 - x);
                    d2 += x * x;
                }
                dmin = dmin.min(d2);
            }
            if dmin > best.1 {
                best = (g, dmin);
            }
        }
        Lattice {
            k,
            generator: best.0,
        }
    }

    /// Coordinate `d` of point `l` shifted by `shift` (toroidally).
    #[inline]
    pub fn point(&self, l: usize, d: usize, shift: f32) -> f32 {
        let base = (l as u64 * self.generator[d] as u64 % self.k as u64) as f32 / self.k as f32;
        wrap01(base + shift)
    }
}

/// How a step records its samples (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Splatting {
    /// x* with weight a, x with 1 − a: unbiased.
    ExpectedValue,
    /// Every candidate y_l with a₁(x, y_l)/k, x with 1 − Σ_l a₁(x, y_l)/k,
    /// where a₁ is the one-proposal Metropolis–Hastings acceptance
    /// min(1, p(y)T(y→x) / (p(x)T(x→y))): the average of the k
    /// expected-value records of k ordinary Metropolis–Hastings steps from
    /// x, one per candidate. Unbiased (see the module docs) and records k
    /// samples per step instead of one; the reference set is traced only to
    /// move the chain. The default: 1.30× lower error than expected-value
    /// splatting at k = 16, m = 4 (docs/accuracy.md).
    #[default]
    Recycled,
    /// Segovia 2007's eq. 36: all k candidates and all k reference points, weighted
    /// by a·p(y_l)/F_y and (1 − a)·p(z_l)/F_z. Biased for k > 1 (kept for
    /// the measurement in the tests and for comparison).
    AllCandidates,
}

/// The step's rule: `Correct` in the library; the deliberately wrong
/// variants exist only in test builds, where the negative-control tests
/// run them through the very same code path (their branches are not
/// compiled into the library).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Variant {
    /// Liu et al. / Algorithm 3.
    Correct,
    /// Algorithm 4, step d as printed: reference set drawn from x (but
    /// weighed from x*).
    #[cfg(test)]
    ReferenceFromX,
    /// Algorithm 4, step e as printed: reference set drawn from x*, but
    /// weighed w(x, z_l).
    #[cfg(test)]
    DenominatorFromX,
    /// Steps d and e both as printed.
    #[cfg(test)]
    AsPrinted,
    /// Algorithm 4, step e-ii as printed: on rejection the side chain
    /// returns to the level-1 state x_i instead of keeping x_i^(j).
    #[cfg(test)]
    RejectToStart,
    /// [`Splatting::Recycled`] with T(y→x) taken equal to T(x→y), as if
    /// every perturbation were symmetric.
    #[cfg(test)]
    RecycledWithoutReverse,
}

impl Variant {
    /// Whether a k = 1 step may take the plain Metropolis–Hastings path
    /// (the variants that change the reference set need the general one).
    #[inline(always)]
    fn single_step(self) -> bool {
        match self {
            Variant::Correct => true,
            #[cfg(test)]
            Variant::RejectToStart => true,
            #[cfg(test)]
            _ => false,
        }
    }

    /// Whether a rejected side-chain step returns to the level-1 state.
    #[inline(always)]
    fn rejects_to_start(self) -> bool {
        #[cfg(test)]
        return self == Variant::RejectToStart;
        #[cfg(not(test))]
        false
    }
}

/// A chain state with its target value p (luminance, ≥ 0, finite).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ChainState<S> {
    /// The state.
    pub x: S,
    /// Its target value p(x).
    pub p: f32,
}

impl<S> ChainState<S> {
    /// A state with target value `p`; negative, NaN or infinite values
    /// become 0.
    pub fn new(x: S, p: f32) -> Self {
        ChainState {
            x,
            p: sanitize_target(p),
        }
    }
}

/// p if it is positive and finite, else 0: what the chain uses as target.
#[inline]
pub(crate) fn sanitize_target(p: f32) -> f32 {
    if p.is_finite() && p > 0.0 { p } else { 0.0 }
}

/// w = p(to) / T(from→to) (eqs. 34–35) for a candidate y drawn from
/// T(from→·): 0 when p = 0 or T is zero or non-finite. In exact arithmetic
/// a drawn candidate has T > 0; T = 0 means the density underflowed where
/// the sampler had (numerically) no mass, so weight 0 is the harmless
/// choice. Computed in f64: p/T overflows f32 for T near f32's subnormals.
#[inline]
pub(super) fn weight(p_to: f32, t_from_to: f32) -> f64 {
    if p_to > 0.0 && t_from_to > 0.0 && t_from_to.is_finite() {
        p_to as f64 / t_from_to as f64
    } else {
        0.0
    }
}

/// w(x*, z) for a reference point: as [`weight`], but `None` ("infinite")
/// when p(z) > 0 and T(x*→z) = 0. That happens for z_k = x when the
/// reverse density T(x*→x) underflows (a narrow perturbation at x* far
/// from x): w(x*, x) → ∞ and a → 0, so the step must reject. Treating it
/// as weight 0 instead would accept exactly the moves whose reverse is
/// (almost) impossible.
#[inline]
pub(super) fn reference_weight(p_to: f32, t_from_to: f32) -> Option<f64> {
    if p_to > 0.0 && !(t_from_to > 0.0 && t_from_to.is_finite()) {
        None
    } else {
        Some(weight(p_to, t_from_to))
    }
}

/// The Metropolis–Hastings acceptance of one proposal y drawn from x,
/// min(1, p(y)·T(y→x) / (p(x)·T(x→y))), in f64 (the products may leave
/// f32's range). 0 when p(y) = 0 or T(y→x) = 0 (the move cannot be
/// reversed), or when T(x→y) is zero or non-finite (y could not have been
/// drawn: [`weight`]'s convention); 1 when p(x) = 0 < p(y) (a chain started
/// on a black state moves on, as the level-1 chain does).
#[inline]
fn mh_acceptance(p_x: f32, p_y: f32, t_xy: f32, t_yx: f32) -> f32 {
    if !(p_y > 0.0 && t_yx > 0.0 && t_yx.is_finite() && t_xy > 0.0 && t_xy.is_finite()) {
        return 0.0;
    }
    if !(p_x > 0.0) {
        return 1.0;
    }
    let r = (p_y as f64 * t_yx as f64) / (p_x as f64 * t_xy as f64);
    r.min(1.0) as f32
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Index drawn with probability w_i / total for a uniform `u`; rounding
/// that runs past the end falls back to the last positive weight.
#[inline]
fn select(w: &[f64], total: f64, u: f32) -> usize {
    let t = u as f64 * total;
    let mut acc = 0.0;
    let mut last = 0;
    for (i, &wi) in w.iter().enumerate() {
        if wi > 0.0 {
            acc += wi;
            last = i;
            if t < acc {
                return i;
            }
        }
    }
    last
}

/// What one multiple-try step did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct MtmStep {
    /// Acceptance probability a = min(1, Σ w(x, y) / Σ w(x*, z)); 0 when
    /// no candidate had weight.
    pub acceptance: f32,
    /// Whether x* became the current state.
    pub accepted: bool,
    /// Index of x* among the candidates (`None` when none had weight).
    pub selected: Option<usize>,
    /// Candidates y with positive weight.
    pub nonzero: u32,
}

/// Result of a side chain.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SideChain<S> {
    /// The side chain's last state. For diagnostics and tests only: the
    /// level-1 chain continues from its own state (Algorithm 4, step 2).
    pub end: ChainState<S>,
    /// Steps run (m).
    pub steps: u32,
    /// Steps accepted.
    pub accepted: u32,
    /// Candidates with zero weight (zero target or a failed perturbation),
    /// over all steps.
    pub zero: u32,
}

/// The multiple-try stepper with scratch for up to `K` candidates and `K`
/// reference points (k ≤ K chosen at construction). Reuse one per thread:
/// steps allocate nothing.
#[derive(Clone, Debug)]
pub(crate) struct MultipleTry<S, const K: usize> {
    k: usize,
    splatting: Splatting,
    candidates: Candidates,
    lattice: Option<Lattice>,
    #[cfg(test)]
    variant: Variant,
    y: [Option<S>; K],
    py: [f32; K],
    /// T(x→y) of each candidate (0 for a failed one), for the weights and
    /// for recycled splatting's acceptances.
    ty: [f32; K],
    wy: [f64; K],
    /// Reference points z₁…z_{k−1} (z_k = x is not stored).
    z: [Option<S>; K],
    pz: [f32; K],
}

impl<S: Clone, const K: usize> MultipleTry<S, K> {
    /// A stepper drawing `k` independent candidates per step and recording
    /// with `splatting`. Panics unless 1 ≤ k ≤ K.
    pub fn new(k: usize, splatting: Splatting) -> Self {
        assert!(k >= 1 && k <= K, "k = {k} outside 1..={K}");
        MultipleTry {
            k,
            splatting,
            candidates: Candidates::Independent,
            lattice: None,
            #[cfg(test)]
            variant: Variant::Correct,
            y: core::array::from_fn(|_| None),
            py: [0.0; K],
            ty: [0.0; K],
            wy: [0.0; K],
            z: core::array::from_fn(|_| None),
            pz: [0.0; K],
        }
    }

    /// The same stepper drawing its candidates as `candidates` says, for
    /// proposals of `dim` uniforms (the lattice is built here, once).
    pub fn with_candidates(mut self, candidates: Candidates, dim: usize) -> Self {
        self.candidates = candidates;
        self.lattice = (candidates == Candidates::Stratified).then(|| Lattice::new(self.k, dim));
        self
    }

    /// The rule this stepper runs: always [`Variant::Correct`] outside the
    /// tests.
    #[inline(always)]
    fn variant(&self) -> Variant {
        #[cfg(test)]
        return self.variant;
        #[cfg(not(test))]
        Variant::Correct
    }

    /// Selects a deliberately wrong variant (negative controls only; they
    /// apply to independent candidates).
    #[cfg(test)]
    pub(crate) fn with_variant(mut self, variant: Variant) -> Self {
        self.variant = variant;
        self
    }

    /// One multiple-try step from `state` (updated in place on acceptance),
    /// reporting its records to `splat(state, weight)`. The k candidates
    /// are evaluated by `target` as one batch, the k − 1 reference points
    /// as another.
    pub fn step<P, T, R>(
        &mut self,
        proposal: &P,
        target: &mut T,
        state: &mut ChainState<S>,
        rng: &mut R,
        splat: &mut impl FnMut(&S, f32),
    ) -> MtmStep
    where
        P: Proposal<S>,
        T: Target<S> + ?Sized,
        R: Sampler + ?Sized,
    {
        const { assert!(P::DIM <= MAX_PROPOSAL_DIM) };
        let k = self.k;
        let variant = self.variant();
        if k == 1 && variant.single_step() {
            return self.step_single(proposal, target, state, rng, splat);
        }
        let lattice = match self.candidates {
            Candidates::Stratified => self.lattice,
            Candidates::Independent => None,
        };
        let Self {
            y,
            py,
            ty,
            wy,
            z,
            pz,
            ..
        } = self;
        let x = &state.x;

        // b): k candidates from x, independent or one shifted lattice.
        match &lattice {
            None => {
                for yl in y.iter_mut().take(k) {
                    *yl = draw(proposal, x, rng);
                }
            }
            Some(lat) => {
                let mut shift = [0.0f32; MAX_PROPOSAL_DIM];
                for v in &mut shift[..P::DIM] {
                    *v = rng.next_f32();
                }
                for (l, yl) in y.iter_mut().take(k).enumerate() {
                    *yl = lattice_draw(proposal, x, lat, l, &shift);
                }
            }
        }
        // c): one batch through the target, weighed w(x, y) = p(y)/T(x→y).
        py[..k].fill(0.0);
        target.evaluate(&mut y[..k], &mut py[..k]);
        let mut wy_sum = 0.0f64;
        let mut nonzero = 0;
        for l in 0..k {
            let (p, t) = match &y[l] {
                Some(c) => (sanitize_target(py[l]), proposal.density(x, c)),
                None => (0.0, 0.0),
            };
            let w = weight(p, t);
            py[l] = p;
            ty[l] = t;
            wy[l] = w;
            wy_sum += w;
            nonzero += (w > 0.0) as u32;
        }
        if !(wy_sum > 0.0) {
            // Nothing to select: reject without a reference set.
            if state.p > 0.0 {
                splat(&state.x, 1.0);
            }
            return MtmStep {
                acceptance: 0.0,
                accepted: false,
                selected: None,
                nonzero,
            };
        }
        let sel = if k == 1 {
            0
        } else {
            select(&wy[..k], wy_sum, rng.next_f32())
        };
        let x_star = y[sel].as_ref().expect("selected candidates have weight");

        // d): reference set z₁…z_{k−1} ~ T(x*→·), z_k = x; e): weighed
        // w(x*, z). The variants reproduce the printed typos.
        let draw_from = match variant {
            #[cfg(test)]
            Variant::ReferenceFromX | Variant::AsPrinted => x,
            _ => x_star,
        };
        let weigh_from = match variant {
            #[cfg(test)]
            Variant::DenominatorFromX | Variant::AsPrinted => x,
            _ => x_star,
        };
        // False when the lattice through x cannot be rebuilt from x* (the
        // proposal cannot invert the move): the step must reject.
        let mut reference_ok = true;
        match &lattice {
            None => {
                for zl in z.iter_mut().take(k - 1) {
                    *zl = draw(proposal, draw_from, rng);
                }
            }
            Some(lat) => {
                // Shift Δ′ that puts lattice point `sel` on the uniforms of
                // x as drawn from x*; the other points are the z.
                let mut ux = [0.0f32; MAX_PROPOSAL_DIM];
                reference_ok = proposal.invert(x_star, x, &mut ux[..P::DIM]);
                let mut shift = [0.0f32; MAX_PROPOSAL_DIM];
                for d in 0..P::DIM {
                    shift[d] = ux[d] - lat.point(sel, d, 0.0);
                }
                for (i, l) in (0..k).filter(|&l| l != sel).enumerate() {
                    z[i] = if reference_ok {
                        lattice_draw(proposal, x_star, lat, l, &shift)
                    } else {
                        None
                    };
                }
            }
        }
        pz[..k - 1].fill(0.0);
        if reference_ok {
            target.evaluate(&mut z[..k - 1], &mut pz[..k - 1]);
        }
        // None: some reference point has infinite weight (see
        // `reference_weight`), so a = 0.
        let mut wz_sum = Some(0.0f64);
        for l in 0..k - 1 {
            let (p, w) = match &z[l] {
                Some(c) => {
                    let p = sanitize_target(pz[l]);
                    (p, reference_weight(p, proposal.density(weigh_from, c)))
                }
                None => (0.0, Some(0.0)),
            };
            pz[l] = p;
            wz_sum = wz_sum.zip(w).map(|(s, w)| s + w);
        }
        let wx = reference_weight(state.p, proposal.density(weigh_from, x));
        wz_sum = wz_sum.zip(wx).map(|(s, w)| s + w);

        let a = match wz_sum {
            _ if !reference_ok => 0.0,
            None => 0.0,
            Some(wz) if wz > 0.0 => (wy_sum / wz).min(1.0) as f32,
            // Only when p(x) = 0 and every z has p = 0: move on.
            Some(_) => 1.0,
        };
        // a = 1 always accepts (u < 1), a = 0 never does.
        let accepted = rng.next_f32() < a;

        match self.splatting {
            Splatting::ExpectedValue => {
                if a > 0.0 {
                    splat(x_star, a);
                }
                if a < 1.0 && state.p > 0.0 {
                    splat(&state.x, 1.0 - a);
                }
            }
            Splatting::Recycled => {
                // The k one-proposal records, averaged; they do not depend
                // on x*, a or the reference set.
                let mut rest = 1.0f32;
                for l in 0..k {
                    if let Some(c) = &y[l] {
                        let t_xy = ty[l];
                        let t_yx = match variant {
                            #[cfg(test)]
                            Variant::RecycledWithoutReverse => t_xy,
                            _ => proposal.density(c, x),
                        };
                        let a1 = mh_acceptance(state.p, py[l], t_xy, t_yx);
                        if a1 > 0.0 {
                            let w = a1 / k as f32;
                            splat(c, w);
                            rest -= w;
                        }
                    }
                }
                if rest > 0.0 && state.p > 0.0 {
                    splat(&state.x, rest);
                }
            }
            Splatting::AllCandidates => {
                // Eq. 36. F_y > 0: some candidate has weight, so p > 0.
                let fy: f32 = py[..k].iter().sum();
                if a > 0.0 {
                    for l in 0..k {
                        if let (Some(c), true) = (&y[l], py[l] > 0.0) {
                            splat(c, a * py[l] / fy);
                        }
                    }
                }
                let fz: f32 = pz[..k - 1].iter().sum::<f32>() + state.p;
                if a < 1.0 && fz > 0.0 {
                    let b = 1.0 - a;
                    for l in 0..k - 1 {
                        if let (Some(c), true) = (&z[l], pz[l] > 0.0) {
                            splat(c, b * pz[l] / fz);
                        }
                    }
                    if state.p > 0.0 {
                        splat(&state.x, b * state.p / fz);
                    }
                }
            }
        }

        if accepted {
            state.p = py[sel];
            state.x = y[sel].take().expect("selected candidates exist");
        }
        MtmStep {
            acceptance: a,
            accepted,
            selected: Some(sel),
            nonzero,
        }
    }

    /// [`MultipleTry::step`] for k = 1: a Metropolis–Hastings step with
    /// a = min(1, p(y)T(y→x) / (p(x)T(x→y))), the multiple-try ratio
    /// w(x, y)/w(y, x) with the reference set reduced to z₁ = x. It does
    /// only what that needs: no selection, no reference set (so no
    /// [`Proposal::invert`] of the lattice through x, which has no other
    /// point), no empty batch through the target, and T(y→x) evaluated
    /// once (not at all for a [`Proposal::SYMMETRIC`] proposal). All
    /// three splatting rules record y with a and x with 1 − a at k = 1
    /// (see the module docs), so they share this code. Random numbers:
    /// `DIM` for y (a one-point lattice is its shift), one for the test —
    /// the general step's.
    fn step_single<P, T, R>(
        &mut self,
        proposal: &P,
        target: &mut T,
        state: &mut ChainState<S>,
        rng: &mut R,
        splat: &mut impl FnMut(&S, f32),
    ) -> MtmStep
    where
        P: Proposal<S>,
        T: Target<S> + ?Sized,
        R: Sampler + ?Sized,
    {
        let x = &state.x;
        let y = &mut self.y[..1];
        y[0] = draw(proposal, x, rng);
        let mut py = [0.0f32];
        target.evaluate(y, &mut py);
        // A symmetric T cancels from a: only p matters, and T(x→y) of a
        // drawn y stands for any positive value (weight's > 0 test).
        let (p_y, t_xy) = match &y[0] {
            Some(_) if P::SYMMETRIC => (sanitize_target(py[0]), 1.0),
            Some(c) => (sanitize_target(py[0]), proposal.density(x, c)),
            None => (0.0, 0.0),
        };
        let wy = weight(p_y, t_xy);
        if !(wy > 0.0) {
            if state.p > 0.0 {
                splat(&state.x, 1.0);
            }
            return MtmStep {
                acceptance: 0.0,
                accepted: false,
                selected: None,
                nonzero: 0,
            };
        }
        let cand = y[0].as_ref().expect("a candidate with weight exists");
        let t_yx = if P::SYMMETRIC {
            t_xy
        } else {
            proposal.density(cand, x)
        };
        let a = match reference_weight(state.p, t_yx) {
            None => 0.0,
            Some(wx) if wx > 0.0 => (wy / wx).min(1.0) as f32,
            // Only when p(x) = 0: move on.
            Some(_) => 1.0,
        };
        let accepted = rng.next_f32() < a;
        if a > 0.0 {
            splat(cand, a);
        }
        if a < 1.0 && state.p > 0.0 {
            splat(&state.x, 1.0 - a);
        }
        if accepted {
            state.p = p_y;
            state.x = self.y[0].take().expect("the candidate exists");
        }
        MtmStep {
            acceptance: a,
            accepted,
            selected: Some(0),
            nonzero: 1,
        }
    }

    /// The side chain of Algorithm 4, step 1 (corrected): `m` steps from a
    /// copy of the level-1 state `start`, each from the side chain's own
    /// current state, recording every step through `splat`. `start` is not
    /// modified: level 1 continues from it.
    pub fn side_chain<P, T, R>(
        &mut self,
        proposal: &P,
        target: &mut T,
        start: &ChainState<S>,
        m: u32,
        rng: &mut R,
        splat: &mut impl FnMut(&S, f32),
    ) -> SideChain<S>
    where
        P: Proposal<S>,
        T: Target<S> + ?Sized,
        R: Sampler + ?Sized,
    {
        let mut current = start.clone();
        let (mut accepted, mut zero) = (0, 0);
        for _ in 0..m {
            let st = self.step(proposal, target, &mut current, rng, splat);
            accepted += st.accepted as u32;
            zero += self.k as u32 - st.nonzero;
            if !st.accepted && self.variant().rejects_to_start() {
                current = start.clone();
            }
        }
        SideChain {
            end: current,
            steps: m,
            accepted,
            zero,
        }
    }
}

/// Candidate `l` of the lattice `lat` shifted by `shift`, from `from`.
#[inline]
fn lattice_draw<S, P: Proposal<S>>(
    proposal: &P,
    from: &S,
    lat: &Lattice,
    l: usize,
    shift: &[f32; MAX_PROPOSAL_DIM],
) -> Option<S> {
    let mut u = [0.0f32; MAX_PROPOSAL_DIM];
    for d in 0..P::DIM {
        u[d] = lat.point(l, d, shift[d]);
    }
    proposal.sample(from, &u[..P::DIM])
}

/// One candidate from `from` with `P::DIM` fresh uniforms.
#[inline]
fn draw<S, P: Proposal<S>, R: Sampler + ?Sized>(proposal: &P, from: &S, rng: &mut R) -> Option<S> {
    const { assert!(P::DIM <= MAX_PROPOSAL_DIM) };
    let mut u = [0.0f32; MAX_PROPOSAL_DIM];
    for v in &mut u[..P::DIM] {
        *v = rng.next_f32();
    }
    proposal.sample(from, &u[..P::DIM])
}

#[cfg(test)]
pub(crate) mod tests;

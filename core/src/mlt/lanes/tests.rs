//! Tests of the parallel side chains on the toy target of the multiple-try
//! tests (a ramp, a block with hard edges, a hole): many independent
//! level-1 states drawn exactly from p, each followed by its side chain;
//! every state's records are one i.i.d. draw, so each cell's mean total is
//! checked against its exact mass with a per-cell z bound (Bonferroni,
//! valid however the cells and the lanes are correlated).

extern crate std;
use std::eprintln;

use glam::Vec2;

use super::*;
use crate::mlt::multiple_try::tests::{
    Independence, N, StateSigma, SymmetricWalk, Walk, Z_MAX, cell, cell_mass, p, sample_target,
    walk,
};
use crate::sampler::SampleStream;

/// The class of a toy state: the left half (0) or the right half (1).
fn class(v: Vec2) -> usize {
    (v.x >= 0.5) as usize
}

/// [`Walk`] that never leaves its class: a candidate across x = ½ fails
/// (as a lens candidate that changes the path's specular pattern does).
struct ClassWalk(Walk);

impl Proposal<Vec2> for ClassWalk {
    const DIM: usize = 2;
    fn sample(&self, from: &Vec2, u: &[f32]) -> Option<Vec2> {
        self.0.sample(from, u).filter(|y| class(*y) == class(*from))
    }
    fn density(&self, from: &Vec2, to: &Vec2) -> f32 {
        if class(*to) == class(*from) {
            self.0.density(from, to)
        } else {
            0.0
        }
    }
}

/// How the harness weighs a side chain.
#[derive(Clone, Copy, PartialEq)]
enum Weighting {
    /// Total `share` per side chain, whatever its length (the rule).
    Share,
    /// Weight 1/n per lane step: total m(c), not the share (wrong when the
    /// lengths differ between classes).
    PerRecord,
}

/// Level 1 in equilibrium (exact samples of p) followed by the side chain
/// of its class: `lengths[class]` steps of `n` lanes, carrying `share`; a
/// class of length 0 records its level-1 state with weight 1 + share.
/// Returns (max_c |z_c|, max relative deviation) of the cells' mean totals
/// against (1 + share)·P_c.
#[allow(clippy::too_many_arguments)]
fn deviation<P: Proposal<Vec2>>(
    proposal: &P,
    n: usize,
    variant: LaneVariant,
    lengths: [u32; 2],
    share: f32,
    weighting: Weighting,
    chains: u32,
    seed: u64,
) -> (f64, f64) {
    let mut lanes = Lanes::<Vec2, 16>::new(n, P::DIM).with_variant(variant);
    let mut sum = [0f64; N * N];
    let mut sum2 = [0f64; N * N];
    let mut local = [0f64; N * N];
    for c in 0..chains as u64 {
        let mut s = SampleStream::new(seed, n as u64, c);
        let start = sample_target(&mut s);
        let m = lengths[class(start.x)];
        local.fill(0.0);
        local[cell(start.x)] += 1.0 + if m == 0 { share as f64 } else { 0.0 };
        let chain_share = match weighting {
            Weighting::Share => share,
            Weighting::PerRecord => m as f32,
        };
        lanes.run(
            proposal,
            &mut |v: &Vec2| p(*v),
            &start,
            m,
            chain_share,
            &mut s,
            &mut |v, w| {
                assert!(w > 0.0 && w.is_finite(), "weight {w}");
                local[cell(*v)] += w as f64;
            },
        );
        if weighting == Weighting::Share {
            let total: f64 = local.iter().sum();
            assert!((total - 1.0 - share as f64).abs() < 1e-4 * (1.0 + share as f64));
        }
        for (i, &x) in local.iter().enumerate() {
            sum[i] += x;
            sum2[i] += x * x;
        }
    }
    let nf = chains as f64;
    let (mut zmax, mut rel_max) = (0.0f64, 0.0f64);
    for c in 0..N * N {
        let e = cell_mass(c % N, c / N) * (1.0 + share as f64);
        if e == 0.0 {
            assert_eq!(sum[c], 0.0, "records where p = 0");
            continue;
        }
        let mean = sum[c] / nf;
        let var = (sum2[c] / nf - mean * mean).max(1e-300) * nf / (nf - 1.0);
        zmax = zmax.max((mean - e).abs() / (var / nf).sqrt());
        rel_max = rel_max.max((mean - e).abs() / e);
    }
    (zmax, rel_max)
}

const CHAINS: u32 = 20_000;

/// Every lane count keeps p, with symmetric, state-dependent and
/// independence proposals (the last one fails 10% of its candidates).
#[test]
fn lanes_keep_target() {
    fn check<P: Proposal<Vec2>>(name: &str, proposal: &P, seed: u64) {
        for n in [1, 4, 16] {
            let (z, rel) = deviation(
                proposal,
                n,
                LaneVariant::Correct,
                [8, 8],
                8.0,
                Weighting::Share,
                CHAINS,
                seed,
            );
            eprintln!("lanes, {name}, n = {n}: max |z| = {z:.2}, max rel {rel:.3}");
            assert!(z < Z_MAX, "{name}, n = {n}: max |z| = {z:.2}");
        }
    }
    check("walk", &walk(), 51);
    check("symmetric walk", &SymmetricWalk(walk()), 52);
    check("state-σ", &StateSigma, 53);
    check("independence", &Independence, 54);
}

/// Negative controls: one accept decision for the whole packet, or each
/// lane's acceptance taken against the start, record the wrong density.
#[test]
fn broken_lanes_fail() {
    for (name, variant) in [
        ("one decision", LaneVariant::OneDecision),
        ("start reference", LaneVariant::StartReference),
    ] {
        let (z, rel) = deviation(
            &walk(),
            8,
            variant,
            [8, 8],
            8.0,
            Weighting::Share,
            CHAINS,
            55,
        );
        eprintln!("{name}: max |z| = {z:.2}, max rel {rel:.3}");
        assert!(z > 2.0 * Z_MAX, "{name} passed: max |z| = {z:.2}");
    }
}

/// Side chains whose length depends on the class (none on the left, long
/// on the right, or both but of different lengths), each carrying the same
/// share, keep p; the same lengths with weight 1 per record, or with a
/// proposal that leaves its class, do not.
#[test]
fn class_lengths_keep_target() {
    let class_walk = ClassWalk(walk());
    for (lengths, n) in [([0, 4], 1), ([0, 4], 4), ([2, 8], 4)] {
        let (z, rel) = deviation(
            &class_walk,
            n,
            LaneVariant::Correct,
            lengths,
            4.0,
            Weighting::Share,
            CHAINS,
            56,
        );
        eprintln!("class lengths {lengths:?}, n = {n}: max |z| = {z:.2}, max rel {rel:.3}");
        assert!(z < Z_MAX, "{lengths:?}, n = {n}: max |z| = {z:.2}");
    }
    // Weight per record instead of per side chain.
    let (z, _) = deviation(
        &class_walk,
        4,
        LaneVariant::Correct,
        [2, 8],
        4.0,
        Weighting::PerRecord,
        CHAINS,
        57,
    );
    eprintln!("weight per record: max |z| = {z:.2}");
    assert!(
        z > 2.0 * Z_MAX,
        "weight per record passed: max |z| = {z:.2}"
    );
    // A side chain that leaves its class: the right half's chains spread
    // its share over the left half too, which also gets its own.
    let (z, _) = deviation(
        &walk(),
        4,
        LaneVariant::Correct,
        [0, 4],
        4.0,
        Weighting::Share,
        CHAINS,
        58,
    );
    eprintln!("class left: max |z| = {z:.2}");
    assert!(
        z > 2.0 * Z_MAX,
        "class-leaving side chain passed: max |z| = {z:.2}"
    );
}

/// One lane is the multiple-try step at k = 1, random number for random
/// number: the same records and the same end state.
#[test]
fn one_lane_is_the_single_step() {
    use crate::mlt::multiple_try::{MultipleTry, Splatting};
    for c in 0..200u64 {
        let mut s = SampleStream::new(59, 0, c);
        let start = sample_target(&mut s);
        let mut a = std::vec::Vec::new();
        let mut b = std::vec::Vec::new();
        let mut s1 = s.clone();
        let mut mtm = MultipleTry::<Vec2, 4>::new(1, Splatting::ExpectedValue);
        mtm.side_chain(
            &walk(),
            &mut |v: &Vec2| p(*v),
            &start,
            6,
            &mut s1,
            &mut |v, w| a.push((*v, w)),
        );
        let mut lanes = Lanes::<Vec2, 4>::new(1, 2);
        lanes.run(
            &walk(),
            &mut |v: &Vec2| p(*v),
            &start,
            6,
            6.0,
            &mut s,
            &mut |v, w| b.push((*v, w)),
        );
        assert_eq!(a, b, "chain {c}");
    }
}

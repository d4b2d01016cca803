//! Which mutation the path-space chain tries at a path (Veach 1997,
//! §11.4): each mutation that applies to the path with probability its
//! weight ([`PathMutations`]) over the sum of the weights of those that
//! apply. A mutation's probability at the proposed path enters its
//! acceptance ratio (`chain.rs`): p_m(ȳ)/p_m(x̄), which is 1 for moves
//! that keep the set of mutations that apply.

use super::lens_subpath;
use crate::integrator::bdpt::PathVertex;
use crate::mlt::PathMutations;
use crate::mlt::perturbation::Applicable;

/// A path-space level-1 mutation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Mutation {
    /// A new lens subpath (`lens_subpath.rs`).
    LensSubpath,
    /// Delete a subpath, regenerate it from both ends (`bidirectional.rs`).
    Bidirectional,
    /// The lens perturbation (`perturbations.rs`).
    Lens,
    /// The caustic perturbation (`perturbations.rs`).
    Caustic,
    /// The multi-chain perturbation (`perturbations.rs`).
    MultiChain,
}

impl Mutation {
    /// Every mutation, in the order of [`Probabilities`] (the lens subpath
    /// mutation first: without perturbations a chain draws the mutations
    /// from its random numbers as it did before they existed).
    pub const ALL: [Mutation; 5] = [
        Mutation::LensSubpath,
        Mutation::Bidirectional,
        Mutation::Lens,
        Mutation::Caustic,
        Mutation::MultiChain,
    ];

    /// The perturbation that applies to a path of class `class`.
    pub fn perturbation(class: &Applicable) -> Option<Mutation> {
        match class {
            Applicable::Lens(_) => Some(Mutation::Lens),
            Applicable::Caustic(_) => Some(Mutation::Caustic),
            Applicable::MultiChain(_) => Some(Mutation::MultiChain),
            Applicable::Neither => None,
        }
    }
}

/// The probability of each mutation at one path, in [`Mutation::ALL`]'s
/// order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Probabilities([f32; 5]);

impl Probabilities {
    /// The probabilities at `path`, whose class is `class`, under
    /// `weights` (module docs).
    pub fn at(weights: &PathMutations, path: &[PathVertex], class: &Applicable) -> Self {
        let mut p = [0.0f32; 5];
        p[Mutation::Bidirectional as usize] = weights.bidirectional;
        if lens_subpath::applies(path).is_some() {
            p[Mutation::LensSubpath as usize] = weights.lens_subpath;
        }
        match Mutation::perturbation(class) {
            Some(m @ Mutation::Lens) => p[m as usize] = weights.lens,
            Some(m @ Mutation::Caustic) => p[m as usize] = weights.caustic,
            Some(m @ Mutation::MultiChain) => p[m as usize] = weights.multi_chain,
            _ => {}
        }
        // The bidirectional weight is positive (`PathMutations::validate`).
        let total: f32 = p.iter().sum();
        Probabilities(p.map(|w| w / total))
    }

    /// The probability of `m`.
    pub fn of(&self, m: Mutation) -> f32 {
        self.0[m as usize]
    }

    /// The mutation at `u` ∈ [0, 1) of the cumulative probabilities.
    pub fn pick(&self, u: f32) -> Mutation {
        let mut acc = 0.0;
        for m in Mutation::ALL {
            acc += self.of(m);
            if u < acc {
                return m;
            }
        }
        // Rounding left u above the sum: the last mutation that applies.
        Mutation::ALL
            .into_iter()
            .rev()
            .find(|&m| self.of(m) > 0.0)
            .unwrap_or(Mutation::Bidirectional)
    }
}

//! The path-space level 1 (Veach and Guibas 1997; Veach 1997, ch. 11),
//! beside the primary-sample one: a chain's state is a path x̄ = x₀ (lens)
//! … x_k (emitter), its vertices with their surface records, and its
//! target is Y(f(x̄)), the luminance of the path's measurement contribution
//! in the product area measure. A mutation proposes a path ȳ with a
//! density T(x̄→ȳ) in that measure and is accepted with probability
//! min(1, f(ȳ)T(ȳ→x̄) / (f(x̄)T(x̄→ȳ))).
//!
//! What exists: the measure every mutation's ratio is made of,
//! f(x̄) and the area densities with which BDPT's strategies generate each
//! vertex ([`crate::integrator::bdpt::path_contribution`],
//! [`crate::integrator::bdpt::path_densities`]), checked here against
//! BDPT's own unweighted strategy estimates (`tests`). Not yet: the
//! state and start-up, the bidirectional and lens-subpath mutations, the
//! perturbations as level-1 mutations, the chain and its selection by
//! `Level1`.

// Not yet driven by the renderer: its tests use it (the chain's wiring
// behind `Level1` is the next step).
#![cfg_attr(not(test), allow(dead_code))]

pub(crate) mod bidirectional;
pub(crate) mod chain;
pub(crate) mod state;

#[cfg(all(test, feature = "std"))]
mod tests;

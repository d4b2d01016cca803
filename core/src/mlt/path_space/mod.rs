//! The path-space level 1 (Veach and Guibas 1997; Veach 1997, ch. 11),
//! beside the primary-sample one: a chain's state is a path x̄ = x₀ (lens)
//! … x_k (emitter), its vertices with their surface records, and its
//! target is Y(f(x̄)), the luminance of the path's measurement contribution
//! in the product area measure. A mutation proposes a path ȳ with a
//! density T(x̄→ȳ) in that measure and is accepted with probability
//! min(1, f(ȳ)T(ȳ→x̄) / (f(x̄)T(x̄→ȳ))).
//!
//! What exists: the measure every mutation's ratio is made of, f(x̄) and
//! the area densities with which BDPT's strategies generate each vertex
//! ([`crate::integrator::bdpt::path_contribution`],
//! [`crate::integrator::bdpt::path_densities`]); the state and Veach's
//! start-up (`state`); the bidirectional mutation (`bidirectional`), the
//! lens subpath mutation (`lens_subpath`) and level 2's lens, caustic and
//! multi-chain perturbations as level-1 mutations (`perturbations`); the
//! choice among those that apply to a path (`selection`); the chain with
//! its expected-value records (`chain`); a worker's chains as the renderer
//! drives them (`worker`), selected by [`super::Level1::PathSpace`] for
//! MLT, and with CMLT's level 2 run from each state (`worker`'s docs say
//! why one level 2 serves both level 1s); paths ending on every kind of
//! emitter — area, point, spot, directional and environment lights
//! (`emitters`; the perturbations leave paths ending on the lights that
//! are not meshes alone, `mlt::perturbation::classify`); participating
//! media and null boundaries (`media`: the walks sample free flights and
//! cross null boundaries, f(x̄) has each segment's transmittance and the
//! densities BDPT's free-flight densities, `PathState::evaluate`; the
//! perturbations retrace their rays through media as level 2 does,
//! keeping a moving medium vertex's free-flight distance,
//! `perturbations.rs`). Not yet: stratified raster positions for the lens
//! subpath mutation; paths through a mixed BSDF's Dirac lobe (smooth
//! plastic's coating), which f(x̄) cannot evaluate (`state.rs`): the
//! renderer refuses such a scene here (`renderer::check_path_space`).

pub(crate) mod bidirectional;
pub(crate) mod chain;
mod emitters;
pub(crate) mod lens_subpath;
mod media;
pub(crate) mod perturbations;
pub(crate) mod selection;
pub(crate) mod state;
pub(crate) mod worker;

#[cfg(all(test, feature = "std"))]
mod emitter_tests;
#[cfg(all(test, feature = "std"))]
mod perturbation_tests;
#[cfg(all(test, feature = "std"))]
mod stationary_tests;
#[cfg(all(test, feature = "std"))]
mod tests;

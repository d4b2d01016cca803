//! The lens, caustic and multi-chain perturbations as path-space level-1
//! mutations (Veach and Guibas 1997, §3.3; Veach 1997, §11.4.3): level 2's
//! perturbations ([`crate::mlt::perturbation`]: which one applies, what it
//! keeps fixed, its proposal and its target), made into moves between
//! paths.
//!
//! ## The move
//!
//! The path's class ([`classify`]) gives the perturbation and its anchor,
//! the fixed part of the path. The path's coordinates in the
//! perturbation's own measure (its raster position at the fixed lens
//! point; the direction leaving x_j; both for the multi-chain one) are read
//! from its vertices, the proposal offsets them ([`Proposals`]), and the
//! proposed path's vertices are traced from the new coordinates through
//! the same specular lobes ([`follow`]) and joined to the fixed part.
//!
//! ## Its ratio
//!
//! Level 2's target at coordinates u is p(u) = c · Y(f(x̄(u))) · |∂x̄/∂u|,
//! Y(f) times the Jacobian from the coordinates to the moving vertices'
//! area measure, c a constant of the anchor (`perturbation/mod.rs`).
//! The proposal is symmetric in u, so in the area measure
//! T(x̄→ȳ) = q(u_y − u_x) / |∂ȳ/∂u| and
//!
//! T(ȳ→x̄) / T(x̄→ȳ) = |∂ȳ/∂u| / |∂x̄/∂u| = (p(u_y)/Y(f(ȳ))) / (p(u_x)/Y(f(x̄))),
//!
//! so the chain's Y(f(ȳ))T(ȳ→x̄) / (Y(f(x̄))T(x̄→ȳ)) is p(u_y)/p(u_x), the
//! ratio level 2 accepts with. Both values come from the same target
//! function of the same anchor (the lens perturbation values its start
//! from the stored vertices, as level 2 does): a path both ways round
//! gets the same value. The tests check the ratio against T computed from
//! [`crate::integrator::bdpt::path_densities`] instead.
//!
//! Every perturbation keeps the path's depth, its pattern of specular
//! vertices and their lobes, and its anchor: the proposed path has the
//! same class, so the same perturbation applies to it with the same
//! anchor, and the reverse move exists.
//!
//! ## Through media
//!
//! In a scene with media the rays are retraced as level 2's targets
//! retrace them (`perturbation/media.rs`): null boundaries crossed, and a
//! moving medium vertex placed at the free-flight distance s its class
//! keeps. The coordinates are then (u, s) with s fixed, level 2's target
//! is the density in them (its Jacobian has the volume element s² of such
//! a vertex), and the ratio above holds as it stands; the tests check it
//! against the path's densities on `fog_box`.

use alloc::vec::Vec;

use glam::{Vec2, Vec3};

use super::bidirectional::{Proposal, surface_vertex};
use super::state::PathState;
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, offset};
use crate::integrator::Tracer;
use crate::integrator::bdpt::PathVertex;
use crate::math::Rgb;
use crate::mlt::multiple_try::{Proposal as Offset, Target};
use crate::mlt::perturbation::{
    Applicable, CausticAnchor, CausticState, CausticTarget, LensAnchor, LensState, LensTarget,
    MultiChainAnchor, MultiChainState, MultiChainTarget, Proposals, SpecularChain,
};
#[cfg(feature = "media")]
use crate::mlt::perturbation::{caustic_vertices, lens_vertices, multi_chain_vertices};
use crate::sampler::Sampler;

/// The three perturbations as level-1 mutations, with their proposals and
/// scratch storage.
#[derive(Clone, Debug)]
pub(crate) struct Perturbations {
    /// `None`: invalid offsets, never chosen (`chain.rs`).
    proposals: Option<Proposals>,
    /// The caustic perturbation's new vertices, from x_j towards the lens.
    scratch: Vec<PathVertex>,
    /// The tests' negative control: the ratio without the Jacobians, as if
    /// T were symmetric in the area measure.
    #[cfg(test)]
    pub broken: bool,
}

impl Perturbations {
    /// The perturbations drawing from `proposals`, for paths of up to
    /// `max_depth` segments.
    pub fn new(proposals: Option<Proposals>, max_depth: u32) -> Self {
        Perturbations {
            proposals,
            scratch: Vec::with_capacity(max_depth as usize + 1),
            #[cfg(test)]
            broken: false,
        }
    }

    /// Makes ȳ from `x`, whose class is `class` (not `Neither`), in `y`.
    pub fn propose<I: Intersector, R: Sampler>(
        &mut self,
        tr: &mut Tracer<'_, I>,
        x: &PathState,
        class: &Applicable,
        y: &mut PathState,
        rng: &mut R,
    ) -> Proposal {
        let mut u = [0.0f32; 4];
        for v in &mut u {
            *v = rng.next_f32();
        }
        let Some(to) = self.sample(x, class, &u) else {
            return Proposal::Failed;
        };
        self.propose_to(tr, x, class, &to, y)
    }

    /// The coordinates the proposal draws from `x` with the uniforms `u`;
    /// `None` when they leave the image, `class` is `Neither` or the
    /// offsets are invalid.
    pub fn sample(&self, x: &PathState, class: &Applicable, u: &[f32; 4]) -> Option<Coordinates> {
        let p = self.proposals.as_ref()?;
        match (class, coordinates(x, class)?) {
            (Applicable::Lens(_), Coordinates::Lens(s)) => {
                p.lens.sample(&s, &u[..2]).map(Coordinates::Lens)
            }
            (Applicable::Caustic(_), Coordinates::Caustic(s)) => {
                p.caustic.sample(&s, &u[..2]).map(Coordinates::Caustic)
            }
            (Applicable::MultiChain(_), Coordinates::MultiChain(s)) => p
                .multi_chain
                .sample(&s, &u[..4])
                .map(Coordinates::MultiChain),
            _ => None,
        }
    }

    /// Makes the path at coordinates `to` with `x`'s anchor (`class`) in
    /// `y`, with T(ȳ→x̄)/T(x̄→ȳ) (module docs).
    pub fn propose_to<I: Intersector>(
        &mut self,
        tr: &mut Tracer<'_, I>,
        x: &PathState,
        class: &Applicable,
        to: &Coordinates,
        y: &mut PathState,
    ) -> Proposal {
        let Some((p_x, p_y)) = values(tr, x, class, to) else {
            return Proposal::Failed;
        };
        if !(p_y > 0.0 && p_x > 0.0) {
            return Proposal::Failed;
        }
        y.f = Rgb::ZERO;
        if self.build(tr, &x.path, class, to, &mut y.path).is_none() || y.path.len() != x.path.len()
        {
            return Proposal::Failed;
        }
        y.evaluate(tr);
        let (y_x, y_y) = (x.target(), y.target());
        if !(y_y > 0.0) {
            return Proposal::Failed;
        }
        #[cfg(test)]
        if self.broken {
            return Proposal::Made { ratio: 1.0 };
        }
        let ratio = (p_y / y_y) / (p_x / y_x);
        if ratio.is_finite() && ratio > 0.0 {
            Proposal::Made { ratio }
        } else {
            Proposal::Failed
        }
    }

    /// Traces ȳ's moving vertices into `y` from the coordinates `to` and
    /// joins them to the fixed ones of x̄ (`x`, whose class is `class`);
    /// `None` when a specular link fails.
    fn build<I: Intersector>(
        &mut self,
        tr: &mut Tracer<'_, I>,
        x: &[PathVertex],
        class: &Applicable,
        to: &Coordinates,
        y: &mut Vec<PathVertex>,
    ) -> Option<()> {
        y.clear();
        y.push(x[0]);
        match (class, to) {
            (Applicable::Lens(a), Coordinates::Lens(s)) => {
                lens_part(tr, a, s.raster, y)?;
                y.extend_from_slice(x.get(a.chain.len() + 2..)?);
            }
            (Applicable::Caustic(a), Coordinates::Caustic(s)) => {
                self.scratch.clear();
                caustic_part(tr, a, s.dir, &mut self.scratch)?;
                y.extend(self.scratch.iter().rev());
                y.extend_from_slice(x.get(a.chain.len() + 2..)?);
            }
            (Applicable::MultiChain(a), Coordinates::MultiChain(s)) => {
                multi_chain_part(tr, a, s.raster, s.dir, y)?;
                y.extend_from_slice(x.get(a.first.len() + a.second.len() + 3..)?);
            }
            _ => return None,
        }
        Some(())
    }
}

/// The lens perturbation's moving vertices x′₁ … x′_t at `raster`, pushed
/// onto `y`: through the specular chain, and in a scene with media as
/// level 2's target retraces them (null boundaries crossed, a medium x′_t
/// at its kept distance: `perturbation/media.rs`), so that ȳ is the path
/// whose value the ratio's p(u_y) is.
fn lens_part<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    a: &LensAnchor,
    raster: Vec2,
    y: &mut Vec<PathVertex>,
) -> Option<()> {
    #[cfg(feature = "media")]
    if tr.has_media() {
        return lens_vertices(tr, a, a.media.as_ref()?, raster, y);
    }
    let ray = tr.camera.ray_from_lens(raster, a.p_lens);
    follow(tr, ray, &a.chain, TransportMode::Radiance, y)
}

/// The caustic perturbation's moving vertices along `dir` from x_j,
/// x′_{j−1} … x′₁ in tracing order, pushed onto `out` (through media as
/// [`lens_part`]).
fn caustic_part<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    a: &CausticAnchor,
    dir: Vec3,
    out: &mut Vec<PathVertex>,
) -> Option<()> {
    #[cfg(feature = "media")]
    if tr.has_media() {
        return caustic_vertices(tr, a, a.media.as_ref()?, dir, out);
    }
    let o = &a.origin.sp;
    let ray = offset::spawn_ray(o.p, o.p_error, o.ng, dir);
    follow(tr, ray, &a.chain, TransportMode::Importance, out)
}

/// The multi-chain perturbation's moving vertices x′₁ … x′_u at `raster`
/// and `dir`, pushed onto `y` (through media as [`lens_part`]).
fn multi_chain_part<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    a: &MultiChainAnchor,
    raster: Vec2,
    dir: Vec3,
    y: &mut Vec<PathVertex>,
) -> Option<()> {
    #[cfg(feature = "media")]
    if tr.has_media() {
        return multi_chain_vertices(tr, a, a.media.as_ref()?, raster, dir, y);
    }
    let ray = tr.camera.ray_from_lens(raster, a.p_lens);
    follow(tr, ray, &a.first, TransportMode::Radiance, y)?;
    let xt = &y[y.len() - 1].sp;
    let ray = offset::spawn_ray(xt.p, xt.p_error, xt.ng, dir);
    follow(tr, ray, &a.second, TransportMode::Radiance, y)
}

/// A path's coordinates in its perturbation's measure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Coordinates {
    /// The lens perturbation's raster position.
    Lens(LensState),
    /// The caustic perturbation's direction leaving x_j.
    Caustic(CausticState),
    /// The multi-chain perturbation's raster position and direction
    /// leaving x_t.
    MultiChain(MultiChainState),
}

/// The unit direction from `a` to `b`.
fn direction(a: &PathVertex, b: &PathVertex) -> Vec3 {
    (b.sp.p - a.sp.p).normalize()
}

/// `x`'s coordinates for the perturbation of `class`; `None` for
/// `Neither`.
pub(crate) fn coordinates(x: &PathState, class: &Applicable) -> Option<Coordinates> {
    let path = &x.path;
    Some(match class {
        Applicable::Lens(_) => Coordinates::Lens(LensState {
            raster: x.raster,
            value: Rgb::ZERO,
        }),
        Applicable::Caustic(a) => {
            let j = a.chain.len() + 2;
            Coordinates::Caustic(CausticState {
                dir: direction(path.get(j)?, path.get(j - 1)?),
                raster: Vec2::ZERO,
                value: Rgb::ZERO,
            })
        }
        Applicable::MultiChain(a) => {
            let t = a.first.len() + 1;
            Coordinates::MultiChain(MultiChainState {
                raster: x.raster,
                dir: direction(path.get(t)?, path.get(t + 1)?),
                value: Rgb::ZERO,
            })
        }
        Applicable::Neither => return None,
    })
}

/// Level 2's target values p(u_x), p(u_y) of `x`'s coordinates and of
/// `to` under `x`'s anchor (module docs); `None` for a class without a
/// perturbation.
fn values<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    x: &PathState,
    class: &Applicable,
    to: &Coordinates,
) -> Option<(f32, f32)> {
    let mut p = [0.0f32; 2];
    match (class, to) {
        (Applicable::Lens(anchor), Coordinates::Lens(s)) => {
            let mut target = LensTarget { tracer: tr, anchor };
            let start = target.evaluate_path(&x.path, x.raster)?;
            let mut states = [Some(*s)];
            target.evaluate(&mut states, &mut p[1..]);
            p[0] = start.value.luminance();
        }
        (Applicable::Caustic(anchor), Coordinates::Caustic(s)) => {
            let Some(Coordinates::Caustic(from)) = coordinates(x, class) else {
                return None;
            };
            let mut states = [Some(from), Some(*s)];
            CausticTarget { tracer: tr, anchor }.evaluate(&mut states, &mut p);
        }
        (Applicable::MultiChain(anchor), Coordinates::MultiChain(s)) => {
            let Some(Coordinates::MultiChain(from)) = coordinates(x, class) else {
                return None;
            };
            let mut states = [Some(from), Some(*s)];
            MultiChainTarget { tracer: tr, anchor }.evaluate(&mut states, &mut p);
        }
        _ => return None,
    }
    let ok = |v: f32| if v.is_finite() && v > 0.0 { v } else { 0.0 };
    Some((ok(p[0]), ok(p[1])))
}

/// Traces `ray` through the specular chain `chain`, taking its recorded
/// lobe at each link, pushing each vertex it meets onto `out`, the last
/// the first non-specular one; `None` when a link misses, meets a
/// non-specular surface, cannot take its lobe, or the end is specular
/// (as level 2's retrace fails, `perturbation/retrace.rs`).
fn follow<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    mut ray: Ray,
    chain: &SpecularChain,
    mode: TransportMode,
    out: &mut Vec<PathVertex>,
) -> Option<()> {
    for link in 0..=chain.len() {
        let sh = tr.trace(&ray)?;
        if link == chain.len() {
            if sh.bsdf.is_delta() {
                return None;
            }
            out.push(surface_vertex(sh));
            return Some(());
        }
        let wo = sh.frame.to_local(-ray.d);
        let (wi, _) = sh.bsdf.specular(wo, chain.reflects(link), mode)?;
        let d = sh.frame.to_world(wi);
        out.push(surface_vertex(sh));
        ray = offset::spawn_ray(sh.sp.p, sh.sp.p_error, sh.sp.ng, d);
    }
    None
}

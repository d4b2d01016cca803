//! Level 2's perturbations: which one applies to the complete vertex list
//! x₀ (lens) … x_k (emitter) of a level-1 state and what it keeps fixed
//! (here), the retracing of specular chains as ray bundles they share
//! (`retrace`), and the three perturbations themselves (`lens`, `caustic`,
//! `multi_chain`), each a multiple-try `Proposal` with an exact density and
//! a packet-traced `Target`.
//!
//! ## Which perturbation (Veach & Guibas 1997, §3)
//!
//! Let x_t be the first non-specular vertex after the lens.
//! - **Lens**: x₁ … x_{t−1} specular and x_{t+1} non-specular (or x_t the
//!   emitter itself, t = k). The image point moves; the camera ray is
//!   retraced through the same specular lobes to a new x′_t, which is
//!   joined to the unchanged x_{t+1} (or must be on an emitter).
//! - **Caustic**: x₁ non-specular, x₂ … x_{j−1} specular (j ≥ 3), x_j the
//!   next non-specular vertex or the emitter. The direction leaving x_j
//!   moves; the ray is retraced through the same lobes towards the camera
//!   to a new x′₁, which is joined to the unchanged lens point.
//!
//! - **Multi-chain** (Veach 1997, §11.4.3.3): x₁ … x_{t−1} specular with
//!   t ≥ 2, x_{t+1} … x_{u−1} specular, x_u the next non-specular vertex or
//!   the emitter, and (when x_u is not the emitter) x_{u+1} non-specular —
//!   E S+ D S+ (L | D D), a caustic seen through water or in a mirror. The
//!   image point and the direction leaving x_t move; both chains are
//!   retraced ([`multi_chain`]) and x′_u is completed as the lens
//!   perturbation completes x′_t.
//!
//! All three preserve the path's pattern of specular and non-specular
//! vertices and its lobes (reflection or refraction), and a candidate that
//! breaks it is a failed perturbation. The pattern decides which one
//! applies — they exclude each other (lens needs x_{t+1} non-specular;
//! caustic and multi-chain need it specular, caustic with t = 1,
//! multi-chain with t ≥ 2) — so the choice is the same for every state a
//! side chain can reach, as invariance requires. Paths fitting none (a
//! third specular chain, E S D S D S L) stay put: their side chain is the
//! identity kernel.
//!
//! So do paths through the Dirac lobe of a mixed BSDF (smooth plastic's
//! coating, [`crate::integrator::bdpt::PathVertex::mixed_delta`]): such a
//! vertex is not specular by [`crate::bsdf::Bsdf::is_delta`], so a
//! perturbation would re-evaluate it with `eval`, which lacks that lobe.
//!
//! ## Targets in the perturbation's own measure
//!
//! The side chain must leave the level-1 chain's stationary distribution
//! invariant. Over paths (summing over the BDPT strategy that level 1
//! picked, whose MIS weights sum to 1) that distribution is Y(f(x̄)) dμ(x̄),
//! so conditioned on the fixed part of the path the moving vertices are
//! distributed ∝ Y(f(x̄)) in path measure. Expressed in the perturbation's
//! coordinates (raster area at a fixed lens point; solid angle at x_j) this
//! is Y(f(x̄)) times the Jacobian from those coordinates to the vertices'
//! area measure — exactly the contribution of the corresponding BDPT
//! strategy *without* its MIS weight and with the coordinate density set to
//! 1: camera throughput per unit raster area (We·cos/p = 1 for our camera)
//! times the connection for the lens perturbation (strategy (k − t, t + 1)),
//! light throughput per unit solid angle times the lens connection for the
//! caustic one (strategy (k, 1)). Factors of the fixed part are constant
//! along the side chain and cancel in every ratio, except their colour,
//! which the splat keeps: it enters as [`tail_colour`].

mod caustic;
mod lens;
#[cfg(feature = "media")]
mod media;
#[cfg(all(test, feature = "std", feature = "media", feature = "specular"))]
pub(crate) mod media_tests;
mod multi_chain;
mod retrace;

pub(crate) use caustic::{CausticProposal, CausticState, CausticTarget};
pub(crate) use lens::{LensProposal, LensState, LensTarget};
pub(crate) use multi_chain::{MultiChainProposal, MultiChainState, MultiChainTarget};

#[cfg(feature = "media")]
pub(crate) use media::{
    CausticMedia, LensMedia, MultiChainMedia, caustic_vertices, lens_vertices, multi_chain_vertices,
};

use glam::Vec3;

use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::integrator::Tracer;
use crate::integrator::bdpt::{PathVertex, scatter};
use crate::math::Rgb;

/// Truncation radius of the perturbation offsets, in standard deviations:
/// the disk holds 1 − e^{−8} of the Gaussian.
const R_MAX_SIGMAS: f32 = 4.0;

/// A perturbation's candidate state, whose value its target sets.
trait Candidate {
    /// The path contribution the target evaluated for this candidate.
    fn value_mut(&mut self) -> &mut Rgb;
}

/// Fails every candidate of a bundle: zero value and zero target. What
/// a target does when its anchor cannot be evaluated (an anchor of a
/// scene with media that was never completed), so the chain stays put.
fn fail_all<S: Candidate>(states: &mut [Option<S>], p: &mut [f32]) {
    for (s, p) in states.iter_mut().zip(p.iter_mut()) {
        if let Some(s) = s {
            *s.value_mut() = Rgb::ZERO;
            *p = 0.0;
        }
    }
}

/// The three perturbations' proposals, as level 2 and the path-space
/// level 1 both draw them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Proposals {
    /// The lens perturbation's raster offset.
    pub lens: LensProposal,
    /// The caustic perturbation's angular offset.
    pub caustic: CausticProposal,
    /// The multi-chain perturbation's pair of offsets.
    pub multi_chain: MultiChainProposal,
}

impl Proposals {
    /// Raster offsets of σ = `lens_sigma` pixels and angular offsets of
    /// σ = `lens_sigma` × `caustic_scale` pixel angles (`pixel_angle`
    /// radians each) on a `width` × `height` image, each truncated at
    /// [`R_MAX_SIGMAS`] σ; `None` for invalid parameters.
    pub fn new(
        lens_sigma: f32,
        caustic_scale: f32,
        width: u32,
        height: u32,
        pixel_angle: f32,
    ) -> Option<Self> {
        let sigma = lens_sigma;
        let lens = LensProposal::new(sigma, R_MAX_SIGMAS * sigma, width, height)?;
        // The caustic offset is an angle at x_j: the lens width in pixels
        // times a pixel's angle, scaled (the specular chain magnifies or
        // compresses it on its way to the image).
        let s = sigma * pixel_angle * caustic_scale;
        let caustic =
            CausticProposal::new(s, (R_MAX_SIGMAS * s).min(0.99 * core::f32::consts::PI))?;
        Some(Proposals {
            lens,
            caustic,
            // The direction leaving x_t moves by the caustic perturbation's
            // angle: both are directions at a non-specular vertex whose
            // change the specular chain carries to the image.
            multi_chain: MultiChainProposal::new(lens, caustic),
        })
    }
}

/// Longest specular chain a perturbation retraces (longer ones: identity).
const MAX_CHAIN: usize = 32;

/// A run of specular vertices to retrace, each with the lobe the original
/// path took there (true = reflection).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct SpecularChain {
    len: usize,
    reflect: [bool; MAX_CHAIN],
}

impl SpecularChain {
    /// Number of specular vertices.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the path reflects (rather than refracts) at specular vertex
    /// `link` of the chain (0-based, in tracing order).
    pub fn reflects(&self, link: usize) -> bool {
        self.reflect[link]
    }

    /// Lobes of `path[range]` in the order given by `order` (indices into
    /// `path`); `None` when longer than [`MAX_CHAIN`].
    fn of(path: &[PathVertex], order: impl Iterator<Item = usize>) -> Option<Self> {
        let mut c = SpecularChain {
            len: 0,
            reflect: [false; MAX_CHAIN],
        };
        for i in order {
            if c.len == MAX_CHAIN {
                return None;
            }
            c.reflect[c.len] = is_reflection(path, i);
            c.len += 1;
        }
        Some(c)
    }
}

/// Whether the path reflects at interior vertex `i` (both neighbours on
/// the same side of the geometric normal) rather than refracting.
fn is_reflection(path: &[PathVertex], i: usize) -> bool {
    let v = &path[i];
    let a = (path[i - 1].sp.p - v.sp.p).dot(v.sp.ng);
    let b = (path[i + 1].sp.p - v.sp.p).dot(v.sp.ng);
    (a > 0.0) == (b > 0.0)
}

/// The colour of the fixed vertices x_from … x_k (x_k the emitter) as
/// f(x̄) weighs them: Le(x_k → x_{k−1}) times, for each interior vertex,
/// its BSDF in light-transport direction (importance, with the shading
/// correction) or its specular lobe's throughput. Geometry terms are
/// scalars constant along a side chain and are left out: only the colour
/// matters (see the module docs). A medium vertex weighs σ_s × phase
/// (`media::medium_factor`); the segments' transmittance is the caller's.
fn tail_colour<I: Intersector>(tr: &Tracer<'_, I>, path: &[PathVertex], from: usize) -> Rgb {
    let k = path.len() - 1;
    let light = &path[k];
    let mut c = tr
        .scene
        .emitted(&light.sp, (path[k - 1].sp.p - light.sp.p).normalize());
    for i in (from.max(1)..k).rev() {
        #[cfg(feature = "media")]
        if path[i].is_medium() {
            c *= media::medium_factor(tr, &path[i], path[i + 1].sp.p, path[i - 1].sp.p);
            continue;
        }
        match surface_colour(path, i) {
            Some(f) => c *= f,
            None => return Rgb::ZERO,
        }
    }
    c
}

/// The colour surface vertex x_i (0 < i < k) gives a fixed tail: its
/// BSDF in light-transport direction, or its specular lobe's throughput;
/// `None` when it has no shading or its lobe does not connect x_{i+1}
/// to x_{i−1}.
fn surface_colour(path: &[PathVertex], i: usize) -> Option<Rgb> {
    let v = &path[i];
    let sh = v.shading.as_ref()?;
    let (prev, next) = (path[i + 1].sp.p, path[i - 1].sp.p);
    Some(if sh.bsdf.is_delta() {
        let wo = sh.frame.to_local((prev - v.sp.p).normalize());
        sh.bsdf
            .specular(wo, is_reflection(path, i), TransportMode::Importance)?
            .1
    } else {
        scatter(sh, prev, next, TransportMode::Importance)
    })
}

/// What the lens perturbation keeps fixed.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LensAnchor {
    /// The lens point x₀.
    pub p_lens: Vec3,
    /// Lobes of x₁ … x_{t−1}.
    pub chain: SpecularChain,
    /// How the new x′_t is completed.
    pub end: LensEnd,
    /// In a scene with media, what the perturbation through media needs
    /// ([`LensAnchor::complete_media`] sets it; `None` until then, and
    /// always in a scene without media).
    #[cfg(feature = "media")]
    pub media: Option<LensMedia>,
}

/// The far end of a lens perturbation.
// Held by value on the stack for one side chain; boxing it would allocate.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub(crate) enum LensEnd {
    /// x_t is the emitter (t = k): x′_t must emit towards x′_{t−1}.
    Emitter,
    /// x′_t is joined to the fixed x_{t+1} = `next`.
    Connect {
        /// x_{t+1}.
        next: PathVertex,
        /// x_{t+2}'s position, when x_{t+1} is not the emitter.
        after: Option<Vec3>,
        /// [`tail_colour`] from x_{t+2} on (1 when x_{t+1} is the emitter).
        tail: Rgb,
    },
}

/// What the caustic perturbation keeps fixed.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CausticAnchor {
    /// The lens point x₀.
    pub p_lens: Vec3,
    /// x_j, where the direction is perturbed.
    pub origin: PathVertex,
    /// x_{j−1}'s position: the level-1 path leaves x_j towards it.
    pub toward: Vec3,
    /// x_{j+1}'s position (`None` when x_j is the emitter).
    pub before: Option<Vec3>,
    /// Lobes of x_{j−1} … x₂, in tracing order (from x_j towards the lens).
    pub chain: SpecularChain,
    /// [`tail_colour`] from x_{j+1} on (1 when x_j is the emitter).
    pub tail: Rgb,
    /// In a scene with media, what the perturbation through media needs
    /// ([`Applicable::complete_media`]).
    #[cfg(feature = "media")]
    pub media: Option<CausticMedia>,
}

/// What the multi-chain perturbation keeps fixed.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MultiChainAnchor {
    /// The lens point x₀.
    pub p_lens: Vec3,
    /// Lobes of x₁ … x_{t−1} (the camera's chain).
    pub first: SpecularChain,
    /// Lobes of x_{t+1} … x_{u−1} (the chain behind x_t).
    pub second: SpecularChain,
    /// How the new x′_u is completed.
    pub end: LensEnd,
    /// In a scene with media, what the perturbation through media needs
    /// ([`Applicable::complete_media`]).
    #[cfg(feature = "media")]
    pub media: Option<MultiChainMedia>,
}

/// The perturbation that applies to a path, with what it keeps fixed.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub(crate) enum Applicable {
    /// The lens perturbation.
    Lens(LensAnchor),
    /// The caustic perturbation.
    Caustic(CausticAnchor),
    /// The multi-chain perturbation.
    MultiChain(MultiChainAnchor),
    /// Neither: the side chain stays at the level-1 state.
    Neither,
}

impl Applicable {
    /// In a scene with media, measures the media along the level-1 path
    /// `path` this class was found for (with rays: the transmittance of
    /// each segment) and completes the anchor with them, the tail's colour
    /// included (see `media`'s module docs). False when the path's own
    /// segments cannot be measured (a zero transmittance by rounding): the
    /// side chain must then stay at its start. A scene without media needs
    /// nothing: true, the anchor untouched.
    pub(crate) fn complete_media<I: Intersector>(
        &mut self,
        tr: &mut Tracer<'_, I>,
        path: &[PathVertex],
    ) -> bool {
        #[cfg(feature = "media")]
        if tr.has_media() {
            let set_tail = |end: &mut LensEnd, tail: Rgb| {
                if let LensEnd::Connect { tail: old, .. } = end {
                    *old = tail;
                }
            };
            match self {
                Applicable::Lens(a) => {
                    let t = a.chain.len() + 1;
                    let Some((m, tail)) = media::lens_media(tr, path, t) else {
                        return false;
                    };
                    set_tail(&mut a.end, tail);
                    a.media = Some(m);
                }
                Applicable::Caustic(a) => {
                    let j = a.chain.len() + 2;
                    let Some((m, tail)) = media::caustic_media(tr, path, j) else {
                        return false;
                    };
                    a.tail = tail;
                    a.media = Some(m);
                }
                Applicable::MultiChain(a) => {
                    let t = a.first.len() + 1;
                    let u = t + 1 + a.second.len();
                    let Some((m, tail)) = media::multi_chain_media(tr, path, t, u) else {
                        return false;
                    };
                    set_tail(&mut a.end, tail);
                    a.media = Some(m);
                }
                Applicable::Neither => {}
            }
        }
        let _ = (tr, path);
        true
    }
}

/// `is_complete` for the anchors: whether the anchor can be evaluated —
/// in a scene without media always, in one with media once
/// [`Applicable::complete_media`] completed it.
macro_rules! is_complete {
    ($($anchor:ty),*) => {$(
        impl $anchor {
            /// Whether the anchor can be evaluated: in a scene without
            /// media always, in one with media once
            /// [`Applicable::complete_media`] completed it.
            #[inline]
            pub(crate) fn is_complete<I: Intersector>(&self, tr: &Tracer<'_, I>) -> bool {
                #[cfg(feature = "media")]
                if tr.has_media() {
                    return self.media.is_some();
                }
                let _ = tr;
                true
            }
        }
    )*};
}

is_complete!(LensAnchor, CausticAnchor, MultiChainAnchor);

/// Classifies a complete path x₀ … x_k (see the module docs).
pub(crate) fn classify<I: Intersector>(tr: &Tracer<'_, I>, path: &[PathVertex]) -> Applicable {
    // With alpha masks a segment's visibility is a stochastic test
    // decided per ray (a hash of the ray), so the perturbations, which
    // re-evaluate the same path through different rays, would see another
    // contribution than level 1 did for the same path at fractional
    // opacity (a mask's bilinear edges are fractional even for a binary
    // cut-out). No perturbation is then known to keep the chain unbiased:
    // every path of such a scene stays at its level-1 state.
    if path.len() < 2 || tr.has_alpha_masks() {
        return Applicable::Neither;
    }
    // A path through the Dirac lobe of a mixed BSDF (smooth plastic's
    // coating): the perturbations evaluate such a vertex with `eval`, which
    // holds only the smooth lobes, so their target would not be the level-1
    // contribution of this path. The identity kernel is always correct.
    if path.iter().any(|v| v.mixed_delta) {
        return Applicable::Neither;
    }
    let k = path.len() - 1;
    // A path ending on a light that is not a mesh — a point or spot light
    // (a delta position: moving x_{k−1} would need a delta connection), a
    // directional light or the environment (a vertex at infinity, no
    // surface to connect to) — fits neither perturbation's assumptions:
    // "none" keeps CMLT unbiased. Such an end is the only vertex on no
    // surface (`u32::MAX`) besides the lens.
    if tr.scene.lights.has_others() && path[k].sp.surface == u32::MAX {
        return Applicable::Neither;
    }
    let p_lens = path[0].sp.p;
    // A medium vertex (no shading, `PathVertex::is_medium`) is a
    // non-specular vertex: it ends a specular chain as a diffuse surface
    // does, and the lens perturbation moves it at its free-flight distance
    // (`media`).
    // A vertex without shading (a sampled light point) is never specular,
    // and without specular chains in the scene none is: no vertex is
    // inspected, the caustic branch is never reached and every path gets
    // the lens perturbation (through no specular vertex).
    let chains = tr.analysis.specular_chains;
    let spec = |i: usize| chains && path[i].is_specular();
    let t = (1..=k).find(|&i| !spec(i)).unwrap_or(k);
    if spec(t) {
        // The camera chain ends on a specular emitter: not a path we make.
        return Applicable::Neither;
    }
    if t == k {
        return match SpecularChain::of(path, 1..t) {
            Some(chain) => Applicable::Lens(LensAnchor {
                p_lens,
                chain,
                end: LensEnd::Emitter,
                #[cfg(feature = "media")]
                media: None,
            }),
            None => Applicable::Neither,
        };
    }
    if !spec(t + 1) {
        let Some(chain) = SpecularChain::of(path, 1..t) else {
            return Applicable::Neither;
        };
        let after = (t + 1 < k).then(|| path[t + 2].sp.p);
        let tail = if t + 1 < k {
            tail_colour(tr, path, t + 2)
        } else {
            Rgb::ONE
        };
        return Applicable::Lens(LensAnchor {
            p_lens,
            chain,
            end: LensEnd::Connect {
                next: path[t + 1],
                after,
                tail,
            },
            #[cfg(feature = "media")]
            media: None,
        });
    }
    // t + 1 is specular: a caustic if t = 1 and the chain ends on a
    // non-specular vertex or the emitter, else a multi-chain path.
    if t != 1 {
        return multi_chain(tr, path, t, spec, p_lens);
    }
    let Some(j) = (2..=k).find(|&i| !spec(i)) else {
        return Applicable::Neither;
    };
    let Some(chain) = SpecularChain::of(path, (2..j).rev()) else {
        return Applicable::Neither;
    };
    let tail = if j < k {
        tail_colour(tr, path, j + 1)
    } else {
        Rgb::ONE
    };
    Applicable::Caustic(CausticAnchor {
        p_lens,
        origin: path[j],
        toward: path[j - 1].sp.p,
        before: (j < k).then(|| path[j + 1].sp.p),
        chain,
        tail,
        #[cfg(feature = "media")]
        media: None,
    })
}

/// The multi-chain anchor of a path whose first non-specular vertex x_t
/// (t ≥ 2) is followed by a specular x_{t+1}; `Neither` when the second
/// chain ends on a specular emitter or is followed by a third chain.
fn multi_chain<I: Intersector>(
    tr: &Tracer<'_, I>,
    path: &[PathVertex],
    t: usize,
    spec: impl Fn(usize) -> bool,
    p_lens: Vec3,
) -> Applicable {
    let k = path.len() - 1;
    let Some(u) = (t + 2..=k).find(|&i| !spec(i)) else {
        return Applicable::Neither;
    };
    let (Some(first), Some(second)) = (
        SpecularChain::of(path, 1..t),
        SpecularChain::of(path, t + 1..u),
    ) else {
        return Applicable::Neither;
    };
    let end = if u == k {
        LensEnd::Emitter
    } else if !spec(u + 1) {
        LensEnd::Connect {
            next: path[u + 1],
            after: (u + 1 < k).then(|| path[u + 2].sp.p),
            tail: if u + 1 < k {
                tail_colour(tr, path, u + 2)
            } else {
                Rgb::ONE
            },
        }
    } else {
        return Applicable::Neither;
    };
    Applicable::MultiChain(MultiChainAnchor {
        p_lens,
        first,
        second,
        end,
        #[cfg(feature = "media")]
        media: None,
    })
}

//! The lens perturbation (Veach & Guibas 1997, §3.3.1) as a multiple-try
//! [`Proposal`] and a packet-traced [`Target`].
//!
//! State: the raster position of the path's camera ray, at the fixed lens
//! point x₀. Proposal: a clamped 2-D Gaussian offset in pixels, so
//! T(x→y) = q(y − x) per unit raster area is symmetric and exact; positions
//! that leave the image fail. Target: the path's contribution per unit
//! raster area with x_{t+1} … x_k fixed ([`super`]).
//!
//! A bundle is evaluated as: all camera rays as one packet, one packet per
//! specular bounce, then all connection rays to the shared vertex x_{t+1}
//! as one occlusion packet.
//!
//! ## No tail ray
//!
//! Level 1 tests a connection with two rays
//! ([`offset::spawn_rays_between`]): the main ray from x′_t up to
//! 1 − `SHADOW_EPSILON` of the segment and a short tail from x_{t+1} back
//! over the last 2·`SHADOW_EPSILON`, which finds a surface crossed within
//! that margin of x_{t+1} (an exit through the face next to x_{t+1}'s at a
//! grazing connection). Here the connection is tested by the main ray
//! alone: the tail cost 1 232 of the 6 993 instructions of a k = 1 lens
//! step on veach-bidir (callgrind), almost two thirds of the main ray,
//! and what it alone decides is the last 10⁻⁴ of the segment, next to the
//! fixed vertex x_{t+1}. The cost to exactness: the side chain's target
//! may count as visible a connection that crosses another surface within
//! 10⁻⁴·|x′_t − x_{t+1}| of x_{t+1}, which level 1 counts blocked — only
//! for a fixed vertex that close to another surface, with x′_t on that
//! surface's far side. The side chain starts from level-1 states and
//! leaves its own target invariant, so its records differ from level 1's
//! distribution by at most the share of such paths.

use glam::{Vec2, Vec3};

use super::retrace::{Bundled, Retraced, evaluate_in_bundles, retrace};
use super::{LensAnchor, LensEnd};
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, offset};
use crate::integrator::Tracer;
use crate::integrator::bdpt::{PathVertex, scatter};
use crate::integrator::tracer::Shading;
use crate::math::Rgb;
use crate::math::warp::ClampedGaussian2;
use crate::mlt::multiple_try::{Proposal, Target};
use crate::scene::SurfacePoint;

/// A lens-perturbed path: where it crosses the image and what it carries.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct LensState {
    /// Raster position (continuous pixels).
    pub raster: Vec2,
    /// Contribution per unit raster area, up to the side chain's constant
    /// (zero until evaluated).
    pub value: Rgb,
}

impl super::Candidate for LensState {
    fn value_mut(&mut self) -> &mut Rgb {
        &mut self.value
    }
}

/// T(x→·): a clamped Gaussian offset of the raster position.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LensProposal {
    offset: ClampedGaussian2,
    size: Vec2,
}

impl LensProposal {
    /// Offsets of standard deviation `sigma` pixels, truncated at
    /// `r_max` pixels, on an image of `width` × `height` pixels.
    pub fn new(sigma: f32, r_max: f32, width: u32, height: u32) -> Option<Self> {
        Some(LensProposal {
            offset: ClampedGaussian2::new(sigma, r_max)?,
            size: Vec2::new(width as f32, height as f32),
        })
    }
}

impl Proposal<LensState> for LensProposal {
    const DIM: usize = 2;
    // The density depends on the offset's squared length only, and
    // negating the offset is exact.
    const SYMMETRIC: bool = true;

    fn sample(&self, from: &LensState, u: &[f32]) -> Option<LensState> {
        let r = from.raster + self.offset.sample(Vec2::new(u[0], u[1]));
        (r.x >= 0.0 && r.y >= 0.0 && r.x < self.size.x && r.y < self.size.y).then_some(LensState {
            raster: r,
            value: Rgb::ZERO,
        })
    }

    fn density(&self, from: &LensState, to: &LensState) -> f32 {
        self.offset.pdf(to.raster - from.raster)
    }

    fn invert(&self, from: &LensState, to: &LensState, u: &mut [f32]) -> bool {
        self.offset.invert_into(to.raster - from.raster, u)
    }
}

/// The lens perturbation's target for one side chain: traces bundles of
/// candidates through `tracer` against the fixed part `anchor`.
pub(crate) struct LensTarget<'r, 'a, I: Intersector> {
    /// The worker's tracer (its counters record the packets).
    pub tracer: &'r mut Tracer<'a, I>,
    /// What the perturbation keeps fixed.
    pub anchor: &'r LensAnchor,
}

impl<I: Intersector> Target<LensState> for LensTarget<'_, '_, I> {
    fn evaluate(&mut self, states: &mut [Option<LensState>], p: &mut [f32]) {
        evaluate_in_bundles(self, states, p);
    }
}

/// The value of a path whose camera part ends at x′_t (position and
/// shading `sp`, `sh`; `None` for a light point without a BSDF), reached
/// from `prev` with specular throughput `beta`, completed by the
/// fixed end `end`; with [`LensEnd::Connect`] also the segment to
/// x_{t+1} whose visibility the value assumes (`None` when the
/// connection cannot be made; the value is then zero). Zero when the
/// path carries nothing.
pub(super) fn end_value<I: Intersector>(
    tracer: &mut Tracer<'_, I>,
    end: &LensEnd,
    sp: &SurfacePoint,
    sh: Option<&Shading>,
    prev: Vec3,
    beta: Rgb,
) -> (Rgb, Option<offset::SegmentRays>) {
    match end {
        LensEnd::Emitter => {
            let wo = (prev - sp.p).normalize();
            (beta * tracer.scene.emitted(sp, wo), None)
        }
        LensEnd::Connect { next, after, tail } => {
            let Some(h) = sh else {
                return (Rgb::ZERO, None);
            };
            let d = next.sp.p - sp.p;
            let d2 = d.length_squared();
            if !(d2 > 0.0) {
                return (Rgb::ZERO, None);
            }
            let dn = d / libm::sqrtf(d2);
            let f_t = scatter(h, prev, next.sp.p, TransportMode::Radiance);
            tracer.stats.bsdf_evals.add(h.bsdf.lobe());
            // x_{t+1}'s factor: emission towards x′_t (BDPT s = 1
            // uses the emitter's geometric cosine), or its BSDF in
            // light-transport direction.
            let (f_next, cos_next) = match (after, &next.shading) {
                (None, _) => (
                    tracer.scene.emitted(&next.sp, -dn),
                    next.sp.ng.dot(dn).abs(),
                ),
                (Some(after), Some(nsh)) => {
                    tracer.stats.bsdf_evals.add(nsh.bsdf.lobe());
                    (
                        scatter(nsh, *after, sp.p, TransportMode::Importance),
                        next.sp.ns.dot(dn).abs(),
                    )
                }
                (Some(_), None) => return (Rgb::ZERO, None),
            };
            let g = sp.ns.dot(dn).abs() * cos_next / d2;
            let v = beta * f_t * f_next * *tail * g;
            if v.is_black() || !v.is_finite() {
                return (Rgb::ZERO, None);
            }
            match offset::spawn_rays_between(
                sp.p,
                sp.p_error,
                sp.ng,
                next.sp.p,
                next.sp.p_error,
                next.sp.ng,
            ) {
                Some(seg) => (v, Some(seg)),
                None => (Rgb::ZERO, None),
            }
        }
    }
}

/// The values of a bundle whose lanes reached x′_t at `ends` (`None`: a
/// failed lane), each with its end's specular throughput times `beta[i]`,
/// completed by `end` ([`end_value`]); with [`LensEnd::Connect`] the
/// connection rays to x_{t+1} are traced as one occlusion packet and a
/// blocked lane is zero. Only the main ray: see the module docs ("No tail
/// ray").
pub(super) fn end_values<I: Intersector, const N: usize>(
    tracer: &mut Tracer<'_, I>,
    end: &LensEnd,
    ends: &[Option<Retraced>],
    beta: &[Rgb],
) -> [Rgb; N] {
    let n = ends.len();
    let mut value = [Rgb::ZERO; N];
    let mut shadow: [Option<Ray>; N] = [None; N];
    for i in 0..n {
        let Some(e) = &ends[i] else { continue };
        let (v, seg) = end_value(
            tracer,
            end,
            &e.hit.sp,
            Some(&e.hit),
            e.prev,
            beta[i] * e.beta,
        );
        value[i] = v;
        shadow[i] = seg.map(|seg| seg.main);
    }
    if matches!(end, LensEnd::Connect { .. }) {
        let mut blocked = [false; N];
        tracer.occluded_bundle(&shadow[..n], &mut blocked[..n]);
        for i in 0..n {
            if shadow[i].is_none() || blocked[i] {
                value[i] = Rgb::ZERO;
            }
        }
    }
    value
}

impl<I: Intersector> LensTarget<'_, '_, I> {
    /// The target at the level-1 path itself (`path`, whose camera ray
    /// crosses the image at `raster`), evaluated from its stored vertices
    /// instead of retraced: every segment of a level-1 path was traced or
    /// tested for visibility when level 1 made it, so no ray is needed. The
    /// value is [`Target::evaluate`]'s (the same end value and
    /// specular lobes), up to the rounding of retracing the camera ray.
    /// `None` when the path does not fit the anchor (it always does for
    /// the anchor [`super::classify`] made of it).
    pub fn evaluate_path(&mut self, path: &[PathVertex], raster: Vec2) -> Option<LensState> {
        if !self.anchor.is_complete(self.tracer) {
            return None;
        }
        #[cfg(feature = "media")]
        if let Some(media) = &self.anchor.media {
            let v = super::media::lens_value_of_path(self.tracer, self.anchor, media, path)?;
            return Some(LensState {
                raster,
                value: if v.is_finite() { v } else { Rgb::ZERO },
            });
        }
        let t = self.anchor.chain.len() + 1;
        let x_t = path.get(t)?;
        let mut beta = Rgb::ONE;
        for (link, i) in (1..t).enumerate() {
            let sh = path[i].shading.as_ref()?;
            let wo = (path[i - 1].sp.p - path[i].sp.p).normalize();
            let (_, w) = sh.bsdf.specular(
                sh.frame.to_local(wo),
                self.anchor.chain.reflects(link),
                TransportMode::Radiance,
            )?;
            beta *= w;
        }
        let (v, _) = end_value(
            self.tracer,
            &self.anchor.end,
            &x_t.sp,
            x_t.shading.as_ref(),
            path[t - 1].sp.p,
            beta,
        );
        Some(LensState {
            raster,
            value: if v.is_finite() { v } else { Rgb::ZERO },
        })
    }
}

impl<I: Intersector> Bundled<LensState> for LensTarget<'_, '_, I> {
    fn evaluate_bundle<const N: usize>(&mut self, states: &mut [Option<LensState>], p: &mut [f32]) {
        let n = states.len();
        let camera = self.tracer.camera;
        let a = self.anchor;
        // An anchor of a scene with media that was never completed has no
        // target it could evaluate: every candidate fails.
        if !a.is_complete(self.tracer) {
            super::fail_all(states, p);
            return;
        }
        // Through media: one lane at a time (`media`), with the
        // transmittance queries BDPT connects with.
        #[cfg(feature = "media")]
        if let Some(media) = &a.media {
            for (s, p) in states.iter_mut().zip(p.iter_mut()) {
                if let Some(s) = s {
                    let v = super::media::lens_value(self.tracer, a, media, s.raster);
                    s.value = if v.is_finite() { v } else { Rgb::ZERO };
                    *p = s.value.luminance();
                }
            }
            return;
        }
        let mut rays: [Option<Ray>; N] = [None; N];
        for (r, s) in rays.iter_mut().zip(states.iter()) {
            *r = s.map(|s| camera.ray_from_lens(s.raster, a.p_lens));
        }
        let mut ends: [Option<Retraced>; N] = [None; N];
        retrace::<I, N>(
            self.tracer,
            &mut rays[..n],
            &a.chain,
            TransportMode::Radiance,
            &mut ends[..n],
        );
        let value = end_values::<I, N>(self.tracer, &a.end, &ends[..n], &[Rgb::ONE; N][..n]);
        for i in 0..n {
            if let Some(s) = &mut states[i] {
                s.value = if value[i].is_finite() {
                    value[i]
                } else {
                    Rgb::ZERO
                };
                p[i] = s.value.luminance();
            }
        }
    }
}

#[cfg(all(test, feature = "std", feature = "specular"))]
mod tests;

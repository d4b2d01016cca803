//! The lens perturbation (Veach & Guibas 1997, §3.3.1) as a multiple-try
//! [`Proposal`] and a packet-traced [`Target`].
//!
//! State: the raster position of the path's camera ray, at the fixed lens
//! point x₀. Proposal: a clamped 2-D Gaussian offset in pixels, so
//! T(x→y) = q(y − x) per unit raster area is symmetric and exact; positions
//! that leave the image fail. Target: the path's contribution per unit
//! raster area with x_{t+1} … x_k fixed ([`super::path`]).
//!
//! A bundle is evaluated as: all camera rays as one packet, one packet per
//! specular bounce, then all connection rays to the shared vertex x_{t+1}
//! as one occlusion packet.

use glam::Vec2;

use super::multiple_try::{Proposal, Target};
use super::path::{LensAnchor, LensEnd, MAX_LANES, Retraced, retrace};
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, offset};
use crate::integrator::Tracer;
use crate::integrator::bdpt::scatter;
use crate::math::Rgb;
use crate::math::warp::ClampedGaussian2;

/// A lens-perturbed path: where it crosses the image and what it carries.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LensState {
    /// Raster position (continuous pixels).
    pub raster: Vec2,
    /// Contribution per unit raster area, up to the side chain's constant
    /// (zero until evaluated).
    pub value: Rgb,
}

/// T(x→·): a clamped Gaussian offset of the raster position.
#[derive(Clone, Copy, Debug)]
pub struct LensProposal {
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
pub struct LensTarget<'r, 'a, I: Intersector> {
    /// The worker's tracer (its counters record the packets).
    pub tracer: &'r mut Tracer<'a, I>,
    /// What the perturbation keeps fixed.
    pub anchor: &'r LensAnchor,
}

impl<I: Intersector> Target<LensState> for LensTarget<'_, '_, I> {
    fn evaluate(&mut self, states: &mut [Option<LensState>], p: &mut [f32]) {
        for (states, p) in states.chunks_mut(MAX_LANES).zip(p.chunks_mut(MAX_LANES)) {
            self.evaluate_chunk(states, p);
        }
    }
}

impl<I: Intersector> LensTarget<'_, '_, I> {
    fn evaluate_chunk(&mut self, states: &mut [Option<LensState>], p: &mut [f32]) {
        let n = states.len();
        let camera = self.tracer.camera;
        let a = self.anchor;
        let mut rays: [Option<Ray>; MAX_LANES] = [None; MAX_LANES];
        for (r, s) in rays.iter_mut().zip(states.iter()) {
            *r = s.map(|s| camera.ray_from_lens(s.raster, a.p_lens));
        }
        let mut ends: [Option<Retraced>; MAX_LANES] = [None; MAX_LANES];
        retrace(
            self.tracer,
            &mut rays[..n],
            &a.chain,
            TransportMode::Radiance,
            &mut ends[..n],
        );
        let mut value = [Rgb::ZERO; MAX_LANES];
        // Connection rays to x_{t+1}, traced as one occlusion packet.
        let mut shadow: [Option<Ray>; MAX_LANES] = [None; MAX_LANES];
        let mut tails: [Option<Ray>; MAX_LANES] = [None; MAX_LANES];
        for i in 0..n {
            let Some(e) = &ends[i] else { continue };
            let h = &e.hit;
            match &a.end {
                LensEnd::Emitter => {
                    let wo = (e.prev - h.sp.p).normalize();
                    value[i] = e.beta * self.tracer.scene.emitted(&h.sp, wo);
                }
                LensEnd::Connect { next, after, tail } => {
                    let d = next.sp.p - h.sp.p;
                    let d2 = d.length_squared();
                    if !(d2 > 0.0) {
                        continue;
                    }
                    let dn = d / libm::sqrtf(d2);
                    let f_t = scatter(h, e.prev, next.sp.p, TransportMode::Radiance);
                    self.tracer.stats.bsdf_evals.add(h.bsdf.lobe());
                    // x_{t+1}'s factor: emission towards x′_t (BDPT s = 1
                    // uses the emitter's geometric cosine), or its BSDF in
                    // light-transport direction.
                    let (f_next, cos_next) = match (after, &next.shading) {
                        (None, _) => (
                            self.tracer.scene.emitted(&next.sp, -dn),
                            next.sp.ng.dot(dn).abs(),
                        ),
                        (Some(after), Some(sh)) => {
                            self.tracer.stats.bsdf_evals.add(sh.bsdf.lobe());
                            (
                                scatter(sh, *after, h.sp.p, TransportMode::Importance),
                                next.sp.ns.dot(dn).abs(),
                            )
                        }
                        (Some(_), None) => continue,
                    };
                    let g = h.sp.ns.dot(dn).abs() * cos_next / d2;
                    let v = e.beta * f_t * f_next * *tail * g;
                    if v.is_black() || !v.is_finite() {
                        continue;
                    }
                    value[i] = v;
                    if let Some(seg) = offset::spawn_rays_between(
                        h.sp.p,
                        h.sp.p_error,
                        h.sp.ng,
                        next.sp.p,
                        next.sp.p_error,
                        next.sp.ng,
                    ) {
                        shadow[i] = Some(seg.main);
                        tails[i] = seg.tail;
                    }
                }
            }
        }
        if matches!(a.end, LensEnd::Connect { .. }) {
            let mut blocked = [false; MAX_LANES];
            self.tracer.occluded_bundle(&shadow[..n], &mut blocked[..n]);
            // The tails all leave the shared vertex x_{t+1}: a coherent
            // bundle of its own, for the lanes still open.
            for i in 0..n {
                if blocked[i] {
                    tails[i] = None;
                }
            }
            let mut tail_blocked = [false; MAX_LANES];
            self.tracer
                .occluded_bundle(&tails[..n], &mut tail_blocked[..n]);
            for i in 0..n {
                if shadow[i].is_none() || blocked[i] || tail_blocked[i] {
                    value[i] = Rgb::ZERO;
                }
            }
        }
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

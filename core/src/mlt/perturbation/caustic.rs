//! The caustic perturbation (Veach & Guibas 1997, §3.3.2) as a
//! multiple-try [`Proposal`] and a packet-traced [`Target`].
//!
//! State: the unit direction leaving x_j (the vertex on the light side of
//! the specular chain). Proposal: a clamped 2-D Gaussian offset d in the
//! tangent plane of the current direction ω, mapped by the exponential map
//! ω′ = cos|d| ω + sin|d| d̂ (|d| is the angle between ω and ω′). Per unit
//! solid angle its density is T(ω→ω′) = q(|d|) · |d| / sin|d| (the
//! exponential map's area element on the sphere is sin|d|/|d|), which
//! depends only on the angle, so T is symmetric; the truncation radius is
//! below π, where the map is one-to-one. Target: the path's contribution
//! per unit solid angle at x_j with x_j … x_k fixed ([`super`]),
//! i.e. light tracing through the chain and a connection to the lens point.
//!
//! A bundle is evaluated as: all rays from x_j as one packet, one packet per
//! specular bounce, then all connection rays to the lens point (a shared
//! vertex) as one occlusion packet.

use glam::{Vec2, Vec3};

use super::CausticAnchor;
use super::retrace::{Bundled, Retraced, evaluate_in_bundles, retrace};
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, offset};
use crate::integrator::Tracer;
use crate::integrator::bdpt::scatter;
use crate::math::warp::ClampedGaussian2;
use crate::math::{Frame, Rgb};
use crate::mlt::multiple_try::{Proposal, Target};

/// A caustic-perturbed path.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct CausticState {
    /// Unit direction leaving x_j.
    pub dir: Vec3,
    /// Where the path lands on the image (set by the evaluation).
    pub raster: Vec2,
    /// Contribution per unit solid angle at x_j, up to the side chain's
    /// constant (zero until evaluated).
    pub value: Rgb,
}

impl super::Candidate for CausticState {
    fn value_mut(&mut self) -> &mut Rgb {
        &mut self.value
    }
}

/// T(ω→·): a clamped Gaussian offset of the direction by the exponential
/// map.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CausticProposal {
    offset: ClampedGaussian2,
}

impl CausticProposal {
    /// Angular offsets of standard deviation `sigma` radians truncated at
    /// `r_max` < π. `None` for invalid parameters.
    pub fn new(sigma: f32, r_max: f32) -> Option<Self> {
        if !(r_max < core::f32::consts::PI) {
            return None;
        }
        Some(CausticProposal {
            offset: ClampedGaussian2::new(sigma, r_max)?,
        })
    }
}

/// The angle between two unit vectors, accurate for small angles too.
#[inline]
fn angle_between(a: Vec3, b: Vec3) -> f32 {
    libm::atan2f(a.cross(b).length(), a.dot(b))
}

/// |d| / sin|d|: the inverse area element of the exponential map.
#[inline]
fn inv_area_element(theta: f32) -> f32 {
    if theta < 1e-4 {
        1.0 + theta * theta / 6.0
    } else {
        theta / libm::sinf(theta)
    }
}

impl Proposal<CausticState> for CausticProposal {
    const DIM: usize = 2;

    fn sample(&self, from: &CausticState, u: &[f32]) -> Option<CausticState> {
        let d = self.offset.sample(Vec2::new(u[0], u[1]));
        let theta = d.length();
        let frame = Frame::from_normal(from.dir);
        let dir = if theta > 0.0 {
            let t = d / theta;
            let local = Vec3::new(
                libm::sinf(theta) * t.x,
                libm::sinf(theta) * t.y,
                libm::cosf(theta),
            );
            frame.to_world(local).normalize()
        } else {
            from.dir
        };
        Some(CausticState {
            dir,
            raster: Vec2::ZERO,
            value: Rgb::ZERO,
        })
    }

    fn density(&self, from: &CausticState, to: &CausticState) -> f32 {
        let theta = angle_between(from.dir, to.dir);
        self.offset.pdf(Vec2::new(theta, 0.0)) * inv_area_element(theta)
    }

    fn invert(&self, from: &CausticState, to: &CausticState, u: &mut [f32]) -> bool {
        let theta = angle_between(from.dir, to.dir);
        let local = Frame::from_normal(from.dir).to_local(to.dir);
        let phi = libm::atan2f(local.y, local.x);
        let d = Vec2::new(theta * libm::cosf(phi), theta * libm::sinf(phi));
        self.offset.invert_into(d, u)
    }
}

/// The caustic perturbation's target for one side chain.
pub(crate) struct CausticTarget<'r, 'a, I: Intersector> {
    /// The worker's tracer (its counters record the packets).
    pub tracer: &'r mut Tracer<'a, I>,
    /// What the perturbation keeps fixed.
    pub anchor: &'r CausticAnchor,
}

impl<I: Intersector> Target<CausticState> for CausticTarget<'_, '_, I> {
    fn evaluate(&mut self, states: &mut [Option<CausticState>], p: &mut [f32]) {
        evaluate_in_bundles(self, states, p);
    }
}

impl<I: Intersector> Bundled<CausticState> for CausticTarget<'_, '_, I> {
    fn evaluate_bundle<const N: usize>(
        &mut self,
        states: &mut [Option<CausticState>],
        p: &mut [f32],
    ) {
        let n = states.len();
        let scene = self.tracer.scene;
        let camera = self.tracer.camera;
        let a = self.anchor;
        // An anchor of a scene with media that was never completed has no
        // target it could evaluate: every candidate fails.
        if !a.is_complete(self.tracer) {
            super::fail_all(states, p);
            return;
        }
        // Through media: one lane at a time (`super::media`).
        #[cfg(feature = "media")]
        if let Some(media) = &a.media {
            for (s, p) in states.iter_mut().zip(p.iter_mut()) {
                if let Some(s) = s {
                    let (v, raster) = super::media::caustic_value(self.tracer, a, media, s.dir)
                        .unwrap_or((Rgb::ZERO, Vec2::ZERO));
                    s.value = if v.is_finite() { v } else { Rgb::ZERO };
                    s.raster = raster;
                    *p = s.value.luminance();
                }
            }
            return;
        }
        let o = &a.origin;
        // x_j's factor per unit solid angle: emission (with the emitter's
        // geometric cosine, as light subpaths start) or BSDF × shading
        // cosine in light-transport direction.
        let mut start = [Rgb::ZERO; N];
        let mut rays: [Option<Ray>; N] = [None; N];
        for i in 0..n {
            let Some(s) = &states[i] else { continue };
            let w = s.dir;
            let f = match (&a.before, &o.shading) {
                (None, _) => scene.emitted(&o.sp, w) * o.sp.ng.dot(w).abs(),
                (Some(before), Some(sh)) => {
                    self.tracer.stats.bsdf_evals.add(sh.bsdf.lobe());
                    scatter(sh, *before, o.sp.p + w, TransportMode::Importance)
                        * o.sp.ns.dot(w).abs()
                }
                (Some(_), None) => Rgb::ZERO,
            };
            if f.is_black() || !f.is_finite() {
                continue;
            }
            start[i] = f * a.tail;
            rays[i] = Some(offset::spawn_ray(o.sp.p, o.sp.p_error, o.sp.ng, w));
        }
        let mut ends: [Option<Retraced>; N] = [None; N];
        retrace::<I, N>(
            self.tracer,
            &mut rays[..n],
            &a.chain,
            TransportMode::Importance,
            &mut ends[..n],
        );
        let mut value = [Rgb::ZERO; N];
        let mut raster = [Vec2::ZERO; N];
        let mut shadow: [Option<Ray>; N] = [None; N];
        for i in 0..n {
            let Some(e) = &ends[i] else { continue };
            let h = &e.hit;
            // The lens connection of BDPT's t = 1, at the fixed lens point.
            let Some(conn) = camera.connect_at(h.sp.p, a.p_lens) else {
                continue;
            };
            let to_cam = conn.p_lens - h.sp.p;
            let d2 = to_cam.length_squared();
            let w = to_cam / libm::sqrtf(d2);
            let f1 = scatter(h, e.prev, conn.p_lens, TransportMode::Importance);
            self.tracer.stats.bsdf_evals.add(h.bsdf.lobe());
            let v = start[i]
                * e.beta
                * f1
                * (h.sp.ns.dot(w).abs() * conn.we * conn.cos_theta / (d2 * conn.pdf_lens_area));
            if v.is_black() || !v.is_finite() {
                continue;
            }
            value[i] = v;
            raster[i] = conn.raster;
            // The lens is on no surface: the main ray reaches it, no tail.
            shadow[i] = offset::spawn_rays_between(
                h.sp.p,
                h.sp.p_error,
                h.sp.ng,
                conn.p_lens,
                Vec3::ZERO,
                Vec3::ZERO,
            )
            .map(|seg| seg.main);
        }
        let mut blocked = [false; N];
        self.tracer.occluded_bundle(&shadow[..n], &mut blocked[..n]);
        for i in 0..n {
            if let Some(s) = &mut states[i] {
                let ok = shadow[i].is_some() && !blocked[i];
                s.value = if ok { value[i] } else { Rgb::ZERO };
                s.raster = raster[i];
                p[i] = s.value.luminance();
            }
        }
    }
}

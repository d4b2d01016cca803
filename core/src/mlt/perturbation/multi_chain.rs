//! The multi-chain perturbation (Veach 1997, §11.4.3.3) as a multiple-try
//! [`Proposal`] and a packet-traced [`Target`]: level 2 for paths
//! E S+ D S+ …, a caustic or a light seen through glass, water or in a
//! mirror — the paths neither the lens nor the caustic perturbation can
//! move, and the ones primary-sample mutations find worst.
//!
//! Let x_t be the first non-specular vertex after the lens and
//! x_{t+1} … x_{u−1} the specular chain behind it, ending at x_u, the next
//! non-specular vertex or the emitter. The lens perturbation cannot join a
//! moved x′_t to x_{t+1} (a connection to a specular vertex has probability
//! zero), so the perturbation continues: the camera ray is retraced
//! through the first chain to x′_t, a direction ω′ leaving x′_t is traced
//! through the second chain to x′_u, and x′_u is completed as the lens
//! perturbation completes x′_t ([`super::LensEnd`]: it must emit,
//! or it is joined to the fixed non-specular x_{u+1}).
//!
//! State: (raster position, ω), ω the unit direction leaving x_t. Veach
//! derives the second chain's change from the first one's; here the two
//! coordinates move independently — the lens offset of
//! [`super::lens::LensProposal`] and the angular offset of
//! [`super::caustic::CausticProposal`] — so T(x→y) is the product of two
//! symmetric densities (per unit raster area × per unit solid angle) and is
//! itself symmetric. Keeping ω fixed while x_t moves shifts the second
//! chain's ray parallel to itself, which keeps it on a small light as long
//! as the first chain's footprint is small.
//!
//! Target: the path's contribution per unit raster area at the fixed lens
//! point and per unit solid angle at x_t with x_{u+1} … x_k fixed — camera
//! throughput per raster area (1 for our camera) through the first chain,
//! x_t's BSDF × shading cosine for ω in radiance direction (as a path tracer
//! weighs a direction it sampled, with the pdf set to 1), the second
//! chain's lobes and the end value. That is Y(f(x̄)) times the Jacobian
//! from (raster, ω) to the moving vertices' area measure, so the side chain
//! leaves level 1's distribution, restricted to the path's class,
//! invariant ([`super`], [`crate::mlt::level2`]).
//!
//! A bundle is evaluated as: all camera rays as one packet, one packet per
//! specular bounce of the first chain, all rays leaving x′_t as one packet,
//! one per bounce of the second chain, then all connection rays to x_{u+1}
//! as one occlusion packet (only the main ray, as
//! [`super::lens`] explains).

use glam::{Vec2, Vec3};

use super::MultiChainAnchor;
use super::caustic::{CausticProposal, CausticState};
use super::lens::{LensProposal, LensState, end_values};
use super::retrace::{Bundled, Retraced, evaluate_in_bundles, retrace};
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, offset};
use crate::integrator::Tracer;
use crate::integrator::bdpt::scatter;
use crate::math::Rgb;
use crate::mlt::multiple_try::{Proposal, Target};

/// A multi-chain-perturbed path: where it crosses the image, the direction
/// it leaves x_t in, and what it carries.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct MultiChainState {
    /// Raster position (continuous pixels).
    pub raster: Vec2,
    /// Unit direction leaving x_t towards the second specular chain.
    pub dir: Vec3,
    /// Contribution per unit raster area and unit solid angle at x_t, up
    /// to the side chain's constant (zero until evaluated).
    pub value: Rgb,
}

impl super::Candidate for MultiChainState {
    fn value_mut(&mut self) -> &mut Rgb {
        &mut self.value
    }
}

/// T(x→·): the lens perturbation's raster offset and the caustic
/// perturbation's angular offset of ω, independently.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MultiChainProposal {
    lens: LensProposal,
    dir: CausticProposal,
}

impl MultiChainProposal {
    /// Raster offsets drawn by `lens`, angular offsets of ω by `dir`.
    pub fn new(lens: LensProposal, dir: CausticProposal) -> Self {
        MultiChainProposal { lens, dir }
    }

    fn lens_state(s: &MultiChainState) -> LensState {
        LensState {
            raster: s.raster,
            value: Rgb::ZERO,
        }
    }

    fn dir_state(s: &MultiChainState) -> CausticState {
        CausticState {
            dir: s.dir,
            ..CausticState::default()
        }
    }
}

impl Proposal<MultiChainState> for MultiChainProposal {
    const DIM: usize = LensProposal::DIM + CausticProposal::DIM;
    // A product of two symmetric densities.
    const SYMMETRIC: bool = true;

    fn sample(&self, from: &MultiChainState, u: &[f32]) -> Option<MultiChainState> {
        let (ul, ud) = u.split_at(LensProposal::DIM);
        let r = self.lens.sample(&Self::lens_state(from), ul)?;
        let d = self.dir.sample(&Self::dir_state(from), ud)?;
        Some(MultiChainState {
            raster: r.raster,
            dir: d.dir,
            value: Rgb::ZERO,
        })
    }

    fn density(&self, from: &MultiChainState, to: &MultiChainState) -> f32 {
        self.lens
            .density(&Self::lens_state(from), &Self::lens_state(to))
            * self
                .dir
                .density(&Self::dir_state(from), &Self::dir_state(to))
    }

    fn invert(&self, from: &MultiChainState, to: &MultiChainState, u: &mut [f32]) -> bool {
        let (ul, ud) = u.split_at_mut(LensProposal::DIM);
        self.lens
            .invert(&Self::lens_state(from), &Self::lens_state(to), ul)
            && self
                .dir
                .invert(&Self::dir_state(from), &Self::dir_state(to), ud)
    }
}

/// The multi-chain perturbation's target for one side chain.
pub(crate) struct MultiChainTarget<'r, 'a, I: Intersector> {
    /// The worker's tracer (its counters record the packets).
    pub tracer: &'r mut Tracer<'a, I>,
    /// What the perturbation keeps fixed.
    pub anchor: &'r MultiChainAnchor,
}

impl<I: Intersector> Target<MultiChainState> for MultiChainTarget<'_, '_, I> {
    fn evaluate(&mut self, states: &mut [Option<MultiChainState>], p: &mut [f32]) {
        evaluate_in_bundles(self, states, p);
    }
}

impl<I: Intersector> Bundled<MultiChainState> for MultiChainTarget<'_, '_, I> {
    fn evaluate_bundle<const N: usize>(
        &mut self,
        states: &mut [Option<MultiChainState>],
        p: &mut [f32],
    ) {
        let n = states.len();
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
                    let v = super::media::multi_chain_value(self.tracer, a, media, s.raster, s.dir);
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
        let mut mids: [Option<Retraced>; N] = [None; N];
        retrace::<I, N>(
            self.tracer,
            &mut rays[..n],
            &a.first,
            TransportMode::Radiance,
            &mut mids[..n],
        );
        // x′_t's factor per unit solid angle of ω′, then the second chain.
        let mut beta = [Rgb::ZERO; N];
        for i in 0..n {
            rays[i] = None;
            let (Some(e), Some(s)) = (&mids[i], &states[i]) else {
                continue;
            };
            let h = &e.hit;
            let w = s.dir;
            self.tracer.stats.bsdf_evals.add(h.bsdf.lobe());
            let f = e.beta
                * scatter(h, e.prev, h.sp.p + w, TransportMode::Radiance)
                * h.sp.ns.dot(w).abs();
            if f.is_black() || !f.is_finite() {
                continue;
            }
            beta[i] = f;
            rays[i] = Some(offset::spawn_ray(h.sp.p, h.sp.p_error, h.sp.ng, w));
        }
        let mut ends: [Option<Retraced>; N] = [None; N];
        retrace::<I, N>(
            self.tracer,
            &mut rays[..n],
            &a.second,
            TransportMode::Radiance,
            &mut ends[..n],
        );
        let value = end_values::<I, N>(self.tracer, &a.end, &ends[..n], &beta[..n]);
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

#[cfg(test)]
mod tests {
    use super::*;

    fn proposal() -> MultiChainProposal {
        MultiChainProposal::new(
            LensProposal::new(1.5, 6.0, 64, 48).unwrap(),
            CausticProposal::new(0.05, 0.2).unwrap(),
        )
    }

    fn start() -> MultiChainState {
        MultiChainState {
            raster: Vec2::new(32.0, 24.0),
            dir: Vec3::new(0.3, -0.4, 0.8).normalize(),
            value: Rgb::ZERO,
        }
    }

    /// Uniforms from a fixed LCG (no RNG crate in the core's tests).
    fn uniforms(seed: &mut u64) -> [f32; 4] {
        core::array::from_fn(|_| {
            *seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (*seed >> 40) as f32 / (1u64 << 24) as f32
        })
    }

    /// E[1/T(x→y)] over y ~ T(x→·) is the measure of T's support: π r² of
    /// raster area times the cap of angular radius r on the sphere,
    /// 2π(1 − cos r). It holds only if `density` is the density of
    /// `sample` in raster area × solid angle, the measure the target is
    /// written in.
    #[test]
    fn density_is_the_density_of_sample() {
        let (p, x) = (proposal(), start());
        let mut seed = 7;
        let n = 200_000;
        let mut acc = 0.0f64;
        for _ in 0..n {
            let y = p.sample(&x, &uniforms(&mut seed)).unwrap();
            acc += 1.0 / p.density(&x, &y) as f64;
        }
        let support =
            core::f64::consts::PI * 36.0 * 2.0 * core::f64::consts::PI * (1.0 - 0.2f64.cos());
        let rel = (acc / n as f64 - support).abs() / support;
        assert!(rel < 0.02, "E[1/T] {} vs support {support}", acc / n as f64);
    }

    /// T is symmetric (the steps use that) and `invert` finds the uniforms
    /// that lead to a state (the multiple-try reference set needs them).
    #[test]
    fn symmetric_and_invertible() {
        let (p, x) = (proposal(), start());
        let mut seed = 11;
        for _ in 0..1000 {
            let y = p.sample(&x, &uniforms(&mut seed)).unwrap();
            let (a, b) = (p.density(&x, &y), p.density(&y, &x));
            assert!(a > 0.0 && (a - b).abs() <= 1e-3 * a, "{a} vs {b}");
            let mut u = [0.0f32; 4];
            assert!(p.invert(&x, &y, &mut u));
            let z = p.sample(&x, &u).unwrap();
            assert!((z.raster - y.raster).length() < 1e-3, "{z:?} vs {y:?}");
            assert!(z.dir.dot(y.dir) > 1.0 - 1e-6, "{z:?} vs {y:?}");
        }
    }
}

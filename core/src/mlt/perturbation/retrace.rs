//! Specular-chain retracing as ray bundles, shared by the three
//! perturbations: a bundle of candidates is traced one packet per bounce
//! ([`retrace`]), and a target is evaluated a bundle of at most
//! [`MAX_LANES`] states at a time ([`evaluate_in_bundles`]).

use glam::Vec3;

use super::SpecularChain;
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, offset};
use crate::integrator::Tracer;
use crate::integrator::bdpt::shading_correction;
use crate::integrator::tracer::Shading;
use crate::math::Rgb;

/// Lanes one bundle evaluation handles at a time: the widest packet.
/// Larger k are evaluated in chunks of this size, which also keeps the
/// per-call scratch small (it is initialised on every call).
pub(super) const MAX_LANES: usize = 16;

/// A path-space target evaluated one bundle of at most [`MAX_LANES`]
/// states at a time ([`evaluate_in_bundles`]).
pub(super) trait Bundled<S> {
    /// One bundle of at most `N` ≤ [`MAX_LANES`] states, with scratch for
    /// `N` lanes.
    fn evaluate_bundle<const N: usize>(&mut self, states: &mut [Option<S>], p: &mut [f32]);
}

/// [`crate::mlt::multiple_try::Target::evaluate`] for a [`Bundled`] target:
/// bundles of [`MAX_LANES`], each with scratch for the lanes at hand (a
/// one-candidate step sets up one lane, not 16).
pub(super) fn evaluate_in_bundles<S, T: Bundled<S>>(
    target: &mut T,
    states: &mut [Option<S>],
    p: &mut [f32],
) {
    for (states, p) in states.chunks_mut(MAX_LANES).zip(p.chunks_mut(MAX_LANES)) {
        match states.len() {
            0..=1 => target.evaluate_bundle::<1>(states, p),
            2..=4 => target.evaluate_bundle::<4>(states, p),
            5..=8 => target.evaluate_bundle::<8>(states, p),
            _ => target.evaluate_bundle::<MAX_LANES>(states, p),
        }
    }
}

/// Per-lane result of [`retrace`].
#[derive(Clone, Copy, Debug)]
pub(super) struct Retraced {
    /// The first non-specular vertex reached.
    pub hit: Shading,
    /// The vertex before it (for its incoming direction).
    pub prev: Vec3,
    /// Throughput of the specular lobes crossed.
    pub beta: Rgb,
}

/// Retraces a bundle of rays through `chain` with packets, one packet per
/// bounce: every lane must hit a specular surface at each link and take the
/// recorded lobe, then hit a non-specular surface, else it fails (`None`).
/// `rays` is consumed as the bundle's current rays. `N` ≥ `rays.len()` is
/// the scratch's lane count: a one-candidate step sets up
/// one lane, not [`MAX_LANES`].
pub(super) fn retrace<I: Intersector, const N: usize>(
    tr: &mut Tracer<'_, I>,
    rays: &mut [Option<Ray>],
    chain: &SpecularChain,
    mode: TransportMode,
    out: &mut [Option<Retraced>],
) {
    let n = rays.len();
    debug_assert!(n <= N && out.len() == n);
    let mut hits: [Option<Shading>; N] = [None; N];
    let mut beta = [Rgb::ONE; N];
    let mut prev = [Vec3::ZERO; N];
    for (p, r) in prev.iter_mut().zip(rays.iter()) {
        if let Some(r) = r {
            *p = r.o;
        }
    }
    for link in 0..=chain.len {
        tr.trace_bundle(rays, &mut hits[..n]);
        for i in 0..n {
            let (Some(ray), Some(h)) = (rays[i], hits[i]) else {
                rays[i] = None;
                continue;
            };
            if link == chain.len {
                continue;
            }
            // A specular link: same kind of vertex, same lobe.
            let wo_world = -ray.d;
            tr.stats.bsdf_samples.add(h.bsdf.lobe());
            let next = h
                .bsdf
                .specular(h.frame.to_local(wo_world), chain.reflect[link], mode);
            let Some((wi, w)) = next else {
                rays[i] = None;
                continue;
            };
            let wi_world = h.frame.to_world(wi);
            let mut w = w;
            if mode == TransportMode::Importance {
                w *= shading_correction(&h.sp, wo_world, wi_world);
            }
            beta[i] *= w;
            prev[i] = h.sp.p;
            rays[i] = (beta[i].is_finite() && !beta[i].is_black())
                .then(|| offset::spawn_ray(h.sp.p, h.sp.p_error, h.sp.ng, wi_world));
        }
    }
    for i in 0..n {
        out[i] = match (rays[i], hits[i]) {
            (Some(_), Some(h)) if !h.bsdf.is_delta() => Some(Retraced {
                hit: h,
                prev: prev[i],
                beta: beta[i],
            }),
            _ => None,
        };
    }
}

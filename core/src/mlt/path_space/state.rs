//! A path-space chain's state and Veach's start-up.
//!
//! The state is the complete path x̄ = x₀ (lens) … x_k (emitter) with its
//! contribution f(x̄) ([`bdpt::path_contribution`]) and the raster position
//! x₀ → x₁ lands at. Start-up (Veach 1997, §11.3.1): the chain starts at
//! the path of a BDPT sample picked in proportion to its weight — the
//! bootstrap samples of the primary-sample level 1, each one strategy's
//! MIS-weighted estimate Y(l) = Y(n·w_{s,t}·f/p_{s,t}), picked ∝ Y(l) by
//! [`Bootstrap::pick`] and replayed here. Those weights are one-sample MIS
//! estimates of ∫Y(f), so the pick is a sampling-importance-resampling
//! draw from Y(f(x̄))/b_d, and b_d is the bootstrap's (the same
//! normalisation as the primary-sample level 1's).
//!
//! Paths through the Dirac lobe of a mixed BSDF ([`PathVertex::mixed_delta`])
//! are given zero contribution: f(x̄) cannot evaluate that lobe.

use alloc::vec::Vec;

use glam::Vec2;

use super::super::{Bootstrap, PrimarySampler, target};
use crate::accel::Intersector;
use crate::integrator::bdpt::{self, PathEnd, PathVertex};
use crate::integrator::{Settings, Tracer};
use crate::math::Rgb;
use crate::scene::{Camera, Scene};

/// A complete path and what it contributes.
#[derive(Clone, Debug, Default)]
pub(crate) struct PathState {
    /// x₀ (lens) … x_k (emitter).
    pub path: Vec<PathVertex>,
    /// f(x̄) in the product area measure (zero for a path that carries
    /// nothing or that f cannot evaluate).
    pub f: Rgb,
    /// Where x₀ → x₁ lands on the image.
    pub raster: Vec2,
    /// In a scene with media, each segment x_i → x_{i+1}'s free-flight
    /// densities ([`bdpt::with_flights`]), set by [`PathState::evaluate`];
    /// empty otherwise.
    #[cfg(feature = "media")]
    pub flights: Vec<(f32, f32)>,
    /// In a scene with media, the medium each vertex lies in (the one its
    /// incoming segment arrives in, the camera's for x₀), set by
    /// [`PathState::evaluate`]; empty otherwise.
    #[cfg(feature = "media")]
    pub media: Vec<Option<crate::scene::MediumId>>,
}

impl PathState {
    /// An empty state with room for paths of up to `depth` segments.
    pub fn with_capacity(depth: u32) -> Self {
        PathState {
            path: Vec::with_capacity(depth as usize + 1),
            f: Rgb::ZERO,
            raster: Vec2::ZERO,
            #[cfg(feature = "media")]
            flights: Vec::with_capacity(depth as usize),
            #[cfg(feature = "media")]
            media: Vec::with_capacity(depth as usize + 1),
        }
    }

    /// The path's depth k (segments).
    pub fn depth(&self) -> usize {
        self.path.len().saturating_sub(1)
    }

    /// The chain's target Y(f(x̄)); 0 for non-finite or non-positive
    /// values.
    pub fn target(&self) -> f32 {
        let y = self.f.luminance();
        if y.is_finite() && y > 0.0 && self.f.is_finite() {
            y
        } else {
            0.0
        }
    }

    /// Sets f and the raster position from the path (see the module docs).
    /// A light at infinity ending the path is moved to lie along its
    /// direction from x_{k−1} (a mutation may have replaced x_{k−1}), where
    /// the mutations' BSDF sampling at x_{k−1} looks for it. In a scene
    /// with media f has every segment's transmittance (a segment found
    /// blocked makes it zero: the mutations do not test the visibility of
    /// their joining edges there), and the segments' free-flight densities
    /// and the vertices' media are kept ([`PathState::densities`]).
    pub fn evaluate<I: Intersector>(&mut self, tr: &mut Tracer<'_, I>) {
        let (scene, camera) = (tr.scene, tr.camera);
        self.evaluate_surfaces(scene, &camera);
        #[cfg(feature = "media")]
        {
            self.flights.clear();
            self.media.clear();
            if tr.has_media() && self.path.len() >= 2 {
                let (mut trans, flights, media) = (Rgb::ONE, &mut self.flights, &mut self.media);
                let ok = bdpt::media::walk_path(
                    tr,
                    &self.path,
                    |_, t, flight| {
                        trans *= t;
                        flights.push(flight);
                    },
                    |_, m| media.push(m),
                );
                self.f = if ok { self.f * trans } else { Rgb::ZERO };
            }
        }
    }

    /// The area densities `fwd`, `rev` of every vertex of the path
    /// ([`bdpt::path_densities`]), with the free-flight densities of its
    /// segments in a scene with media (as [`PathState::evaluate`] found
    /// them).
    pub fn densities(&self, scene: &Scene, camera: &Camera, fwd: &mut [f32], rev: &mut [f32]) {
        bdpt::path_densities(scene, camera, &self.path, fwd, rev);
        #[cfg(feature = "media")]
        bdpt::with_flights(fwd, rev, &self.flights);
    }

    /// [`PathState::evaluate`] without the media: f from the vertices.
    fn evaluate_surfaces(&mut self, scene: &Scene, camera: &Camera) {
        if let [.., before, end] = &mut self.path[..]
            && end.sp.surface == u32::MAX
            && PathEnd::of(scene, end).is_infinite()
        {
            end.sp.p = bdpt::environment_vertex(scene, before.sp.p, end.sp.ng).sp.p;
        }
        let supported = !self.path.iter().any(|v| v.mixed_delta);
        match bdpt::path_contribution(scene, camera, &self.path) {
            Some((f, raster)) if supported => (self.f, self.raster) = (f, raster),
            Some((_, raster)) => (self.f, self.raster) = (Rgb::ZERO, raster),
            None => self.f = Rgb::ZERO,
        }
    }

    /// Veach's start-up: becomes the path of bootstrap sample `index` of
    /// depth `depth` (replayed through `sampler`, restarted at the
    /// sample's primary point). False, with an empty path, when that
    /// sample carries nothing.
    #[allow(clippy::too_many_arguments)]
    pub fn start<I: Intersector>(
        &mut self,
        tracer: &mut Tracer<'_, I>,
        settings: &Settings,
        ws: &mut bdpt::PathStorage,
        sampler: &mut PrimarySampler,
        bootstrap: &Bootstrap,
        depth: u32,
        index: u64,
    ) -> bool {
        sampler.restart(bootstrap.seed_of(index));
        let s = target::evaluate(tracer, settings, ws, depth, sampler);
        self.f = Rgb::ZERO;
        if s.target() <= 0.0 || !bdpt::strategy_path(ws, &mut self.path) {
            self.path.clear();
            return false;
        }
        self.evaluate(tracer);
        self.target() > 0.0
    }
}

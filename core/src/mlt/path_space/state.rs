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
}

impl PathState {
    /// An empty state with room for paths of up to `depth` segments.
    pub fn with_capacity(depth: u32) -> Self {
        PathState {
            path: Vec::with_capacity(depth as usize + 1),
            f: Rgb::ZERO,
            raster: Vec2::ZERO,
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
    /// the mutations' BSDF sampling at x_{k−1} looks for it.
    pub fn evaluate(&mut self, scene: &Scene, camera: &Camera) {
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
        let (scene, camera) = (tracer.scene, tracer.camera);
        self.evaluate(scene, &camera);
        self.target() > 0.0
    }
}

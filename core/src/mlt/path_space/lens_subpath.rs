//! Veach's lens subpath mutation (Veach and Guibas 1997, §3.3; Veach 1997,
//! §11.4.2.3): a new lens subpath for the rest of the path, for the image
//! to be covered more evenly than the other mutations' small moves cover
//! it.
//!
//! The lens subpath of x̄ = x₀ … x_k is x₀ … x_t, x_t its first
//! non-specular vertex after the lens (E S* D). The mutation keeps the lens
//! point and x_{t+1} … x_k, traces a new camera ray from a uniform raster
//! position through x₀, follows it through the specular vertices it meets
//! (sampling their Dirac lobes) to the first non-specular vertex y_j, and
//! joins y_j to x_{t+1}. It applies when t < k and x_{t+1} can be joined
//! (non-specular, or the emitter, of any kind): then it applies to every path it
//! proposes too (their lens subpaths end at y_j, followed by the same
//! x_{t+1}), so choosing it with a probability that depends only on
//! whether it applies keeps detailed balance (`chain.rs`).
//!
//! Its density is the camera side's: T(x̄→ȳ) = ∏_{i=1}^{j} fwd_ȳ[i]
//! ([`bdpt::path_densities`]: the raster position's density as an area
//! density at y₁, then BSDF sampling's, Dirac lobes symbolic), and
//! T(ȳ→x̄) = ∏_{i=1}^{t} fwd_x̄[i]. (Veach draws the raster positions from a
//! stratified sequence over the image; they are uniform here.)

use alloc::vec::Vec;

use glam::Vec2;

use super::bidirectional::Proposal;
use super::emitters::edge_visible;
use super::media::Walk;
use super::state::PathState;
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::integrator::Tracer;
use crate::integrator::bdpt::PathVertex;
use crate::sampler::Sampler;
use crate::scene::{Camera, Scene};

/// The lens subpath mutation for paths of up to `max_depth` segments, with
/// its scratch storage.
#[derive(Clone, Debug)]
pub(crate) struct LensSubpath {
    max_depth: usize,
    fwd: Vec<f32>,
    rev: Vec<f32>,
}

/// The end t of `path`'s lens subpath when the mutation applies to it
/// (module docs), else `None`.
pub(crate) fn applies(path: &[PathVertex]) -> Option<usize> {
    let k = path.len().checked_sub(1)?;
    let t = (1..k).find(|&i| !path[i].is_specular())?;
    let next = &path[t + 1];
    let joinable = t + 1 == k || !(next.is_specular() || next.mixed_delta);
    (joinable && !path[t].mixed_delta).then_some(t)
}

impl LensSubpath {
    /// The mutation for paths of up to `max_depth` segments.
    pub fn new(max_depth: u32) -> Self {
        let n = max_depth as usize + 2;
        LensSubpath {
            max_depth: max_depth as usize,
            fwd: alloc::vec![0.0; n],
            rev: alloc::vec![0.0; n],
        }
    }

    /// The density ∏_{i=1}^{t} fwd[i] of the lens subpath x₀ … x_t of
    /// `x` (with the free-flight densities through media:
    /// [`PathState::densities`]).
    pub fn density(&mut self, scene: &Scene, camera: &Camera, x: &PathState, t: usize) -> f32 {
        x.densities(scene, camera, &mut self.fwd, &mut self.rev);
        self.fwd[1..=t].iter().product()
    }

    /// Makes ȳ from `x` (to which the mutation applies, its lens subpath
    /// ending at `t`) in `y`.
    pub fn propose<I: Intersector, R: Sampler>(
        &mut self,
        tr: &mut Tracer<'_, I>,
        x: &PathState,
        t: usize,
        y: &mut PathState,
        rng: &mut R,
    ) -> Proposal {
        let camera = tr.camera;
        let k = x.depth();
        // Segments the new lens subpath may have.
        let room = self.max_depth - (k - t);
        y.path.clear();
        y.path.push(x.path[0]);
        let u = rng.next_2d();
        let raster = Vec2::new(u.x * camera.width() as f32, u.y * camera.height() as f32);
        let mut ray = camera.ray_from_lens(raster, x.path[0].sp.p);
        let mut walk = Walk::new(tr, x, Some(0));
        loop {
            let Some(Some(v)) = walk.trace(tr, &ray, rng) else {
                return Proposal::Failed;
            };
            y.path.push(v);
            let n = y.path.len();
            if !y.path[n - 1].is_specular() {
                break;
            }
            let u_lobe = rng.next_f32();
            let u = rng.next_2d();
            if n > room {
                return Proposal::Failed;
            }
            match walk.scatter(
                tr,
                &y.path[n - 1],
                &y.path[n - 2],
                u_lobe,
                u,
                TransportMode::Radiance,
            ) {
                Some(r) => ray = r,
                None => return Proposal::Failed,
            }
        }
        let j = y.path.len() - 1;
        if j > room {
            return Proposal::Failed;
        }
        y.path.extend_from_slice(&x.path[t + 1..]);
        // With media the joining edge's transmittance, in f(ȳ), is its
        // visibility through null boundaries (`PathState::evaluate`).
        if !tr.has_media() && !edge_visible(tr, &y.path, j) {
            return Proposal::Failed;
        }
        y.evaluate(tr);
        let scene = tr.scene;
        if y.target() <= 0.0 {
            return Proposal::Failed;
        }
        let t_xy = self.density(scene, &camera, y, j);
        let t_yx = self.density(scene, &camera, x, t);
        if !(t_xy > 0.0) {
            return Proposal::Failed;
        }
        Proposal::Made { ratio: t_yx / t_xy }
    }
}

//! Veach's bidirectional mutation (Veach and Guibas 1997, §3.3; Veach
//! 1997, §11.4.2): delete a subpath of x̄, regenerate it from both ends,
//! reconnect.
//!
//! ## The move
//!
//! For x̄ = x₀ … x_k:
//! 1. k_d, the number of edges deleted, with Veach's weights p_d(1) = ¼,
//!    p_d(2) = ½, p_d(j) = 2^{−j} for j ≥ 3 (normalised over the lengths
//!    that fit), then the position l uniformly: the vertices x_{l+1} …
//!    x_{m−1}, m = l + k_d, go. l = −1 deletes the lens point (only with a
//!    lens: a pinhole's is fixed), m = k + 1 the emitter point; the kept
//!    prefix never ends at the emitter (l ≤ k − 1) and the kept suffix
//!    never starts at the lens (m ≥ 1).
//! 2. k_a, the number of edges added, ∝ 2^{−|k_a − k_d|} over the lengths
//!    that keep the new depth k′ = k − k_d + k_a within 1 … the depth limit
//!    (Veach's shape: the deleted length most likely, then one more or
//!    fewer).
//! 3. The split: t, the number of vertices y₀ … y_{t−1} on the camera side,
//!    uniformly among the strategies that can make the new vertices
//!    y_{l+1} … y_{m′−1}, m′ = l + k_a, from the kept ends (t from
//!    max(l + 1, 1) to m′, without BDPT's missing (1, 1)). The camera side
//!    extends x_l by random walk (a new lens point first when l = −1; a
//!    uniform raster position from the lens), the light side extends x_m
//!    backwards (a new emitter vertex first when m = k + 1; emission
//!    from the emitter as BDPT's light subpaths sample it, `emitters`;
//!    BSDF sampling in importance mode), and y_{t−1}, y_t are joined by
//!    an edge (no edge when s = k′ + 1 − t = 0: the camera side reached
//!    the emitter, an emissive surface or, leaving the scene, the
//!    environment).
//!
//! ## Its density
//!
//! T(x̄→ȳ) = p(k_d | k) · p(l | k_d, k) · p(k_a | k_d, k) · Σ_t (1/n_t)
//! ∏_{new i < t} fwd_ȳ[i] · ∏_{new i ≥ t} rev_ȳ[i],
//!
//! summed over every split t that could have made the same new vertices
//! (Veach's sum over (s, t)), with the per-vertex area densities of
//! [`bdpt::path_densities`] of ȳ; a split that would join two vertices
//! across a specular vertex (or a mixed BSDF's Dirac lobe) cannot make
//! ȳ and is left out of the sum, and when drawn the proposal fails. The
//! reverse move deletes the same position's k_a edges from ȳ and adds k_d:
//! T(ȳ→x̄) is the same function with the roles swapped, so the chain
//! accepts with min(1, f(ȳ)T(ȳ→x̄) / (f(x̄)T(x̄→ȳ))).
//!
//! Every kind of emitter ([`bdpt::PathEnd`]): a point, spot or
//! directional light cannot be reached by the camera side (its `fwd[k]`
//! is 0, so the split s = 0 adds nothing to T and is never made), and its
//! vertex is joined by the edge of the split s = 1 as next-event
//! estimation joins it; the environment is reached when the camera side's
//! last ray leaves the scene.

use alloc::vec::Vec;

use glam::Vec2;

use super::emitters::{edge_visible, emission_ray, new_emitter};
use super::media::Walk;
use super::state::PathState;
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::geometry::offset;
use crate::integrator::Tracer;
use crate::integrator::bdpt::{self, PathEnd, PathVertex};
use crate::sampler::Sampler;
use crate::scene::{Camera, Scene, SurfacePoint};

/// What a proposal did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Proposal {
    /// Nothing deleted and nothing added (k_d = k_a = 1): ȳ = x̄.
    Identity,
    /// The walk missed, was absorbed, took a mixed BSDF's Dirac lobe, or
    /// the drawn split cannot join its ends: ȳ has density 0 under this
    /// move, the chain stays.
    Failed,
    /// ȳ was made, with T(ȳ→x̄) / T(x̄→ȳ).
    Made {
        /// T(ȳ→x̄) / T(x̄→ȳ).
        ratio: f32,
    },
}

/// The deletion and addition a proposal drew.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Move {
    /// Last kept vertex of the camera side (−1: none).
    pub l: isize,
    /// Edges deleted.
    pub kd: usize,
    /// Edges added.
    pub ka: usize,
    /// The split drawn: vertices on the camera side (0 when nothing was
    /// made).
    pub t: usize,
}

/// The bidirectional mutation of paths of up to `max_depth` segments, with
/// its scratch storage (no allocation once made).
#[derive(Clone, Debug)]
pub(crate) struct Bidirectional {
    max_depth: usize,
    fwd: Vec<f32>,
    rev: Vec<f32>,
    /// The light side while it is built: x_k … x_m, then the new vertices
    /// in the order they are made.
    light: Vec<PathVertex>,
    /// The tests' negative controls: a T that is wrong.
    #[cfg(test)]
    pub broken: Option<Broken>,
}

/// How the tests' negative controls break T.
#[cfg(test)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Broken {
    /// The drawn split's density alone, without Veach's sum.
    SingleSplit,
    /// Without the probabilities of the deleted and added lengths, which
    /// differ between a move and its reverse.
    NoLengths,
    /// The chain's ratio without the mutations' selection probabilities,
    /// which differ between a path the lens subpath mutation applies to
    /// and one it does not.
    NoSelection,
    /// Without the density of the emitter vertex (its `rev[k]`: light
    /// selection, and the direction's density on the environment).
    NoEmitterDensity,
    /// Without the free-flight densities of the segments through media
    /// (the walks sample them: `media.rs`).
    NoFlights,
}

/// Veach's deletion weight p_d(k_d).
fn deletion_weight(kd: usize) -> f32 {
    match kd {
        1 => 0.25,
        2 => 0.5,
        _ => libm::powf(0.5, kd as f32),
    }
}

/// The added-length weight given k_d deleted edges.
fn addition_weight(ka: usize, kd: usize) -> f32 {
    libm::powf(0.5, (ka as f32 - kd as f32).abs())
}

/// The positions l of a deletion of `kd` edges from a path of depth `k`:
/// lo ..= hi (empty when lo > hi).
fn positions(k: usize, kd: usize, lens: bool) -> (isize, isize) {
    let (k, kd) = (k as isize, kd as isize);
    let lo = (if lens { -1 } else { 0 }).max(1 - kd);
    (lo, (k - 1).min(k + 1 - kd))
}

/// The range of added lengths k_a after deleting `kd` edges after vertex
/// `l` of a path of depth `k`: the new depth in 1 ..= `max_depth`, and the
/// reverse move one of [`positions`]' (the kept prefix does not end at the
/// new path's emitter, k′ ≥ l + 1, and the kept suffix does not start at
/// its lens, l + k_a ≥ 1: a new lens or emitter point replaces a deleted
/// one).
fn added_lengths(k: usize, kd: usize, l: isize, max_depth: usize) -> (usize, usize) {
    let (k, kd, d) = (k as isize, kd as isize, max_depth as isize);
    let lo = 1.max(1.max(l + 1) + kd - k).max(1 - l);
    (lo as usize, (d + kd - k).max(0) as usize)
}

/// The camera-side vertex counts t of the splits of a new path of depth
/// `k2` whose new vertices are l + 1 … m2 − 1, and how many there are.
fn splits(l: isize, m2: usize, k2: usize) -> (usize, usize, usize) {
    let lo = ((l + 1).max(1)) as usize;
    let n = (m2 + 1 - lo) - usize::from(k2 == 1 && lo == 1);
    (lo, m2, n)
}

/// Whether strategy t of path `y` (depth k2) can join its ends: no edge
/// for s = 0; otherwise neither end scatters only through a Dirac lobe
/// (the lens and the emitter point always can be joined).
fn joinable(y: &[PathVertex], t: usize) -> bool {
    let k2 = y.len() - 1;
    if t == k2 + 1 {
        return true;
    }
    if k2 == 1 && t == 1 {
        return false;
    }
    let ok = |i: usize| i == 0 || i == k2 || !(y[i].is_specular() || y[i].mixed_delta);
    ok(t - 1) && ok(t)
}

impl Bidirectional {
    /// The mutation for paths of up to `max_depth` segments.
    pub fn new(max_depth: u32) -> Self {
        let n = max_depth as usize + 2;
        Bidirectional {
            max_depth: max_depth as usize,
            fwd: alloc::vec![0.0; n],
            rev: alloc::vec![0.0; n],
            light: Vec::with_capacity(n),
            #[cfg(test)]
            broken: None,
        }
    }

    /// p(k_d | k) · p(l | k_d, k) · p(k_a | k_d, k) of the move `mv` from a
    /// path of depth `k`.
    fn choice_probability(&self, k: usize, mv: Move, lens: bool) -> f32 {
        let kd_total: f32 = (1..=k + 2)
            .filter(|&j| {
                let (lo, hi) = positions(k, j, lens);
                lo <= hi
            })
            .map(deletion_weight)
            .sum();
        let (lo, hi) = positions(k, mv.kd, lens);
        let (a_lo, a_hi) = added_lengths(k, mv.kd, mv.l, self.max_depth);
        if !(lo..=hi).contains(&mv.l) || !(a_lo..=a_hi).contains(&mv.ka) {
            return 0.0;
        }
        let ka_total: f32 = (a_lo..=a_hi).map(|a| addition_weight(a, mv.kd)).sum();
        #[cfg(test)]
        if self.broken == Some(Broken::NoLengths) {
            return 1.0;
        }
        deletion_weight(mv.kd) / kd_total / (hi - lo + 1) as f32
            * (addition_weight(mv.ka, mv.kd) / ka_total)
    }

    /// T(`from` → `to`) for the move `mv` that deletes `mv.kd` edges of
    /// `from` after vertex `mv.l` and adds `mv.ka` (module docs); 0 for a
    /// move the mutation never draws. With `only` = Some(t), split t alone
    /// counts (the tests' negative control: a density without Veach's
    /// sum).
    pub fn density(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        from: &[PathVertex],
        to: &PathState,
        mv: Move,
        only: Option<usize>,
    ) -> f32 {
        let (k, k2) = (from.len() - 1, to.depth());
        let lens = camera.has_lens();
        let choice = self.choice_probability(k, mv, lens);
        to.densities(scene, camera, &mut self.fwd, &mut self.rev);
        #[cfg(test)]
        if self.broken == Some(Broken::NoFlights) {
            bdpt::path_densities(scene, camera, &to.path, &mut self.fwd, &mut self.rev);
        }
        let to = &to.path;
        #[cfg(test)]
        if self.broken == Some(Broken::NoEmitterDensity) {
            self.rev[k2] = 1.0;
        }
        let m2 = (mv.l + mv.ka as isize) as usize;
        let first = (mv.l + 1) as usize;
        let (lo, hi, n) = splits(mv.l, m2, k2);
        if n == 0 {
            return 0.0;
        }
        let mut sum = 0.0f32;
        for t in lo..=hi {
            if !joinable(to, t) || only.is_some_and(|o| o != t) {
                continue;
            }
            let camera_side: f32 = self.fwd[first..t].iter().product();
            let light_side: f32 = self.rev[t..m2].iter().product();
            sum += camera_side * light_side;
        }
        choice * sum / n as f32
    }

    /// Draws the move from `x` (depth k ≥ 1) and makes ȳ in `y` (module
    /// docs), returning the move and what became of it.
    pub fn propose<I: Intersector, R: Sampler>(
        &mut self,
        tr: &mut Tracer<'_, I>,
        x: &PathState,
        y: &mut PathState,
        rng: &mut R,
    ) -> (Move, Proposal) {
        let k = x.depth();
        let lens = tr.camera.has_lens();
        let u = rng.next_2d();
        let u_add = rng.next_f32();
        let u_split = rng.next_f32();
        // k_d ∝ p_d over the lengths that fit, then l uniformly.
        let fits = |j: usize| {
            let (lo, hi) = positions(k, j, lens);
            lo <= hi
        };
        let kd_total: f32 = (1..=k + 2).filter(|&j| fits(j)).map(deletion_weight).sum();
        let mut acc = 0.0;
        let mut kd = 1;
        for j in (1..=k + 2).filter(|&j| fits(j)) {
            kd = j;
            acc += deletion_weight(j) / kd_total;
            if u.x < acc {
                break;
            }
        }
        let (lo, hi) = positions(k, kd, lens);
        let l = (lo + (u.y * (hi - lo + 1) as f32) as isize).min(hi);
        let (a_lo, a_hi) = added_lengths(k, kd, l, self.max_depth);
        if a_lo > a_hi {
            return (Move { l, kd, ka: 0, t: 0 }, Proposal::Failed);
        }
        let ka_total: f32 = (a_lo..=a_hi).map(|a| addition_weight(a, kd)).sum();
        let mut acc = 0.0;
        let mut ka = a_lo;
        for a in a_lo..=a_hi {
            ka = a;
            acc += addition_weight(a, kd) / ka_total;
            if u_add < acc {
                break;
            }
        }
        let mut mv = Move { l, kd, ka, t: 0 };
        if kd == 1 && ka == 1 {
            return (mv, Proposal::Identity);
        }
        let k2 = k + ka - kd;
        let m = (l + kd as isize) as usize;
        let m2 = (l + ka as isize) as usize;
        let (s_lo, _, n) = splits(l, m2, k2);
        if n == 0 {
            // Lens and emitter joined directly, the (1, 1) that is no
            // strategy: no split can make this path.
            return (mv, Proposal::Failed);
        }
        let mut t = s_lo + ((u_split * n as f32) as usize).min(n - 1);
        if k2 == 1 && s_lo == 1 {
            // (1, 1) is not a split: the n splits are 2 ..= m2.
            t += 1;
        }
        mv.t = t;
        if self.make(tr, x, y, l, m, m2, t, rng).is_none() || !joinable(&y.path, t) {
            return (mv, Proposal::Failed);
        }
        // With media the joining edge's transmittance, in f(ȳ), is its
        // visibility through null boundaries (`PathState::evaluate`).
        if k2 + 1 != t && !tr.has_media() && !edge_visible(tr, &y.path, t - 1) {
            return (mv, Proposal::Failed);
        }
        y.evaluate(tr);
        let (scene, camera) = (tr.scene, tr.camera);
        if y.target() <= 0.0 {
            return (mv, Proposal::Failed);
        }
        #[cfg(test)]
        let (only, only_back) = if self.broken == Some(Broken::SingleSplit) {
            // The reverse move's split: the same boundary between the
            // sides, counted from the same kept prefix.
            (Some(t), Some((t + kd).saturating_sub(ka)))
        } else {
            (None, None)
        };
        #[cfg(not(test))]
        let (only, only_back) = (None, None);
        let t_xy = self.density(scene, &camera, &x.path, y, mv, only);
        let back = Move {
            l,
            kd: ka,
            ka: kd,
            t: 0,
        };
        let t_yx = self.density(scene, &camera, &y.path, x, back, only_back);
        if !(t_xy > 0.0) {
            return (mv, Proposal::Failed);
        }
        (mv, Proposal::Made { ratio: t_yx / t_xy })
    }

    /// Builds ȳ: x₀ … x_l, t − l − 1 camera-side vertices, m2 − t
    /// light-side ones, x_m … x_k. `None` when a walk fails.
    #[allow(clippy::too_many_arguments)]
    fn make<I: Intersector, R: Sampler>(
        &mut self,
        tr: &mut Tracer<'_, I>,
        x: &PathState,
        y: &mut PathState,
        l: isize,
        m: usize,
        m2: usize,
        t: usize,
        rng: &mut R,
    ) -> Option<()> {
        let k = x.depth();
        let camera = tr.camera;
        let environment = cfg!(feature = "environment") && tr.scene.lights.has_environment();
        y.path.clear();
        y.f = crate::math::Rgb::ZERO;
        if l >= 0 {
            y.path.extend_from_slice(&x.path[..=l as usize]);
        }
        let mut walk = Walk::new(tr, x, (l >= 0).then_some(l as usize));
        while y.path.len() < t {
            let n = y.path.len();
            let u_lobe = rng.next_f32();
            let u = rng.next_2d();
            if n == 0 {
                let p = camera.lens_point(u);
                y.path.push(lens_vertex(p, camera.forward()));
                continue;
            }
            let ray = if n == 1 {
                let raster = Vec2::new(u.x * camera.width() as f32, u.y * camera.height() as f32);
                camera.ray_from_lens(raster, y.path[0].sp.p)
            } else {
                walk.scatter(
                    tr,
                    &y.path[n - 1],
                    &y.path[n - 2],
                    u_lobe,
                    u,
                    TransportMode::Radiance,
                )?
            };
            match walk.trace(tr, &ray, rng)? {
                Some(v) => y.path.push(v),
                // The camera side's last vertex is the path's emitter
                // (s = 0, the emitter deleted): leaving the scene, it is
                // the environment, as BDPT's escaped camera subpath.
                None if m > k && n + 1 == m2 && t == m2 && environment => {
                    let from = y.path[n - 1].sp.p;
                    y.path
                        .push(bdpt::environment_vertex(tr.scene, from, ray.d.normalize()));
                }
                None => return None,
            }
        }
        // The light side, from the emitter backwards.
        self.light.clear();
        if m <= k {
            self.light.extend(x.path[m..].iter().rev());
        }
        let mut walk = Walk::new(tr, x, Some(m));
        let new_light = m2 - t;
        // The ray a new light that is not a mesh emits with its vertex.
        let mut emitted = None;
        for _ in 0..new_light {
            let n = self.light.len();
            let u_lobe = rng.next_f32();
            let u = rng.next_2d();
            if n == 0 {
                let (v, ray) = new_emitter(tr, u_lobe, u, rng.next_2d())?;
                self.light.push(v);
                emitted = ray;
                continue;
            }
            let ray = if n == 1 {
                let ray = match emitted.take() {
                    Some(ray) => ray,
                    None => {
                        let ray = emission_ray(tr.scene, &self.light[0], u)?;
                        if PathEnd::of(tr.scene, &self.light[0]) != PathEnd::Area {
                            // A light at infinity's vertex stands where
                            // its ray starts, so that the direction from
                            // the next vertex towards it is the ray's.
                            self.light[0].sp.p = ray.o;
                        }
                        ray
                    }
                };
                let kept = (m <= k).then_some((x, k));
                walk.emitted(tr, &self.light[0], &ray, kept);
                ray
            } else {
                walk.scatter(
                    tr,
                    &self.light[n - 1],
                    &self.light[n - 2],
                    u_lobe,
                    u,
                    TransportMode::Importance,
                )?
            };
            self.light.push(walk.trace(tr, &ray, rng)??);
        }
        y.path.extend(self.light.iter().rev());
        Some(())
    }
}

/// The lens vertex at `p` (its normal the viewing direction).
pub(super) fn lens_vertex(p: glam::Vec3, forward: glam::Vec3) -> PathVertex {
    PathVertex {
        sp: SurfacePoint {
            p,
            p_error: glam::Vec3::ZERO,
            ng: forward,
            ns: forward,
            uv: Vec2::ZERO,
            surface: u32::MAX,
            prim: u32::MAX,
        },
        shading: None,
        mixed_delta: false,
    }
}

/// A surface vertex a walk reached.
pub(super) fn surface_vertex(sh: crate::integrator::tracer::Shading) -> PathVertex {
    PathVertex {
        sp: sh.sp,
        shading: Some(sh),
        mixed_delta: false,
    }
}

/// The ray BSDF sampling sends from `v`, reached from `from`, in `mode`;
/// `None` when the BSDF absorbs or a mixed BSDF's Dirac lobe is drawn
/// (f(x̄) cannot evaluate it).
pub(super) fn scatter_ray<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    v: &PathVertex,
    from: &PathVertex,
    u_lobe: f32,
    u: Vec2,
    mode: TransportMode,
) -> Option<crate::geometry::Ray> {
    let sh = v.shading?;
    let wo = sh.frame.to_local((from.sp.p - v.sp.p).normalize());
    let bs = tr.sample_bsdf(&sh.bsdf, wo, u_lobe, u, mode)?;
    if !(bs.pdf > 0.0) || bs.f.is_black() || (bs.delta && !sh.bsdf.is_delta()) {
        return None;
    }
    let d = sh.frame.to_world(bs.wi);
    Some(offset::spawn_ray(v.sp.p, v.sp.p_error, v.sp.ng, d))
}

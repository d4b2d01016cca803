//! A complete path's measurement contribution f(x̄) and the area densities
//! with which BDPT's strategies generate its vertices (Veach 1997, §8.2
//! and §10.2): what path-space Metropolis light transport needs of a path
//! given by its vertices alone (`mlt::path_space`), where BDPT keeps them
//! in its subpaths as it samples.
//!
//! The path is x₀ (the lens point) … x_k (a point on an area emitter), as
//! [`super::strategy_path`] writes it. Its contribution, in the product
//! area measure, is the one path tracing's estimator (s = 0) divides by its
//! density:
//!
//! f(x̄) = W_e(x₀→x₁) cos θ₀ · ∏_{i=0}^{k−1} |n_g(x_{i+1})·ω_i| / d_i² ·
//! ∏_{i=1}^{k−1} f_s(x_{i−1} ← x_i → x_{i+1}) |n_s(x_i)·ω_i| · L_e(x_k→x_{k−1}),
//!
//! ω_i the unit direction from x_i to x_{i+1} and d_i their distance: the
//! cosine at the end a segment arrives at about the geometric normal (the
//! area-measure conversion), the one at the scattering vertex about the
//! shading normal (BSDF sampling's cosine). Where the two normals agree
//! every strategy's unweighted estimate is f(x̄)/p_{s,t}(x̄); with shading
//! normals light subpaths weigh their vertices by Veach's adjoint
//! correction (eq. 5.19), as BDPT does.
//!
//! The densities are per vertex, from either neighbour: `fwd[i]` of
//! generating x_i from x_{i−1} (the camera subpath's walk; `fwd[0]` the
//! lens point's density), `rev[i]` of generating x_i from x_{i+1} (the
//! light subpath's walk; `rev[k]` the emitter point's density, light
//! selection included, and `rev[0]` the lens point's again, as light
//! tracing's connection samples it). Strategy (s, t) generates x₀ … x_{t−1}
//! from the camera and x_t … x_k from the light, so
//!
//! p_{s,t}(x̄) = ∏_{i<t} fwd[i] · ∏_{i≥t} rev[i].
//!
//! Specular vertices are kept symbolic, as in BDPT's estimates: f(x̄)
//! takes a Dirac lobe's sampling weight f·|cos|/p (the throughput BSDF
//! sampling gives it) in place of f_s|cos|, and the density of the vertex
//! sampled through it is that of a unit solid-angle density, the area
//! conversion |n_g·ω|/d² alone. Every strategy that does not connect at a
//! specular vertex walks through it from one side, so the Dirac factors
//! f and p leave out are the same and cancel in f/p and in every ratio.
//! Strategies that connect at a specular vertex (x_{t−1} or x_t specular)
//! cannot sample the path; [`strategy_density`] does not know the path
//! and the caller must leave them out. A mixed BSDF's Dirac lobe (smooth
//! plastic's coating, [`PathVertex::mixed_delta`]) is not handled.

use glam::Vec2;

use super::{Kind, Local, PathVertex, Vertex, camera_vertex, light_emission_pdf};
use crate::bsdf::TransportMode;
use crate::math::Rgb;
use crate::scene::{Camera, Scene};

/// The BDPT vertex of `path[i]`: the camera at 0, the emitter at the end,
/// a surface between (one with no BSDF is treated as absorbing).
fn vertex(camera: &Camera, path: &[PathVertex], i: usize) -> Vertex {
    let v = &path[i];
    if i == 0 {
        return camera_vertex(v.sp.p, camera.forward());
    }
    let kind = if i + 1 == path.len() {
        Kind::Light
    } else {
        Kind::Surface
    };
    Vertex {
        kind,
        sp: v.sp,
        local: v.shading.map(|sh| Local {
            bsdf: sh.bsdf,
            frame: sh.frame,
        }),
        beta: Rgb::ONE,
        pdf_fwd: 0.0,
        pdf_rev: 0.0,
        delta: false,
    }
}

/// f(x̄) of the complete path `path` = x₀ … x_k (k ≥ 1, x_k on an area
/// emitter) and the raster position of x₀ → x₁ (module docs); `None` when
/// that direction leaves the image or the path has fewer than two
/// vertices. Visibility is not tested: the path's segments were traced
/// when it was made. A specular vertex contributes its Dirac lobe's
/// weight (the factor BSDF sampling gives it), the Dirac measure itself
/// left symbolic.
pub fn path_contribution(
    scene: &Scene,
    camera: &Camera,
    path: &[PathVertex],
) -> Option<(Rgb, Vec2)> {
    let k = path.len().checked_sub(1).filter(|&k| k >= 1)?;
    let p0 = path[0].sp.p;
    let w0 = (path[1].sp.p - p0).normalize();
    let (we, raster) = camera.importance(p0, w0)?;
    let cos0 = camera.forward().dot(w0);
    let mut f = Rgb::splat(we * cos0);
    for i in 0..k {
        let (a, b) = (&path[i], &path[i + 1]);
        let d = b.sp.p - a.sp.p;
        let d2 = d.length_squared();
        if !(d2 > 0.0) {
            return Some((Rgb::ZERO, raster));
        }
        let w = d / libm::sqrtf(d2);
        let mut g = b.sp.ng.dot(w).abs() / d2;
        if i > 0 {
            let Some(sh) = &a.shading else {
                return Some((Rgb::ZERO, raster));
            };
            let prev = path[i - 1].sp.p;
            let fs = if sh.bsdf.is_delta() {
                // The lobe's weight f·|cos|/p of sampling it, without the
                // Dirac measure; the cosine is in it already.
                let wo = sh.frame.to_local((prev - a.sp.p).normalize());
                let reflect = (prev - a.sp.p).dot(a.sp.ng) * d.dot(a.sp.ng) > 0.0;
                match sh.bsdf.specular(wo, reflect, TransportMode::Radiance) {
                    Some((_, weight)) => weight,
                    None => return Some((Rgb::ZERO, raster)),
                }
            } else {
                g *= sh.sp.ns.dot(w).abs();
                super::scatter(sh, prev, b.sp.p, TransportMode::Radiance)
            };
            f *= fs;
        }
        f *= g;
    }
    let light = &path[k];
    f *= scene.emitted(&light.sp, (path[k - 1].sp.p - light.sp.p).normalize());
    Some((f, raster))
}

/// Fills `fwd[i]` and `rev[i]` (i = 0 … k) with the area densities of
/// generating x_i from x_{i−1} and from x_{i+1} (module docs) for the
/// complete path `path` = x₀ … x_k, x_k on an area emitter. Both slices
/// must hold at least `path.len()` values.
pub fn path_densities(
    scene: &Scene,
    camera: &Camera,
    path: &[PathVertex],
    fwd: &mut [f32],
    rev: &mut [f32],
) {
    let n = path.len();
    if n < 2 {
        return;
    }
    let lights_pdf = |l: &Vertex, to: &Vertex| light_emission_pdf(scene, l, to);
    let w0 = (path[1].sp.p - path[0].sp.p).normalize();
    let lens = camera.pdf_ray(path[0].sp.p, w0).0;
    fwd[0] = lens;
    rev[0] = lens;
    rev[n - 1] = scene.lights.pdf_area(path[n - 1].sp.surface as usize);
    // A sliding window of three vertices, so that none is built twice.
    let mut before: Option<Vertex> = None;
    let mut a = vertex(camera, path, 0);
    let mut b = vertex(camera, path, 1);
    for i in 1..n {
        // fwd[i]: from a = x_{i−1}, reached from x_{i−2}.
        fwd[i] = if is_specular(&a) {
            a.area_density_at(1.0, &b)
        } else {
            a.pdf(camera, lights_pdf, before.as_ref(), &b)
        };
        // rev[i − 1]: from b = x_i, reached from x_{i+1}.
        let c = (i + 1 < n).then(|| vertex(camera, path, i + 1));
        if i > 1 {
            rev[i - 1] = if is_specular(&b) {
                b.area_density_at(1.0, &a)
            } else {
                b.pdf(camera, lights_pdf, c.as_ref(), &a)
            };
        }
        before = Some(a);
        a = b;
        if let Some(c) = c {
            b = c;
        }
    }
}

/// A surface vertex that scatters only through Dirac lobes.
fn is_specular(v: &Vertex) -> bool {
    v.kind == Kind::Surface && v.local.is_some_and(|l| l.bsdf.is_delta())
}

/// The density p_{s,t}(x̄) = ∏_{i<t} `fwd[i]` · ∏_{i≥t} `rev[i]` of strategy
/// (s, t), s + t = k + 1, from [`path_densities`]' values.
pub fn strategy_density(fwd: &[f32], rev: &[f32], t: usize) -> f32 {
    let camera: f32 = fwd[..t].iter().product();
    let light: f32 = rev[t..].iter().product();
    camera * light
}

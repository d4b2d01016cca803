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
//! Specular vertices are kept symbolic: f(x̄) takes a Dirac lobe's
//! throughput f·|cos| in radiance (F, or (1 − F)/η² for refracted
//! radiance; [`crate::bsdf::Bsdf::specular`]) in place of f_s|cos|, the
//! Dirac measure left out, and the density of the vertex sampled through
//! it is the probability with which BSDF sampling chooses that lobe (1 at
//! a mirror, F or 1 − F at a dielectric) in the same measure, times the
//! area conversion |n_g·ω|/d². A light subpath walks through the vertex
//! the other way, in importance, whose Dirac measure differs by the
//! Jacobian of the lobe's mapping (η² across a refraction): its density
//! takes the ratio of the lobe's throughputs in the two modes as well
//! (`dirac_density`). Every strategy that does not connect at a specular
//! vertex walks through it from one side, so f/p is BDPT's estimate and
//! the Dirac measure cancels in every ratio; the path-space mutations'
//! walks choose lobes by BSDF sampling, so their densities need the lobe
//! probabilities too (without them a chain weighed paths through glass by
//! F or 1 − F per vertex).
//! Strategies that connect at a specular vertex (x_{t−1} or x_t specular)
//! cannot sample the path; [`strategy_density`] does not know the path
//! and the caller must leave them out. A mixed BSDF's Dirac lobe (smooth
//! plastic's coating, [`PathVertex::mixed_delta`]) is not handled.
//!
//! Lights that are not meshes end a path as BDPT's vertices for them do
//! ([`PathEnd`]; pbrt-v4's convention). A point or spot light x_k is a
//! delta position: its segment's factor is 1/d² (no cosine at the light)
//! times the intensity I(x_k→x_{k−1}), `rev[k]` its selection probability
//! (the position's Dirac measure symbolic) and `fwd[k]` = 0 (no ray hits
//! it, so s = 0 cannot make the path). A light at infinity x_k is a unit
//! direction ω (`sp.ng`, towards the light): its segment's factor is 1 (a
//! solid-angle measure at x_{k−1}) times the radiance L(ω) of the
//! environment or the irradiance E of a directional light, `fwd[k]` the
//! solid-angle density of ω from x_{k−1} (0 for a directional light's
//! delta direction), `rev[k]` the density of ω by light selection and
//! sampling (the environment's summed over its lights; a directional
//! light's selection probability) and `rev[k−1]` the area density of the
//! emitted ray's origin on the bounding sphere's disk, 1/(π r²)·|n_g·ω|.
//! Every strategy's estimate is then f/p as above (the
//! `strategy_estimates_are_contribution_over_density` tests check it).
//!
//! **Media** (the `media` feature, scenes with media or null boundaries):
//! a medium vertex ([`PathVertex::is_medium`]) contributes σ_s times its
//! phase function in place of f_s|n_s·ω_i|, and no segment has a cosine
//! at it; the densities take the phase function's density there (it is
//! sampled exactly) and no cosine (the `media` module's docs). What needs
//! rays — every segment's transmittance through the media and null
//! boundaries, and its free-flight densities as BDPT's walks sample them —
//! is `media::walk_path`'s: f(x̄) is [`path_contribution`] times the
//! transmittances, and `fwd[i+1]`, `rev[i]` are [`path_densities`]' times
//! the segment x_i → x_{i+1}'s free-flight densities ([`with_flights`]).

use glam::{Vec2, Vec3};

use super::{
    Kind, Local, PathVertex, Vertex, at_infinity, camera_vertex, light_emission_pdf,
    other_light_vertex,
};
use crate::bsdf::TransportMode;
use crate::math::Rgb;
use crate::scene::light::Emission;
use crate::scene::{Camera, Light, Scene};

/// What the last vertex x_k of a complete path is (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PathEnd {
    /// A point on an emissive mesh.
    Area,
    /// Point or spot light `.0` of [`crate::scene::light::LightSet::others`].
    Point(u32),
    /// Directional light `.0` of [`crate::scene::light::LightSet::others`].
    Directional(u32),
    /// The environment (every non-delta light at infinity), in direction
    /// `sp.ng`.
    Environment,
}

impl PathEnd {
    /// The kind of emitter vertex `v` (the end of a path of `scene`, made
    /// by [`super::strategy_path`] or the path-space mutations): a vertex
    /// on no surface is one of the other lights, an index in `sp.prim`
    /// naming a point or directional light and none the environment.
    pub fn of(scene: &Scene, v: &PathVertex) -> PathEnd {
        if v.sp.surface != u32::MAX {
            return PathEnd::Area;
        }
        let i = v.sp.prim;
        match scene.lights.others().nth(i as usize) {
            Some(Light::Directional { .. }) => PathEnd::Directional(i),
            Some(Light::Point { .. } | Light::Spot { .. }) => PathEnd::Point(i),
            _ => PathEnd::Environment,
        }
    }

    /// A point, spot or directional light: no ray reaches it.
    pub fn is_delta(self) -> bool {
        matches!(self, PathEnd::Point(_) | PathEnd::Directional(_))
    }

    /// A light at infinity: the vertex is a direction.
    pub fn is_infinite(self) -> bool {
        matches!(self, PathEnd::Directional(_) | PathEnd::Environment)
    }

    /// The BDPT vertex kind.
    fn kind(self) -> Kind {
        match self {
            PathEnd::Area => Kind::Light,
            PathEnd::Point(_) => Kind::PointLight,
            PathEnd::Directional(_) => Kind::Directional,
            PathEnd::Environment => Kind::Environment,
        }
    }
}

/// The emitter vertex of other light `index` from which emission `e`
/// leaves ([`crate::scene::light::LightSet::sample_emission`]), as a light subpath
/// of BDPT starts.
pub fn emission_vertex(scene: &Scene, index: usize, e: &Emission) -> PathVertex {
    let mut v = other_light_vertex(scene, index, e.origin, e.origin, -e.dir);
    v.sp.p = e.origin;
    PathVertex {
        sp: v.sp,
        shading: None,
        mixed_delta: false,
    }
}

/// The environment vertex a ray from `from` along unit `d` reaches when
/// it leaves the scene, as BDPT's escaped camera subpath ends.
pub fn environment_vertex(scene: &Scene, from: Vec3, d: Vec3) -> PathVertex {
    let (center, r) = scene.lights.bounding_sphere();
    PathVertex {
        sp: at_infinity(Kind::Environment, from, d, center, r).sp,
        shading: None,
        mixed_delta: false,
    }
}

/// Unit direction from x_i to x_{i+1} of `path` (whose end is `end`).
fn direction(path: &[PathVertex], end: PathEnd, i: usize) -> Vec3 {
    if i + 2 == path.len() && end.is_infinite() {
        path[i + 1].sp.ng
    } else {
        (path[i + 1].sp.p - path[i].sp.p).normalize()
    }
}

/// The BDPT vertex of `path[i]`: the camera at 0, the emitter `end` at
/// the end, a surface between (one with no BSDF is treated as absorbing).
fn vertex(camera: &Camera, path: &[PathVertex], end: PathEnd, i: usize) -> Vertex {
    let v = &path[i];
    if i == 0 {
        return camera_vertex(v.sp.p, camera.forward());
    }
    let kind = if i + 1 == path.len() {
        end.kind()
    } else if v.is_medium() {
        // `Vertex::pdf` then takes the phase function's density and
        // `area_density_at` no cosine at it (media module docs).
        Kind::Medium
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

/// f(x̄) of the complete path `path` = x₀ … x_k (k ≥ 1, x_k an emitter of
/// any kind, [`PathEnd`]) and the raster position of x₀ → x₁ (module
/// docs); `None` when that direction leaves the image or the path has
/// fewer than two vertices. Visibility is not tested: the path's segments
/// were traced when it was made. A specular vertex contributes its Dirac
/// lobe's weight (the factor BSDF sampling gives it), the Dirac measure
/// itself left symbolic. A medium vertex contributes σ_s × phase (module
/// docs); the segments' transmittance is not in the value (the caller's:
/// `media::walk_path`).
pub fn path_contribution(
    scene: &Scene,
    camera: &Camera,
    path: &[PathVertex],
) -> Option<(Rgb, Vec2)> {
    let k = path.len().checked_sub(1).filter(|&k| k >= 1)?;
    let end = PathEnd::of(scene, &path[k]);
    let p0 = path[0].sp.p;
    let w0 = direction(path, end, 0);
    let (we, raster) = camera.importance(p0, w0)?;
    let cos0 = camera.forward().dot(w0);
    let mut f = Rgb::splat(we * cos0);
    for i in 0..k {
        let (a, b) = (&path[i], &path[i + 1]);
        let last = i + 1 == k;
        let (w, mut g) = if last && end.is_infinite() {
            // A direction: solid angle at x_{k−1}, no area conversion.
            (b.sp.ng, 1.0)
        } else {
            let d = b.sp.p - a.sp.p;
            let d2 = d.length_squared();
            if !(d2 > 0.0) {
                return Some((Rgb::ZERO, raster));
            }
            let w = d / libm::sqrtf(d2);
            // A point light has no surface, a medium vertex neither: no
            // cosine at it.
            let cos = if (last && end.is_delta()) || b.is_medium() {
                1.0
            } else {
                b.sp.ng.dot(w).abs()
            };
            (w, cos / d2)
        };
        if i > 0 {
            let prev = path[i - 1].sp.p;
            let Some(sh) = &a.shading else {
                // A medium vertex: σ_s × phase, no cosine (the media's
                // f(x̄), `media` module docs); the segments' transmittance
                // is the caller's (`media::walk_path`).
                #[cfg(feature = "media")]
                if a.is_medium() {
                    let next = if last && end.is_infinite() {
                        a.sp.p + w
                    } else {
                        b.sp.p
                    };
                    f *= super::media::medium_factor(scene, a, prev, next) * g;
                    continue;
                }
                return Some((Rgb::ZERO, raster));
            };
            let fs = if sh.bsdf.is_delta() {
                // The lobe's weight f·|cos|/p of sampling it, without the
                // Dirac measure; the cosine is in it already.
                let wo = sh.frame.to_local((prev - a.sp.p).normalize());
                let reflect = (prev - a.sp.p).dot(a.sp.ng) * w.dot(a.sp.ng) > 0.0;
                match sh.bsdf.specular(wo, reflect, TransportMode::Radiance) {
                    Some((_, weight)) => weight,
                    None => return Some((Rgb::ZERO, raster)),
                }
            } else {
                g *= sh.sp.ns.dot(w).abs();
                let next = if last && end.is_infinite() {
                    a.sp.p + w
                } else {
                    b.sp.p
                };
                super::scatter(sh, prev, next, TransportMode::Radiance)
            };
            f *= fs;
        }
        f *= g;
    }
    let light = &path[k];
    // Towards x_{k−1} from the light.
    let back = -direction(path, end, k - 1);
    let le = match end {
        PathEnd::Area => scene.emitted(&light.sp, back),
        PathEnd::Point(i) => scene.lights.intensity(i as usize, back),
        PathEnd::Directional(i) => match scene.lights.others().nth(i as usize) {
            Some(&Light::Directional { irradiance, .. }) => irradiance,
            _ => Rgb::ZERO,
        },
        PathEnd::Environment => scene.lights.environment_radiance(light.sp.ng),
    };
    Some((f * le, raster))
}

/// Fills `fwd[i]` and `rev[i]` (i = 0 … k) with the area densities of
/// generating x_i from x_{i−1} and from x_{i+1} (module docs) for the
/// complete path `path` = x₀ … x_k, x_k an emitter of any kind. Both
/// slices must hold at least `path.len()` values.
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
    let end = PathEnd::of(scene, &path[n - 1]);
    let lights_pdf = |l: &Vertex, to: &Vertex| light_emission_pdf(scene, l, to);
    let w0 = direction(path, end, 0);
    let lens = camera.pdf_ray(path[0].sp.p, w0).0;
    fwd[0] = lens;
    rev[0] = lens;
    let lights = &scene.lights;
    rev[n - 1] = match end {
        PathEnd::Area => lights.pdf_area(path[n - 1].sp.surface as usize),
        PathEnd::Point(i) | PathEnd::Directional(i) => lights.pmf_other(i as usize),
        PathEnd::Environment => lights.pdf_environment(path[n - 1].sp.ng),
    };
    // A sliding window of three vertices, so that none is built twice.
    let mut before: Option<Vertex> = None;
    let mut a = vertex(camera, path, end, 0);
    let mut b = vertex(camera, path, end, 1);
    for i in 1..n {
        // fwd[i]: from a = x_{i−1}, reached from x_{i−2}.
        fwd[i] = if is_specular(&a) {
            let from = before.as_ref().map_or(a.sp.p, |v| v.sp.p);
            a.area_density_at(dirac_density(&a, from, b.sp.p, TransportMode::Radiance), &b)
        } else {
            a.pdf(camera, lights_pdf, before.as_ref(), &b)
        };
        // rev[i − 1]: from b = x_i, reached from x_{i+1}.
        let c = (i + 1 < n).then(|| vertex(camera, path, end, i + 1));
        if i > 1 {
            rev[i - 1] = if is_specular(&b) {
                let from = c.as_ref().map_or(b.sp.p, |v| v.sp.p);
                b.area_density_at(
                    dirac_density(&b, from, a.sp.p, TransportMode::Importance),
                    &a,
                )
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
    if end.is_delta() {
        fwd[n - 1] = 0.0;
    }
}

/// Multiplies [`path_densities`]' `fwd` and `rev` by the free-flight
/// densities of each segment, `flights[i]` = (of reaching x_{i+1} from x_i,
/// of reaching x_i from x_{i+1}) (module docs: media; none without).
/// Through a specular vertex too: the walk samples the segment's flight
/// either way, and the Dirac factors alone are symbolic.
pub fn with_flights(fwd: &mut [f32], rev: &mut [f32], flights: &[(f32, f32)]) {
    for (i, &(to_next, to_prev)) in flights.iter().enumerate() {
        fwd[i + 1] *= to_next;
        rev[i] *= to_prev;
    }
}

/// The symbolic solid-angle density with which a walk in `mode` arriving
/// at the specular vertex `v` from `from` leaves it towards `to`, in the
/// Dirac measure f(x̄) takes its lobe in (module docs): BSDF sampling's
/// probability of choosing that lobe (F or 1 − F at a dielectric, 1 at a
/// mirror), times, for the light side's walk, the lobe's weight in
/// radiance over its weight in importance — the Jacobian between the Dirac
/// measures of the two directions, which the adjoint BSDF leaves out
/// (1/η² across a refraction: `bsdf::dielectric`). With these, every
/// strategy's f/p_{s,t} is BDPT's estimate through dielectrics too, and
/// the path-space mutations' densities are those of their walks, which
/// choose lobes by sampling. 0 where the lobe carries nothing.
fn dirac_density(v: &Vertex, from: Vec3, to: Vec3, mode: TransportMode) -> f32 {
    let Some(l) = &v.local else {
        return 0.0;
    };
    let (back, ahead) = (from - v.sp.p, to - v.sp.p);
    // As `path_contribution` tells the lobes apart: by the geometric normal.
    let reflect = back.dot(v.sp.ng) * ahead.dot(v.sp.ng) > 0.0;
    let wo = l.frame.to_local(back.normalize());
    let u_lobe = if reflect { 0.0 } else { 1.0 };
    let Some(s) = l.bsdf.sample(wo, u_lobe, Vec2::ZERO, mode) else {
        return 0.0;
    };
    if ((s.wi.z > 0.0) == (wo.z > 0.0)) != reflect {
        return 0.0;
    }
    match mode {
        TransportMode::Radiance => s.pdf,
        TransportMode::Importance => {
            let radiance = l.bsdf.specular(
                l.frame.to_local(ahead.normalize()),
                reflect,
                TransportMode::Radiance,
            );
            let importance = s.f * s.wi.z.abs();
            match radiance {
                Some((_, w)) if importance.luminance() > 0.0 => {
                    s.pdf * (w.luminance() / importance.luminance())
                }
                _ => 0.0,
            }
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

//! The lens perturbation through media and null boundaries (scenes with
//! media only; a scene without runs none of this, and its side chains are
//! those of [`super::lens`] bit for bit).
//!
//! ## The path's contribution with media
//!
//! Level 1's target is BDPT's (`integrator::bdpt::media`), whose
//! measurement contribution f(x̄) has, besides the surface factors, the
//! transmittance T of every segment (the product of e^{−σ_t ℓ} over the
//! stretches between null boundaries, `Tracer::transmittance`), and at a
//! medium vertex σ_s times the phase function in place of a BSDF, with no
//! cosine in the geometry terms at that end. Volume measure at a medium
//! vertex replaces area measure.
//!
//! ## Which perturbation
//!
//! A medium vertex is a non-specular vertex: it ends a specular chain as a
//! diffuse surface does ([`crate::integrator::bdpt::PathVertex::is_medium`],
//! never [`crate::integrator::bdpt::PathVertex::is_specular`]), so
//! [`super::classify`] finds the same classes. Only the lens perturbation
//! is implemented through media; a caustic or multi-chain path of a scene
//! with media stays at its level-1 state (the identity kernel).
//!
//! ## The free-flight distance is kept
//!
//! When x_t is a medium vertex the perturbation keeps its distance
//! s = |x_t − x_{t−1}| along the last segment of the retraced camera chain
//! (Veach's, and Mitsuba 0.6's, choice): the new x′_t is x′_{t−1} + s ω′,
//! ω′ the retraced direction. The state is then (raster position, s), the
//! proposal moves the raster position by the symmetric clamped Gaussian of
//! [`super::lens::LensProposal`] and leaves s alone: a block update of the
//! raster coordinates given s, which leaves any distribution over
//! (raster, s) invariant when its acceptance uses that distribution's
//! density as a function of the raster position at that s. No density of
//! s enters the ratio (T(x→y) is the same symmetric Gaussian; s is not
//! drawn).
//!
//! That density is f(x̄) times the Jacobian from (raster, s) to the moving
//! vertices' measure. The specular chain maps the raster position to the
//! direction ω′ of its last segment exactly as it does without media, and
//! a point at distance s along ω′ has volume element s² ds dω′; f's
//! geometry term of that segment is |cos at x′_{t−1}| / s² (no cosine at a
//! medium vertex), so s² cancels as d²/cos_t cancels against a surface
//! x_t's geometry term. What is left is the camera-side throughput per unit
//! raster area through the chain (1 for our camera, times the specular
//! lobes) times the transmittance of every segment up to x′_t, σ_s(x′_t),
//! then the connection to the fixed x_{t+1} (phase function at x′_t, the
//! geometry term without the medium ends' cosines, its transmittance) and
//! the fixed rest: a path tracer's estimate of the path with every
//! coordinate density (raster, direction, free-flight distance) set to 1.
//! A candidate whose retraced segment meets a surface before s, or whose
//! point at s lies in vacuum, is no path of the class: zero.
//!
//! The fixed part's colour (the tail, [`super::tail_colour`]) gains the
//! transmittance of the segments from x_{t+1} on and σ_s × phase at its
//! medium vertices; x_{t+1}'s own factor is evaluated with the end.

use glam::{Vec2, Vec3};

use super::{LensAnchor, LensEnd, is_reflection};
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, offset};
use crate::integrator::Tracer;
use crate::integrator::bdpt::{PathVertex, scatter};
use crate::integrator::tracer::{Endpoint, MAX_NULL_CROSSINGS, Shading};
use crate::math::Rgb;
use crate::scene::{MaterialKind, MediumId, Phase, SurfacePoint};

/// What the lens perturbation through media needs beyond [`LensAnchor`]'s
/// surface fields: where the camera's medium starts, the free-flight
/// distance it keeps, and the level-1 path's own factors for its start.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LensMedia {
    /// The medium the camera rays start in.
    pub camera: Option<MediumId>,
    /// |x_t − x_{t−1}| when x_t is a medium vertex (kept by the
    /// perturbation), `None` when it is a surface.
    pub scatter_at: Option<f32>,
    /// The level-1 path's transmittance over its segments x₀ … x_t, times
    /// σ_s(x_t) when x_t is a medium vertex ([`super::LensTarget::evaluate_path`]).
    pub camera_part: Rgb,
    /// The medium the level-1 path's segment x_t → x_{t+1} starts in.
    pub toward_next: Option<MediumId>,
}

/// The medium vertex's medium.
#[inline]
fn medium_of(v: &PathVertex) -> MediumId {
    MediumId(v.sp.prim)
}

/// The normal to offset a segment's start by: none (zero) at the lens and
/// at a medium vertex, the geometric normal on a surface.
#[inline]
fn start_normal(v: &PathVertex, i: usize) -> Vec3 {
    if i == 0 || v.is_medium() {
        Vec3::ZERO
    } else {
        v.sp.ng
    }
}

/// The far end of a segment towards `v`, as the transmittance query wants it.
#[inline]
fn endpoint(v: &PathVertex) -> Endpoint {
    if v.is_medium() {
        Endpoint::Point(v.sp.p)
    } else {
        Endpoint::Surface(v.sp)
    }
}

/// The medium a segment leaving a surface point `sp` along `w` starts in,
/// the point being in `medium` (a surface that names media decides).
#[inline]
fn medium_leaving<I: Intersector>(
    tr: &Tracer<'_, I>,
    sp: &SurfacePoint,
    medium: Option<MediumId>,
    w: Vec3,
) -> Option<MediumId> {
    let iface = tr.scene.surface_media(sp.surface);
    if iface.is_transition() {
        iface.target(sp.ng, w)
    } else {
        medium
    }
}

/// σ_s × phase at medium vertex `v` for light between `a` and `b` (the
/// phase function depends only on the angle, so the order does not matter).
fn medium_factor<I: Intersector>(tr: &Tracer<'_, I>, v: &PathVertex, a: Vec3, b: Vec3) -> Rgb {
    let m = tr.scene.medium(medium_of(v));
    let d = (v.sp.p - a).normalize();
    let wi = (b - v.sp.p).normalize();
    m.sigma_s() * m.phase().eval(d, wi)
}

/// The lens perturbation's media facts of the level-1 path `path` whose
/// first non-specular vertex is x_t, and the colour of its fixed part from
/// x_{t+2} on (`None` when x_t is the emitter): [`super::tail_colour`] with
/// medium vertices' σ_s × phase and the transmittance of the segments
/// x_{t+1} → … → x_k. The media along the path are tracked from the
/// camera's, segment by segment, with the transmittance queries BDPT
/// connects with. `None` when a segment's transmittance is zero (a
/// segment the query finds blocked, by rounding): no perturbation then.
pub(super) fn lens_media<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    path: &[PathVertex],
    t: usize,
) -> Option<(LensMedia, Rgb)> {
    let k = path.len() - 1;
    let camera = tr.scene.camera_medium();
    let mut medium = camera;
    let mut camera_part = Rgb::ONE;
    let mut tail_trans = Rgb::ONE;
    let mut toward_next = None;
    for i in 0..k {
        let (a, b) = (&path[i], &path[i + 1]);
        let start = if i > 0 && !a.is_medium() {
            medium_leaving(tr, &a.sp, medium, b.sp.p - a.sp.p)
        } else {
            medium
        };
        let mut arrival = start;
        let tr_i = tr.transmittance_pieces(
            a.sp.p,
            a.sp.p_error,
            start_normal(a, i),
            endpoint(b),
            start,
            |m, _| arrival = m,
        );
        if tr_i.is_black() || !tr_i.is_finite() {
            return None;
        }
        if i < t {
            camera_part *= tr_i;
        } else if i == t {
            toward_next = start;
        } else {
            tail_trans *= tr_i;
        }
        medium = arrival;
    }
    let x_t = &path[t];
    let scatter_at = if x_t.is_medium() {
        camera_part *= tr.scene.medium(medium_of(x_t)).sigma_s();
        Some((x_t.sp.p - path[t - 1].sp.p).length())
    } else {
        None
    };
    let tail = if t + 1 < k {
        tail_colour(tr, path, t + 2) * tail_trans
    } else {
        Rgb::ONE
    };
    Some((
        LensMedia {
            camera,
            scatter_at,
            camera_part,
            toward_next,
        },
        tail,
    ))
}

/// [`super::tail_colour`] through media: a medium vertex weighs σ_s ×
/// phase (transmittances are the caller's).
fn tail_colour<I: Intersector>(tr: &Tracer<'_, I>, path: &[PathVertex], from: usize) -> Rgb {
    let k = path.len() - 1;
    let light = &path[k];
    let mut c = tr
        .scene
        .emitted(&light.sp, (path[k - 1].sp.p - light.sp.p).normalize());
    for i in (from.max(1)..k).rev() {
        let v = &path[i];
        let (prev, next) = (path[i + 1].sp.p, path[i - 1].sp.p);
        if v.is_medium() {
            c *= medium_factor(tr, v, prev, next);
            continue;
        }
        let Some(sh) = &v.shading else {
            return Rgb::ZERO;
        };
        c *= if sh.bsdf.is_delta() {
            let wo = sh.frame.to_local((prev - v.sp.p).normalize());
            match sh
                .bsdf
                .specular(wo, is_reflection(path, i), TransportMode::Importance)
            {
                Some((_, w)) => w,
                None => return Rgb::ZERO,
            }
        } else {
            scatter(sh, prev, next, TransportMode::Importance)
        };
    }
    c
}

/// The far end x′_t of the camera part: a surface point with its shading,
/// or a point in a medium.
// Built once per candidate on the stack and matched at once; boxing the
// surface variant would allocate.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub(super) enum Here {
    /// A surface vertex, with its shading (`None` for a light point
    /// sampled on an emitter).
    Surface(SurfacePoint, Option<Shading>),
    /// A medium vertex at `.0` in medium `.1`.
    Medium(Vec3, MediumId),
}

impl Here {
    fn p(&self) -> Vec3 {
        match self {
            Here::Surface(sp, _) => sp.p,
            Here::Medium(p, _) => *p,
        }
    }
}

/// The first surface other than a null boundary that a ray from `o` along
/// unit `d` reaches in `medium` (null boundaries crossed as BDPT's walks
/// cross them, the medium tracked), the transmittance up to it and the
/// medium the ray arrives in; `None` when it leaves the scene or crosses
/// too many null boundaries.
fn trace_through<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    mut ray: Ray,
    mut medium: Option<MediumId>,
) -> Option<(Shading, Rgb, Option<MediumId>)> {
    let scene = tr.scene;
    let mut trans = Rgb::ONE;
    for _ in 0..=MAX_NULL_CROSSINGS {
        let h = tr.trace(&ray)?;
        if let Some(m) = medium {
            trans *= scene.medium(m).transmittance((h.sp.p - ray.o).length());
        }
        if !matches!(scene.material(&h.sp).kind, MaterialKind::Null) {
            return Some((h, trans, medium));
        }
        medium = medium_leaving(tr, &h.sp, medium, ray.d);
        let o = offset::offset_ray_origin(h.sp.p, h.sp.p_error, h.sp.ng, ray.d);
        ray = Ray::new(o, ray.d);
    }
    None
}

/// The lens target through media of the path crossing the image at
/// `raster` ([`super::lens::LensTarget`]'s, per lane: the module docs
/// derive it). Zero when the retrace leaves the class.
pub(super) fn lens_value<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    anchor: &LensAnchor,
    media: &LensMedia,
    raster: Vec2,
) -> Rgb {
    let scene = tr.scene;
    let ray = tr.camera.ray_from_lens(raster, anchor.p_lens);
    // The segment's start: point, error bound, normal (zero off surfaces).
    let (mut p, mut p_err, mut ng) = (ray.o, Vec3::ZERO, Vec3::ZERO);
    let mut d = ray.d.normalize();
    let mut medium = media.camera;
    let mut beta = Rgb::ONE;
    for link in 0..anchor.chain.len() {
        let o = offset::offset_ray_origin(p, p_err, ng, d);
        let Some((h, trans, arrival)) = trace_through(tr, Ray::new(o, d), medium) else {
            return Rgb::ZERO;
        };
        tr.stats.bsdf_samples.add(h.bsdf.lobe());
        let Some((wi, w)) = h.bsdf.specular(
            h.frame.to_local(-d),
            anchor.chain.reflects(link),
            TransportMode::Radiance,
        ) else {
            return Rgb::ZERO;
        };
        let wi = h.frame.to_world(wi);
        beta *= trans * w;
        if beta.is_black() || !beta.is_finite() {
            return Rgb::ZERO;
        }
        medium = medium_leaving(tr, &h.sp, arrival, wi);
        (p, p_err, ng, d) = (h.sp.p, h.sp.p_error, h.sp.ng, wi);
    }
    let prev = p;
    let here = match media.scatter_at {
        Some(s) => {
            // x′_t at the kept distance: the query is zero when a surface
            // other than a null boundary comes first; the last stretch's
            // medium is the one x′_t lies in.
            let x = p + d * s;
            let mut at = medium;
            let trans =
                tr.transmittance_pieces(p, p_err, ng, Endpoint::Point(x), medium, |m, _| at = m);
            let Some(id) = at else {
                return Rgb::ZERO;
            };
            beta *= trans * scene.medium(id).sigma_s();
            (Here::Medium(x, id), Some(id))
        }
        None => {
            let o = offset::offset_ray_origin(p, p_err, ng, d);
            let Some((h, trans, arrival)) = trace_through(tr, Ray::new(o, d), medium) else {
                return Rgb::ZERO;
            };
            if h.bsdf.is_delta() {
                return Rgb::ZERO;
            }
            beta *= trans;
            (Here::Surface(h.sp, Some(h)), arrival)
        }
    };
    if beta.is_black() {
        return Rgb::ZERO;
    }
    let (here, around) = here;
    let toward = match (&here, &anchor.end) {
        (Here::Surface(sp, _), LensEnd::Connect { next, .. }) => {
            medium_leaving(tr, sp, around, next.sp.p - sp.p)
        }
        _ => around,
    };
    end_value(tr, &anchor.end, &here, prev, beta, toward)
}

/// The value of a path whose camera part ends at `here`, reached from
/// `prev` with throughput `beta`, completed by `end` through media: as
/// [`super::lens::end_value`], with the phase function and no cosine at a
/// medium end, σ_s at a medium x_{t+1}, and the transmittance of the
/// connection (which also tests its visibility) from `toward`, the medium
/// it starts in.
pub(super) fn end_value<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    end: &LensEnd,
    here: &Here,
    prev: Vec3,
    beta: Rgb,
    toward: Option<MediumId>,
) -> Rgb {
    let scene = tr.scene;
    match end {
        LensEnd::Emitter => match here {
            Here::Surface(sp, _) => beta * scene.emitted(sp, (prev - sp.p).normalize()),
            Here::Medium(..) => Rgb::ZERO,
        },
        LensEnd::Connect { next, after, tail } => {
            let x = here.p();
            let dv = next.sp.p - x;
            let d2 = dv.length_squared();
            if !(d2 > 0.0) {
                return Rgb::ZERO;
            }
            let dn = dv / libm::sqrtf(d2);
            let (f_t, cos_t, (p, p_err, ng)) = match here {
                Here::Surface(_, None) => return Rgb::ZERO,
                Here::Surface(_, Some(h)) => {
                    tr.stats.bsdf_evals.add(h.bsdf.lobe());
                    (
                        scatter(h, prev, next.sp.p, TransportMode::Radiance),
                        h.sp.ns.dot(dn).abs(),
                        (h.sp.p, h.sp.p_error, h.sp.ng),
                    )
                }
                Here::Medium(p, id) => {
                    let phase: Phase = scene.medium(*id).phase();
                    (
                        Rgb::splat(phase.eval((*p - prev).normalize(), dn)),
                        1.0,
                        (*p, Vec3::ZERO, Vec3::ZERO),
                    )
                }
            };
            let (f_next, cos_next) = match (after, &next.shading) {
                (None, _) => (scene.emitted(&next.sp, -dn), next.sp.ng.dot(dn).abs()),
                (Some(after), _) if next.is_medium() => (medium_factor(tr, next, x, *after), 1.0),
                (Some(after), Some(nsh)) => {
                    tr.stats.bsdf_evals.add(nsh.bsdf.lobe());
                    (
                        scatter(nsh, *after, x, TransportMode::Importance),
                        next.sp.ns.dot(dn).abs(),
                    )
                }
                (Some(_), None) => return Rgb::ZERO,
            };
            let v = beta * f_t * f_next * *tail * (cos_t * cos_next / d2);
            if v.is_black() || !v.is_finite() {
                return Rgb::ZERO;
            }
            v * tr.transmittance(p, p_err, ng, endpoint(next), toward)
        }
    }
}

/// [`super::LensTarget::evaluate_path`] through media: the level-1 path's
/// own vertices x₀ … x_t and the factors [`lens_media`] measured along it,
/// completed by the same [`end_value`] as a retrace.
pub(super) fn lens_value_of_path<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    anchor: &LensAnchor,
    media: &LensMedia,
    path: &[PathVertex],
) -> Option<Rgb> {
    let t = anchor.chain.len() + 1;
    let x_t = path.get(t)?;
    let mut beta = media.camera_part;
    for (link, i) in (1..t).enumerate() {
        let sh = path[i].shading.as_ref()?;
        let wo = (path[i - 1].sp.p - path[i].sp.p).normalize();
        let (_, w) = sh.bsdf.specular(
            sh.frame.to_local(wo),
            anchor.chain.reflects(link),
            TransportMode::Radiance,
        )?;
        beta *= w;
    }
    let here = if x_t.is_medium() {
        Here::Medium(x_t.sp.p, medium_of(x_t))
    } else {
        Here::Surface(x_t.sp, x_t.shading)
    };
    Some(end_value(
        tr,
        &anchor.end,
        &here,
        path[t - 1].sp.p,
        beta,
        media.toward_next,
    ))
}

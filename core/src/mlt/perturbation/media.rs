//! Level 2's perturbations through media and null boundaries (scenes with
//! media only; a scene without runs none of this, and its side chains are
//! those of [`super::lens`], [`super::caustic`] and [`super::multi_chain`]
//! bit for bit).
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
//! [`super::classify`] finds the same classes, and each perturbation moves
//! the same coordinates as without media. Null boundaries are crossed
//! without a vertex, switching the medium, as BDPT's walks cross them.
//!
//! ## The free-flight distance is kept
//!
//! When the vertex that ends a retraced chain — x_t for the lens
//! perturbation, x₁ for the caustic one, x_t and x_u for the multi-chain
//! one — is a medium vertex, the perturbation keeps its distance s from
//! its predecessor along the retraced ray (Veach's, and Mitsuba 0.6's,
//! choice): the new vertex is x′ + s ω′, x′ the retraced predecessor and ω′
//! the retraced direction. The state is then (raster position or
//! direction, s), the proposal moves the first coordinates by its
//! symmetric clamped Gaussian and leaves s alone: a block update of those
//! coordinates given s, which leaves any distribution over the state
//! invariant when its acceptance uses that distribution's density as a
//! function of the moved coordinates at that s. No density of s enters the
//! ratio (T(x→y) is the same symmetric Gaussian; s is not drawn).
//!
//! That density is f(x̄) times the Jacobian from the state to the moving
//! vertices' measure. The specular chain maps the raster position (or the
//! direction at x_j) to the direction ω′ of its last segment exactly as it
//! does without media, and a point at distance s along ω′ has volume
//! element s² ds dω′; f's geometry term of that segment is |cos at x′| / s²
//! (no cosine at a medium vertex), so s² cancels as d²/cos cancels against
//! a surface vertex's geometry term. What is left is the perturbation's
//! target without media — a path tracer's (or light tracer's) estimate of
//! the path with every coordinate density (raster, direction, free-flight
//! distance) set to 1 — with the transmittance of every segment, σ_s at
//! each medium vertex and its phase function in place of BSDF × cosine. A
//! candidate whose retraced segment meets a surface before s, or whose
//! point at s lies in vacuum, is no path of the class: zero.
//!
//! The fixed part's colour (the tail, [`super::tail_colour`]) gains the
//! transmittance of its segments and σ_s × phase at its medium vertices,
//! measured once per side chain along the level-1 path
//! ([`super::Applicable::complete_media`]); the fixed vertex joined to the
//! moving end is evaluated with the end.
//!
//! Candidates are traced one lane at a time, not as packets: only scenes
//! with media take this code.

use glam::{Vec2, Vec3};

use super::{CausticAnchor, LensAnchor, LensEnd, MultiChainAnchor, SpecularChain};
use crate::accel::Intersector;
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, offset};
use crate::integrator::Tracer;
use crate::integrator::bdpt::{self, PathVertex, scatter, shading_correction};
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

/// σ_s × phase at medium vertex `v` for light between `a` and `b`
/// ([`bdpt::media::medium_factor`]).
#[inline]
pub(super) fn medium_factor<I: Intersector>(
    tr: &Tracer<'_, I>,
    v: &PathVertex,
    a: Vec3,
    b: Vec3,
) -> Rgb {
    bdpt::media::medium_factor(tr.scene, v, a, b)
}

/// Walks the level-1 path's segments x_i → x_{i+1} from the camera's
/// medium, handing each to `seg(i, transmittance)`, and returns the medium
/// each vertex lies in through `around(i, medium)` (the one its incoming
/// segment arrives in): [`bdpt::media::walk_path`], which tracks media as
/// BDPT's walks track them with the transmittance queries BDPT connects
/// with. False when a segment's transmittance is zero (found blocked, by
/// rounding): no perturbation then.
pub(super) fn walk_media<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    path: &[PathVertex],
    mut seg: impl FnMut(usize, Rgb),
    around: impl FnMut(usize, Option<MediumId>),
) -> bool {
    bdpt::media::walk_path(tr, path, |i, t, _| seg(i, t), around)
}

/// The free-flight distance a perturbation keeps at `path[i]` (from
/// `path[from]`, its predecessor in tracing order) when it is a medium
/// vertex.
fn kept_distance(path: &[PathVertex], i: usize, from: usize) -> Option<f32> {
    path[i]
        .is_medium()
        .then(|| (path[i].sp.p - path[from].sp.p).length())
}

/// The colour of the fixed part of `path` from x_{from} on through media:
/// [`super::tail_colour`] times `trans`, the transmittance of its segments; 1
/// when `from` is past the emitter (nothing fixed beyond the end).
fn fixed_tail<I: Intersector>(
    tr: &Tracer<'_, I>,
    path: &[PathVertex],
    from: usize,
    trans: Rgb,
) -> Rgb {
    if from < path.len() {
        super::tail_colour(tr, path, from) * trans
    } else {
        Rgb::ONE
    }
}

/// The lens perturbation's media facts of the level-1 path `path` whose
/// first non-specular vertex is x_t, and the colour of its fixed part from
/// x_{t+2} on (1 when there is none): [`super::tail_colour`] with medium vertices'
/// σ_s × phase, times the transmittance of the segments x_{t+1} → … → x_k.
/// `None` when [`walk_media`] fails.
pub(super) fn lens_media<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    path: &[PathVertex],
    t: usize,
) -> Option<(LensMedia, Rgb)> {
    let (mut camera_part, mut tail, mut toward_next) = (Rgb::ONE, Rgb::ONE, None);
    let mut at_t = None;
    let camera = tr.scene.camera_medium();
    let ok = walk_media(
        tr,
        path,
        |i, tr_i| {
            if i < t {
                camera_part *= tr_i;
            } else if i > t {
                tail *= tr_i;
            }
        },
        |i, m| {
            if i == t {
                at_t = m;
            }
        },
    );
    if !ok {
        return None;
    }
    let x_t = &path[t];
    if x_t.is_medium() {
        camera_part *= tr.scene.medium(medium_of(x_t)).sigma_s();
        toward_next = at_t;
    } else if t + 1 < path.len() {
        toward_next = medium_leaving(tr, &x_t.sp, at_t, path[t + 1].sp.p - x_t.sp.p);
    }
    Some((
        LensMedia {
            camera,
            scatter_at: kept_distance(path, t, t - 1),
            camera_part,
            toward_next,
        },
        fixed_tail(tr, path, t + 2, tail),
    ))
}

/// What the caustic perturbation through media needs beyond
/// [`CausticAnchor`]'s surface fields.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CausticMedia {
    /// The medium x_j lies in (the rays leaving it start there unless its
    /// surface names media).
    pub origin: Option<MediumId>,
    /// |x₁ − x₂| when x₁ is a medium vertex (kept by the perturbation).
    pub scatter_at: Option<f32>,
}

/// The caustic perturbation's media facts of `path` (x_j the far end of
/// its chain) and the colour of its fixed part from x_{j+1} on, with the
/// transmittance of the segments x_j → … → x_k.
pub(super) fn caustic_media<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    path: &[PathVertex],
    j: usize,
) -> Option<(CausticMedia, Rgb)> {
    let (mut tail, mut origin) = (Rgb::ONE, None);
    let ok = walk_media(
        tr,
        path,
        |i, tr_i| {
            if i >= j {
                tail *= tr_i;
            }
        },
        |i, m| {
            if i == j {
                origin = m;
            }
        },
    );
    ok.then(|| {
        (
            CausticMedia {
                origin,
                scatter_at: kept_distance(path, 1, 2),
            },
            fixed_tail(tr, path, j + 1, tail),
        )
    })
}

/// What the multi-chain perturbation through media needs beyond
/// [`MultiChainAnchor`]'s surface fields.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MultiChainMedia {
    /// The medium the camera rays start in.
    pub camera: Option<MediumId>,
    /// |x_t − x_{t−1}| when x_t is a medium vertex.
    pub scatter_t: Option<f32>,
    /// |x_u − x_{u−1}| when x_u is a medium vertex.
    pub scatter_u: Option<f32>,
}

/// The multi-chain perturbation's media facts of `path` (x_t, x_u the ends
/// of its two chains) and the colour of its fixed part from x_{u+2} on,
/// with the transmittance of the segments x_{u+1} → … → x_k.
pub(super) fn multi_chain_media<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    path: &[PathVertex],
    t: usize,
    u: usize,
) -> Option<(MultiChainMedia, Rgb)> {
    let mut tail = Rgb::ONE;
    let camera = tr.scene.camera_medium();
    let ok = walk_media(
        tr,
        path,
        |i, tr_i| {
            if i > u {
                tail *= tr_i;
            }
        },
        |_, _| {},
    );
    ok.then(|| {
        (
            MultiChainMedia {
                camera,
                scatter_t: kept_distance(path, t, t - 1),
                scatter_u: kept_distance(path, u, u - 1),
            },
            fixed_tail(tr, path, u + 2, tail),
        )
    })
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

/// Where a retrace through media ends ([`retrace`]).
struct Reached {
    /// x′: a surface point or a point in a medium.
    here: Here,
    /// The vertex before it (for its incoming direction).
    prev: Vec3,
    /// Specular lobes crossed, the transmittance of every segment and σ_s
    /// at a medium end.
    beta: Rgb,
    /// The medium x′ lies in (or a surface x′ was reached through).
    around: Option<MediumId>,
}

/// Retraces one ray from the start point (`p`, error bound `p_err`,
/// normal `ng`, zero off surfaces) along unit `d` in `medium` through the
/// specular `chain` (each link the recorded lobe, in transport `mode`, null
/// boundaries crossed), to its end: the point at distance `scatter_at`
/// along the last segment (a medium vertex, which must lie in a medium
/// and before any surface) or the next non-specular surface. `None` when
/// the ray leaves the class.
/// `visit` sees each specular vertex the retrace passes, in order (the
/// path-space perturbations build their proposals' vertices from them).
#[allow(clippy::too_many_arguments)]
fn retrace<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    (mut p, mut p_err, mut ng): (Vec3, Vec3, Vec3),
    mut d: Vec3,
    mut medium: Option<MediumId>,
    chain: &SpecularChain,
    mode: TransportMode,
    scatter_at: Option<f32>,
    mut visit: impl FnMut(&Shading),
) -> Option<Reached> {
    let scene = tr.scene;
    let mut beta = Rgb::ONE;
    for link in 0..chain.len() {
        let o = offset::offset_ray_origin(p, p_err, ng, d);
        let (h, trans, arrival) = trace_through(tr, Ray::new(o, d), medium)?;
        tr.stats.bsdf_samples.add(h.bsdf.lobe());
        let (wi, w) = h
            .bsdf
            .specular(h.frame.to_local(-d), chain.reflects(link), mode)?;
        let wi = h.frame.to_world(wi);
        let mut w = w;
        if mode == TransportMode::Importance {
            w *= shading_correction(&h.sp, -d, wi);
        }
        beta *= trans * w;
        if beta.is_black() || !beta.is_finite() {
            return None;
        }
        visit(&h);
        medium = medium_leaving(tr, &h.sp, arrival, wi);
        (p, p_err, ng, d) = (h.sp.p, h.sp.p_error, h.sp.ng, wi);
    }
    let prev = p;
    match scatter_at {
        Some(s) => {
            // x′ at the kept distance: the query is zero when a surface
            // other than a null boundary comes first; the last stretch's
            // medium is the one x′ lies in.
            let x = p + d * s;
            let mut at = medium;
            let trans =
                tr.transmittance_pieces(p, p_err, ng, Endpoint::Point(x), medium, |m, _| at = m);
            let id = at?;
            beta *= trans * scene.medium(id).sigma_s();
            (!beta.is_black()).then_some(Reached {
                here: Here::Medium(x, id),
                prev,
                beta,
                around: Some(id),
            })
        }
        None => {
            let o = offset::offset_ray_origin(p, p_err, ng, d);
            let (h, trans, arrival) = trace_through(tr, Ray::new(o, d), medium)?;
            if h.bsdf.is_delta() {
                return None;
            }
            beta *= trans;
            (!beta.is_black()).then_some(Reached {
                here: Here::Surface(h.sp, Some(h)),
                prev,
                beta,
                around: arrival,
            })
        }
    }
}

/// The medium the connection from `here` (in `around`) towards `to`
/// starts in.
fn medium_towards<I: Intersector>(
    tr: &Tracer<'_, I>,
    here: &Here,
    around: Option<MediumId>,
    to: Vec3,
) -> Option<MediumId> {
    match here {
        Here::Surface(sp, _) => medium_leaving(tr, sp, around, to - sp.p),
        Here::Medium(..) => around,
    }
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
    let ray = tr.camera.ray_from_lens(raster, anchor.p_lens);
    let Some(r) = retrace(
        tr,
        (ray.o, Vec3::ZERO, Vec3::ZERO),
        ray.d.normalize(),
        media.camera,
        &anchor.chain,
        TransportMode::Radiance,
        media.scatter_at,
        |_| {},
    ) else {
        return Rgb::ZERO;
    };
    let toward = match &anchor.end {
        LensEnd::Connect { next, .. } => medium_towards(tr, &r.here, r.around, next.sp.p),
        LensEnd::Emitter => r.around,
    };
    end_value(tr, &anchor.end, &r.here, r.prev, r.beta, toward)
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

/// The caustic target through media for the direction `dir` leaving x_j
/// ([`super::caustic::CausticTarget`]'s, per lane): x_j's factor per unit
/// solid angle (σ_s × phase at a medium vertex, no cosine), the retrace
/// through the chain towards the camera (x′₁ at the kept distance when it
/// is a medium vertex, with its σ_s), and BDPT's t = 1 lens connection with
/// its transmittance. With the value, where it lands on the image; `None`
/// when the retrace leaves the class or the camera cannot see x′₁.
pub(super) fn caustic_value<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    a: &CausticAnchor,
    media: &CausticMedia,
    dir: Vec3,
) -> Option<(Rgb, Vec2)> {
    let scene = tr.scene;
    let o = &a.origin;
    let f = if o.is_medium() {
        // A medium vertex is never the emitter: `before` is set.
        medium_factor(tr, o, a.before?, o.sp.p + dir)
    } else {
        match (&a.before, &o.shading) {
            (None, _) => scene.emitted(&o.sp, dir) * o.sp.ng.dot(dir).abs(),
            (Some(before), Some(sh)) => {
                tr.stats.bsdf_evals.add(sh.bsdf.lobe());
                scatter(sh, *before, o.sp.p + dir, TransportMode::Importance)
                    * o.sp.ns.dot(dir).abs()
            }
            (Some(_), None) => return None,
        }
    };
    let (start, medium) = caustic_start(tr, a, media, dir);
    if f.is_black() || !f.is_finite() {
        return None;
    }
    let r = retrace(
        tr,
        start,
        dir,
        medium,
        &a.chain,
        TransportMode::Importance,
        media.scatter_at,
        |_| {},
    )?;
    let x = r.here.p();
    let conn = tr.camera.connect_at(x, a.p_lens)?;
    let to_cam = conn.p_lens - x;
    let d2 = to_cam.length_squared();
    let w = to_cam / libm::sqrtf(d2);
    let (f1, cos1, (p, p_err, ng)) = match &r.here {
        Here::Surface(_, Some(h)) => {
            tr.stats.bsdf_evals.add(h.bsdf.lobe());
            (
                scatter(h, r.prev, conn.p_lens, TransportMode::Importance),
                h.sp.ns.dot(w).abs(),
                (h.sp.p, h.sp.p_error, h.sp.ng),
            )
        }
        Here::Surface(_, None) => return None,
        Here::Medium(p, id) => (
            Rgb::splat(scene.medium(*id).phase().eval((*p - r.prev).normalize(), w)),
            1.0,
            (*p, Vec3::ZERO, Vec3::ZERO),
        ),
    };
    let v =
        f * a.tail * r.beta * f1 * (cos1 * conn.we * conn.cos_theta / (d2 * conn.pdf_lens_area));
    if v.is_black() || !v.is_finite() {
        return None;
    }
    let toward = medium_towards(tr, &r.here, r.around, conn.p_lens);
    let trans = tr.transmittance(p, p_err, ng, Endpoint::Point(conn.p_lens), toward);
    Some((v * trans, conn.raster))
}

/// The multi-chain target through media at raster position `raster` and
/// direction `dir` leaving x′_t ([`super::multi_chain::MultiChainTarget`]'s,
/// per lane): the camera chain to x′_t (at its kept distance when a medium
/// vertex), x′_t's factor per unit solid angle of `dir` (phase function
/// at a medium vertex, no cosine), the second chain to x′_u (likewise) and
/// the lens perturbation's end value from there.
pub(super) fn multi_chain_value<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    a: &MultiChainAnchor,
    media: &MultiChainMedia,
    raster: Vec2,
    dir: Vec3,
) -> Rgb {
    let scene = tr.scene;
    let ray = tr.camera.ray_from_lens(raster, a.p_lens);
    let Some(r1) = retrace(
        tr,
        (ray.o, Vec3::ZERO, Vec3::ZERO),
        ray.d.normalize(),
        media.camera,
        &a.first,
        TransportMode::Radiance,
        media.scatter_t,
        |_| {},
    ) else {
        return Rgb::ZERO;
    };
    let f = match &r1.here {
        Here::Surface(_, Some(h)) => {
            tr.stats.bsdf_evals.add(h.bsdf.lobe());
            scatter(h, r1.prev, h.sp.p + dir, TransportMode::Radiance) * h.sp.ns.dot(dir).abs()
        }
        Here::Surface(_, None) => return Rgb::ZERO,
        Here::Medium(p, id) => Rgb::splat(
            scene
                .medium(*id)
                .phase()
                .eval((*p - r1.prev).normalize(), dir),
        ),
    };
    let Some((start, medium)) = chain_start(tr, &r1.here, r1.around, dir) else {
        return Rgb::ZERO;
    };
    let beta = r1.beta * f;
    if beta.is_black() || !beta.is_finite() {
        return Rgb::ZERO;
    }
    let Some(r2) = retrace(
        tr,
        start,
        dir,
        medium,
        &a.second,
        TransportMode::Radiance,
        media.scatter_u,
        |_| {},
    ) else {
        return Rgb::ZERO;
    };
    let toward = match &a.end {
        LensEnd::Connect { next, .. } => medium_towards(tr, &r2.here, r2.around, next.sp.p),
        LensEnd::Emitter => r2.around,
    };
    end_value(tr, &a.end, &r2.here, r2.prev, beta * r2.beta, toward)
}

/// Where a retrace from the caustic perturbation's origin x_j along `dir`
/// starts: the point with its error bound and normal (zero off surfaces),
/// and the medium the ray leaves in.
fn caustic_start<I: Intersector>(
    tr: &Tracer<'_, I>,
    a: &CausticAnchor,
    media: &CausticMedia,
    dir: Vec3,
) -> ((Vec3, Vec3, Vec3), Option<MediumId>) {
    let o = &a.origin;
    if o.is_medium() {
        ((o.sp.p, Vec3::ZERO, Vec3::ZERO), media.origin)
    } else {
        (
            (o.sp.p, o.sp.p_error, o.sp.ng),
            medium_leaving(tr, &o.sp, media.origin, dir),
        )
    }
}

/// Where the multi-chain perturbation's second retrace starts from the
/// first one's end `here` (reached in `around`) along `dir`, as
/// [`caustic_start`]; `None` at a light point.
fn chain_start<I: Intersector>(
    tr: &Tracer<'_, I>,
    here: &Here,
    around: Option<MediumId>,
    dir: Vec3,
) -> Option<((Vec3, Vec3, Vec3), Option<MediumId>)> {
    match here {
        Here::Surface(_, Some(h)) => Some((
            (h.sp.p, h.sp.p_error, h.sp.ng),
            medium_leaving(tr, &h.sp, around, dir),
        )),
        Here::Surface(_, None) => None,
        Here::Medium(p, id) => Some(((*p, Vec3::ZERO, Vec3::ZERO), Some(*id))),
    }
}

/// The path vertex of a retrace's end; `None` at a light point.
fn end_vertex<I: Intersector>(tr: &Tracer<'_, I>, here: &Here) -> Option<PathVertex> {
    match here {
        Here::Surface(_, Some(h)) => Some(specular_vertex(h)),
        Here::Surface(_, None) => None,
        Here::Medium(p, id) => Some(bdpt::media::medium_path_vertex(tr.scene, *p, *id)),
    }
}

/// The path vertex of a surface hit.
fn specular_vertex(h: &Shading) -> PathVertex {
    PathVertex {
        sp: h.sp,
        shading: Some(*h),
        mixed_delta: false,
    }
}

/// [`retrace`] that pushes the vertices it reaches onto `out`: each
/// specular one, then the end (`None` at a light point). Returns the end.
#[allow(clippy::too_many_arguments)]
fn retrace_vertices<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    start: (Vec3, Vec3, Vec3),
    d: Vec3,
    medium: Option<MediumId>,
    chain: &SpecularChain,
    mode: TransportMode,
    scatter_at: Option<f32>,
    out: &mut alloc::vec::Vec<PathVertex>,
) -> Option<Reached> {
    let r = retrace(tr, start, d, medium, chain, mode, scatter_at, |h| {
        out.push(specular_vertex(h))
    })?;
    out.push(end_vertex(tr, &r.here)?);
    Some(r)
}

/// The moving vertices of the path-space lens perturbation's proposal at
/// `raster` through media (`mlt::path_space::perturbations`): the ones
/// [`lens_value`] retraces, x′₁ … x′_t, pushed onto `out`, x′_t at the
/// kept distance when it is a medium vertex. `None` when the retrace
/// leaves the class.
pub(crate) fn lens_vertices<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    anchor: &LensAnchor,
    media: &LensMedia,
    raster: Vec2,
    out: &mut alloc::vec::Vec<PathVertex>,
) -> Option<()> {
    let ray = tr.camera.ray_from_lens(raster, anchor.p_lens);
    let start = (ray.o, Vec3::ZERO, Vec3::ZERO);
    let (chain, mode) = (&anchor.chain, TransportMode::Radiance);
    retrace_vertices(
        tr,
        start,
        ray.d.normalize(),
        media.camera,
        chain,
        mode,
        media.scatter_at,
        out,
    )?;
    Some(())
}

/// The caustic perturbation's moving vertices along `dir` through media,
/// as [`caustic_value`] retraces them: x′_{j−1} … x′₁ in tracing order
/// (from x_j towards the camera), pushed onto `out`.
pub(crate) fn caustic_vertices<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    a: &CausticAnchor,
    media: &CausticMedia,
    dir: Vec3,
    out: &mut alloc::vec::Vec<PathVertex>,
) -> Option<()> {
    let (start, medium) = caustic_start(tr, a, media, dir);
    let mode = TransportMode::Importance;
    retrace_vertices(
        tr,
        start,
        dir,
        medium,
        &a.chain,
        mode,
        media.scatter_at,
        out,
    )?;
    Some(())
}

/// The multi-chain perturbation's moving vertices at `raster` and `dir`
/// through media, as [`multi_chain_value`] retraces them: x′₁ … x′_u
/// pushed onto `out`.
pub(crate) fn multi_chain_vertices<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    a: &MultiChainAnchor,
    media: &MultiChainMedia,
    raster: Vec2,
    dir: Vec3,
    out: &mut alloc::vec::Vec<PathVertex>,
) -> Option<()> {
    let ray = tr.camera.ray_from_lens(raster, a.p_lens);
    let start = (ray.o, Vec3::ZERO, Vec3::ZERO);
    let mode = TransportMode::Radiance;
    let r1 = retrace_vertices(
        tr,
        start,
        ray.d.normalize(),
        media.camera,
        &a.first,
        mode,
        media.scatter_t,
        out,
    )?;
    let (start, medium) = chain_start(tr, &r1.here, r1.around, dir)?;
    retrace_vertices(
        tr,
        start,
        dir,
        medium,
        &a.second,
        mode,
        media.scatter_u,
        out,
    )?;
    Some(())
}

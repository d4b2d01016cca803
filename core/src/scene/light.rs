//! Emitters and their sampling.
//!
//! Every emissive mesh is one area light. Lights that are not meshes —
//! Mitsuba 3's `point`, `spot`, `directional`, `constant` and `envmap`
//! emitters —
//! are [`Light`]s added to the scene by the host. All of them share one
//! power distribution: a light is chosen with probability proportional to
//! its power (luminance, since p(x̄) is luminance):
//! - an area light Φ = π · A · Y(Le); then a triangle in proportion to its
//!   area, then a uniform point on it, so the density is uniform in area
//!   measure over each light: p_A = P(light) / A(light). Zero-area
//!   triangles are never chosen;
//! - a point light 4π · Y(I); a spot 2π · Y(I) · (1 − (sin α − sin β)/(α −
//!   β)), the exact integral of Mitsuba's linear falloff in angle from the
//!   beam width β to the cutoff α;
//! - infinite lights use the scene's bounding sphere of radius r, as
//!   pbrt-v4 does: a directional light π r² · Y(E), a constant environment
//!   π r² · 4π · Y(L), an environment map π r² · ∫ Y(L) dω (its mean
//!   radiance weighted by solid angle, [`EnvMap::luminance_integral`]), a
//!   sun disc π r² · Y(L) · Ω with Ω = 2π (1 − cos α) its solid angle.
//!
//! Area lights come first in the distribution, so a scene of area lights
//! only chooses exactly as it always did.

use alloc::vec::Vec;

use glam::{Mat3, Vec2, Vec3};

use super::effects::Effect;
use super::envmap::{EnvMap, is_orthonormal};
use super::scene::Mesh;
use super::texture::{Bitmap, BitmapId};
use crate::math::{Frame, PI, Rgb, warp};

/// A light that is not an emissive mesh, with Mitsuba 3's semantics.
// The sun's profile (288 bytes) is held inline: lights are built once per
// scene and read by reference, and inline keeps `Light` `Copy` and the
// core free of allocation.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Mitsuba's `point`: radiant intensity `intensity` (W/sr) in every
    /// direction from `position`.
    Point {
        /// Position.
        position: Vec3,
        /// Radiant intensity (W/sr).
        intensity: Rgb,
    },
    /// Mitsuba's `spot`: intensity `intensity` inside a cone around
    /// `direction` (the `to_world` image of +z), full up to `beam_width`
    /// degrees off the axis, falling linearly in angle to zero at
    /// `cutoff_angle` degrees (Mitsuba's defaults: 20° and 3/4 of it).
    Spot {
        /// Apex of the cone.
        position: Vec3,
        /// Axis of the cone (any length but zero).
        direction: Vec3,
        /// Radiant intensity on the axis (W/sr).
        intensity: Rgb,
        /// Half-angle of the cone in degrees, in (0, 180].
        cutoff_angle: f32,
        /// Half-angle of the full-intensity beam in degrees, in
        /// [0, `cutoff_angle`].
        beam_width: f32,
    },
    /// Mitsuba's `directional`: a sun at infinity, irradiance `irradiance`
    /// (W/m²) on a surface facing it, light travelling along `direction`.
    Directional {
        /// Direction the light travels in (any length but zero).
        direction: Vec3,
        /// Irradiance on a surface perpendicular to `direction`.
        irradiance: Rgb,
    },
    /// Mitsuba's `constant`: radiance `radiance` arriving from every
    /// direction at infinity.
    Constant {
        /// Radiance.
        radiance: Rgb,
    },
    /// Mitsuba's `envmap`: radiance from a latitude-longitude image at
    /// infinity (see [`super::envmap`] for the mapping).
    Envmap {
        /// The image (linear RGB, finite, non-negative), among the scene's
        /// bitmaps.
        bitmap: BitmapId,
        /// Factor on the image's radiance.
        scale: f32,
        /// Emitter-to-world rotation (Mitsuba's `to_world` without its
        /// translation, which does not move a light at infinity).
        to_world: Mat3,
    },
    /// The sun of Mitsuba 3's `sunsky`: a disc of radiance `radiance` at
    /// infinity (uniform, or times `profile` where one is given), every
    /// direction within `half_aperture` degrees of the one it shines
    /// from, light travelling along `direction`. Rays can hit it (it is an
    /// environment, unlike [`Light::Directional`]), and it is sampled
    /// uniformly in solid angle over its cone whatever its profile. The
    /// sky around it is a separate [`Light::Envmap`].
    Sun {
        /// Direction the light travels in (any length but zero): the
        /// sun's centre is seen along −`direction`.
        direction: Vec3,
        /// Radiance of the disc; with a `profile`, the disc's mean
        /// radiance (the light's power, which sets how often it is
        /// chosen, takes it so).
        radiance: Rgb,
        /// Angular radius of the disc in degrees, in (0, 90).
        half_aperture: f32,
        /// Relative radiance across the disc (limb darkening and a
        /// gradient in elevation, Mitsuba's `complex_sun`), or `None` for
        /// a uniform disc.
        profile: Option<SunProfile>,
    },
}

/// Degree + 1 of a [`SunProfile`] in the elevation offset `s`.
pub const SUN_PROFILE_S: usize = 4;
/// Degree + 1 of a [`SunProfile`] in μ = cos ψ.
pub const SUN_PROFILE_MU: usize = 6;

/// A radiance profile across the sun's disc, after Hosek & Wilkie 2013
/// ("Adding a Solar-Radiance Function to the Hosek–Wilkie Skylight
/// Model") as Mitsuba 3's `complex_sun` evaluates it: per channel c the
/// factor on the light's `radiance` seen along a direction w in the disc is
///
/// P_c(w) = max(0, Σ_k Σ_j `coeffs[c][k][j]` · s^k · μ^j),
///
/// with s = (e(w) − e(centre)) / α the elevation offset (e the elevation
/// above the plane normal to `up`, α the disc's angular radius; s ∈ [−1, 1]
/// across the disc) and μ = cos ψ = √(1 − sin²γ / sin²α) the limb
/// parameter (γ the angle from the disc's centre: 1 at the centre, 0 on
/// the rim). Directions below that plane (e(w) < 0) see nothing, as in
/// Mitsuba, whose sun is clipped by the horizon. A profile whose mean over
/// the disc is 1 keeps the light's power right.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunProfile {
    /// The zenith (any length but zero) elevations are measured from.
    pub up: Vec3,
    /// Polynomial coefficients, `coeffs[channel][k][j]` on s^k μ^j.
    pub coeffs: [[[f32; SUN_PROFILE_MU]; SUN_PROFILE_S]; 3],
}

fn valid_rgb(c: Rgb) -> bool {
    c.is_finite() && c.r >= 0.0 && c.g >= 0.0 && c.b >= 0.0
}

fn valid_dir(d: Vec3) -> bool {
    d.is_finite() && d.length_squared() > 0.0 && d.length_squared().is_finite()
}

impl Light {
    /// A spot light with Mitsuba's default angles (cutoff 20°, beam width
    /// 15°).
    pub fn spot(position: Vec3, direction: Vec3, intensity: Rgb) -> Light {
        Light::Spot {
            position,
            direction,
            intensity,
            cutoff_angle: 20.0,
            beam_width: 15.0,
        }
    }

    /// Checks the parameters: finite non-negative powers, finite
    /// positions, non-zero finite directions, angles in range. The error
    /// says what is wrong.
    pub fn validate(&self) -> Result<(), &'static str> {
        match *self {
            Light::Point {
                position,
                intensity,
            } => {
                if !position.is_finite() {
                    return Err("point light: position must be finite");
                }
                if !valid_rgb(intensity) {
                    return Err("point light: intensity must be finite and non-negative");
                }
            }
            Light::Spot {
                position,
                direction,
                intensity,
                cutoff_angle,
                beam_width,
            } => {
                if !position.is_finite() {
                    return Err("spot light: position must be finite");
                }
                if !valid_dir(direction) {
                    return Err("spot light: direction must be finite and non-zero");
                }
                if !valid_rgb(intensity) {
                    return Err("spot light: intensity must be finite and non-negative");
                }
                if !(cutoff_angle > 0.0 && cutoff_angle <= 180.0) {
                    return Err("spot light: cutoff_angle must be in (0, 180] degrees");
                }
                if !(beam_width >= 0.0 && beam_width <= cutoff_angle) {
                    return Err("spot light: beam_width must be in [0, cutoff_angle] degrees");
                }
            }
            Light::Directional {
                direction,
                irradiance,
            } => {
                if !valid_dir(direction) {
                    return Err("directional light: direction must be finite and non-zero");
                }
                if !valid_rgb(irradiance) {
                    return Err("directional light: irradiance must be finite and non-negative");
                }
            }
            Light::Constant { radiance } => {
                if !valid_rgb(radiance) {
                    return Err("constant environment: radiance must be finite and non-negative");
                }
            }
            Light::Sun {
                direction,
                radiance,
                half_aperture,
                profile,
            } => {
                if !valid_dir(direction) {
                    return Err("sun: direction must be finite and non-zero");
                }
                if !valid_rgb(radiance) {
                    return Err("sun: radiance must be finite and non-negative");
                }
                if !(half_aperture > 0.0 && half_aperture < 90.0) {
                    return Err("sun: half_aperture must be in (0, 90) degrees");
                }
                if let Some(p) = profile {
                    if !valid_dir(p.up) {
                        return Err("sun: the profile's up must be finite and non-zero");
                    }
                    if !p.coeffs.iter().flatten().flatten().all(|c| c.is_finite()) {
                        return Err("sun: the profile's coefficients must be finite");
                    }
                }
            }
            Light::Envmap {
                scale, to_world, ..
            } => {
                if !(scale.is_finite() && scale >= 0.0) {
                    return Err("environment map: scale must be finite and non-negative");
                }
                if !is_orthonormal(to_world) {
                    return Err(
                        "environment map: to_world must be finite and a rotation (orthonormal, no scaling or shear)",
                    );
                }
            }
        }
        Ok(())
    }

    /// True for lights at a single point or from a single direction
    /// (point, spot, directional): no ray can hit them, only next-event
    /// estimation reaches them.
    pub fn is_delta(&self) -> bool {
        !self.is_environment()
    }

    /// True for environments: non-delta lights at infinity (constant,
    /// environment map, sun disc), which rays escaping the scene see.
    pub fn is_environment(&self) -> bool {
        matches!(
            self,
            Light::Constant { .. } | Light::Envmap { .. } | Light::Sun { .. }
        )
    }

    /// True for lights at infinity (directional, constant).
    pub fn is_infinite(&self) -> bool {
        matches!(self, Light::Directional { .. }) || self.is_environment()
    }

    /// The effect the light calls for.
    pub fn effect(&self) -> Effect {
        match self {
            Light::Constant { .. } | Light::Envmap { .. } | Light::Sun { .. } => {
                Effect::Environment
            }
            _ => Effect::PointLights,
        }
    }
}

/// A [`Light`] with what sampling it needs precomputed.
#[derive(Clone, Copy, Debug)]
struct Prepared {
    light: Light,
    /// Frame around the unit spot axis or the unit direction towards a
    /// directional light.
    frame: Frame,
    /// cos of the spot's cutoff angle.
    cos_cutoff: f32,
    /// cos of the spot's beam width.
    cos_beam: f32,
    /// The spot's cutoff angle in radians.
    cutoff: f32,
    /// 1 / (cutoff − beam width) in radians (Mitsuba's transition slope).
    inv_transition: f32,
    /// An environment map's index in [`LightSet::envmaps`].
    env: u32,
    /// The sun's 1 − cos α and 2 (1 − cos α), the squared chord between
    /// its centre and its rim on the unit sphere (f64-accurate: at α ≈
    /// 0.27°, 1 − cos α ≈ 1.1e-5 is far below f32's resolution of cos α
    /// near 1).
    sun_one_minus_cos: f32,
    sun_chord2: f32,
    /// For a sun with a [`SunProfile`]: its unit `up`, the centre's
    /// sin and cos of elevation (c · up and |c × up|), 1/α (α in
    /// radians) and 1 / sin² α.
    sun_up: Vec3,
    sun_sin_e0: f32,
    sun_cos_e0: f32,
    sun_inv_alpha: f32,
    sun_inv_sin2_alpha: f32,
}

impl Prepared {
    fn new(light: Light) -> Self {
        let mut p = Prepared {
            light,
            frame: Frame::from_normal(Vec3::Z),
            cos_cutoff: -1.0,
            cos_beam: -1.0,
            cutoff: PI,
            inv_transition: 0.0,
            env: u32::MAX,
            sun_one_minus_cos: 0.0,
            sun_chord2: 0.0,
            sun_up: Vec3::Z,
            sun_sin_e0: 0.0,
            sun_cos_e0: 0.0,
            sun_inv_alpha: 0.0,
            sun_inv_sin2_alpha: 0.0,
        };
        match light {
            Light::Spot {
                direction,
                cutoff_angle,
                beam_width,
                ..
            } => {
                p.frame = Frame::from_normal(direction.normalize());
                p.cutoff = cutoff_angle.to_radians();
                let beam = beam_width.to_radians();
                p.cos_cutoff = libm::cosf(p.cutoff);
                p.cos_beam = libm::cosf(beam);
                p.inv_transition = 1.0 / (p.cutoff - beam);
            }
            Light::Directional { direction, .. } => {
                p.frame = Frame::from_normal(-direction.normalize());
            }
            Light::Sun {
                direction,
                half_aperture,
                profile,
                ..
            } => {
                p.frame = Frame::from_normal(-direction.normalize());
                // 1 − cos α = 2 sin²(α/2), exact for small α.
                let alpha = (half_aperture as f64).to_radians();
                let s = libm::sin(alpha * 0.5);
                p.sun_one_minus_cos = (2.0 * s * s) as f32;
                p.sun_chord2 = (4.0 * s * s) as f32;
                if let Some(profile) = profile {
                    p.sun_up = profile.up.normalize();
                    p.sun_sin_e0 = p.frame.n.dot(p.sun_up);
                    p.sun_cos_e0 = p.frame.n.cross(p.sun_up).length();
                    p.sun_inv_alpha = (1.0 / alpha) as f32;
                    p.sun_inv_sin2_alpha = (1.0 / (libm::sin(alpha) * libm::sin(alpha))) as f32;
                }
            }
            _ => {}
        }
        p
    }

    /// Solid angle of the sun's disc, 2π (1 − cos α).
    fn sun_solid_angle(&self) -> f32 {
        2.0 * PI * self.sun_one_minus_cos
    }

    /// True when the unit direction `w` (towards the light) lies in the
    /// sun's disc: by the squared chord |w − c|² ≤ 2 (1 − cos α), which,
    /// unlike w · c ≥ cos α, keeps its precision for a disc a fraction of
    /// a degree wide.
    fn in_sun(&self, w: Vec3) -> bool {
        (w - self.frame.n).length_squared() <= self.sun_chord2
    }

    /// The sun's radiance along the unit direction `w` (towards it): zero
    /// outside the disc, `radiance` on a uniform disc, times the
    /// profile's factor on one with a [`SunProfile`].
    fn sun_radiance(&self, w: Vec3) -> Rgb {
        let Light::Sun {
            radiance,
            ref profile,
            ..
        } = self.light
        else {
            return Rgb::ZERO;
        };
        if !self.in_sun(w) {
            return Rgb::ZERO;
        }
        match profile {
            None => radiance,
            Some(p) => radiance * self.sun_profile(p, w),
        }
    }

    /// [`SunProfile`]'s factor along the unit direction `w` in the disc.
    fn sun_profile(&self, p: &SunProfile, w: Vec3) -> Rgb {
        let sin_e = w.dot(self.sun_up);
        if sin_e < 0.0 {
            // Below the horizon: Mitsuba's sun is clipped there.
            return Rgb::ZERO;
        }
        // Elevation offset from the centre's: sin(e − e0) = sin e cos e0 −
        // cos e sin e0, the cosines as cross-product lengths, so that it
        // keeps its precision for a disc a fraction of a degree wide and
        // for a sun at the zenith (where it is −sin γ).
        let cos_e = w.cross(self.sun_up).length();
        let sin_de = sin_e * self.sun_cos_e0 - cos_e * self.sun_sin_e0;
        let s = libm::asinf(sin_de.clamp(-1.0, 1.0)) * self.sun_inv_alpha;
        // μ = cos ψ = √(1 − sin²γ / sin²α), sin γ = |w × c|.
        let sin2_gamma = w.cross(self.frame.n).length_squared();
        let mu = crate::math::safe_sqrt(1.0 - sin2_gamma * self.sun_inv_sin2_alpha);
        let channel = |c: usize| {
            // Horner in s over Horner in μ.
            let mut v = 0.0f32;
            for row in p.coeffs[c].iter().rev() {
                let mut r = 0.0f32;
                for &a in row.iter().rev() {
                    r = r * mu + a;
                }
                v = v * s + r;
            }
            v.max(0.0)
        };
        Rgb::new(channel(0), channel(1), channel(2))
    }

    /// Luminance power, with the infinite lights' through a disk of radius
    /// `radius` (pbrt-v4's `Phi`).
    fn power(&self, radius: f32) -> f64 {
        let disk = PI as f64 * radius as f64 * radius as f64;
        match self.light {
            Light::Point { intensity, .. } => 4.0 * PI as f64 * intensity.luminance() as f64,
            Light::Spot {
                intensity,
                cutoff_angle,
                beam_width,
                ..
            } => {
                let (a, b) = (
                    (cutoff_angle as f64).to_radians(),
                    (beam_width as f64).to_radians(),
                );
                // ∫ falloff dω = 2π (1 − (sin α − sin β)/(α − β)); the limit
                // β → α is a hard cone, 2π (1 − cos α).
                let cone = if a - b > 1e-6 {
                    1.0 - (libm::sin(a) - libm::sin(b)) / (a - b)
                } else {
                    1.0 - libm::cos(a)
                };
                2.0 * PI as f64 * intensity.luminance() as f64 * cone
            }
            Light::Directional { irradiance, .. } => disk * irradiance.luminance() as f64,
            Light::Constant { radiance } => disk * 4.0 * PI as f64 * radiance.luminance() as f64,
            Light::Sun { radiance, .. } => {
                disk * self.sun_solid_angle() as f64 * radiance.luminance() as f64
            }
            // Needs the map: LightSet::with_bitmaps computes it.
            Light::Envmap { .. } => 0.0,
        }
    }

    /// Mitsuba's spot falloff times the intensity towards unit `w`; the
    /// plain intensity of a point light.
    fn intensity(&self, w: Vec3) -> Rgb {
        match self.light {
            Light::Point { intensity, .. } => intensity,
            Light::Spot { intensity, .. } => {
                let cos = w.dot(self.frame.n);
                if cos <= self.cos_cutoff {
                    Rgb::ZERO
                } else if cos >= self.cos_beam {
                    intensity
                } else {
                    let theta = libm::acosf(cos.min(1.0));
                    intensity * ((self.cutoff - theta) * self.inv_transition).clamp(0.0, 1.0)
                }
            }
            _ => Rgb::ZERO,
        }
    }

    /// A direction towards the sun, uniform in solid angle over its disc:
    /// 1 − cos θ = u.x (1 − cos α) (the cone's cos θ is uniform), sin θ =
    /// √(h (2 − h)) from h = 1 − cos θ so that it stays accurate for a
    /// fraction of a degree.
    fn sample_sun(&self, u: Vec2) -> Vec3 {
        let h = u.x * self.sun_one_minus_cos;
        let sin = crate::math::safe_sqrt(h * (2.0 - h));
        let phi = 2.0 * PI * u.y;
        let local = Vec3::new(sin * libm::cosf(phi), sin * libm::sinf(phi), 1.0 - h);
        self.frame.to_world(local).normalize()
    }

    /// Solid-angle density of the direction `w` (unit) a point or spot
    /// light emits its sampled ray along.
    fn pdf_emit_dir(&self, w: Vec3) -> f32 {
        match self.light {
            Light::Point { .. } => 1.0 / (4.0 * PI),
            Light::Spot { .. } if w.dot(self.frame.n) > self.cos_cutoff => {
                1.0 / (2.0 * PI * (1.0 - self.cos_cutoff))
            }
            _ => 0.0,
        }
    }
}

/// Where a light selection landed: a point on an area light, or one of
/// the other lights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Chosen {
    /// A point on an emissive mesh.
    Area(LightPointSample),
    /// Light `index` of [`LightSet::others`], chosen with probability
    /// `pmf`.
    Other {
        /// Index into [`LightSet::others`].
        index: usize,
        /// Selection probability.
        pmf: f32,
    },
}

/// Light arriving at a point from one non-area light
/// ([`LightSet::sample_incident`]): the estimate of its reflection is
/// f · `li` · |cos| / (`pdf` · selection probability).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Incident {
    /// Unit direction from the receiving point towards the light.
    pub wi: Vec3,
    /// The light's position; `None` at infinity.
    pub position: Option<Vec3>,
    /// Radiance arriving along `wi` (a point light's I / d²).
    pub li: Rgb,
    /// Solid-angle density of `wi`; 1 for a delta light, whose sample is a
    /// certain outcome.
    pub pdf: f32,
    /// A point, spot or directional light.
    pub delta: bool,
}

/// A ray leaving a non-area light (pbrt-v4's `SampleLe`), to start a light
/// subpath from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emission {
    /// Ray origin: the light's position, or a point on a disk outside the
    /// scene's bounding sphere for infinite lights.
    pub origin: Vec3,
    /// Unit direction the light travels in.
    pub dir: Vec3,
    /// Intensity (point, spot), irradiance (directional) or radiance
    /// (environment) carried along `dir`.
    pub le: Rgb,
    /// Density of `origin`: 1 for a point light (a certain position),
    /// 1/(π r²) on the disk of an infinite light.
    pub pdf_pos: f32,
    /// Solid-angle density of `dir`; 1 for a directional light.
    pub pdf_dir: f32,
}

/// One emissive mesh.
#[derive(Clone, Debug)]
pub struct AreaLight {
    /// Mesh index in the scene.
    pub mesh: u32,
    /// Total surface area.
    pub area: f32,
    /// Cumulative triangle areas normalised to end at 1.
    tri_cdf: Vec<f32>,
}

/// All lights of a scene and the power distribution over them.
#[derive(Clone, Debug, Default)]
pub struct LightSet {
    lights: Vec<AreaLight>,
    /// Lights that are not meshes, after the area lights in `cdf`/`pmf`.
    others: Vec<Prepared>,
    /// Cumulative selection probabilities, ending at 1.
    cdf: Vec<f32>,
    /// Selection probability of each light.
    pmf: Vec<f32>,
    /// Light index of each mesh, or `u32::MAX` for non-emissive meshes.
    mesh_light: Vec<u32>,
    /// Indices into `others` of the environment (non-delta infinite)
    /// lights: those a ray escaping the scene sees.
    environment: Vec<u32>,
    /// The environment maps' tables (`Prepared::env` indexes them).
    envmaps: Vec<EnvMap>,
    /// Centre of the scene's bounding sphere.
    center: Vec3,
    /// Radius of the scene's bounding sphere (positive).
    radius: f32,
}

/// Where a light sample landed, before any geometry is evaluated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightPointSample {
    /// Mesh-local triangle index.
    pub triangle: usize,
    /// Mesh index.
    pub mesh: usize,
    /// Barycentrics of vertices 1 and 2.
    pub b: Vec2,
    /// Density per unit area, selection included.
    pub pdf_area: f32,
}

/// The area of triangle `t` of `m` (0 when not finite), in f64 as the
/// light distributions sum it.
fn triangle_area(m: &Mesh, t: &[u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| m.positions[i as usize]);
    let area = 0.5 * (b - a).cross(c - a).length() as f64;
    if area.is_finite() { area } else { 0.0 }
}

/// The total area of `m`, summed in triangle order.
fn mesh_area(m: &Mesh) -> f64 {
    m.indices.iter().map(|t| triangle_area(m, t)).sum()
}

/// Centre and radius of the meshes' bounding sphere when some light is
/// infinite (its power and sampling need them), else the unit sphere.
fn bounding_sphere<'a>(
    meshes: &[Mesh],
    mut others: impl Iterator<Item = &'a Light>,
) -> (Vec3, f32) {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    if others.any(Light::is_infinite) {
        for p in meshes.iter().flat_map(|m| m.positions.iter()) {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
    }
    if lo.x <= hi.x {
        ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(1e-3))
    } else {
        (Vec3::ZERO, 1.0)
    }
}

/// The power of a light that is not a mesh inside a bounding sphere of
/// `radius`, as [`LightSet::with_bitmaps`] weighs it.
fn other_power(envmaps: &[EnvMap], p: &Prepared, radius: f32) -> f64 {
    match p.light {
        Light::Envmap { .. } => {
            PI as f64 * radius as f64 * radius as f64 * envmaps[p.env as usize].luminance_integral()
        }
        _ => p.power(radius),
    }
}

/// Binary search of a cumulative distribution ending at 1: the first index
/// whose cumulative value exceeds `u`, skipping zero-probability entries.
fn sample_cdf(cdf: &[f32], u: f32) -> usize {
    let i = cdf.partition_point(|&c| c <= u);
    i.min(cdf.len() - 1)
}

impl LightSet {
    /// Builds the light set of the emissive meshes among `meshes` and the
    /// lights `others` (validated by the caller), with infinite lights
    /// around the bounding sphere of the meshes. Environment maps need
    /// their images: see [`LightSet::with_bitmaps`]; here they emit
    /// nothing.
    pub fn new(meshes: &[Mesh], others: &[Light]) -> Self {
        Self::with_bitmaps(meshes, others, &[])
    }

    /// [`LightSet::new`] with the scene's `bitmaps`, which environment maps
    /// name (validated by the caller: ids in range, texels finite and
    /// non-negative). Builds each map's sampling tables once.
    pub fn with_bitmaps(meshes: &[Mesh], others: &[Light], bitmaps: &[Bitmap]) -> Self {
        let (center, radius) = bounding_sphere(meshes, others.iter());
        let mut set = LightSet {
            mesh_light: alloc::vec![u32::MAX; meshes.len()],
            center,
            radius,
            ..Default::default()
        };
        let mut power = Vec::new();
        for (mi, m) in meshes.iter().enumerate() {
            let Some(le) = m.emission else { continue };
            let mut acc = 0.0f64;
            let mut cdf = Vec::with_capacity(m.indices.len());
            for t in &m.indices {
                acc += triangle_area(m, t);
                cdf.push(acc);
            }
            let phi = PI as f64 * acc * le.luminance() as f64;
            if !(acc > 0.0 && phi > 0.0) {
                continue;
            }
            set.mesh_light[mi] = set.lights.len() as u32;
            set.lights.push(AreaLight {
                mesh: mi as u32,
                area: acc as f32,
                tri_cdf: cdf.iter().map(|c| (c / acc) as f32).collect(),
            });
            power.push(phi);
        }
        for l in others {
            let mut p = Prepared::new(*l);
            let mut phi = p.power(radius);
            if let Light::Envmap {
                bitmap,
                scale,
                to_world,
            } = *l
            {
                // A black map, or one whose image is missing, emits nothing.
                let Some(env) = bitmaps
                    .get(bitmap.0 as usize)
                    .and_then(|b| EnvMap::new(b, scale, to_world))
                else {
                    continue;
                };
                phi = PI as f64 * radius as f64 * radius as f64 * env.luminance_integral();
                p.env = set.envmaps.len() as u32;
                set.envmaps.push(env);
            }
            // A light that emits nothing is left out, as black meshes are.
            if !(phi > 0.0 && phi.is_finite()) {
                continue;
            }
            if l.is_environment() {
                set.environment.push(set.others.len() as u32);
            }
            set.others.push(p);
            power.push(phi);
        }
        let total: f64 = power.iter().sum();
        let mut acc = 0.0;
        for p in &power {
            acc += p;
            set.pmf.push((p / total) as f32);
            set.cdf.push((acc / total) as f32);
        }
        if let Some(last) = set.cdf.last_mut() {
            *last = 1.0;
        }
        for l in &mut set.lights {
            if let Some(last) = l.tri_cdf.last_mut() {
                *last = 1.0;
            }
        }
        set
    }

    /// Brings the set up to date after the positions of mesh `changed`
    /// moved (topology, emission and the other lights as at
    /// [`LightSet::with_bitmaps`]), in place and without allocating: that
    /// mesh's triangle distribution, the scene's bounding sphere, every
    /// light's power and the selection distribution, to the bit what a
    /// rebuild computes. Returns false and changes nothing when the lights
    /// that emit would change (an emitter's area became or stopped being
    /// zero, an infinite light's power stopped being finite): only a
    /// rebuild handles that.
    pub fn refresh(&mut self, meshes: &[Mesh], changed: usize) -> bool {
        // Which lights emit must stay as it is (the lists keep their size).
        for (mi, m) in meshes.iter().enumerate() {
            let Some(le) = m.emission else { continue };
            let acc = mesh_area(m);
            let emits = acc > 0.0 && PI as f64 * acc * le.luminance() as f64 > 0.0;
            if emits != (self.mesh_light.get(mi).is_some_and(|&l| l != u32::MAX)) {
                return false;
            }
        }
        let (center, radius) = bounding_sphere(meshes, self.others.iter().map(|p| &p.light));
        if self.others.iter().any(|p| {
            let phi = other_power(&self.envmaps, p, radius);
            !(phi > 0.0 && phi.is_finite())
        }) {
            return false;
        }
        self.center = center;
        self.radius = radius;
        // The moved emitter's triangle distribution, as `with_bitmaps`
        // normalises it.
        if let Some(&li) = self.mesh_light.get(changed)
            && li != u32::MAX
        {
            let m = &meshes[changed];
            let acc = mesh_area(m);
            let light = &mut self.lights[li as usize];
            light.area = acc as f32;
            let mut run = 0.0f64;
            for (c, t) in light.tri_cdf.iter_mut().zip(&m.indices) {
                run += triangle_area(m, t);
                *c = (run / acc) as f32;
            }
            if let Some(last) = light.tri_cdf.last_mut() {
                *last = 1.0;
            }
        }
        // Selection by power: area lights in mesh order, then the others.
        let power = |i: usize| -> f64 {
            match self.lights.get(i) {
                Some(l) => {
                    let m = &meshes[l.mesh as usize];
                    let le = m.emission.unwrap_or_default();
                    PI as f64 * mesh_area(m) * le.luminance() as f64
                }
                None => other_power(&self.envmaps, &self.others[i - self.lights.len()], radius),
            }
        };
        let n = self.pmf.len();
        let total: f64 = (0..n).map(power).sum();
        let mut acc = 0.0;
        for i in 0..n {
            let p = power(i);
            acc += p;
            self.pmf[i] = (p / total) as f32;
            self.cdf[i] = (acc / total) as f32;
        }
        if let Some(last) = self.cdf.last_mut() {
            *last = 1.0;
        }
        true
    }

    /// Number of lights that can be sampled (area lights and others).
    pub fn len(&self) -> usize {
        self.lights.len() + self.others.len()
    }

    /// True when nothing emits: every estimate of such a scene is black.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The area lights.
    pub fn lights(&self) -> &[AreaLight] {
        &self.lights
    }

    /// The lights that are not meshes, in [`Chosen::Other`]'s numbering.
    pub fn others(&self) -> impl ExactSizeIterator<Item = &Light> {
        self.others.iter().map(|p| &p.light)
    }

    /// True when some light is not an area light: only then do the
    /// estimators run any code of the other kinds.
    #[inline]
    pub fn has_others(&self) -> bool {
        !self.others.is_empty()
    }

    /// True when an environment (a non-delta light at infinity) surrounds
    /// the scene: only then do escaping rays carry radiance.
    #[inline]
    pub fn has_environment(&self) -> bool {
        !self.environment.is_empty()
    }

    /// Centre and radius of the scene's bounding sphere, through which
    /// infinite lights emit their light subpaths.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        (self.center, self.radius)
    }

    /// Whether other light `index` is a point, spot or directional light.
    #[inline]
    pub fn is_delta(&self, index: usize) -> bool {
        self.others[index].light.is_delta()
    }

    /// Whether other light `index` lies at infinity.
    #[inline]
    pub fn is_infinite(&self, index: usize) -> bool {
        self.others[index].light.is_infinite()
    }

    /// Chooses a light by power; for an area light also a uniform point on
    /// it. `u_select` picks the light and then, rescaled, the triangle; `u`
    /// places the point.
    #[inline]
    pub fn choose(&self, u_select: f32, u: Vec2) -> Option<Chosen> {
        if self.cdf.is_empty() {
            return None;
        }
        let li = sample_cdf(&self.cdf, u_select);
        let pmf = self.pmf[li];
        if li >= self.lights.len() {
            return Some(Chosen::Other {
                index: li - self.lights.len(),
                pmf,
            });
        }
        let lo = if li == 0 { 0.0 } else { self.cdf[li - 1] };
        // Reuse the leftover of u_select for the triangle choice.
        let u_tri = if pmf > 0.0 {
            ((u_select - lo) / pmf).clamp(0.0, 1.0 - f32::EPSILON)
        } else {
            0.0
        };
        let light = &self.lights[li];
        let ti = sample_cdf(&light.tri_cdf, u_tri);
        Some(Chosen::Area(LightPointSample {
            triangle: ti,
            mesh: light.mesh as usize,
            b: warp::square_to_uniform_triangle(u),
            pdf_area: pmf / light.area,
        }))
    }

    /// Samples a light by power and a uniform point on it; `None` when the
    /// chosen light is not an area light (see [`LightSet::choose`]).
    pub fn sample(&self, u_select: f32, u: Vec2) -> Option<LightPointSample> {
        match self.choose(u_select, u)? {
            Chosen::Area(s) => Some(s),
            Chosen::Other { .. } => None,
        }
    }

    /// Density per unit area with which [`LightSet::sample`] picks a point
    /// on surface `surface` (a `SurfacePoint::surface`: zero for
    /// non-emissive meshes and for host shapes, which never emit).
    #[inline]
    pub fn pdf_area(&self, surface: usize) -> f32 {
        match self.mesh_light.get(surface) {
            Some(&li) if li != u32::MAX => self.pmf[li as usize] / self.lights[li as usize].area,
            _ => 0.0,
        }
    }

    /// Selection probability of other light `index`.
    #[inline]
    pub fn pmf_other(&self, index: usize) -> f32 {
        self.pmf[self.lights.len() + index]
    }

    /// Samples the light arriving at `p` from other light `index` (`u`
    /// places a direction on an environment). `None` when nothing arrives
    /// (outside a spot's cone, `p` at a point light).
    pub fn sample_incident(&self, index: usize, p: Vec3, u: Vec2) -> Option<Incident> {
        let l = &self.others[index];
        match l.light {
            Light::Point { position, .. } | Light::Spot { position, .. } => {
                let to = position - p;
                let d2 = to.length_squared();
                if !(d2 > 0.0) {
                    return None;
                }
                let wi = to / libm::sqrtf(d2);
                let li = l.intensity(-wi) * (1.0 / d2);
                if li.is_black() {
                    return None;
                }
                Some(Incident {
                    wi,
                    position: Some(position),
                    li,
                    pdf: 1.0,
                    delta: true,
                })
            }
            Light::Directional { irradiance, .. } => Some(Incident {
                wi: l.frame.n,
                position: None,
                li: irradiance,
                pdf: 1.0,
                delta: true,
            }),
            Light::Constant { radiance } => {
                let wi = warp::square_to_uniform_sphere(u);
                Some(Incident {
                    wi,
                    position: None,
                    li: radiance,
                    pdf: 1.0 / (4.0 * PI),
                    delta: false,
                })
            }
            Light::Sun { .. } => {
                let wi = l.sample_sun(u);
                let pdf = self.pdf_incident(index, wi);
                let li = l.sun_radiance(wi);
                if li.is_black() || !(pdf > 0.0) {
                    return None;
                }
                Some(Incident {
                    wi,
                    position: None,
                    li,
                    pdf,
                    delta: false,
                })
            }
            Light::Envmap { .. } => {
                let env = &self.envmaps[l.env as usize];
                let (wi, pdf) = env.sample(u);
                let li = env.eval(wi);
                if li.is_black() || !(pdf > 0.0) {
                    return None;
                }
                Some(Incident {
                    wi,
                    position: None,
                    li,
                    pdf,
                    delta: false,
                })
            }
        }
    }

    /// Solid-angle density with which [`LightSet::sample_incident`] of
    /// environment light `index` picks the unit direction `wi` (towards
    /// the light); zero for delta lights.
    #[inline]
    pub fn pdf_incident(&self, index: usize, wi: Vec3) -> f32 {
        let l = &self.others[index];
        match l.light {
            Light::Constant { .. } => 1.0 / (4.0 * PI),
            Light::Envmap { .. } => self.envmaps[l.env as usize].pdf(wi),
            Light::Sun { .. } if l.in_sun(wi) => 1.0 / l.sun_solid_angle(),
            _ => 0.0,
        }
    }

    /// Radiance of environment light `index` arriving from unit direction
    /// `wi` (towards the light); zero for delta lights.
    #[inline]
    pub fn radiance(&self, index: usize, wi: Vec3) -> Rgb {
        let l = &self.others[index];
        match l.light {
            Light::Constant { radiance } => radiance,
            Light::Envmap { .. } => self.envmaps[l.env as usize].eval(wi),
            Light::Sun { .. } => l.sun_radiance(wi),
            _ => Rgb::ZERO,
        }
    }

    /// The environment lights' indices (see [`LightSet::has_environment`]).
    #[inline]
    pub fn environment(&self) -> impl Iterator<Item = usize> + '_ {
        self.environment.iter().map(|&i| i as usize)
    }

    /// Total radiance of the environment from unit direction `wi`.
    pub fn environment_radiance(&self, wi: Vec3) -> Rgb {
        let mut l = Rgb::ZERO;
        for i in self.environment() {
            l += self.radiance(i, wi);
        }
        l
    }

    /// Solid-angle density with which light selection and
    /// [`LightSet::sample_incident`] together pick direction `wi` on the
    /// environment (pbrt-v4's `InfiniteLightDensity`).
    pub fn pdf_environment(&self, wi: Vec3) -> f32 {
        let mut pdf = 0.0;
        for i in self.environment() {
            pdf += self.pmf_other(i) * self.pdf_incident(i, wi);
        }
        pdf
    }

    /// Samples a ray leaving other light `index` (pbrt-v4's `SampleLe`):
    /// `u_pos` places the origin on an infinite light's disk, `u_dir` the
    /// direction.
    pub fn sample_emission(&self, index: usize, u_pos: Vec2, u_dir: Vec2) -> Option<Emission> {
        let l = &self.others[index];
        let (origin, dir, pdf_pos, pdf_dir) = match l.light {
            Light::Point { position, .. } => (
                position,
                warp::square_to_uniform_sphere(u_dir),
                1.0,
                1.0 / (4.0 * PI),
            ),
            Light::Spot { position, .. } => {
                // Uniform in the cone of the cutoff angle, as Mitsuba.
                let cos = 1.0 - u_dir.x * (1.0 - l.cos_cutoff);
                let sin = crate::math::safe_sqrt(1.0 - cos * cos);
                let phi = 2.0 * PI * u_dir.y;
                let local = Vec3::new(sin * libm::cosf(phi), sin * libm::sinf(phi), cos);
                (
                    position,
                    l.frame.to_world(local),
                    1.0,
                    l.pdf_emit_dir(l.frame.n),
                )
            }
            Light::Directional { .. }
            | Light::Constant { .. }
            | Light::Envmap { .. }
            | Light::Sun { .. } => {
                let (wi, pdf_dir) = match l.light {
                    Light::Directional { .. } => (l.frame.n, 1.0),
                    Light::Envmap { .. } => self.envmaps[l.env as usize].sample(u_dir),
                    Light::Sun { .. } => {
                        let wi = l.sample_sun(u_dir);
                        (wi, self.pdf_incident(index, wi))
                    }
                    _ => (warp::square_to_uniform_sphere(u_dir), 1.0 / (4.0 * PI)),
                };
                let origin = self.disk_origin(wi, u_pos);
                (origin, -wi, 1.0 / (PI * self.radius * self.radius), pdf_dir)
            }
        };
        let le = match l.light {
            Light::Point { .. } | Light::Spot { .. } => l.intensity(dir),
            Light::Directional { irradiance, .. } => irradiance,
            Light::Constant { radiance } => radiance,
            Light::Envmap { .. } => self.envmaps[l.env as usize].eval(-dir),
            Light::Sun { .. } => self.radiance(index, -dir),
        };
        if le.is_black() || !(pdf_dir > 0.0) {
            return None;
        }
        Some(Emission {
            origin,
            dir,
            le,
            pdf_pos,
            pdf_dir,
        })
    }

    /// The origin, placed by `u`, of a ray an infinite light sends along
    /// −`wi` (`wi` the unit direction towards the light): uniform, density
    /// [`LightSet::pdf_disk`], on a disk of the bounding sphere's radius
    /// facing `wi`, pushed out of the sphere, so that every ray through
    /// the scene crosses it.
    pub fn disk_origin(&self, wi: Vec3, u: Vec2) -> Vec3 {
        let f = Frame::from_normal(wi);
        let d = warp::square_to_uniform_disk_concentric(u);
        self.center + (f.s * d.x + f.t * d.y + wi) * self.radius
    }

    /// Intensity of point or spot light `index` along unit `w` (away from
    /// the light).
    #[inline]
    pub fn intensity(&self, index: usize, w: Vec3) -> Rgb {
        self.others[index].intensity(w)
    }

    /// Solid-angle density of a point or spot light `index` emitting its
    /// sampled ray along unit `w`.
    #[inline]
    pub fn pdf_emit_dir(&self, index: usize, w: Vec3) -> f32 {
        self.others[index].pdf_emit_dir(w)
    }

    /// Density per unit area perpendicular to the direction of an infinite
    /// light's emitted ray: uniform on its disk, 1/(π r²) (pbrt-v4's
    /// `PdfLight` for infinite lights).
    #[inline]
    pub fn pdf_disk(&self) -> f32 {
        1.0 / (PI * self.radius * self.radius)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(y: f32, scale: f32, emission: Option<Rgb>) -> Mesh {
        Mesh {
            positions: [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .map(|(x, z)| Vec3::new(x * scale, y, z * scale * 0.5))
                .to_vec(),
            normals: Vec::new(),
            uvs: Vec::new(),
            indices: alloc::vec![[0, 1, 2], [0, 2, 3]],
            material: super::super::MaterialId(0),
            emission,
        }
    }

    /// Refreshing after a move gives, field for field, the light set a
    /// rebuild gives (area, triangle and selection distributions, bounding
    /// sphere), and refuses when an emitter's area becomes zero.
    #[test]
    fn refresh_after_a_move_equals_a_rebuild() {
        let others = [
            Light::Constant {
                radiance: Rgb::splat(0.5),
            },
            spot(30.0, 20.0),
        ];
        let mut meshes = alloc::vec![
            quad(0.0, 2.0, None),
            quad(1.0, 0.3, Some(Rgb::splat(5.0))),
            quad(0.5, 0.2, Some(Rgb::new(1.0, 2.0, 3.0))),
        ];
        let mut set = LightSet::new(&meshes, &others);
        let before = alloc::format!("{set:?}");
        for (mesh, scale, y) in [(1, 0.7, 1.5), (0, 3.0, -0.2), (2, 0.1, 0.4)] {
            meshes[mesh] = quad(y, scale, meshes[mesh].emission);
            assert!(set.refresh(&meshes, mesh));
            let rebuilt = LightSet::new(&meshes, &others);
            assert_eq!(alloc::format!("{set:?}"), alloc::format!("{rebuilt:?}"));
        }
        assert_ne!(alloc::format!("{set:?}"), before);
        let kept = alloc::format!("{set:?}");
        meshes[1] = quad(1.0, 0.0, meshes[1].emission);
        assert!(!set.refresh(&meshes, 1), "an emitter lost its area");
        assert_eq!(
            alloc::format!("{set:?}"),
            kept,
            "a refused refresh changed the set"
        );
    }

    fn spot(cutoff: f32, beam: f32) -> Light {
        Light::Spot {
            position: Vec3::ZERO,
            direction: Vec3::new(0.3, -0.5, 0.8),
            intensity: Rgb::splat(2.0),
            cutoff_angle: cutoff,
            beam_width: beam,
        }
    }

    /// The spot's power formula is the integral of its falloff over the
    /// sphere (midpoint rule in θ), and its emission samples stay in the
    /// cone with the density [`Prepared::pdf_emit_dir`] states (which
    /// integrates to 1 over the sphere).
    #[test]
    fn spot_power_and_emission_density() {
        for (cutoff, beam) in [(20.0, 15.0), (45.0, 10.0), (60.0, 60.0)] {
            let p = Prepared::new(spot(cutoff, beam));
            let n = 200_000;
            let mut integral = 0.0f64;
            let mut pdf_integral = 0.0f64;
            for i in 0..n {
                let theta = (i as f64 + 0.5) / n as f64 * core::f64::consts::PI;
                let w = p.frame.to_world(Vec3::new(
                    libm::sin(theta) as f32,
                    0.0,
                    libm::cos(theta) as f32,
                ));
                let dw = 2.0 * core::f64::consts::PI * libm::sin(theta) * core::f64::consts::PI
                    / n as f64;
                integral += p.intensity(w).luminance() as f64 * dw;
                pdf_integral += p.pdf_emit_dir(w) as f64 * dw;
            }
            let phi = p.power(1.0);
            assert!(
                (integral - phi).abs() < 2e-3 * phi,
                "{cutoff}/{beam}: {integral} vs {phi}"
            );
            assert!((pdf_integral - 1.0).abs() < 2e-3, "{pdf_integral}");
        }
        let set = LightSet::new(&[], &[spot(30.0, 20.0)]);
        let cos_cutoff = libm::cosf(30f32.to_radians());
        for i in 0..64 {
            let u = Vec2::new((i % 8) as f32 / 8.0 + 0.06, (i / 8) as f32 / 8.0 + 0.01);
            let e = set.sample_emission(0, u, Vec2::new(u.y, u.x)).unwrap();
            let axis = Vec3::new(0.3, -0.5, 0.8).normalize();
            assert!(e.dir.dot(axis) >= cos_cutoff - 1e-5);
            assert_eq!(e.pdf_dir, set.pdf_emit_dir(0, e.dir));
        }
    }

    /// Lights are chosen in proportion to their power, area lights first;
    /// an infinite light's power uses the bounding sphere.
    #[test]
    fn selection_follows_power() {
        let point = Light::Point {
            position: Vec3::ZERO,
            intensity: Rgb::splat(1.0),
        };
        let env = Light::Constant {
            radiance: Rgb::splat(1.0),
        };
        let black = Light::Point {
            position: Vec3::ZERO,
            intensity: Rgb::ZERO,
        };
        let set = LightSet::new(&[], &[point, black, env]);
        // No geometry: radius 1, so Φ_env = π · 4π and Φ_point = 4π.
        assert_eq!(set.len(), 2, "a black light is left out");
        let want = 1.0 / (1.0 + PI);
        assert!((set.pmf_other(0) - want).abs() < 1e-6);
        assert!((set.pmf_other(1) - (1.0 - want)).abs() < 1e-6);
        assert!(set.has_environment() && set.is_delta(0) && !set.is_delta(1));
        match set.choose(0.5 * want, Vec2::ZERO) {
            Some(Chosen::Other { index: 0, pmf }) => assert_eq!(pmf, set.pmf_other(0)),
            other => panic!("{other:?}"),
        }
        match set.choose(0.99, Vec2::ZERO) {
            Some(Chosen::Other { index: 1, .. }) => {}
            other => panic!("{other:?}"),
        }
        // pdf_environment is the selection times the uniform sphere.
        let pdf = set.pdf_environment(Vec3::Z);
        assert!((pdf - (1.0 - want) / (4.0 * PI)).abs() < 1e-7);
    }

    /// The sun disc at its real size (α = 0.2679°): the directions its
    /// sampler draws lie in the disc and report the density `pdf_incident`
    /// gives, that density integrates to one over the disc (a fine grid on
    /// the tangent plane, so the disc's rim as `in_sun` draws it must hold
    /// the solid angle 2π (1 − cos α) the density assumes: a rim test in
    /// f32 cosines would be off by percents), nothing is seen or sampled
    /// outside it, and its power is π r² · Y(L) · Ω.
    #[test]
    fn sun_disc_sampling_and_density() {
        let alpha = 0.2679f32;
        let dir = Vec3::new(-0.3, -0.8, 0.2);
        let radiance = Rgb::new(3.0e4, 2.5e4, 2.0e4);
        let set = LightSet::new(
            &[],
            &[Light::Sun {
                direction: dir,
                radiance,
                half_aperture: alpha,
                profile: None,
            }],
        );
        assert!(set.has_environment());
        let omega = 2.0 * core::f64::consts::PI * (1.0 - libm::cos((alpha as f64).to_radians()));
        let centre = -dir.normalize();
        let cos_alpha = libm::cos((alpha as f64).to_radians());
        for k in 0..500 {
            let u = Vec2::new((k as f32 + 0.5) / 500.0, (k as f32 * 0.618_034).fract());
            let inc = set
                .sample_incident(0, Vec3::ZERO, u)
                .expect("inside the disc");
            assert!(!inc.delta && inc.position.is_none());
            assert_eq!(inc.li, radiance);
            assert!((inc.pdf as f64 * omega - 1.0).abs() < 1e-3, "{}", inc.pdf);
            assert!((inc.wi.dot(centre) as f64) >= cos_alpha - 1e-7);
            let e = set.sample_emission(0, u, u).expect("emits");
            assert_eq!((e.le, e.pdf_dir), (radiance, inc.pdf));
            assert!(set.radiance(0, -e.dir) == radiance);
        }
        // ∫ pdf dω over the tangent plane: dω = dx dy / (1 + x² + y²)^{3/2}.
        let f = Frame::from_normal(centre);
        let half = 1.3 * (alpha as f64).to_radians();
        let n = 600;
        let h = 2.0 * half / n as f64;
        let (mut integral, mut seen) = (0.0f64, 0.0f64);
        for i in 0..n {
            for j in 0..n {
                let (x, y) = (-half + (i as f64 + 0.5) * h, -half + (j as f64 + 0.5) * h);
                let w = (f.n + f.s * x as f32 + f.t * y as f32).normalize();
                let dw = h * h / libm::pow(1.0 + x * x + y * y, 1.5);
                integral += set.pdf_incident(0, w) as f64 * dw;
                seen += set.radiance(0, w).r as f64 * dw;
            }
        }
        assert!((integral - 1.0).abs() < 5e-3, "{integral}");
        assert!(
            (seen / (radiance.r as f64 * omega) - 1.0).abs() < 5e-3,
            "{seen}"
        );
        // Twice the radius off the centre: neither seen nor sampled.
        let off = (f.n + f.s * 2.0 * alpha.to_radians()).normalize();
        assert_eq!(
            (set.radiance(0, off), set.pdf_incident(0, off)),
            (Rgb::ZERO, 0.0)
        );
        let (_, r) = set.bounding_sphere();
        let power = PI as f64 * (r as f64).powi(2) * omega * radiance.luminance() as f64;
        let p = Prepared::new(set.others[0].light);
        assert!((p.power(r) / power - 1.0).abs() < 1e-3);
        assert!(
            Light::Sun {
                direction: dir,
                radiance,
                half_aperture: 90.0,
                profile: None,
            }
            .validate()
            .is_err()
        );
    }

    /// A sun with a [`SunProfile`]: the factor at directions whose s and μ
    /// are known in closed form (the centre; half the radius straight up
    /// from it, where the elevation offset is exactly α/2; the same at the
    /// zenith, where it is −γ), zero below the horizon, and sampling that
    /// stays unbiased: the mean of li / pdf over stratified samples is the
    /// disc's ∫ L dω on a fine grid. Were `sample_incident` to return the
    /// plain `radiance`, red's mean would be 25 % high (its profile
    /// 0.4 + 0.6 μ averages 0.8 over the disc, μ's mean being 2/3).
    #[test]
    fn sun_profile_values_and_sampling() {
        let alpha_deg = 0.5f32;
        let alpha = (alpha_deg as f64).to_radians();
        let mut coeffs = [[[0.0f32; SUN_PROFILE_MU]; SUN_PROFILE_S]; 3];
        // r: 0.4 + 0.6 μ; g: 1 + 0.3 s; b: 0.5 + 0.2 s² + 0.1 s μ².
        coeffs[0][0][0] = 0.4;
        coeffs[0][0][1] = 0.6;
        coeffs[1][0][0] = 1.0;
        coeffs[1][1][0] = 0.3;
        coeffs[2][0][0] = 0.5;
        coeffs[2][2][0] = 0.2;
        coeffs[2][1][2] = 0.1;
        let want = |s: f64, mu: f64| {
            [
                0.4 + 0.6 * mu,
                1.0 + 0.3 * s,
                0.5 + 0.2 * s * s + 0.1 * s * mu * mu,
            ]
        };
        let up = Vec3::Y;
        let radiance = Rgb::new(2.0, 3.0, 4.0);
        let sun_at = |elevation_deg: f32| {
            let e = elevation_deg.to_radians();
            let centre = Vec3::new(libm::cosf(e), libm::sinf(e), 0.0);
            let set = LightSet::new(
                &[],
                &[Light::Sun {
                    direction: -centre,
                    radiance,
                    half_aperture: alpha_deg,
                    profile: Some(SunProfile { up, coeffs }),
                }],
            );
            (set, centre)
        };
        let check = |set: &LightSet, w: Vec3, s: f64, mu: f64| {
            let got = set.radiance(0, w);
            let w_ = want(s, mu);
            for c in 0..3 {
                let expect = w_[c] * radiance[c] as f64;
                assert!(
                    (got[c] as f64 - expect).abs() < 2e-3 * expect,
                    "channel {c}: {got:?} vs {expect} (s {s}, μ {mu})"
                );
            }
        };
        let (set, centre) = sun_at(20.0);
        check(&set, centre, 0.0, 1.0);
        // Half the radius straight up: s = 1/2, μ = √(1 − sin²(α/2)/sin²α).
        let half = alpha * 0.5;
        let mu_half = (1.0 - (half.sin() / alpha.sin()).powi(2)).sqrt();
        let e = 20f64.to_radians() + half;
        let w = Vec3::new(e.cos() as f32, e.sin() as f32, 0.0);
        check(&set, w, 0.5, mu_half);
        // The same below the centre: s = −1/2.
        let e = 20f64.to_radians() - half;
        check(
            &set,
            Vec3::new(e.cos() as f32, e.sin() as f32, 0.0),
            -0.5,
            mu_half,
        );
        // At the zenith every offset lowers the elevation: s = −γ/α.
        let (zenith, _) = sun_at(90.0);
        let w = Vec3::new(half.sin() as f32, half.cos() as f32, 0.0);
        check(&zenith, w, -0.5, mu_half);
        // A sun 0.1° up: the part of its disc below the horizon is black.
        let (low, centre) = sun_at(0.1);
        let below = Vec3::new(1.0, -(0.2f32.to_radians()), 0.0).normalize();
        assert!(low.pdf_incident(0, below) > 0.0, "inside the disc");
        assert_eq!(low.radiance(0, below), Rgb::ZERO);
        assert!(!low.radiance(0, centre).is_black());
        // Unbiased sampling: mean li / pdf against ∫ L dω, high and low sun.
        for (set, centre) in [sun_at(20.0), sun_at(0.1)] {
            let n = 256;
            let mut mc = [0.0f64; 3];
            for i in 0..n {
                for j in 0..n {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    if let Some(inc) = set.sample_incident(0, Vec3::ZERO, u) {
                        for (c, m) in mc.iter_mut().enumerate() {
                            *m += (inc.li[c] / inc.pdf) as f64 / (n * n) as f64;
                        }
                    }
                }
            }
            let f = Frame::from_normal(centre);
            let h_max = 1.05 * alpha;
            let m = 600;
            let h = 2.0 * h_max / m as f64;
            let mut grid = [0.0f64; 3];
            for i in 0..m {
                for j in 0..m {
                    let (x, y) = (-h_max + (i as f64 + 0.5) * h, -h_max + (j as f64 + 0.5) * h);
                    let w = (f.n + f.s * x as f32 + f.t * y as f32).normalize();
                    let dw = h * h / libm::pow(1.0 + x * x + y * y, 1.5);
                    let l = set.radiance(0, w);
                    for (c, g) in grid.iter_mut().enumerate() {
                        *g += l[c] as f64 * dw;
                    }
                }
            }
            for c in 0..3 {
                assert!(
                    (mc[c] / grid[c] - 1.0).abs() < 5e-3,
                    "channel {c}: sampled {} vs grid {}",
                    mc[c],
                    grid[c]
                );
            }
        }
    }
}

//! Homogeneous participating media (Mitsuba 3's `homogeneous` medium with
//! an `isotropic` or `hg` phase function) and how they attach to surfaces.
//!
//! A medium fills the space on one side of a mesh: each mesh may name an
//! interior and an exterior medium ([`MediumInterface`]), the camera the
//! medium it sits in. A ray crossing a mesh that names media enters the
//! medium on the side it goes to (Mitsuba's `target_medium`: the exterior
//! where the direction leaves along the geometric normal, the interior
//! otherwise); a mesh that names none leaves the current medium as it is.
//! A surface with the null material ([`super::MaterialKind::Null`]) only
//! separates media: rays pass it unchanged.
//!
//! The types here check their invariants when built, so the estimators
//! never see a negative or non-finite coefficient.

use core::fmt;

use glam::Vec3;

use crate::math::{Frame, Rgb};

/// Index of a [`Medium`] in the scene's media (`Scene::media`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MediumId(pub u32);

/// The media on the two sides of a mesh (`None`: vacuum on that side).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MediumInterface {
    /// The medium on the side the geometric normal points away from.
    pub interior: Option<MediumId>,
    /// The medium on the side the geometric normal points to.
    pub exterior: Option<MediumId>,
}

impl MediumInterface {
    /// Whether crossing the surface may change the medium (Mitsuba's
    /// `is_medium_transition`: either side names one).
    #[inline]
    pub fn is_transition(&self) -> bool {
        self.interior.is_some() || self.exterior.is_some()
    }

    /// The medium a ray leaving the surface in direction `d` is in, for a
    /// surface with geometric normal `ng`.
    #[inline]
    pub fn target(&self, ng: Vec3, d: Vec3) -> Option<MediumId> {
        if ng.dot(d) > 0.0 {
            self.exterior
        } else {
            self.interior
        }
    }
}

/// A phase function: the angular distribution of light scattered in a
/// medium, normalised over the sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    /// Uniform over the sphere, 1/(4π).
    Isotropic,
    /// Henyey–Greenstein with mean cosine `g` in (−1, 1): forward
    /// scattering for g > 0 (Mitsuba's `hg`).
    HenyeyGreenstein {
        /// Mean cosine between the incoming and the scattered direction.
        g: f32,
    },
}

/// A direction scattered by a [`Phase`] function and its density.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseSample {
    /// The scattered direction (unit).
    pub wi: Vec3,
    /// Its density per unit solid angle, equal to the phase function's
    /// value (phase functions are sampled exactly).
    pub pdf: f32,
}

const INV_4PI: f32 = 1.0 / (4.0 * core::f32::consts::PI);

impl Phase {
    /// Checks g: finite, |g| < 1 (at ±1 the function is a Dirac delta).
    pub fn validate(&self) -> Result<(), MediumError> {
        match *self {
            Phase::Isotropic => Ok(()),
            Phase::HenyeyGreenstein { g } if g.is_finite() && g.abs() < 1.0 => Ok(()),
            Phase::HenyeyGreenstein { .. } => Err(MediumError::PhaseG),
        }
    }

    /// The phase function's value (= density) for light travelling in unit
    /// direction `d` scattered into unit direction `wi`.
    #[inline]
    pub fn eval(&self, d: Vec3, wi: Vec3) -> f32 {
        match *self {
            Phase::Isotropic => INV_4PI,
            Phase::HenyeyGreenstein { g } => hg(g, d.dot(wi)),
        }
    }

    /// Samples a scattered direction for light travelling in unit
    /// direction `d`, exactly by the function's density.
    #[inline]
    pub fn sample(&self, d: Vec3, u: glam::Vec2) -> PhaseSample {
        let cos = match *self {
            Phase::HenyeyGreenstein { g } => {
                // Inverting the CDF of μ = cos θ (θ from d), whose density is
                // (1 − g²) / (2 (1 + g² − 2gμ)^{3/2}), gives
                // μ = (1 + g² − ((1 − g²) / a)²) / (2g), a = 1 − g + 2gu.
                // Its numerator (1 + g²)a² − (1 − g²)² is a difference of two
                // numbers near 1 that vanishes with g. Written as
                // (a − 1)(a + 1) + g²(a² + 2 − g²) with a − 1 = g(2u − 1),
                // the factor g cancels exactly and the expression holds from
                // g = 0 (μ = 2u − 1) up; it cancels in turn as g → 1 (at
                // u = 0 its two terms sum to −2(1 − g)²), where the first
                // form is exact. Either is the same inverse; each is used
                // where it keeps its precision.
                let v = 2.0 * u.x - 1.0;
                let a = 1.0 + g * v;
                let mu = if g.abs() < 0.5 {
                    (v * (a + 1.0) + g * (a * a + 2.0 - g * g)) / (2.0 * a * a)
                } else {
                    let s = (1.0 - g * g) / a;
                    (1.0 + g * g - s * s) / (2.0 * g)
                };
                mu.clamp(-1.0, 1.0)
            }
            Phase::Isotropic => 1.0 - 2.0 * u.x,
        };
        let sin = libm::sqrtf((1.0 - cos * cos).max(0.0));
        let phi = 2.0 * core::f32::consts::PI * u.y;
        let local = Vec3::new(sin * libm::cosf(phi), sin * libm::sinf(phi), cos);
        let wi = Frame::from_normal(d).to_world(local);
        PhaseSample {
            wi,
            pdf: self.eval(d, wi),
        }
    }
}

/// Henyey–Greenstein's density of cos θ = `cos` between the travel
/// direction and the scattered one, per unit solid angle:
/// (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}).
#[inline]
fn hg(g: f32, cos: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos;
    INV_4PI * (1.0 - g * g) / (denom * libm::sqrtf(denom))
}

/// A homogeneous medium: constant extinction and single-scattering albedo
/// per RGB channel and one phase function. Built by
/// [`Medium::homogeneous`], which checks every value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medium {
    sigma_t: Rgb,
    albedo: Rgb,
    phase: Phase,
}

/// Why a medium's parameters were refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MediumError {
    /// σ_t · scale is negative or not finite in some channel (or the
    /// scale itself is).
    SigmaT,
    /// The albedo is outside [0, 1] in some channel.
    Albedo,
    /// The Henyey–Greenstein g is not finite or |g| ≥ 1.
    PhaseG,
}

impl fmt::Display for MediumError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            MediumError::SigmaT => {
                "medium: sigma_t times scale must be finite and non-negative in every channel"
            }
            MediumError::Albedo => "medium: albedo must be in [0, 1] in every channel",
            MediumError::PhaseG => "phase: hg's g must be finite with |g| < 1",
        })
    }
}

impl Medium {
    /// Mitsuba's `homogeneous` medium: extinction `sigma_t` (per unit
    /// length, multiplied by `scale`), single-scattering `albedo`
    /// (σ_s / σ_t) and the phase function.
    pub fn homogeneous(
        sigma_t: Rgb,
        albedo: Rgb,
        scale: f32,
        phase: Phase,
    ) -> Result<Medium, MediumError> {
        let sigma_t = sigma_t.map(|v| v * scale);
        let ok = |v: f32| v.is_finite() && v >= 0.0;
        if !(scale.is_finite() && ok(sigma_t.r) && ok(sigma_t.g) && ok(sigma_t.b)) {
            return Err(MediumError::SigmaT);
        }
        let unit = |v: f32| (0.0..=1.0).contains(&v);
        if !(unit(albedo.r) && unit(albedo.g) && unit(albedo.b)) {
            return Err(MediumError::Albedo);
        }
        phase.validate()?;
        Ok(Medium {
            sigma_t,
            albedo,
            phase,
        })
    }

    /// Extinction coefficient σ_t per channel (scale applied).
    #[inline]
    pub fn sigma_t(&self) -> Rgb {
        self.sigma_t
    }

    /// Single-scattering albedo σ_s / σ_t per channel.
    #[inline]
    pub fn albedo(&self) -> Rgb {
        self.albedo
    }

    /// Scattering coefficient σ_s = albedo · σ_t per channel.
    #[inline]
    pub fn sigma_s(&self) -> Rgb {
        self.sigma_t * self.albedo
    }

    /// The phase function.
    #[inline]
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Whether light can scatter in the medium (σ_s > 0 in some channel).
    pub fn scatters(&self) -> bool {
        !self.sigma_s().is_black()
    }

    /// Transmittance over distance `dist` (may be infinite): exp(−σ_t d)
    /// per channel, 1 where σ_t = 0 (Beer–Lambert).
    #[inline]
    pub fn transmittance(&self, dist: f32) -> Rgb {
        self.sigma_t
            .map(|s| if s == 0.0 { 1.0 } else { libm::expf(-s * dist) })
    }
}

/// The outcome of free-flight sampling along a ray in a medium
/// ([`Medium::sample_flight`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flight {
    /// The ray scatters at distance `s`; `weight` is
    /// σ_s e^{−σ_t s} / p(s) per channel.
    Scatter {
        /// Distance from the ray's origin.
        s: f32,
        /// The throughput's factor.
        weight: Rgb,
    },
    /// The ray reaches the end of its extent; `weight` is e^{−σ_t t} / P,
    /// P the probability of passing ([`Medium::pass_density`]).
    Pass {
        /// The throughput's factor.
        weight: Rgb,
    },
    /// The sampled event has zero density (every channel's transmittance
    /// underflowed): the path ends.
    Absorbed,
}

impl Medium {
    /// Samples a free-flight distance along a ray whose next surface is at
    /// distance `t_max` (infinite for none) by spectral MIS over the RGB
    /// channels (see `integrator::pt::media`): channel ⌊3 `u_channel`⌋,
    /// distance −ln(1 − `u`)/σ_t,c; the weight divides by the density
    /// averaged over the channels ([`Medium::scatter_density`],
    /// [`Medium::pass_density`]). The one implementation that path tracing
    /// and both BDPT subpaths draw their medium vertices with.
    ///
    /// A medium that only absorbs (σ_s = 0 in every channel: a tinted
    /// glass's or liquid's interior) has no vertex to sample: the ray
    /// always passes, weighted by the transmittance itself (probability
    /// 1, which `pass_density` and `scatter_density` report too). Sampling
    /// a distance there would only turn the transmittance into a coin
    /// flip, a sample passing with weight T/P or ending, with variance
    /// (1 − P)/P times the square of the mean where passing has zero.
    /// `u_channel` and `u` are still taken, so the sample streams of the
    /// other dimensions stay where they are.
    #[inline]
    pub fn sample_flight(&self, t_max: f32, u_channel: f32, u: f32) -> Flight {
        if !self.scatters() {
            let tr = self.transmittance(t_max);
            return if tr.is_black() {
                Flight::Absorbed
            } else {
                Flight::Pass { weight: tr }
            };
        }
        let sigma_t = self.sigma_t.to_array();
        let channel = ((u_channel * 3.0) as usize).min(2);
        let s = if sigma_t[channel] > 0.0 {
            -libm::log1pf(-u) / sigma_t[channel]
        } else {
            f32::INFINITY
        };
        if s < t_max {
            let tr = self.transmittance(s);
            let pdf = (self.sigma_t * tr).average();
            if !(pdf > 0.0) {
                return Flight::Absorbed;
            }
            Flight::Scatter {
                s,
                weight: self.sigma_s() * tr * (1.0 / pdf),
            }
        } else {
            let tr = self.transmittance(t_max);
            let pdf = tr.average();
            if !(pdf > 0.0) {
                return Flight::Absorbed;
            }
            Flight::Pass {
                weight: tr * (1.0 / pdf),
            }
        }
    }

    /// Density (per unit length) with which [`Medium::sample_flight`]
    /// scatters at distance `s`: (1/3) Σ_c σ_t,c e^{−σ_t,c s}, and 0 in a
    /// medium that only absorbs.
    #[inline]
    pub fn scatter_density(&self, s: f32) -> f32 {
        if !self.scatters() {
            return 0.0;
        }
        (self.sigma_t * self.transmittance(s)).average()
    }

    /// Probability that [`Medium::sample_flight`] passes a distance `t`:
    /// (1/3) Σ_c e^{−σ_t,c t}, and 1 in a medium that only absorbs.
    #[inline]
    pub fn pass_density(&self, t: f32) -> f32 {
        if !self.scatters() {
            return 1.0;
        }
        self.transmittance(t).average()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    #[test]
    fn invalid_parameters_are_refused() {
        let iso = Phase::Isotropic;
        let one = Rgb::ONE;
        assert_eq!(
            Medium::homogeneous(Rgb::new(1.0, -0.1, 1.0), one, 1.0, iso),
            Err(MediumError::SigmaT)
        );
        assert_eq!(
            Medium::homogeneous(one, one, f32::NAN, iso),
            Err(MediumError::SigmaT)
        );
        assert_eq!(
            Medium::homogeneous(Rgb::splat(f32::INFINITY), one, 1.0, iso),
            Err(MediumError::SigmaT)
        );
        assert_eq!(
            Medium::homogeneous(one, Rgb::new(0.5, 1.1, 0.5), 1.0, iso),
            Err(MediumError::Albedo)
        );
        for g in [1.0, -1.0, f32::NAN] {
            assert_eq!(
                Medium::homogeneous(one, one, 1.0, Phase::HenyeyGreenstein { g }),
                Err(MediumError::PhaseG)
            );
        }
        let m = Medium::homogeneous(Rgb::new(1.0, 2.0, 0.0), Rgb::splat(0.5), 2.0, iso).unwrap();
        assert_eq!(m.sigma_t(), Rgb::new(2.0, 4.0, 0.0));
        assert_eq!(m.sigma_s(), Rgb::new(1.0, 2.0, 0.0));
        let tr = m.transmittance(f32::INFINITY);
        assert_eq!(tr, Rgb::new(0.0, 0.0, 1.0));
    }

    /// Each phase function integrates to 1 over the sphere, its mean cosine
    /// is g, and its samples have the density it reports (checked through
    /// E[1/pdf] = 4π over the sampled directions).
    /// A medium that only absorbs is passed with its transmittance as the
    /// weight, whatever the random numbers, with the densities saying so;
    /// one that scatters at all still samples distances (its mean weight
    /// is the transmittance, each sample's is not).
    #[test]
    fn absorbers_are_passed_with_their_transmittance() {
        let sigma_t = Rgb::new(0.5, 1.0, 2.0);
        let absorber = Medium::homogeneous(sigma_t, Rgb::ZERO, 1.0, Phase::Isotropic).unwrap();
        let tr = absorber.transmittance(1.0);
        for (uc, u) in [(0.1, 0.9), (0.5, 0.01), (0.99, 0.5)] {
            assert_eq!(
                absorber.sample_flight(1.0, uc, u),
                Flight::Pass { weight: tr }
            );
        }
        assert_eq!(
            absorber.sample_flight(f32::INFINITY, 0.5, 0.5),
            Flight::Absorbed
        );
        assert_eq!(absorber.pass_density(1.0), 1.0);
        assert_eq!(absorber.scatter_density(0.5), 0.0);
        let faint = Rgb::new(0.0, 0.01, 0.0);
        let scatterer = Medium::homogeneous(sigma_t, faint, 1.0, Phase::Isotropic).unwrap();
        assert!(matches!(
            scatterer.sample_flight(1.0, 0.5, 0.3),
            Flight::Scatter { .. }
        ));
        let Flight::Pass { weight } = scatterer.sample_flight(1.0, 0.5, 0.9) else {
            panic!("a short flight passes");
        };
        let want = tr * (1.0 / tr.average());
        assert!((weight.r - want.r).abs() + (weight.b - want.b).abs() < 1e-6);
        assert!((scatterer.pass_density(1.0) - tr.average()).abs() < 1e-7);
    }

    /// Henyey–Greenstein sampling inverts the CDF exactly at every g, the
    /// tiny ones included: the sampled cosine equals the inverse CDF's,
    /// evaluated in f64 (where 1/(2g) loses nothing at these g). An
    /// isotropic sample for small |g| (what this replaced) puts μ = 1 − 2u
    /// there, off by up to 2.
    #[test]
    fn henyey_greenstein_is_inverted_exactly_at_every_g() {
        let d = Vec3::new(0.3, -0.4, 0.866).normalize();
        for g in [1e-6f32, -2e-5, 5e-4, -9e-4, 0.3, -0.49, 0.51, -0.6, 0.95] {
            let phase = Phase::HenyeyGreenstein { g };
            for i in 0..=64 {
                let u = Vec2::new(i as f32 / 64.0, 0.3);
                let (g64, u64) = (g as f64, u.x as f64);
                let s = (1.0 - g64 * g64) / (1.0 - g64 + 2.0 * g64 * u64);
                let want = ((1.0 + g64 * g64 - s * s) / (2.0 * g64)).clamp(-1.0, 1.0);
                let got = d.dot(phase.sample(d, u).wi) as f64;
                assert!(
                    (got - want).abs() < 2e-5,
                    "g {g}, u {}: {got} against {want}",
                    u.x
                );
            }
        }
    }

    #[test]
    fn phase_functions_are_normalised_and_sampled_exactly() {
        let d = Vec3::new(0.3, -0.4, 0.866).normalize();
        for phase in [
            Phase::Isotropic,
            Phase::HenyeyGreenstein { g: 0.7 },
            Phase::HenyeyGreenstein { g: -0.4 },
            Phase::HenyeyGreenstein { g: 1e-4 },
        ] {
            let n = 256;
            let (mut integral, mut inv_pdf, mut mean_cos) = (0.0f64, 0.0f64, 0.0f64);
            for i in 0..n {
                for j in 0..n {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    // Quadrature over the sphere in (z, φ): dω = dz dφ.
                    let z = 1.0 - 2.0 * u.x;
                    let r = libm::sqrtf((1.0 - z * z).max(0.0));
                    let phi = 2.0 * core::f32::consts::PI * u.y;
                    let w = Vec3::new(r * libm::cosf(phi), r * libm::sinf(phi), z);
                    integral += phase.eval(d, w) as f64 * 4.0 * core::f64::consts::PI;
                    let s = phase.sample(d, u);
                    assert!((s.wi.length() - 1.0).abs() < 1e-4);
                    assert!((s.pdf - phase.eval(d, s.wi)).abs() <= 1e-4 * s.pdf);
                    inv_pdf += 1.0 / s.pdf as f64;
                    mean_cos += d.dot(s.wi) as f64;
                }
            }
            let m = (n * n) as f64;
            let g = match phase {
                Phase::Isotropic => 0.0,
                Phase::HenyeyGreenstein { g } => g as f64,
            };
            assert!(
                (integral / m - 1.0).abs() < 2e-3,
                "{phase:?}: ∫p = {}",
                integral / m
            );
            assert!(
                (mean_cos / m - g).abs() < 2e-3,
                "{phase:?}: mean cos {}",
                mean_cos / m
            );
            let four_pi = 4.0 * core::f64::consts::PI;
            assert!(
                (inv_pdf / m / four_pi - 1.0).abs() < 1e-2,
                "{phase:?}: E[1/pdf] = {}",
                inv_pdf / m
            );
        }
    }
}

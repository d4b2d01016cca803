//! Mitsuba 3's `sunsky` emitter in its RGB form: the Hosek–Wilkie sky
//! (Hosek & Wilkie 2012, "An Analytic Model for Full Spectral Sky-Dome
//! Radiance") plus the sun's disc (Hosek & Wilkie 2013, "Adding a
//! Solar-Radiance Function to the Hosek–Wilkie Skylight Model"), with the
//! parameters, frame and units of Mitsuba 3.9's plugin.
//!
//! The model's RGB coefficients come from the datasets shipped with the
//! Mitsuba 3 Python package (3-clause BSD, Hosek & Wilkie), reduced by
//! `mitsuba/data/make_sunsky_rgb.py` to `mitsuba/data/sunsky_rgb.bin`
//! (layout in that script; licence in `LICENSE-hosek-wilkie.txt` beside
//! it).
//!
//! **Frame.** The emitter's local frame is z-up (Mitsuba 3's; 0.6 was
//! y-up): a direction's zenith angle θ has cos θ = d.z, and `to_world`
//! (a rotation) turns the whole dome. The sun is given either as
//! `sun_direction` (world space, towards the sun) or by time and place
//! (Blanco-Muriel et al. 2001, "Computing the solar vector", Solar Energy
//! 70(5): zenith angle θ_s and azimuth, the local direction being
//! (sin θ_s cos φ, sin θ_s sin φ, cos θ_s) with φ = azimuth − π).
//!
//! **Sky** (paper, eq. 9), per channel, for a view direction at zenith
//! angle θ and angle γ from the sun:
//! L = (1 + A e^{B / (cos θ + 0.01)}) (C + D e^{E γ} + F cos² γ +
//! G χ(H, γ) + I √cos θ) · L_M, χ(H, γ) = (1 + cos² γ) / (1 + H² − 2 H cos γ)^{3/2},
//! with the nine coefficients and the mean radiance L_M interpolated
//! linearly in turbidity (levels 1…10) and ground albedo (0 and 1, per
//! channel) and by the quintic Bézier in x = ∛(η / (π/2)) of the sun's
//! elevation η that the model is fitted with; times Mitsuba's
//! `MI_CIE_Y_NORMALIZATION`. Zero below the horizon (cos θ < 0), and the
//! whole emitter is black when the sun is below it (Mitsuba's `active`).
//!
//! **Sun** (`complex_sun = false`, Mitsuba's default): a disc of uniform
//! radiance E / (2π (1 − cos α)) where α is half of `sun_aperture` and E
//! the sun's RGB irradiance at that turbidity and elevation (the table
//! interpolated linearly in turbidity and in elevation at 2°, 5°, …, 89°),
//! so the sun delivers the same irradiance at any aperture, as in Mitsuba.
//! Linear sRGB can be negative for a low red sun; negative channels are
//! clamped to zero (Mitsuba leaves them, cmlt's lights must be
//! non-negative).
//!
//! **Complex sun** (`complex_sun = true`): Hosek & Wilkie 2013's solar
//! radiance, a piecewise polynomial in the elevation of the *view
//! direction* (45 segments, cubic in each) times a quintic in the limb
//! parameter μ = cos ψ = √(1 − sin²γ / sin²α) (γ from the disc's centre),
//! which Mitsuba's RGB mode reads with the limb darkening baked into its
//! `sun_rad_rgb` table; scaled by the aperture's area ratio to the data's
//! 0.5358° so that the irradiance does not depend on the aperture; clipped
//! by the horizon ([`complex_sun_radiance`] says exactly what Mitsuba
//! 3.9.1's `BaseSunskyEmitter::eval_sun` does). Mitsuba's docs say both
//! suns "integrate to the same total power", but they come from different
//! tables: their irradiances agree within 0.3 % for a sun 59° up and part
//! at a low one (blue −13 % at 6°, red −40 % at 1°; figures in
//! `complex_sun_irradiance_matches_mitsuba`). The complex disc's centre is
//! about 20 % brighter than its mean, its rim darker, and a low sun is
//! redder at its bottom than at its top. In cmlt it is a
//! [`Light::Sun`] whose radiance is the disc's mean and whose
//! [`SunProfile`] carries Mitsuba's μ polynomial and, per power of μ, one
//! cubic in the elevation offset fitted across the disc
//! ([`complex_sun_profile`]); it is sampled uniformly in solid angle over
//! the disc, as Mitsuba samples it, the varying radiance being in the
//! estimate (li / pdf) and not in the density.
//!
//! **In cmlt** the sky becomes a [`Light::Envmap`] baked at
//! [`SKY_WIDTH`] × [`SKY_HEIGHT`] texels, its poles on the sky's zenith
//! and nadir so that a row lies on the horizon, and the sun a
//! [`Light::Sun`] disc (a 0.27° disc would be blurred away in a map of any
//! reasonable size). The map's error against the analytic sky is measured
//! by `baked_sky_matches_the_model` below.

use glam::{DMat3, DVec3, Mat3, Vec3};

use cmlt::math::Rgb;
use cmlt::scene::{Bitmap, Light, SUN_PROFILE_MU, SUN_PROFILE_S, SunProfile};

/// The packed RGB model data (see the module docs).
static DATA: &[u8] = include_bytes!("../data/sunsky_rgb.bin");
const MAGIC: &[u8; 8] = b"CMLTSKY2";
const TURBIDITIES: usize = 10;
const CTRL: usize = 6;
const PARAMS: usize = 9;
const SUN_ELEVATIONS: usize = 30;
/// Segments of the complex sun's piecewise polynomial in elevation.
const SUN_SEGMENTS: usize = 45;
/// Its degree + 1 in the elevation x within a segment.
const SUN_CTRL: usize = 4;
/// Its degree + 1 in cos ψ (the baked-in limb darkening).
const SUN_LD: usize = 6;
const SKY_PARAMS_OFFSET: usize = 0;
const SKY_RAD_OFFSET: usize = TURBIDITIES * 2 * CTRL * 3 * PARAMS;
const SUN_OFFSET: usize = SKY_RAD_OFFSET + TURBIDITIES * 2 * CTRL * 3;
const SUN_RAD_OFFSET: usize = SUN_OFFSET + TURBIDITIES * SUN_ELEVATIONS * 3;
const VALUES: usize = SUN_RAD_OFFSET + TURBIDITIES * SUN_SEGMENTS * 3 * SUN_CTRL * SUN_LD;
// The profile's μ polynomial is the data's.
const _: () = assert!(SUN_LD == SUN_PROFILE_MU);
/// Mitsuba's `SPEC_TO_RGB_SUN_CONV`, the factor on the RGB sun tables.
const SPEC_TO_RGB_SUN_CONV: f64 = 467.069280386;
/// Mitsuba's `SUN_HALF_APERTURE` (0.5358° / 2) in radians, the aperture
/// the complex sun's data describe.
const DEFAULT_SUN_HALF_APERTURE: f64 = std::f64::consts::PI * (0.5 * 0.5358) / 180.0;
/// Mitsuba 3.9's `MI_CIE_Y_NORMALIZATION`, 1 / ∫ ȳ(λ) dλ over its CIE
/// table (1 / 106.750 26, as the package reports it).
const CIE_Y_NORMALIZATION: f64 = 0.009_367_658_735_689_113;

/// Width of the baked sky map (2 × its rows, square texels in angle).
pub const SKY_WIDTH: u32 = 512;
/// Height of the baked sky map: 2k + 1 rows, row k on the horizon.
pub const SKY_HEIGHT: u32 = 257;

/// Value `i` of the packed data.
fn value(i: usize) -> f64 {
    debug_assert!(DATA.len() == MAGIC.len() + 4 * VALUES && &DATA[..8] == MAGIC);
    let o = MAGIC.len() + 4 * i;
    f32::from_le_bytes([DATA[o], DATA[o + 1], DATA[o + 2], DATA[o + 3]]) as f64
}

/// The `sunsky` parameters, as Mitsuba 3 takes them.
#[derive(Clone, Copy, Debug)]
pub struct SunSky {
    /// Atmospheric turbidity in [1, 10].
    pub turbidity: f64,
    /// Ground albedo per channel, in [0, 1].
    pub albedo: [f64; 3],
    /// Unit direction towards the sun in the emitter's local frame (z up).
    pub sun_local: DVec3,
    /// Factor on the sun's radiance.
    pub sun_scale: f64,
    /// Factor on the sky's radiance.
    pub sky_scale: f64,
    /// Full apparent diameter of the sun in degrees, in (0, 180).
    pub sun_aperture: f64,
    /// Mitsuba's `complex_sun`: the disc limb-darkened and varying with
    /// elevation (see [`complex_sun_radiance`]) instead of uniform.
    pub complex_sun: bool,
    /// Emitter-to-world rotation.
    pub to_world: DMat3,
}

/// A date, time and place for [`sun_from_time`] (Mitsuba's defaults:
/// Tokyo, 10 July 2010, 15:00).
#[derive(Clone, Copy, Debug)]
pub struct TimePlace {
    /// Degrees north.
    pub latitude: f64,
    /// Degrees east.
    pub longitude: f64,
    /// Hours ahead of UTC.
    pub timezone: f64,
    /// Year.
    pub year: i64,
    /// Month, 1…12.
    pub month: i64,
    /// Day of the month.
    pub day: i64,
    /// Local hour.
    pub hour: f64,
    /// Minute.
    pub minute: f64,
    /// Second.
    pub second: f64,
}

impl Default for TimePlace {
    fn default() -> Self {
        TimePlace {
            latitude: 35.6894,
            longitude: 139.6917,
            timezone: 9.0,
            year: 2010,
            month: 7,
            day: 10,
            hour: 15.0,
            minute: 0.0,
            second: 0.0,
        }
    }
}

/// The sun's local direction (z up) at `t` (Blanco-Muriel et al. 2001, the
/// PSA algorithm, with its parallax correction): zenith angle θ_s and
/// azimuth ψ from north through east give (sin θ_s cos φ, sin θ_s sin φ,
/// cos θ_s) with φ = ψ − π, Mitsuba 3's convention.
pub fn sun_from_time(t: &TimePlace) -> DVec3 {
    use std::f64::consts::{PI, TAU};
    // Universal time in decimal hours, and the Julian day (integer
    // arithmetic of the paper, truncating division as in C).
    let dec_hours = t.hour - t.timezone + (t.minute + t.second / 60.0) / 60.0;
    let aux1 = (t.month - 14) / 12;
    let aux2 = (1461 * (t.year + 4800 + aux1)) / 4 + (367 * (t.month - 2 - 12 * aux1)) / 12
        - (3 * ((t.year + 4900 + aux1) / 100)) / 4
        + t.day
        - 32075;
    let jd = aux2 as f64 - 0.5 + dec_hours / 24.0;
    let n = jd - 2451545.0;
    // Ecliptic coordinates.
    let omega = 2.1429 - 0.0010394594 * n;
    let mean_longitude = 4.8950630 + 0.017202791698 * n;
    let anomaly = 6.2400600 + 0.0172019699 * n;
    let ecl_longitude =
        mean_longitude + 0.03341607 * anomaly.sin() + 0.00034894 * (2.0 * anomaly).sin()
            - 0.0001134
            - 0.0000203 * omega.sin();
    let ecl_obliquity = 0.4090928 - 6.2140e-9 * n + 0.0000396 * omega.cos();
    // Celestial coordinates.
    let sin_l = ecl_longitude.sin();
    let mut ra = (ecl_obliquity.cos() * sin_l).atan2(ecl_longitude.cos());
    if ra < 0.0 {
        ra += TAU;
    }
    let declination = (ecl_obliquity.sin() * sin_l).asin();
    // Local coordinates.
    let gmst = 6.6974243242 + 0.0657098283 * n + dec_hours;
    let lmst = (gmst * 15.0 + t.longitude).to_radians();
    let lat = t.latitude.to_radians();
    let hour_angle = lmst - ra;
    let mut zenith = (lat.cos() * hour_angle.cos() * declination.cos()
        + declination.sin() * lat.sin())
    .clamp(-1.0, 1.0)
    .acos();
    let mut azimuth =
        (-hour_angle.sin()).atan2(declination.tan() * lat.cos() - lat.sin() * hour_angle.cos());
    if azimuth < 0.0 {
        azimuth += TAU;
    }
    // Parallax: Earth's mean radius over the astronomical unit (km).
    zenith += (6371.01 / 149597890.0) * zenith.sin();
    let phi = azimuth - PI;
    DVec3::new(
        zenith.sin() * phi.cos(),
        zenith.sin() * phi.sin(),
        zenith.cos(),
    )
}

/// The sky model's coefficients for one sun position and atmosphere.
#[derive(Clone, Debug)]
pub struct SkyModel {
    /// A…I per channel, in the data's order (A B C D E F G I H).
    params: [[f64; PARAMS]; 3],
    /// Mean radiance per channel.
    radiance: [f64; 3],
    /// Unit direction towards the sun (local, z up).
    sun: DVec3,
}

/// Linear interpolation weights of `t` (clamped) on levels 0…n − 1.
fn lerp_index(t: f64, n: usize) -> (usize, usize, f64) {
    let t = t.clamp(0.0, (n - 1) as f64);
    let i = (t.floor() as usize).min(n - 1);
    let j = (i + 1).min(n - 1);
    (i, j, t - i as f64)
}

impl SkyModel {
    /// The model for `s`'s turbidity, albedo and sun.
    pub fn new(s: &SunSky) -> Self {
        let elevation =
            (std::f64::consts::FRAC_PI_2 - s.sun_local.z.clamp(-1.0, 1.0).acos()).max(0.0);
        // Bézier parameter of the elevation (the fit's cube-root spacing).
        let x = (elevation / std::f64::consts::FRAC_PI_2)
            .cbrt()
            .min(1.0 - f64::EPSILON);
        const BINOMIAL: [f64; CTRL] = [1.0, 5.0, 10.0, 10.0, 5.0, 1.0];
        let bernstein: Vec<f64> = (0..CTRL)
            .map(|k| BINOMIAL[k] * x.powi(k as i32) * (1.0 - x).powi((CTRL - 1 - k) as i32))
            .collect();
        let (t0, t1, ft) = lerp_index(s.turbidity - 1.0, TURBIDITIES);
        let mut params = [[0.0; PARAMS]; 3];
        let mut radiance = [0.0; 3];
        for c in 0..3 {
            let a = s.albedo[c];
            // Weight of (turbidity level, albedo level).
            let corners = [
                (t0, 0, (1.0 - ft) * (1.0 - a)),
                (t0, 1, (1.0 - ft) * a),
                (t1, 0, ft * (1.0 - a)),
                (t1, 1, ft * a),
            ];
            for (t, al, w) in corners {
                for (k, b) in bernstein.iter().enumerate() {
                    let wk = w * b;
                    let base = ((t * 2 + al) * CTRL + k) * 3 + c;
                    for (p, v) in params[c].iter_mut().enumerate() {
                        *v += wk * value(SKY_PARAMS_OFFSET + base * PARAMS + p);
                    }
                    radiance[c] += wk * value(SKY_RAD_OFFSET + base);
                }
            }
        }
        SkyModel {
            params,
            radiance,
            sun: s.sun_local,
        }
    }

    /// Sky radiance (linear RGB, before `sky_scale`) seen along the unit
    /// local direction `d` (z up).
    pub fn radiance(&self, d: DVec3) -> [f64; 3] {
        let cos_theta = d.z;
        if cos_theta < 0.0 || self.sun.z < 0.0 {
            return [0.0; 3];
        }
        let cos_gamma = d.dot(self.sun).clamp(-1.0, 1.0);
        let gamma = cos_gamma.acos();
        let mut out = [0.0; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let [a, b, cc, dd, e, f, g, i, h] = self.params[c];
            let chi = (1.0 + cos_gamma * cos_gamma) / (1.0 + h * h - 2.0 * h * cos_gamma).powf(1.5);
            let zenith = 1.0 + a * (b / (cos_theta + 0.01)).exp();
            let glow = cc
                + dd * (e * gamma).exp()
                + f * cos_gamma * cos_gamma
                + g * chi
                + i * cos_theta.sqrt();
            *o = zenith * glow * self.radiance[c] * CIE_Y_NORMALIZATION;
        }
        out
    }
}

/// The sun's RGB irradiance at turbidity `turbidity` and the elevation of
/// the unit local direction `sun` (the table's linear interpolation, its
/// elevations 2° + 3° i clamped to its range as Mitsuba does).
pub fn sun_irradiance(turbidity: f64, sun: DVec3) -> [f64; 3] {
    let elevation = 90.0 - sun.z.clamp(-1.0, 1.0).acos().to_degrees();
    let (e0, e1, fe) = lerp_index((elevation - 2.0) / 3.0, SUN_ELEVATIONS);
    let (t0, t1, ft) = lerp_index(turbidity - 1.0, TURBIDITIES);
    let at = |t: usize, e: usize, c: usize| value(SUN_OFFSET + (t * SUN_ELEVATIONS + e) * 3 + c);
    let mut out = [0.0; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let lo = at(t0, e0, c) * (1.0 - fe) + at(t0, e1, c) * fe;
        let hi = at(t1, e0, c) * (1.0 - fe) + at(t1, e1, c) * fe;
        *o = lo * (1.0 - ft) + hi * ft;
    }
    out
}

/// The envmap frame's zenith (+y) turned onto the sky's (+z): a quarter
/// turn about x, (x, y, z) ↦ (x, −z, y).
fn envmap_to_sky() -> DMat3 {
    DMat3::from_cols(DVec3::X, DVec3::Z, -DVec3::Y)
}

/// Local (z-up) direction of texel `(x, y)` of a `w` × `h` lat-long map in
/// the envmap's parameterisation (column x at φ = 2π (x + ½)/w, row y at
/// θ = π y/(h − 1), its own y axis the zenith), turned by
/// [`envmap_to_sky`].
fn texel_direction(x: u32, y: u32, w: u32, h: u32) -> DVec3 {
    let phi = std::f64::consts::TAU * (x as f64 + 0.5) / w as f64;
    let theta = std::f64::consts::PI * y as f64 / (h - 1) as f64;
    let v = DVec3::new(
        phi.sin() * theta.sin(),
        theta.cos(),
        -phi.cos() * theta.sin(),
    );
    envmap_to_sky() * v
}

/// The sky baked into a `w` × `h` lat-long bitmap (times `sky_scale`) and
/// the rotation to give it as the envmap's `to_world`.
pub fn bake_sky(s: &SunSky, w: u32, h: u32) -> (Bitmap, Mat3) {
    let model = SkyModel::new(s);
    let mut texels = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        // The row on the horizon samples a step (the sky above, black
        // below): it holds the mean of the two sides, so that the bilinear
        // ramp across it errs as much above the horizon as below and the
        // map keeps the sky's power (the one-sided value would add a band
        // of horizon light below the horizon, which a low camera sees).
        let step = if 2 * y == h - 1 { 0.5 } else { 1.0 };
        for x in 0..w {
            let l = model.radiance(texel_direction(x, y, w, h));
            let c = |v: f64| (v * s.sky_scale * step).max(0.0) as f32;
            texels.push(Rgb::new(c(l[0]), c(l[1]), c(l[2])));
        }
    }
    let bitmap = Bitmap::new(w, h, texels).expect("finite sky texels");
    (bitmap, (s.to_world * envmap_to_sky()).as_mat3())
}

/// The complex sun's radiance (Mitsuba 3.9.1's `complex_sun`, RGB) along
/// the unit local direction `w`, before `sun_scale`: zero outside the disc
/// (γ > α, α half of `sun_aperture`) and below the horizon; else, per
/// channel c, Hosek & Wilkie 2013's piecewise polynomial with the limb
/// darkening baked in,
///
/// L_c = r · K · N · Σ_k Σ_j x^k μ^j D[t][p][c][k][j],
///
/// where e = π/2 − acos(w.z) is the elevation *of the view direction*,
/// p = min(⌊∛(2e/π) · 45⌋, 44) its segment, x = e − (π/2)(p/45)³ its
/// offset in it, μ = √(1 − sin²γ / sin²α), D the table interpolated
/// linearly in turbidity, r = (1 − cos α₀)/(1 − cos α) the aperture's
/// area ratio to the data's α₀ = 0.2679° (so the irradiance does not
/// depend on the aperture), K = 467.069280386 and N =
/// `MI_CIE_Y_NORMALIZATION` (Mitsuba's `BaseSunskyEmitter::eval_sun`
/// and `eval`, include/mitsuba/render/sunsky.h). Mitsuba computes r in
/// f32; this is the exact value.
// The model the tests hold Mitsuba's values and the fitted light to.
#[cfg_attr(not(test), allow(dead_code))]
pub fn complex_sun_radiance(s: &SunSky, w: DVec3) -> [f64; 3] {
    let half = (s.sun_aperture * 0.5).to_radians();
    let cos_gamma = w.dot(s.sun_local);
    if w.z < 0.0 || s.sun_local.z < 0.0 || cos_gamma < half.cos() {
        return [0.0; 3];
    }
    let sin2_gamma = w.cross(s.sun_local).length_squared();
    let mu = (1.0 - sin2_gamma / half.sin().powi(2)).max(0.0).sqrt();
    let e = std::f64::consts::FRAC_PI_2 - w.z.clamp(-1.0, 1.0).acos();
    let scale = area_ratio(half) * SPEC_TO_RGB_SUN_CONV * CIE_Y_NORMALIZATION;
    let poly = sun_polynomial(s.turbidity, e);
    let mut out = [0.0; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let mut v = 0.0;
        for j in (0..SUN_LD).rev() {
            v = v * mu + poly[c][j];
        }
        *o = scale * v;
    }
    out
}

/// (1 − cos α₀)/(1 − cos α) for the half aperture α (radians), α₀ the
/// data's (1 − cos α = 2 sin²(α/2), exact for small α).
fn area_ratio(half: f64) -> f64 {
    (DEFAULT_SUN_HALF_APERTURE * 0.5).sin().powi(2) / (half * 0.5).sin().powi(2)
}

/// The complex sun's coefficients of μ^j per channel at elevation `e`
/// (radians, ≥ 0): Σ_k x^k D[t][p][c][k][j] of [`complex_sun_radiance`].
fn sun_polynomial(turbidity: f64, e: f64) -> [[f64; SUN_LD]; 3] {
    use std::f64::consts::FRAC_PI_2;
    let segment = ((e.max(0.0) / FRAC_PI_2).cbrt() * SUN_SEGMENTS as f64).floor() as usize;
    let p = segment.min(SUN_SEGMENTS - 1);
    let x = e - FRAC_PI_2 * (p as f64 / SUN_SEGMENTS as f64).powi(3);
    let (t0, t1, ft) = lerp_index(turbidity - 1.0, TURBIDITIES);
    let at = |t: usize, c: usize, k: usize, j: usize| {
        value(SUN_RAD_OFFSET + (((t * SUN_SEGMENTS + p) * 3 + c) * SUN_CTRL + k) * SUN_LD + j)
    };
    let mut out = [[0.0; SUN_LD]; 3];
    for (c, row) in out.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            for k in (0..SUN_CTRL).rev() {
                let d = at(t0, c, k, j) * (1.0 - ft) + at(t1, c, k, j) * ft;
                *v = *v * x + d;
            }
        }
    }
    out
}

/// The complex sun as cmlt's [`SunProfile`] and the disc's mean radiance
/// (before `sun_scale`). The profile's μ polynomial is Mitsuba's; its
/// dependence on the view direction's elevation e, a cubic in x within
/// each segment, becomes one cubic in s = (e − e₀)/α over the disc (e₀ the
/// centre's elevation): a least-squares fit on Chebyshev nodes over the
/// disc's range of s above the horizon, exact (to rounding) where the disc
/// lies in one segment, an approximation where it straddles a segment
/// boundary (measured in `complex_sun_profile_matches_mitsuba`). The
/// mean is ∫ L dω / Ω over the disc (clipped by the horizon), so that the
/// profile averages 1.
pub fn complex_sun_profile(s: &SunSky) -> ([f64; 3], [[[f64; SUN_PROFILE_MU]; SUN_PROFILE_S]; 3]) {
    use std::f64::consts::{FRAC_PI_2, PI};
    let half = (s.sun_aperture * 0.5).to_radians();
    let c = s.sun_local;
    let e0 = c.z.clamp(-1.0, 1.0).asin();
    let scale = area_ratio(half) * SPEC_TO_RGB_SUN_CONV * CIE_Y_NORMALIZATION;
    // The range of s over the disc: no lower than the horizon, no higher
    // than the zenith.
    let lo = (-e0 / half).max(-1.0);
    let hi = ((FRAC_PI_2 - e0) / half).min(1.0);
    // Least squares for a cubic in s: normal equations on Chebyshev nodes
    // (well conditioned for s in [−1, 1]).
    const NODES: usize = 48;
    let mut ata = [[0.0f64; SUN_PROFILE_S]; SUN_PROFILE_S];
    let mut atb = [[[0.0f64; SUN_PROFILE_S]; SUN_LD]; 3];
    for n in 0..NODES {
        let t = (PI * (n as f64 + 0.5) / NODES as f64).cos();
        let sv = lo + (hi - lo) * 0.5 * (t + 1.0);
        let poly = sun_polynomial(s.turbidity, (e0 + half * sv).max(0.0));
        let basis: [f64; SUN_PROFILE_S] = std::array::from_fn(|k| sv.powi(k as i32));
        for a in 0..SUN_PROFILE_S {
            for b in 0..SUN_PROFILE_S {
                ata[a][b] += basis[a] * basis[b];
            }
            for ch in 0..3 {
                for j in 0..SUN_LD {
                    atb[ch][j][a] += basis[a] * poly[ch][j] * scale;
                }
            }
        }
    }
    let mut coeffs = [[[0.0f64; SUN_PROFILE_MU]; SUN_PROFILE_S]; 3];
    for ch in 0..3 {
        for j in 0..SUN_LD {
            let sol = solve4(ata, atb[ch][j]);
            for k in 0..SUN_PROFILE_S {
                coeffs[ch][k][j] = sol[k];
            }
        }
    }
    // The mean over the disc: dω = sin γ dγ dφ = sin²α μ dμ dφ / cos γ
    // (sin²γ = sin²α (1 − μ²)), smooth in μ, so a midpoint rule in (μ, φ).
    let (v, h) = disc_axes(c);
    const M: usize = 64;
    let (mut sum, mut weight) = ([0.0f64; 3], 0.0f64);
    for i in 0..M {
        let mu = (i as f64 + 0.5) / M as f64;
        let sin_g = half.sin() * (1.0 - mu * mu).sqrt();
        let cos_g = (1.0 - sin_g * sin_g).sqrt();
        let wt = mu / cos_g;
        for k in 0..2 * M {
            let phi = PI * (k as f64 + 0.5) / M as f64;
            weight += wt;
            let w = c * cos_g + (v * phi.cos() + h * phi.sin()) * sin_g;
            if w.z < 0.0 {
                continue;
            }
            let sv = (w.z.clamp(-1.0, 1.0).asin() - e0) / half;
            for (ch, acc) in sum.iter_mut().enumerate() {
                *acc += wt * eval_profile(&coeffs[ch], sv, mu).max(0.0);
            }
        }
    }
    let mean: [f64; 3] = std::array::from_fn(|ch| sum[ch] / weight);
    for (ch, m) in mean.iter().enumerate() {
        for row in coeffs[ch].iter_mut() {
            for a in row.iter_mut() {
                *a = if *m > 0.0 { *a / m } else { 0.0 };
            }
        }
    }
    (mean.map(|m| m.max(0.0)), coeffs)
}

/// Σ_k Σ_j coeffs[k][j] s^k μ^j.
fn eval_profile(coeffs: &[[f64; SUN_PROFILE_MU]; SUN_PROFILE_S], s: f64, mu: f64) -> f64 {
    let mut v = 0.0;
    for row in coeffs.iter().rev() {
        let mut r = 0.0;
        for &a in row.iter().rev() {
            r = r * mu + a;
        }
        v = v * s + r;
    }
    v
}

/// Two unit vectors completing the unit `c` to a right-handed frame, the
/// first towards the zenith (+z) where `c` is not vertical.
fn disc_axes(c: DVec3) -> (DVec3, DVec3) {
    let toward_up = DVec3::Z - c * c.z;
    let v = if toward_up.length_squared() > 1e-20 {
        toward_up.normalize()
    } else {
        c.any_orthonormal_vector()
    };
    (v, c.cross(v))
}

/// Solves the 4 × 4 system `a x = b` (symmetric positive definite: the
/// normal equations) by Gaussian elimination with partial pivoting.
fn solve4(mut a: [[f64; 4]; 4], mut b: [f64; 4]) -> [f64; 4] {
    for col in 0..4 {
        let piv = (col..4)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap_or(col);
        a.swap(col, piv);
        b.swap(col, piv);
        for r in col + 1..4 {
            let f = a[r][col] / a[col][col];
            let pivot = a[col];
            for (x, p) in a[r].iter_mut().zip(pivot).skip(col) {
                *x -= f * p;
            }
            b[r] -= f * b[col];
        }
    }
    let mut x = [0.0; 4];
    for r in (0..4).rev() {
        let mut v = b[r];
        for k in r + 1..4 {
            v -= a[r][k] * x[k];
        }
        x[r] = v / a[r][r];
    }
    x
}

/// The sun as a [`Light::Sun`], `None` when it is black or below the
/// horizon: a uniform disc, or with `complex_sun` one whose radiance is the
/// disc's mean and whose [`SunProfile`] is [`complex_sun_profile`].
pub fn sun_light(s: &SunSky) -> Option<Light> {
    if s.sun_local.z < 0.0 || s.sun_scale == 0.0 {
        return None;
    }
    let half = (s.sun_aperture * 0.5).to_radians();
    let (mean, profile) = if s.complex_sun {
        let (mean, coeffs) = complex_sun_profile(s);
        let up = (s.to_world * DVec3::Z).normalize().as_vec3();
        let coeffs = coeffs.map(|ch| ch.map(|row| row.map(|a| a as f32)));
        (mean, Some(SunProfile { up, coeffs }))
    } else {
        // 1 − cos α = 2 sin²(α/2).
        let omega = std::f64::consts::TAU * 2.0 * (half * 0.5).sin().powi(2);
        let e = sun_irradiance(s.turbidity, s.sun_local);
        (e.map(|v| v / omega), None)
    };
    let l = |c: usize| (s.sun_scale * mean[c]).max(0.0) as f32;
    let radiance = Rgb::new(l(0), l(1), l(2));
    if radiance.is_black() {
        return None;
    }
    let world: Vec3 = (s.to_world * s.sun_local).normalize().as_vec3();
    Some(Light::Sun {
        direction: -world,
        radiance,
        half_aperture: (s.sun_aperture * 0.5) as f32,
        profile,
    })
}

/// The lights of `s`: the baked sky (unless black) and the sun (unless
/// black); none when the sun is below the horizon (Mitsuba's emitter is
/// black then).
pub fn lights(
    s: &SunSky,
    add_bitmap: &mut impl FnMut(Bitmap) -> cmlt::scene::BitmapId,
) -> Vec<Light> {
    let mut out = Vec::new();
    if s.sun_local.z < 0.0 {
        return out;
    }
    if s.sky_scale > 0.0 {
        let (bitmap, to_world) = bake_sky(s, SKY_WIDTH, SKY_HEIGHT);
        out.push(Light::Envmap {
            bitmap: add_bitmap(bitmap),
            scale: 1.0,
            to_world,
        });
    }
    out.extend(sun_light(s));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sunsky(turbidity: f64, albedo: f64, sun: [f64; 3]) -> SunSky {
        SunSky {
            turbidity,
            albedo: [albedo; 3],
            sun_local: DVec3::from(sun).normalize(),
            sun_scale: 1.0,
            sky_scale: 1.0,
            sun_aperture: 0.5358,
            complex_sun: false,
            to_world: DMat3::IDENTITY,
        }
    }

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        a.iter()
            .zip(b)
            .all(|(x, y)| (x - y).abs() <= tol * y.abs().max(1e-3))
    }

    /// The sky's radiance against Mitsuba 3.9.1's own `sunsky` (scalar_rgb,
    /// `emitter.eval` along these directions, values printed by the
    /// package): zenith, horizon, the aureole next to the sun, below the
    /// horizon, for two atmospheres. Any slip in the data's layout, the
    /// interpolation or the formula moves these by far more than 1e-4.
    #[test]
    fn sky_matches_mitsuba() {
        /// A direction and Mitsuba's radiance along it.
        type Seen = ([f64; 3], [f64; 3]);
        let cases: [(SunSky, &[Seen]); 2] = [
            (
                sunsky(3.0, 0.3, [0.3, 0.2, 0.6]),
                &[
                    ([0.0, 0.0, 1.0], [0.035132058, 0.055181347, 0.10501389]),
                    ([1.0, 0.0, 0.05], [0.16537689, 0.22496219, 0.29140681]),
                    ([-0.4, 0.5, 0.3], [0.047798362, 0.086071663, 0.15901458]),
                    ([0.3, 0.2, 0.62], [0.15666626, 0.18632774, 0.21895139]),
                    ([0.29, 0.21, 0.6], [0.15695794, 0.18678971, 0.22033571]),
                    ([0.0, -1.0, 0.2], [0.082220115, 0.13417350, 0.21798086]),
                    ([0.5, 0.5, -0.2], [0.0, 0.0, 0.0]),
                ],
            ),
            (
                sunsky(7.5, 0.8, [-0.8, 0.1, 0.12]),
                &[
                    ([0.0, 0.0, 1.0], [0.013633034, 0.020677406, 0.030057849]),
                    ([-0.8, 0.1, 0.2], [0.93129408, 0.61425656, 0.25725695]),
                    ([0.7, 0.7, 0.1], [0.066596702, 0.070284717, 0.059963491]),
                    ([0.0, 1.0, 0.01], [0.053653043, 0.042335257, 0.026829410]),
                ],
            ),
        ];
        for (s, dirs) in cases {
            let m = SkyModel::new(&s);
            for &(d, want) in dirs {
                let got = m.radiance(DVec3::from(d).normalize());
                assert!(close(got, want, 2e-4), "{d:?}: {got:?} vs Mitsuba {want:?}");
            }
        }
    }

    /// The sun disc's radiance against Mitsuba's (sky off, looking at the
    /// sun's centre), at the default aperture and at 2°: the same
    /// irradiance spread over a larger disc. Mitsuba computes 1 − cos α in
    /// f32 (α ≈ 0.0047 rad: cos α rounds to 6e-8, 0.5 % of 1 − cos α), so
    /// the tolerance is 1 %; a wrong table index or constant is off by
    /// more (neighbouring elevations differ by 2–10 %).
    #[test]
    fn sun_matches_mitsuba() {
        for (s, want) in [
            (
                sunsky(3.0, 0.3, [0.3, 0.2, 0.6]),
                [21850.881, 18281.656, 14052.230],
            ),
            (
                SunSky {
                    sun_aperture: 2.0,
                    ..sunsky(7.5, 0.3, [-0.8, 0.1, 0.12])
                },
                [394.91138, 208.46579, 66.557144],
            ),
        ] {
            let Some(Light::Sun {
                radiance,
                half_aperture,
                direction,
                profile: None,
            }) = sun_light(&s)
            else {
                panic!("no sun");
            };
            let got = [radiance.r as f64, radiance.g as f64, radiance.b as f64];
            assert!(close(got, want, 1e-2), "{got:?} vs Mitsuba {want:?}");
            assert!((half_aperture as f64 - s.sun_aperture / 2.0).abs() < 1e-6);
            assert!((-direction.as_dvec3() - s.sun_local).length() < 1e-6);
        }
        // Below the horizon: no sun, no sky (Mitsuba's emitter is black).
        let low = sunsky(3.0, 0.3, [0.3, 0.2, -0.1]);
        assert!(sun_light(&low).is_none());
        assert_eq!(SkyModel::new(&low).radiance(DVec3::Z), [0.0; 3]);
    }

    /// The sun's position from time and place against Mitsuba's (its
    /// `sun_direction` after loading): Paris at the 2024 equinox, 10:30,
    /// and the defaults (Tokyo, 10 July 2010, 15:00). Mitsuba computes in
    /// f32 (its Julian day resolves about 20 s, 0.1° of the sun's travel).
    #[test]
    fn sun_position_matches_mitsuba() {
        let paris = TimePlace {
            latitude: 48.0,
            longitude: 2.3,
            timezone: 1.0,
            year: 2024,
            month: 3,
            day: 21,
            hour: 10.5,
            ..TimePlace::default()
        };
        for (t, want) in [
            (paris, [0.587496, -0.601175, 0.541699]),
            (TimePlace::default(), [0.0513854, 0.691748, 0.720308]),
        ] {
            let got = sun_from_time(&t);
            let angle = got.angle_between(DVec3::from(want)).to_degrees();
            assert!(angle < 0.15, "{got:?} vs {want:?}: {angle}°");
        }
    }

    /// The baked map against the analytic sky it stands for, over a fine
    /// grid of directions on the whole sphere: its power (∫ L dω), the
    /// irradiance on the ground (∫ L cos θ dω over the upper hemisphere)
    /// and the mean absolute error of the radiance, for a high and a low
    /// sun. Prints the figures (`cargo test -- --nocapture`); the bounds
    /// are what the chosen resolution achieves with margin (the mean error
    /// is mostly the one-row ramp across the horizon; without the
    /// horizon row's half value the power is 1 % high at this size).
    #[test]
    fn baked_sky_matches_the_model() {
        use cmlt::scene::envmap::EnvMap;
        for sun in [[0.3, 0.2, 0.6], [-0.8, 0.1, 0.05]] {
            let s = sunsky(3.0, 0.3, sun);
            let model = SkyModel::new(&s);
            let (bitmap, to_world) = bake_sky(&s, SKY_WIDTH, SKY_HEIGHT);
            let env = EnvMap::new(&bitmap, 1.0, to_world).unwrap();
            let (n_phi, n_z) = (720, 1440);
            let (mut p_map, mut p_model, mut e_map, mut e_model, mut abs_err) =
                (0.0, 0.0, 0.0, 0.0, 0.0);
            for i in 0..n_phi {
                for j in 0..n_z {
                    // cos θ uniform in (−1, 1): equal solid angles.
                    let z = -1.0 + 2.0 * (j as f64 + 0.5) / n_z as f64;
                    let phi = std::f64::consts::TAU * (i as f64 + 0.5) / n_phi as f64;
                    let r = (1.0 - z * z).sqrt();
                    let d = DVec3::new(r * phi.cos(), r * phi.sin(), z);
                    let want = model.radiance(d)[1];
                    let got = env.eval(d.as_vec3()).g as f64;
                    p_map += got;
                    p_model += want;
                    if z > 0.0 {
                        e_map += got * z;
                        e_model += want * z;
                    }
                    abs_err += (got - want).abs();
                }
            }
            let (power, irr, mae) = (
                p_map / p_model - 1.0,
                e_map / e_model - 1.0,
                abs_err / p_model,
            );
            eprintln!(
                "sun {sun:?}: {SKY_WIDTH}x{SKY_HEIGHT} map, power error {power:.3e}, ground irradiance error {irr:.3e}, mean |ΔL|/mean L {mae:.3e}"
            );
            assert!(
                power.abs() < 2e-3 && irr.abs() < 2e-3 && mae < 2e-2,
                "{power} {irr} {mae}"
            );
        }
    }

    /// A direction `f` radii from the sun's centre (`f` < 0: the other
    /// way), towards the zenith or (`side`) horizontally: the points the
    /// Mitsuba values below were taken at.
    fn across_disc(s: &SunSky, f: f64, side: bool) -> DVec3 {
        let (v, h) = disc_axes(s.sun_local);
        let a = f * (s.sun_aperture * 0.5).to_radians();
        s.sun_local * a.cos() + if side { h } else { v } * a.sin()
    }

    /// Sun-only `sunsky`s with `complex_sun` as Mitsuba 3.9.1 was given
    /// them, and its `emitter.eval` (scalar_rgb, sky_scale 0) at the
    /// centre, half a radius up and down, 0.9 radii up, down and sideways
    /// ([`across_disc`]): a high sun, a low one at another turbidity,
    /// a 1° aperture and a sun 1° up whose disc spans two segments of the
    /// model (and whose blue is negative there).
    #[allow(clippy::type_complexity)]
    fn mitsuba_complex_suns() -> Vec<(SunSky, Vec<(f64, bool, [f64; 3])>)> {
        let sun = |turbidity: f64, dir: [f64; 3], aperture: f64| SunSky {
            sun_aperture: aperture,
            complex_sun: true,
            sky_scale: 0.0,
            ..sunsky(turbidity, 0.3, dir)
        };
        let e1 = 1f64.to_radians();
        vec![
            (
                sun(2.0, [e1.cos(), 0.0, e1.sin()], 0.5358),
                vec![
                    (0.0, false, [4037.5847, 846.72443, -107.29343]),
                    (0.5, false, [4128.0688, 901.0058, -105.99438]),
                    (-0.5, false, [3440.802, 676.4068, -94.795242]),
                    (0.9, false, [3299.7537, 710.21478, -84.496849]),
                    (-0.9, false, [2374.1538, 422.74966, -67.354385]),
                    (0.9, true, [2831.8914, 557.04736, -77.092056]),
                ],
            ),
            (
                sun(3.0, [0.3, 0.2, 0.6], 0.5358),
                vec![
                    (0.0, false, [26340.289, 22867.713, 18595.379]),
                    (0.5, false, [24739.492, 21205.197, 16905.375]),
                    (-0.5, false, [24732.205, 21193.748, 16886.859]),
                    (0.9, false, [18733.473, 15105.847, 10906.834]),
                    (-0.9, false, [18723.199, 15090.872, 10885.013]),
                    (0.9, true, [18727.633, 15097.654, 10895.267]),
                ],
            ),
            (
                sun(6.5, [-0.8, 0.1, 0.087], 0.5358),
                vec![
                    (0.0, false, [5883.3867, 2797.4807, 618.83417]),
                    (0.5, false, [5695.2656, 2707.9329, 601.74567]),
                    (-0.5, false, [5337.1729, 2477.5769, 515.80505]),
                    (0.9, false, [4389.6162, 1991.0175, 395.63571]),
                    (-0.9, false, [3903.9736, 1696.609, 297.37982]),
                    (0.9, true, [4147.8667, 1842.6071, 344.79065]),
                ],
            ),
            (
                sun(3.0, [0.2, -0.9, 0.35], 1.0),
                vec![
                    (0.0, false, [6516.1865, 5010.6787, 3076.2085]),
                    (0.5, false, [6134.6621, 4668.0562, 2822.9641]),
                    (-0.5, false, [6099.501, 4619.9282, 2763.4517]),
                    (0.9, false, [4648.1372, 3335.1689, 1829.6898]),
                    (-0.9, false, [4599.7866, 3273.3652, 1760.3129]),
                    (0.9, true, [4624.3467, 3304.6995, 1795.3394]),
                ],
            ),
        ]
    }

    /// The complex sun's model ([`complex_sun_radiance`], f64) against
    /// Mitsuba's values, negative blue included: 3e-4 at the default
    /// aperture (Mitsuba's f32 γ near the rim), 1 % at 1° (Mitsuba's f32
    /// 1 − cos α, as for the uniform sun). A wrong segment, power of x or
    /// of μ, or turbidity level moves them by percents.
    #[test]
    fn complex_sun_model_matches_mitsuba() {
        for (s, points) in mitsuba_complex_suns() {
            let tol = if s.sun_aperture == 0.5358 { 3e-4 } else { 1e-2 };

            for (f, side, want) in points {
                let got = complex_sun_radiance(&s, across_disc(&s, f, side));
                assert!(
                    close(got, want, tol),
                    "sun {:?} at {f} {side}: {got:?} vs Mitsuba {want:?}",
                    s.sun_local
                );
            }
        }
    }

    /// The light cmlt renders (the core's [`Light::Sun`] with the fitted
    /// profile, evaluated as a path would see it) against Mitsuba's values,
    /// with channels below zero (Mitsuba's, cmlt clamps) compared as zero.
    /// Tolerance 1e-3 at the default aperture (measured: 2e-4 at worst,
    /// the sun 1° up whose fit spans two segments), 1 % at 1° (Mitsuba's
    /// f32 1 − cos α; measured 2.5e-3). Negative control: the uniform disc of the same sun is
    /// 10–40 % off at these points and fails.
    #[test]
    fn complex_sun_light_matches_mitsuba() {
        use cmlt::scene::light::LightSet;
        for (s, points) in mitsuba_complex_suns() {
            let light = sun_light(&s).expect("a sun");
            assert!(light.validate().is_ok());
            let set = LightSet::new(&[], &[light]);
            let uniform = LightSet::new(
                &[],
                &[sun_light(&SunSky {
                    complex_sun: false,
                    ..s
                })
                .expect("a sun")],
            );
            let (mut worst, mut uniform_worst) = (0.0f64, 0.0f64);
            for (f, side, want) in points {
                let w = across_disc(&s, f, side).as_vec3();
                let want = want.map(|v| v.max(0.0));
                // Relative error per channel, a clamped (zero) channel
                // against 1 % of red, the largest.
                let err = |l: Rgb| {
                    (0..3)
                        .map(|c| (l[c] as f64 - want[c]).abs() / want[c].max(0.01 * want[0]))
                        .fold(0.0, f64::max)
                };
                worst = worst.max(err(set.radiance(0, w)));
                uniform_worst = uniform_worst.max(err(uniform.radiance(0, w)));
            }
            eprintln!(
                "complex sun {:?}, turbidity {}, aperture {}: worst error vs Mitsuba {worst:.2e} (uniform disc {uniform_worst:.2e})",
                s.sun_local, s.turbidity, s.sun_aperture
            );
            let tol = if s.sun_aperture == 0.5358 { 1e-3 } else { 1e-2 };
            assert!(worst < tol, "{worst}");
            assert!(
                uniform_worst > 0.1,
                "the uniform disc passes: {uniform_worst}"
            );
        }
    }

    /// The fitted profile as the core evaluates it against the model
    /// ([`complex_sun_radiance`], negatives clamped) over a 41 × 41 grid
    /// across the disc, for suns from 0.1° (half the disc below the
    /// horizon) to 89.9° and two apertures: the worst error relative to
    /// the disc's brightest channel at its centre, and ∫ L dω against the
    /// model's. Low suns whose disc spans several of the model's segments
    /// are where a single cubic in elevation is least exact; the figures
    /// are printed and the bounds are what they reach with margin.
    #[test]
    fn complex_sun_profile_matches_the_model() {
        use cmlt::scene::light::LightSet;
        for aperture in [0.5358, 2.0] {
            for elevation in [0.1, 0.3, 1.0, 2.0, 5.76, 10.0, 30.0, 60.0, 89.9f64] {
                let e = elevation.to_radians();
                let s = SunSky {
                    sun_aperture: aperture,
                    complex_sun: true,
                    sky_scale: 0.0,
                    ..sunsky(4.0, 0.3, [e.cos() * 0.6, e.cos() * 0.8, e.sin()])
                };
                let set = LightSet::new(&[], &[sun_light(&s).expect("a sun")]);
                let peak = complex_sun_radiance(&s, s.sun_local)
                    .into_iter()
                    .fold(0.0, f64::max);
                let (v, h) = disc_axes(s.sun_local);
                let half = (aperture * 0.5).to_radians();
                let n = 41;
                let (mut worst, mut p_model, mut p_light) = (0.0f64, [0.0f64; 3], [0.0f64; 3]);
                for i in 0..n {
                    for j in 0..n {
                        let x = half * (2.0 * (i as f64 + 0.5) / n as f64 - 1.0);
                        let y = half * (2.0 * (j as f64 + 0.5) / n as f64 - 1.0);
                        let w = (s.sun_local + v * x + h * y).normalize();
                        let want = complex_sun_radiance(&s, w).map(|c| c.max(0.0));
                        let got = set.radiance(0, w.as_vec3());
                        for c in 0..3 {
                            worst = worst.max((got[c] as f64 - want[c]).abs() / peak);
                            p_model[c] += want[c];
                            p_light[c] += got[c] as f64;
                        }
                    }
                }
                let power = (0..3)
                    .map(|c| (p_light[c] / p_model[c] - 1.0).abs())
                    .fold(0.0, f64::max);
                eprintln!(
                    "aperture {aperture}°, sun {elevation}° up: worst |ΔL| / peak {worst:.2e}, power error {power:.2e}"
                );
                assert!(worst < 2e-2 && power < 5e-3, "{worst} {power}");
            }
        }
    }

    /// The complex sun's irradiance on a surface facing it, ∫ L dω over
    /// the disc, against Mitsuba's: the mean of `sample_direction`'s
    /// weights (L / pdf, the sky off so every sample is on the sun) over a
    /// 300 × 300 grid of samples, for the suns of
    /// [`mitsuba_complex_suns`]. cmlt's is the light's radiance (the
    /// disc's mean) times the disc's solid angle; Mitsuba's negative blue
    /// of the sun 1° up is 0 here. Tolerance 3e-3 (measured 8.5e-4 at
    /// worst): Mitsuba's sampling density takes 1 − cos α in f32, whose
    /// cos α near 1 resolves 0.5 % of 1 − cos α at 0.27°; 1 % at the 1°
    /// aperture, as elsewhere. It is not the uniform disc's
    /// (Mitsuba's second figure, taken the same way): the two come from
    /// different tables and part at a low sun (−40 % red at 1°, +15 %
    /// blue at 6°), so an implementation that scaled the profile to the
    /// uniform disc's irradiance fails here.
    #[test]
    fn complex_sun_irradiance_matches_mitsuba() {
        let want: [([f64; 3], [f64; 3]); 4] = [
            (
                [0.22860521, 0.04664766, -0.00611662],
                [0.38366103, 0.10707566, -0.00594049],
            ),
            (
                [1.50079194, 1.25609672, 0.96598965],
                [1.4975456, 1.25292945, 0.9630667],
            ),
            (
                [0.33377656, 0.15350816, 0.03147397],
                [0.32853374, 0.15544155, 0.03619415],
            ),
            (
                [1.2934818, 0.95907649, 0.55599015],
                [1.2913059, 0.95689386, 0.55423653],
            ),
        ];
        for ((s, _), (complex, uniform)) in mitsuba_complex_suns().into_iter().zip(want) {
            let Some(Light::Sun {
                radiance,
                profile: Some(_),
                ..
            }) = sun_light(&s)
            else {
                panic!("no complex sun");
            };
            let half = (s.sun_aperture * 0.5).to_radians();
            let omega = std::f64::consts::TAU * 2.0 * (half * 0.5).sin().powi(2);
            let got = [0, 1, 2].map(|c| radiance[c] as f64 * omega);
            let tol = if s.sun_aperture == 0.5358 { 3e-3 } else { 1e-2 };
            let complex = complex.map(|v| v.max(0.0));
            eprintln!(
                "complex sun {:?}: irradiance {got:?}, Mitsuba {complex:?} (uniform disc {uniform:?})",
                s.sun_local
            );
            for c in 0..3 {
                let scale = complex[c].max(0.01 * complex[0]);
                assert!(
                    (got[c] - complex[c]).abs() < tol * scale,
                    "channel {c}: {got:?} vs Mitsuba {complex:?}"
                );
            }
        }
    }
}

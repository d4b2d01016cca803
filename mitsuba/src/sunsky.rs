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
//! **In cmlt** the sky becomes a [`Light::Envmap`] baked at
//! [`SKY_WIDTH`] × [`SKY_HEIGHT`] texels, its poles on the sky's zenith
//! and nadir so that a row lies on the horizon, and the sun a
//! [`Light::Sun`] disc (a 0.27° disc would be blurred away in a map of any
//! reasonable size). The map's error against the analytic sky is measured
//! by `baked_sky_matches_the_model` below.

use glam::{DMat3, DVec3, Mat3, Vec3};

use cmlt::math::Rgb;
use cmlt::scene::{Bitmap, Light};

/// The packed RGB model data (see the module docs).
static DATA: &[u8] = include_bytes!("../data/sunsky_rgb.bin");
const MAGIC: &[u8; 8] = b"CMLTSKY1";
const TURBIDITIES: usize = 10;
const CTRL: usize = 6;
const PARAMS: usize = 9;
const SUN_ELEVATIONS: usize = 30;
const SKY_PARAMS_OFFSET: usize = 0;
const SKY_RAD_OFFSET: usize = TURBIDITIES * 2 * CTRL * 3 * PARAMS;
const SUN_OFFSET: usize = SKY_RAD_OFFSET + TURBIDITIES * 2 * CTRL * 3;
const VALUES: usize = SUN_OFFSET + TURBIDITIES * SUN_ELEVATIONS * 3;
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

/// The sun as a [`Light::Sun`], `None` when it is black or below the
/// horizon.
pub fn sun_light(s: &SunSky) -> Option<Light> {
    if s.sun_local.z < 0.0 || s.sun_scale == 0.0 {
        return None;
    }
    let half = (s.sun_aperture * 0.5).to_radians();
    // 1 − cos α = 2 sin²(α/2).
    let omega = std::f64::consts::TAU * 2.0 * (half * 0.5).sin().powi(2);
    let e = sun_irradiance(s.turbidity, s.sun_local);
    let l = |c: usize| (s.sun_scale * e[c] / omega).max(0.0) as f32;
    let radiance = Rgb::new(l(0), l(1), l(2));
    if radiance.is_black() {
        return None;
    }
    let world: Vec3 = (s.to_world * s.sun_local).normalize().as_vec3();
    Some(Light::Sun {
        direction: -world,
        radiance,
        half_aperture: (s.sun_aperture * 0.5) as f32,
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
}

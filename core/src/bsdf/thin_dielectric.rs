//! Infinitely thin dielectric slab (Mitsuba 3's `thindielectric`): a window
//! pane. Light bouncing inside the slab leaves on either side; summing the
//! geometric series of internal reflections (each with the same Fresnel
//! reflectance R, since both faces are parallel) gives the slab's
//! reflectance R' = R + T²R/(1 − R²) with T = 1 − R, and everything else,
//! 1 − R', is transmitted. Transmission is not bent: the two refractions
//! cancel, so the direction is −wo (η = 1 for the path).

use glam::Vec3;

use super::{BsdfSample, fresnel};
use crate::math::Rgb;

/// The slab's total reflectance R' for |cos θ| = `cos` and relative index
/// `eta` (symmetric: both sides are alike).
pub(super) fn reflectance(cos: f32, eta: f32) -> f32 {
    let r = fresnel::dielectric(cos.abs(), eta).reflectance;
    if r < 1.0 {
        let t = 1.0 - r;
        r + t * t * r / (1.0 - r * r)
    } else {
        1.0
    }
}

/// Reflection with probability R', straight transmission with 1 − R':
/// throughput weight = the tint of the chosen lobe.
pub(super) fn sample(
    eta: f32,
    reflect_tint: Rgb,
    transmit_tint: Rgb,
    wo: Vec3,
    u_lobe: f32,
) -> Option<BsdfSample> {
    let c = wo.z.abs();
    if c == 0.0 {
        return None;
    }
    let r = reflectance(c, eta);
    let (wi, pdf, tint) = if u_lobe < r {
        (Vec3::new(-wo.x, -wo.y, wo.z), r, reflect_tint)
    } else {
        (-wo, 1.0 - r, transmit_tint)
    };
    (pdf > 0.0).then(|| BsdfSample {
        wi,
        f: tint * (pdf / c),
        pdf,
        delta: true,
        eta: 1.0,
    })
}

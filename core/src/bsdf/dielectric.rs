//! Smooth dielectric interface (Mitsuba's `dielectric`): Dirac reflection
//! and refraction, lobe chosen in proportion to the Fresnel reflectance.

use glam::Vec3;

use super::{BsdfSample, TransportMode, fresnel};
use crate::math::Rgb;

/// Samples reflection with probability F and refraction with 1 − F, so the
/// throughput weight is the lobe's tint (Mitsuba's `specular_reflectance`
/// or `specular_transmittance`, 1 for clear glass), times 1/η² for
/// refracted radiance. `eta` = η_inside/η_outside; `wo.z < 0` means `wo`
/// is inside.
pub(super) fn sample(
    eta: f32,
    tints: (Rgb, Rgb),
    wo: Vec3,
    u_lobe: f32,
    mode: TransportMode,
) -> Option<BsdfSample> {
    let cos_o = wo.z;
    // Exactly edge-on, F = 1 and f = F/|cos θ| is infinite; nothing enters.
    if cos_o == 0.0 {
        return None;
    }
    let fr = fresnel::dielectric(cos_o, eta);
    let f_r = fr.reflectance;
    if u_lobe < f_r {
        // Mirror about the normal (on the same side as wo).
        let wi = Vec3::new(-wo.x, -wo.y, wo.z);
        // f = weight · pdf / |cos θi| with weight 1, pdf F.
        return Some(BsdfSample {
            wi,
            f: tints.0 * (f_r / cos_o.abs()),
            pdf: f_r,
            delta: true,
            eta: 1.0,
        });
    }
    let pdf = 1.0 - f_r;
    if pdf <= 0.0 || fr.cos_t == 0.0 {
        return None;
    }
    let wi = if eta == 1.0 {
        // Index-matched: exactly straight through.
        -wo
    } else {
        // Snell's law: tangential components scale by η_i/η_t, the normal
        // component is cos θt on the far side (Mitsuba's `refract`).
        Vec3::new(-fr.eta_ti * wo.x, -fr.eta_ti * wo.y, fr.cos_t)
    };
    // Radiance is compressed by (η_t/η_i)² on entering a denser medium
    // (Veach 1997, §5.2); importance is not, so the adjoint BSDF lacks the
    // factor.
    let scale = match mode {
        TransportMode::Radiance => fr.eta_ti * fr.eta_ti,
        TransportMode::Importance => 1.0,
    };
    Some(BsdfSample {
        wi,
        f: tints.1 * (pdf * scale / wi.z.abs()),
        pdf,
        delta: true,
        eta: fr.eta_it,
    })
}

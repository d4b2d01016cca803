//! Rough diffuse (Oren–Nayar) through every estimator on a scene with an
//! analytic answer: a `roughdiffuse` plane lit only by a directional light
//! of irradiance E, seen by a pinhole camera. Light arrives from one
//! direction ωi and bounces once (the open plane sees nothing else), so a
//! point's radiance towards the camera is f(ωo, ωi) · E · cos θi exactly,
//! with f from Oren and Nayar's published formula evaluated here in f64,
//! independently of the core's code.

use cmlt::integrator::Settings;
use cmlt::math::{Rgb, Vec3};
use cmlt::renderer::Estimator;
use cmlt::scene::{Effect, Light, Material, MaterialKind, Scene, SceneBuilder, Texture};

use super::lights::{
    assert_image, assert_quadrants, cmlt, expected_on_plane, mlt, plane, render, render_mlt,
};
use crate::common;

/// Oren–Nayar (1994) eqs. 30–32 from the angles of ωo and ωi to the normal
/// `n` (α = the larger, β = the smaller) and their azimuth difference,
/// with σ = Mitsuba's α/√2; `fast` is eq. 31 alone.
fn oren_nayar(rho: f64, alpha_mitsuba: f64, fast: bool, n: Vec3, wo: Vec3, wi: Vec3) -> f64 {
    use std::f64::consts::PI;
    let (n, wo, wi) = (n.as_dvec3(), wo.as_dvec3(), wi.as_dvec3());
    let (tr, ti) = (wo.dot(n).acos(), wi.dot(n).acos());
    let (po, pi) = (
        (wo - n * wo.dot(n)).normalize(),
        (wi - n * wi.dot(n)).normalize(),
    );
    let c = po.dot(pi);
    let s2 = alpha_mitsuba * alpha_mitsuba / 2.0;
    let (a, b) = (ti.max(tr), ti.min(tr));
    let c1 = 1.0 - 0.5 * s2 / (s2 + 0.33);
    let k = s2 / (s2 + 0.09);
    if fast {
        return rho / PI * (c1 + 0.45 * k * c.max(0.0) * a.sin() * b.tan());
    }
    let c2 = 0.45
        * k
        * if c >= 0.0 {
            a.sin()
        } else {
            a.sin() - (2.0 * b / PI).powi(3)
        };
    let c3 = 0.125 * k * (4.0 * a * b / (PI * PI)).powi(2);
    let l1 = rho / PI * (c1 + c * c2 * b.tan() + (1.0 - c.abs()) * c3 * ((a + b) / 2.0).tan());
    let l2 = 0.17 * rho * rho / PI * s2 / (s2 + 0.13) * (1.0 - c * (2.0 * b / PI).powi(2));
    (l1 + l2).max(0.0)
}

const RHO: f32 = 0.6;
const ALPHA: f32 = 0.8;
const E: f32 = 2.0;
/// The sun's travel direction: towards +z, obliquely (θi ≈ 58°), so the
/// roughness changes the image well beyond the noise.
const SUN: Vec3 = Vec3::new(0.8, -0.3, 0.5);

/// The plane of `roughdiffuse` under the sun, and each pixel's exact mean.
fn sunlit_rough_plane(fast: bool) -> (Scene, Vec<f32>) {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material {
        kind: MaterialKind::RoughDiffuse {
            reflectance: Texture::Constant(Rgb::splat(RHO)),
            alpha: ALPHA,
            fast_approx: fast,
        },
        two_sided: true,
        detail: Default::default(),
    });
    b.add_mesh(plane(m));
    b.add_light(Light::Directional {
        direction: SUN,
        irradiance: Rgb::splat(E),
    });
    b.set_camera(common::furnace_camera(Vec3::ZERO, 0.0));
    let scene = b.build().unwrap();
    assert!(
        scene
            .analysis(&scene.camera)
            .effects
            .contains(Effect::RoughDiffuse)
    );
    // The plane at z = PLANE_Z faces the camera: its normal is −z.
    let n = Vec3::NEG_Z;
    let wi = -SUN.normalize();
    let cos_i = wi.dot(n);
    let expected = expected_on_plane(&scene, |p| {
        let wo = (-p).normalize();
        (oren_nayar(RHO as f64, ALPHA as f64, fast, n, wo, wi) * (E * cos_i) as f64) as f32
    });
    assert!(expected.iter().all(|&v| v > 0.0));
    (scene, expected)
}

#[test]
fn sunlit_rough_plane_pt_and_bdpt() {
    for fast in [false, true] {
        let (scene, expected) = sunlit_rough_plane(fast);
        // A Lambertian plane would differ by far more than the tolerances:
        // the test sees the roughness.
        let lambert = RHO / std::f32::consts::PI * E * (-SUN.normalize()).z.abs();
        let off: f32 = expected
            .iter()
            .map(|e| (e - lambert).abs() / e)
            .sum::<f32>()
            / expected.len() as f32;
        assert!(
            off > 0.05,
            "fast={fast}: Oren–Nayar within {off} of Lambert"
        );
        let img = render(&scene, Estimator::Path, Settings::default(), 256);
        assert_image(&format!("fast={fast} PT"), &img, &expected, 0.005, 0.03);
        let img = render(&scene, Estimator::Bdpt, Settings::default(), 256);
        assert_image(&format!("fast={fast} BDPT"), &img, &expected, 0.01, 0.08);
    }
}

#[test]
fn sunlit_rough_plane_mlt_and_cmlt() {
    let (scene, expected) = sunlit_rough_plane(false);
    // The mean converges fast; the quadrants, which also see where the
    // chains spent their time, more slowly.
    let (img, _) = render_mlt(&scene, mlt(), 1024);
    assert_quadrants("MLT", &img, &expected, 0.01, 0.05);
    let (img, r) = render_mlt(&scene, cmlt(4, 2), 1024);
    assert!(r.stats.mlt.mutations > 0);
    assert_quadrants("CMLT", &img, &expected, 0.01, 0.05);
}

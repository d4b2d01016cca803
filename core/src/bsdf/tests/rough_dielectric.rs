//! Tests of the rough dielectric (`roughdielectric`): χ² fits of its
//! sampler inside and outside, agreement of `sample` with `eval`/`pdf`,
//! reflection reciprocity and the adjoint relation of refraction, energy
//! bounds and total internal reflection. Its refused parameters and its
//! ignoring `two_sided` are the material's (`scene::material` tests).

use super::*;

fn rough_glass(dist: Distribution, alpha: f32, eta: f32) -> Bsdf {
    tinted_glass(dist, alpha, eta, Rgb::ONE, Rgb::ONE)
}

fn tinted_glass(dist: Distribution, alpha: f32, eta: f32, refl: Rgb, trans: Rgb) -> Bsdf {
    Bsdf::rough_dielectric(dist, alpha, eta, (refl, trans))
}

/// Signed incident cosines: outside (positive) and inside (negative, where
/// the grazing one is past the critical angle of η = 1.5).
const COS_O_BOTH: [f32; 4] = [0.8, 0.3, -0.8, -0.3];
/// Roughnesses of the χ² tests: fairly smooth and rough.
const ALPHAS_RD: [f32; 2] = [0.1, 0.5];
/// χ² tests in this file: 2 distributions × 2 α × 4 angles, plus 2 with
/// η < 1 and 1 with a grazing `wo`.
const CHI2_RD_TESTS: usize = 2 * 2 * 4 + 3;

fn chi2_rd(name: &str, bsdf: Bsdf, wo: Vec3, seed: u64) {
    let alpha = chi2::sidak(SIGNIFICANCE, CHI2_RD_TESTS);
    let out = chi2::fit_bsdf(name, &bsdf, wo, SAMPLES, seed, alpha);
    // Both lobes together lose only the directions single scattering drops:
    // far more than half of the attempts return.
    assert!(out.integral > 0.8, "{name}: ∫pdf = {}", out.integral);
}

fn chi2_rd_dist(dist: Distribution) {
    for (j, &alpha) in ALPHAS_RD.iter().enumerate() {
        for (i, &c) in COS_O_BOTH.iter().enumerate() {
            chi2_rd(
                &format!("rough glass {dist:?} α={alpha} cosθo={c}"),
                rough_glass(dist, alpha, 1.5),
                dir(c, PHI_O),
                5000 + 10 * j as u64 + i as u64 + dist as u64 * 100,
            );
        }
    }
}

#[test]
fn chi2_rough_dielectric_ggx() {
    chi2_rd_dist(Distribution::Ggx);
    // A grazing view from outside.
    let bsdf = rough_glass(Distribution::Ggx, 0.3, 1.5);
    chi2_rd("rough glass GGX grazing", bsdf, dir(0.05, PHI_O), 5300);
}

#[test]
fn chi2_rough_dielectric_beckmann() {
    chi2_rd_dist(Distribution::Beckmann);
    // η < 1 (a bubble in water): total internal reflection from outside.
    for (i, c) in [0.6f32, -0.6].into_iter().enumerate() {
        let bsdf = rough_glass(Distribution::Beckmann, 0.3, 1.0 / 1.33);
        chi2_rd("rough bubble", bsdf, dir(c, PHI_O), 5400 + i as u64);
    }
}

#[test]
fn rough_dielectric_sample_matches_eval_and_pdf() {
    let mut rng = Pcg32::new(77, 1);
    let eta = 1.5;
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for alpha in [1e-3f32, 0.05, 0.3, 1.0] {
            let bsdf = rough_glass(dist, alpha, eta);
            assert!(!bsdf.is_delta() && bsdf.has_transmission());
            let (mut reflected, mut refracted) = (0, 0);
            for _ in 0..4000 {
                let wo = random_dir(&mut rng);
                let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
                let u_lobe = uniform(&mut rng);
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    let Some(s) = bsdf.sample(wo, u_lobe, u, mode) else {
                        continue;
                    };
                    let name = format!("{dist:?} α={alpha} wo={wo} wi={}", s.wi);
                    assert!(!s.delta, "{name}");
                    assert!((s.wi.length() - 1.0).abs() < 1e-5, "{name}");
                    let f = bsdf.eval(wo, s.wi, mode);
                    let pdf = bsdf.pdf(wo, s.wi);
                    assert!(rgb_close(s.f, f, 1e-6), "{name}: {:?} vs {f:?}", s.f);
                    assert!(close(s.pdf, pdf, 1e-6), "{name}: {} vs {pdf}", s.pdf);
                    assert!(s.pdf > 0.0 && s.f.is_finite(), "{name}");
                    if s.wi.z * wo.z > 0.0 {
                        reflected += 1;
                        assert_eq!(s.eta, 1.0, "{name}");
                    } else {
                        refracted += 1;
                        // η of the side entered over the side left.
                        let want = if wo.z > 0.0 { eta } else { 1.0 / eta };
                        assert_eq!(s.eta, want, "{name}");
                    }
                }
            }
            // Both lobes occur; refraction dominates for glass.
            assert!(
                refracted > reflected && reflected > 100,
                "{dist:?} α={alpha}: {reflected} reflected, {refracted} refracted"
            );
        }
    }
}

#[test]
fn rough_dielectric_reciprocity_and_adjoint() {
    let mut rng = Pcg32::new(9, 9);
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for (alpha, eta) in [(0.1f32, 1.5f32), (0.5, 1.5), (0.3, 1.0 / 1.33)] {
            let bsdf = rough_glass(dist, alpha, eta);
            let mut transmitting = 0;
            for _ in 0..4000 {
                let (wo, wi) = (random_dir(&mut rng), random_dir(&mut rng));
                let name = format!("{dist:?} α={alpha} η={eta} wo={wo} wi={wi}");
                // Near grazing incidence on the microfacet, 1 − F is
                // ill-conditioned in f32 (F has infinite slope there): both
                // orders are right to the rounding of wo·m, not to 1e-3.
                let e = if wo.z * wi.z > 0.0 {
                    1.0
                } else if wo.z > 0.0 {
                    eta
                } else {
                    1.0 / eta
                };
                let m = (wo + wi * e).normalize();
                if wo.dot(m).abs().min(wi.dot(m).abs()) < 0.02 {
                    continue;
                }
                let rad = bsdf.eval(wo, wi, TransportMode::Radiance);
                let rad_rev = bsdf.eval(wi, wo, TransportMode::Radiance);
                let imp = bsdf.eval(wo, wi, TransportMode::Importance);
                assert!(rad.is_finite() && rad.g >= 0.0, "{name}: {rad:?}");
                // The adjoint BSDF: importance through (wo, wi) is radiance
                // through (wi, wo).
                assert!(
                    rgb_close(imp, rad_rev, 1e-3),
                    "{name}: {imp:?} vs {rad_rev:?}"
                );
                if wo.z * wi.z > 0.0 {
                    // Reflection is reciprocal and mode-independent.
                    assert!(rgb_close(rad, rad_rev, 1e-3), "{name}");
                    assert!(rgb_close(rad, imp, 1e-6), "{name}");
                } else {
                    // Refraction: f(wo, wi)/η_wo² = f(wi, wo)/η_wi² (Veach
                    // 1997, eq. 5.14), here with η_outside = 1.
                    let (n_wo, n_wi) = if wo.z > 0.0 { (1.0, eta) } else { (eta, 1.0) };
                    let a = rad.g / (n_wo * n_wo);
                    let b = rad_rev.g / (n_wi * n_wi);
                    assert!(close(a, b, 1e-3), "{name}: {a} vs {b}");
                    transmitting += (a > 0.0) as u32;
                }
                let pdf = bsdf.pdf(wo, wi);
                assert!(pdf.is_finite() && pdf >= 0.0, "{name}: pdf {pdf}");
            }
            assert!(transmitting > 100, "{dist:?} α={alpha}: {transmitting}");
        }
    }
}

/// Energy: the fraction of the flux arriving from one direction that is
/// scattered (reflected plus refracted) is the importance-mode albedo
/// ∫ f*(wo, wi) |cos θi| dωi; it is at most 1, and close to 1 for a fairly
/// smooth surface seen near the normal (single scattering loses little).
/// The sampler's weights estimate the same integral.
#[test]
fn rough_dielectric_conserves_at_most_the_energy() {
    let mut rng = Pcg32::new(11, 11);
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for alpha in [0.05f32, 0.3, 1.0] {
            let bsdf = rough_glass(dist, alpha, 1.5);
            for c in [1.0f32, 0.5, 0.1, -1.0, -0.5, -0.1] {
                let wo = dir(c, PHI_O);
                let name = format!("{dist:?} α={alpha} cos={c}");
                let quad = chi2::integrate_sphere(
                    &|wi| (bsdf.eval(wo, wi, TransportMode::Importance).g * wi.z.abs()) as f64,
                    chi2::COUNT_TOL,
                );
                assert!(quad <= 1.0 + 1e-3, "{name}: albedo {quad}");
                if alpha <= 0.05 && c.abs() == 1.0 {
                    assert!(quad > 0.98, "{name}: albedo {quad}");
                }
                let n = 100_000;
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
                    let u_lobe = uniform(&mut rng);
                    if let Some(s) = bsdf.sample(wo, u_lobe, u, TransportMode::Importance) {
                        // Weight G1(wi) ≤ 1 (the lobe choice absorbs F).
                        let w = (s.f.g * s.wi.z.abs() / s.pdf) as f64;
                        assert!(w <= 1.0 + 1e-4, "{name}: weight {w}");
                        sum += w;
                        sum2 += w * w;
                    }
                }
                let mean = sum / n as f64;
                let sigma = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                assert!(
                    (mean - quad).abs() <= 5.0 * sigma + 2e-3,
                    "{name}: MC {mean} ± {sigma} vs cubature {quad}"
                );
            }
        }
    }
}

/// Radiance mode differs from importance only by 1/η² on refraction: from
/// outside into glass the refracted radiance albedo is the flux albedo's
/// refracted part over η².
#[test]
fn rough_dielectric_radiance_scale() {
    let eta = 1.5f32;
    let bsdf = rough_glass(Distribution::Ggx, 0.2, eta);
    let wo = dir(0.7, PHI_O);
    let part = |mode| {
        chi2::integrate_sphere(
            &|wi| {
                if wi.z < 0.0 {
                    (bsdf.eval(wo, wi, mode).g * wi.z.abs()) as f64
                } else {
                    0.0
                }
            },
            chi2::COUNT_TOL,
        )
    };
    let (rad, imp) = (
        part(TransportMode::Radiance),
        part(TransportMode::Importance),
    );
    assert!(imp > 0.5, "refracted flux {imp}");
    let want = imp / (eta * eta) as f64;
    assert!((rad - want).abs() < 1e-3 * want, "{rad} vs {want}");
}

#[test]
fn rough_dielectric_tints_and_total_internal_reflection() {
    let red = Rgb::new(1.0, 0.0, 0.0);
    let blue = Rgb::new(0.0, 0.0, 1.0);
    let bsdf = tinted_glass(Distribution::Ggx, 0.2, 1.5, red, blue);
    let wo = dir(0.7, PHI_O);
    let refl = bsdf.eval(
        wo,
        dir(0.7, PHI_O + core::f32::consts::PI),
        TransportMode::Radiance,
    );
    let trans = bsdf.eval(wo, -wo, TransportMode::Radiance);
    assert!(refl.r > 0.0 && refl.g == 0.0 && refl.b == 0.0, "{refl:?}");
    assert!(
        trans.b > 0.0 && trans.r == 0.0 && trans.g == 0.0,
        "{trans:?}"
    );

    // From inside, far past the critical angle (41.8° for η = 1.5) with a
    // fairly smooth Beckmann surface (whose microfacets never tilt the
    // 35° refraction would need; GGX's long tail does), every sample
    // reflects.
    let bsdf = rough_glass(Distribution::Beckmann, 0.02, 1.5);
    let wo = dir(-0.2, PHI_O);
    let mut rng = Pcg32::new(1, 2);
    let mut n = 0;
    for _ in 0..10_000 {
        let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
        if let Some(s) = bsdf.sample(wo, uniform(&mut rng), u, TransportMode::Radiance) {
            assert!(s.wi.z < 0.0 && s.eta == 1.0, "{s:?}");
            n += 1;
        }
    }
    assert!(n > 9000, "{n}");
}

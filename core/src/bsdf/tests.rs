//! Tests of the BSDF models: χ² fits of every sampler against its density,
//! consistency of `sample` with `eval`/`pdf`, reciprocity, energy bounds,
//! Fresnel values, and the dielectric's Snell / TIR / pass-through cases.

use glam::{Vec2, Vec3};
use rand_pcg::Pcg32;

use super::chi2::{self, uniform};
use super::microfacet::{Distribution, Microfacet};
use super::*;

// ---------------------------------------------------------------- helpers

fn diffuse(albedo: f32, two_sided: bool) -> Bsdf {
    Bsdf::diffuse(Rgb::splat(albedo), two_sided)
}

fn rough(
    distribution: Distribution,
    alpha: f32,
    fresnel: ConductorFresnel,
    two_sided: bool,
) -> Bsdf {
    Bsdf::rough_conductor(distribution, alpha, fresnel, Rgb::ONE, two_sided)
}

fn smooth_conductor(fresnel: ConductorFresnel, tint: Rgb, two_sided: bool) -> Bsdf {
    Bsdf::conductor(fresnel, tint, two_sided)
}

fn dielectric(eta: f32) -> Bsdf {
    Bsdf::dielectric(eta, (Rgb::ONE, Rgb::ONE))
}

/// Gold: approximate (η, k) at red, green and blue wavelengths.
fn gold() -> ConductorFresnel {
    ConductorFresnel::Complex {
        eta: Rgb::new(0.143, 0.374, 1.442),
        k: Rgb::new(3.983, 2.385, 1.603),
    }
}

/// Direction with cos θ = `cos_theta` at azimuth `phi`.
fn dir(cos_theta: f32, phi: f32) -> Vec3 {
    let s = libm::sqrtf((1.0 - cos_theta * cos_theta).max(0.0));
    Vec3::new(s * libm::cosf(phi), s * libm::sinf(phi), cos_theta)
}

fn random_dir(rng: &mut Pcg32) -> Vec3 {
    crate::math::warp::square_to_uniform_sphere(Vec2::new(uniform(rng), uniform(rng)))
}

fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-30
}

fn rgb_close(a: Rgb, b: Rgb, rel: f32) -> bool {
    close(a.r, b.r, rel) && close(a.g, b.g, rel) && close(a.b, b.b, rel)
}

const ALPHAS: [f32; 5] = [0.05, 0.1, 0.25, 0.5, 1.0];
/// Incident cosines for the χ² tests: normal, oblique, grazing.
const COS_O: [f32; 3] = [1.0, 0.5, 0.05];
/// Azimuth of wo: off the axes so binning symmetries cannot hide errors.
const PHI_O: f32 = 0.7;
const SAMPLES: usize = 1_000_000;
/// Every χ² test below, for the Šidák correction: diffuse 3 + 2 (from
/// below), rough 2 distributions × 5 α × 3 angles + 2 (from below).
const CHI2_TESTS: usize = 5 + 2 * 5 * 3 + 2;
/// Family-wise significance level.
const SIGNIFICANCE: f64 = 0.01;

/// χ² test of `bsdf.sample` against `bsdf.pdf` for one `wo`
/// ([`chi2::fit_bsdf`] at this file's family-wise significance).
fn chi2_bsdf(name: &str, bsdf: Bsdf, wo: Vec3, seed: u64) -> chi2::Chi2Outcome {
    let alpha = chi2::sidak(SIGNIFICANCE, CHI2_TESTS);
    chi2::fit_bsdf(name, &bsdf, wo, SAMPLES, seed, alpha)
}

fn chi2_rough(dist: Distribution, alpha: f32) {
    for (i, &c) in COS_O.iter().enumerate() {
        // Fresnel does not affect directions; Perfect keeps the test fast.
        let bsdf = rough(dist, alpha, ConductorFresnel::Perfect, false);
        let name = format!("{dist:?} α={alpha} cosθo={c}");
        chi2_bsdf(
            &name,
            bsdf,
            dir(c, PHI_O),
            1000 + i as u64 + (alpha * 1e4) as u64,
        );
    }
}

// ---------------------------------------------------------------- χ² fits

#[test]
fn chi2_diffuse() {
    for (i, &c) in COS_O.iter().enumerate() {
        let out = chi2_bsdf(
            &format!("diffuse cosθo={c}"),
            diffuse(0.8, false),
            dir(c, PHI_O),
            1 + i as u64,
        );
        assert!((out.integral - 1.0).abs() < 1e-4, "∫pdf = {}", out.integral);
    }
    // Two-sided, seen from below: the lobe must mirror to the lower side.
    for (i, c) in [-0.5f32, -0.05].into_iter().enumerate() {
        let out = chi2_bsdf(
            &format!("two-sided diffuse cosθo={c}"),
            diffuse(0.8, true),
            dir(c, PHI_O),
            10 + i as u64,
        );
        assert!((out.integral - 1.0).abs() < 1e-4, "∫pdf = {}", out.integral);
    }
}

#[test]
fn chi2_ggx_smooth() {
    for a in &ALPHAS[..2] {
        chi2_rough(Distribution::Ggx, *a);
    }
}

#[test]
fn chi2_ggx_rough() {
    for a in &ALPHAS[2..] {
        chi2_rough(Distribution::Ggx, *a);
    }
    let bsdf = rough(Distribution::Ggx, 0.25, gold(), true);
    chi2_bsdf("two-sided GGX from below", bsdf, dir(-0.5, PHI_O), 20);
}

#[test]
fn chi2_beckmann_005() {
    chi2_rough(Distribution::Beckmann, ALPHAS[0]);
}

#[test]
fn chi2_beckmann_01() {
    chi2_rough(Distribution::Beckmann, ALPHAS[1]);
}

#[test]
fn chi2_beckmann_025() {
    chi2_rough(Distribution::Beckmann, ALPHAS[2]);
    let bsdf = rough(Distribution::Beckmann, 0.25, gold(), true);
    chi2_bsdf("two-sided Beckmann from below", bsdf, dir(-0.5, PHI_O), 21);
}

#[test]
fn chi2_beckmann_05() {
    chi2_rough(Distribution::Beckmann, ALPHAS[3]);
}

#[test]
fn chi2_beckmann_1() {
    chi2_rough(Distribution::Beckmann, ALPHAS[4]);
}

/// Negative controls: the same test must reject densities that are wrong,
/// or the passes above prove nothing.
#[test]
fn chi2_rejects_wrong_densities() {
    let alpha = chi2::sidak(SIGNIFICANCE, CHI2_TESTS);
    let wo = dir(0.5, PHI_O);
    let sampler = |bsdf: Bsdf| {
        move |rng: &mut Pcg32| {
            let u = Vec2::new(uniform(rng), uniform(rng));
            bsdf.sample(wo, 0.5, u, TransportMode::Radiance)
                .map(|s| s.wi)
        }
    };
    let lambert = diffuse(1.0, false);

    // The right density scaled by 1.1.
    let out = chi2::run(SAMPLES, 7, sampler(lambert), |wi| {
        1.1 * lambert.pdf(wo, wi) as f64
    });
    assert!(!out.passes(alpha), "pdf × 1.1 accepted: {out}");

    // Cosine-weighted samples against the uniform-hemisphere density.
    let out = chi2::run(SAMPLES, 8, sampler(lambert), |wi| {
        if wi.z > 0.0 {
            1.0 / core::f64::consts::TAU
        } else {
            0.0
        }
    });
    assert!(!out.passes(alpha), "cosine vs uniform accepted: {out}");

    // GGX visible normals against the Beckmann density of the same α: the
    // lobes differ mainly in their tails.
    let ggx = rough(Distribution::Ggx, 0.25, gold(), false);
    let beckmann = rough(Distribution::Beckmann, 0.25, gold(), false);
    let out = chi2::run(SAMPLES, 9, sampler(ggx), |wi| beckmann.pdf(wo, wi) as f64);
    assert!(
        !out.passes(alpha),
        "GGX samples vs Beckmann pdf accepted: {out}"
    );

    // GGX samples against the density of sampling D(m) cos θm instead of
    // visible normals (the classic Walter 2007 sampler): differs in the
    // G1(wo) (wo·m)/cos θm factor, which matters most at grazing angles.
    let wo_g = dir(0.2, PHI_O);
    let mf = Microfacet::new(Distribution::Ggx, 0.5);
    let ggx = rough(Distribution::Ggx, 0.5, gold(), false);
    let out = chi2::run(
        SAMPLES,
        10,
        |rng| {
            ggx.sample(
                wo_g,
                0.5,
                Vec2::new(uniform(rng), uniform(rng)),
                TransportMode::Radiance,
            )
            .map(|s| s.wi)
        },
        |wi| {
            if wi.z <= 0.0 {
                return 0.0;
            }
            let m = (wo_g + wi).normalize();
            (mf.d(m) * m.z / (4.0 * wo_g.dot(m))) as f64
        },
    );
    assert!(
        !out.passes(alpha),
        "VNDF samples vs D·cos pdf accepted: {out}"
    );
}

// ----------------------------------------------------- microfacet identities

#[test]
fn microfacet_distributions_are_normalised() {
    // ∫ D(m) cos θm dm = 1 (projected microfacet area = macro area), and
    // ∫ G1(v, m) ⟨v·m⟩ D(m) dm = cos θv (Heitz 2014, eqs. 2 and 17): the
    // visible projected area equals the macrosurface's, which pins down Λ
    // independently of its closed form.
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for alpha in [0.05f32, 0.3, 1.0, 2.0] {
            let mf = Microfacet::new(dist, alpha);
            let norm = chi2::integrate_sphere(&|m| (mf.d(m) * m.z.max(0.0)) as f64, chi2::FINE_TOL);
            assert!(
                (norm - 1.0).abs() < 1e-4,
                "{dist:?} α={alpha}: ∫D cos = {norm}"
            );
            for c in [1.0f32, 0.7, 0.3, 0.05] {
                let v = dir(c, 0.4);
                let projected = chi2::integrate_sphere(
                    &|m| (mf.d(m) * v.dot(m).max(0.0)) as f64,
                    chi2::FINE_TOL,
                );
                let g1 = mf.g1(v, Vec3::Z) as f64; // any m facing v
                assert!(
                    (g1 * projected / c as f64 - 1.0).abs() < 1e-5,
                    "{dist:?} α={alpha} cos={c}: G1 {g1} × {projected} ≠ {c}"
                );
            }
        }
    }
}

// ------------------------------------------------ sample / eval / pdf agree

/// Every model with a non-delta lobe, with a label.
fn glossy_models() -> Vec<(String, Bsdf)> {
    let mut v = vec![
        ("diffuse".to_string(), diffuse(0.7, false)),
        ("diffuse 2s".to_string(), diffuse(0.7, true)),
    ];
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for a in ALPHAS.iter().copied().chain([1e-4, 1e-3, 2.0]) {
            v.push((format!("{dist:?} {a}"), rough(dist, a, gold(), false)));
            v.push((format!("{dist:?} {a} 2s"), rough(dist, a, gold(), true)));
        }
    }
    v
}

#[test]
fn sample_matches_eval_and_pdf() {
    let mut rng = Pcg32::new(42, 1);
    for (name, bsdf) in glossy_models() {
        let mut returned = 0;
        for _ in 0..2000 {
            let wo = random_dir(&mut rng);
            let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                let Some(s) = bsdf.sample(wo, uniform(&mut rng), u, mode) else {
                    continue;
                };
                returned += 1;
                assert!(!s.delta && s.eta == 1.0, "{name}");
                assert!(
                    (s.wi.length() - 1.0).abs() < 1e-5,
                    "{name}: |wi| = {}",
                    s.wi.length()
                );
                let f = bsdf.eval(wo, s.wi, mode);
                let pdf = bsdf.pdf(wo, s.wi);
                assert!(
                    rgb_close(s.f, f, 1e-6),
                    "{name}: sample f {:?} vs eval {f:?}",
                    s.f
                );
                assert!(
                    close(s.pdf, pdf, 1e-6),
                    "{name}: sample pdf {} vs pdf {pdf}",
                    s.pdf
                );
                assert!(
                    s.pdf > 0.0 && s.pdf.is_finite() && s.f.is_finite(),
                    "{name}: {s:?}"
                );
                // Reflection stays on wo's side.
                assert!(s.wi.z * wo.z > 0.0, "{name}: {wo} → {}", s.wi);
            }
        }
        // Two-sided models scatter from both sides, one-sided from one
        // (minus, for rough ones, reflections below the horizon).
        assert!(
            returned > if name.ends_with("2s") { 1500 } else { 750 },
            "{name}: {returned}"
        );
    }
}

#[test]
fn reflection_is_reciprocal() {
    let mut rng = Pcg32::new(3, 3);
    for (name, bsdf) in glossy_models() {
        for _ in 0..2000 {
            let (wo, wi) = (random_dir(&mut rng), random_dir(&mut rng));
            let a = bsdf.eval(wo, wi, TransportMode::Radiance);
            let b = bsdf.eval(wi, wo, TransportMode::Radiance);
            assert!(
                rgb_close(a, b, 1e-4),
                "{name}: f({wo}, {wi}) = {a:?} but reversed {b:?}"
            );
            assert!(
                a.is_finite() && a.r >= 0.0 && a.g >= 0.0 && a.b >= 0.0,
                "{name}: {a:?}"
            );
            let pdf = bsdf.pdf(wo, wi);
            assert!(pdf.is_finite() && pdf >= 0.0, "{name}: pdf {pdf}");
        }
    }
}

// ----------------------------------------------------------------- energy

#[test]
fn white_diffuse_conserves_energy() {
    for (bsdf, c) in [(diffuse(1.0, false), 0.3f32), (diffuse(1.0, true), -0.8)] {
        let wo = dir(c, 0.2);
        // Directional albedo ∫ f |cos θi| dωi by cubature, independent of the
        // sampler.
        let albedo = chi2::integrate_sphere(
            &|wi| (bsdf.eval(wo, wi, TransportMode::Radiance).g * wi.z.abs()) as f64,
            chi2::COUNT_TOL,
        );
        assert!((albedo - 1.0).abs() < 1e-5, "albedo {albedo}");
        let s = bsdf
            .sample(wo, 0.0, Vec2::new(0.3, 0.6), TransportMode::Radiance)
            .unwrap();
        assert!(close(s.f.g * s.wi.z.abs() / s.pdf, 1.0, 1e-5), "{s:?}");
    }
}

#[test]
fn rough_conductor_albedo_is_at_most_one() {
    let mut rng = Pcg32::new(5, 5);
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for alpha in [0.05f32, 0.25, 1.0] {
            let bsdf = rough(dist, alpha, ConductorFresnel::Perfect, false);
            for c in COS_O {
                let wo = dir(c, PHI_O);
                let quad = chi2::integrate_sphere(
                    &|wi| (bsdf.eval(wo, wi, TransportMode::Radiance).g * wi.z.abs()) as f64,
                    chi2::COUNT_TOL,
                );
                // Single scattering loses energy at high roughness and grazing
                // angles, never gains it; near-specular at normal incidence it
                // loses almost nothing.
                assert!(
                    quad <= 1.0 + 1e-4,
                    "{dist:?} α={alpha} cos={c}: albedo {quad}"
                );
                if alpha <= 0.05 && c == 1.0 {
                    assert!(quad > 0.995, "{dist:?} α={alpha}: albedo {quad}");
                }
                // The sampler's estimate agrees (weights F·G1(wi) ≤ 1, and 0
                // for failed samples).
                let n = 100_000;
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
                    if let Some(s) = bsdf.sample(wo, 0.5, u, TransportMode::Radiance) {
                        let w = (s.f.g * s.wi.z / s.pdf) as f64;
                        assert!(w <= 1.0 + 1e-5, "{dist:?} α={alpha}: weight {w}");
                        sum += w;
                        sum2 += w * w;
                    }
                }
                let mean = sum / n as f64;
                let sigma = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                assert!(
                    (mean - quad).abs() <= 5.0 * sigma + 1e-4,
                    "{dist:?} α={alpha} cos={c}: MC {mean} ± {sigma} vs cubature {quad}"
                );
            }
        }
    }
}

// ---------------------------------------------------------------- Fresnel

/// The textbook closed form for conductors (Moeller, *Optics*, 1988; also
/// pbrt-v3's `FrConductor`), in f64 as an independent reference.
fn conductor_reference(cos_i: f64, eta: f64, k: f64) -> f64 {
    let c2 = cos_i * cos_i;
    let s2 = 1.0 - c2;
    let t0 = eta * eta - k * k - s2;
    let a2b2 = (t0 * t0 + 4.0 * eta * eta * k * k).sqrt();
    let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
    let rs = (a2b2 + c2 - 2.0 * a * cos_i) / (a2b2 + c2 + 2.0 * a * cos_i);
    let t1 = a2b2 * c2 + s2 * s2;
    let t2 = 2.0 * a * cos_i * s2;
    let rp = rs * (t1 - t2) / (t1 + t2);
    0.5 * (rs + rp)
}

#[test]
fn conductor_fresnel_values() {
    let media = [
        (0.143f32, 3.983f32),
        (0.374, 2.385),
        (1.442, 1.603),
        (1.657, 9.224),
        (0.2, 3.9),
        (1.5, 0.0),
        (3.0, 0.5),
    ];
    for (eta, k) in media {
        // Normal incidence: ((η−1)² + k²)/((η+1)² + k²).
        let expect = ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k);
        let got = fresnel::conductor(1.0, eta, k);
        assert!(
            (got - expect).abs() < 1e-6,
            "η={eta} k={k}: {got} vs {expect}"
        );
        for i in 0..=100 {
            let c = i as f32 / 100.0;
            let got = fresnel::conductor(c, eta, k) as f64;
            let reference = if c == 0.0 {
                1.0
            } else {
                conductor_reference(c as f64, eta as f64, k as f64)
            };
            assert!(
                (got - reference).abs() < 2e-5,
                "η={eta} k={k} cos={c}: {got} vs {reference}"
            );
        }
        // A conductor without absorption is a dielectric.
        if k == 0.0 {
            for c in [0.1f32, 0.5, 0.9] {
                let d = fresnel::dielectric(c, eta).reflectance;
                assert!((fresnel::conductor(c, eta, k) - d).abs() < 1e-5);
            }
        }
    }
    // Mitsuba's "none" material is η = 0, k = 1, a perfect mirror.
    for c in [0.0f32, 0.3, 1.0] {
        assert!((fresnel::conductor(c, 0.0, 1.0) - 1.0).abs() < 1e-6);
    }
}

#[test]
fn dielectric_fresnel_values() {
    for eta in [1.5f32, 1.33, 2.4, 0.7] {
        let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
        // Normal incidence, from either side.
        assert!((fresnel::dielectric(1.0, eta).reflectance - r0).abs() < 1e-6);
        assert!((fresnel::dielectric(-1.0, eta).reflectance - r0).abs() < 1e-6);
        // Brewster's angle tan θB = η_t/η_i: p-polarised reflectance
        // vanishes, so F = R_s/2 there; check against R_s computed directly.
        let tb = libm::atanf(eta);
        let (ci, si) = (libm::cosf(tb), libm::sinf(tb));
        let ct = libm::sqrtf(1.0 - si * si / (eta * eta));
        let rs = ((ci - eta * ct) / (ci + eta * ct)).powi(2);
        assert!((fresnel::dielectric(ci, eta).reflectance - 0.5 * rs).abs() < 1e-5);
    }
}

// ------------------------------------------------------ smooth conductor

#[test]
fn smooth_conductor_is_a_fresnel_mirror() {
    let tint = Rgb::new(0.9, 0.8, 0.7);
    for fr in [gold(), ConductorFresnel::Perfect] {
        let one_sided = smooth_conductor(fr, tint, false);
        let two_sided = smooth_conductor(fr, tint, true);
        assert!(
            one_sided.is_delta() && !one_sided.has_transmission() && one_sided.roughness() == 0.0
        );
        for c in [1.0f32, 0.6, 0.05] {
            let wo = dir(c, 1.1);
            let s = one_sided
                .sample(wo, 0.3, Vec2::new(0.2, 0.9), TransportMode::Radiance)
                .unwrap();
            assert!(s.delta && s.pdf == 1.0 && s.eta == 1.0);
            assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
            let weight = s.f * s.wi.z.abs() / s.pdf;
            let expect = match fr {
                ConductorFresnel::Complex { eta, k } => fresnel::conductor_rgb(c, eta, k) * tint,
                ConductorFresnel::Perfect => tint,
            };
            assert!(rgb_close(weight, expect, 1e-5), "{weight:?} vs {expect:?}");
            assert!(one_sided.eval(wo, s.wi, TransportMode::Radiance).is_black());
            assert_eq!(one_sided.pdf(wo, s.wi), 0.0);
            // From below: black one-sided, mirrored two-sided.
            let below = Vec3::new(wo.x, wo.y, -wo.z);
            assert!(
                one_sided
                    .sample(below, 0.3, Vec2::new(0.2, 0.9), TransportMode::Radiance)
                    .is_none()
            );
            let s2 = two_sided
                .sample(below, 0.3, Vec2::new(0.2, 0.9), TransportMode::Radiance)
                .unwrap();
            assert!((s2.wi - Vec3::new(-wo.x, -wo.y, -wo.z)).length() < 1e-6);
            assert!(rgb_close(s2.f, s.f, 1e-6));
        }
    }
}

// ------------------------------------------------------------- dielectric

/// The lobe's share of energy, f·|cos θi| = weight·pdf.
fn lobe_energy(s: &BsdfSample) -> f32 {
    s.f.g * s.wi.z.abs()
}

#[test]
fn dielectric_lobes_partition_energy_and_obey_snell() {
    for eta in [1.5f32, 1.0 / 1.5, 1.33, 0.8, 2.4] {
        let bsdf = dielectric(eta);
        assert!(bsdf.is_delta() && bsdf.has_transmission());
        for c in [1.0f32, 0.9, 0.5, 0.2, 0.05, -0.05, -0.3, -0.7, -1.0] {
            let wo = dir(c, 2.0);
            assert!(
                bsdf.eval(wo, -wo, TransportMode::Radiance).is_black() && bsdf.pdf(wo, -wo) == 0.0
            );
            let fr = fresnel::dielectric(c, eta);
            // Indices of the sides of wo and of the refracted wi.
            let (eta_o, eta_i) = if c > 0.0 { (1.0, eta) } else { (eta, 1.0) };
            for mode in [TransportMode::Importance, TransportMode::Radiance] {
                let r = bsdf.sample(wo, 0.0, Vec2::ZERO, mode);
                let t = bsdf.sample(wo, 1.0 - f32::EPSILON, Vec2::ZERO, mode);
                let mut energy = 0.0;
                if let Some(r) = r.filter(|r| r.wi.z * wo.z > 0.0) {
                    assert!(r.delta && r.eta == 1.0 && close(r.pdf, fr.reflectance, 1e-6));
                    assert!((r.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
                    assert!(
                        close(lobe_energy(&r) / r.pdf, 1.0, 1e-5),
                        "reflection weight"
                    );
                    energy += lobe_energy(&r);
                }
                if let Some(t) = t.filter(|t| t.wi.z * wo.z < 0.0) {
                    assert!(t.delta && close(t.pdf, 1.0 - fr.reflectance, 1e-6));
                    assert!(close(t.eta, eta_i / eta_o, 1e-6), "eta {}", t.eta);
                    assert!((t.wi.length() - 1.0).abs() < 1e-5);
                    // Snell: η_o sin θo = η_i sin θi, in the plane of incidence
                    // on the far side.
                    let (so, si) = (wo.truncate().length(), t.wi.truncate().length());
                    assert!(
                        (eta_o * so - eta_i * si).abs() < 1e-5,
                        "Snell: {eta_o}·{so} vs {eta_i}·{si}"
                    );
                    assert!(t.wi.truncate().dot(wo.truncate()) <= 0.0);
                    let radiance_scale = if mode == TransportMode::Radiance {
                        (eta_o / eta_i).powi(2)
                    } else {
                        1.0
                    };
                    assert!(
                        close(lobe_energy(&t) / t.pdf, radiance_scale, 1e-5),
                        "transmission weight"
                    );
                    energy += lobe_energy(&t) / radiance_scale;
                } else {
                    // Only total internal reflection may suppress refraction.
                    assert_eq!(fr.reflectance, 1.0, "η={eta} cos={c}");
                }
                assert!(
                    close(energy, 1.0, 1e-5),
                    "η={eta} cos={c} {mode:?}: R + T = {energy}"
                );
            }
        }
    }
}

#[test]
fn dielectric_total_internal_reflection() {
    // Inside glass the critical angle is asin(1/1.5); from outside a medium
    // with η < 1 behaves the same.
    for (eta, side) in [(1.5f32, -1.0f32), (1.0 / 1.5, 1.0)] {
        let bsdf = dielectric(eta);
        let critical = libm::asinf(1.0 / 1.5);
        for theta in [critical + 1e-3, 1.0, 1.4, 1.55] {
            let wo = Vec3::new(libm::sinf(theta), 0.0, side * libm::cosf(theta));
            for u in [0.0f32, 0.5, 0.999_999] {
                let s = bsdf
                    .sample(wo, u, Vec2::ZERO, TransportMode::Radiance)
                    .unwrap();
                assert!(
                    s.delta && s.pdf == 1.0 && s.wi.z * wo.z > 0.0,
                    "θ={theta}: {s:?}"
                );
                assert!(close(lobe_energy(&s), 1.0, 1e-5));
            }
        }
        // Just inside the critical angle refraction still happens.
        let theta = critical - 1e-2;
        let wo = Vec3::new(libm::sinf(theta), 0.0, side * libm::cosf(theta));
        let s = bsdf
            .sample(wo, 0.999_999, Vec2::ZERO, TransportMode::Radiance)
            .unwrap();
        assert!(s.wi.z * wo.z < 0.0 && s.f.is_finite());
    }
}

#[test]
fn index_matched_dielectric_passes_straight_through() {
    let bsdf = dielectric(1.0);
    let mut rng = Pcg32::new(9, 9);
    for c in [1.0f32, 0.5, 1e-3, -1e-3, -0.5, -1.0] {
        let wo = dir(c, 0.4);
        for _ in 0..100 {
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                let s = bsdf
                    .sample(wo, uniform(&mut rng), Vec2::ZERO, mode)
                    .unwrap();
                assert_eq!(s.wi, -wo);
                assert!(s.delta && s.pdf == 1.0 && s.eta == 1.0 && s.f.is_finite());
                assert!(close(lobe_energy(&s), 1.0, 1e-6));
            }
        }
    }
    // Exactly grazing has no well-defined throughput; it must not be NaN.
    assert!(
        bsdf.sample(Vec3::X, 0.5, Vec2::ZERO, TransportMode::Radiance)
            .is_none()
    );
}

// ------------------------------------------------------------- robustness

#[test]
fn near_specular_and_grazing_are_finite() {
    let mut rng = Pcg32::new(11, 11);
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for alpha in [1e-4f32, 1e-3, 1.0, 3.0] {
            let bsdf = rough(dist, alpha, ConductorFresnel::Perfect, false);
            for c in [1.0f32, 0.5, 0.05, 1e-3, 1e-6] {
                let wo = dir(c, PHI_O);
                let mut returned = 0;
                for _ in 0..5000 {
                    let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
                    if let Some(s) = bsdf.sample(wo, 0.5, u, TransportMode::Radiance) {
                        returned += 1;
                        assert!(
                            s.f.is_finite() && s.pdf.is_finite() && s.pdf > 0.0,
                            "{dist:?} α={alpha} c={c}: {s:?}"
                        );
                        assert!(s.wi.z > 0.0 && (s.wi.length() - 1.0).abs() < 1e-5);
                        let w = s.f.g * s.wi.z / s.pdf;
                        assert!(
                            (0.0..=1.0 + 1e-4).contains(&w),
                            "{dist:?} α={alpha} c={c}: weight {w}"
                        );
                    }
                    let wi = random_dir(&mut rng);
                    let (f, p) = (bsdf.eval(wo, wi, TransportMode::Radiance), bsdf.pdf(wo, wi));
                    assert!(f.is_finite() && p.is_finite() && p >= 0.0);
                }
                // A near-mirror reflects almost everything above the horizon
                // (only grazing incidence loses samples to the horizon).
                if alpha <= 1e-3 && c >= 0.05 {
                    assert!(returned > 4900, "{dist:?} α={alpha} c={c}: {returned}");
                }
            }
            // The exact mirror direction: D is largest there.
            let wo = dir(0.3, 0.1);
            let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
            assert!(
                bsdf.eval(wo, mirror, TransportMode::Radiance).is_finite()
                    && bsdf.pdf(wo, mirror).is_finite()
            );
        }
    }
}

#[test]
fn one_sided_models_are_black_from_below() {
    let below = dir(-0.6, 0.3);
    let above = dir(0.6, 2.0);
    for bsdf in [
        diffuse(0.5, false),
        rough(Distribution::Ggx, 0.3, gold(), false),
        rough(Distribution::Beckmann, 0.3, gold(), false),
    ] {
        for wi in [below, above, -above] {
            assert!(bsdf.eval(below, wi, TransportMode::Radiance).is_black());
            assert_eq!(bsdf.pdf(below, wi), 0.0);
        }
        assert!(
            bsdf.sample(below, 0.5, Vec2::new(0.5, 0.5), TransportMode::Radiance)
                .is_none()
        );
        // Transmission is never produced by the opaque models.
        assert!(bsdf.eval(above, -above, TransportMode::Radiance).is_black());
        assert!(!bsdf.is_delta() && !bsdf.has_transmission());
    }
}

#[test]
fn bsdf_stays_small() {
    fn is_copy<T: Copy>() {}
    is_copy::<Bsdf>();
    // Every path vertex holds one. The largest model is the rough plastic
    // (colours, weights and its 8-entry coating table, 60 bytes) and the
    // principled (a colour, seven f32 and four 16-bit weights, 48 bytes); a
    // normal-mapped frame adds the unperturbed normal for Mitsuba's side
    // test.
    assert!(
        core::mem::size_of::<Bsdf>() <= 72,
        "{}",
        core::mem::size_of::<Bsdf>()
    );
}

// The rough dielectric's tests live in their own file.
#[cfg(feature = "rough-refraction")]
mod rough_dielectric;

// The principled BSDF's tests live in their own file.
#[cfg(feature = "principled")]
mod principled;
// So do the rough diffuse model's.
#[cfg(feature = "rough-diffuse")]
mod rough_diffuse;

//! Tests of the plastics (`plastic`, `roughplastic`), the thin dielectric
//! and the dielectric's tints: χ² fits of the samplers against their
//! densities, `sample` against `eval`/`pdf`, reciprocity, white-furnace
//! energy, the coating table against the smooth interface it tends to, and
//! the Dirac lobes' weights.

use glam::{Vec2, Vec3};
use rand_pcg::Pcg32;

use super::chi2::{self, uniform};
use super::microfacet::Distribution;
use super::roughplastic::RoughCoating;
use super::*;

fn plastic(eta: f32, rho: Rgb, nonlinear: bool, two_sided: bool) -> Bsdf {
    Bsdf::plastic(eta, (rho, Rgb::ONE), nonlinear, two_sided)
}

fn rough_plastic(dist: Distribution, alpha: f32, eta: f32, rho: Rgb, two_sided: bool) -> Bsdf {
    let coating = RoughCoating::new(dist, alpha, eta);
    Bsdf::rough_plastic(
        dist,
        alpha,
        eta,
        &coating,
        (rho, Rgb::ONE),
        false,
        two_sided,
    )
}

fn thin(eta: f32, r: Rgb, t: Rgb) -> Bsdf {
    Bsdf::thin_dielectric(eta, (r, t))
}

fn dir(cos_theta: f32, phi: f32) -> Vec3 {
    let s = libm::sqrtf((1.0 - cos_theta * cos_theta).max(0.0));
    Vec3::new(s * libm::cosf(phi), s * libm::sinf(phi), cos_theta)
}

fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-30
}

/// Incident cosines: normal, oblique, grazing.
const COS_O: [f32; 3] = [1.0, 0.5, 0.05];
const PHI_O: f32 = 0.7;
const SAMPLES: usize = 500_000;
/// The χ² tests below: smooth plastic 3 + 1 (two-sided from below), rough
/// plastic 2 distributions × 2 α × 3 angles.
const CHI2_TESTS: usize = 4 + 12;

/// χ² of the smooth (non-delta) samples against `pdf`;
/// [`chi2::fit_bsdf`] counts the Dirac samples as not returned, so ∫pdf
/// must equal the fraction of smooth ones.
fn chi2_smooth_part(name: &str, bsdf: Bsdf, wo: Vec3, seed: u64) {
    chi2::fit_bsdf(
        name,
        &bsdf,
        wo,
        SAMPLES,
        seed,
        chi2::sidak(0.01, CHI2_TESTS),
    );
}

#[test]
fn chi2_plastic() {
    let rho = Rgb::new(0.7, 0.2, 0.1);
    for (i, &co) in COS_O.iter().enumerate() {
        let name = format!("plastic cosθo={co}");
        chi2_smooth_part(
            &name,
            plastic(1.5, rho, false, false),
            dir(co, PHI_O),
            70 + i as u64,
        );
    }
    chi2_smooth_part(
        "plastic two-sided from below",
        plastic(1.5, rho, true, true),
        dir(-0.4, PHI_O),
        79,
    );
}

#[test]
fn chi2_rough_plastic() {
    let rho = Rgb::splat(0.5);
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for alpha in [0.1f32, 0.4] {
            let bsdf = rough_plastic(dist, alpha, 1.5, rho, false);
            for (i, &co) in COS_O.iter().enumerate() {
                let name = format!("roughplastic {dist:?} α={alpha} cosθo={co}");
                let seed = 90 + i as u64 + (alpha * 100.0) as u64;
                chi2_smooth_part(&name, bsdf, dir(co, PHI_O), seed);
            }
        }
    }
}

/// The plastics of the consistency tests.
fn coatings() -> Vec<(String, Bsdf)> {
    let rho = Rgb::new(0.8, 0.4, 0.1);
    let mut v = vec![
        ("plastic".into(), plastic(1.5, rho, false, false)),
        (
            "plastic nonlinear 2s".into(),
            plastic(1.33, rho, true, true),
        ),
        ("plastic η<1".into(), plastic(0.8, rho, false, false)),
    ];
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for alpha in [0.01f32, 0.2, 0.7] {
            v.push((
                format!("roughplastic {dist:?} {alpha}"),
                rough_plastic(dist, alpha, 1.49, rho, false),
            ));
        }
        v.push((
            format!("roughplastic {dist:?} 2s"),
            rough_plastic(dist, 0.3, 1.6, rho, true),
        ));
    }
    v
}

#[test]
fn coating_samples_match_eval_and_pdf_and_are_reciprocal() {
    let mut rng = Pcg32::new(11, 2);
    for (name, bsdf) in coatings() {
        assert!(!bsdf.is_delta() && !bsdf.has_transmission(), "{name}");
        assert_eq!(bsdf.lobe(), Lobe::Coating);
        let mut deltas = 0;
        for _ in 0..3000 {
            let wo = crate::math::warp::square_to_uniform_sphere(Vec2::new(
                uniform(&mut rng),
                uniform(&mut rng),
            ));
            let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
            if let Some(s) = bsdf.sample(wo, uniform(&mut rng), u, TransportMode::Radiance) {
                assert!(
                    s.f.is_finite() && s.pdf > 0.0 && s.wi.z * wo.z > 0.0,
                    "{name}"
                );
                if s.delta {
                    // Only the smooth plastic has a Dirac lobe: the mirror
                    // direction, which eval and pdf do not contain.
                    deltas += 1;
                    assert!(name.starts_with("plastic"), "{name}");
                    assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
                } else {
                    let f = bsdf.eval(wo, s.wi, TransportMode::Radiance);
                    let pdf = bsdf.pdf(wo, s.wi);
                    assert!(
                        close(s.f.r, f.r, 1e-5) && close(s.f.b, f.b, 1e-5),
                        "{name}: {:?} vs {f:?}",
                        s.f
                    );
                    assert!(close(s.pdf, pdf, 1e-5), "{name}: {} vs {pdf}", s.pdf);
                }
            }
            let wi = crate::math::warp::square_to_uniform_sphere(Vec2::new(
                uniform(&mut rng),
                uniform(&mut rng),
            ));
            let a = bsdf.eval(wo, wi, TransportMode::Radiance);
            let b = bsdf.eval(wi, wo, TransportMode::Radiance);
            assert!(
                close(a.r, b.r, 1e-4) && close(a.g, b.g, 1e-4) && close(a.b, b.b, 1e-4),
                "{name}: f({wo}, {wi}) = {a:?}, reversed {b:?}"
            );
        }
        if name.starts_with("plastic") {
            assert!(deltas > 30, "{name}: the coating lobe is never sampled");
        }
    }
}

/// Directional albedo: ∫ f cos dω by cubature plus the Dirac lobe's
/// weight (the sampled coating reflection's f·cos/pdf times its probability
/// pdf, i.e. f·cos).
fn albedo(bsdf: &Bsdf, wo: Vec3) -> f64 {
    let smooth = chi2::integrate_sphere(
        &|wi| (bsdf.eval(wo, wi, TransportMode::Radiance).g * wi.z.abs()) as f64,
        chi2::COUNT_TOL,
    );
    let dirac = bsdf
        .sample(wo, 0.0, Vec2::new(0.3, 0.3), TransportMode::Radiance)
        .filter(|s| s.delta)
        .map_or(0.0, |s| (s.f.g * s.wi.z.abs()) as f64);
    smooth + dirac
}

#[test]
fn white_plastic_conserves_energy() {
    // With a white base, all light that enters the coating leaves again:
    // F(θo) is reflected, and 1 − F(θo) returns through the interface,
    // since 1 − F_dr(η) = η² (1 − F_dr(1/η)). The diffuse-Fresnel fits are
    // good to < 0.5% for these η.
    for eta in [1.33f32, 1.5, 1.9] {
        for nonlinear in [false, true] {
            let bsdf = plastic(eta, Rgb::ONE, nonlinear, false);
            for co in [1.0f32, 0.6, 0.2] {
                let a = albedo(&bsdf, dir(co, 0.3));
                assert!((a - 1.0).abs() < 6e-3, "η={eta} cos={co}: albedo {a}");
            }
        }
    }
    // A grey base absorbs: strictly less, and nonlinear is darker.
    let wo = dir(0.7, 0.3);
    let lin = albedo(&plastic(1.5, Rgb::splat(0.5), false, false), wo);
    let nl = albedo(&plastic(1.5, Rgb::splat(0.5), true, false), wo);
    assert!(nl < lin && lin < 0.9, "{nl} {lin}");
}

#[test]
fn rough_plastic_albedo_is_at_most_one() {
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for alpha in [0.05f32, 0.3, 0.8] {
            let bsdf = rough_plastic(dist, alpha, 1.5, Rgb::ONE, false);
            for co in [1.0f32, 0.5, 0.1] {
                let a = albedo(&bsdf, dir(co, 0.3));
                // Single scattering in the coating loses energy, never
                // gains it.
                assert!(a <= 1.0 + 2e-3, "{dist:?} α={alpha} cos={co}: {a}");
            }
        }
    }
    // Nearly smooth, the model tends to the smooth plastic, whose albedo
    // is 1, but not exactly: Mitsuba's R_int (a 64-point mean of R·μ
    // rather than the integral) is 1.5% low, so 1/(1 − R_int) is 2% low.
    for co in [1.0f32, 0.5] {
        let a = albedo(
            &rough_plastic(Distribution::Ggx, 1e-3, 1.5, Rgb::ONE, false),
            dir(co, 0.3),
        );
        assert!((0.97..=0.99).contains(&a), "cos={co}: {a}");
    }
}

#[test]
fn smooth_limit_of_the_coating_table_is_the_fresnel_transmittance() {
    // As α → 0 every visible normal is the macro normal: t(μ) = 1 − F(μ)
    // and R_int = the diffuse Fresnel reflectance from inside.
    for eta in [1.33f32, 1.5] {
        let table = RoughCoating::new(Distribution::Ggx, 1e-3, eta);
        for k in 1..RoughCoating::NODES {
            let mu = RoughCoating::node(k);
            let exact = 1.0 - fresnel::dielectric(mu, eta).reflectance;
            let t = table.transmittance(mu);
            assert!((t - exact).abs() < 2e-3, "η={eta} μ={mu}: t {t} vs {exact}");
        }
        // Mitsuba's mean over 64 evenly spaced cosines is a coarse
        // quadrature of 2∫R μ dμ: agree to 1%.
        let r = table.internal_reflectance();
        let fit = super::plastic::diffuse_fresnel(1.0 / eta);
        assert!((r - fit).abs() < 0.01, "η={eta}: R_int {r} vs {fit}");
    }
    // Rougher coatings transmit more at grazing incidence (facets face the
    // light) and the table is monotone in μ near the normal.
    let smooth = RoughCoating::new(Distribution::Beckmann, 0.01, 1.5);
    let rough = RoughCoating::new(Distribution::Beckmann, 0.5, 1.5);
    assert!(rough.transmittance(0.02) > smooth.transmittance(0.02) + 0.05);
}

#[test]
fn thin_dielectric_reflects_the_slab_total_and_passes_straight() {
    let bsdf = thin(1.5, Rgb::ONE, Rgb::ONE);
    assert!(bsdf.is_delta() && bsdf.has_transmission());
    for co in [1.0f32, 0.5, 0.1, -0.3, -0.9] {
        let wo = dir(co, 0.4);
        let r = fresnel::dielectric(co.abs(), 1.5).reflectance;
        let slab = r + (1.0 - r) * (1.0 - r) * r / (1.0 - r * r);
        for mode in [TransportMode::Radiance, TransportMode::Importance] {
            let (wr, fr) = bsdf.specular(wo, true, mode).unwrap();
            let (wt, ft) = bsdf.specular(wo, false, mode).unwrap();
            assert!((wr - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
            // Unbent: the two refractions cancel (no 1/η² either).
            assert!((wt + wo).length() < 1e-6, "{wt} vs {wo}");
            assert!(close(fr.g, slab, 1e-5), "cos {co}: {} vs {slab}", fr.g);
            assert!(
                close(fr.g + ft.g, 1.0, 1e-5),
                "cos {co}: energy {}",
                fr.g + ft.g
            );
        }
        // A slab reflects more than one face, less than two faces' worth.
        assert!(slab > r && slab <= 2.0 * r + 1e-6);
    }
    // Tints scale the lobes' weights.
    let tinted = thin(1.5, Rgb::new(0.5, 0.5, 0.5), Rgb::new(1.0, 0.5, 0.0));
    let wo = dir(0.8, 0.1);
    let (_, ft) = tinted.specular(wo, false, TransportMode::Radiance).unwrap();
    let (_, fc) = bsdf.specular(wo, false, TransportMode::Radiance).unwrap();
    assert!(close(ft.r, fc.r, 1e-6) && close(ft.g, 0.5 * fc.g, 1e-6) && ft.b == 0.0);
}

#[test]
fn dielectric_tints_scale_the_lobes() {
    let clear = Bsdf::dielectric(1.5, (Rgb::ONE, Rgb::ONE));
    let tinted = Bsdf::dielectric(1.5, (Rgb::new(0.8, 0.8, 0.8), Rgb::new(0.9, 0.5, 0.2)));
    assert!(tinted.is_delta() && tinted.lobe() == Lobe::Refraction);
    for co in [0.9f32, -0.95] {
        let wo = dir(co, 0.2);
        for (reflect, tint) in [(true, Rgb::splat(0.8)), (false, Rgb::new(0.9, 0.5, 0.2))] {
            let (w0, f0) = clear
                .specular(wo, reflect, TransportMode::Radiance)
                .unwrap();
            let (w1, f1) = tinted
                .specular(wo, reflect, TransportMode::Radiance)
                .unwrap();
            assert_eq!(w0, w1);
            assert!(
                close(f1.r, f0.r * tint.r, 1e-6) && close(f1.b, f0.b * tint.b, 1e-6),
                "{f1:?} vs {f0:?}·{tint:?}"
            );
        }
    }
}

/// Values of Mitsuba 3.9.1's `scalar_rgb` plugins (`BSDF::eval` divided by
/// cos θi, and `BSDF::pdf`), printed by `mi.load_dict(...)` for these
/// directions (Mitsuba's `si.wi` is our `wo`): (wo, wi, f, pdf).
type MitsubaCase = ([f32; 3], [f32; 3], [f32; 3], f32);

fn against_mitsuba(name: &str, bsdf: Bsdf, cases: &[MitsubaCase], f_tol: f32, pdf_tol: f32) {
    for (wo, wi, f, pdf) in cases {
        let (wo, wi) = (Vec3::from(*wo), Vec3::from(*wi));
        let ours = bsdf.eval(wo, wi, TransportMode::Radiance);
        let p = bsdf.pdf(wo, wi);
        for (a, b) in [(ours.r, f[0]), (ours.g, f[1]), (ours.b, f[2])] {
            assert!(
                close(a, b, f_tol),
                "{name} {wo} {wi}: f {ours:?} vs Mitsuba {f:?}"
            );
        }
        assert!(
            close(p, *pdf, pdf_tol),
            "{name} {wo} {wi}: pdf {p} vs Mitsuba {pdf}"
        );
    }
}

const DIRS: [([f32; 3], [f32; 3]); 4] = [
    (
        [0.433_712_3, 0.043_516_4, 0.9],
        [-0.706_996, 0.100_779_8, 0.7],
    ),
    ([0.866_025_4, 0.0, 0.5], [-0.866_025_4, 2.298e-6, 0.5]),
    (
        [0.529_386, 0.824_469_8, 0.2],
        [-0.129_941_8, 0.283_928, 0.95],
    ),
    ([0.998_749_2, 0.0, 0.05], [-0.764_242_3, 0.570_906, 0.3]),
];

#[test]
fn plastics_agree_with_mitsuba() {
    let with = |f: [[f32; 3]; 4], p: [f32; 4]| -> Vec<MitsubaCase> {
        (0..4).map(|i| (DIRS[i].0, DIRS[i].1, f[i], p[i])).collect()
    };
    // Smooth plastic: the same closed form, so up to f32 rounding (f) and
    // the sampling weight's texture mean (pdf).
    let smooth = with(
        [
            [0.223_612_8, 0.047_917_03, 0.031_944_68],
            [0.203_776, 0.043_666_28, 0.029_110_86],
            [0.155_869_8, 0.033_400_68, 0.022_267_12],
            [0.048_239_81, 0.010_337_1, 0.006_891_402],
        ],
        [0.196_468_4, 0.121_589, 0.115_494_4, 0.009_025_181],
    );
    against_mitsuba(
        "plastic",
        plastic(1.5, Rgb::new(0.7, 0.15, 0.1), false, false),
        &smooth,
        5e-4,
        // Mitsuba's mean of an RGB texture differs in the 4th digit.
        1e-3,
    );
    // Rough plastics: our 8-cosine transmittance table against Mitsuba's
    // 64 (and, for Beckmann, the exact Smith G1 against Mitsuba's rational
    // fit) leave small differences.
    let ggx = with(
        [
            [0.161_357_2, 0.087_107_07, 0.235_607_4],
            [0.768_888_6, 0.701_791_2, 0.835_986],
            [0.103_277_8, 0.042_540_71, 0.164_014_9],
            [0.098_041_09, 0.051_585_02, 0.144_497_2],
        ],
        [0.258_140_3, 0.830_618_7, 0.205_738_6, 0.069_903_95],
    );
    let bsdf = Bsdf::rough_plastic(
        Distribution::Ggx,
        0.2,
        1.49,
        &RoughCoating::new(Distribution::Ggx, 0.2, 1.49),
        (Rgb::new(0.5, 0.2, 0.8), Rgb::ONE),
        false,
        false,
    );
    against_mitsuba("roughplastic ggx", bsdf, &ggx, 0.01, 0.01);
    let beckmann = with(
        [
            [0.064_350_67, 0.088_939_64, 0.220_335],
            [0.336_490_7, 0.358_634_1, 0.476_961_1],
            [0.017_190_72, 0.037_642_19, 0.146_928_1],
            [0.013_365_89, 0.029_273_2, 0.114_276_7],
        ],
        [0.269_257_6, 0.495_895, 0.181_159_4, 0.047_513_43],
    );
    let bsdf = Bsdf::rough_plastic(
        Distribution::Beckmann,
        0.3,
        1.5046,
        &RoughCoating::new(Distribution::Beckmann, 0.3, 1.5046),
        (Rgb::new(0.15, 0.3, 0.8), Rgb::ONE),
        true,
        false,
    );
    against_mitsuba("roughplastic beckmann", bsdf, &beckmann, 0.01, 0.015);
}

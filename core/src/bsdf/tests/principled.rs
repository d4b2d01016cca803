//! Tests of the principled BSDF (`principled`): agreement with Mitsuba 3's
//! values, χ² fits of its sampler on parameter sets that exercise every
//! lobe, agreement of `sample` with `eval`/`pdf`, reciprocity and the
//! adjoint relation of its refraction, energy bounds and the effect of its
//! parameters on sidedness. Its refused parameters are the material's
//! (`scene::material` tests).

use super::*;
use crate::bsdf::PrincipledValues;

/// Named scalar parameters over Mitsuba's defaults (roughness 0.5, every
/// other scalar 0).
fn principled_with(base: Rgb, eta: f32, scalars: &[(&str, f32)]) -> PrincipledValues {
    let mut p = PrincipledValues {
        base_color: base,
        roughness: 0.5,
        anisotropic: 0.0,
        metallic: 0.0,
        spec_trans: 0.0,
        eta,
        spec_tint: 0.0,
        sheen: 0.0,
        sheen_tint: 0.0,
        clearcoat: 0.0,
        clearcoat_gloss: 0.0,
        flatness: 0.0,
    };
    for &(name, v) in scalars {
        let t = match name {
            "roughness" => &mut p.roughness,
            "anisotropic" => &mut p.anisotropic,
            "metallic" => &mut p.metallic,
            "spec_trans" => &mut p.spec_trans,
            "spec_tint" => &mut p.spec_tint,
            "sheen" => &mut p.sheen,
            "sheen_tint" => &mut p.sheen_tint,
            "clearcoat" => &mut p.clearcoat,
            "clearcoat_gloss" => &mut p.clearcoat_gloss,
            "flatness" => &mut p.flatness,
            _ => panic!("unknown parameter {name}"),
        };
        *t = v;
    }
    p
}

fn principled(base: Rgb, eta: f32, scalars: &[(&str, f32)]) -> Bsdf {
    Bsdf::principled(&principled_with(base, eta, scalars), false)
}

/// Mitsuba's `specular` = 0.6 as η: 2/(1 − √(0.08 s)) − 1 (Burley 2015;
/// the scene's `PrincipledParams::eta_from_specular`).
fn eta_of_specular_06() -> f32 {
    2.0 / (1.0 - libm::sqrtf(0.08 * 0.6)) - 1.0
}

/// Every lobe but transmission, anisotropic (the "opaque" set of
/// `principled_mitsuba.py`).
fn opaque_set() -> Bsdf {
    principled(
        Rgb::new(0.8, 0.3, 0.2),
        eta_of_specular_06(),
        &[
            ("roughness", 0.4),
            ("anisotropic", 0.5),
            ("metallic", 0.3),
            ("spec_tint", 0.5),
            ("sheen", 0.7),
            ("sheen_tint", 0.5),
            ("clearcoat", 0.8),
            ("clearcoat_gloss", 0.6),
            ("flatness", 0.3),
        ],
    )
}

/// Mostly transmitting (the "glass" set of `principled_mitsuba.py`).
fn glass_set() -> Bsdf {
    principled(
        Rgb::new(0.9, 0.8, 0.7),
        1.4,
        &[("roughness", 0.3), ("metallic", 0.1), ("spec_trans", 0.7)],
    )
}

/// Mitsuba 3.9.1's `principled` (scalar_rgb) at six direction pairs for
/// each set, printed by `principled_mitsuba.py` beside this file: its eval
/// is f·|cos θ| of the light-side direction `wi`, hence the factor below.
/// One deliberate difference: seen from inside, an opaque set (nothing
/// transmits) has no density here, because `sample` returns nothing there
/// (Mitsuba's sampler does the same; its `pdf` still reports the
/// reflection lobe's 3.564, where its `eval` is 0).
// The values are Mitsuba's printouts, verbatim.
#[allow(clippy::excessive_precision)]
#[test]
fn principled_matches_mitsuba() {
    let d = |c: f32, phi: f32| dir(c, phi);
    let pi = core::f32::consts::PI;
    let pairs = [
        (d(0.8, 0.7), d(0.6, 0.7 + pi)),
        (d(0.8, 0.7), d(0.3, 2.0)),
        (d(0.3, 0.2), d(0.9, 3.0)),
        (d(0.8, 0.7), d(-0.7, 0.7 + pi)),
        (d(-0.6, 1.0), d(0.5, 1.0 + pi)),
        (d(-0.6, 1.0), d(-0.5, 1.0 + pi)),
    ];
    #[rustfmt::skip]
    let opaque: [([f32; 3], f32); 6] = [
        ([4.5480868e-01, 1.9355299e-01, 1.4130184e-01], 7.6885241e-01),
        ([5.5893660e-02, 2.1105483e-02, 1.4147846e-02], 3.8239148e-02),
        ([2.2827655e-01, 9.0920322e-02, 6.3449070e-02], 2.3349528e-01),
        ([0.0, 0.0, 0.0], 0.0),
        ([0.0, 0.0, 0.0], 0.0),
        ([0.0, 0.0, 0.0], 0.0), // Mitsuba's pdf: 3.5641253 (see above)
    ];
    #[rustfmt::skip]
    let glass: [([f32; 3], f32); 6] = [
        ([1.7262426e-01, 1.5722652e-01, 1.4182879e-01], 3.5971221e-01),
        ([2.3168696e-02, 2.0601673e-02, 1.8034644e-02], 2.1062052e-02),
        ([7.4496359e-02, 6.6468194e-02, 5.8440041e-02], 7.9714514e-02),
        ([1.1491317e-02, 1.0834118e-02, 1.0134390e-02], 1.8733259e-02),
        ([1.7964932e-01, 1.6937502e-01, 1.5843582e-01], 1.5428452e-01),
        ([4.9299288e+00, 4.9299288e+00, 4.9299288e+00], 7.8725367e+00),
    ];
    for (name, bsdf, want) in [
        ("opaque", opaque_set(), opaque),
        ("glass", glass_set(), glass),
    ] {
        for (&(wo, wi), &(f, pdf)) in pairs.iter().zip(want.iter()) {
            let got = bsdf.eval(wo, wi, TransportMode::Radiance) * wi.z.abs();
            let want_f = Rgb::from_array(f);
            assert!(
                rgb_close(got, want_f, 2e-4),
                "{name} wo={wo} wi={wi}: eval {got:?}, Mitsuba {want_f:?}"
            );
            let got_pdf = bsdf.pdf(wo, wi);
            assert!(
                close(got_pdf, pdf, 2e-4),
                "{name} wo={wo} wi={wi}: pdf {got_pdf}, Mitsuba {pdf}"
            );
        }
    }
}

/// The χ² parameter sets: (name, BSDF, signed cosines of `wo`).
fn chi2_sets() -> Vec<(&'static str, Bsdf, &'static [f32])> {
    let base = Rgb::new(0.7, 0.5, 0.3);
    let outside: &[f32] = &[0.9, 0.4, 0.1];
    let both: &[f32] = &[0.8, 0.3, -0.8, -0.3];
    vec![
        (
            "dielectric r=0.1",
            principled(base, 1.5, &[("roughness", 0.1)]),
            outside,
        ),
        (
            "dielectric r=0.7",
            principled(base, 1.5, &[("roughness", 0.7)]),
            outside,
        ),
        (
            "metal r=0.1",
            principled(base, 1.5, &[("roughness", 0.1), ("metallic", 1.0)]),
            outside,
        ),
        (
            "metal r=0.7 aniso=0.5",
            principled(
                base,
                1.5,
                &[("roughness", 0.7), ("metallic", 1.0), ("anisotropic", 0.5)],
            ),
            outside,
        ),
        (
            "dielectric r=0.1 aniso=0.5",
            principled(base, 1.5, &[("roughness", 0.1), ("anisotropic", 0.5)]),
            outside,
        ),
        (
            "glass r=0.1",
            principled(base, 1.5, &[("roughness", 0.1), ("spec_trans", 1.0)]),
            both,
        ),
        (
            "glass r=0.7 aniso=0.5",
            principled(
                base,
                1.5,
                &[
                    ("roughness", 0.7),
                    ("spec_trans", 1.0),
                    ("anisotropic", 0.5),
                ],
            ),
            both,
        ),
        (
            "half glass",
            principled(
                base,
                1.33,
                &[("roughness", 0.3), ("spec_trans", 0.5), ("metallic", 0.2)],
            ),
            both,
        ),
        (
            "clearcoat",
            principled(
                base,
                1.5,
                &[
                    ("roughness", 0.7),
                    ("clearcoat", 1.0),
                    ("clearcoat_gloss", 0.5),
                ],
            ),
            outside,
        ),
        (
            "sheen",
            principled(
                base,
                1.5,
                &[("roughness", 0.5), ("sheen", 1.0), ("sheen_tint", 0.5)],
            ),
            outside,
        ),
        ("every lobe", opaque_set(), outside),
    ]
}

#[test]
fn chi2_principled() {
    let sets = chi2_sets();
    let tests: usize = sets.iter().map(|s| s.2.len()).sum();
    let alpha = chi2::sidak(SIGNIFICANCE, tests);
    for (k, (name, bsdf, cosines)) in sets.into_iter().enumerate() {
        for (i, &c) in cosines.iter().enumerate() {
            let wo = dir(c, PHI_O);
            let name = format!("{name} cosθo={c}");
            // Principled never samples a Dirac lobe, so the shared fit's
            // delta filter removes nothing.
            let out = chi2::fit_bsdf(
                &name,
                &bsdf,
                wo,
                SAMPLES,
                7000 + 10 * k as u64 + i as u64,
                alpha,
            );
            // Single scattering drops little (the lobes leave on their
            // side for most facets).
            assert!(out.integral > 0.7, "{name}: ∫pdf = {}", out.integral);
        }
    }
}

#[test]
fn principled_sample_matches_eval_and_pdf() {
    let mut rng = Pcg32::new(31, 7);
    for (name, bsdf, _) in chi2_sets() {
        assert!(!bsdf.is_delta(), "{name}");
        assert_eq!(bsdf.lobe(), Lobe::Principled, "{name}");
        let (mut reflected, mut refracted) = (0, 0);
        for _ in 0..3000 {
            let wo = random_dir(&mut rng);
            let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
            let u_lobe = uniform(&mut rng);
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                let Some(s) = bsdf.sample(wo, u_lobe, u, mode) else {
                    continue;
                };
                let what = format!("{name} wo={wo} wi={}", s.wi);
                assert!(!s.delta && (s.wi.length() - 1.0).abs() < 1e-5, "{what}");
                assert!(rgb_close(s.f, bsdf.eval(wo, s.wi, mode), 1e-6), "{what}");
                assert!(close(s.pdf, bsdf.pdf(wo, s.wi), 1e-6), "{what}");
                assert!(s.pdf > 0.0 && s.f.is_finite(), "{what}");
                if s.wi.z * wo.z > 0.0 {
                    reflected += 1;
                    assert_eq!(s.eta, 1.0, "{what}");
                } else {
                    refracted += 1;
                    assert!(bsdf.has_transmission(), "{what}");
                    let want = if wo.z > 0.0 { 1.5 } else { 1.0 / 1.5 };
                    if name.starts_with("glass") {
                        assert_eq!(s.eta, want, "{what}");
                    }
                }
            }
        }
        assert!(reflected > 100, "{name}: {reflected} reflected");
        assert_eq!(
            refracted > 100,
            bsdf.has_transmission(),
            "{name}: {refracted} refracted"
        );
    }
}

/// Reflection is reciprocal; refraction satisfies the adjoint relation
/// eval(wo, wi, Importance) = eval(wi, wo, Radiance) and Veach's
/// f(wo, wi)/η_wo² = f(wi, wo)/η_wi².
#[test]
fn principled_reciprocity_and_adjoint() {
    let mut rng = Pcg32::new(5, 55);
    for (name, bsdf, _) in chi2_sets() {
        let eta = if name == "half glass" { 1.33 } else { 1.5 };
        let (mut reflecting, mut transmitting) = (0, 0);
        for _ in 0..4000 {
            let (wo, wi) = (random_dir(&mut rng), random_dir(&mut rng));
            let e = if wo.z * wi.z > 0.0 {
                1.0
            } else if wo.z > 0.0 {
                eta
            } else {
                1.0 / eta
            };
            // 1 − F is ill-conditioned in f32 near grazing facets.
            let m = (wo + wi * e).normalize();
            if wo.dot(m).abs().min(wi.dot(m).abs()) < 0.02 {
                continue;
            }
            let what = format!("{name} wo={wo} wi={wi}");
            let rad = bsdf.eval(wo, wi, TransportMode::Radiance);
            let rad_rev = bsdf.eval(wi, wo, TransportMode::Radiance);
            let imp = bsdf.eval(wo, wi, TransportMode::Importance);
            assert!(
                rad.is_finite() && rad.r >= 0.0 && rad.g >= 0.0 && rad.b >= 0.0,
                "{what}"
            );
            assert!(
                rgb_close(imp, rad_rev, 1e-3),
                "{what}: {imp:?} vs {rad_rev:?}"
            );
            if wo.z * wi.z > 0.0 {
                assert!(
                    rgb_close(rad, rad_rev, 1e-3),
                    "{what}: {rad:?} vs {rad_rev:?}"
                );
                reflecting += (!rad.is_black()) as u32;
            } else {
                let (n_wo, n_wi) = if wo.z > 0.0 { (1.0, eta) } else { (eta, 1.0) };
                let (a, b) = (rad.g / (n_wo * n_wo), rad_rev.g / (n_wi * n_wi));
                assert!(close(a, b, 1e-3), "{what}: {a} vs {b}");
                transmitting += (a > 0.0) as u32;
            }
        }
        assert!(reflecting > 100, "{name}: {reflecting}");
        assert_eq!(
            transmitting > 100,
            bsdf.has_transmission(),
            "{name}: {transmitting}"
        );
    }
}

/// The albedo ∫ f(wo, wi) |cos θi| dωi (importance mode: the fraction of
/// the flux from `wo` that is scattered) of the green channel (the tests
/// use white, where the channels agree).
fn albedo(bsdf: &Bsdf, wo: Vec3) -> f32 {
    chi2::integrate_sphere(
        &|wi| (bsdf.eval(wo, wi, TransportMode::Importance).g * wi.z.abs()) as f64,
        chi2::COUNT_TOL,
    ) as f32
}

/// White furnace. The specular lobes are energy-conserving: a white metal,
/// a clear glass (reflection plus refraction) and a dielectric whose
/// diffuse part is black scatter at most what arrives, and nearly all of
/// it when smooth and seen from the normal. Burley's diffuse and sheen are
/// not: retro-reflection adds up to 2·roughness·cos²θd·(F_L + F_V) at
/// grazing angles, sheen adds up to sheen·(1 − cos θd)⁵ on top of
/// everything, and Mitsuba adds the diffuse lobe under the specular one
/// without taking out what the specular reflects (only the clearcoat is
/// small enough not to matter). Their albedo is bounded here by the sum of
/// those excesses, and shown to exceed 1 where the model makes it.
#[test]
fn principled_furnace() {
    let white = Rgb::ONE;
    let conserving = [
        (
            "white metal r=0.1",
            principled(white, 1.5, &[("metallic", 1.0), ("roughness", 0.1)]),
        ),
        (
            "white metal r=0.7",
            principled(white, 1.5, &[("metallic", 1.0), ("roughness", 0.7)]),
        ),
        (
            "clear glass r=0.1",
            principled(white, 1.5, &[("spec_trans", 1.0), ("roughness", 0.1)]),
        ),
        (
            "clear glass r=0.7",
            principled(white, 1.5, &[("spec_trans", 1.0), ("roughness", 0.7)]),
        ),
        (
            "black dielectric",
            principled(Rgb::ZERO, 1.5, &[("roughness", 0.3)]),
        ),
    ];
    for (name, bsdf) in conserving {
        for c in [1.0f32, 0.5, 0.1, -1.0, -0.5] {
            if c < 0.0 && !bsdf.has_transmission() {
                continue;
            }
            let a = albedo(&bsdf, dir(c, PHI_O));
            assert!(a <= 1.0 + 1e-3, "{name} cos={c}: albedo {a}");
            if c == 1.0 && name.ends_with("0.1") {
                assert!(a > 0.97, "{name}: albedo {a}");
            }
        }
    }
    // Diffuse with full retro-reflection, sheen and clearcoat on white:
    // the albedo exceeds 1 and grows towards grazing (1.07 from the normal,
    // 1.65 at cos θ = 0.02 when written), staying below 2.
    let rough = principled(
        white,
        1.5,
        &[("roughness", 1.0), ("sheen", 1.0), ("clearcoat", 1.0)],
    );
    let mut worst = 0.0f32;
    for c in [1.0f32, 0.5, 0.1, 0.02] {
        let a = albedo(&rough, dir(c, PHI_O));
        assert!(a < 2.0, "cos={c}: {a}");
        worst = worst.max(a);
    }
    assert!(worst > 1.3, "the non-conserving lobes add light: {worst}");
    // Without retro-reflection (roughness → 0) and sheen, a white diffuse
    // dielectric seen from the normal stays below 1 + F (the specular on top).
    let smooth = principled(white, 1.5, &[("roughness", 0.0)]);
    let a = albedo(&smooth, dir(1.0, PHI_O));
    assert!(a <= 1.0 + 0.1, "{a}");
}

/// Sidedness: an opaque principled is black from below unless two-sided
/// (then mirrored), a transmitting one is one interface (never two-sided).
#[test]
fn principled_sides() {
    let p = principled_with(Rgb::splat(0.5), 1.5, &[("roughness", 0.5)]);
    let one = Bsdf::principled(&p, false);
    let two = Bsdf::principled(&p, true);
    let (wo, wi) = (dir(0.7, 0.3), dir(0.6, 2.0));
    let (wo_b, wi_b) = (-wo, dir(-0.6, 2.0));
    assert!(!one.eval(wo, wi, TransportMode::Radiance).is_black());
    assert!(one.eval(wo_b, wi_b, TransportMode::Radiance).is_black());
    assert_eq!(one.pdf(wo_b, wi_b), 0.0);
    assert!(
        one.sample(wo_b, 0.5, Vec2::new(0.3, 0.6), TransportMode::Radiance)
            .is_none()
    );
    let mirrored = |v: Vec3| Vec3::new(v.x, v.y, -v.z);
    assert_eq!(
        two.eval(wo_b, wi_b, TransportMode::Radiance),
        one.eval(mirrored(wo_b), mirrored(wi_b), TransportMode::Radiance)
    );
    let mut g = p;
    g.spec_trans = 1.0;
    let glass = Bsdf::principled(&g, true);
    assert!(glass.has_transmission());
    // Seen from inside it reflects and refracts as an interface.
    assert!(!glass.eval(wo_b, wi_b, TransportMode::Radiance).is_black());
    assert!(!glass.eval(wo_b, wo, TransportMode::Radiance).is_black());
}

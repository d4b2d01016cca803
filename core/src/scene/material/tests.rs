//! Tests of [`Material`]: the one rule for colours and roughness, each
//! model's refused parameters, and the models that ignore `two_sided`.

use super::*;

fn with(kind: MaterialKind) -> Result<(), &'static str> {
    Material {
        kind,
        two_sided: false,
        detail: Detail::NONE,
    }
    .validate()
}

fn c(v: f32) -> Texture {
    Texture::Constant(Rgb::new(0.5, v, 0.5))
}

fn rough_metal(alpha: f32, tint: f32) -> MaterialKind {
    MaterialKind::RoughConductor {
        distribution: Distribution::Ggx,
        alpha,
        fresnel: ConductorFresnel::Perfect,
        specular_reflectance: c(tint),
    }
}

/// Colours in [0, 1], microfacet α in (0, 1e4], for every model: the
/// one rule the loader and the C API apply through `validate`.
#[test]
fn one_rule_for_colours_and_roughness() {
    for v in [0.0, 0.5, 1.0] {
        assert_eq!(with(MaterialKind::Diffuse { reflectance: c(v) }), Ok(()));
    }
    for v in [1.0001, 2.0, -0.1, f32::NAN, f32::INFINITY] {
        assert!(
            with(MaterialKind::Diffuse { reflectance: c(v) }).is_err(),
            "{v}"
        );
        assert!(with(rough_metal(0.3, v)).is_err(), "{v}");
        let e = with(MaterialKind::ThinDielectric {
            eta: 1.5,
            specular_reflectance: c(0.5),
            specular_transmittance: c(v),
        });
        assert!(e.is_err_and(|e| e.contains("[0, 1]")), "{v}");
        let checker = Texture::Checkerboard {
            color0: Rgb::splat(0.5),
            color1: Rgb::new(v, 0.5, 0.5),
            to_uv: glam::Affine2::IDENTITY,
        };
        assert!(
            with(MaterialKind::Diffuse {
                reflectance: checker
            })
            .is_err()
        );
    }
    // Roughness: Mitsuba's α > 1 is accepted, up to MAX_ROUGHNESS.
    for a in [1e-3, 1.0, 2.0, MAX_ROUGHNESS] {
        assert_eq!(with(rough_metal(a, 1.0)), Ok(()), "{a}");
    }
    for a in [0.0, -0.5, 1.0001e4, f32::NAN, f32::INFINITY] {
        let e = with(rough_metal(a, 1.0));
        assert_eq!(e, Err("roughconductor alpha must be in (0, 1e4]"), "{a}");
    }
}

fn constant(c: Rgb) -> Texture {
    Texture::Constant(c)
}

#[test]
fn bad_coating_parameters_are_refused() {
    let m = |kind| Material {
        kind,
        two_sided: false,
        detail: Detail::NONE,
    };
    let ok = m(MaterialKind::Plastic {
        eta: 1.5,
        diffuse_reflectance: constant(Rgb::splat(0.5)),
        specular_reflectance: constant(Rgb::ONE),
        nonlinear: false,
    });
    assert!(ok.validate().is_ok());
    for eta in [f32::NAN, -1.0, 0.0] {
        let bad = m(MaterialKind::Plastic {
            eta,
            diffuse_reflectance: constant(Rgb::splat(0.5)),
            specular_reflectance: constant(Rgb::ONE),
            nonlinear: false,
        });
        assert!(bad.validate().is_err(), "η={eta}");
    }
    let rough = |alpha: f32, eta: f32, rho: f32| {
        m(MaterialKind::RoughPlastic {
            distribution: Distribution::Ggx,
            alpha,
            eta,
            diffuse_reflectance: constant(Rgb::splat(rho)),
            specular_reflectance: constant(Rgb::ONE),
            nonlinear: false,
            coating: RoughCoating::new(Distribution::Ggx, 0.1, 1.5),
        })
    };
    assert!(rough(0.1, 1.5, 0.5).validate().is_ok());
    for (a, e, r) in [
        (0.0, 1.5, 0.5),
        (f32::NAN, 1.5, 0.5),
        (0.1, 1.0, 0.5),
        (0.1, 1.5, -0.1),
    ] {
        assert!(rough(a, e, r).validate().is_err(), "{a} {e} {r}");
    }
    let thin_bad = m(MaterialKind::ThinDielectric {
        eta: 1.5,
        specular_reflectance: constant(Rgb::new(f32::NAN, 0.0, 0.0)),
        specular_transmittance: constant(Rgb::ONE),
    });
    assert!(thin_bad.validate().is_err());
}

fn rough_glass(alpha: f32, eta: f32, t: f32, two_sided: bool) -> Material {
    Material {
        kind: MaterialKind::RoughDielectric {
            distribution: Distribution::Ggx,
            alpha,
            eta,
            specular_reflectance: constant(Rgb::ONE),
            specular_transmittance: constant(Rgb::splat(t)),
        },
        two_sided,
        detail: Detail::NONE,
    }
}

#[test]
fn rough_dielectric_refuses_bad_parameters() {
    let m = |alpha, eta, t| rough_glass(alpha, eta, t, false);
    assert!(m(0.1, 1.5, 1.0).validate().is_ok());
    for (a, e, t) in [
        (f32::NAN, 1.5, 1.0),
        (0.0, 1.5, 1.0),
        (-0.1, 1.5, 1.0),
        (0.1, 1.0, 1.0),
        (0.1, f32::NAN, 1.0),
        (0.1, -1.5, 1.0),
        (0.1, 1.5, -1.0),
        (0.1, 1.5, f32::INFINITY),
    ] {
        assert!(m(a, e, t).validate().is_err(), "α {a} η {e} t {t}");
    }
}

/// A rough dielectric is one interface: `two_sided` is ignored, so the
/// inside keeps its own (different) behaviour.
#[cfg(feature = "rough-refraction")]
#[test]
fn rough_dielectric_ignores_two_sided() {
    use crate::bsdf::TransportMode;
    let texture = |t: &Texture| match t {
        Texture::Constant(c) => *c,
        _ => panic!("tests use constant textures"),
    };
    let two = rough_glass(0.3, 1.5, 1.0, true).bsdf(texture);
    let one = rough_glass(0.3, 1.5, 1.0, false).bsdf(texture);
    // Both below the surface, at opposite azimuths.
    let dir = |phi: f32| {
        let s = libm::sqrtf(1.0 - 0.6 * 0.6);
        glam::Vec3::new(s * libm::cosf(phi), s * libm::sinf(phi), -0.6)
    };
    let (wo, wi) = (dir(0.7), dir(0.7 + core::f32::consts::PI));
    assert_eq!(
        two.eval(wo, wi, TransportMode::Radiance),
        one.eval(wo, wi, TransportMode::Radiance)
    );
}

/// Named scalar parameters over Mitsuba's defaults.
fn principled_with(base: Rgb, eta: f32, scalars: &[(&str, f32)]) -> PrincipledParams {
    let mut p = PrincipledParams::DEFAULT;
    p.base_color = Texture::Constant(base);
    p.eta = eta;
    for &(name, v) in scalars {
        let t = match name {
            "roughness" => &mut p.roughness,
            "metallic" => &mut p.metallic,
            "spec_trans" => &mut p.spec_trans,
            "sheen" => &mut p.sheen,
            "clearcoat_gloss" => &mut p.clearcoat_gloss,
            _ => panic!("unknown parameter {name}"),
        };
        *t = Texture::Constant(Rgb::splat(v));
    }
    p
}

#[test]
fn principled_refuses_bad_parameters() {
    let ok = principled_with(Rgb::splat(0.5), 1.5, &[]);
    let material = |p: PrincipledParams| Material {
        kind: MaterialKind::Principled(p),
        two_sided: false,
        detail: Default::default(),
    };
    assert!(material(ok).validate().is_ok());
    let mut bad = Vec::new();
    for (name, v) in [
        ("roughness", f32::NAN),
        ("metallic", -0.1),
        ("sheen", 1.5),
        ("clearcoat_gloss", 2.0),
    ] {
        bad.push((name, principled_with(Rgb::splat(0.5), 1.5, &[(name, v)])));
    }
    bad.push((
        "base_color",
        principled_with(Rgb::new(0.5, -1.0, 0.5), 1.5, &[]),
    ));
    bad.push((
        "base_color NaN",
        principled_with(Rgb::new(0.5, f32::NAN, 0.5), 1.5, &[]),
    ));
    bad.push(("eta", principled_with(Rgb::splat(0.5), -1.5, &[])));
    bad.push(("eta NaN", principled_with(Rgb::splat(0.5), f32::NAN, &[])));
    bad.push((
        "eta 1 with spec_trans",
        principled_with(Rgb::splat(0.5), 1.0, &[("spec_trans", 0.5)]),
    ));
    for (name, p) in bad {
        assert!(material(p).validate().is_err(), "{name} accepted");
    }
    // Index-matched is allowed when nothing transmits (Mitsuba's
    // `specular` = 0): the dielectric specular then vanishes.
    assert!(
        material(principled_with(Rgb::splat(0.5), 1.0, &[]))
            .validate()
            .is_ok()
    );
}

/// Mitsuba's `specular` as η: 0.5 is F0 = 0.04, η = 1.5 (Burley 2015).
#[test]
fn principled_eta_from_specular() {
    let eta = PrincipledParams::eta_from_specular(0.5);
    assert!((eta - 1.5).abs() < 1e-6, "{eta}");
    let r = (eta - 1.0) / (eta + 1.0);
    assert!((r * r - 0.04).abs() < 1e-6, "{}", r * r);
}

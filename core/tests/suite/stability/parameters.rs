//! Extreme parameters: k = 1 and 64, m = 1 and 1000, σ tiny and huge,
//! large-step probability 0 and 1, 1×1 and 4096×16 images; chains started
//! on zero-contribution paths; multiple-try steps whose candidates are all
//! zero. Each on a furnace (answer 2).

use cmlt::math::{Rgb, Vec3};
use cmlt::mlt::{CmltSettings, Level2Settings, MltSettings};
use cmlt::renderer::{Estimator, RendererConfig};
use cmlt::scene::{ConductorFresnel, Material, MaterialKind, Scene, Texture};

use super::*;

/// The furnace with an emitting mirror sphere (reflectance ½, Le = 1):
/// still 2 everywhere, and it has paths for both level-2 perturbations
/// (lens: E D …; caustic: E D S D …).
fn mirror_sphere_furnace() -> Scene {
    furnace_with(1.0, Vec3::ZERO, |_, _, b| {
        let mirror = b.add_material(Material {
            kind: MaterialKind::Conductor {
                fresnel: ConductorFresnel::Perfect,
                specular_reflectance: Texture::Constant(Rgb::splat(0.5)),
            },
            two_sided: false,
            detail: Default::default(),
        });
        let mut s = common::sphere(Vec3::new(0.2, 0.1, 0.3), 0.45, mirror);
        s.emission = Some(Rgb::ONE);
        b.add_mesh(s);
    })
}

/// CMLT with `c` at depth 12.
fn cmlt(c: CmltSettings) -> RendererConfig {
    RendererConfig {
        estimator: Estimator::Cmlt(c),
        ..config(EstimatorKind::Cmlt, Some(12))
    }
}

/// The stability suite's CMLT settings.
fn base() -> CmltSettings {
    match config(EstimatorKind::Cmlt, None).estimator {
        Estimator::Cmlt(c) => c,
        other => panic!("{other:?}"),
    }
}

#[test]
fn extreme_level2_parameters_keep_the_furnace_at_two() {
    let scene = mirror_sphere_furnace();
    let base = base();
    let (m, l2) = (base.mlt, base.level2);
    let level2 = |level2| CmltSettings { level2, ..base };
    let level1 = |mlt| CmltSettings { mlt, ..base };
    let cases: [(&str, CmltSettings, u64); 10] = [
        ("k = 1", level2(Level2Settings { k: 1, ..l2 }), 16),
        ("k = 64", level2(Level2Settings { k: 64, m: 1, ..l2 }), 2),
        ("m = 1", level2(Level2Settings { m: 1, ..l2 }), 16),
        (
            "m = 1000",
            CmltSettings {
                mlt: MltSettings { n_chains: 4, ..m },
                level2: Level2Settings {
                    m: 1000,
                    k: 1,
                    ..l2
                },
            },
            1,
        ),
        (
            "lens σ = 1e-6 px",
            level2(Level2Settings {
                lens_sigma: 1e-6,
                ..l2
            }),
            8,
        ),
        (
            "caustic scale 1e-6",
            level2(Level2Settings {
                caustic_scale: 1e-6,
                ..l2
            }),
            8,
        ),
        ("σ = 1e-30", level1(MltSettings { sigma: 1e-30, ..m }), 8),
        ("σ = 1", level1(MltSettings { sigma: 1.0, ..m }), 8),
        (
            "large steps only",
            level1(MltSettings {
                large_step_prob: 1.0,
                ..m
            }),
            8,
        ),
        (
            "small steps only",
            level1(MltSettings {
                large_step_prob: 0.0,
                ..m
            }),
            8,
        ),
    ];
    for (what, c, upp) in cases {
        let r = render_cfg(what, &scene, cmlt(c), upp);
        r.assert_finite().assert_mean(2.0, 0.05);
        let s = r.stats.mlt;
        assert_eq!(
            s.records - s.pass_records,
            s.mutations * (1 + c.level2.m as u64),
            "{what}"
        );
        assert!(s.lens_steps + s.caustic_steps > 0, "{what}: {s:?}");
    }
}

/// Lens σ of 10⁶ pixels (and a caustic σ to match) throws every
/// multiple-try candidate off the image: all k candidates of every step
/// have zero contribution, the side chain stays put and records the state
/// where it is. The image is still right.
#[test]
fn multiple_try_steps_with_only_zero_candidates() {
    let scene = mirror_sphere_furnace();
    let c = base();
    let c = CmltSettings {
        level2: Level2Settings {
            lens_sigma: 1e6,
            k: 8,
            m: 2,
            ..c.level2
        },
        ..c
    };
    let r = render_cfg("all candidates zero", &scene, cmlt(c), 16);
    r.assert_finite().assert_mean(2.0, 0.05);
    let s = r.stats.mlt;
    assert!(s.l2_candidates > 0);
    assert_eq!(s.lens_accepted, 0, "{s:?}");
    assert!(s.l2_zero_fraction() > 0.99, "{s:?}");
    // Half the image is still right (the level-1 chains carry it).
    let left = r.region_mean(0..8, 0..12);
    assert!((left - 2.0).abs() < 0.3, "left half {left}");
}

/// One bootstrap sample per depth: at most depths it has zero contribution,
/// while the BDPT passes still find b_d > 0 there, so chains start on
/// zero-contribution paths and must walk off them. Plain MLT and CMLT.
#[test]
fn chains_started_on_zero_contribution_paths() {
    let scene = mirror_sphere_furnace();
    for m in [EstimatorKind::Mlt, EstimatorKind::Cmlt] {
        let cfg = with_mlt(config(m, Some(12)), |s| {
            s.n_bootstrap = 1;
            s.b_passes = 4;
        });
        let r = render_cfg("zero-contribution starts", &scene, cfg, 16);
        r.assert_finite().assert_mean(2.0, 0.05);
        assert!(r.stats.mlt.chains > 0);
    }
    // And an open scene where most seed paths miss everything.
    let mut b = cmlt::scene::SceneBuilder::new();
    let grey = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    b.add_mesh(quad(
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::new(2.0, 0.0, 0.0),
        grey,
        None,
    ));
    b.add_mesh(quad(
        Vec3::new(-0.05, 1.0, -0.05),
        Vec3::new(0.1, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 0.1),
        grey,
        Some(50.0),
    ));
    b.set_camera(look_at(Vec3::new(0.0, 3.0, -3.0), Vec3::ZERO, 40.0, 16, 12));
    let open = b.build().unwrap();
    let reference = render("open", &open, EstimatorKind::Bdpt, Some(3), 64).mean();
    for m in [EstimatorKind::Mlt, EstimatorKind::Cmlt] {
        let cfg = with_mlt(config(m, Some(3)), |s| {
            s.n_bootstrap = 1;
            s.b_passes = 8;
        });
        render_cfg("zero-contribution starts, open", &open, cfg, 16)
            .assert_finite()
            .assert_mean(reference, 0.1);
    }
}

/// 1×1 and 4096×16 images of the furnace (the latter 256:1, so its
/// vertical field of view is tiny).
#[test]
fn one_pixel_and_4096_by_16_images() {
    for (w, h, upp) in [(1u32, 1u32, 256u64), (4096, 16, 1)] {
        let mut scene = furnace();
        scene.camera = look_at(
            Vec3::new(0.1, -0.2, -0.6),
            Vec3::new(0.1, -0.2, 0.4),
            70.0,
            w,
            h,
        );
        let what = format!("{w}×{h}");
        for m in ALL {
            let mut cfg = config(m, Some(12));
            if w == 1 && m.is_metropolis() {
                // One pixel: b comes from `b_passes` samples only.
                cfg = with_mlt(cfg, |s| {
                    s.n_chains = 8;
                    s.b_passes = 256;
                });
            }
            render_cfg(&what, &scene, cfg, upp)
                .assert_finite()
                .assert_mean(2.0, furnace_tol(m));
        }
    }
}

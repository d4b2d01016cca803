//! Feature-stripped builds: a scene needing an effect whose cargo feature
//! is off is rejected with an error naming the effect and the feature,
//! never rendered; with the feature on it builds. The same test runs in
//! every configuration, e.g. the minimal one in CI:
//!
//!     cargo test -p cmlt --no-default-features --features std --test effects
//!
//! and with all effects in `cargo test --workspace`.

use crate::common;

use cmlt::accel::bvh::Bvh;
use cmlt::math::{Mat4, Rgb};
use cmlt::mlt::{CmltSettings, MltSettings};
use cmlt::renderer::{Estimator, RenderError, RenderWorker, Renderer, RendererConfig};
use cmlt::scene::{
    Camera, ConductorFresnel, Detail, Distribution, Effect, EffectSet, FovAxis, Material,
    MaterialKind, PrincipledParams, RoughCoating, Scene, SceneBuilder, SceneError, ShapeGroup,
    ShapePoint, ShapeSurface, Texture,
};

fn camera(aperture: f32) -> Camera {
    Camera::perspective(Mat4::IDENTITY, 60.0, FovAxis::X, 4, 4, aperture, 1.0).unwrap()
}

/// A closed emitting box of `material` seen through a camera with
/// `aperture`.
fn build(material: Material, aperture: f32) -> Result<Scene, SceneError> {
    let mut b = SceneBuilder::new();
    let m = b.add_material(material);
    b.add_mesh(common::inward_box(m, 1.0));
    b.set_camera(camera(aperture));
    b.build()
}

fn opaque(kind: MaterialKind) -> Material {
    Material {
        kind,
        two_sided: true,
        detail: Default::default(),
    }
}

/// One scene per effect with a feature, each needing only that one beyond
/// diffuse reflection and area lights.
fn scenes() -> Vec<(Effect, Material, f32)> {
    let tint = Texture::Constant(Rgb::splat(0.8));
    vec![
        (
            Effect::Glossy,
            opaque(MaterialKind::RoughConductor {
                distribution: Distribution::Ggx,
                alpha: 0.2,
                fresnel: ConductorFresnel::Perfect,
                specular_reflectance: tint,
            }),
            0.0,
        ),
        (
            Effect::SpecularReflection,
            opaque(MaterialKind::Conductor {
                fresnel: ConductorFresnel::Perfect,
                specular_reflectance: tint,
            }),
            0.0,
        ),
        (
            Effect::Refraction,
            Material {
                kind: MaterialKind::Dielectric { eta: 1.5 },
                two_sided: false,
                detail: Default::default(),
            },
            0.0,
        ),
        (
            Effect::RoughRefraction,
            Material {
                kind: MaterialKind::RoughDielectric {
                    distribution: Distribution::Beckmann,
                    alpha: 0.2,
                    eta: 1.5,
                    specular_reflectance: tint,
                    specular_transmittance: tint,
                },
                two_sided: false,
                detail: Detail::NONE,
            },
            0.0,
        ),
        (
            Effect::Principled,
            opaque(MaterialKind::Principled(PrincipledParams {
                metallic: Texture::Constant(Rgb::splat(0.5)),
                ..PrincipledParams::DEFAULT
            })),
            0.0,
        ),
        (
            Effect::Textures,
            opaque(MaterialKind::Diffuse {
                reflectance: Texture::Checkerboard {
                    color0: Rgb::splat(0.2),
                    color1: Rgb::splat(0.8),
                    to_uv: glam::Affine2::IDENTITY,
                },
            }),
            0.0,
        ),
        (
            Effect::DepthOfField,
            Material::diffuse(Rgb::splat(0.5)),
            0.05,
        ),
        (
            Effect::NormalMapping,
            Material {
                detail: Detail {
                    normal_map: Some(Texture::Constant(Rgb::new(0.6, 0.5, 0.9))),
                    ..Detail::NONE
                },
                ..Material::diffuse(Rgb::splat(0.5))
            },
            0.0,
        ),
        (
            Effect::AlphaMasks,
            Material {
                detail: Detail {
                    opacity: Some(Texture::Constant(Rgb::splat(0.5))),
                    ..Detail::NONE
                },
                ..Material::diffuse(Rgb::splat(0.5))
            },
            0.0,
        ),
        (
            Effect::Coating,
            opaque(MaterialKind::Plastic {
                eta: 1.5,
                diffuse_reflectance: tint,
                specular_reflectance: Texture::Constant(Rgb::ONE),
                nonlinear: false,
            }),
            0.0,
        ),
        (
            Effect::Coating,
            opaque(MaterialKind::RoughPlastic {
                distribution: Distribution::Beckmann,
                alpha: 0.2,
                eta: 1.5,
                diffuse_reflectance: tint,
                specular_reflectance: Texture::Constant(Rgb::ONE),
                nonlinear: true,
                coating: RoughCoating::new(Distribution::Beckmann, 0.2, 1.5),
            }),
            0.0,
        ),
        (
            Effect::RoughDiffuse,
            opaque(MaterialKind::RoughDiffuse {
                reflectance: tint,
                alpha: 0.5,
                fast_approx: false,
            }),
            0.0,
        ),
        (
            Effect::Refraction,
            Material {
                kind: MaterialKind::ThinDielectric {
                    eta: 1.5,
                    specular_reflectance: tint,
                    specular_transmittance: tint,
                },
                two_sided: false,
                detail: Detail::NONE,
            },
            0.0,
        ),
        (
            Effect::Media,
            Material {
                kind: MaterialKind::Null,
                two_sided: false,
                detail: Detail::NONE,
            },
            0.0,
        ),
    ]
}

#[test]
fn a_scene_needing_an_unbuilt_effect_is_rejected_by_name() {
    for (effect, material, aperture) in scenes() {
        let feature = effect
            .feature()
            .expect("every stripped effect has a feature");
        match build(material, aperture) {
            Ok(scene) => {
                assert!(
                    effect.is_built(),
                    "{} built without `{feature}`",
                    effect.name()
                );
                let a = scene.analysis(&scene.camera);
                assert!(a.effects.contains(effect));
            }
            Err(e) => {
                assert!(!effect.is_built(), "{}: {e}", effect.name());
                assert_eq!(e, SceneError::EffectNotBuilt { effect });
                let text = e.to_string();
                assert!(
                    text.contains(effect.name()) && text.contains(&format!("`{feature}`")),
                    "{text}"
                );
            }
        }
    }
}

/// A host shape's material counts like a mesh's: a glass sphere the host
/// intersects itself needs `refraction` too.
#[test]
fn host_shapes_need_their_materials_built() {
    struct Nowhere;
    impl ShapeSurface for Nowhere {
        fn surface(&self, _: u32, _: f32, _: f32) -> Option<ShapePoint> {
            None
        }
    }
    let mut b = SceneBuilder::new();
    let walls = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    let glass = b.add_material(Material {
        kind: MaterialKind::Dielectric { eta: 1.5 },
        two_sided: false,
        detail: Default::default(),
    });
    b.add_mesh(common::inward_box(walls, 1.0));
    b.add_shapes(ShapeGroup {
        count: 1,
        material: glass,
        surface: std::sync::Arc::new(Nowhere),
    });
    b.set_camera(camera(0.0));
    match b.build() {
        Ok(scene) => {
            assert!(Effect::Refraction.is_built());
            assert!(
                scene
                    .analysis(&scene.camera)
                    .effects
                    .contains(Effect::Refraction)
            );
        }
        Err(e) => assert_eq!(
            e,
            SceneError::EffectNotBuilt {
                effect: Effect::Refraction
            }
        ),
    }
}

#[test]
fn diffuse_scenes_always_build_and_a_lens_camera_needs_its_feature() {
    // Diffuse reflection and area lights are never stripped.
    assert!(build(Material::diffuse(Rgb::splat(0.5)), 0.0).is_ok());
    let built = EffectSet::built();
    assert!(built.contains(Effect::Diffuse) && built.contains(Effect::AreaLights));
    // A renderer refuses a thin-lens camera the build cannot simulate
    // (the camera is not part of a scene there).
    let r = Renderer::new(RendererConfig::default(), camera(0.05));
    if Effect::DepthOfField.is_built() {
        assert!(r.is_ok());
    } else {
        assert_eq!(
            r.err(),
            Some(RenderError::EffectNotBuilt(Effect::DepthOfField))
        );
    }
}

/// The image mean of `scene` rendered through the frame loop with the
/// analysis on or off, and the renderer's analysis.
fn renderer_mean(
    scene: &Scene,
    estimator: Estimator,
    all_effects: bool,
    budget: u64,
) -> (f64, cmlt::scene::Analysis) {
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cfg = RendererConfig {
        estimator,
        seed: 5,
        all_effects,
        ..RendererConfig::default()
    };
    let mut r = Renderer::new(cfg, scene.camera).unwrap();
    let mut w = RenderWorker::new(&r, 0).unwrap();
    common::prepare(&mut r, std::slice::from_mut(&mut w), scene, &bvh);
    r.render(&mut w, scene, &bvh, budget).unwrap();
    let mut sum = 0.0f64;
    let mut n = 0;
    r.resolve(&[&w], |_, c| {
        sum += c.luminance() as f64;
        n += 1;
    })
    .unwrap();
    (sum / n as f64, *r.analysis())
}

#[test]
fn surfaces_that_do_not_scatter_cap_paths_at_one_segment_with_the_same_image() {
    // A black box that emits: every pixel sees emission directly and
    // nothing more, which the analysis turns into depth 1.
    let scene = build(Material::diffuse(Rgb::ZERO), 0.0).unwrap();
    let cmlt = Estimator::Cmlt(CmltSettings {
        mlt: MltSettings {
            n_bootstrap: 200,
            n_chains: 32,
            ..MltSettings::default()
        },
        ..CmltSettings::default()
    });
    for estimator in [Estimator::Path, Estimator::Bdpt, cmlt] {
        let kind = estimator.kind();
        let budget = 4 * 16;
        let (on, a) = renderer_mean(&scene, estimator, false, budget);
        let (off, all) = renderer_mean(&scene, estimator, true, budget);
        assert!(a.emitters_only && !all.emitters_only, "{kind:?}");
        assert!(on > 0.0, "{kind:?}");
        // Emission seen directly is exact for PT and BDPT; CMLT's b is
        // estimated, so allow noise.
        let tol = if kind.is_metropolis() { 0.05 } else { 1e-5 };
        assert!(
            (on - off).abs() <= tol * off,
            "{kind:?}: {on} with the analysis, {off} with every effect"
        );
    }
}

/// A point light needs `delta-lights`, a constant environment or an
/// environment map `environment`: without the feature the scene is
/// refused by name.
#[test]
fn lights_need_their_features_built() {
    use cmlt::scene::Light;
    let lights = [
        (
            Effect::PointLights,
            Light::Point {
                position: glam::Vec3::ZERO,
                intensity: Rgb::ONE,
            },
        ),
        (Effect::Environment, Light::Constant { radiance: Rgb::ONE }),
        (
            Effect::Environment,
            Light::Envmap {
                bitmap: cmlt::scene::BitmapId(0),
                scale: 1.0,
                to_world: glam::Mat3::IDENTITY,
            },
        ),
    ];
    for (effect, light) in lights {
        let mut b = SceneBuilder::new();
        b.add_bitmap(cmlt::scene::Bitmap::new(2, 1, vec![Rgb::ONE; 2]).unwrap());
        let m = b.add_material(Material::diffuse(Rgb::splat(0.5)));
        b.add_mesh(common::inward_box(m, 0.0));
        b.add_light(light);
        b.set_camera(camera(0.0));
        match b.build() {
            Ok(scene) => {
                assert!(effect.is_built(), "{}", effect.name());
                assert!(scene.analysis(&scene.camera).effects.contains(effect));
            }
            Err(e) => {
                assert!(!effect.is_built(), "{e}");
                assert_eq!(e, SceneError::EffectNotBuilt { effect });
            }
        }
    }
}

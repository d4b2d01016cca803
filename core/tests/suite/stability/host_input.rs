//! NaN, Inf and out-of-range values handed in through the Rust API are
//! rejected with a clear error before anything renders, and whatever was
//! built before stays usable.

use cmlt::integrator::Settings;
use cmlt::math::{Mat4, Rgb, Vec2, Vec3};
use cmlt::mlt::{Level2Settings, MltSettings};
use cmlt::renderer::{RenderError, RendererConfig};
use cmlt::scene::{
    CameraError, ConductorFresnel, Distribution, Material, MaterialKind, Mesh, SceneBuilder,
    SceneError, Texture,
};

use super::*;

fn good_mesh() -> Mesh {
    quad(
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::new(2.0, 0.0, 0.0),
        cmlt::scene::MaterialId(0),
        Some(1.0),
    )
}

#[test]
fn scene_builder_rejects_non_finite_and_out_of_range_values() {
    let build = |mesh: Mesh, material: Material| {
        let mut b = SceneBuilder::new();
        b.add_material(material);
        b.add_mesh(mesh);
        b.set_camera(look_at(Vec3::new(0.0, 1.0, -2.0), Vec3::ZERO, 60.0, 4, 4));
        b.build()
    };
    let white = Material::diffuse(Rgb::splat(0.5));
    assert!(build(good_mesh(), white).is_ok());
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    let with = |f: &dyn Fn(&mut Mesh)| {
        let mut m = good_mesh();
        f(&mut m);
        m
    };
    let bad_meshes: Vec<(&str, Mesh)> = vec![
        ("NaN position", with(&|m| m.positions[1].y = nan)),
        ("Inf position", with(&|m| m.positions[2].x = -inf)),
        (
            "NaN normal",
            with(&|m| m.normals = vec![Vec3::Y, Vec3::new(nan, 1.0, 0.0), Vec3::Y, Vec3::Y]),
        ),
        (
            "Inf uv",
            with(&|m| m.uvs = vec![Vec2::ZERO, Vec2::ZERO, Vec2::new(inf, 0.0), Vec2::ZERO]),
        ),
        ("normal count", with(&|m| m.normals = vec![Vec3::Y])),
        ("index", with(&|m| m.indices[1][2] = 4)),
        ("index u32::MAX", with(&|m| m.indices[0][0] = u32::MAX)),
        (
            "material",
            with(&|m| m.material = cmlt::scene::MaterialId(1)),
        ),
        (
            "NaN emission",
            with(&|m| m.emission = Some(Rgb::new(1.0, nan, 1.0))),
        ),
        (
            "Inf emission",
            with(&|m| m.emission = Some(Rgb::splat(inf))),
        ),
        (
            "negative emission",
            with(&|m| m.emission = Some(Rgb::new(1.0, -1.0, 1.0))),
        ),
    ];
    for (what, m) in bad_meshes {
        let e = build(m, white).expect_err(what);
        assert!(!e.to_string().is_empty());
        assert!(
            matches!(
                e,
                SceneError::NonFiniteVertex { mesh: 0, .. }
                    | SceneError::IndexOutOfRange { mesh: 0, .. }
                    | SceneError::AttributeCount { mesh: 0 }
                    | SceneError::UnknownMaterial { mesh: 0 }
                    | SceneError::InvalidEmission { mesh: 0 }
            ),
            "{what}: {e:?}"
        );
    }
    let c = |v: Rgb| Texture::Constant(v);
    let bad_materials = [
        ("NaN albedo", Material::diffuse(Rgb::new(nan, 0.5, 0.5))),
        (
            "negative albedo",
            Material::diffuse(Rgb::new(0.5, -0.1, 0.5)),
        ),
        ("Inf albedo", Material::diffuse(Rgb::splat(inf))),
        (
            "negative checkerboard colour",
            Material {
                kind: MaterialKind::Diffuse {
                    reflectance: Texture::Checkerboard {
                        color0: Rgb::splat(0.5),
                        color1: Rgb::new(0.5, -0.5, 0.5),
                        to_uv: glam::Affine2::IDENTITY,
                    },
                },
                two_sided: true,
                detail: Default::default(),
            },
        ),
        (
            "NaN glass",
            Material {
                kind: MaterialKind::Dielectric { eta: nan },
                two_sided: false,
                detail: Default::default(),
            },
        ),
        (
            "zero glass",
            Material {
                kind: MaterialKind::Dielectric { eta: 0.0 },
                two_sided: false,
                detail: Default::default(),
            },
        ),
        (
            "Inf glass",
            Material {
                kind: MaterialKind::Dielectric { eta: inf },
                two_sided: false,
                detail: Default::default(),
            },
        ),
        (
            "zero roughness",
            Material {
                kind: MaterialKind::RoughConductor {
                    distribution: Distribution::Ggx,
                    alpha: 0.0,
                    fresnel: ConductorFresnel::Perfect,
                    specular_reflectance: c(Rgb::ONE),
                },
                two_sided: true,
                detail: Default::default(),
            },
        ),
        (
            "NaN roughness",
            Material {
                kind: MaterialKind::RoughConductor {
                    distribution: Distribution::Beckmann,
                    alpha: nan,
                    fresnel: ConductorFresnel::Perfect,
                    specular_reflectance: c(Rgb::ONE),
                },
                two_sided: true,
                detail: Default::default(),
            },
        ),
        (
            "NaN conductor eta",
            Material {
                kind: MaterialKind::Conductor {
                    fresnel: ConductorFresnel::Complex {
                        eta: Rgb::splat(nan),
                        k: Rgb::ONE,
                    },
                    specular_reflectance: c(Rgb::ONE),
                },
                two_sided: false,
                detail: Default::default(),
            },
        ),
        (
            "unknown bitmap",
            Material {
                kind: MaterialKind::Diffuse {
                    reflectance: Texture::Bitmap {
                        id: cmlt::scene::BitmapId(3),
                        to_uv: glam::Affine2::IDENTITY,
                    },
                },
                two_sided: true,
                detail: Default::default(),
            },
        ),
    ];
    for (what, m) in bad_materials {
        let e = build(good_mesh(), m).expect_err(what);
        assert!(
            matches!(
                e,
                SceneError::InvalidMaterial { material: 0, .. }
                    | SceneError::UnknownBitmap { material: 0 }
            ),
            "{what}: {e:?}"
        );
    }
    let mut b = SceneBuilder::new();
    b.add_material(white);
    b.add_mesh(good_mesh());
    assert_eq!(b.build().err(), Some(SceneError::MissingCamera));
}

#[test]
fn camera_rejects_non_finite_and_out_of_range_values() {
    let ok = |m: Mat4, fov: f32, w: u32, h: u32, ap: f32, fd: f32| {
        Camera::perspective(m, fov, FovAxis::X, w, h, ap, fd)
    };
    let id = Mat4::IDENTITY;
    assert!(ok(id, 60.0, 4, 4, 0.0, 1.0).is_ok());
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    let cases = [
        ("NaN fov", ok(id, nan, 4, 4, 0.0, 1.0), CameraError::BadFov),
        ("zero fov", ok(id, 0.0, 4, 4, 0.0, 1.0), CameraError::BadFov),
        (
            "180° fov",
            ok(id, 180.0, 4, 4, 0.0, 1.0),
            CameraError::BadFov,
        ),
        (
            "negative fov",
            ok(id, -10.0, 4, 4, 0.0, 1.0),
            CameraError::BadFov,
        ),
        ("Inf fov", ok(id, inf, 4, 4, 0.0, 1.0), CameraError::BadFov),
        (
            "zero width",
            ok(id, 60.0, 0, 4, 0.0, 1.0),
            CameraError::BadResolution,
        ),
        (
            "zero height",
            ok(id, 60.0, 4, 0, 0.0, 1.0),
            CameraError::BadResolution,
        ),
        (
            "NaN aperture",
            ok(id, 60.0, 4, 4, nan, 1.0),
            CameraError::BadLens,
        ),
        (
            "negative aperture",
            ok(id, 60.0, 4, 4, -1.0, 1.0),
            CameraError::BadLens,
        ),
        (
            "zero focus",
            ok(id, 60.0, 4, 4, 0.5, 0.0),
            CameraError::BadLens,
        ),
        (
            "Inf focus",
            ok(id, 60.0, 4, 4, 0.5, inf),
            CameraError::BadLens,
        ),
        (
            "NaN transform",
            ok(
                Mat4::from_translation(Vec3::new(nan, 0.0, 0.0)),
                60.0,
                4,
                4,
                0.0,
                1.0,
            ),
            CameraError::BadTransform,
        ),
        (
            "Inf transform",
            ok(Mat4::from_scale(Vec3::splat(inf)), 60.0, 4, 4, 0.0, 1.0),
            CameraError::BadTransform,
        ),
        (
            "zero transform",
            ok(Mat4::ZERO, 60.0, 4, 4, 0.0, 1.0),
            CameraError::BadTransform,
        ),
        (
            "up along the view",
            ok(
                Mat4::from_cols(Vec4::X, Vec4::Z, Vec4::Z, Vec4::W),
                60.0,
                4,
                4,
                0.0,
                1.0,
            ),
            CameraError::BadTransform,
        ),
    ];
    for (what, got, want) in cases {
        assert_eq!(got.err(), Some(want), "{what}");
    }
}

use glam::Vec4;

/// Bad configurations are refused by `Renderer::new` (nothing is made);
/// a renderer made before them keeps rendering the same image.
#[test]
fn renderer_config_rejects_out_of_range_values_and_stays_usable() {
    let scene = furnace();
    let good = config(EstimatorKind::Cmlt, Some(8));
    let before = render_cfg("before", &scene, good, 4);
    before.assert_finite();
    let level1 = |f: fn(&mut MltSettings)| with_mlt(good, f);
    let level2 = |f: fn(&mut Level2Settings)| with_level2(good, f);
    let unbounded = |depth_cap| RendererConfig {
        depth_cap,
        settings: Settings {
            max_depth: None,
            ..good.settings
        },
        ..good
    };
    let bad: Vec<(&str, RendererConfig)> = vec![
        ("no workers", RendererConfig { workers: 0, ..good }),
        ("k = 0", level2(|l| l.k = 0)),
        ("k = 65", level2(|l| l.k = 65)),
        ("m = 0", level2(|l| l.m = 0)),
        ("σ = 0", level1(|m| m.sigma = 0.0)),
        ("σ NaN", level1(|m| m.sigma = f32::NAN)),
        ("σ > 1", level1(|m| m.sigma = 1.5)),
        ("large step NaN", level1(|m| m.large_step_prob = f32::NAN)),
        ("large step 2", level1(|m| m.large_step_prob = 2.0)),
        ("no chains", level1(|m| m.n_chains = 0)),
        ("lens σ Inf", level2(|l| l.lens_sigma = f32::INFINITY)),
        ("lens σ 0", level2(|l| l.lens_sigma = 0.0)),
        ("caustic scale NaN", level2(|l| l.caustic_scale = f32::NAN)),
        ("no bootstrap samples", level1(|m| m.n_bootstrap = 0)),
        (
            "path space, bidirectional weight 0",
            level1(|m| m.path_mutations.bidirectional = 0.0),
        ),
        (
            "path space, caustic weight NaN",
            level1(|m| m.path_mutations.caustic = f32::NAN),
        ),
        (
            "path space, perturbation σ -1",
            level1(|m| m.path_mutations.sigma = -1.0),
        ),
        ("depth cap 0, unbounded", unbounded(0)),
        (
            "depth u32::MAX",
            RendererConfig {
                settings: Settings {
                    max_depth: Some(u32::MAX),
                    ..good.settings
                },
                ..good
            },
        ),
        ("depth cap u32::MAX", unbounded(u32::MAX)),
    ];
    for (what, cfg) in &bad {
        match Renderer::new(*cfg, scene.camera) {
            Err(RenderError::Config(msg)) => assert!(!msg.is_empty()),
            other => panic!("{what}: {:?}", other.err()),
        }
        // The depth limit and the worker count are every estimator's.
        if what.starts_with("depth") || what.starts_with("no workers") {
            for estimator in [Estimator::Path, Estimator::Mlt(small_mlt())] {
                let cfg = RendererConfig { estimator, ..*cfg };
                match Renderer::new(cfg, scene.camera) {
                    Err(RenderError::Config(msg)) => assert!(!msg.is_empty()),
                    other => panic!("{what} ({estimator:?}): {:?}", other.err()),
                }
            }
        }
    }
    let after = render_cfg("after", &scene, good, 4);
    assert_eq!(before.img, after.img);
}

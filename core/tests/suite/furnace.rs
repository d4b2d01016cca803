//! White furnace: a closed box whose walls all emit Le = 1 and reflect with
//! albedo a = 0.5 has radiance Le / (1 − a) = 2 everywhere; truncated at
//! `max_depth` segments it is Le · Σ_{k<max_depth} aᵏ (Mitsuba's depth
//! semantics). Every estimator must reproduce these numbers.

use crate::common;

use cmlt::accel::bvh::Bvh;
use cmlt::film::Film;
use cmlt::integrator::bdpt::{self, PathStorage};
use cmlt::integrator::{Settings, Tracer};
use cmlt::math::{Rgb, Vec2, Vec3};
use cmlt::renderer::Estimator;
use cmlt::sampler::SampleStream;
use cmlt::scene::{ConductorFresnel, Material, MaterialKind, Scene, SceneBuilder, Texture};

/// The cube [-1,1]³ with every face wound so its normal points inwards.
fn inward_box(albedo: f32, emission: f32) -> Scene {
    furnace(Material::diffuse(Rgb::splat(albedo)), emission, 0.0, None)
}

/// A closed emitting box of `wall` material, optionally with an object,
/// seen by a camera with the given aperture.
fn furnace(wall: Material, emission: f32, aperture: f32, object: Option<(Material, f32)>) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.add_material(wall);
    if let Some((mat, radius)) = object {
        let id = b.add_material(mat);
        b.add_mesh(common::sphere(Vec3::new(0.0, 0.0, 0.6), radius, id));
    }
    b.add_mesh(common::inward_box(m, emission));
    b.set_camera(common::furnace_camera(Vec3::new(0.1, -0.2, -0.6), aperture));
    b.build().unwrap()
}

fn mean(img: &[Rgb]) -> Rgb {
    let mut s = Rgb::ZERO;
    for p in img {
        s += *p;
    }
    s / img.len() as f32
}

/// The mean of `passes` passes of PT or BDPT (seed 7) through the
/// renderer, and the non-finite contributions its film dropped.
fn render_mean(scene: &Scene, method: Estimator, settings: Settings, passes: u64) -> (Rgb, u64) {
    let r = common::render(scene, method, settings, 7, passes);
    (mean(&r.image), r.stats.nonfinite)
}

/// The mean of `passes` passes of BDPT whose samples go through `paths`
/// (with its strategy filter), one sample per pixel and pass from the
/// stream of (`seed`, pass, pixel) as the renderer draws them: the
/// renderer keeps its path storage to itself, so this test calls
/// [`bdpt::sample`] itself. The furnaces here use seed 7.
pub(crate) fn bdpt_mean_with(
    scene: &Scene,
    passes: u64,
    mut paths: PathStorage,
    seed: u64,
) -> (Rgb, Film) {
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(scene, &accel);
    let (w, h) = (scene.camera.width(), scene.camera.height());
    let mut film = Film::new(w, h);
    let settings = Settings::default();
    for pass in 0..passes {
        for y in 0..h {
            for x in 0..w {
                let mut rng = SampleStream::new(seed, pass, y as u64 * w as u64 + x as u64);
                let raster = Vec2::new(x as f32, y as f32) + rng.next_2d();
                bdpt::sample(
                    &mut tracer,
                    &settings,
                    &mut paths,
                    raster,
                    x,
                    y,
                    &mut rng,
                    &mut film,
                );
            }
        }
        film.end_pass();
    }
    (mean(&film.resolve()), film)
}

#[test]
fn furnace_radiance_is_two_for_pt_and_bdpt() {
    let scene = inward_box(0.5, 1.0);
    for method in [Estimator::Path, Estimator::Bdpt] {
        let (mean, nonfinite) = render_mean(&scene, method, Settings::default(), 256);
        assert_eq!(nonfinite, 0);
        for c in 0..3 {
            let rel = (mean[c] - 2.0).abs() / 2.0;
            assert!(
                rel < 0.005,
                "{method:?}: mean {mean:?}, expected 2 within 0.5%"
            );
        }
    }
}

#[test]
fn truncated_furnace_follows_mitsuba_depth() {
    let scene = inward_box(0.5, 1.0);
    for method in [Estimator::Path, Estimator::Bdpt] {
        for max_depth in [1u32, 2, 3, 5] {
            let settings = Settings {
                max_depth: Some(max_depth),
                ..Settings::default()
            };
            let (mean, _) = render_mean(&scene, method, settings, 96);
            let expected: f32 = (0..max_depth).map(|k| 0.5f32.powi(k as i32)).sum();
            let rel = (mean.g - expected).abs() / expected;
            assert!(
                rel < 0.005,
                "{method:?} max_depth {max_depth}: {} vs {expected}",
                mean.g
            );
        }
    }
}

#[test]
fn hidden_emitters_remove_only_the_first_segment() {
    let scene = inward_box(0.5, 1.0);
    let settings = Settings {
        hide_emitters: true,
        ..Settings::default()
    };
    for method in [Estimator::Path, Estimator::Bdpt] {
        let (mean, _) = render_mean(&scene, method, settings, 128);
        assert!((mean.g - 1.0).abs() < 0.01, "{method:?}: {}", mean.g);
    }
}

#[test]
fn thin_lens_furnace_is_two() {
    let scene = furnace(Material::diffuse(Rgb::splat(0.5)), 1.0, 0.3, None);
    for method in [Estimator::Path, Estimator::Bdpt] {
        let (mean, _) = render_mean(&scene, method, Settings::default(), 256);
        assert!((mean.g - 2.0).abs() / 2.0 < 0.005, "{method:?}: {}", mean.g);
    }
}

#[test]
fn mirror_furnace_is_two() {
    // Perfect-Fresnel mirror walls reflecting half the light: L = Le + ½L.
    let mirror = Material {
        kind: MaterialKind::Conductor {
            fresnel: ConductorFresnel::Perfect,
            specular_reflectance: Texture::Constant(Rgb::splat(0.5)),
        },
        two_sided: true,
        detail: Default::default(),
    };
    let scene = furnace(mirror, 1.0, 0.0, None);
    for method in [Estimator::Path, Estimator::Bdpt] {
        let (mean, nonfinite) = render_mean(&scene, method, Settings::default(), 64);
        assert_eq!(nonfinite, 0);
        assert!((mean.g - 2.0).abs() / 2.0 < 0.005, "{method:?}: {}", mean.g);
    }
}

#[test]
fn glass_in_a_furnace_is_invisible() {
    // A lossless dielectric in a uniform radiance field changes nothing seen
    // from outside: the η² radiance scaling on entry and exit cancels, and
    // BDPT's importance transport must agree.
    for eta in [1.5f32, 1.0, 0.7] {
        let glass = Material {
            kind: MaterialKind::Dielectric { eta },
            two_sided: false,
            detail: Default::default(),
        };
        let scene = furnace(
            Material::diffuse(Rgb::splat(0.5)),
            1.0,
            0.0,
            Some((glass, 0.3)),
        );
        for method in [Estimator::Path, Estimator::Bdpt] {
            let (mean, nonfinite) = render_mean(&scene, method, Settings::default(), 128);
            assert_eq!(nonfinite, 0);
            assert!(
                (mean.g - 2.0).abs() / 2.0 < 0.006,
                "eta {eta} {method:?}: {}",
                mean.g
            );
        }
    }
}

/// The inside of an emitting diffuse sphere (radius 1, albedo ½, Le = 1):
/// between two points of a sphere G = cos·cos/d² = 1/(4R²) is constant, so
/// connection strategies have no geometric singularity and tiny variance.
fn sphere_furnace(aperture: f32) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    let mut mesh = common::sphere(Vec3::ZERO, 1.0, m);
    for t in &mut mesh.indices {
        t.swap(1, 2);
    }
    mesh.emission = Some(Rgb::ONE);
    b.add_mesh(mesh);
    b.set_camera(common::furnace_camera(Vec3::new(0.1, -0.2, -0.3), aperture));
    b.build().unwrap()
}

/// Each BDPT strategy alone (unweighted) must estimate exactly the paths of
/// its length: in the furnace, paths of k = s + t − 1 segments carry
/// Le · a^(k−1). This checks light tracing (t = 1, both camera models),
/// next-event estimation (s = 1), pure camera paths (s = 0) and every
/// interior connection separately, where the MIS-weighted furnace could
/// hide an error in a strategy of small weight. Run for one camera model.
fn check_every_bdpt_strategy_alone(aperture: f32) {
    macro_rules! only {
        ($s:literal, $t:literal) => {
            (|s, t| s == $s && t == $t) as fn(usize, usize) -> bool
        };
    }
    type Filter = fn(usize, usize) -> bool;
    let strategies: [(usize, usize, Filter); 12] = [
        (0, 2, only!(0, 2)),
        (0, 3, only!(0, 3)),
        (0, 4, only!(0, 4)),
        (1, 2, only!(1, 2)),
        (1, 3, only!(1, 3)),
        (2, 1, only!(2, 1)),
        (3, 1, only!(3, 1)),
        (4, 1, only!(4, 1)),
        (2, 2, only!(2, 2)),
        (2, 3, only!(2, 3)),
        (3, 2, only!(3, 2)),
        (1, 4, only!(1, 4)),
    ];
    let scene = sphere_furnace(aperture);
    for (s, t, filter) in strategies {
        let mut paths = PathStorage::new();
        paths.set_strategy_filter(Some(filter));
        let (mean, film) = bdpt_mean_with(&scene, 256, paths, 7);
        assert_eq!(film.nonfinite(), 0);
        let expected = 0.5f32.powi((s + t) as i32 - 2);
        let rel = (mean.g - expected).abs() / expected;
        assert!(
            rel < 0.02,
            "aperture {aperture}, strategy (s={s}, t={t}): {} vs {expected}",
            mean.g
        );
    }
}

// The two camera models are two tests, so that they run side by side.

#[test]
fn every_bdpt_strategy_alone_is_unbiased_pinhole() {
    check_every_bdpt_strategy_alone(0.0);
}

#[test]
fn every_bdpt_strategy_alone_is_unbiased_thin_lens() {
    check_every_bdpt_strategy_alone(0.3);
}

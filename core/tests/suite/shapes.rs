//! Host shapes (`cmlt::scene::shapes`): analytic spheres the "host"
//! intersects itself, shaded from the points its `ShapeSurface` returns.
//! Checked against analytic answers with every estimator: a lossless
//! sphere in a white furnace keeps the radiance 2 everywhere, and a convex
//! diffuse sphere under uniform light Le has radiance ρ·Le at every pixel
//! it covers. Invalid host answers never reach the film.

use crate::common;

use std::sync::Arc;

use cmlt::accel::Intersector;
use cmlt::accel::bvh::Bvh;
use cmlt::geometry::{Hit, Ray};
use cmlt::math::{Rgb, Vec2, Vec3};
use cmlt::mlt::{CmltSettings, Level2Settings, MltSettings};
use cmlt::renderer::{Estimator, RenderStats, RenderWorker, Renderer, RendererConfig};
use cmlt::scene::{
    Material, MaterialId, MaterialKind, SHAPE_PRIM_BIT, Scene, SceneBuilder, SceneError,
    ShapeGroup, ShapePoint, ShapeSurface,
};

/// Spheres as a host would keep them: centre and radius.
#[derive(Clone)]
struct Spheres(Vec<(Vec3, f32)>);

impl Spheres {
    /// Ray parameter of the nearest crossing of sphere `i` in `(0, t_max)`,
    /// solved in f64 so rays leaving the surface (offset by the core past
    /// the point's error bound) do not find it again.
    fn hit(&self, i: usize, ray: &Ray) -> Option<f32> {
        let (c, r) = self.0[i];
        let o = (ray.o - c).as_dvec3();
        let d = ray.d.as_dvec3();
        let a = d.length_squared();
        let half_b = o.dot(d);
        let cc = o.length_squared() - (r as f64) * (r as f64);
        let disc = half_b * half_b - a * cc;
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        [(-half_b - s) / a, (-half_b + s) / a]
            .into_iter()
            .map(|t| t as f32)
            .find(|&t| t > 0.0 && t < ray.t_max)
    }
}

impl ShapeSurface for Spheres {
    /// `(u, v)` = polar angle θ and azimuth φ of the hit, as the
    /// intersector reports them.
    fn surface(&self, shape: u32, u: f32, v: f32) -> Option<ShapePoint> {
        let (c, r) = *self.0.get(shape as usize)?;
        let n = Vec3::new(u.sin() * v.cos(), u.sin() * v.sin(), u.cos());
        let p = c + r * n;
        Some(ShapePoint {
            p,
            // pbrt's bound for a point reprojected onto a sphere: γ₅·|p|.
            p_error: p.abs() * (5.0 * f32::EPSILON),
            ng: n,
            ns: n,
            uv: Vec2::new(v / std::f32::consts::TAU, u / std::f32::consts::PI),
        })
    }
}

/// The host's ray tracer: our BVH over the triangles plus the spheres.
struct Host {
    bvh: Bvh,
    spheres: Spheres,
}

impl Host {
    fn new(scene: &Scene, spheres: Spheres) -> Self {
        Host {
            bvh: Bvh::build(&scene.triangles().collect::<Vec<_>>()),
            spheres,
        }
    }
}

impl Intersector for Host {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best = self.bvh.intersect(ray);
        for i in 0..self.spheres.0.len() {
            let short = Ray {
                t_max: best.map_or(ray.t_max, |h| h.t),
                ..*ray
            };
            if let Some(t) = self.spheres.hit(i, &short) {
                let (c, _) = self.spheres.0[i];
                let n = (ray.at(t) - c).normalize();
                best = Some(Hit {
                    t,
                    prim: SHAPE_PRIM_BIT | i as u32,
                    b1: n.z.clamp(-1.0, 1.0).acos(),
                    b2: n.y.atan2(n.x),
                });
            }
        }
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        (0..self.spheres.0.len()).any(|i| self.spheres.hit(i, ray).is_some())
            || self.bvh.occluded(ray)
    }
}

/// PT, BDPT, MLT and CMLT (k = 4, m = 2, side chains on every path), the
/// Metropolis ones with `n_bootstrap` bootstrap samples per depth (most of
/// a render's time here: the depth cap is 32).
fn all(n_bootstrap: u32) -> [Estimator; 4] {
    let mlt = MltSettings {
        n_bootstrap,
        b_passes: 64,
        b_min_samples: 0,
        n_chains: 64,
        ..MltSettings::default()
    };
    let level2 = Level2Settings {
        k: 4,
        m: 2,
        lens_sigma: 2.0,
        side_chain_min_depth: 0,
        ..Level2Settings::default()
    };
    [
        Estimator::Path,
        Estimator::Bdpt,
        Estimator::Mlt(mlt),
        Estimator::Cmlt(CmltSettings { mlt, level2 }),
    ]
}

/// Renders `scene` through `host` with `estimator`, returning the image
/// and statistics.
fn render(
    scene: &Scene,
    host: &Host,
    estimator: Estimator,
    budget_per_pixel: u64,
) -> (Vec<Rgb>, RenderStats) {
    let config = RendererConfig {
        estimator,
        seed: 3,
        ..RendererConfig::default()
    };
    let mut r = Renderer::new(config, scene.camera).unwrap();
    let mut w = RenderWorker::new(&r, 0).unwrap();
    common::prepare(&mut r, std::slice::from_mut(&mut w), scene, host);
    let (width, height) = (scene.camera.width(), scene.camera.height());
    let pixels = (width * height) as u64;
    r.render(&mut w, scene, host, budget_per_pixel * pixels)
        .unwrap();
    let mut img = vec![Rgb::ZERO; pixels as usize];
    r.resolve(&[&w], |i, c| img[i] = c).unwrap();
    (img, r.stats(&[&w]))
}

fn mean(img: &[Rgb]) -> f32 {
    img.iter().map(|c| c.g).sum::<f32>() / img.len() as f32
}

/// A closed box of `wall` material emitting `emission`, with one analytic
/// sphere of `object` material inside, in view of the furnace camera.
fn box_with_sphere(wall: Material, emission: f32, object: Material) -> (Scene, Host) {
    let spheres = Spheres(vec![(Vec3::new(0.0, 0.0, 0.6), 0.35)]);
    let mut b = SceneBuilder::new();
    let w = b.add_material(wall);
    let o = b.add_material(object);
    b.add_mesh(common::inward_box(w, emission));
    let first = b.add_shapes(ShapeGroup {
        count: 1,
        material: o,
        surface: Arc::new(spheres.clone()),
    });
    assert_eq!(first, 0);
    b.set_camera(common::furnace_camera(Vec3::new(0.1, -0.2, -0.6), 0.0));
    let scene = b.build().unwrap();
    let host = Host::new(&scene, spheres);
    (scene, host)
}

#[test]
fn lossless_analytic_spheres_keep_the_furnace_at_two() {
    let glass = Material {
        kind: MaterialKind::Dielectric { eta: 1.5 },
        two_sided: true,
        detail: Default::default(),
    };
    for (what, object) in [("white", Material::diffuse(Rgb::ONE)), ("glass", glass)] {
        let (scene, host) = box_with_sphere(Material::diffuse(Rgb::splat(0.5)), 1.0, object);
        let a = scene.analysis(&scene.camera);
        assert!(
            a.effects.contains(cmlt::scene::Effect::Refraction) == (what == "glass"),
            "{what}: the shape's material counts in the analysis"
        );
        // A furnace is lit alike everywhere: where the chains start does
        // not matter, and b comes from the 64 passes.
        for estimator in all(1_000) {
            let (img, stats) = render(&scene, &host, estimator, 192);
            assert_eq!(stats.nonfinite, 0);
            let m = mean(&img);
            let kind = estimator.kind();
            assert!(
                (m - 2.0).abs() < 0.02 * 2.0,
                "{what}, {kind:?}: furnace mean {m}, expected 2"
            );
        }
    }
}

#[test]
fn convex_diffuse_sphere_reflects_albedo_times_radiance() {
    // Black walls emitting 1: the sphere sees only the walls, so each of
    // its points reflects exactly ρ·1.
    let rho = 0.3;
    let (scene, host) = box_with_sphere(
        Material::diffuse(Rgb::ZERO),
        1.0,
        Material::diffuse(Rgb::splat(rho)),
    );
    let cam = scene.camera;
    let covered = common::covered_pixels(&cam, |ray| {
        host.intersect(ray)
            .is_some_and(|h| h.prim & SHAPE_PRIM_BIT != 0)
    });
    assert!(
        covered.len() >= 6,
        "the sphere covers {} pixels",
        covered.len()
    );
    // PT, BDPT and MLT.
    // The sphere's pixels are a few of the image's: the chains must start
    // there often enough (1 000 samples per depth left MLT's 5 % high).
    for estimator in &all(8_000)[..3] {
        let (img, stats) = render(&scene, &host, *estimator, 1024);
        assert_eq!(stats.nonfinite, 0);
        let sphere: f32 = covered.iter().map(|&i| img[i].g).sum::<f32>() / covered.len() as f32;
        assert!(
            (sphere - rho).abs() < 0.03 * rho,
            "{:?}: sphere pixels {sphere}, expected {rho}",
            estimator.kind()
        );
    }
}

/// A host whose surface answers are broken in a chosen way.
struct Broken(fn(ShapePoint) -> Option<ShapePoint>, Spheres);

impl ShapeSurface for Broken {
    fn surface(&self, shape: u32, u: f32, v: f32) -> Option<ShapePoint> {
        self.1.surface(shape, u, v).and_then(self.0)
    }
}

#[test]
fn invalid_host_points_scatter_nothing_and_never_reach_the_film() {
    let breakages: [fn(ShapePoint) -> Option<ShapePoint>; 5] = [
        |p| Some(ShapePoint { ng: Vec3::NAN, ..p }),
        |p| {
            Some(ShapePoint {
                ns: Vec3::ZERO,
                ..p
            })
        },
        |p| {
            Some(ShapePoint {
                p: Vec3::INFINITY,
                ..p
            })
        },
        |p| {
            Some(ShapePoint {
                p_error: -Vec3::ONE,
                ..p
            })
        },
        |_| None,
    ];
    for (k, broken) in breakages.into_iter().enumerate() {
        let spheres = Spheres(vec![(Vec3::new(0.0, 0.0, 0.6), 0.35)]);
        let mut b = SceneBuilder::new();
        let w = b.add_material(Material::diffuse(Rgb::splat(0.5)));
        b.add_mesh(common::inward_box(w, 1.0));
        b.add_shapes(ShapeGroup {
            count: 1,
            material: w,
            surface: Arc::new(Broken(broken, spheres.clone())),
        });
        b.set_camera(common::furnace_camera(Vec3::new(0.1, -0.2, -0.6), 0.0));
        let scene = b.build().unwrap();
        let hit = Hit {
            t: 1.0,
            prim: SHAPE_PRIM_BIT,
            b1: 1.0,
            b2: 0.5,
        };
        assert_eq!(scene.hit_point(&hit), None, "breakage {k}");
        let host = Host::new(&scene, spheres);
        // PT, BDPT and CMLT; a small bootstrap (only finiteness is asked).
        let [pt, bdpt, _, cmlt] = all(500);
        for estimator in [pt, bdpt, cmlt] {
            let kind = estimator.kind();
            let (img, stats) = render(&scene, &host, estimator, 16);
            assert_eq!(stats.nonfinite, 0, "breakage {k}, {kind:?}");
            assert!(img.iter().all(|c| c.is_finite()));
            // The sphere renders black, the walls still see the furnace.
            assert!(mean(&img) > 0.5, "breakage {k}, {kind:?}");
        }
    }
}

#[test]
fn shape_numbering_and_validation() {
    let spheres = Arc::new(Spheres(vec![(Vec3::ZERO, 1.0); 3]));
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    b.add_mesh(common::inward_box(m, 1.0));
    assert_eq!(
        b.add_shapes(ShapeGroup {
            count: 2,
            material: m,
            surface: spheres.clone(),
        }),
        0
    );
    assert_eq!(
        b.add_shapes(ShapeGroup {
            count: 1,
            material: m,
            surface: spheres.clone(),
        }),
        2
    );
    b.set_camera(common::furnace_camera(Vec3::ZERO, 0.0));
    let mut bad = b.clone();
    let scene = b.build().unwrap();
    assert_eq!(scene.shape_count(), 3);
    // Shape 2 is the second group's shape 0; shape 3 does not exist.
    let at = |shape: u32| {
        scene.hit_point(&Hit {
            t: 1.0,
            prim: SHAPE_PRIM_BIT | shape,
            b1: 0.5,
            b2: 0.5,
        })
    };
    let p2 = at(2).unwrap();
    assert_eq!(p2.surface, SHAPE_PRIM_BIT | 1);
    assert_eq!(p2.prim, SHAPE_PRIM_BIT | 2);
    assert!((p2.ns.length() - 1.0).abs() < 1e-6);
    assert_eq!(at(3), None);
    assert_eq!(scene.lights.pdf_area(p2.surface as usize), 0.0);
    assert_eq!(scene.emitted(&p2, p2.ns), Rgb::ZERO);

    bad.add_shapes(ShapeGroup {
        count: 1,
        material: MaterialId(7),
        surface: spheres,
    });
    assert_eq!(
        bad.build().unwrap_err(),
        SceneError::UnknownShapeMaterial { group: 2 }
    );
}

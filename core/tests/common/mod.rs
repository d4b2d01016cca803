//! Scene builders shared by the core's integration tests and the unit
//! tests of `mlt` (which include this file): the closed furnace box, UV
//! spheres, the furnace camera and furnace scenes; and renders through the
//! renderer on the test's thread.
#![allow(dead_code)]

use cmlt::accel::Intersector;
use cmlt::accel::bvh::Bvh;
use cmlt::geometry::Ray;
use cmlt::integrator::Settings;
use cmlt::math::{Mat4, Rgb, Vec2, Vec3};
use cmlt::mlt::Bootstrap;
use cmlt::renderer::{Estimator, RenderStats, RenderWorker, Renderer, RendererConfig};
use cmlt::scene::{
    Camera, ConductorFresnel, FovAxis, Material, MaterialId, MaterialKind, Mesh, Scene,
    SceneBuilder, Texture,
};

/// What [`render`] gives.
pub struct Rendered {
    /// The image, row-major.
    pub image: Vec<Rgb>,
    /// The counters (bootstrap rays included) and b.
    pub stats: RenderStats,
    /// The bootstrap (MLT, CMLT; empty for PT and BDPT).
    pub bootstrap: Bootstrap,
}

/// Renders `scene` through its camera with `estimator`, `settings` (an
/// unbounded depth at the default depth cap) and `seed` on one worker:
/// `per_pixel` samples (PT, BDPT: passes 0 … per_pixel − 1) or level-1
/// mutations (MLT, CMLT: whole rounds) per pixel.
pub fn render(
    scene: &Scene,
    estimator: Estimator,
    settings: Settings,
    seed: u64,
    per_pixel: u64,
) -> Rendered {
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let config = RendererConfig {
        estimator,
        settings,
        seed,
        ..RendererConfig::default()
    };
    let mut r = Renderer::new(config, scene.camera).unwrap();
    let mut w = RenderWorker::new(&r, 0).unwrap();
    prepare(&mut r, std::slice::from_mut(&mut w), scene, &bvh);
    let steps = r.steps_for(0, per_pixel);
    r.render_steps(&mut w, scene, &bvh, steps).unwrap();
    let mut image = vec![Rgb::ZERO; scene.camera.pixel_count() as usize];
    r.resolve(&[&w], |i, c| image[i] = c).unwrap();
    Rendered {
        image,
        stats: r.stats(&[&w]),
        bootstrap: r.bootstrap().clone(),
    }
}

/// Readies `renderer` for its frame on this thread: `begin_prepare`, every
/// worker's `prepare_worker`, `finish_prepare` (the one way to prepare).
pub fn prepare<I: Intersector>(
    renderer: &mut Renderer,
    workers: &mut [RenderWorker],
    scene: &Scene,
    accel: &I,
) {
    if renderer.begin_prepare(scene) {
        for w in workers.iter_mut() {
            renderer.prepare_worker(w, scene, accel).unwrap();
        }
        renderer.finish_prepare(workers.iter()).unwrap();
    }
}

/// The cube [-1,1]³ with every face wound so its normal points inwards,
/// emitting `emission` on the inside.
pub fn inward_box(material: MaterialId, emission: f32) -> Mesh {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            // Face at coordinate `sign` on `axis`; inward normal = −sign·e_axis.
            let mut n = Vec3::ZERO;
            n[axis] = -sign;
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = positions.len() as u32;
            for (a, c) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let mut p = Vec3::ZERO;
                p[axis] = sign;
                p[u] = a;
                p[v] = c;
                positions.push(p);
            }
            let mut t = [[base, base + 1, base + 2], [base, base + 2, base + 3]];
            let [p0, p1, p2] = t[0].map(|i| positions[i as usize]);
            if (p1 - p0).cross(p2 - p0).dot(n) < 0.0 {
                for tri in &mut t {
                    tri.swap(1, 2);
                }
            }
            indices.extend(t);
        }
    }
    Mesh {
        positions,
        normals: vec![],
        uvs: vec![],
        indices,
        material,
        emission: Some(Rgb::splat(emission)),
    }
}

/// A UV sphere of `radius` at `centre`, outward normals, flat shading.
pub fn sphere(centre: Vec3, radius: f32, material: MaterialId) -> Mesh {
    let (nu, nv) = (48u32, 24u32);
    let mut positions = Vec::new();
    for j in 0..=nv {
        let theta = std::f32::consts::PI * j as f32 / nv as f32;
        for i in 0..nu {
            let phi = 2.0 * std::f32::consts::PI * i as f32 / nu as f32;
            positions.push(
                centre
                    + radius
                        * Vec3::new(
                            theta.sin() * phi.cos(),
                            theta.sin() * phi.sin(),
                            theta.cos(),
                        ),
            );
        }
    }
    let mut indices = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            let a = j * nu + i;
            let b = j * nu + (i + 1) % nu;
            let c = (j + 1) * nu + i;
            let d = (j + 1) * nu + (i + 1) % nu;
            for t in [[a, c, b], [b, c, d]] {
                let [p0, p1, p2] = t.map(|k| positions[k as usize]);
                let n = (p1 - p0).cross(p2 - p0);
                if n.length() > 0.0 {
                    // Wind outwards.
                    indices.push(if n.dot(p0 - centre) >= 0.0 {
                        t
                    } else {
                        [t[0], t[2], t[1]]
                    });
                }
            }
        }
    }
    Mesh {
        positions,
        normals: vec![],
        uvs: vec![],
        indices,
        material,
        emission: None,
    }
}

/// The furnace tests' camera: 16×12 pixels, 70° horizontal field of view,
/// looking down +z from `origin`, focused at distance 1.
pub fn furnace_camera(origin: Vec3, aperture: f32) -> Camera {
    Camera::perspective(
        Mat4::from_translation(origin),
        70.0,
        FovAxis::X,
        16,
        12,
        aperture,
        1.0,
    )
    .unwrap()
}

/// The cube [-1,1]³, normals inwards, every face emitting `emission` and
/// made of `wall`, seen by a 16×12 pinhole camera.
pub fn furnace_scene(wall: Material, emission: f32) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.add_material(wall);
    b.add_mesh(inward_box(m, emission));
    b.set_camera(furnace_camera(Vec3::new(0.1, -0.2, -0.6), 0.0));
    b.build().unwrap()
}

/// A mirror (Fresnel factor 1) reflecting `reflectance` of the light.
pub fn perfect_mirror(reflectance: f32) -> Material {
    Material {
        kind: MaterialKind::Conductor {
            fresnel: ConductorFresnel::Perfect,
            specular_reflectance: Texture::Constant(Rgb::splat(reflectance)),
        },
        two_sided: false,
        detail: Default::default(),
    }
}

/// The diffuse furnace with an emitting mirror sphere of reflectance ½
/// inside: every surface emits 1 and reflects ½ of a uniform field, so the
/// radiance is still exactly 2 everywhere — and the scene has paths for
/// both level-2 perturbations: lens (E D …, E S D …) and caustic (E D S D …).
pub fn mirror_sphere_furnace() -> Scene {
    let mut b = SceneBuilder::new();
    let wall = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    let mirror = b.add_material(perfect_mirror(0.5));
    b.add_mesh(inward_box(wall, 1.0));
    let mut sphere = sphere(Vec3::new(0.2, 0.1, 0.3), 0.45, mirror);
    sphere.emission = Some(Rgb::splat(1.0));
    b.add_mesh(sphere);
    b.set_camera(furnace_camera(Vec3::new(0.1, -0.2, -0.6), 0.0));
    b.build().unwrap()
}

/// The diffuse furnace (walls emitting 1, albedo ½) with a large sphere of
/// clear glass of relative index `eta` before the camera, covering much of
/// its image: paths reflected and refracted by a dielectric (Dirac lobes
/// chosen with probability F and 1 − F), refracted radiance scaled by 1/η²
/// and back. Lossless, the sphere leaves the untruncated radiance at 2.
pub fn glass_sphere_furnace(eta: f32) -> Scene {
    let mut b = SceneBuilder::new();
    let wall = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    let glass = b.add_material(Material {
        kind: MaterialKind::Dielectric { eta },
        two_sided: false,
        detail: Default::default(),
    });
    b.add_mesh(inward_box(wall, 1.0));
    b.add_mesh(sphere(Vec3::new(0.1, -0.1, 0.3), 0.45, glass));
    b.set_camera(furnace_camera(Vec3::new(0.1, -0.2, -0.6), 0.0));
    b.build().unwrap()
}

/// Indices of the pixels of `camera` lying entirely on what `on_object`
/// accepts: the pinhole rays through all four of a pixel's corners do.
/// Pixels straddling an edge mix two radiances and are left out.
pub fn covered_pixels(camera: &Camera, on_object: impl Fn(&Ray) -> bool) -> Vec<usize> {
    let (w, h) = (camera.width(), camera.height());
    let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)];
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            corners.into_iter().all(|(dx, dy)| {
                let raster = Vec2::new(x as f32 + dx, y as f32 + dy);
                on_object(&camera.generate_ray(raster, Vec2::splat(0.5)))
            })
        })
        .map(|(x, y)| (y * w + x) as usize)
        .collect()
}

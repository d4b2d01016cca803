//! A small subset for Miri (`cargo +nightly miri test -p cmlt --test
//! miri`): BVH construction and traversal with the scalar kernel forced
//! (Miri runs no SIMD intrinsics), single rays, packets with partial
//! lane masks and an interleaved stream against the brute-force reference, and one tiny render pass
//! of PT and BDPT through the renderer. Natively it is just a fast test.

use crate::common;

use cmlt::accel::Intersector;
use cmlt::accel::brute::BruteForce;
use cmlt::accel::bvh::{Bvh, Kernel};
use cmlt::geometry::{HitPacket, LaneMask, Ray, RayPacket};
use cmlt::integrator::Settings;
use cmlt::math::{Rgb, Vec3};
use cmlt::renderer::{Estimator, RenderWorker, Renderer, RendererConfig};
use cmlt::scene::{Material, SceneBuilder};

fn scalar(tris: &[[Vec3; 3]]) -> Bvh {
    Bvh::build(tris).with_kernel(Kernel::Scalar).ok().unwrap()
}

#[test]
fn scalar_bvh_matches_brute_force() {
    let m = common::sphere(Vec3::ZERO, 1.0, cmlt::scene::MaterialId(0));
    let tris: Vec<[Vec3; 3]> = m
        .indices
        .iter()
        .step_by(29)
        .map(|t| t.map(|i| m.positions[i as usize]))
        .collect();
    let bvh = scalar(&tris);
    // 80 of the sphere's 2,304 triangles: enough for inner nodes below the
    // root, so traversal pushes and pops its stack (329 triangles took
    // Miri about 2 minutes longer).
    assert!(bvh.view().depth() >= 2, "depth {}", bvh.view().depth());
    let brute = BruteForce::new(tris.iter().copied());
    let mut rays = Vec::new();
    for i in 0..16 {
        let a = i as f32 * 0.7;
        let o = Vec3::new(a.cos() * 3.0, (a * 1.3).sin(), a.sin() * 3.0);
        rays.push(Ray::new(o, -o + Vec3::new(0.1, 0.05 * i as f32, 0.0)));
    }
    for r in &rays {
        assert_eq!(bvh.intersect(r), brute.intersect(r));
        assert_eq!(bvh.occluded(r), brute.occluded(r));
    }
    // The same rays as an interleaved stream (more rays than walks in
    // flight, so slots are refilled and their stacks reused).
    let stream = bvh.view().with_interleave_from(0);
    let mut hits = vec![None; rays.len()];
    let mut occ = vec![false; rays.len()];
    stream.intersect_stream(&rays, &mut hits);
    stream.occluded_stream(&rays, &mut occ);
    for (i, r) in rays.iter().enumerate() {
        assert_eq!(hits[i], brute.intersect(r), "stream ray {i}");
        assert_eq!(occ[i], brute.occluded(r), "stream ray {i}");
    }
    // Distinct origins (the per-lane traversal), then one origin and
    // directions close together (the frustum traversal).
    let o = Vec3::new(0.2, 0.1, 3.0);
    let bundle: Vec<Ray> = (0..8)
        .map(|i| Ray::new(o, Vec3::new(0.01 + 0.005 * i as f32, -0.03, -1.0)))
        .collect();
    for lanes in [&rays[..8], &bundle[..]] {
        let mut packet = RayPacket::<8>::default();
        for (i, r) in lanes.iter().enumerate() {
            packet.set(i, r);
        }
        for mask in [0xffu32, 0b1010_0101, 0b1] {
            let mut hits = HitPacket::<8>::default();
            bvh.intersect_packet(&packet, LaneMask(mask), &mut hits);
            let occ = bvh.occluded_packet(&packet, LaneMask(mask)).0;
            for (i, r) in lanes.iter().enumerate() {
                if mask & (1 << i) != 0 {
                    assert_eq!(hits.get(i), brute.intersect(r), "lane {i}");
                    assert_eq!(occ & (1 << i) != 0, brute.occluded(r), "lane {i}");
                }
            }
        }
    }
}

#[test]
fn tiny_render_passes() {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    b.add_mesh(common::inward_box(m, 1.0));
    b.set_camera(
        cmlt::scene::Camera::perspective(
            cmlt::math::Mat4::IDENTITY,
            60.0,
            cmlt::scene::FovAxis::X,
            2,
            2,
            0.0,
            1.0,
        )
        .unwrap(),
    );
    let scene = b.build().unwrap();
    let bvh = scalar(&scene.triangles().collect::<Vec<_>>());
    let settings = Settings {
        max_depth: Some(3),
        ..Settings::default()
    };
    for estimator in [Estimator::Path, Estimator::Bdpt] {
        let config = RendererConfig {
            estimator,
            settings,
            seed: 1,
            ..RendererConfig::default()
        };
        let mut r = Renderer::new(config, scene.camera).unwrap();
        let mut w = RenderWorker::new(&r, 0).unwrap();
        common::prepare(&mut r, std::slice::from_mut(&mut w), &scene, &bvh);
        assert_eq!(r.render_steps(&mut w, &scene, &bvh, 1).unwrap(), 4);
        let mut finite = true;
        r.resolve(&[&w], |_, c| finite &= c.is_finite()).unwrap();
        assert!(finite, "{estimator:?}");
        assert_eq!(r.stats(&[&w]).nonfinite, 0);
    }
}

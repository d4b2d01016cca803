//! The Embree backend against the brute-force ground truth: closest hits,
//! occlusion, packets of 4/8/16 with inactive lanes holding garbage, the
//! `(prim, b1, b2)` convention, non-finite rays, empty scenes and
//! watertightness on closed meshes.
//!
//! Embree's triangle test rounds differently from ours, so a ray whose
//! answer is decided by rounding (through an edge, grazing, starting on a
//! surface) may legitimately differ; `Checker::lenient` excuses those and
//! bounds how many there are.
#![cfg(feature = "embree")]

mod intersect;

use cmlt::accel::embree::EmbreeScene;
use cmlt::accel::{BruteForce, Intersector};
use cmlt::geometry::{Hit, HitPacket, LaneMask, Ray, RayPacket};
use glam::Vec3;
use intersect::*;

fn compare(name: &str, tris: &[[Vec3; 3]], rays: &[Ray]) {
    let embree = EmbreeScene::new(tris).expect("Embree device");
    let brute = BruteForce::new(tris.iter().copied());
    let truth: Vec<Option<Hit>> = rays.iter().map(|r| brute.intersect(r)).collect();
    let check = Checker::lenient(tris);
    compare_backend(name, &embree, &brute, rays, &truth, &check);
    check.finish(name);
}

#[test]
fn embree_matches_brute_force_soup() {
    let mut rng = Rng(1);
    let tris = soup(&mut rng, 3000);
    let rays = random_rays(&mut rng, &tris, 20_000);
    compare("soup", &tris, &rays);
}

#[test]
fn embree_matches_brute_force_spheres_and_room() {
    let mut rng = Rng(2);
    let mut tris = icosphere(4).tris();
    tris.extend(
        uv_sphere(24, 48)
            .transformed(|v| v * 0.3 + Vec3::new(0.2, 0.1, 0.0))
            .tris(),
    );
    let rays = random_rays(&mut rng, &tris, 20_000);
    compare("spheres", &tris, &rays);
    let tris = room();
    let rays = random_rays(&mut rng, &tris, 20_000);
    compare("room", &tris, &rays);
}

#[test]
fn embree_matches_brute_force_far_from_origin() {
    let mut rng = Rng(5);
    let off = Vec3::new(1e4, -1e4, 1e4);
    let r = rotation();
    let mut tris: Vec<[Vec3; 3]> = room()
        .iter()
        .map(|t| t.map(|v| r * v * 10.0 + off))
        .collect();
    tris.extend(
        soup(&mut rng, 500)
            .iter()
            .map(|t| t.map(|v| v * 10.0 + off)),
    );
    let rays = random_rays(&mut rng, &tris, 10_000);
    compare("far", &tris, &rays);
}

/// Exact answers on one triangle: primitive numbering past a degenerate
/// triangle, barycentrics as (b1, b2) = (u, v), both faces, the open
/// interval (0, t_max), and non-finite or empty rays in single rays and
/// packets.
#[test]
fn single_triangle_conventions_and_nasty_rays() {
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let embree = EmbreeScene::new(&[[Vec3::ZERO; 3], tri]).unwrap();
    let h = embree
        .intersect(&Ray::new(Vec3::new(0.25, 0.5, 2.0), -Vec3::Z))
        .unwrap();
    assert_eq!(h.prim, 1);
    assert!((h.t - 2.0).abs() < 1e-6 && (h.b1 - 0.25).abs() < 1e-6 && (h.b2 - 0.5).abs() < 1e-6);
    let back = embree
        .intersect(&Ray::new(Vec3::new(0.25, 0.5, -2.0), Vec3::Z * 4.0))
        .unwrap();
    // t in units of the unnormalised direction (2 / 4, not 2). Embree's
    // arithmetic depends on the ISA it picks at run time: Debian's Embree
    // 3.13.5 on a CPU without AVX-512 gives 0.49999997, so within a few
    // ulps; likewise the open interval below is checked a few ulps inside
    // and outside the hit at t = 2 (that machine counts a hit at 2.0 with
    // t_max = 2.0).
    assert_eq!(back.prim, 1);
    assert!((back.t - 0.5).abs() < 1e-6, "t = {}", back.t);
    let seg = |t_max| Ray {
        o: Vec3::new(0.25, 0.5, 2.0),
        d: -Vec3::Z,
        t_max,
    };
    assert!(!embree.occluded(&seg(2.0 - 1e-5)), "t_max is exclusive");
    assert_eq!(embree.intersect(&seg(2.0 - 1e-5)), None);
    assert!(embree.occluded(&seg(2.0001)));
    let rays = nasty_rays();
    for r in &rays {
        assert_eq!(embree.intersect(r), None, "{r:?}");
        assert!(!embree.occluded(r), "{r:?}");
    }
    let good = Ray::new(Vec3::new(0.25, 0.5, 2.0), -Vec3::Z);
    let mut p = RayPacket::<16>::default();
    for k in 0..16 {
        p.set(k, rays.get(k).unwrap_or(&good));
    }
    let mut hits = HitPacket::<16>::default();
    embree.intersect_packet(&p, LaneMask::first(16), &mut hits);
    for k in 0..16 {
        assert_eq!(hits.get(k).is_some(), k >= rays.len(), "lane {k}");
    }
    assert_eq!(
        embree.occluded_packet(&p, LaneMask::first(16)).0,
        LaneMask::first(16).0 & !LaneMask::first(rays.len()).0
    );
    // An odd width goes lane by lane.
    let mut p3 = RayPacket::<3>::default();
    p3.set(0, &good);
    p3.set(2, &good);
    let mut h3 = HitPacket::<3>::default();
    embree.intersect_packet(&p3, LaneMask(0b101), &mut h3);
    assert_eq!(h3.prim, [1, HitPacket::<3>::MISS, 1]);
}

#[test]
fn empty_and_degenerate_scenes_miss() {
    let degenerate = [
        [Vec3::ZERO, Vec3::X, Vec3::X],
        [Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
        [Vec3::NAN, Vec3::X, Vec3::Y],
    ];
    for tris in [&[][..], &degenerate[..]] {
        let embree = EmbreeScene::new(tris).unwrap();
        let mut rng = Rng(9);
        let mut p = RayPacket::<8>::default();
        for k in 0..8 {
            p.set(k, &Ray::new(rng.unit(), rng.unit()));
        }
        for r in (0..8).map(|k| p.get(k)).chain(nasty_rays()) {
            assert_eq!(embree.intersect(&r), None);
            assert!(!embree.occluded(&r));
        }
        let mut hits = HitPacket::<8>::default();
        let keep = Hit {
            t: 1.0,
            prim: 3,
            b1: 0.0,
            b2: 0.0,
        };
        hits.set(1, Some(keep));
        embree.intersect_packet(&p, LaneMask(0b101), &mut hits);
        assert_eq!(
            hits.prim[..3],
            [HitPacket::<8>::MISS, 3, HitPacket::<8>::MISS]
        );
        assert_eq!(
            embree.occluded_packet(&p, LaneMask::first(8)),
            LaneMask::NONE
        );
    }
}

/// Robust mode is watertight: rays from inside a closed mesh aimed exactly
/// at its vertices and edge midpoints never escape.
#[test]
fn watertight_from_inside() {
    let r = rotation();
    for (mesh, s, off) in [
        (icosphere(3), 1.0f32, Vec3::ZERO),
        (cube(6), 1.0, Vec3::ZERO),
        (icosphere(2), 1e3, Vec3::splat(1e3)),
    ] {
        let mesh = mesh.transformed(|v| r * v * s + off);
        let embree = EmbreeScene::new(&mesh.tris()).unwrap();
        let mut targets = mesh.verts.clone();
        for &(a, b) in mesh.edges().keys() {
            targets.push((mesh.verts[a as usize] + mesh.verts[b as usize]) * 0.5);
        }
        for (k, chunk) in targets.chunks(8).enumerate() {
            let o = off + r * Vec3::new(0.1, -0.05, 0.02) * s * (k % 3) as f32;
            let mut p = RayPacket::<8>::default();
            for (l, t) in chunk.iter().enumerate() {
                let ray = Ray::new(o, *t - o);
                assert!(embree.intersect(&ray).is_some(), "escaped through {t:?}");
                p.set(l, &ray);
            }
            let live = LaneMask::first(chunk.len());
            let mut hits = HitPacket::<8>::default();
            embree.intersect_packet(&p, live, &mut hits);
            assert!(live.iter().all(|l| hits.get(l).is_some()), "packet escaped");
        }
    }
}

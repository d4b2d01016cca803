//! The default BVH against the brute-force ground truth, watertightness on
//! closed meshes, robust spawn offsets, and the edge cases (empty, single
//! triangle, non-finite rays, packets with inactive lanes).

use crate::intersect;

use cmlt::accel::bvh::{Bvh, BvhView, Kernel, LayoutError, MAX_DEPTH, Node, WIDTH};
use cmlt::accel::{BruteForce, Intersector};
use cmlt::geometry::offset::{TrianglePoint, offset_ray_origin, triangle_point};
use cmlt::geometry::triangle::intersect_triangle;
use cmlt::geometry::{Hit, HitPacket, LaneMask, Ray, RayPacket};
use glam::Vec3;
use intersect::*;

/// Our BVH (every query) against brute force on `rays`.
fn compare_scene(name: &str, tris: &[[Vec3; 3]], rays: &[Ray]) {
    let bvh = Bvh::build(tris);
    let brute = BruteForce::new(tris.iter().copied());
    assert!(bvh.view().depth() as usize <= MAX_DEPTH);
    let truth: Vec<Option<Hit>> = rays.iter().map(|r| brute.intersect(r)).collect();
    for (k, (ray, &want)) in rays.iter().zip(&truth).enumerate().step_by(16) {
        assert_eq!(
            brute.occluded(ray),
            want.is_some(),
            "{name}: brute force occlusion disagrees with its closest hit (ray {k})"
        );
    }
    // The scenes are meant to exercise both outcomes.
    let hits = truth.iter().filter(|h| h.is_some()).count();
    assert!(
        hits > rays.len() / 10 && hits < rays.len(),
        "{name}: {hits} hits of {}",
        rays.len()
    );
    let check = Checker::exact(tris);
    compare_backend(name, &bvh, &brute, rays, &truth, &check);
    // Every kernel this machine runs: the same answers as brute force, and
    // bit for bit the scalar kernel's.
    let scalar = bvh.view().with_kernel(Kernel::Scalar).unwrap();
    let reference: Vec<Option<Hit>> = rays.iter().map(|r| scalar.intersect(r)).collect();
    for k in Kernel::ALL {
        let Some(view) = bvh.view().with_kernel(k) else {
            continue;
        };
        let what = format!("{name} {}", k.name());
        compare_backend(&what, &view, &brute, rays, &truth, &check);
        for (r, want) in rays.iter().zip(&reference) {
            assert_eq!(
                view.intersect(r),
                *want,
                "{what}: differs from scalar for {r:?}"
            );
        }
        // Streams interleaved whatever the tree's size: every ray's own
        // single-ray answer, bit for bit.
        let interleaved = view.with_interleave_from(0);
        compare_stream(
            &format!("{what} interleaved"),
            &interleaved,
            rays,
            &truth,
            &check,
        );
        let mut hits = vec![None; rays.len()];
        let mut occ = vec![false; rays.len()];
        interleaved.intersect_stream(rays, &mut hits);
        interleaved.occluded_stream(rays, &mut occ);
        for ((r, want), (h, o)) in rays.iter().zip(&reference).zip(hits.iter().zip(&occ)) {
            assert_eq!(*h, *want, "{what}: interleaved stream differs for {r:?}");
            assert_eq!(
                *o,
                view.occluded(r),
                "{what}: interleaved occlusion differs for {r:?}"
            );
        }
    }
}

#[test]
fn kernels_available() {
    assert!(Kernel::Scalar.is_available());
    assert_eq!(cfg!(target_arch = "x86_64"), Kernel::Sse2.is_available());
    assert!(Kernel::best().is_available());
    let bvh = Bvh::build(&[[Vec3::ZERO, Vec3::X, Vec3::Y]]);
    assert_eq!(bvh.kernel(), Kernel::best());
    let forced = bvh.with_kernel(Kernel::Scalar).unwrap();
    assert_eq!(forced.view().kernel(), Kernel::Scalar);
    for k in Kernel::ALL {
        assert_eq!(forced.view().with_kernel(k).is_some(), k.is_available());
    }
}

#[test]
fn bvh_matches_brute_force_soup() {
    let mut rng = Rng(1);
    let tris = soup(&mut rng, 3000);
    let rays = random_rays(&mut rng, &tris, 30_000);
    compare_scene("soup", &tris, &rays);
}

#[test]
fn bvh_matches_brute_force_spheres() {
    let mut rng = Rng(2);
    let mut tris = icosphere(4).tris();
    tris.extend(
        uv_sphere(24, 48)
            .transformed(|v| v * 0.3 + Vec3::new(0.2, 0.1, 0.0))
            .tris(),
    );
    let rays = random_rays(&mut rng, &tris, 25_000);
    compare_scene("spheres", &tris, &rays);
}

#[test]
fn bvh_matches_brute_force_room() {
    let mut rng = Rng(3);
    let tris = room();
    let rays = random_rays(&mut rng, &tris, 25_000);
    compare_scene("room", &tris, &rays);
}

#[test]
fn bvh_matches_brute_force_tiny_scale() {
    let mut rng = Rng(4);
    let mut tris: Vec<[Vec3; 3]> = room().iter().map(|t| t.map(|v| v * 1e-4)).collect();
    tris.extend(soup(&mut rng, 500).iter().map(|t| t.map(|v| v * 1e-4)));
    let rays = random_rays(&mut rng, &tris, 25_000);
    compare_scene("1e-4", &tris, &rays);
}

#[test]
fn bvh_matches_brute_force_huge_scale_far_away() {
    let mut rng = Rng(5);
    let off = Vec3::new(1e5, -1e5, 1e5);
    let r = rotation();
    let mut tris: Vec<[Vec3; 3]> = room()
        .iter()
        .map(|t| t.map(|v| r * v * 1e6 + off))
        .collect();
    tris.extend(soup(&mut rng, 500).iter().map(|t| t.map(|v| v * 1e6 + off)));
    let rays = random_rays(&mut rng, &tris, 25_000);
    compare_scene("1e6+1e5", &tris, &rays);
}

#[test]
fn bvh_matches_brute_force_identical_triangles() {
    // Every centroid equal: a worst case for Morton-ordered builders; the
    // depth must stay bounded and every copy is a tie.
    let mut rng = Rng(6);
    let t = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.1),
        Vec3::new(0.0, 1.0, -0.1),
    ];
    let mut tris = vec![t; 1000];
    tris.extend(soup(&mut rng, 200));
    let rays = random_rays(&mut rng, &tris, 5_000);
    compare_scene("identical", &tris, &rays);
}

#[test]
fn bvh_matches_brute_force_exponential_spacing() {
    // Triangles at x = 1.5^k, each as large as its distance from the
    // origin: a split can only peel off the few largest at every level,
    // so the binary trees are deeper than `MAX_DEPTH` wide levels allow
    // and the collapse has to flatten their bottoms into leaves (the last
    // assertion checks that the layout reached the limit).
    let mut rng = Rng(7);
    let tris: Vec<[Vec3; 3]> = (0..215)
        .map(|k| {
            let s = 1.5f32.powi(k);
            let c = Vec3::new(s, 0.0, 0.0);
            [
                c + Vec3::new(0.0, -0.3, -0.3) * s,
                c + Vec3::new(0.1, 0.3, -0.2) * s,
                c + Vec3::new(-0.1, 0.0, 0.3) * s,
            ]
        })
        .collect();
    // Rays from around triangle k's scale towards (or past) triangle k:
    // random rays in the whole box would only see the largest few.
    let rays: Vec<Ray> = (0..20_000)
        .map(|_| {
            let k = rng.below(tris.len());
            let s = 1.5f32.powi(k as i32);
            let o = rng.in_box(Vec3::new(0.0, -s, -s), Vec3::new(2.0 * s, s, s));
            let t = tris[k];
            let aim = (t[0] + t[1] + t[2]) / 3.0
                + rng.in_box(Vec3::splat(-0.4 * s), Vec3::splat(0.4 * s));
            Ray::new(o, aim - o)
        })
        .collect();
    compare_scene("1.5^k", &tris, &rays);
    assert_eq!(Bvh::build(&tris).view().depth() as usize, MAX_DEPTH);
}

// ---------------------------------------------------------------------------
// Watertightness.

/// Rays aimed exactly at every shared vertex and edge midpoint of a closed
/// convex mesh, from inside and from outside within the cone of entering
/// directions, must hit near the target — with the plain triangle test, the
/// BVH, and BVH packets.
fn check_watertight(name: &str, mesh: &Mesh, center: Vec3, dirs_per_target: usize) {
    let tris = mesh.tris();
    let bvh = Bvh::build(&tris);
    let mut rng = Rng(99);
    let edges = mesh.edges();
    let mut vert_faces: Vec<Vec<usize>> = vec![Vec::new(); mesh.verts.len()];
    for (f, t) in mesh.idx.iter().enumerate() {
        for &v in t {
            vert_faces[v as usize].push(f);
        }
    }
    let scale = (mesh.verts[0] - center).length();
    // Face normals oriented away from the centre (the meshes are convex).
    let outward = |f: usize| {
        let n = mesh.normal(f);
        let c = mesh.idx[f]
            .iter()
            .map(|&i| mesh.verts[i as usize])
            .sum::<Vec3>()
            / 3.0;
        if n.dot(c - center) < 0.0 { -n } else { n }
    };
    // (target, faces around it)
    let mut targets: Vec<(Vec3, Vec<usize>)> = Vec::new();
    for (v, faces) in vert_faces.iter().enumerate() {
        targets.push((mesh.verts[v], faces.clone()));
    }
    for ((a, b), faces) in &edges {
        assert_eq!(faces.len(), 2, "{name}: mesh not closed");
        targets.push((
            (mesh.verts[*a as usize] + mesh.verts[*b as usize]) * 0.5,
            faces.clone(),
        ));
    }
    let mut rays = Vec::new();
    for (p, faces) in &targets {
        // From inside: the centre and random interior points.
        for k in 0..dirs_per_target {
            let o = if k == 0 {
                center
            } else {
                center + rng.unit() * scale * rng.range(0.0, 0.5)
            };
            rays.push(Ray::new(o, *p - o));
        }
        // From outside, entering through the target: the direction has to
        // enter every face around it.
        let mut made = 0;
        for _ in 0..dirs_per_target * 50 {
            if made == dirs_per_target {
                break;
            }
            let u = rng.unit();
            if faces.iter().all(|&f| u.dot(outward(f)) > 0.05) {
                let o = *p + u * scale * rng.range(0.1, 3.0);
                rays.push(Ray::new(o, *p - o));
                made += 1;
            }
        }
    }
    // Every ray targets `o + d` and must hit there, up to the rounding of
    // `d` (magnified at grazing incidence), not further along.
    let check = |how: &str, r: &Ray, h: Option<Hit>| {
        let target = r.o + r.d;
        let h =
            h.unwrap_or_else(|| panic!("{name}: {how} leaked through {target:?} from {:?}", r.o));
        let tol = 1e-4 * scale + 200.0 * f32::EPSILON * target.abs().max_element();
        assert!(
            r.at(h.t).distance(target) < tol,
            "{name}: {how} hit at t = {} for {r:?}",
            h.t
        );
    };
    for r in &rays {
        let single = tris
            .iter()
            .enumerate()
            .filter_map(|(i, t)| {
                intersect_triangle(r, t[0], t[1], t[2]).map(|(t, b1, b2)| Hit {
                    t,
                    prim: i as u32,
                    b1,
                    b2,
                })
            })
            .min_by(|a, b| a.t.total_cmp(&b.t));
        check("triangle test", r, single);
        check("BVH", r, bvh.intersect(r));
        assert!(bvh.occluded(r), "{name}: BVH occlusion leaked for {r:?}");
    }
    for chunk in rays.chunks_exact(8) {
        let mut p = RayPacket::<8>::default();
        for (l, r) in chunk.iter().enumerate() {
            p.set(l, r);
        }
        let mut hits = HitPacket::<8>::default();
        bvh.intersect_packet(&p, LaneMask::first(8), &mut hits);
        for (l, r) in chunk.iter().enumerate() {
            check("BVH packet", r, hits.get(l));
        }
        assert_eq!(
            bvh.occluded_packet(&p, LaneMask::first(8)),
            LaneMask::first(8),
            "{name}: packet occlusion leaked"
        );
    }
    assert!(rays.len() > targets.len() * dirs_per_target);
}

#[test]
fn watertight_cube() {
    let m = cube(8);
    check_watertight("cube", &m, Vec3::ZERO, 6);
    // Axis-aligned rays exactly through every vertex and edge midpoint of
    // the axis-aligned cube: in ray space the target is exactly (0, 0), so
    // edge functions are exactly zero (and faces parallel to the ray are
    // edge-on). Zero must count as inside.
    let tris = m.tris();
    let bvh = Bvh::build(&tris);
    let mut targets: Vec<Vec3> = m.verts.clone();
    targets.extend(
        m.edges()
            .keys()
            .map(|&(a, b)| (m.verts[a as usize] + m.verts[b as usize]) * 0.5),
    );
    let mut rays = Vec::new();
    for p in targets {
        for a in 0..3 {
            if p[a].abs() == 1.0 {
                let mut n = Vec3::ZERO;
                n[a] = p[a];
                let mut inner = p;
                inner[a] = 0.0;
                rays.push(Ray::new(p + n * 2.0, -n));
                rays.push(Ray::new(inner, n));
            }
        }
    }
    for r in &rays {
        let single = tris
            .iter()
            .filter_map(|t| intersect_triangle(r, t[0], t[1], t[2]))
            .map(|h| h.0)
            .fold(f32::INFINITY, f32::min);
        let want = if r.o.abs().max_element() > 1.0 {
            2.0
        } else {
            1.0
        };
        assert_eq!(single, want, "triangle test leaked: {r:?}");
        assert_eq!(
            bvh.intersect(r).map(|h| h.t),
            Some(want),
            "BVH leaked: {r:?}"
        );
    }
    for chunk in rays.chunks_exact(4) {
        let mut p = RayPacket::<4>::default();
        for (l, r) in chunk.iter().enumerate() {
            p.set(l, r);
        }
        let mut hits = HitPacket::<4>::default();
        bvh.intersect_packet(&p, LaneMask::first(4), &mut hits);
        assert!(
            hits.prim.iter().all(|&p| p != HitPacket::<4>::MISS),
            "packet leaked: {chunk:?}"
        );
    }
    let r = rotation();
    check_watertight(
        "rotated cube",
        &m.transformed(|v| r * v * 3.0 + Vec3::new(0.3, 0.1, -0.2)),
        Vec3::new(0.3, 0.1, -0.2),
        4,
    );
}

#[test]
fn watertight_spheres_and_fans() {
    check_watertight("icosphere", &icosphere(3), Vec3::ZERO, 4);
    check_watertight("uv sphere", &uv_sphere(16, 64), Vec3::ZERO, 4);
    check_watertight("double fan", &double_fan(200), Vec3::ZERO, 8);
}

#[test]
fn watertight_at_extreme_scales() {
    let r = rotation();
    for (s, off) in [
        (1e-4f32, Vec3::ZERO),
        (1e6, Vec3::splat(1e5)),
        (1.0, Vec3::new(1e3, -2e3, 5e2)),
        (1e-3, Vec3::splat(1.0)),
    ] {
        let ico = icosphere(2).transformed(|v| r * v * s + off);
        check_watertight(&format!("icosphere x{s} +{off}"), &ico, off, 4);
        let c = cube(4).transformed(|v| r * v * s + off);
        check_watertight(&format!("cube x{s} +{off}"), &c, off, 4);
    }
}

// ---------------------------------------------------------------------------
// Robust spawn offsets.

/// Spawns rays from points on triangles (as a renderer computes them from
/// barycentrics) in random directions off the surface: they must never
/// re-hit their own triangle, for large, tiny and far-away triangles.
#[test]
fn spawned_rays_never_self_intersect() {
    let mut rng = Rng(7);
    let mut spawned = 0;
    for (size, offset) in [
        (1e4f32, 0.0f32),
        (1e-4, 0.0),
        (1.0, 1e5),
        (10.0, 1e6),
        (1e-2, 1e3),
        (1.0, 0.0),
    ] {
        for _ in 0..300 {
            let c = rng.unit() * offset;
            let tri = [
                c + rng.unit() * size,
                c + rng.unit() * size,
                c + rng.unit() * size,
            ];
            let ng = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize_or_zero();
            if ng == Vec3::ZERO {
                continue;
            }
            for _ in 0..40 {
                let (mut b1, mut b2) = (rng.f(), rng.f());
                if b1 + b2 > 1.0 {
                    (b1, b2) = (1.0 - b1, 1.0 - b2);
                }
                let TrianglePoint { p, p_error, .. } = triangle_point(tri, b1, b2);
                let mut w = rng.unit();
                if rng.chance(0.3) {
                    // Grazing.
                    w = (w - ng * w.dot(ng) * 0.999).normalize();
                }
                if w.dot(ng) == 0.0 {
                    continue;
                }
                let o = offset_ray_origin(p, p_error, ng, w);
                let ray = Ray::new(o, w);
                assert!(
                    intersect_triangle(&ray, tri[0], tri[1], tri[2]).is_none(),
                    "self-intersection: tri {tri:?} from {o:?} along {w:?}"
                );
                spawned += 1;
            }
        }
    }
    assert!(spawned > 50_000);
}

/// The renderer's loop on meshes: trace, take the hit point from the
/// reported barycentrics, spawn a bounce; the bounce never hits the triangle
/// it left.
#[test]
fn bounces_never_hit_their_own_triangle() {
    let mut rng = Rng(8);
    let r = rotation();
    for (s, off) in [
        (1.0f32, Vec3::ZERO),
        (1e-4, Vec3::ZERO),
        (1e6, Vec3::splat(1e5)),
        (10.0, Vec3::new(1e5, 0.0, -1e5)),
    ] {
        let mut tris = icosphere(3).transformed(|v| r * v * s + off).tris();
        tris.extend(room().iter().map(|t| t.map(|v| r * v * s + off)));
        let bvh = Bvh::build(&tris);
        let mut bounced = 0;
        for _ in 0..4000 {
            let o = off + rng.unit() * s * 3.0;
            let mut ray = Ray::new(o, rng.unit());
            for _ in 0..4 {
                let Some(h) = bvh.intersect(&ray) else { break };
                let t = tris[h.prim as usize];
                let TrianglePoint { p, p_error, .. } = triangle_point(t, h.b1, h.b2);
                let ng = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
                let w = rng.unit();
                ray = Ray::new(offset_ray_origin(p, p_error, ng, w), w);
                if let Some(next) = bvh.intersect(&ray) {
                    assert_ne!(
                        next.prim, h.prim,
                        "self-intersection at scale {s} (t = {})",
                        next.t
                    );
                }
                bounced += 1;
            }
        }
        assert!(bounced > 4000);
    }
}

// ---------------------------------------------------------------------------
// Edge cases.

#[test]
fn empty_bvh_misses_everything() {
    let degenerate = [
        [Vec3::ZERO, Vec3::X, Vec3::X],
        [Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
        [Vec3::NAN, Vec3::X, Vec3::Y],
    ];
    for tris in [&[][..], &degenerate[..]] {
        let bvh = Bvh::build(tris);
        assert!(bvh.view().is_empty());
        let mut rng = Rng(9);
        let mut p = RayPacket::<8>::default();
        for k in 0..8 {
            p.set(k, &Ray::new(rng.unit(), rng.unit()));
        }
        for r in (0..8).map(|k| p.get(k)).chain(nasty_rays()) {
            assert_eq!(bvh.intersect(&r), None);
            assert!(!bvh.occluded(&r));
        }
        let mut hits = HitPacket::<8>::default();
        hits.set(
            1,
            Some(Hit {
                t: 1.0,
                prim: 3,
                b1: 0.0,
                b2: 0.0,
            }),
        );
        hits.set(
            2,
            Some(Hit {
                t: 1.0,
                prim: 3,
                b1: 0.0,
                b2: 0.0,
            }),
        );
        bvh.intersect_packet(&p, LaneMask(0b101), &mut hits);
        assert_eq!(
            hits.prim[..3],
            [HitPacket::<8>::MISS, 3, HitPacket::<8>::MISS]
        );
        assert_eq!(bvh.occluded_packet(&p, LaneMask::first(8)), LaneMask::NONE);
    }
}

#[test]
fn single_triangle_and_non_finite_rays() {
    let tri = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let bvh = Bvh::build(&[[Vec3::ZERO; 3], tri]);
    assert_eq!(bvh.view().triangles().collect::<Vec<_>>(), [(tri, 1)]);
    let h = bvh
        .intersect(&Ray::new(Vec3::new(0.25, 0.5, 2.0), -Vec3::Z))
        .unwrap();
    assert_eq!(
        h,
        Hit {
            t: 2.0,
            prim: 1,
            b1: 0.25,
            b2: 0.5
        }
    );
    let back = bvh
        .intersect(&Ray::new(Vec3::new(0.25, 0.5, -2.0), Vec3::Z * 4.0))
        .unwrap();
    assert_eq!((back.t, back.prim), (0.5, 1));
    assert_eq!(
        bvh.intersect(&Ray::new(Vec3::new(0.75, 0.5, 2.0), -Vec3::Z)),
        None
    );
    assert!(!bvh.occluded(&Ray {
        o: Vec3::new(0.25, 0.5, 2.0),
        d: -Vec3::Z,
        t_max: 2.0
    }));
    assert!(bvh.occluded(&Ray {
        o: Vec3::new(0.25, 0.5, 2.0),
        d: -Vec3::Z,
        t_max: 2.0001
    }));
    // In the plane of the triangle and along its edges: no hit, no panic.
    for r in [
        Ray::new(Vec3::new(-1.0, 0.0, 0.0), Vec3::X),
        Ray::new(Vec3::new(-1.0, 0.5, 0.0), Vec3::X),
        Ray::new(Vec3::new(0.0, 0.0, 1.0), -Vec3::Z),
    ] {
        let _ = bvh.intersect(&r);
    }
    let rays = nasty_rays();
    for r in &rays {
        assert_eq!(bvh.intersect(r), None, "{r:?}");
        assert!(!bvh.occluded(r), "{r:?}");
        assert_eq!(intersect_triangle(r, tri[0], tri[1], tri[2]), None, "{r:?}");
    }
    // Packets mixing nasty and good rays.
    let good = Ray::new(Vec3::new(0.25, 0.5, 2.0), -Vec3::Z);
    let mut p = RayPacket::<16>::default();
    for (k, r) in rays.iter().enumerate() {
        p.set(k, r);
    }
    for k in rays.len()..16 {
        p.set(k, &good);
    }
    let mut hits = HitPacket::<16>::default();
    bvh.intersect_packet(&p, LaneMask::first(16), &mut hits);
    for k in 0..16 {
        assert_eq!(hits.get(k).is_some(), k >= rays.len(), "lane {k}");
    }
    assert_eq!(
        bvh.occluded_packet(&p, LaneMask::first(16)).0,
        LaneMask::first(16).0 & !LaneMask::first(rays.len()).0
    );
}

#[test]
fn layouts_are_validated() {
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let bvh = Bvh::build(&[tri, tri.map(|v| v + Vec3::Z)]);
    let (nodes, blocks) = bvh.clone().into_parts();
    assert!(BvhView::new(&nodes, &blocks).is_ok());
    let mut bad = blocks.clone();
    bad[0].ids[2] = u32::MAX;
    assert!(matches!(
        BvhView::new(&nodes, &bad),
        Err(LayoutError::ReservedPrimId { index: 2 })
    ));
    // A leaf range past the last block's slots.
    let leaf = (0..WIDTH).find(|&c| nodes[0].count[c] > 0).unwrap();
    let mut bad = nodes.clone();
    bad[0].count[leaf] = 4 * blocks.len() as u32 + 1;
    assert!(matches!(
        BvhView::new(&bad, &blocks),
        Err(LayoutError::BadChild { node: 0, .. })
    ));
    // A leaf that does not start a block.
    let mut bad = nodes.clone();
    bad[0].child[leaf] += 1;
    bad[0].count[leaf] = 1;
    assert!(matches!(
        BvhView::new(&bad, &blocks),
        Err(LayoutError::BadChild { node: 0, .. })
    ));
    let mut bad = nodes.clone();
    bad[0].child[0] = 0;
    bad[0].count[0] = 0;
    assert!(matches!(
        BvhView::new(&bad, &blocks),
        Err(LayoutError::BadChild { node: 0, slot: 0 })
    ));
    // `from_parts` checks the leaf-order input before packing it.
    let mut one = Node::EMPTY;
    one.set_bounds(0, [0.0; 3], [1.0, 1.0, 1.0]);
    (one.child[0], one.count[0]) = (0, 2);
    let two = vec![tri, tri.map(|v| v + Vec3::Z)];
    assert!(Bvh::from_parts(vec![one], two.clone(), vec![0, 1]).is_ok());
    assert_eq!(
        Bvh::from_parts(vec![one], two.clone(), vec![0]).unwrap_err(),
        LayoutError::Lengths
    );
    assert!(matches!(
        Bvh::from_parts(vec![one], two.clone(), vec![0, u32::MAX]),
        Err(LayoutError::ReservedPrimId { index: 1 })
    ));
    one.count[0] = 3;
    assert!(matches!(
        Bvh::from_parts(vec![one], two, vec![0, 1]),
        Err(LayoutError::BadChild { node: 0, slot: 0 })
    ));

    // A chain: node k holds a leaf with triangle k and the next node. At
    // MAX_DEPTH levels it is valid and traversable; one more is too deep.
    let chain = |levels: usize| {
        let tris: Vec<[Vec3; 3]> = (0..levels)
            .map(|k| tri.map(|v| v + Vec3::Z * k as f32))
            .collect();
        let mut nodes = vec![Node::EMPTY; levels];
        for k in (0..levels).rev() {
            nodes[k].child[0] = k as u32;
            nodes[k].count[0] = 1;
            nodes[k].set_bounds(0, [0.0, 0.0, k as f32], [1.0, 1.0, k as f32]);
            if k + 1 < levels {
                nodes[k].child[1] = k as u32 + 1;
                nodes[k].set_bounds(
                    1,
                    [0.0, 0.0, k as f32 + 1.0],
                    [1.0, 1.0, levels as f32 - 1.0],
                );
            }
        }
        let ids = (0..levels as u32).rev().collect::<Vec<_>>();
        (nodes, tris, ids)
    };
    let (n, t, i) = chain(MAX_DEPTH);
    let deep = Bvh::from_parts(n, t, i).unwrap();
    assert_eq!(deep.view().depth() as usize, MAX_DEPTH);
    let down = deep
        .intersect(&Ray::new(Vec3::new(0.1, 0.1, 100.0), -Vec3::Z))
        .unwrap();
    assert_eq!(down.prim, 0); // top triangle, id reversed
    let up = deep
        .intersect(&Ray::new(Vec3::new(0.1, 0.1, -1.0), Vec3::Z))
        .unwrap();
    assert_eq!(up.prim, MAX_DEPTH as u32 - 1);
    let (n, t, i) = chain(MAX_DEPTH + 1);
    assert_eq!(Bvh::from_parts(n, t, i).unwrap_err(), LayoutError::TooDeep);
}

/// Coordinates so large that the test's products overflow: building and
/// tracing must not panic, and the BVH must still agree with brute force.
#[test]
fn extreme_coordinates_do_not_panic() {
    let mut rng = Rng(77);
    for s in [1e18f32, 1e30, 3e38] {
        let tris: Vec<[Vec3; 3]> = (0..200)
            .map(|_| [rng.unit() * s, rng.unit() * s, rng.unit() * s])
            .collect();
        let bvh = Bvh::build(&tris);
        let brute = BruteForce::new(tris.iter().copied());
        for _ in 0..2000 {
            let r = Ray::new(rng.unit() * s * 0.5, rng.unit());
            check_hit("extreme", &r, bvh.intersect(&r), brute.intersect(&r));
            assert_eq!(bvh.occluded(&r), brute.occluded(&r));
        }
    }
}

// ---------------------------------------------------------------------------
// Packets against single rays.

/// Packet answers of `view` for `lanes` under every mask kind — all, none,
/// each single lane, both alternating masks, random — against the same
/// kernel's single-ray answers: the same triangle with bit-identical `t`,
/// `b1`, `b2` (or, for a tie between triangles, the same `t`), the same
/// occlusion, and inactive lanes neither read (they hold garbage) nor
/// written.
fn packet_matches_single<const N: usize>(
    what: &str,
    view: &BvhView<'_>,
    lanes: &[Ray; N],
    rng: &mut Rng,
) {
    let all = LaneMask::first(N).0;
    let mut masks = vec![all, 0, ALTERNATING[0] & all, ALTERNATING[1] & all];
    masks.extend((0..N).map(|i| 1u32 << i));
    masks.extend((0..4).map(|_| rng.next_u64() as u32 & all));
    let sentinel = Hit {
        t: -7.0,
        prim: 12345,
        b1: -3.0,
        b2: -4.0,
    };
    let single: Vec<(Option<Hit>, bool)> = lanes
        .iter()
        .map(|r| (view.intersect(r), view.occluded(r)))
        .collect();
    for mask in masks {
        let active = LaneMask(mask);
        let mut packet = RayPacket::<N>::default();
        for (l, r) in lanes.iter().enumerate() {
            let garbage = Ray {
                o: Vec3::splat(f32::NAN),
                d: Vec3::new(0.0, f32::INFINITY, 1.0),
                t_max: f32::NAN,
            };
            packet.set(l, if active.get(l) { r } else { &garbage });
        }
        let mut hits = HitPacket::<N>::default();
        for l in 0..N {
            hits.set(l, Some(sentinel));
        }
        view.intersect_packet(&packet, active, &mut hits);
        let occ = view.occluded_packet(&packet, active);
        for l in 0..N {
            let ctx = || format!("{what} packet{N} mask {mask:#x} lane {l}: {:?}", lanes[l]);
            if !active.get(l) {
                assert_eq!(
                    hits.get(l),
                    Some(sentinel),
                    "{}: inactive lane written",
                    ctx()
                );
                assert!(!occ.get(l), "{}: inactive lane occluded", ctx());
                continue;
            }
            let (want, want_occ) = single[l];
            let got = hits.get(l);
            match (got, want) {
                (Some(g), Some(w)) if g.prim != w.prim => {
                    assert_eq!(g.t.to_bits(), w.t.to_bits(), "{}: {g:?} vs {w:?}", ctx())
                }
                _ => assert_eq!(
                    got.map(|h| (h.prim, h.t.to_bits(), h.b1.to_bits(), h.b2.to_bits())),
                    want.map(|h| (h.prim, h.t.to_bits(), h.b1.to_bits(), h.b2.to_bits())),
                    "{}",
                    ctx()
                ),
            }
            assert_eq!(occ.get(l), want_occ, "{}: occlusion", ctx());
        }
    }
}

/// Bundles shaped like the multiple-try step's (one origin, directions a
/// small perturbation apart, all with the same signs), wider bundles with
/// mixed signs, rays leaving a triangle they start on, and incoherent
/// rays; N = 4, 8, 16; every kernel this CPU runs.
fn packets_match_single_rays<const N: usize>(tris: &[[Vec3; 3]], name: &str) {
    let bvh = Bvh::build(tris);
    let mut rng = Rng(31 + N as u64);
    let rays = random_rays(&mut rng, tris, 60 * N);
    let mut bundles: Vec<[Ray; N]> = Vec::new();
    for (b, chunk) in rays.chunks_exact(N).enumerate() {
        let base = chunk[0];
        let mut lanes = [base; N];
        match b % 4 {
            // Incoherent.
            0 => lanes.copy_from_slice(chunk),
            // Rays leaving a surface: origins on one triangle, unoffset, so
            // lanes meet it again at a distance of either sign within
            // rounding (the f64 decision of "unsure" lanes, in registers
            // of every width, and two triangles at once for packets of 8
            // on AVX-512).
            3 => {
                let [p0, p1, p2] = tris[rng.below(tris.len())];
                let n = (p1 - p0).cross(p2 - p0).normalize_or(Vec3::Z);
                for r in lanes.iter_mut() {
                    let (u, v) = (rng.range(0.05, 0.45), rng.range(0.05, 0.45));
                    r.o = p0 + (p1 - p0) * u + (p2 - p0) * v;
                    let side = if rng.chance(0.5) { 1.0 } else { -1.0 };
                    r.d = n * side + rng.unit() * 0.9;
                    r.t_max = f32::INFINITY;
                }
            }
            // A bundle: one origin, spread 10⁻⁵ … 10⁻¹ around one direction.
            k => {
                let spread = 10f32.powf(rng.range(-5.0, -1.0));
                let d = base.d.normalize_or(Vec3::X);
                for r in lanes.iter_mut() {
                    r.d = d + rng.unit() * spread * if k == 1 { 0.1 } else { 10.0 };
                    if rng.chance(0.2) {
                        r.t_max = rng.range(0.0, 4.0);
                    }
                }
            }
        }
        bundles.push(lanes);
    }
    for k in Kernel::ALL {
        let Some(view) = bvh.view().with_kernel(k) else {
            continue;
        };
        for lanes in &bundles {
            packet_matches_single(&format!("{name} {}", k.name()), &view, lanes, &mut rng);
        }
    }
}

#[test]
fn packets_with_any_mask_match_single_rays() {
    let mut rng = Rng(30);
    let mut tris = room();
    tris.extend(soup(&mut rng, 800));
    packets_match_single_rays::<4>(&tris, "room+soup");
    packets_match_single_rays::<8>(&tris, "room+soup");
    packets_match_single_rays::<16>(&tris, "room+soup");
    // A dense mesh: bundles split deep in the tree.
    let sphere = uv_sphere(64, 128).tris();
    packets_match_single_rays::<16>(&sphere, "uv sphere");
    packets_match_single_rays::<8>(&sphere, "uv sphere");
}

/// Refitting after the triangles moved (a rotation, a translation and a
/// per-vertex jitter that deforms the spheres) answers every query as
/// brute force over the moved triangles does, with every kernel; the tree
/// kept from the first build is only slower, never wrong. (Triangles
/// degenerate at build time stay out, as `Bvh::refit` documents.)
#[test]
fn refit_after_motion_matches_brute_force() {
    let mut rng = Rng(9);
    let mut tris = icosphere(3).tris();
    tris.extend(
        uv_sphere(16, 32)
            .transformed(|v| v * 0.4 + Vec3::new(0.9, 0.2, 0.0))
            .tris(),
    );
    tris.extend(soup(&mut rng, 500));
    let mut bvh = Bvh::build(&tris);
    let turn = glam::Quat::from_rotation_y(0.7);
    let moved: Vec<[Vec3; 3]> = tris
        .iter()
        .enumerate()
        .map(|(i, t)| {
            t.map(|v| {
                // A deterministic wobble of each vertex (different per
                // triangle, so shared vertices also tear apart).
                let wobble = 0.05 * Vec3::new((i as f32).sin(), (v.x * 7.0).cos(), v.y);
                turn * v + Vec3::new(0.3, -0.5, 0.2) + wobble
            })
        })
        .collect();
    bvh.refit(|prim| moved[prim as usize]);
    // Triangles degenerate at build time (the soup has some) stay out of
    // the tree by contract, even once the wobble unfolds them.
    let ids: Vec<u32> = bvh.view().triangles().map(|(_, id)| id).collect();
    assert!(ids.len() < tris.len(), "the soup has degenerate triangles");
    let moved: Vec<[Vec3; 3]> = (0..moved.len() as u32)
        .map(|p| {
            let t = moved[p as usize];
            if ids.contains(&p) { t } else { [t[0]; 3] }
        })
        .collect();
    let brute = BruteForce::new(moved.iter().copied());
    let rays = random_rays(&mut rng, &moved, 20_000);
    let truth: Vec<Option<Hit>> = rays.iter().map(|r| brute.intersect(r)).collect();
    let hits = truth.iter().filter(|h| h.is_some()).count();
    assert!(hits > rays.len() / 10, "{hits} hits");
    let check = Checker::exact(&moved);
    for k in Kernel::ALL {
        let Some(view) = bvh.view().with_kernel(k) else {
            continue;
        };
        compare_backend(
            &format!("refit {}", k.name()),
            &view,
            &brute,
            &rays,
            &truth,
            &check,
        );
    }
    // Moving back restores the original answers exactly.
    bvh.refit(|prim| tris[prim as usize]);
    let fresh = Bvh::build(&tris);
    for r in &rays {
        assert_eq!(
            bvh.intersect(r).map(|h| h.prim),
            fresh.intersect(r).map(|h| h.prim)
        );
    }
}

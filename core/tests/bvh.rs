//! The default BVH against the brute-force ground truth, watertightness on
//! closed meshes, robust spawn offsets, and the edge cases (empty, single
//! triangle, non-finite rays, packets with inactive lanes).

use std::collections::HashMap;

use cmlt::accel::bvh::{Bvh, BvhView, LayoutError, MAX_DEPTH, Node4};
use cmlt::accel::{BruteForce, Intersector};
use cmlt::geometry::offset::{barycentric_error, offset_ray_origin};
use cmlt::geometry::triangle::intersect_triangle;
use cmlt::geometry::{Hit, HitPacket, LaneMask, Ray, RayPacket};
use glam::{Mat3, Vec3};

// ---------------------------------------------------------------------------
// Deterministic randomness (splitmix64).

struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn f(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    fn chance(&mut self, p: f32) -> bool {
        self.f() < p
    }
    fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
    fn in_box(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
        Vec3::new(
            self.range(lo.x, hi.x),
            self.range(lo.y, hi.y),
            self.range(lo.z, hi.z),
        )
    }
}

// ---------------------------------------------------------------------------
// Meshes. Shared vertices are computed once (indexed meshes) so that
// neighbouring triangles see bit-identical coordinates.

struct Mesh {
    verts: Vec<Vec3>,
    idx: Vec<[u32; 3]>,
}

impl Mesh {
    fn tris(&self) -> Vec<[Vec3; 3]> {
        self.idx
            .iter()
            .map(|t| t.map(|i| self.verts[i as usize]))
            .collect()
    }
    fn transformed(&self, f: impl Fn(Vec3) -> Vec3) -> Mesh {
        Mesh {
            verts: self.verts.iter().map(|&v| f(v)).collect(),
            idx: self.idx.clone(),
        }
    }
    /// Undirected edges with the faces on each side.
    fn edges(&self) -> HashMap<(u32, u32), Vec<usize>> {
        let mut m: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
        for (f, t) in self.idx.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                m.entry((a.min(b), a.max(b))).or_default().push(f);
            }
        }
        m
    }
    fn normal(&self, f: usize) -> Vec3 {
        let [a, b, c] = self.idx[f].map(|i| self.verts[i as usize]);
        (b - a).cross(c - a).normalize()
    }
}

/// Surface of the cube [-1, 1]³, each face an n×n grid split into 2n²
/// triangles (diagonals alternating), vertices on the integer lattice.
fn cube(n: u32) -> Mesh {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let mut verts = Vec::new();
    let mut idx = Vec::new();
    let mut vid = |p: [u32; 3], verts: &mut Vec<Vec3>| {
        *ids.entry(p).or_insert_with(|| {
            verts.push(Vec3::from_array(
                p.map(|c| -1.0 + 2.0 * c as f32 / n as f32),
            ));
            (verts.len() - 1) as u32
        })
    };
    for axis in 0..3 {
        for side in [0, n] {
            for i in 0..n {
                for j in 0..n {
                    let at = |di: u32, dj: u32| {
                        let mut p = [0; 3];
                        p[axis] = side;
                        p[(axis + 1) % 3] = i + di;
                        p[(axis + 2) % 3] = j + dj;
                        p
                    };
                    let q = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)].map(|p| vid(p, &mut verts));
                    if (i + j) % 2 == 0 {
                        idx.push([q[0], q[1], q[2]]);
                        idx.push([q[0], q[2], q[3]]);
                    } else {
                        idx.push([q[0], q[1], q[3]]);
                        idx.push([q[1], q[2], q[3]]);
                    }
                }
            }
        }
    }
    Mesh { verts, idx }
}

/// Icosphere of radius 1 (subdivided icosahedron, midpoints cached).
fn icosphere(levels: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut verts: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vec3::from_array(*p).normalize())
    .collect();
    let mut idx: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut m = |a: u32, b: u32, verts: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                verts.push(((verts[a as usize] + verts[b as usize]) * 0.5).normalize());
                (verts.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(idx.len() * 4);
        for [a, b, c] in idx {
            let (ab, bc, ca) = (
                m(a, b, &mut verts),
                m(b, c, &mut verts),
                m(c, a, &mut verts),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        idx = next;
    }
    Mesh { verts, idx }
}

/// UV sphere of radius 1: rings of quads plus triangle fans at the poles.
fn uv_sphere(rings: u32, segments: u32) -> Mesh {
    let mut verts = vec![Vec3::Z, -Vec3::Z];
    for r in 1..rings {
        let th = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let ph = std::f32::consts::TAU * s as f32 / segments as f32;
            verts.push(Vec3::new(
                th.sin() * ph.cos(),
                th.sin() * ph.sin(),
                th.cos(),
            ));
        }
    }
    let v = |r: u32, s: u32| 2 + (r - 1) * segments + s % segments;
    let mut idx = Vec::new();
    for s in 0..segments {
        idx.push([0, v(1, s), v(1, s + 1)]);
        idx.push([1, v(rings - 1, s + 1), v(rings - 1, s)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            idx.push([v(r, s), v(r + 1, s), v(r + 1, s + 1)]);
            idx.push([v(r, s), v(r + 1, s + 1), v(r, s + 1)]);
        }
    }
    Mesh { verts, idx }
}

/// A closed double cone: two fans of `n` thin triangles around the apexes
/// (0, 0, ±1), sharing a rim.
fn double_fan(n: u32) -> Mesh {
    let mut verts = vec![Vec3::Z, -Vec3::Z];
    for s in 0..n {
        let ph = std::f32::consts::TAU * s as f32 / n as f32;
        verts.push(Vec3::new(ph.cos(), ph.sin(), 0.0));
    }
    let mut idx = Vec::new();
    for s in 0..n {
        let (a, b) = (2 + s, 2 + (s + 1) % n);
        idx.push([0, a, b]);
        idx.push([1, b, a]);
    }
    Mesh { verts, idx }
}

fn rotation() -> Mat3 {
    Mat3::from_axis_angle(Vec3::new(0.3, -0.7, 0.5).normalize(), 0.7)
}

// ---------------------------------------------------------------------------
// Comparison against the ground truth.

fn rel_close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs())
}

/// Hits agree: same miss, or same triangle at (nearly) the same `t`, or a
/// tie — different triangles at the same `t`.
fn check_hit(what: &str, ray: &Ray, got: Option<Hit>, want: Option<Hit>) {
    match (got, want) {
        (None, None) => {}
        (Some(g), Some(w)) => {
            assert!(
                rel_close(g.t, w.t, 1e-5),
                "{what}: t {} vs {} (prims {} {}) for {ray:?}",
                g.t,
                w.t,
                g.prim,
                w.prim
            );
            if g.prim == w.prim {
                assert!(
                    (g.b1 - w.b1).abs() <= 1e-5 && (g.b2 - w.b2).abs() <= 1e-5,
                    "{what}: barycentrics {g:?} vs {w:?}"
                );
            }
        }
        _ => panic!("{what}: {got:?} vs ground truth {want:?} for {ray:?}"),
    }
}

/// Random rays for a scene with the given vertices: uniform, axis-aligned
/// (zero and negative-zero components), from vertices, aimed at vertices
/// and edge midpoints, bounded, unnormalised.
fn random_rays(rng: &mut Rng, tris: &[[Vec3; 3]], count: usize) -> Vec<Ray> {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for v in tris.iter().flatten() {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    let ext = (hi - lo).max(Vec3::splat(1e-30));
    let (blo, bhi) = (lo - ext * 0.25, hi + ext * 0.25);
    let axes = [
        Vec3::X,
        Vec3::Y,
        Vec3::Z,
        -Vec3::X,
        -Vec3::Y,
        -Vec3::Z,
        Vec3::new(0.0, -0.0, 1.0),
        Vec3::new(-0.0, 1.0, -0.0),
    ];
    (0..count)
        .map(|_| {
            let tri = tris[rng.below(tris.len())];
            let vert = tri[rng.below(3)];
            let o = match rng.below(6) {
                0 => vert,
                1 => Vec3::new(vert.x, rng.range(blo.y, bhi.y), rng.range(blo.z, bhi.z)),
                _ => rng.in_box(blo, bhi),
            };
            let mut d = match rng.below(8) {
                0 => axes[rng.below(axes.len())],
                1 => vert - o,
                2 => (tri[0] + tri[1]) * 0.5 - o,
                3 => tri[0] * 0.2 + tri[1] * 0.3 + tri[2] * 0.5 - o,
                4 => {
                    let mut d = rng.unit();
                    d[rng.below(3)] = 0.0;
                    d
                }
                _ => rng.unit(),
            };
            if d == Vec3::ZERO {
                d = rng.unit();
            }
            if rng.chance(0.2) {
                d *= 10f32.powf(rng.range(-3.0, 3.0));
            }
            let t_max = if rng.chance(0.25) {
                ext.length() / d.length() * rng.range(0.0, 1.5)
            } else {
                f32::INFINITY
            };
            Ray { o, d, t_max }
        })
        .collect()
}

fn compare_scene(name: &str, tris: &[[Vec3; 3]], rays: &[Ray]) {
    let bvh = Bvh::build(tris);
    let brute = BruteForce::new(tris.iter().copied());
    assert!(bvh.view().depth() as usize <= MAX_DEPTH);
    let truth: Vec<Option<Hit>> = rays.iter().map(|r| brute.intersect(r)).collect();
    for (k, (ray, &want)) in rays.iter().zip(&truth).enumerate() {
        check_hit(name, ray, bvh.intersect(ray), want);
        check_hit(name, ray, bvh.view().intersect(ray), want);
        assert_eq!(
            bvh.occluded(ray),
            want.is_some(),
            "{name}: occlusion for {ray:?}"
        );
        if k % 16 == 0 {
            assert_eq!(
                brute.occluded(ray),
                want.is_some(),
                "{name}: brute force occlusion disagrees with its closest hit"
            );
        }
    }
    // The scenes are meant to exercise both outcomes.
    let hits = truth.iter().filter(|h| h.is_some()).count();
    assert!(
        hits > rays.len() / 10 && hits < rays.len(),
        "{name}: {hits} hits of {}",
        rays.len()
    );
    compare_packets::<4>(name, &bvh, &brute, rays, &truth);
    compare_packets::<8>(name, &bvh, &brute, rays, &truth);
    compare_packets::<16>(name, &bvh, &brute, rays, &truth);
}

/// Packets of random rays and of coherent bundles, with random active
/// masks; inactive lanes hold garbage that must be neither read nor written.
fn compare_packets<const N: usize>(
    name: &str,
    bvh: &Bvh,
    brute: &BruteForce,
    rays: &[Ray],
    truth: &[Option<Hit>],
) {
    let mut rng = Rng(N as u64 * 7919);
    let garbage = [f32::NAN, f32::INFINITY, -1e30, 0.0, 3.0];
    let sentinel = Hit {
        t: -7.0,
        prim: 12345,
        b1: -3.0,
        b2: -4.0,
    };
    let mut packets = 0;
    let mut i = 0;
    while i + N <= rays.len() && packets < rays.len() / N / 2 {
        packets += 1;
        let mut lane_rays = [rays[i]; N];
        let coherent = rng.chance(0.5);
        if !coherent {
            lane_rays.copy_from_slice(&rays[i..i + N]);
        } else {
            // Coherent bundle: one origin, nearby directions.
            let base = rays[i];
            let spread = 10f32.powf(rng.range(-6.0, -1.0));
            for r in lane_rays.iter_mut() {
                r.d = base.d.normalize_or(Vec3::X) + rng.unit() * spread;
                r.t_max = if rng.chance(0.7) {
                    base.t_max
                } else {
                    rng.range(0.0, 3.0)
                };
            }
        }
        let first = i;
        i += N;
        let active = match rng.below(6) {
            0 => LaneMask::first(N),
            1 => LaneMask(1 << rng.below(N)),
            2 => LaneMask::NONE,
            _ => LaneMask(rng.next_u64() as u32 & LaneMask::first(N).0),
        };
        let mut packet = RayPacket::<N>::default();
        for (l, r) in lane_rays.iter().enumerate() {
            if active.get(l) {
                packet.set(l, r);
            } else {
                let g = garbage[rng.below(garbage.len())];
                packet.set(
                    l,
                    &Ray {
                        o: Vec3::splat(g),
                        d: Vec3::new(g, 1.0, -g),
                        t_max: g,
                    },
                );
            }
        }
        let mut hits = HitPacket::<N>::default();
        for l in 0..N {
            hits.set(l, Some(sentinel));
        }
        bvh.intersect_packet(&packet, active, &mut hits);
        let occ = bvh.occluded_packet(&packet, active);
        assert_eq!(
            occ.0 & !active.0,
            0,
            "{name}: occlusion bits outside the active mask"
        );
        for (l, r) in lane_rays.iter().enumerate() {
            if active.get(l) {
                let want = if coherent {
                    brute.intersect(r)
                } else {
                    truth[first + l]
                };
                check_hit(&format!("{name} packet{N} lane {l}"), r, hits.get(l), want);
                assert_eq!(
                    occ.get(l),
                    want.is_some(),
                    "{name}: packet{N} occlusion lane {l} for {r:?}"
                );
            } else {
                assert_eq!(
                    hits.get(l),
                    Some(sentinel),
                    "{name}: packet{N} wrote inactive lane {l}"
                );
            }
        }
    }
}

fn soup(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
    let mut tris = Vec::with_capacity(n + 16);
    for _ in 0..n {
        let c = rng.in_box(Vec3::splat(-1.0), Vec3::splat(1.0));
        let s = 10f32.powf(rng.range(-3.0, -0.3));
        tris.push([c + rng.unit() * s, c + rng.unit() * s, c + rng.unit() * s]);
    }
    // Exact duplicates and coplanar overlaps (ties), and degenerates.
    for k in 0..8 {
        let t = tris[k * 7];
        tris.push(t);
        tris.push([t[1], t[2], t[0]]);
        tris.push([t[0], t[0], t[1]]);
        tris.push([t[0], t[1], t[0] * 2.0 - t[1]]);
    }
    tris
}

/// A closed room (inward cube) with boxes and a ball inside: axis-aligned
/// faces, flat bounding boxes, coplanar neighbours.
fn room() -> Vec<[Vec3; 3]> {
    let mut tris = cube(6).transformed(|v| v * 4.0).tris();
    for (c, s) in [
        (Vec3::new(-1.5, -2.5, 0.5), 1.0),
        (Vec3::new(1.0, -3.0, -1.0), 0.5),
        (Vec3::new(2.0, 1.0, 2.0), 0.3),
    ] {
        tris.extend(cube(3).transformed(|v| c + v * s).tris());
    }
    tris.extend(
        icosphere(2)
            .transformed(|v| Vec3::new(0.0, 2.0, -2.0) + v)
            .tris(),
    );
    tris
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
    let mut tris = vec![t; 3000];
    tris.extend(soup(&mut rng, 200));
    let rays = random_rays(&mut rng, &tris, 5_000);
    compare_scene("identical", &tris, &rays);
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
                let b0 = 1.0 - b1 - b2;
                let p = tri[0] * b0 + tri[1] * b1 + tri[2] * b2;
                let err = barycentric_error(tri[0], tri[1], tri[2], b0, b1, b2);
                let mut w = rng.unit();
                if rng.chance(0.3) {
                    // Grazing.
                    w = (w - ng * w.dot(ng) * 0.999).normalize();
                }
                if w.dot(ng) == 0.0 {
                    continue;
                }
                let o = offset_ray_origin(p, err, ng, w);
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
                let b0 = 1.0 - h.b1 - h.b2;
                let p = t[0] * b0 + t[1] * h.b1 + t[2] * h.b2;
                let err = barycentric_error(t[0], t[1], t[2], b0, h.b1, h.b2);
                let ng = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
                let w = rng.unit();
                ray = Ray::new(offset_ray_origin(p, err, ng, w), w);
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

fn nasty_rays() -> Vec<Ray> {
    let n = f32::NAN;
    let i = f32::INFINITY;
    let good = Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z);
    vec![
        Ray {
            o: Vec3::new(n, 0.0, 0.0),
            ..good
        },
        Ray {
            d: Vec3::new(0.0, n, -1.0),
            ..good
        },
        Ray {
            d: Vec3::ZERO,
            ..good
        },
        Ray {
            o: Vec3::new(0.0, 0.0, i),
            ..good
        },
        Ray {
            d: Vec3::new(0.0, 0.0, -i),
            ..good
        },
        Ray { t_max: n, ..good },
        Ray { t_max: 0.0, ..good },
        Ray {
            t_max: -1.0,
            ..good
        },
        Ray { t_max: -i, ..good },
    ]
}

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
    assert_eq!(bvh.view().tris().len(), 1);
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
    let (nodes, tris, ids) = bvh.clone().into_parts();
    assert!(BvhView::new(&nodes, &tris, &ids).is_ok());
    assert_eq!(
        BvhView::new(&nodes, &tris, &ids[..1]).unwrap_err(),
        LayoutError::Lengths
    );
    assert!(matches!(
        BvhView::new(&nodes, &tris, &[0, u32::MAX]),
        Err(LayoutError::ReservedPrimId { index: 1 })
    ));
    let mut bad = nodes.clone();
    bad[0].count[0] = 7;
    assert!(matches!(
        BvhView::new(&bad, &tris, &ids),
        Err(LayoutError::BadChild { node: 0, .. })
    ));
    let mut bad = nodes.clone();
    bad[0].child[0] = 0;
    bad[0].count[0] = 0;
    assert!(matches!(
        BvhView::new(&bad, &tris, &ids),
        Err(LayoutError::BadChild { node: 0, slot: 0 })
    ));

    // A chain: node k holds a leaf with triangle k and the next node. At
    // MAX_DEPTH levels it is valid and traversable; one more is too deep.
    let chain = |levels: usize| {
        let tris: Vec<[Vec3; 3]> = (0..levels)
            .map(|k| tri.map(|v| v + Vec3::Z * k as f32))
            .collect();
        let mut nodes = vec![Node4::EMPTY; levels];
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

//! Helpers shared by the intersector tests: deterministic randomness,
//! meshes, adversarial ray sets, and comparison against `BruteForce`.
#![allow(dead_code)]

use std::cell::Cell;
use std::collections::{HashMap, HashSet};

use cmlt::accel::{BruteForce, Intersector};
use cmlt::geometry::{Hit, HitPacket, LaneMask, Ray, RayPacket};
use glam::{Mat3, Vec3};

// ---------------------------------------------------------------------------
// Deterministic randomness (splitmix64).

pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn f(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f()
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    pub fn chance(&mut self, p: f32) -> bool {
        self.f() < p
    }
    pub fn unit(&mut self) -> Vec3 {
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
    pub fn in_box(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
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

pub struct Mesh {
    pub verts: Vec<Vec3>,
    pub idx: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn tris(&self) -> Vec<[Vec3; 3]> {
        self.idx
            .iter()
            .map(|t| t.map(|i| self.verts[i as usize]))
            .collect()
    }
    pub fn transformed(&self, f: impl Fn(Vec3) -> Vec3) -> Mesh {
        Mesh {
            verts: self.verts.iter().map(|&v| f(v)).collect(),
            idx: self.idx.clone(),
        }
    }
    /// Undirected edges with the faces on each side.
    pub fn edges(&self) -> HashMap<(u32, u32), Vec<usize>> {
        let mut m: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
        for (f, t) in self.idx.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                m.entry((a.min(b), a.max(b))).or_default().push(f);
            }
        }
        m
    }
    pub fn normal(&self, f: usize) -> Vec3 {
        let [a, b, c] = self.idx[f].map(|i| self.verts[i as usize]);
        (b - a).cross(c - a).normalize()
    }
}

/// Surface of the cube [-1, 1]³, each face an n×n grid split into 2n²
/// triangles (diagonals alternating), vertices on the integer lattice.
pub fn cube(n: u32) -> Mesh {
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
pub fn icosphere(levels: u32) -> Mesh {
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
pub fn uv_sphere(rings: u32, segments: u32) -> Mesh {
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
pub fn double_fan(n: u32) -> Mesh {
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

pub fn rotation() -> Mat3 {
    Mat3::from_axis_angle(Vec3::new(0.3, -0.7, 0.5).normalize(), 0.7)
}

// ---------------------------------------------------------------------------
// Comparison against the ground truth.

pub fn rel_close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs())
}

/// Hits agree: same miss, or same triangle at (nearly) the same `t`, or a
/// tie — different triangles at the same `t`. `bary_tol` bounds the
/// barycentric difference on the same triangle.
fn hit_agrees(
    got: Option<Hit>,
    want: Option<Hit>,
    bary_tol: f32,
    t_tol: f32,
) -> Result<(), String> {
    match (got, want) {
        (None, None) => Ok(()),
        (Some(g), Some(w)) => {
            if !rel_close(g.t, w.t, 1e-5) && (g.t - w.t).abs() > t_tol {
                return Err(format!(
                    "t {} vs {} (prims {} {})",
                    g.t, w.t, g.prim, w.prim
                ));
            }
            if g.prim == w.prim
                && ((g.b1 - w.b1).abs() > bary_tol || (g.b2 - w.b2).abs() > bary_tol)
            {
                return Err(format!("barycentrics {g:?} vs {w:?}"));
            }
            Ok(())
        }
        _ => Err(format!("{got:?} vs ground truth {want:?}")),
    }
}

/// Exact agreement (our kernels) with the ground truth.
pub fn check_hit(what: &str, ray: &Ray, got: Option<Hit>, want: Option<Hit>) {
    if let Err(e) = hit_agrees(got, want, 1e-5, 0.0) {
        panic!("{what}: {e} for {ray:?}");
    }
}

/// Compares a backend with the ground truth. Our kernels must agree
/// exactly (up to ties); a backend with another triangle test (Embree) may
/// disagree on rays whose answer is decided by rounding — hits within 1e-4
/// (barycentric) of an edge, grazing hits, hits within 1e-4 of the scene's
/// extent from the origin — and those disagreements are counted and
/// bounded by [`Checker::finish`].
pub struct Checker<'a> {
    tris: &'a [[Vec3; 3]],
    /// The scene's extent, for a lenient checker.
    lenient: Option<f32>,
    /// The scene's vertices (bit patterns), for a lenient checker: a ray
    /// starting exactly on one starts on the surface.
    verts: HashSet<[u32; 3]>,
    excused: Cell<usize>,
    on_surface: Cell<usize>,
    checked: Cell<usize>,
}

impl<'a> Checker<'a> {
    /// Exact agreement.
    pub fn exact(tris: &'a [[Vec3; 3]]) -> Self {
        Checker {
            tris,
            lenient: None,
            verts: HashSet::new(),
            excused: Cell::new(0),
            on_surface: Cell::new(0),
            checked: Cell::new(0),
        }
    }

    /// Agreement except on rounding-decided rays.
    pub fn lenient(tris: &'a [[Vec3; 3]]) -> Self {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for v in tris.iter().flatten() {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        Checker {
            lenient: Some((hi - lo).length()),
            verts: tris
                .iter()
                .flatten()
                .map(|v| v.to_array().map(f32::to_bits))
                .collect(),
            ..Self::exact(tris)
        }
    }

    /// Whether `h` on `ray` is decided by rounding: the ray starts on a
    /// vertex, or hits near an edge, near its origin, at a grazing angle,
    /// or on a sliver.
    fn ambiguous(&self, ray: &Ray, h: Option<Hit>) -> bool {
        let Some(extent) = self.lenient else {
            return false;
        };
        let Some(h) = h else { return false };
        let Some(t) = self.tris.get(h.prim as usize) else {
            return false;
        };
        let b0 = 1.0 - h.b1 - h.b2;
        let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
        let n = e1.cross(e2);
        let sliver = n.length() < 1e-3 * e1.length_squared().max(e2.length_squared());
        let grazing = n.normalize_or_zero().dot(ray.d.normalize_or_zero()).abs() < 1e-3;
        // Distance of the hit point to the nearest edge, against the
        // rounding of a point at the ray's reach.
        let min_b = b0.min(h.b1).min(h.b2);
        let longest = e1.length().max(e2.length()).max((t[2] - t[1]).length());
        let reach = ray.o.length() + h.t * ray.d.length();
        let near_edge = min_b < 1e-4 || min_b * n.length() / longest < 1e-5 * reach;
        near_edge || h.t * ray.d.length() < 1e-4 * extent || grazing || sliver
    }

    fn excuse(&self, what: &str, ray: &Ray, e: String, got: Option<Hit>, want: Option<Hit>) {
        if self.lenient.is_some() && self.verts.contains(&ray.o.to_array().map(f32::to_bits)) {
            // Starts on the surface: outside what the contract can promise
            // (renderers offset their origins); not counted.
            self.on_surface.set(self.on_surface.get() + 1);
        } else if self.ambiguous(ray, got) || self.ambiguous(ray, want) {
            if std::env::var_os("CMLT_DEBUG_EXCUSE").is_some() {
                eprintln!("excused {what}: {e} for {ray:?}");
            }
            self.excused.set(self.excused.get() + 1);
        } else {
            panic!("{what}: {e} for {ray:?}");
        }
    }

    /// Closest hits agree.
    pub fn hit(&self, what: &str, ray: &Ray, got: Option<Hit>, want: Option<Hit>) {
        self.checked.set(self.checked.get() + 1);
        let tol = match (self.lenient, got) {
            // Another test's barycentrics are as precise as its hit point,
            // which is within a few ulps of the ray's reach: relative to
            // the triangle's size, that is coarse for small, far triangles.
            (Some(_), Some(g)) => {
                let t = self.tris[g.prim as usize];
                let size = (t[1] - t[0]).length().max((t[2] - t[0]).length());
                1e-4 + 1e-5 * (ray.o.length() + g.t * ray.d.length()) / size
            }
            _ => 1e-5,
        };
        // Likewise, distances are as precise as the origin's coordinates.
        let t_tol = match self.lenient {
            Some(_) => 1e-5 * ray.o.length() / ray.d.length(),
            None => 0.0,
        };
        if let Err(e) = hit_agrees(got, want, tol, t_tol) {
            self.excuse(what, ray, e, got, want);
        }
    }

    /// The occlusion answer agrees with the ground truth's closest hit;
    /// `closest` is the backend's own closest hit (to judge ambiguity).
    pub fn occluded(
        &self,
        what: &str,
        ray: &Ray,
        got: bool,
        want: Option<Hit>,
        closest: impl FnOnce() -> Option<Hit>,
    ) {
        self.checked.set(self.checked.get() + 1);
        if got != want.is_some() {
            let e = format!("occlusion {got} vs ground truth {want:?}");
            self.excuse(what, ray, e, closest(), want);
        }
    }

    /// At most 1% of the comparisons may have been excused as decided by
    /// rounding (the ray sets aim a quarter of their rays at vertices and
    /// edges); rays starting on a vertex are not counted.
    pub fn finish(&self, name: &str) {
        let (e, c, s) = (
            self.excused.get(),
            self.checked.get(),
            self.on_surface.get(),
        );
        eprintln!(
            "{name}: {e} of {c} comparisons excused as rounding-decided, {s} start on a vertex"
        );
        assert!(e * 100 <= c, "{name}: {e} of {c} comparisons disagree");
    }
}

/// Random rays for a scene with the given vertices: uniform, axis-aligned
/// (zero and negative-zero components), from vertices, aimed at vertices
/// and edge midpoints, bounded, unnormalised.
pub fn random_rays(rng: &mut Rng, tris: &[[Vec3; 3]], count: usize) -> Vec<Ray> {
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

/// Single rays of `rays` against their ground truth `truth`.
pub fn compare_rays<I: Intersector>(
    name: &str,
    backend: &I,
    rays: &[Ray],
    truth: &[Option<Hit>],
    check: &Checker<'_>,
) {
    for (ray, &want) in rays.iter().zip(truth) {
        let got = backend.intersect(ray);
        check.hit(name, ray, got, want);
        check.occluded(name, ray, backend.occluded(ray), want, || got);
    }
}

/// The two alternating lane masks (even lanes, odd lanes).
pub const ALTERNATING: [u32; 2] = [0x5555_5555, 0xaaaa_aaaa];

/// Packets of random rays and of coherent bundles, with random active
/// masks (all, none, one lane, alternating, random); inactive lanes hold garbage that must be neither read nor written.
pub fn compare_packets<const N: usize, I: Intersector>(
    name: &str,
    backend: &I,
    brute: &BruteForce,
    rays: &[Ray],
    truth: &[Option<Hit>],
    check: &Checker<'_>,
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
        let active = match rng.below(7) {
            0 => LaneMask::first(N),
            1 => LaneMask(1 << rng.below(N)),
            2 => LaneMask::NONE,
            3 => LaneMask(ALTERNATING[rng.below(2)] & LaneMask::first(N).0),
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
        backend.intersect_packet(&packet, active, &mut hits);
        let occ = backend.occluded_packet(&packet, active);
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
                let what = format!("{name} packet{N} lane {l}");
                check.hit(&what, r, hits.get(l), want);
                check.occluded(&what, r, occ.get(l), want, || backend.intersect(r));
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

/// Streams of `rays` (with [`nasty_rays`] mixed in, in chunks of odd
/// lengths) against `truth`; outputs past the shorter of the two slices
/// must be left alone.
pub fn compare_stream<I: Intersector>(
    name: &str,
    backend: &I,
    rays: &[Ray],
    truth: &[Option<Hit>],
    check: &Checker<'_>,
) {
    let sentinel = Hit {
        t: -7.0,
        prim: 12345,
        b1: -3.0,
        b2: -4.0,
    };
    let nasty = nasty_rays();
    let mut stream: Vec<(Ray, Option<Hit>)> = Vec::new();
    for (k, (r, h)) in rays.iter().zip(truth).enumerate() {
        stream.push((*r, *h));
        if k % 5 == 0 {
            stream.push((nasty[k / 5 % nasty.len()], None));
        }
    }
    let mut start = 0;
    for len in [1usize, 3, 7, 8, 9, 31, 200].into_iter().cycle() {
        if start >= stream.len() {
            break;
        }
        let chunk = &stream[start..(start + len).min(stream.len())];
        start += len;
        let chunk_rays: Vec<Ray> = chunk.iter().map(|c| c.0).collect();
        // One output more than there are rays: it must stay untouched.
        let mut hits = vec![Some(sentinel); chunk.len() + 1];
        let mut occ = vec![true; chunk.len() + 1];
        backend.intersect_stream(&chunk_rays, &mut hits);
        backend.occluded_stream(&chunk_rays, &mut occ);
        assert_eq!(
            hits[chunk.len()],
            Some(sentinel),
            "{name}: stream wrote past its rays"
        );
        assert!(
            occ[chunk.len()],
            "{name}: occlusion stream wrote past its rays"
        );
        for (i, (r, want)) in chunk.iter().enumerate() {
            let what = format!("{name} stream");
            check.hit(&what, r, hits[i], *want);
            check.occluded(&what, r, occ[i], *want, || hits[i]);
        }
        // Fewer outputs than rays: only those are written.
        if chunk.len() >= 2 {
            let mut short = vec![Some(sentinel); chunk.len() - 1];
            backend.intersect_stream(&chunk_rays, &mut short);
            assert_eq!(&short[..], &hits[..chunk.len() - 1], "{name}: short stream");
        }
    }
}

/// Every backend query — single rays, packets of 4, 8 and 16, streams —
/// against the brute-force answers `truth` for `rays`.
pub fn compare_backend<I: Intersector>(
    name: &str,
    backend: &I,
    brute: &BruteForce,
    rays: &[Ray],
    truth: &[Option<Hit>],
    check: &Checker<'_>,
) {
    compare_rays(name, backend, rays, truth, check);
    compare_packets::<4, I>(name, backend, brute, rays, truth, check);
    compare_packets::<8, I>(name, backend, brute, rays, truth, check);
    compare_packets::<16, I>(name, backend, brute, rays, truth, check);
    compare_stream(name, backend, rays, truth, check);
}

pub fn soup(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
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
pub fn room() -> Vec<[Vec3; 3]> {
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

/// Rays no backend may hit with: NaN/inf origins or directions, a zero
/// direction, NaN, zero and negative `t_max`.
pub fn nasty_rays() -> Vec<Ray> {
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

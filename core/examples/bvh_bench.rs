//! Single-thread BVH throughput: builds the default BVH over a procedural
//! mesh of ≥ 250k triangles and reports Mrays/s for coherent primary-like
//! rays and for random rays, single rays vs packets of 8.
//!
//! Run with `cargo run --release -p cmlt --example bvh_bench [sphere_res ground_res]`.

#[cfg(not(feature = "std"))]
fn main() {}

#[cfg(feature = "std")]
fn main() {
    bench::run();
}

#[cfg(feature = "std")]
mod bench {
    use std::hint::black_box;
    use std::time::Instant;

    use cmlt::accel::Intersector;
    use cmlt::accel::bvh::Bvh;
    use cmlt::geometry::{HitPacket, LaneMask, Ray, RayPacket};
    use glam::Vec3;

    /// xorshift64*.
    struct Rng(u64);
    impl Rng {
        fn f(&mut self) -> f32 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// A bumpy sphere (`n × 2n` grid) plus a wavy ground plane (`m × m`).
    fn scene(n: u32, m: u32) -> Vec<[Vec3; 3]> {
        let mut tris = Vec::new();
        let sphere = |i: u32, j: u32| {
            let th = std::f32::consts::PI * i as f32 / n as f32;
            let ph = std::f32::consts::TAU * (j % (2 * n)) as f32 / (2 * n) as f32;
            let r = 1.0
                + 0.05 * (7.0 * th).sin() * (9.0 * ph).cos()
                + 0.02 * (31.0 * th).cos() * (23.0 * ph).sin();
            Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()) * r
                + Vec3::new(0.0, 0.2, 0.0)
        };
        for i in 0..n {
            for j in 0..2 * n {
                let (a, b, c, d) = (
                    sphere(i, j),
                    sphere(i + 1, j),
                    sphere(i + 1, j + 1),
                    sphere(i, j + 1),
                );
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            }
        }
        let ground = |i: u32, j: u32| {
            let (x, z) = (
                -4.0 + 8.0 * i as f32 / m as f32,
                -4.0 + 8.0 * j as f32 / m as f32,
            );
            Vec3::new(x, -1.0 + 0.05 * (3.0 * x).sin() * (2.0 * z).cos(), z)
        };
        for i in 0..m {
            for j in 0..m {
                let (a, b, c, d) = (
                    ground(i, j),
                    ground(i + 1, j),
                    ground(i + 1, j + 1),
                    ground(i, j + 1),
                );
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            }
        }
        tris
    }

    /// Pinhole camera rays, `w × h`, in 4×2 pixel tiles (one packet of 8 per
    /// tile) so consecutive rays are coherent.
    fn primary(w: u32, h: u32) -> Vec<Ray> {
        let eye = Vec3::new(0.5, 0.8, 4.5);
        let fwd = (Vec3::new(0.0, 0.0, 0.0) - eye).normalize();
        let right = fwd.cross(Vec3::Y).normalize();
        let up = right.cross(fwd);
        let mut rays = Vec::with_capacity((w * h) as usize);
        for ty in (0..h).step_by(2) {
            for tx in (0..w).step_by(4) {
                for y in ty..ty + 2 {
                    for x in tx..tx + 4 {
                        let u = (x as f32 + 0.5) / w as f32 * 2.0 - 1.0;
                        let v = 1.0 - (y as f32 + 0.5) / h as f32 * 2.0;
                        let d = fwd + right * u * 0.6 * w as f32 / h as f32 + up * v * 0.6;
                        rays.push(Ray::new(eye, d.normalize()));
                    }
                }
            }
        }
        rays
    }

    /// Rays from random points in the scene's box in random directions.
    fn random(count: usize) -> Vec<Ray> {
        let mut rng = Rng(0x1234_5678_9abc_def1);
        (0..count)
            .map(|_| {
                let o = Vec3::new(
                    rng.f() * 8.0 - 4.0,
                    rng.f() * 3.5 - 1.2,
                    rng.f() * 8.0 - 4.0,
                );
                let d = loop {
                    let d = Vec3::new(
                        rng.f() * 2.0 - 1.0,
                        rng.f() * 2.0 - 1.0,
                        rng.f() * 2.0 - 1.0,
                    );
                    if d.length_squared() <= 1.0 && d.length_squared() > 1e-4 {
                        break d.normalize();
                    }
                };
                Ray::new(o, d)
            })
            .collect()
    }

    /// Seconds this thread has spent on a CPU (Linux `schedstat`, ns
    /// resolution), so that other load on the machine does not count;
    /// wall-clock time elsewhere.
    fn cpu_seconds(start: Instant) -> f64 {
        std::fs::read_to_string("/proc/thread-self/schedstat")
            .ok()
            .and_then(|s| s.split_whitespace().next()?.parse::<u64>().ok())
            .map_or_else(|| start.elapsed().as_secs_f64(), |ns| ns as f64 * 1e-9)
    }

    /// Best of a few runs, in Mrays/s of thread CPU time; also returns the
    /// hit count.
    fn measure(rays: &[Ray], mut f: impl FnMut(&[Ray]) -> usize) -> (f64, usize) {
        let origin = Instant::now();
        let mut best = f64::INFINITY;
        let mut hits = 0;
        for _ in 0..5 {
            let t = cpu_seconds(origin);
            hits = f(black_box(rays));
            best = best.min(cpu_seconds(origin) - t);
        }
        (rays.len() as f64 / best / 1e6, hits)
    }

    fn single(bvh: &Bvh, rays: &[Ray]) -> usize {
        rays.iter().filter(|r| bvh.intersect(r).is_some()).count()
    }

    fn single_occluded(bvh: &Bvh, rays: &[Ray]) -> usize {
        rays.iter().filter(|r| bvh.occluded(r)).count()
    }

    fn packets(bvh: &Bvh, rays: &[Ray]) -> usize {
        let mut hits = 0;
        for chunk in rays.chunks(8) {
            let mut p = RayPacket::<8>::default();
            for (i, r) in chunk.iter().enumerate() {
                p.set(i, r);
            }
            let mut h = HitPacket::<8>::default();
            bvh.intersect_packet(&p, LaneMask::first(chunk.len()), &mut h);
            hits += h
                .prim
                .iter()
                .filter(|&&p| p != HitPacket::<8>::MISS)
                .count();
        }
        hits
    }

    fn packets_occluded(bvh: &Bvh, rays: &[Ray]) -> usize {
        let mut hits = 0;
        for chunk in rays.chunks(8) {
            let mut p = RayPacket::<8>::default();
            for (i, r) in chunk.iter().enumerate() {
                p.set(i, r);
            }
            hits += bvh
                .occluded_packet(&p, LaneMask::first(chunk.len()))
                .count() as usize;
        }
        hits
    }

    pub fn run() {
        // Optional: sphere and ground resolution (default ≈ 279k triangles).
        let arg = |i: usize, default: u32| {
            std::env::args()
                .nth(i)
                .and_then(|a| a.parse().ok())
                .unwrap_or(default)
        };
        let tris = scene(arg(1, 250), arg(2, 120));
        let t = Instant::now();
        let bvh = Bvh::build(&tris);
        let build = t.elapsed();
        let view = bvh.view();
        let leaves: usize = view
            .nodes()
            .iter()
            .map(|n| n.count.iter().filter(|&&c| c > 0).count())
            .sum();
        println!(
            "{} triangles: built in {:.2?}, {} nodes, {} leaves ({:.2} tris/leaf), depth {}",
            tris.len(),
            build,
            view.nodes().len(),
            leaves,
            view.triangles().count() as f64 / leaves as f64,
            view.depth()
        );
        let sets = [
            ("coherent primary (1024x768)", primary(1024, 768)),
            ("random", random(1 << 19)),
        ];
        for (name, rays) in &sets {
            let (s, hs) = measure(rays, |r| single(&bvh, r));
            let (p, hp) = measure(rays, |r| packets(&bvh, r));
            assert_eq!(hs, hp);
            let (so, os) = measure(rays, |r| single_occluded(&bvh, r));
            let (po, op) = measure(rays, |r| packets_occluded(&bvh, r));
            assert_eq!(os, op);
            assert_eq!(os, hs);
            println!(
                "{name}: {} rays, {:.1}% hit",
                rays.len(),
                100.0 * hs as f64 / rays.len() as f64
            );
            println!("  closest hit: single {s:7.2} Mrays/s   packet-8 {p:7.2} Mrays/s");
            println!("  occlusion:   single {so:7.2} Mrays/s   packet-8 {po:7.2} Mrays/s");
        }
    }
}

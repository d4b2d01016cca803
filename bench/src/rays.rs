//! `cmlt-bench rays`: ray throughput of every traversal kernel on the same
//! fixed ray sets.
//!
//! Ray sets, generated once per scene from a fixed seed:
//! - `primary`: pinhole camera rays through jittered pixel centres, ordered
//!   in 4×4 pixel tiles so that consecutive 4/8/16 rays are coherent;
//! - `diffuse`: cosine-distributed bounces from the primary hits, shuffled
//!   (incoherent);
//! - `mtm8`, `mtm16`: multiple-try bundles — k = 8 or 16 small
//!   perturbations (±1 pixel) of one camera ray, bundles scattered over
//!   the image;
//! - `shadow`: occlusion segments from the primary hits to points on the
//!   emitters (or, for the procedural mesh, on an area above it).
//!
//! Kernels: `ours-<isa>` trace ray by ray with our BVH and one kernel
//! (`scalar`, `sse2`, `avx2`, `avx512`, those the CPU runs);
//! `ours-packet{4,8,16}` trace packets with the best kernel;
//! `ours-stream` traces the set as streams of 256 independent rays
//! (`Intersector::intersect_stream`: interleaved walks on trees of
//! `INTERLEAVE_MIN_BYTES` and more); `embree-1`, `embree-{4,8,16}` and
//! `embree-stream` (feature `embree`; `rtcIntersect1M`/`rtcOccluded1M` in
//! incoherent mode) do the same through Embree.
//! Each measurement traces its ray set repeatedly for about `--time`
//! seconds, on 1 and 2 threads (each thread a share of the set); with
//! `--rounds R`, every kernel of a cell is measured R times, the kernels
//! taking turns, and the best of its R figures is reported.

use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

use cmlt::accel::Intersector;
use cmlt::accel::bvh::{Bvh, Kernel};
use cmlt::geometry::offset::{TrianglePoint, spawn_ray, spawn_rays_between, triangle_point};
use cmlt::geometry::{HitPacket, LaneMask, Ray, RayPacket};
use cmlt::math::{Frame, Mat4, Vec2, Vec3};
use cmlt::sampler::SampleStream;
use cmlt::scene::{Camera, FovAxis, Scene};

/// Settings of one benchmark run.
#[derive(Clone, Debug)]
pub struct Options {
    /// Shared scene names or XML paths, and `mesh` for the procedural
    /// large mesh.
    pub scenes: Vec<String>,
    /// Seconds per measurement (at least one pass over the set is timed).
    pub time: f64,
    /// Thread counts to measure.
    pub threads: Vec<usize>,
    /// Primary rays per scene (the other sets derive from them).
    pub rays: usize,
    /// Triangles of the procedural mesh (at least this many).
    pub mesh_triangles: usize,
    /// Directory of the shared scenes (`<dir>/<name>/scene.xml`).
    pub scenes_dir: std::path::PathBuf,
    /// Only these kernels (names as in the table, e.g. `ours-packet16`);
    /// empty = all.
    pub kernels: Vec<String>,
    /// Only these ray sets; empty = all.
    pub sets: Vec<String>,
    /// What the rays are timed against.
    pub clock: Clock,
    /// Measurements per kernel and cell, taken in rounds that visit every
    /// kernel of the cell in turn; the best of a kernel's rounds is
    /// reported. On a shared machine whose speed drifts over seconds, this
    /// puts every kernel of a ratio under the same drift.
    pub rounds: usize,
}

/// The clock a measurement divides by.
///
/// Wall-clock throughput swings with whatever else the machine runs; the
/// CPU time of the tracing threads does much less (preemption does not
/// count), which makes A/B comparisons on a shared machine dependable.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Clock {
    /// Elapsed real time of the whole measurement (all threads).
    #[default]
    Wall,
    /// Per-thread CPU time, summed over the threads (so with `n` threads
    /// it is the throughput per busy core times `n`, ignoring contention
    /// for cores). Linux only: read from `/proc/thread-self/schedstat`.
    Cpu,
}

/// Nanoseconds this thread has spent on a CPU (Linux schedstat: the first
/// field), or `None` where that file does not exist.
fn thread_cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

/// Per-thread elapsed time on `clock`, started by [`Stopwatch::start`].
struct Stopwatch {
    wall: Instant,
    cpu_ns: Option<u64>,
}

impl Stopwatch {
    fn start(clock: Clock) -> Self {
        Stopwatch {
            wall: Instant::now(),
            cpu_ns: if clock == Clock::Cpu {
                thread_cpu_ns()
            } else {
                None
            },
        }
    }

    /// Time since the start: CPU time of this thread if it was started on
    /// the CPU clock (and schedstat is readable), else wall time.
    fn elapsed(&self) -> Duration {
        match (self.cpu_ns, self.cpu_ns.and(thread_cpu_ns())) {
            (Some(a), Some(b)) => Duration::from_nanos(b.saturating_sub(a)),
            _ => self.wall.elapsed(),
        }
    }
}

impl Options {
    fn wants_kernel(&self, kernel: &str) -> bool {
        self.kernels.is_empty() || self.kernels.iter().any(|k| k == kernel)
    }

    fn wants_set(&self, set: &str) -> bool {
        self.sets.is_empty() || self.sets.iter().any(|s| s == set)
    }
}

/// One throughput measurement (a CSV row).
#[derive(Clone, Debug, PartialEq)]
pub struct Measurement {
    /// Scene name.
    pub scene: String,
    /// Ray set (`primary`, `diffuse`, `mtm8`, `mtm16`, `shadow`).
    pub ray_set: String,
    /// Kernel (`ours-…` or `embree-…`).
    pub kernel: String,
    /// Threads used.
    pub threads: usize,
    /// Millions of rays per second.
    pub mrays_per_s: f64,
}

/// The CSV header written by [`write_csv`].
pub const CSV_HEADER: &str = "scene,ray_set,kernel,threads,mrays_per_s";

/// Writes `rows` as CSV with [`CSV_HEADER`].
pub fn write_csv(path: &Path, rows: &[Measurement]) -> Result<(), String> {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for m in rows {
        s.push_str(&format!(
            "{},{},{},{},{}\n",
            m.scene, m.ray_set, m.kernel, m.threads, m.mrays_per_s
        ));
    }
    std::fs::write(path, s).map_err(|e| format!("{}: {e}", path.display()))
}

/// Samples a shadow-ray target: point, error bound, normal.
type LightSampler = Box<dyn Fn(&mut SampleStream) -> (Vec3, Vec3, Vec3)>;

/// Triangles plus what the ray sets need.
struct BenchScene {
    name: String,
    tris: Vec<[Vec3; 3]>,
    camera: Camera,
    /// Shadow-ray targets.
    light: LightSampler,
}

fn load(name: &str, opts: &Options) -> Result<BenchScene, String> {
    if name == "mesh" {
        return Ok(large_mesh(opts.mesh_triangles));
    }
    let path = if Path::new(name).is_file() {
        Path::new(name).to_path_buf()
    } else {
        opts.scenes_dir.join(name).join("scene.xml")
    };
    let loaded = cmlt_cli::mitsuba::load_scene(&path, &[]).map_err(|e| e.to_string())?;
    let scene: Scene = loaded.scene;
    let tris = scene.triangles().collect();
    let camera = scene.camera;
    let light = Box::new(move |rng: &mut SampleStream| {
        let u = rng.next_f32();
        match scene.sample_light(u, rng.next_2d()) {
            Some((sp, _)) => (sp.p, sp.p_error, sp.ng),
            None => (Vec3::ZERO, Vec3::ZERO, Vec3::Y),
        }
    });
    Ok(BenchScene {
        name: name.to_string(),
        tris,
        camera,
        light,
    })
}

/// A displaced sphere of at least `min_tris` triangles (a latitude–longitude
/// grid with bumps of several frequencies), seen from a camera that frames
/// it, lit from an area above.
fn large_mesh(min_tris: usize) -> BenchScene {
    let n = ((min_tris as f64 / 2.0).sqrt().ceil() as usize).max(8);
    let (rings, segs) = (n, n);
    let radius = |theta: f32, phi: f32| {
        1.0 + 0.08 * (7.0 * theta).sin() * (5.0 * phi).cos()
            + 0.03 * (23.0 * theta).cos() * (19.0 * phi).sin()
            + 0.01 * (61.0 * theta + 47.0 * phi).sin()
    };
    let vert = |i: usize, j: usize| {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        let phi = 2.0 * std::f32::consts::PI * (j % segs) as f32 / segs as f32;
        let r = radius(theta, phi);
        Vec3::new(
            r * theta.sin() * phi.cos(),
            r * theta.cos(),
            r * theta.sin() * phi.sin(),
        )
    };
    let mut tris = Vec::with_capacity(2 * rings * segs);
    for i in 0..rings {
        for j in 0..segs {
            let (a, b, c, d) = (
                vert(i, j),
                vert(i + 1, j),
                vert(i + 1, j + 1),
                vert(i, j + 1),
            );
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    let eye = Vec3::new(0.3, 0.8, -3.2);
    let z = (-eye).normalize();
    let x = Vec3::Y.cross(z).normalize();
    let y = z.cross(x);
    let to_world = Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), eye.extend(1.0));
    let camera =
        Camera::perspective(to_world, 45.0, FovAxis::X, 256, 256, 0.0, 1.0).expect("valid camera");
    let light = Box::new(|rng: &mut SampleStream| {
        let u = rng.next_2d();
        (
            Vec3::new(-1.0 + 2.0 * u.x, 3.0, -1.0 + 2.0 * u.y),
            Vec3::ZERO,
            -Vec3::Y,
        )
    });
    BenchScene {
        name: "mesh".to_string(),
        tris,
        camera,
        light,
    }
}

/// The fixed ray sets of one scene.
struct RaySets {
    sets: Vec<(&'static str, Vec<Ray>, bool)>,
}

fn ray_sets(s: &BenchScene, bvh: &Bvh, count: usize) -> RaySets {
    let mut rng = SampleStream::new(7, 0, 0);
    let (w, h) = (s.camera.width() as f32, s.camera.height() as f32);
    // Primary: a grid of about `count` pixels in 4×4 tiles.
    let side = ((count as f64).sqrt() as usize).max(4) / 4 * 4;
    let mut primary = Vec::with_capacity(side * side);
    for ty in (0..side).step_by(4) {
        for tx in (0..side).step_by(4) {
            for k in 0..16 {
                let (px, py) = (tx + k % 4, ty + k / 4);
                let u = rng.next_2d();
                let raster = Vec2::new(
                    (px as f32 + u.x) / side as f32 * w,
                    (py as f32 + u.y) / side as f32 * h,
                );
                primary.push(s.camera.generate_ray(raster, Vec2::splat(0.5)));
            }
        }
    }
    // Hit points of the primary rays, for bounces and shadow rays.
    let mut diffuse = Vec::new();
    let mut shadow = Vec::new();
    for r in &primary {
        let Some(hit) = bvh.intersect(r) else {
            continue;
        };
        let t = s.tris[hit.prim as usize];
        let TrianglePoint {
            p, p_error: err, ..
        } = triangle_point(t, hit.b1, hit.b2);
        let mut ng = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
        if ng.dot(r.d) > 0.0 {
            ng = -ng;
        }
        let local = cmlt::math::warp::square_to_cosine_hemisphere(rng.next_2d());
        diffuse.push(spawn_ray(
            p,
            err,
            ng,
            Frame::from_normal(ng).to_world(local),
        ));
        let (lp, le, ln) = (s.light)(&mut rng);
        // The main ray of each connection (the short tail ray is left out
        // of the throughput measurement).
        if let Some(seg) = spawn_rays_between(p, err, ng, lp, le, ln) {
            shadow.push(seg.main);
        }
    }
    // Shuffle the bounces: incoherent.
    for i in (1..diffuse.len()).rev() {
        let j = (rng.next_f32() * (i + 1) as f32) as usize;
        diffuse.swap(i, j.min(i));
    }
    let mtm = |k: usize, rng: &mut SampleStream| {
        let bundles = primary.len() / k;
        let mut v = Vec::with_capacity(bundles * k);
        for _ in 0..bundles {
            let c = Vec2::new(rng.next_f32() * w, rng.next_f32() * h);
            for _ in 0..k {
                let d = rng.next_2d() * 2.0 - Vec2::ONE;
                let raster = (c + d).clamp(Vec2::ZERO, Vec2::new(w, h) - 1e-3);
                v.push(s.camera.generate_ray(raster, Vec2::splat(0.5)));
            }
        }
        v
    };
    let mtm8 = mtm(8, &mut rng);
    let mtm16 = mtm(16, &mut rng);
    RaySets {
        sets: vec![
            ("primary", primary, false),
            ("diffuse", diffuse, false),
            ("mtm8", mtm8, false),
            ("mtm16", mtm16, false),
            ("shadow", shadow, true),
        ],
    }
}

/// The processor the figures were measured on ([`cpu_model_in`] of
/// `/proc/cpuinfo`), or `unknown`. Printed with every run because the
/// kernels' ratios to Embree differ between processors (an AVX-512 Xeon
/// and a Zen 4 EPYC gave different tables for the same tree).
fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|info| cpu_model_in(&info))
        .unwrap_or_else(|| "unknown".into())
}

/// The first processor's model name in a `/proc/cpuinfo` text, with its
/// x86 family and model numbers when given (they tell apart
/// microarchitectures sold under one name, such as "AMD EPYC").
fn cpu_model_in(info: &str) -> Option<String> {
    let field = |key: &str| {
        info.lines()
            .filter_map(|l| l.split_once(':'))
            .find(|(k, _)| k.trim() == key)
            .map(|(_, v)| v.trim().to_string())
    };
    let name = field("model name")?;
    Some(match (field("cpu family"), field("model")) {
        (Some(fam), Some(model)) => format!("{name} (family {fam}, model {model})"),
        _ => name,
    })
}

/// How a kernel traces a ray set.
#[derive(Clone, Copy)]
enum Mode {
    Single,
    Packet(usize),
    Stream,
}

/// Traces `rays` once (closest hits, or occlusion for shadow rays); returns
/// a checksum so the work cannot be optimised away.
// Never inlined: `bench/rays_instructions.sh` counts this function's
// instructions by name.
#[inline(never)]
fn trace<I: Intersector>(acc: &I, mode: Mode, packets: &Packets, range: (usize, usize)) -> u64 {
    let mut sum = 0u64;
    match mode {
        Mode::Single => {
            for r in &packets.rays[range.0..range.1] {
                if packets.occlusion {
                    sum += acc.occluded(r) as u64;
                } else if let Some(h) = acc.intersect(r) {
                    sum += h.prim as u64;
                }
            }
        }
        Mode::Stream => {
            let rays = &packets.rays[range.0..range.1];
            if packets.occlusion {
                let mut out = [false; 256];
                for c in rays.chunks(256) {
                    acc.occluded_stream(c, &mut out);
                    sum += out[..c.len()].iter().map(|&o| o as u64).sum::<u64>();
                }
            } else {
                let mut out = [None; 256];
                for c in rays.chunks(256) {
                    acc.intersect_stream(c, &mut out);
                    sum += out[..c.len()]
                        .iter()
                        .flatten()
                        .map(|h| h.prim as u64)
                        .sum::<u64>();
                }
            }
        }
        Mode::Packet(4) => sum += trace_packets(acc, &packets.p4, packets.occlusion, range, 4),
        Mode::Packet(8) => sum += trace_packets(acc, &packets.p8, packets.occlusion, range, 8),
        Mode::Packet(_) => sum += trace_packets(acc, &packets.p16, packets.occlusion, range, 16),
    }
    sum
}

fn trace_packets<I: Intersector, const N: usize>(
    acc: &I,
    ps: &[(RayPacket<N>, LaneMask)],
    occlusion: bool,
    range: (usize, usize),
    n: usize,
) -> u64 {
    let mut sum = 0u64;
    let mut hits = HitPacket::<N>::default();
    for (p, m) in &ps[range.0 / n..range.1.div_ceil(n).min(ps.len())] {
        if occlusion {
            sum += acc.occluded_packet(p, *m).count() as u64;
        } else {
            acc.intersect_packet(p, *m, &mut hits);
            sum += hits.prim.iter().map(|&x| x as u64).sum::<u64>();
        }
    }
    sum
}

/// A ray set pre-packed for each packet width.
struct Packets {
    rays: Vec<Ray>,
    occlusion: bool,
    p4: Vec<(RayPacket<4>, LaneMask)>,
    p8: Vec<(RayPacket<8>, LaneMask)>,
    p16: Vec<(RayPacket<16>, LaneMask)>,
}

fn pack<const N: usize>(rays: &[Ray]) -> Vec<(RayPacket<N>, LaneMask)> {
    rays.chunks(N)
        .map(|c| {
            let mut p = RayPacket::<N>::default();
            for (i, r) in c.iter().enumerate() {
                p.set(i, r);
            }
            (p, LaneMask::first(c.len()))
        })
        .collect()
}

/// Rays per second of `acc` on the set with `threads` threads, each
/// tracing its share (whole 16-ray blocks) repeatedly until `time` is up.
fn measure<I: Intersector + Sync>(
    acc: &I,
    mode: Mode,
    packets: &Packets,
    threads: usize,
    time: Duration,
    clock: Clock,
) -> f64 {
    let n = packets.rays.len();
    let blocks = n.div_ceil(16);
    let start = Instant::now();
    // Per thread: rays traced and the thread's time on `clock`.
    let per_thread: Vec<(u64, Duration)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let range = (
                    (blocks * t / threads * 16).min(n),
                    (blocks * (t + 1) / threads * 16).min(n),
                );
                s.spawn(move || {
                    let mut rays = 0u64;
                    let begin = Stopwatch::start(clock);
                    loop {
                        std::hint::black_box(trace(acc, mode, packets, range));
                        rays += (range.1 - range.0) as u64;
                        let spent = begin.elapsed();
                        if spent >= time {
                            break (rays, spent);
                        }
                    }
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("bench thread"))
            .collect()
    });
    match clock {
        Clock::Wall => {
            let traced: u64 = per_thread.iter().map(|&(r, _)| r).sum();
            traced as f64 / start.elapsed().as_secs_f64()
        }
        // Each thread's rate on its own CPU time, summed.
        Clock::Cpu => per_thread
            .iter()
            .map(|&(r, t)| r as f64 / t.as_secs_f64().max(1e-9))
            .sum(),
    }
}

/// Runs the benchmark, printing a table to `out`; returns the measurements.
pub fn run(opts: &Options, out: &mut dyn Write) -> Result<Vec<Measurement>, String> {
    let mut rows = Vec::new();
    let time = Duration::from_secs_f64(opts.time.max(0.0));
    let io = |e: std::io::Error| e.to_string();
    writeln!(out, "cpu: {}", cpu_model()).map_err(io)?;
    for name in &opts.scenes {
        let scene = load(name, opts)?;
        let t0 = Instant::now();
        let bvh = Bvh::build(&scene.tris);
        let build_ours = t0.elapsed();
        #[cfg(feature = "embree")]
        let embree = {
            let t0 = Instant::now();
            let e =
                cmlt::accel::embree::EmbreeScene::new(&scene.tris).map_err(|e| e.to_string())?;
            writeln!(out, "embree build {:.3} s", t0.elapsed().as_secs_f64()).map_err(io)?;
            e
        };
        writeln!(
            out,
            "{}: {} triangles, BVH build {:.3} s, {:.1} MiB, best kernel {}",
            scene.name,
            scene.tris.len(),
            build_ours.as_secs_f64(),
            bvh.view().size_bytes() as f64 / (1024.0 * 1024.0),
            bvh.kernel().name()
        )
        .map_err(io)?;
        let sets = ray_sets(&scene, &bvh, opts.rays);
        let sizes: Vec<String> = sets
            .sets
            .iter()
            .map(|(set, rays, _)| format!("{set} {}", rays.len()))
            .collect();
        writeln!(out, "{}: rays per set: {}", scene.name, sizes.join(", ")).map_err(io)?;
        for (set, rays, occlusion) in sets.sets {
            if !opts.wants_set(set) {
                continue;
            }
            let packets = Packets {
                p4: pack(&rays),
                p8: pack(&rays),
                p16: pack(&rays),
                rays,
                occlusion,
            };
            for &threads in &opts.threads {
                // Every kernel of the cell, as (name, one measurement).
                type Job<'a> = (String, Box<dyn Fn() -> f64 + 'a>);
                let mut jobs: Vec<Job<'_>> = Vec::new();
                let packets = &packets;
                let clock = opts.clock;
                for k in Kernel::ALL {
                    let name = format!("ours-{}", k.name());
                    let Some(view) = bvh.view().with_kernel(k) else {
                        continue;
                    };
                    if opts.wants_kernel(&name) {
                        jobs.push((
                            name,
                            Box::new(move || {
                                measure(&view, Mode::Single, packets, threads, time, clock)
                            }),
                        ));
                    }
                }
                let view = bvh.view();
                if opts.wants_kernel("ours-stream") {
                    jobs.push((
                        "ours-stream".to_string(),
                        Box::new(move || {
                            measure(&view, Mode::Stream, packets, threads, time, clock)
                        }),
                    ));
                }
                for n in [4, 8, 16] {
                    let name = format!("ours-packet{n}");
                    if opts.wants_kernel(&name) {
                        jobs.push((
                            name,
                            Box::new(move || {
                                measure(&view, Mode::Packet(n), packets, threads, time, clock)
                            }),
                        ));
                    }
                }
                #[cfg(feature = "embree")]
                if opts.wants_kernel("embree-stream") {
                    let embree = &embree;
                    jobs.push((
                        "embree-stream".to_string(),
                        Box::new(move || {
                            measure(embree, Mode::Stream, packets, threads, time, clock)
                        }),
                    ));
                }
                #[cfg(feature = "embree")]
                for n in [1, 4, 8, 16] {
                    let name = format!("embree-{n}");
                    if opts.wants_kernel(&name) {
                        let mode = if n == 1 {
                            Mode::Single
                        } else {
                            Mode::Packet(n)
                        };
                        let embree = &embree;
                        jobs.push((
                            name,
                            Box::new(move || measure(embree, mode, packets, threads, time, clock)),
                        ));
                    }
                }
                let mut best = vec![0.0f64; jobs.len()];
                for _ in 0..opts.rounds.max(1) {
                    for (b, (_, job)) in best.iter_mut().zip(&jobs) {
                        *b = b.max(job());
                    }
                }
                let mut line = Vec::new();
                for ((kernel, _), mrays) in jobs.iter().zip(best) {
                    let mrays = mrays * 1e-6;
                    line.push((kernel.clone(), mrays));
                    rows.push(Measurement {
                        scene: scene.name.clone(),
                        ray_set: set.to_string(),
                        kernel: kernel.clone(),
                        threads,
                        mrays_per_s: mrays,
                    });
                }
                print_line(out, &scene.name, set, threads, &line).map_err(io)?;
            }
        }
    }
    Ok(rows)
}

/// One table line: Mrays/s per kernel, then the best ours / best Embree.
fn print_line(
    out: &mut dyn Write,
    scene: &str,
    set: &str,
    threads: usize,
    line: &[(String, f64)],
) -> std::io::Result<()> {
    write!(out, "{scene:>12} {set:>8} {threads}T")?;
    for (k, m) in line {
        write!(out, "  {k} {m:.2}")?;
    }
    let best = |prefix: &str| {
        line.iter()
            .filter(|(k, _)| k.starts_with(prefix))
            .map(|(_, m)| *m)
            .fold(0.0f64, f64::max)
    };
    let (ours, embree) = (best("ours"), best("embree"));
    if embree > 0.0 {
        write!(out, "  | best ours/embree {:.2}", ours / embree)?;
    }
    writeln!(out)
}

#[cfg(test)]
mod tests {
    use super::cpu_model_in;

    #[test]
    fn cpu_model_reads_the_first_processor() {
        let amd = "processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 25\nmodel\t\t: 17\n\
                   model name\t: AMD EPYC\nstepping\t: 1\n\nprocessor\t: 1\nmodel name\t: other\n";
        assert_eq!(
            cpu_model_in(amd).as_deref(),
            Some("AMD EPYC (family 25, model 17)")
        );
        // No x86 family and model (as on other architectures): the name.
        assert_eq!(
            cpu_model_in("processor : 0\nmodel name : Some Core\n").as_deref(),
            Some("Some Core")
        );
        assert_eq!(cpu_model_in("processor : 0\nBogoMIPS : 50.00\n"), None);
    }
}

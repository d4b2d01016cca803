//! Multi-threaded rendering on top of the core's pass renderer.
//!
//! Threads are the host's business, not the core's: this module spawns
//! `threads` scoped std threads; thread `i` renders passes `i, i + T, …`
//! into its own film and the films are merged in thread order. The image is
//! therefore bit-identical for a fixed seed, sample count and thread count.
//! [`render_mlt`] does the same for Metropolis light transport: one shared
//! bootstrap, then per-thread chains and films merged in thread order.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cmlt::accel::Intersector;
use cmlt::film::Film;
use cmlt::integrator::{Method, Settings, Stats, Tracer, Worker, render_pass};
use cmlt::mlt::{Bootstrap, MltSettings, MltStats, MltWorker, bootstrap, image_scale, rounds_for};
use cmlt::scene::{Analysis, Scene};

/// When to stop rendering.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// A fixed number of samples per pixel (deterministic).
    Spp(u64),
    /// Wall-clock seconds; whole passes only, so at least one pass is done.
    Time(f64),
}

/// What a render produced and what it cost.
pub struct RenderOutput {
    /// Merged film of all threads.
    pub film: Film,
    /// Merged counters of all threads.
    pub stats: Stats,
    /// Wall-clock time of the rendering proper.
    pub wall: Duration,
}

impl RenderOutput {
    /// Camera samples per second.
    pub fn samples_per_sec(&self) -> f64 {
        self.stats.samples as f64 / self.wall.as_secs_f64().max(1e-9)
    }

    /// Millions of rays (closest-hit and occlusion) per second.
    pub fn mrays_per_sec(&self) -> f64 {
        self.stats.total_rays() as f64 / self.wall.as_secs_f64().max(1e-9) * 1e-6
    }
}

/// Bytes of memory available to a new allocation without swapping, where
/// the system says (Linux's `/proc/meminfo`).
fn available_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The instant `seconds` after `start`, or an error for a budget that is
/// not finite and non-negative or does not fit the clock.
fn deadline_after(start: Instant, seconds: f64) -> Result<Instant, String> {
    Duration::try_from_secs_f64(seconds)
        .ok()
        .and_then(|d| start.checked_add(d))
        .ok_or_else(|| format!("invalid time budget: {seconds} s"))
}

/// `count` black films of `w × h`, allocated before any thread starts so
/// that a resolution the heap cannot hold is a clear error, not an abort
/// half-way through a render.
/// The films are also checked against the memory the machine has
/// available (Linux: `MemAvailable`), because an over-committing kernel
/// grants an allocation it cannot back and kills the process later.
fn films(w: u32, h: u32, count: usize) -> Result<Vec<Film>, String> {
    check_film_memory(w, h, count)?;
    let mut out = Vec::new();
    out.try_reserve_exact(count)
        .map_err(|_| format!("out of memory: {count} films"))?;
    for _ in 0..count {
        out.push(Film::try_new(w, h).map_err(|e| format!("{w}x{h} image: {e}"))?);
    }
    Ok(out)
}

/// Refuses `count` films of `w × h` that need more memory than the machine
/// has available (see [`films`]); other drivers (the frame loop) call it
/// before they allocate theirs.
pub fn check_film_memory(w: u32, h: u32, count: usize) -> Result<(), String> {
    let bytes = (w as u64 * h as u64)
        .saturating_mul(Film::BYTES_PER_PIXEL)
        .saturating_mul(count as u64);
    if let Some(available) = available_memory()
        && bytes > available
    {
        return Err(format!(
            "out of memory: a {w}x{h} image needs {:.1} GB for {count} films (one per thread and the merged one), the machine has {:.1} GB available",
            bytes as f64 * 1e-9,
            available as f64 * 1e-9
        ));
    }
    Ok(())
}

/// Renders `scene` with `method` under `budget` on `threads` threads,
/// specialised to `analysis` (the scene's, or [`Analysis::all`] for
/// `--all-effects`; [`Settings::specialised`] and
/// [`Tracer::with_analysis`]). `on_pass` is called after every finished
/// pass (progress reporting).
#[allow(clippy::too_many_arguments)]
pub fn render<I: Intersector + Sync>(
    scene: &Scene,
    accel: &I,
    settings: &Settings,
    analysis: &Analysis,
    method: Method,
    budget: Budget,
    threads: usize,
    seed: u64,
    on_pass: &(dyn Fn() + Sync),
) -> Result<RenderOutput, String> {
    let threads = threads.max(1);
    // One film per thread and the merged one.
    let mut films = films(scene.camera.width(), scene.camera.height(), threads + 1)?;
    let mut merged = films.pop().expect("threads + 1 films");
    let settings = &settings.specialised(analysis);
    let start = Instant::now();
    let deadline = match budget {
        Budget::Time(s) => Some(deadline_after(start, s)?),
        Budget::Spp(_) => None,
    };
    let stop = AtomicBool::new(false);
    let results: Vec<(Film, Stats)> = std::thread::scope(|sc| {
        let handles: Vec<_> = films
            .into_iter()
            .enumerate()
            .map(|(i, mut film)| {
                let stop = &stop;
                sc.spawn(move || {
                    let mut tracer = Tracer::new(scene, accel).with_analysis(*analysis);
                    let mut worker = Worker::new();
                    let mut pass = i as u64;
                    loop {
                        match budget {
                            Budget::Spp(n) if pass >= n => break,
                            // Time budgets always finish one pass per thread
                            // so the image is never empty.
                            Budget::Time(_)
                                if pass >= threads as u64
                                    && (stop.load(Ordering::Relaxed)
                                        || deadline.is_some_and(|d| Instant::now() >= d)) =>
                            {
                                stop.store(true, Ordering::Relaxed);
                                break;
                            }
                            _ => {}
                        }
                        render_pass(
                            &mut tracer,
                            settings,
                            method,
                            &mut worker,
                            seed,
                            pass,
                            &mut film,
                        );
                        on_pass();
                        pass += threads as u64;
                    }
                    (film, tracer.stats)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("render thread panicked"))
            .collect()
    });
    let wall = start.elapsed();
    let mut stats = Stats::default();
    for (f, s) in &results {
        merged.merge(f);
        stats.merge(s);
    }
    Ok(RenderOutput {
        film: merged,
        stats,
        wall,
    })
}

/// The work counters per effect, as `cmlt render` prints them: BSDF
/// samples and evaluations by lobe kind, lens samples, and (MLT) the
/// level-2 perturbation steps by kind.
pub fn work_line(stats: &Stats, mlt: Option<&MltStats>) -> String {
    let mut line = String::from("work:");
    for lobe in cmlt::bsdf::Lobe::ALL {
        line += &format!(
            " {} {}/{}",
            lobe.name(),
            stats.bsdf_samples.get(lobe),
            stats.bsdf_evals.get(lobe)
        );
    }
    line += " (BSDF samples/evaluations); lens samples ";
    line += &stats.lens_samples.to_string();
    if let Some(m) = mlt {
        line += &format!(
            "; perturbation steps: lens {}, caustic {}",
            m.lens_steps, m.caustic_steps
        );
    }
    line
}

/// When an MLT render stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MltBudget {
    /// Mutations per pixel in total over all threads, rounded up to whole
    /// rounds of all chains (deterministic).
    MutationsPerPixel(u64),
    /// Wall-clock seconds including the bootstrap; every thread runs at
    /// least one batch of mutations.
    Time(f64),
}

/// What an MLT render produced and what it cost.
pub struct MltOutput {
    /// Merged film of all threads: unit-luminance splats, resolve with
    /// [`MltOutput::scale`].
    pub film: Film,
    /// b · pixels / records ([`cmlt::mlt::image_scale`]).
    pub scale: f64,
    /// The bootstrap (b and its split over depths).
    pub bootstrap: Bootstrap,
    /// Merged ray counters (bootstrap and chains).
    pub stats: Stats,
    /// Merged chain counters.
    pub mlt: MltStats,
    /// Wall-clock time of the bootstrap.
    pub bootstrap_wall: Duration,
    /// Wall-clock time of everything (bootstrap included).
    pub wall: Duration,
}

impl MltOutput {
    /// The image.
    pub fn image(&self) -> Vec<cmlt::math::Rgb> {
        self.film.resolve_scaled(self.scale)
    }

    /// Mutations per second of the chain phase.
    pub fn mutations_per_sec(&self) -> f64 {
        let t = (self.wall - self.bootstrap_wall).as_secs_f64().max(1e-9);
        self.mlt.mutations as f64 / t
    }

    /// Millions of rays (closest-hit and occlusion) per second, overall.
    pub fn mrays_per_sec(&self) -> f64 {
        self.stats.total_rays() as f64 / self.wall.as_secs_f64().max(1e-9) * 1e-6
    }
}

/// Renders `scene` with level-1 MLT on `threads` threads.
///
/// The bootstrap is computed once and shared: its seed samples are split
/// into contiguous index ranges, its normalisation passes dealt
/// round-robin, and both are combined in index order, so b and the chains'
/// starting distribution do not depend on the thread count. Then thread
/// `i` runs `mlt.n_chains` chains (global chains i, i + T, …) seeded by
/// `(seed, i)` into its own film, in whole rounds: a mutation budget
/// becomes the same number of rounds on every thread (rounded up, see
/// [`rounds_for`]); a time budget runs batches of rounds until the deadline.
/// Films are merged in thread order: the image is bit-identical for a fixed
/// seed, mutation budget and thread count. `on_progress(n)` reports `n`
/// more mutations done. `analysis` specialises the render as in
/// [`render`].
#[allow(clippy::too_many_arguments)]
pub fn render_mlt<I: Intersector + Sync>(
    scene: &Scene,
    accel: &I,
    settings: &Settings,
    analysis: &Analysis,
    mlt: &MltSettings,
    budget: MltBudget,
    threads: usize,
    seed: u64,
    on_progress: &(dyn Fn(u64) + Sync),
) -> Result<MltOutput, String> {
    let threads = threads.max(1);
    let settings = &settings.specialised(analysis);
    let start = Instant::now();
    let deadline = match budget {
        MltBudget::Time(s) => Some(deadline_after(start, s)?),
        MltBudget::MutationsPerPixel(_) => None,
    };
    let (w, h) = (scene.camera.width(), scene.camera.height());
    let pixels = w as u64 * h as u64;
    // One film per thread and the merged one, before the bootstrap's work.
    let mut films = films(w, h, threads + 1)?;
    let mut merged = films.pop().expect("threads + 1 films");

    // Bootstrap: seed samples split into contiguous index ranges,
    // normalisation passes dealt round-robin; both combined in index order.
    let n = Bootstrap::seed_count(settings, mlt);
    let depths = cmlt::mlt::path_depth(settings, mlt) as usize;
    let chunk = n.div_ceil(threads as u64);
    type Part = (Vec<f32>, Vec<(u64, Vec<f64>)>, Stats);
    let parts: Vec<Part> = std::thread::scope(|sc| {
        let handles: Vec<_> = (0..threads as u64)
            .map(|i| {
                sc.spawn(move || {
                    let mut tracer = Tracer::new(scene, accel).with_analysis(*analysis);
                    let mut ys = Vec::new();
                    let range = (i * chunk).min(n)..((i + 1) * chunk).min(n);
                    bootstrap::evaluate_seeds(&mut tracer, settings, mlt, seed, range, &mut ys);
                    let mut ws = cmlt::integrator::bdpt::Workspace::new();
                    let mut passes = Vec::new();
                    for pass in (i..mlt.b_passes as u64).step_by(threads) {
                        let mut sums = vec![0.0f64; depths];
                        bootstrap::evaluate_pass(
                            &mut tracer,
                            settings,
                            mlt,
                            &mut ws,
                            seed,
                            pass,
                            &mut sums,
                        );
                        passes.push((pass, sums));
                    }
                    (ys, passes, tracer.stats)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("bootstrap thread panicked"))
            .collect()
    });
    let mut stats = Stats::default();
    let mut values = Vec::with_capacity(n as usize);
    let mut passes: Vec<&(u64, Vec<f64>)> = Vec::new();
    for (ys, ps, s) in &parts {
        values.extend_from_slice(ys);
        passes.extend(ps);
        stats.merge(s);
    }
    passes.sort_by_key(|p| p.0);
    let mut sums = vec![0.0f64; depths];
    for (_, p) in passes {
        for (a, b) in sums.iter_mut().zip(p) {
            *a += b;
        }
    }
    let boot = Bootstrap::from_parts(settings, mlt, seed, &values, &sums, pixels);
    drop(values);
    let bootstrap_wall = start.elapsed();

    let rounds = match budget {
        MltBudget::MutationsPerPixel(0) => 0,
        MltBudget::MutationsPerPixel(m) => {
            rounds_for(m, pixels, threads as u64, mlt.n_chains as u64)
        }
        MltBudget::Time(_) => 0,
    };
    let stop = AtomicBool::new(false);
    let results: Vec<(Film, Stats, MltStats)> = std::thread::scope(|sc| {
        let handles: Vec<_> = films
            .into_iter()
            .zip(0..threads as u64)
            .map(|(mut film, i)| {
                let (stop, boot) = (&stop, &boot);
                sc.spawn(move || {
                    let mut tracer = Tracer::new(scene, accel).with_analysis(*analysis);
                    let mut worker =
                        MltWorker::new(&mut tracer, settings, mlt, boot, seed, i, threads as u64);
                    // Batches of whole rounds, small enough for progress and
                    // deadline checks, large enough to make both negligible.
                    let batch = (4096 / worker.chain_count().max(1) as u64).max(1);
                    match deadline {
                        None => {
                            let mut left = rounds;
                            while left > 0 {
                                let k = left.min(batch);
                                let done = worker.run(&mut tracer, settings, &mut film, k);
                                if done == 0 {
                                    break;
                                }
                                on_progress(done);
                                left -= k;
                            }
                        }
                        Some(d) => loop {
                            let done = worker.run(&mut tracer, settings, &mut film, batch);
                            if done == 0 {
                                break;
                            }
                            on_progress(done);
                            if stop.load(Ordering::Relaxed) || Instant::now() >= d {
                                stop.store(true, Ordering::Relaxed);
                                break;
                            }
                        },
                    }
                    (film, tracer.stats, *worker.stats())
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("render thread panicked"))
            .collect()
    });
    let mut mstats = MltStats::default();
    for (f, s, m) in &results {
        merged.merge(f);
        stats.merge(s);
        mstats.merge(m);
    }
    Ok(MltOutput {
        scale: image_scale(boot.b(), pixels, mstats.records),
        film: merged,
        bootstrap: boot,
        stats,
        mlt: mstats,
        bootstrap_wall,
        wall: start.elapsed(),
    })
}

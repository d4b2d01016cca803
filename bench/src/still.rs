//! `cmlt-bench still`: a still camera's frames kept by the accumulation
//! ([`Accumulation::Keep`], every frame normalised by its own b) against
//! one offline render — of the same total mutations (the kept frames'
//! estimate is unbiased, so only the frames' restarts and set-ups may
//! cost error) and of the same total wall time (their set-up per frame
//! included). A game wants the kept frames within 1.2× the offline
//! render's relMSE at the same time. Without kept chains every frame runs
//! its whole set-up (its own bootstrap and b), as `cmlt render --frames`
//! does; with them the frames after the first give their set-up no time
//! (the chains go on with the first frame's b), as a game's host that
//! slices its set-up (`cmlt-bench frames`) mostly does.
//!
//! Each kept frame's mutations are shared between the workers as they go
//! (every worker renders pieces while the frame's total is not reached),
//! as a game's workers all run to the frame's deadline: a fixed share per
//! worker ([`Shares::Fixed`], each worker its [`Renderer::steps_for`])
//! leaves the faster one idle at every frame's end, waiting for the
//! other.
//!
//! Where the kept frames' time goes ([`Breakdown`]) is printed beside the
//! offline render's: the first frame's set-up against the offline
//! bootstrap, the later set-ups, the renders with the time the workers
//! sat idle waiting for each other at the frames' ends and the time the
//! scheduler kept them waiting to run (`/proc/thread-self/schedstat`, the
//! machine's load), and the mutations per second of the rest. Because
//! the first frame's set-up is the same bootstrap as the offline render's
//! (same seed, same work) but its duration swings with the load by tens
//! of per cent, a second equal-time comparison gives the offline render
//! the kept frames' time after their first set-up, counted from the end
//! of its own.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use cmlt::math::Rgb;
use cmlt::renderer::{
    Accumulation, Budget, Estimator, RenderWorker, Renderer, RendererConfig, Temporal,
};
use cmlt_cli::image_io::Image;
use cmlt_cli::metrics::rel_mse;
use cmlt_cli::render::{prepare, render, render_workers};

use crate::study::{Study, process_cpu_s};

/// One seed's figures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Still {
    /// relMSE of the last kept frame.
    pub kept: f64,
    /// Wall seconds of all the kept frames (set-up, render, resolve).
    pub kept_s: f64,
    /// relMSE of one render of the frames' total mutations per pixel.
    pub same_mutations: f64,
    /// relMSE of one render of the frames' total wall time.
    pub same_time: f64,
    /// relMSE of one render given, after its own set-up, the kept frames'
    /// time after their first set-up.
    pub same_time_after_setup: f64,
    /// Where the kept frames' time went, and the offline render of the
    /// same time's.
    pub breakdown: Breakdown,
}

/// The kept frames' wall time by part, and the offline render of the same
/// time's, in seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Breakdown {
    /// The first frame's set-up (its whole bootstrap).
    pub first_setup_s: f64,
    /// The later frames' set-ups together (begin, the workers' pieces,
    /// finish).
    pub setup_s: f64,
    /// The frames' renders together (worker threads started and joined
    /// once per frame).
    pub render_s: f64,
    /// Of `render_s`, the time a worker sat idle at the frames' ends
    /// waiting for the other workers (mean over workers).
    pub join_idle_s: f64,
    /// Of `render_s`, the time a worker's thread waited to be started
    /// (from the frame's start to its first instruction; mean over
    /// workers).
    pub start_s: f64,
    /// The time the workers' threads spent runnable but not running
    /// during the renders (mean over workers; the machine's load), NaN
    /// where `/proc/thread-self/schedstat` is missing.
    pub run_queue_s: f64,
    /// The last frame's resolve (the image scored).
    pub resolve_s: f64,
    /// Mutations (or samples) per pixel of all the kept frames.
    pub kept_per_pixel: f64,
    /// The offline render of the same time: its bootstrap.
    pub offline_setup_s: f64,
    /// The offline render of the same time: its chains (or passes).
    pub offline_render_s: f64,
    /// Mutations (or samples) per pixel of the offline render of the same
    /// time.
    pub offline_per_pixel: f64,
    /// Process CPU seconds per mutation (or sample) per pixel of the kept
    /// frames after the first set-up (later set-ups, renders, resolve)
    /// over the offline render's after its set-up: the work a kept frame
    /// adds, whatever the machine's load (1 = none).
    pub cpu_ratio: f64,
}

impl Breakdown {
    /// Kept frames' mutations per second of render over the offline
    /// render's (1 = the frames' renders lose nothing to their joins).
    pub fn render_rate_ratio(&self) -> f64 {
        (self.kept_per_pixel / self.render_s) / (self.offline_per_pixel / self.offline_render_s)
    }
}

/// How a kept frame's mutations are split between its workers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shares {
    /// Each worker renders pieces while the frame's total is not reached:
    /// they all end within a piece of each other.
    Shared,
    /// Each worker renders its own [`Renderer::steps_for`] (what
    /// `cmlt render --frames` does): the faster waits for the slower.
    Fixed,
}

/// Nanoseconds the calling thread has run and has waited to run
/// (`/proc/thread-self/schedstat`, Linux).
fn schedstat() -> Option<(u64, u64)> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let mut f = s.split_whitespace().map(|v| v.parse::<u64>().ok());
    Some((f.next()??, f.next()??))
}

/// What one worker's render of a frame cost: wall seconds from its
/// thread's start to its end, seconds until its thread started, seconds
/// waiting to run (NaN unknown).
#[derive(Clone, Copy, Default)]
struct WorkerTime {
    busy_s: f64,
    start_s: f64,
    run_queue_s: f64,
}

/// Renders one kept frame of `units` units (mutations or samples over
/// all workers) on one scoped thread per worker, split by `shares`;
/// returns each worker's times.
fn render_frame(
    r: &Renderer,
    workers: &mut [RenderWorker],
    study: &Study,
    units: u64,
    per_pixel: u64,
    shares: Shares,
) -> Result<Vec<WorkerTime>, String> {
    let (scene, accel) = (&study.loaded.scene, study.accel());
    let rendered = AtomicU64::new(0);
    let t0 = Instant::now();
    std::thread::scope(|s| {
        let handles: Vec<_> = workers
            .iter_mut()
            .map(|w| {
                let rendered = &rendered;
                s.spawn(move || {
                    let start = Instant::now();
                    let q0 = schedstat();
                    match shares {
                        Shares::Fixed => {
                            let steps = r.steps_for(w.index(), per_pixel);
                            r.render_steps(w, scene, accel, steps)?;
                        }
                        Shares::Shared => {
                            // Asked before every piece after the first: each
                            // piece's units go into the frame's count, and
                            // the worker stops once the count is reached.
                            let mut counted = 0;
                            let done = r.render_while(w, scene, accel, u64::MAX, &mut |done| {
                                let sum = rendered.fetch_add(done - counted, Ordering::Relaxed)
                                    + (done - counted);
                                counted = done;
                                sum < units
                            })?;
                            rendered.fetch_add(done - counted, Ordering::Relaxed);
                        }
                    }
                    let q1 = schedstat();
                    let run_queue_s = match (q0, q1) {
                        (Some(a), Some(b)) => (b.1 - a.1) as f64 * 1e-9,
                        _ => f64::NAN,
                    };
                    Ok(WorkerTime {
                        busy_s: start.elapsed().as_secs_f64(),
                        start_s: (start - t0).as_secs_f64(),
                        run_queue_s,
                    })
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("render thread panicked"))
            .collect::<Result<Vec<_>, cmlt::renderer::RenderError>>()
    })
    .map_err(|e| e.to_string())
}

impl Still {
    /// The kept frames' relMSE over the offline render's of the same
    /// mutations.
    pub fn ratio_mutations(&self) -> f64 {
        self.kept / self.same_mutations
    }

    /// The kept frames' relMSE over the offline render's of the same time.
    pub fn ratio_time(&self) -> f64 {
        self.kept / self.same_time
    }

    /// The kept frames' relMSE over the offline render's given their time
    /// after the first set-up.
    pub fn ratio_time_after_setup(&self) -> f64 {
        self.kept / self.same_time_after_setup
    }
}

/// Renders `frames` frames of `study`'s camera with `estimator`, `mpp`
/// mutations (or samples) per pixel each split between the workers by
/// `shares`, kept by the accumulation (`keep_chains`: the chains too), on
/// `threads` workers from `seed`, and the three offline renders.
pub fn run(
    study: &Study,
    estimator: Estimator,
    (frames, mpp): (usize, u64),
    threads: u32,
    (keep_chains, shares): (bool, Shares),
    seed: u64,
) -> Result<Still, String> {
    let scene = &study.loaded.scene;
    let cfg = RendererConfig {
        estimator,
        settings: study.loaded.settings,
        seed,
        workers: threads,
        temporal: Temporal {
            keep_chains: keep_chains && estimator.is_metropolis(),
            ..Temporal::default()
        },
        ..RendererConfig::default()
    };
    let accel = study.accel();
    let mut bd = Breakdown::default();
    let t0 = Instant::now();
    let err = |e: cmlt::renderer::RenderError| e.to_string();
    let mut r = Renderer::new(cfg, scene.camera).map_err(err)?;
    r.set_accumulation(Accumulation::Keep).map_err(err)?;
    let mut workers = (0..threads)
        .map(|i| RenderWorker::new(&r, i))
        .collect::<Result<Vec<_>, _>>()
        .map_err(err)?;
    let mut cpu_after_setup = 0.0;
    for f in 0..frames {
        let s0 = Instant::now();
        if f > 0 {
            r.set_camera(scene.camera).map_err(err)?;
        }
        if f == 0 || !cfg.temporal.keep_chains {
            prepare(&mut r, &mut workers, scene, accel)?;
        } else if r.begin_prepare(scene) {
            // No set-up time: the kept chains go on with the b carried.
            for w in workers.iter_mut() {
                r.prepare_worker_while(w, scene, accel, &mut |_| false)
                    .map_err(err)?;
            }
            r.finish_prepare(workers.iter()).map_err(err)?;
        }
        let s1 = Instant::now();
        if f == 0 {
            cpu_after_setup = process_cpu_s();
        }
        let units = mpp * r.camera().pixel_count();
        let times = render_frame(&r, &mut workers, study, units, mpp, shares)?;
        let wall = s1.elapsed().as_secs_f64();
        let n = times.len() as f64;
        for t in &times {
            bd.join_idle_s += (wall - t.start_s - t.busy_s) / n;
            bd.start_s += t.start_s / n;
            bd.run_queue_s += t.run_queue_s / n;
        }
        let setup = (s1 - s0).as_secs_f64();
        if f == 0 {
            bd.first_setup_s = setup;
        } else {
            bd.setup_s += setup;
        }
        bd.render_s += s1.elapsed().as_secs_f64();
        // Each frame's counters start from zero (PT and BDPT keep their
        // passes' count with their films).
        let refs: Vec<&RenderWorker> = workers.iter().collect();
        let stats = r.stats(&refs);
        bd.kept_per_pixel = if estimator.is_metropolis() {
            bd.kept_per_pixel + stats.mlt.mutations as f64 / r.camera().pixel_count() as f64
        } else {
            stats.passes as f64
        };
    }
    let (w, h) = study.resolution();
    let mut pixels = vec![Rgb::ZERO; w * h];
    let refs: Vec<&RenderWorker> = workers.iter().collect();
    let r0 = Instant::now();
    r.resolve(&refs, |i, c| pixels[i] = c).map_err(err)?;
    bd.resolve_s = r0.elapsed().as_secs_f64();
    let kept_cpu_s = process_cpu_s() - cpu_after_setup;
    let kept_s = t0.elapsed().as_secs_f64();
    let last = Image {
        width: w,
        height: h,
        pixels,
    };
    let kept = rel_mse(&last, &study.reference);
    let total = Budget::PerPixel(frames as u64 * mpp);
    let same_mutations = study.measure(estimator, total, threads as usize, seed)?;
    let offline = RendererConfig {
        temporal: Temporal::default(),
        ..cfg
    };
    let same_time = render(scene, accel, offline, Budget::Seconds(kept_s), &|_| {})?;
    bd.offline_setup_s = same_time.bootstrap_wall.as_secs_f64();
    bd.offline_render_s = (same_time.wall - same_time.bootstrap_wall).as_secs_f64();
    bd.offline_per_pixel = same_time.per_pixel();
    let (after_setup, offline_cpu_s, offline_per_pixel) =
        offline_after_setup(study, offline, kept_s - bd.first_setup_s)?;
    bd.cpu_ratio = (kept_cpu_s / bd.kept_per_pixel) / (offline_cpu_s / offline_per_pixel);
    Ok(Still {
        kept,
        kept_s,
        same_mutations: same_mutations.rel_mse,
        same_time: rel_mse(&same_time.image, &study.reference),
        same_time_after_setup: rel_mse(&after_setup, &study.reference),
        breakdown: bd,
    })
}

/// One offline render of `cfg` given `seconds` after its own set-up: its
/// image, the process CPU seconds after the set-up and its mutations (or
/// samples) per pixel.
fn offline_after_setup(
    study: &Study,
    cfg: RendererConfig,
    seconds: f64,
) -> Result<(Image, f64, f64), String> {
    let (scene, accel) = (&study.loaded.scene, study.accel());
    let err = |e: cmlt::renderer::RenderError| e.to_string();
    let mut r = Renderer::new(cfg, scene.camera).map_err(err)?;
    let mut workers = (0..cfg.workers)
        .map(|i| RenderWorker::new(&r, i))
        .collect::<Result<Vec<_>, _>>()
        .map_err(err)?;
    prepare(&mut r, &mut workers, scene, accel)?;
    let cpu0 = process_cpu_s();
    let deadline = Instant::now() + std::time::Duration::from_secs_f64(seconds.max(0.0));
    render_workers(
        &r,
        &mut workers,
        scene,
        accel,
        Budget::Seconds(seconds),
        Some(deadline),
        &|_| {},
    )?;
    let (w, h) = study.resolution();
    let mut pixels = vec![Rgb::ZERO; w * h];
    let refs: Vec<&RenderWorker> = workers.iter().collect();
    r.resolve(&refs, |i, c| pixels[i] = c).map_err(err)?;
    let cpu_s = process_cpu_s() - cpu0;
    let stats = r.stats(&refs);
    let per_pixel = if cfg.estimator.is_metropolis() {
        stats.mlt.mutations as f64 / r.camera().pixel_count() as f64
    } else {
        stats.passes as f64
    };
    let image = Image {
        width: w,
        height: h,
        pixels,
    };
    Ok((image, cpu_s, per_pixel))
}

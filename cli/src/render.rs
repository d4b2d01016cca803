//! Multi-threaded rendering on top of the core's pass renderer.
//!
//! Threads are the host's business, not the core's: this module spawns
//! `threads` scoped std threads; thread `i` renders passes `i, i + T, …`
//! into its own film and the films are merged in thread order. The image is
//! therefore bit-identical for a fixed seed, sample count and thread count.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cmlt::accel::Intersector;
use cmlt::film::Film;
use cmlt::integrator::{Method, Settings, Stats, Tracer, Worker, render_pass};
use cmlt::scene::Scene;

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

/// Renders `scene` with `method` under `budget` on `threads` threads.
/// `on_pass` is called after every finished pass (progress reporting).
#[allow(clippy::too_many_arguments)]
pub fn render<I: Intersector + Sync>(
    scene: &Scene,
    accel: &I,
    settings: &Settings,
    method: Method,
    budget: Budget,
    threads: usize,
    seed: u64,
    on_pass: &(dyn Fn() + Sync),
) -> RenderOutput {
    let threads = threads.max(1);
    let start = Instant::now();
    let deadline = match budget {
        Budget::Time(s) => Some(start + Duration::from_secs_f64(s.max(0.0))),
        Budget::Spp(_) => None,
    };
    let stop = AtomicBool::new(false);
    let results: Vec<(Film, Stats)> = std::thread::scope(|sc| {
        let handles: Vec<_> = (0..threads)
            .map(|i| {
                let stop = &stop;
                sc.spawn(move || {
                    let mut tracer = Tracer::new(scene, accel);
                    let mut worker = Worker::new();
                    let mut film = Film::new(scene.camera.width(), scene.camera.height());
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
    let mut film = Film::new(scene.camera.width(), scene.camera.height());
    let mut stats = Stats::default();
    for (f, s) in &results {
        film.merge(f);
        stats.merge(s);
    }
    RenderOutput { film, stats, wall }
}

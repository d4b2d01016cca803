//! Multi-threaded rendering of one image: a thin driver over the core's
//! frame loop ([`cmlt::renderer`]).
//!
//! Threads are the host's business, not the core's: this module spawns one
//! scoped std thread per [`RenderWorker`]. The Metropolis bootstrap is
//! spread over them ([`prepare`]: [`Renderer::begin_prepare`],
//! `prepare_worker`, `finish_prepare`), then each renders its share of the
//! budget ([`render_workers`], [`Renderer::steps_for`]) and the films are
//! merged in worker order by [`Renderer::resolve`]. For a fixed seed,
//! per-pixel budget and thread count the image is bit-identical from run
//! to run; `--frames` ([`crate::frames`]) runs the same two functions per
//! frame, and the C API drives the same calls.
//!
//! The drivers take [`Accel`], the intersector the CLI picks at run time,
//! and are not generic, so the renderer is compiled for it once, here:
//! every crate that called a generic driver with its own intersector
//! compiled the whole renderer again (the benchmarks' convergence test took
//! 47.5 s of CPU to build that way, 1.4 s linking this one). Tests build
//! an `Accel::Ours` from a `Bvh`.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cmlt::accel::backend::Accel;
use cmlt::film::Film;
use cmlt::integrator::Stats;
use cmlt::math::Rgb;
use cmlt::mlt::{Bootstrap, LargeStepTally, MltStats};
pub use cmlt::renderer::Budget;
use cmlt::renderer::{RenderError, RenderStats, RenderWorker, Renderer, RendererConfig};
use cmlt::scene::{Camera, Scene};

use crate::image_io::Image;

/// What a render produced and what it cost.
pub struct RenderOutput {
    /// The image (all workers merged).
    pub image: Image,
    /// Counters summed over the workers (bootstrap rays included), and b.
    pub stats: RenderStats,
    /// The bootstrap (MLT, CMLT).
    pub bootstrap: Option<Bootstrap>,
    /// The large steps of all workers by depth (MLT, CMLT): b as the
    /// render's own large steps estimate it.
    pub large_steps: Option<LargeStepTally>,
    /// BDPT samples per depth behind the bootstrap's b (normalisation
    /// passes × pixels; 0 without passes).
    pub normalisation_samples: u64,
    /// Wall-clock time of the bootstrap (zero for PT and BDPT).
    pub bootstrap_wall: Duration,
    /// Wall-clock time of everything (bootstrap included).
    pub wall: Duration,
}

/// b from a render's large steps ([`RenderOutput::large_step_b`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LargeStepB {
    /// Σ_d of the large steps' mean target value at depth d.
    pub b: f64,
    /// Its standard error.
    pub error: f64,
    /// Large steps over all depths.
    pub count: u64,
    /// b pooled from the large steps and the normalisation passes by
    /// sample counts.
    pub pooled: f64,
}

impl RenderOutput {
    /// Samples (PT, BDPT) or level-1 mutations (MLT, CMLT) per pixel.
    pub fn per_pixel(&self) -> f64 {
        let pixels = (self.image.width * self.image.height).max(1) as f64;
        if self.bootstrap.is_some() {
            self.stats.mlt.mutations as f64 / pixels
        } else {
            self.stats.passes as f64
        }
    }

    /// b as the render's large steps estimate it, with its standard
    /// error and the number of large steps (a depth without large steps,
    /// one with no chain, adds the passes' b_d without error), and b
    /// pooled from them and the normalisation passes by sample counts
    /// ([`LargeStepTally::pooled_b`]); `None` for PT and BDPT.
    pub fn large_step_b(&self) -> Option<LargeStepB> {
        let (t, boot) = (self.large_steps.as_ref()?, self.bootstrap.as_ref()?);
        let (mut b, mut var, mut n) = (0.0, 0.0, 0);
        for (i, &b_pass) in boot.depth_b().iter().enumerate() {
            let d = i as u32 + 1;
            n += t.count(d);
            b += t.depth_b(d).unwrap_or(b_pass);
            var += t.depth_b_error(d).map_or(0.0, |e| e * e);
        }
        Some(LargeStepB {
            b,
            error: var.sqrt(),
            count: n,
            pooled: t.pooled_b(boot.depth_b(), self.normalisation_samples),
        })
    }

    /// The tracer's counters (rays, samples, packets, BSDF work).
    pub fn tracer(&self) -> &Stats {
        &self.stats.tracer
    }

    /// The chains' counters (zero for PT and BDPT).
    pub fn mlt(&self) -> &MltStats {
        &self.stats.mlt
    }

    /// Camera samples per second.
    pub fn samples_per_sec(&self) -> f64 {
        self.stats.tracer.samples as f64 / self.wall.as_secs_f64().max(1e-9)
    }

    /// Mutations per second of the chain phase.
    pub fn mutations_per_sec(&self) -> f64 {
        let t = (self.wall - self.bootstrap_wall).as_secs_f64().max(1e-9);
        self.stats.mlt.mutations as f64 / t
    }

    /// Millions of rays (closest-hit and occlusion) per second, overall.
    pub fn mrays_per_sec(&self) -> f64 {
        self.stats.tracer.total_rays() as f64 / self.wall.as_secs_f64().max(1e-9) * 1e-6
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

/// Refuses `count` films of `w × h` that need more memory than the machine
/// has available (Linux: `MemAvailable`), before anything is allocated: an
/// over-committing kernel grants an allocation it cannot back and kills
/// the process later, and a resolution the heap cannot hold must be a
/// clear error, not an abort half-way through a render.
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
    if Film::try_new(w, h).is_err() {
        return Err(format!("out of memory: a {w}x{h} image"));
    }
    Ok(())
}

/// Readies `renderer` for its frame with the bootstrap (MLT, CMLT) spread
/// over one thread per worker: [`Renderer::begin_prepare`] here, each
/// worker's [`Renderer::prepare_worker`] on its thread,
/// [`Renderer::finish_prepare`] here.
pub fn prepare(
    renderer: &mut Renderer,
    workers: &mut [RenderWorker],
    scene: &Scene,
    accel: &Accel,
) -> Result<(), String> {
    if !renderer.begin_prepare(scene) {
        return Ok(());
    }
    let r = &*renderer;
    std::thread::scope(|s| {
        let handles: Vec<_> = workers
            .iter_mut()
            .map(|worker| s.spawn(move || r.prepare_worker(worker, scene, accel)))
            .collect();
        handles
            .into_iter()
            .try_for_each(|h| h.join().expect("bootstrap thread panicked"))
    })
    .map_err(|e| e.to_string())?;
    renderer
        .finish_prepare(workers.iter())
        .map_err(|e| e.to_string())
}

/// Renders every worker's share of `budget` on its own scoped thread: the
/// CLI's one render loop (single images and `--frames`). A per-pixel budget
/// is each worker's [`Renderer::steps_for`]; a time budget runs until
/// `deadline`, every worker at least one step. Steps go in batches (one
/// pass, or up to 4096 mutations' worth of rounds) between which
/// `progress(n)` reports `n` more passes (PT, BDPT) or mutations (MLT,
/// CMLT) and the clock is read; batches change nothing in the image.
pub fn render_workers(
    renderer: &Renderer,
    workers: &mut [RenderWorker],
    scene: &Scene,
    accel: &Accel,
    budget: Budget,
    deadline: Option<Instant>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(), String> {
    let mlt = renderer.config().estimator.mlt();
    // Steps between progress reports and clock checks: one pass, or
    // batches of rounds small enough for both and large enough to make
    // them negligible.
    let batch = mlt.map_or(1, |m| (4096 / m.n_chains.max(1) as u64).max(1));
    let stop = AtomicBool::new(false);
    let r = renderer;
    std::thread::scope(|s| {
        let handles: Vec<_> = workers
            .iter_mut()
            .map(|worker| {
                let stop = &stop;
                s.spawn(move || {
                    let mut left = match budget {
                        Budget::PerPixel(n) => r.steps_for(worker.index(), n),
                        Budget::Seconds(_) => u64::MAX,
                    };
                    // A worker with no steps still starts its frame (its
                    // film is cleared, its chains started).
                    let mut first = true;
                    while left > 0 || first {
                        let k = left.min(batch);
                        let done = r.render_steps(worker, scene, accel, k)?;
                        first = false;
                        if done == 0 {
                            break;
                        }
                        progress(if mlt.is_some() { done } else { k });
                        left -= k;
                        // Time budgets: every worker renders at least one
                        // step, so the image is never empty.
                        if let Some(d) = deadline
                            && (stop.load(Ordering::Relaxed) || Instant::now() >= d)
                        {
                            stop.store(true, Ordering::Relaxed);
                            break;
                        }
                    }
                    Ok(())
                })
            })
            .collect();
        handles
            .into_iter()
            .try_for_each(|h| h.join().expect("render thread panicked"))
    })
    .map_err(|e: RenderError| e.to_string())
}

/// The unscaled sums of all workers' films, layer by layer in worker
/// order (what [`Renderer::resolve`] scales), for a render that is one
/// part of a larger one ([`crate::state`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FilmSums {
    /// Camera-sample sums per pixel, RGB, row-major.
    pub samples: Vec<[f64; 3]>,
    /// Splat sums per pixel, RGB, row-major.
    pub splats: Vec<[f64; 3]>,
}

/// Renders `scene` with `config` (one thread per `config.workers`) under
/// `budget`. `progress(n)` reports `n` more passes (PT, BDPT) or mutations
/// (MLT, CMLT) done.
pub fn render(
    scene: &Scene,
    accel: &Accel,
    config: RendererConfig,
    budget: Budget,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RenderOutput, String> {
    render_inner(scene, accel, config, budget, progress, false, None).map(|(out, _)| out)
}

/// [`render`], also handing back the workers' film sums.
pub fn render_with_sums(
    scene: &Scene,
    accel: &Accel,
    config: RendererConfig,
    budget: Budget,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(RenderOutput, FilmSums), String> {
    render_frame_with_sums(scene, accel, config, budget, progress, None)
}

/// [`render_with_sums`] of frame `k` of a sequence through `camera`
/// (`frame = Some((camera, k))`): the image [`crate::frames::render_frames`]
/// renders as its frame `k` when the frames are independent (no kept chains
/// or b window), since frame `k`'s random streams depend only on the seed
/// and `k`.
pub fn render_frame_with_sums(
    scene: &Scene,
    accel: &Accel,
    config: RendererConfig,
    budget: Budget,
    progress: &(dyn Fn(u64) + Sync),
    frame: Option<(Camera, u64)>,
) -> Result<(RenderOutput, FilmSums), String> {
    let (out, sums) = render_inner(scene, accel, config, budget, progress, true, frame)?;
    Ok((out, sums.expect("sums were asked for")))
}

fn render_inner(
    scene: &Scene,
    accel: &Accel,
    config: RendererConfig,
    budget: Budget,
    progress: &(dyn Fn(u64) + Sync),
    keep_sums: bool,
    frame: Option<(Camera, u64)>,
) -> Result<(RenderOutput, Option<FilmSums>), String> {
    let (w, h) = (scene.camera.width(), scene.camera.height());
    // One film per thread and the merged image (and the two sum layers).
    check_film_memory(w, h, config.workers as usize + 1 + keep_sums as usize)?;
    let start = Instant::now();
    let deadline = match budget {
        Budget::Seconds(s) => Some(deadline_after(start, s)?),
        Budget::PerPixel(_) => None,
    };
    let mut renderer = Renderer::new(config, scene.camera).map_err(|e| e.to_string())?;
    if let Some((camera, k)) = frame {
        // The frame loop starts every frame with `set_camera`, frame k
        // being the renderer's (k + 1)-th; only the count and the last
        // camera matter (nothing is rendered in between).
        for _ in 0..=k {
            renderer.set_camera(camera).map_err(|e| e.to_string())?;
        }
    }
    let mut workers: Vec<RenderWorker> = (0..config.workers)
        .map(|i| RenderWorker::new(&renderer, i))
        .collect::<Result<_, _>>()
        .map_err(|e| e.to_string())?;

    prepare(&mut renderer, &mut workers, scene, accel)?;
    let bootstrap_wall = start.elapsed();

    render_workers(
        &renderer,
        &mut workers,
        scene,
        accel,
        budget,
        deadline,
        progress,
    )?;
    let metropolis = config.estimator.is_metropolis();
    let wall = start.elapsed();
    let refs: Vec<&RenderWorker> = workers.iter().collect();
    let mut pixels = vec![Rgb::ZERO; w as usize * h as usize];
    renderer
        .resolve(&refs, |i, c| pixels[i] = c)
        .map_err(|e| e.to_string())?;
    let sums = keep_sums.then(|| film_sums(&refs));
    let out = RenderOutput {
        image: Image {
            width: w as usize,
            height: h as usize,
            pixels,
        },
        stats: renderer.stats(&refs),
        bootstrap: metropolis.then(|| renderer.bootstrap().clone()),
        large_steps: metropolis.then(|| merged_large_steps(&refs)).flatten(),
        normalisation_samples: config.estimator.mlt().map_or(0, |m| {
            let pixels = u64::from(w) * u64::from(h);
            u64::from(m.normalisation_passes(pixels)) * pixels
        }),
        bootstrap_wall,
        wall,
    };
    Ok((out, sums))
}

/// The workers' large-step tallies merged (`None` without chains).
fn merged_large_steps(workers: &[&RenderWorker]) -> Option<LargeStepTally> {
    let mut tallies = workers.iter().filter_map(|w| w.large_steps());
    let mut all = tallies.next()?.clone();
    for t in tallies {
        all.merge(t);
    }
    Some(all)
}

/// The workers' films summed layer by layer in worker order, as
/// [`Renderer::resolve`] sums them before scaling.
fn film_sums(workers: &[&RenderWorker]) -> FilmSums {
    let n = workers.first().map_or(0, |w| {
        w.film().width() as usize * w.film().height() as usize
    });
    let mut sums = FilmSums {
        samples: vec![[0.0; 3]; n],
        splats: vec![[0.0; 3]; n],
    };
    for (i, (a, b)) in sums.samples.iter_mut().zip(&mut sums.splats).enumerate() {
        for w in workers {
            let (s, p) = w.film().pixel_parts(i);
            for c in 0..3 {
                a[c] += s[c];
                b[c] += p[c];
            }
        }
    }
    sums
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
            "; perturbation steps: lens {}, caustic {}, multi-chain {}",
            m.lens_steps, m.caustic_steps, m.multi_chain_steps
        );
    }
    line
}

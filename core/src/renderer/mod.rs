//! The host's frame loop: a [`Renderer`] (camera, normalisation, the
//! configuration shared by all workers) and one [`RenderWorker`] per host
//! thread or job, each with its own film, chains and path storage.
//!
//! ```text
//!   Renderer::new(config, camera)      RenderWorker::new(&renderer, i)   ← all allocation
//!   loop per frame:
//!     renderer.set_camera(camera)                    (optional: resets accumulation)
//!     scene.update_mesh(…); bvh.refit(…)             (optional: moved geometry, new frame)
//!     if renderer.begin_prepare(scene) {             (one thread)
//!         renderer.prepare_worker(&mut worker_i, scene, accel)   (each worker, any thread)
//!         renderer.finish_prepare([&worker_0, …])    (one thread)
//!     }
//!     renderer.render(&mut worker_i, …, budget)      (any thread, one call per worker)
//!     renderer.resolve(&[&worker_0, …], out)         (merge in worker order)
//!       or resolve_rows(workers, y0..y1, format, …)  (a band of rows, any thread)
//!     aov::render_rows(scene, accel, camera, previous, y0..y1, …)  (optional)
//! ```
//!
//! Preparing is that one three-step form: `begin_prepare` finds what the
//! scene calls for and says whether there is bootstrap work (MLT, CMLT
//! after creation, a camera change or a scene update); the workers then
//! share the Metropolis bootstrap — worker `i` of `W` evaluates the `i`-th
//! contiguous share of the bootstrap samples and of the normalisation
//! passes' blocks ([`NORMALISATION_BLOCKS`]: a pass is shared too when
//! there are fewer passes than workers) — and `finish_prepare` joins
//! their shares in index order,
//! so the bootstrap (and the image) is bit for bit the same whatever the
//! number of workers and whichever thread ran each. A host without
//! threads runs the three steps on its own thread.
//!
//! ## Estimators and depth
//!
//! [`Estimator`] is the one choice of estimator, each variant with the
//! settings only it reads ([`MltSettings`] for MLT, level 1 and level 2
//! for CMLT); [`Renderer::new`] refuses settings the estimator does not
//! read ([`Temporal`]'s Metropolis switches for PT and BDPT). Every
//! estimator renders paths of at most [`RendererConfig::max_depth`]
//! segments: the scene's `max_depth`, or [`RendererConfig::depth_cap`]
//! when that is unbounded.
//!
//! ## Allocation
//!
//! Everything a frame touches is sized when the renderer and its workers
//! are made: films, subpath storage for the deepest path, the bootstrap's
//! buffers, every chain's primary-sample vector and path. Preparing,
//! `render` and `resolve` allocate nothing; a test counts allocations to
//! prove it. That is why even PT renders an unbounded depth at the depth
//! cap.
//!
//! ## Budgets and determinism
//!
//! A host states a [`Budget`]: samples or mutations per pixel over all
//! workers, or seconds. [`Renderer::steps_for`] turns a per-pixel budget
//! into each worker's steps: whole passes (PT, BDPT: passes `i, i + W, …`
//! below n) or whole rounds (MLT, CMLT: [`mlt::rounds_for`] on every
//! worker); a time budget is a clock the host asks between pieces of
//! work ([`Renderer::render_while`]: [`PIECE`] camera samples for PT and
//! BDPT, about a millisecond, or [`PIECE`] level-1 mutations;
//! [`Renderer::prepare_worker_while`] for the Metropolis set-up: [`PIECE`]
//! bootstrap samples or normalisation-pass pixels). The core never reads
//! time. A PT or BDPT frame may end inside a pass: each pixel is then
//! normalised by its own sample count (`renderer/accumulation.rs`), and
//! the next call goes on with the open pass. Below one pass a frame would
//! show only the pixels it reached; [`Renderer::set_pixel_block`] renders
//! passes at a coarser pixel grid instead, each sample filling its block,
//! with the block size fixed by the host or fitted to the workers'
//! measured samples ([`PixelBlock`], `renderer/pixel_block.rs`).
//!
//! At the lowest level a budget is a number of *units*: camera samples for PT and BDPT (rounded
//! up to whole passes, one sample per pixel), level-1 mutations for MLT and
//! CMLT (rounded up to whole rounds, one mutation of every chain). Worker
//! `i` of `W` renders global passes `i, i + W, …` and holds the global
//! chains `i, i + W, …`, so each worker's film alone estimates the image
//! and films of workers that ran different budgets merge correctly. The
//! image is a function of the configuration, the camera and each worker's
//! total budget since the last reset, whatever thread ran which worker.
//!
//! ## Frames
//!
//! [`Renderer::set_camera`] starts a new frame — a new accumulation, even
//! through the same camera: the next preparation re-runs the bootstrap (b
//! depends on the view), and each worker clears its film at its next
//! `render`. A scene update ([`Scene::update_mesh`], with the host
//! refitting its acceleration structure, e.g. `Bvh::refit`) starts a new
//! frame at the next `begin_prepare`, which notices the scene's new
//! revision; `render` refuses a scene updated since. What carries over
//! from frame to frame is set by [`Temporal`]:
//! by default nothing (each frame restarts its chains and draws new random
//! numbers: independent frames); with the switches on, chains are kept and
//! re-evaluated, b is averaged over a window of frames while the camera
//! stays put, and/or every frame reuses the same random sequences.
//!
//! Kept chains also make change cheap: once a first bootstrap is joined,
//! a frame after a camera move or a scene update is ready at
//! `begin_prepare` — the chains are re-evaluated under the new view at
//! the worker's first `render` and go on with the b of earlier frames —
//! while the next bootstrap is evaluated in the pieces the host's
//! `prepare_worker_while` calls allow, across as many frames as it takes,
//! and joined by the `finish_prepare` after it completes (b is then an
//! estimate over the views of those frames). The normalisation passes'
//! image of such a bootstrap ([`MltSettings::pass_records`]) joins the
//! first frame that uses its b only when the bootstrap ran entirely under
//! that frame's camera and scene revision, once: a still camera's kept
//! frames weigh each bootstrap's passes as one offline render does.
//! Between joins b is the last bootstrap's, stale for a moving view;
//! with [`Temporal::large_step_window`] it is tracked instead from the
//! chains' own large steps of the last frames (`mlt::LargeStepTally`,
//! collected by every worker, taken by every frame's `finish_prepare`).
//! Every estimator carries its image by [`Accumulation`]: reset
//! (default), keep or decay, set per frame by
//! [`Renderer::set_accumulation`] — PT and BDPT their films, MLT and CMLT
//! their earlier frames' images, each normalised by its own b and
//! weighted by its records (`renderer/accumulation.rs`), so that with a
//! still camera kept frames converge as one long render does, and a
//! frame with few mutations per pixel still shows a full image.

mod accumulation;
mod estimator;
mod fill;
mod pixel_block;
mod resolve;
mod tracked_b;

use alloc::vec::Vec;
use core::ops::Deref;

use glam::Vec2;

use crate::accel::{DynIntersector, Intersector};
use crate::film::Film;
use crate::integrator::{Settings, Stats, Tracer, bdpt, pt};
use crate::math::Rgb;
use crate::mlt::bootstrap;
use crate::mlt::{
    self, Bootstrap, LargeStepTally, MltSettings, MltStats, PrimarySampler, WorkerChains,
};
use crate::sampler::{SampleStream, mix64};
use crate::scene::{Analysis, Camera, Effect, Scene};

pub use accumulation::Accumulation;
use accumulation::{Kept, Weights};
pub use estimator::{Estimator, EstimatorKind};
pub use fill::FILL_SHARE;
use pixel_block::{BlockGrid, PassOrder};
pub use pixel_block::{FIT_MARGIN, MAX_PIXEL_BLOCK, PixelBlock};
pub(crate) use resolve::check_buffer;
use tracked_b::TrackedB;

/// The smallest piece of work between two questions of a time budget's
/// callback ([`Renderer::render_while`] for PT and BDPT,
/// [`Renderer::prepare_worker_while`] for the Metropolis set-up): camera
/// samples, bootstrap samples or normalisation-pass pixels. At tens of
/// microseconds per BDPT sample, about a millisecond of work.
pub const PIECE: u64 = 16;

/// The blocks each normalisation pass of the Metropolis set-up is cut
/// into: block k of a pass holds its pixels k, k + B, k + 2B, … (B = this
/// number, so every block spreads over the whole image and costs about
/// the same). The blocks of all passes, numbered pass by pass, are shared
/// out to the workers in contiguous runs (worker `i` of `W` takes
/// `⌊i·N/W⌋ .. ⌊(i+1)·N/W⌋` of the N blocks), so every worker evaluates
/// an equal share of the passes even when there are fewer passes than
/// workers; each block's sums are kept apart and added in block order, so
/// b is the same bit for bit whatever the number of workers. 24 divides
/// evenly over 1, 2, 3, 4, 6, 8 and 12 workers.
pub const NORMALISATION_BLOCKS: u64 = 24;

/// The deepest path (segments) a renderer accepts, through `max_depth` or
/// the depth cap: every worker's storage is sized for it at creation.
pub const MAX_DEPTH: u32 = 1024;

/// Default of [`RendererConfig::depth_cap`].
pub const DEFAULT_DEPTH_CAP: u32 = 32;

/// How much a render may do: the one budget of the core, the CLI, the
/// benchmarks and the C API (`cmlt_renderer_render_per_pixel`, and
/// `cmlt_renderer_render_while` with the host's clock).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// Samples per pixel (PT, BDPT) or level-1 mutations per pixel (MLT,
    /// CMLT), over all workers, rounded up to whole steps
    /// ([`Renderer::steps_for`]): the image is a function of the seed.
    PerPixel(u64),
    /// Wall-clock seconds, the bootstrap included; every worker renders at
    /// least one step. The host keeps the time ([`Renderer::render_while`]),
    /// so the image depends on how many steps fitted.
    Seconds(f64),
}

/// Everything that fixes a render apart from the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RendererConfig {
    /// The estimator, with the settings only it reads.
    pub estimator: Estimator,
    /// Path-depth and emitter settings (the scene's request: Mitsuba's
    /// `max_depth`, `rr_depth`, `hide_emitters`).
    pub settings: Settings,
    /// The longest path, in segments, when `settings.max_depth` is
    /// unbounded: what every estimator renders an unbounded depth at
    /// ([`RendererConfig::max_depth`]), because storage is sized for the
    /// deepest path and MLT bootstraps over a finite set of depths. Paths
    /// longer than this are missing (energy of order albedo^cap). 1 ..=
    /// [`MAX_DEPTH`]; ignored when the depth is bounded.
    pub depth_cap: u32,
    /// Seed of every random stream.
    pub seed: u64,
    /// Number of workers whose films make the image (≥ 1).
    pub workers: u32,
    /// Frame-to-frame coherence switches (all off by default; kept chains
    /// and the b window are for MLT and CMLT only).
    pub temporal: Temporal,
    /// Simulate every effect whatever the scene calls for (the CLI's
    /// `--all-effects`): preparing then skips the scene analysis and
    /// renders with [`Analysis::all`]. Off by default: the analysis
    /// specialises the estimators to the scene (see [`Renderer::analysis`]).
    pub all_effects: bool,
}

/// Frames after the first whose chains are kept evaluate
/// `n_bootstrap / KEPT_BOOTSTRAP_SHARE` bootstrap samples per depth (see
/// [`Renderer::begin_prepare`]).
pub const KEPT_BOOTSTRAP_SHARE: u32 = 16;

/// Largest [`Temporal::b_window`].
pub const MAX_B_WINDOW: u32 = 64;

/// How consecutive frames (accumulations started by
/// [`Renderer::set_camera`]) relate. Each switch on its own lowers flicker;
/// `cmlt-bench flicker` measures each.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Temporal {
    /// MLT: keep every chain across frames. With an unchanged camera the
    /// chains simply go on; after a camera change each chain's current
    /// primary-sample point is evaluated again under the new camera
    /// (`WorkerChains::reevaluate`) instead of restarting from the
    /// bootstrap's samples, so the chains stay (near) stationary and
    /// their depths keep the first frame's split by b_d. Frames after the
    /// first then evaluate only a share ([`KEPT_BOOTSTRAP_SHARE`]) of the bootstrap
    /// samples, which restart the chains the new view leaves at zero.
    pub keep_chains: bool,
    /// MLT: the normalisation used for a frame is the mean of the last
    /// `b_window` frames' bootstrap estimates while the camera stays the
    /// same (a window restarts at every camera change, so a moving camera
    /// never lags); 0 or 1 = each frame its own b. At most
    /// [`MAX_B_WINDOW`].
    pub b_window: u32,
    /// Every frame draws the same random numbers (Segovia 2007's §3.1
    /// reproducible perturbations): a static camera gives identical frames
    /// and a moving one a noise pattern that moves with the image.
    /// Otherwise frame f's streams are seeded by (seed, f).
    pub fixed_sequence: bool,
    /// MLT with kept chains: b tracked from the chains' large steps of the
    /// last `large_step_window` frames (the last joined bootstrap's passes
    /// standing in for frames the window has not filled yet), across
    /// camera moves and scene updates — so that b
    /// follows a moving view (lagging it by about half the window)
    /// instead of staying at an earlier bootstrap's and jumping when the
    /// next one is joined (`renderer/tracked_b.rs`). Updated by every
    /// frame's [`Renderer::finish_prepare`] from the workers' previous
    /// frame. Replaces [`Temporal::b_window`]'s b while on; 0 = off. At
    /// most [`MAX_B_WINDOW`].
    pub large_step_window: u32,
}

impl Default for RendererConfig {
    /// BDPT, Mitsuba's integrator defaults, depth cap 32, seed 0, one
    /// worker.
    fn default() -> Self {
        RendererConfig {
            estimator: Estimator::Bdpt,
            settings: Settings::default(),
            depth_cap: DEFAULT_DEPTH_CAP,
            seed: 0,
            workers: 1,
            temporal: Temporal::default(),
            all_effects: false,
        }
    }
}

impl RendererConfig {
    /// The defaults ([`RendererConfig::default`]) with the estimator
    /// `kind` and its default settings ([`Estimator::default_for`]).
    pub fn for_estimator(kind: EstimatorKind) -> Self {
        RendererConfig {
            estimator: Estimator::default_for(kind),
            ..RendererConfig::default()
        }
    }

    /// The longest path, in segments, every estimator renders:
    /// `settings.max_depth`, or [`RendererConfig::depth_cap`] when that is
    /// unbounded. The one depth limit.
    pub fn max_depth(&self) -> u32 {
        self.settings.max_depth.unwrap_or(self.depth_cap)
    }
}

/// Why a renderer call was refused. Nothing changed when one is returned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderError {
    /// A configuration value is out of range (the message names it).
    Config(&'static str),
    /// The camera's resolution differs from the renderer's.
    Resolution,
    /// The worker belongs to another renderer or has an index ≥ `workers`.
    Worker,
    /// `render` before preparing (after creation, a camera change or a
    /// scene update).
    NotPrepared,
    /// `finish_prepare` without every worker's `prepare_worker` for this
    /// frame, or with a worker missing or given twice.
    BootstrapIncomplete,
    /// The camera needs an effect this build of the core left out (a
    /// thin lens without the `depth-of-field` feature).
    EffectNotBuilt(Effect),
    /// The renderer and its workers would need more memory than the
    /// address space holds ([`Renderer::memory_bound`] overflows).
    TooLarge,
    /// An output buffer or row range does not fit the image (the message
    /// says which): [`Renderer::resolve_rows`], [`crate::aov`].
    Output(&'static str),
}

impl core::fmt::Display for RenderError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            RenderError::Config(m) => write!(f, "invalid configuration: {m}"),
            RenderError::Resolution => {
                f.write_str("the camera's resolution differs from the renderer's")
            }
            RenderError::Worker => f.write_str("the worker does not belong to this renderer"),
            RenderError::NotPrepared => f.write_str(
                "prepare the renderer (after creating it, changing the camera or updating the scene) before rendering",
            ),
            RenderError::BootstrapIncomplete => f.write_str(
                "every worker must run prepare_worker for this frame before finish_prepare",
            ),
            RenderError::EffectNotBuilt(e) => write!(
                f,
                "the camera needs {}, which this build of cmlt leaves out (enable the `{}` feature)",
                e.name(),
                e.feature().unwrap_or("?")
            ),
            RenderError::TooLarge => f.write_str(
                "the renderer would need more memory than the address space holds \
                 (fewer workers, chains, bootstrap samples or pixels)",
            ),
            RenderError::Output(m) => write!(f, "invalid output: {m}"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for RenderError {}

/// Counters of a render since its last reset, summed over workers.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Rays, samples and packets.
    pub tracer: Stats,
    /// Metropolis counters (zero for PT and BDPT).
    pub mlt: MltStats,
    /// Passes (PT, BDPT; MLT, CMLT: of the block fill) completed by all
    /// workers.
    pub passes: u64,
    /// Non-finite contributions dropped by the films (0 in a correct
    /// render).
    pub nonfinite: u64,
    /// The normalisation b (MLT; 0 otherwise).
    pub b: f64,
}

/// The state every worker reads: configuration, camera, normalisation.
pub struct Renderer {
    config: RendererConfig,
    camera: Camera,
    /// Bumped by every camera change; workers compare it with their own.
    generation: u64,
    /// The generation the renderer is prepared for (PT, BDPT: the
    /// analysis; MLT, CMLT: also the bootstrap).
    prepared: Option<u64>,
    bootstrap: Bootstrap,
    /// The bootstrap the workers are evaluating (its number among the
    /// bootstraps begun) between `begin_prepare` and `finish_prepare`;
    /// with kept chains it may span frames (see `begin_prepare`).
    pending: Option<u64>,
    /// Bootstraps begun so far.
    epochs: u64,
    /// The generation the pending bootstrap was begun for.
    pending_generation: u64,
    /// The level-1 settings of the pending bootstrap (fewer bootstrap
    /// samples for kept chains, see `begin_prepare`).
    boot_mlt: MltSettings,
    /// The path settings and seed the pending bootstrap evaluates with.
    boot_settings: Settings,
    boot_seed: u64,
    /// Whether a bootstrap has been joined: kept chains can then go on
    /// with it while the next one is evaluated.
    has_bootstrap: bool,
    /// The camera and scene revision the pending bootstrap began under,
    /// and whether both have stayed so since (set_camera and
    /// begin_prepare watch them): then every piece of it evaluated that
    /// one view.
    boot_view: (Camera, Option<u64>),
    boot_one_view: bool,
    /// The last joined bootstrap's epoch and view, when it ran under one
    /// view: with kept chains its passes' image joins a frame of that view
    /// (`mlt/pass_image.rs`).
    joined_view: Option<(u64, Camera, Option<u64>)>,
    /// How workers carry their images into the next frame.
    accumulation: Accumulation,
    /// How many pixels a PT or BDPT sample fills.
    pixel_block: PixelBlock,
    /// Where `finish_prepare` joins the workers' shares.
    shares: Shares,
    /// The last frames' large steps, with [`Temporal::large_step_window`].
    tracked: TrackedB,
    /// Identifies this renderer's workers.
    id: usize,
    /// Frames (accumulations) started so far, minus one: 0 for the first.
    frame: u64,
    /// Whether the view differs from the previous frame's: the camera
    /// moved or the scene changed (the b window restarts).
    view_changed: bool,
    /// The [`Scene::revision`] the current frame was prepared for.
    scene_revision: Option<u64>,
    /// The last frames' estimates of b while the camera stayed the same
    /// (ring buffer of `b_count` entries, newest at `b_next − 1`).
    b_history: [f64; MAX_B_WINDOW as usize],
    b_count: usize,
    b_next: usize,
    /// The b the image is scaled with (the window's mean).
    b_used: f64,
    /// What the scene calls for through the current camera, found by
    /// `begin_prepare` ([`Analysis::all`] before, or with
    /// [`RendererConfig::all_effects`]).
    analysis: Analysis,
    /// `config.settings` specialised to `analysis`: what every estimator
    /// runs with.
    settings: Settings,
}

/// One worker's storage: film, subpaths, chains. Owned by the host, one per
/// thread or job; [`Renderer::render`] takes it by `&mut`.
pub struct RenderWorker {
    renderer: usize,
    index: u32,
    generation: Option<u64>,
    /// The camera of this worker's last accumulation.
    camera: Option<Camera>,
    /// The scene revision of this worker's last accumulation.
    scene_revision: Option<u64>,
    film: Film,
    /// PT, BDPT: samples per pixel in `film`; MLT, CMLT: in `fill`.
    weights: Weights,
    /// MLT, CMLT: the block fill's BDPT samples (`renderer/fill.rs`;
    /// empty for PT and BDPT, whose samples are in `film`).
    fill: Film,
    /// MLT, CMLT: the earlier frames' images kept by [`Accumulation`]
    /// (empty for PT, BDPT).
    kept: Kept,
    /// MLT, CMLT: the b of this worker's last `render` call, which its
    /// film is folded into `kept` with when its next frame starts.
    frame_b: f64,
    /// PT, BDPT: the position of the next sample in the open pass's
    /// order, and where the pass (or the worker's share of a guard pass)
    /// ends; both 0 between passes.
    cursor: u64,
    pass_end: u64,
    /// PT, BDPT: whether the open pass is a reset frame's guard pass
    /// (`renderer/pixel_block.rs`), and whether the next pass begun is
    /// one.
    guard: bool,
    guard_due: bool,
    /// MLT, CMLT with a fitted block fill: where the frame's first fitted
    /// fill pass stands, which the fill renders whole before any further
    /// mutation (`renderer/fill.rs`, work).
    front: Front,
    /// PT, BDPT: whether the open pass visits the pixels in the strided
    /// order of `render_while` (else row-major; see `Renderer::stride`).
    strided: bool,
    /// PT, BDPT: the block size of the open pass (`PixelBlock`).
    block: u32,
    /// PT, BDPT: the samples of this worker's current frame, and of its
    /// last one (what `PixelBlock::Fit` forecasts a frame by).
    frame_samples: u64,
    last_frame_samples: u64,
    bdpt: bdpt::PathStorage,
    mlt: Option<WorkerChains>,
    /// This worker's share of a split bootstrap (MLT, CMLT).
    boot: Option<WorkerBootstrap>,
    /// Passes this worker has completed since the last reset.
    passes: u64,
    stats: Stats,
}

/// Where a worker's block fill stands with the first fitted pass of its
/// frame (`renderer/fill.rs`, work).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Front {
    /// Not begun: the fill owes samples until it begins.
    Due,
    /// Begun: the fill owes samples until the frame has this many.
    Until(u64),
    /// No fitted fill (PT, BDPT; a fixed pixel block).
    Done,
}

/// One worker's share of a bootstrap spread over the workers
/// ([`Renderer::prepare_worker`]): its bootstrap samples' values, the
/// per-depth sums of its normalisation blocks (its `j`-th block at `j ·
/// D`; see [`NORMALISATION_BLOCKS`]), the rays it traced, and the storage
/// it evaluates with — all sized when the worker is made.
struct WorkerBootstrap {
    /// The bootstrap (`Renderer::pending`) these values are for.
    epoch: Option<u64>,
    /// Whether the share is complete.
    complete: bool,
    /// The next bootstrap sample to evaluate (global index).
    next_sample: u64,
    /// The next normalisation block to evaluate (global index: pass
    /// `block / NORMALISATION_BLOCKS`) and the next of its pixels (the
    /// `step`-th).
    block: u64,
    step: u64,
    values: Vec<f32>,
    blocks: Vec<f64>,
    /// Normalisation-pass samples (pixels of its blocks) evaluated.
    pass_samples: u64,
    /// The image of its normalisation passes, when it is added to the
    /// chains' ([`MltSettings::pass_records`] > 0), and whether it has
    /// been added (once, to the first frame that uses the bootstrap's b;
    /// with kept chains only if that frame's view is the one the
    /// bootstrap ran under: `Renderer::joined_view`).
    image: Option<Film>,
    image_added: bool,
    /// Rays of the set-up since the worker's last frame began (they count
    /// towards its next frame).
    stats: Stats,
    ws: bdpt::PathStorage,
    sampler: PrimarySampler,
}

/// The workers' shares of a bootstrap joined in index order by
/// [`Renderer::finish_prepare`], sized when the renderer is made.
struct Shares {
    /// Every bootstrap sample's value, by index.
    values: Vec<f32>,
    /// Every normalisation block's per-depth sums, block `k` at `k · D`.
    blocks: Vec<f64>,
    /// The blocks' sums added in block order, per depth.
    sums: Vec<f64>,
    /// Per worker, whether its share is in.
    joined: Vec<bool>,
}

/// Distinguishes renderers so a worker cannot be used with another one.
/// (`usize`: 64-bit atomics are missing on small targets; a 32-bit count
/// repeats only after 2³² renderers.)
fn next_id() -> usize {
    use core::sync::atomic::{AtomicUsize, Ordering};
    static NEXT: AtomicUsize = AtomicUsize::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

impl Renderer {
    /// A renderer for `camera`'s resolution, after checking `config`
    /// ([`RenderError::Config`] names a value out of range or a setting
    /// the estimator does not read). Unbounded `max_depth` is capped at
    /// `config.depth_cap` ([`RendererConfig::max_depth`]).
    pub fn new(config: RendererConfig, camera: Camera) -> Result<Self, RenderError> {
        check_lens(&camera)?;
        Self::check_config(&config)?;
        let mut config = config;
        config.settings.max_depth = Some(config.max_depth());
        // PT and BDPT keep no bootstrap: empty tables.
        let mlt = config.estimator.mlt().copied().unwrap_or(MltSettings {
            n_bootstrap: 0,
            b_passes: 0,
            ..MltSettings::default()
        });
        let depths = mlt::depths(&config.settings) as usize;
        let passes = mlt.normalisation_passes(camera.pixel_count()) as usize;
        Ok(Renderer {
            bootstrap: Bootstrap::with_capacity(&config.settings, &mlt),
            pending: None,
            epochs: 0,
            pending_generation: 0,
            boot_mlt: mlt,
            boot_settings: config.settings,
            boot_seed: config.seed,
            has_bootstrap: false,
            boot_view: (camera, None),
            boot_one_view: false,
            joined_view: None,
            accumulation: Accumulation::Reset,
            pixel_block: PixelBlock::default(),
            shares: Shares {
                values: Vec::with_capacity(Bootstrap::sample_count(&config.settings, &mlt) as usize),
                blocks: Vec::with_capacity(passes * NORMALISATION_BLOCKS as usize * depths),
                sums: Vec::with_capacity(depths),
                joined: alloc::vec![false; config.workers as usize],
            },
            tracked: TrackedB::new(
                config.temporal.large_step_window,
                config.workers,
                depths as u32,
            ),
            config,
            camera,
            generation: 0,
            prepared: None,
            id: next_id(),
            frame: 0,
            view_changed: true,
            scene_revision: None,
            b_history: [0.0; MAX_B_WINDOW as usize],
            b_count: 0,
            b_next: 0,
            b_used: 0.0,
            analysis: Analysis::all(),
            settings: config.settings,
        })
    }

    /// Refuses a configuration [`Renderer::new`] cannot build (the camera
    /// aside): checked before anything is sized from it, so no bound or
    /// allocation is ever computed from an unchecked field.
    fn check_config(config: &RendererConfig) -> Result<(), RenderError> {
        if config.workers == 0 {
            return Err(RenderError::Config("at least one worker is needed"));
        }
        config.estimator.validate().map_err(RenderError::Config)?;
        let t = &config.temporal;
        if !config.estimator.is_metropolis() {
            // PT and BDPT have no chains and no b: a switch they would
            // ignore is refused, not silently dropped.
            if t.keep_chains {
                return Err(RenderError::Config(
                    "keep_chains is read by MLT and CMLT only (PT and BDPT have no chains)",
                ));
            }
            if t.b_window != 0 {
                return Err(RenderError::Config(
                    "b_window is read by MLT and CMLT only (PT and BDPT have no normalisation b)",
                ));
            }
        }
        if t.large_step_window != 0 && !t.keep_chains {
            return Err(RenderError::Config(
                "large_step_window is read with keep_chains only (other frames run their own bootstrap)",
            ));
        }
        if t.b_window > MAX_B_WINDOW {
            return Err(RenderError::Config("the b window is at most 64 frames"));
        }
        if t.large_step_window > MAX_B_WINDOW {
            return Err(RenderError::Config(
                "the large-step window is at most 64 frames",
            ));
        }
        if config.depth_cap == 0 && config.settings.max_depth.is_none() {
            return Err(RenderError::Config("the depth cap must be at least 1"));
        }
        // Storage is sized for the deepest path up front: an absurd depth
        // from a host (u32::MAX) aborted the process in the allocator
        // instead of being refused. The C API's limit.
        if config.max_depth() > MAX_DEPTH {
            return Err(RenderError::Config("path depth must be at most 1024"));
        }
        Ok(())
    }

    /// An upper bound of the bytes a renderer of `config` at `width ×
    /// height` pixels and its `config.workers` workers allocate together,
    /// in checked arithmetic: [`RenderError::TooLarge`] when it exceeds
    /// `isize::MAX` (no allocation could hold it), so a host can refuse or
    /// reserve before anything is allocated. Allocates nothing; the
    /// configuration is checked first as [`Renderer::new`] checks it
    /// (a bound from an unchecked field, say k = 2³⁰, would be a request no
    /// allocator can meet).
    pub fn memory_bound(
        config: &RendererConfig,
        width: u32,
        height: u32,
    ) -> Result<u64, RenderError> {
        use core::mem::size_of;
        Self::check_config(config)?;
        let depth = u64::from(config.max_depth().min(MAX_DEPTH));
        let workers = u64::from(config.workers);
        let pixels = u64::from(width) * u64::from(height);
        let c = |a: Option<u64>| a.ok_or(RenderError::TooLarge);
        // Allocator bookkeeping a block may carry (a host's header, padding).
        const BLOCK: u64 = 64;
        // A subpath vertex, a path vertex and a primary-sample coordinate
        // with its bookkeeping, rounded up.
        let vertex = 512u64.max(size_of::<bdpt::PathVertex>() as u64);
        let dims = PrimarySampler::dimensions_for_depth(depth as u32) as u64;
        let sampler = dims * 32 + 4 * BLOCK;
        let workspace = 2 * (depth + 2) * vertex + 4 * BLOCK;
        // Every worker: its film (two RGB f64 layers) and path storage;
        // Metropolis ones also a bootstrap share (its own path storage and
        // sampler, its values and pass sums), their chains' path storage,
        // a state, a sampler and a path per chain, and the multiple-try
        // candidates (k ≤ 64 of them).
        // PT and BDPT also count samples per pixel (an f32 each), MLT and
        // CMLT keep the earlier frames' sums (three f64 each).
        let film = pixels * (Film::BYTES_PER_PIXEL + 24);
        let mut worker =
            c(film.checked_add(size_of::<RenderWorker>() as u64 + workspace + 16 * BLOCK))?;
        // Only a Metropolis renderer keeps bootstrap tables and the
        // normalisation blocks' sums (a small image gets up to
        // `MAX_FLOOR_PASSES` passes of `NORMALISATION_BLOCKS` blocks).
        let (mut boot_samples, mut passes) = (0, 0);
        if let Some(mlt) = config.estimator.mlt() {
            boot_samples = c(u64::from(mlt.n_bootstrap).checked_mul(depth))?;
            passes = c(u64::from(mlt.normalisation_passes(pixels))
                .checked_mul(depth)
                .and_then(|p| p.checked_mul(NORMALISATION_BLOCKS)))?;
            let chains = u64::from(mlt.n_chains);
            let chain = 1024 + sampler + (depth + 1) * vertex + 4 * BLOCK;
            let k = config.estimator.level2().map_or(0, |l2| l2.k);
            let level2 = u64::from(k) * 8 * 1024 + 64 * 1024;
            // The block fill's film and sample weights (`renderer/fill.rs`).
            worker = c(worker.checked_add(pixels * (Film::BYTES_PER_PIXEL + 4)))?;
            // The normalisation passes' image (`mlt/pass_image.rs`).
            if mlt.pass_records > 0.0 {
                worker = c(worker.checked_add(pixels * Film::BYTES_PER_PIXEL))?;
            }
            worker = c(chains
                .checked_mul(chain)
                .and_then(|b| b.checked_add(worker))
                .and_then(|b| b.checked_add(3 * workspace + 2 * sampler))
                .and_then(|b| b.checked_add(level2))
                .and_then(|b| b.checked_add(boot_samples.div_ceil(workers.max(1)) * 8))
                // A share of whole blocks: up to one block (D sums) more
                // than an even split of the sums.
                .and_then(|b| b.checked_add((passes.div_ceil(workers.max(1)) + depth) * 8)))?;
        }
        // The renderer: bootstrap tables and the joined shares (bootstrap samples,
        // passes), one slot per worker, the accumulator (two RGB f64
        // layers per pixel).
        // The tracked b's tallies (`renderer/tracked_b.rs`): one per frame
        // of the window and per worker, and their merge, each three
        // vectors of D numbers.
        let window = u64::from(config.temporal.large_step_window);
        let tallies = if window > 0 { window + workers + 1 } else { 0 };
        let renderer = c(boot_samples
            .checked_mul(16)
            .and_then(|b| b.checked_add(passes * 8 + 64 * BLOCK))
            .and_then(|b| b.checked_add(workers * 64))
            .and_then(|b| b.checked_add(tallies * (depth * 24 + 4 * BLOCK)))
            .and_then(|b| b.checked_add(pixels * size_of::<Layers>() as u64)))?;
        let total = c(workers
            .checked_mul(worker)
            .and_then(|b| b.checked_add(renderer)))?;
        if total > isize::MAX as u64 {
            return Err(RenderError::TooLarge);
        }
        Ok(total)
    }

    /// The configuration (with the depth cap applied).
    pub fn config(&self) -> &RendererConfig {
        &self.config
    }

    /// What the scene calls for, as the last `begin_prepare` found it: the
    /// effects the estimators simulate, everything else skipped
    /// ([`Analysis::all`] before the first `begin_prepare` and with
    /// [`RendererConfig::all_effects`]).
    pub fn analysis(&self) -> &Analysis {
        &self.analysis
    }

    /// The current camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The normalisation b the current accumulation is scaled with (MLT,
    /// once prepared: this frame's bootstrap estimate, or the mean over
    /// the b window — with kept chains, of the last bootstrap joined while
    /// the next one is evaluated; 0 otherwise).
    pub fn b(&self) -> f64 {
        self.b_used
    }

    /// The bootstrap of the current frame (MLT, CMLT, once prepared:
    /// b by depth and the chains' bootstrap samples; empty otherwise).
    pub fn bootstrap(&self) -> &Bootstrap {
        &self.bootstrap
    }

    /// Index of the current frame: the number of `set_camera` calls.
    pub fn frame(&self) -> u64 {
        self.frame
    }

    /// The seed of the current frame's random streams: the configured seed
    /// in frame 0 and with [`Temporal::fixed_sequence`], else one derived
    /// from (seed, frame).
    pub fn frame_seed(&self) -> u64 {
        let c = &self.config;
        if c.temporal.fixed_sequence || self.frame == 0 {
            c.seed
        } else {
            mix64(mix64(c.seed ^ 0xF7A3_E000_0000_0000) ^ self.frame)
        }
    }

    /// Starts the next frame: a new accumulation through `camera` (the
    /// same camera again is a new frame too — call it once per displayed
    /// frame, or not at all to accumulate progressively); preparing must
    /// run before the next `render`. The resolution must not change.
    pub fn set_camera(&mut self, camera: Camera) -> Result<(), RenderError> {
        if camera.width() != self.camera.width() || camera.height() != self.camera.height() {
            return Err(RenderError::Resolution);
        }
        check_lens(&camera)?;
        self.view_changed = camera != self.camera;
        if self.pending.is_some() && camera != self.boot_view.0 {
            // A bootstrap under way may be evaluated through this camera
            // too: it no longer images one view.
            self.boot_one_view = false;
        }
        self.camera = camera;
        self.next_frame();
        Ok(())
    }

    fn next_frame(&mut self) {
        self.generation += 1;
        self.frame += 1;
        self.prepared = None;
    }

    /// How workers carry their images into the frames after this one (each
    /// worker applies it when it starts its next frame):
    /// [`Accumulation::Reset`] by default. PT and BDPT keep or decay their
    /// samples; MLT and CMLT their frames' images, each normalised by the
    /// b it was rendered with and weighted by its records (independent of
    /// [`Temporal::keep_chains`], which carries the chains themselves).
    /// [`RenderError::Config`] for a decay factor outside (0, 1); nothing
    /// changes on error.
    pub fn set_accumulation(&mut self, mode: Accumulation) -> Result<(), RenderError> {
        mode.validate().map_err(RenderError::Config)?;
        self.accumulation = mode;
        Ok(())
    }

    /// The accumulation mode ([`Renderer::set_accumulation`]).
    pub fn accumulation(&self) -> Accumulation {
        self.accumulation
    }

    /// How many pixels each PT or BDPT sample of the passes begun from now
    /// on fills (`renderer/pixel_block.rs`): [`PixelBlock::Fixed`]`(1)`
    /// by default (full resolution), a host's dynamic resolution
    /// [`PixelBlock::Fixed`]`(k)`, or [`PixelBlock::Fit`] chosen from the
    /// workers' measured samples so that a frame below one
    /// full-resolution pass still shows a full image, of the image
    /// box-filtered over k × k blocks. May change every frame: a pass
    /// open at another size finishes first, unless the frame is reset
    /// ([`Accumulation::Reset`]), which drops it. MLT and CMLT render
    /// such passes of BDPT beside their chains at any size but 1 — the
    /// *block fill*, [`FILL_SHARE`] of a frame's work, mixed with the
    /// chains' splats pixel by pixel by fixed weights, so that a frame far
    /// below one mutation per pixel still shows a full image
    /// (`renderer/fill.rs`); at `Fixed(1)` they render their chains
    /// alone. [`RenderError::Config`] for a fixed size outside 1 ..=
    /// [`MAX_PIXEL_BLOCK`], or a block fill for MLT or CMLT whose samples
    /// would weigh nothing (`pass_records` = 0); nothing changes on error.
    pub fn set_pixel_block(&mut self, block: PixelBlock) -> Result<(), RenderError> {
        block.validate().map_err(RenderError::Config)?;
        if block != PixelBlock::Fixed(1)
            && self
                .config
                .estimator
                .mlt()
                .is_some_and(|m| !(m.pass_records > 0.0))
        {
            return Err(RenderError::Config(
                "MLT and CMLT weigh the pixel blocks' samples by pass_records, which is 0",
            ));
        }
        self.pixel_block = block;
        Ok(())
    }

    /// The pixel block ([`Renderer::set_pixel_block`]).
    pub fn pixel_block(&self) -> PixelBlock {
        self.pixel_block
    }

    /// The first of the three steps that make the renderer ready for
    /// `render` after creation, a camera change or a scene update (see the
    /// module docs): starts a new frame if the scene changed (a
    /// [`Scene::revision`] other than the one the frame was prepared for:
    /// meshes moved, as `set_camera` does), finds what the scene calls
    /// for, and returns whether the workers have bootstrap work to do —
    /// then every worker runs [`Renderer::prepare_worker`] (or
    /// [`Renderer::prepare_worker_while`]) and one thread
    /// [`Renderer::finish_prepare`]. `false` (already prepared, or PT and
    /// BDPT, which need no bootstrap): the renderer is ready. `scene` must
    /// be the one every `render` uses.
    ///
    /// With [`Temporal::keep_chains`], once a first bootstrap has been
    /// joined the renderer is ready at once: the kept chains go on under
    /// the new camera and scene with the b of the earlier frames, while a
    /// new bootstrap (fewer bootstrap samples: [`KEPT_BOOTSTRAP_SHARE`]) is
    /// evaluated in the background of the frames, in whatever pieces the
    /// host's `prepare_worker_while` calls allow, and joined by the
    /// `finish_prepare` after it is complete: b is tracked over the frames
    /// that bootstrap spanned. A bootstrap that is still being evaluated
    /// carries over a camera change or a scene update instead of starting
    /// again.
    pub fn begin_prepare(&mut self, scene: &Scene) -> bool {
        let revision = Some(scene.revision());
        if self.scene_revision.is_some() && self.scene_revision != revision {
            self.view_changed = true;
            self.next_frame();
        }
        self.scene_revision = revision;
        if self.pending.is_some() && self.boot_view != (self.camera, revision) {
            self.boot_one_view = false;
        }
        let fresh = self.prepared != Some(self.generation);
        if !fresh && self.pending.is_none() {
            return false;
        }
        if fresh {
            // The camera (its lens) may have changed with the frame; the
            // scene's materials never do while it is borrowed.
            self.analysis = if self.config.all_effects {
                Analysis::all()
            } else {
                scene.analysis(&self.camera)
            };
            self.settings = self.config.settings.specialised(&self.analysis);
        }
        let Some(mlt) = self.config.estimator.mlt().copied() else {
            self.prepared = Some(self.generation);
            return false;
        };
        let keep = self.config.temporal.keep_chains;
        // Without kept chains every frame's chains start from its own
        // bootstrap; with them a bootstrap under way goes on (unless the
        // analysis changed what it evaluates).
        let restart = match self.pending {
            None => true,
            Some(_) if keep => self.boot_settings != self.settings,
            Some(_) => self.pending_generation != self.generation,
        };
        if restart {
            // Kept chains need bootstrap samples only to restart the few a
            // new view leaves at zero (and those search further when none
            // of theirs contributes: `WorkerChains::reevaluate`), so a
            // bootstrap after the first draws a share of them. b comes
            // from the normalisation passes then, not from the bootstrap
            // samples.
            self.boot_mlt = if keep && self.has_bootstrap && mlt.b_passes > 0 {
                MltSettings {
                    n_bootstrap: (mlt.n_bootstrap / KEPT_BOOTSTRAP_SHARE).max(1),
                    ..mlt
                }
            } else {
                mlt
            };
            self.epochs += 1;
            self.pending = Some(self.epochs);
            self.pending_generation = self.generation;
            self.boot_settings = self.settings;
            self.boot_seed = self.frame_seed();
            self.boot_view = (self.camera, revision);
            self.boot_one_view = true;
        }
        if keep && self.has_bootstrap {
            self.prepared = Some(self.generation);
        }
        true
    }

    /// Worker `worker`'s share of the bootstrap begun by
    /// [`Renderer::begin_prepare`], evaluated to the end:
    /// [`Renderer::prepare_worker_while`] with a callback that always says
    /// yes.
    pub fn prepare_worker(
        &self,
        worker: &mut RenderWorker,
        scene: &Scene,
        accel: &dyn DynIntersector,
    ) -> Result<(), RenderError> {
        self.prepare_worker_while(worker, scene, accel, &mut |_| true)
            .map(|_| ())
    }

    /// Worker `worker`'s share of the bootstrap begun by
    /// [`Renderer::begin_prepare`]: the `i`-th of `W` contiguous ranges of
    /// bootstrap samples and of the normalisation passes' blocks
    /// ([`NORMALISATION_BLOCKS`]), into the worker's own storage, in pieces
    /// of [`PIECE`] bootstrap samples or pass pixels, asking `keep_going(units so far)` before every piece
    /// after the first. Returns whether the share is complete; when not,
    /// the next call goes on where this one stopped (in a later frame too,
    /// as long as the bootstrap is pending). The values are the same bit
    /// for bit however the share was cut. Workers may run it at the same
    /// time on different threads. Returns `Ok(true)` at once when no
    /// bootstrap is pending. Allocates nothing.
    pub fn prepare_worker_while(
        &self,
        worker: &mut RenderWorker,
        scene: &Scene,
        accel: &dyn DynIntersector,
        keep_going: &mut dyn FnMut(u64) -> bool,
    ) -> Result<bool, RenderError> {
        if worker.renderer != self.id {
            return Err(RenderError::Worker);
        }
        check_path_space(&self.config.estimator, scene)?;
        let Some(epoch) = self.pending else {
            return Ok(true);
        };
        if self.scene_revision != Some(scene.revision()) {
            return Err(RenderError::NotPrepared);
        }
        let Some(boot) = &mut worker.boot else {
            return Err(RenderError::Worker);
        };
        let (i, w) = (worker.index as u64, self.config.workers as u64);
        let (settings, mlt, seed) = (&self.boot_settings, &self.boot_mlt, self.boot_seed);
        let n = Bootstrap::sample_count(settings, mlt);
        let chunk = n.div_ceil(w);
        let range = (i * chunk).min(n)..((i + 1) * chunk).min(n);
        let depths = mlt::depths(settings) as usize;
        let pixels = self.pixels();
        let blocks = u64::from(mlt.normalisation_passes(pixels)) * NORMALISATION_BLOCKS;
        let own_blocks = block_share(i, w, blocks);
        if boot.epoch != Some(epoch) {
            boot.epoch = Some(epoch);
            boot.complete = false;
            boot.next_sample = range.start;
            boot.block = own_blocks.start;
            boot.step = 0;
            boot.values.clear();
            boot.blocks.clear();
            boot.pass_samples = 0;
            if let Some(image) = &mut boot.image {
                image.clear();
            }
            boot.image_added = false;
        }
        if boot.complete {
            return Ok(true);
        }
        let mut tracer = self.tracer(scene, &accel);
        let mut done = 0;
        loop {
            if done > 0 && !keep_going(done) {
                break;
            }
            if boot.next_sample < range.end {
                let end = (boot.next_sample + PIECE).min(range.end);
                bootstrap::evaluate_samples(
                    &mut tracer,
                    settings,
                    seed,
                    boot.next_sample..end,
                    &mut boot.ws,
                    &mut boot.sampler,
                    &mut boot.values,
                );
                done += end - boot.next_sample;
                boot.next_sample = end;
                continue;
            }
            if boot.block >= own_blocks.end {
                boot.complete = true;
                break;
            }
            // Block k of pass p: the pixels k + B·j of the pass, B =
            // NORMALISATION_BLOCKS (spread over the image, so that every
            // block costs about the same).
            let (pass, first) = (
                boot.block / NORMALISATION_BLOCKS,
                boot.block % NORMALISATION_BLOCKS,
            );
            let count = pixels.saturating_sub(first).div_ceil(NORMALISATION_BLOCKS);
            if boot.step == 0 {
                boot.blocks.resize(boot.blocks.len() + depths, 0.0);
            }
            let end = (boot.step + PIECE).min(count);
            let at = boot.blocks.len() - depths;
            for j in boot.step..end {
                let pixel = first + NORMALISATION_BLOCKS * j;
                bootstrap::evaluate_pass(
                    &mut tracer,
                    settings,
                    &mut boot.ws,
                    seed,
                    pass,
                    pixel..pixel + 1,
                    &mut boot.blocks[at..],
                    boot.image.as_mut(),
                );
            }
            boot.pass_samples += end - boot.step;
            done += end - boot.step;
            boot.step = end;
            if end == count {
                boot.step = 0;
                boot.block += 1;
            }
        }
        boot.stats.merge(&tracer.stats);
        Ok(boot.complete)
    }

    /// The last of the three steps: joins the shares of the bootstrap that
    /// `workers` evaluated ([`Renderer::prepare_worker`] for this frame) in
    /// index order — bootstrap samples by index, normalisation blocks' sums
    /// added in block order — so the bootstrap is the same for every split.
    /// Then the renderer is ready for `render`.
    ///
    /// `workers` must be all of the renderer's, in any order, each once;
    /// they are read one at a time (a host holding each worker behind its
    /// own lock hands over guards), so the host need not collect them.
    /// A worker missing, given twice or without its complete share is
    /// [`RenderError::BootstrapIncomplete`] and changes nothing — except
    /// when kept chains go on with an earlier bootstrap (see
    /// [`Renderer::begin_prepare`]): then an incomplete bootstrap is left
    /// pending for later frames and the call succeeds. Does nothing when
    /// no bootstrap is pending. Allocates nothing.
    pub fn finish_prepare<W: Deref<Target = RenderWorker>>(
        &mut self,
        workers: impl IntoIterator<Item = W>,
    ) -> Result<(), RenderError> {
        let Some(epoch) = self.pending else {
            return Ok(());
        };
        let carried = self.prepared == Some(self.generation);
        let pixels = self.pixels();
        let depths = mlt::depths(&self.boot_settings) as usize;
        let n = Bootstrap::sample_count(&self.boot_settings, &self.boot_mlt) as usize;
        let blocks = self.boot_mlt.normalisation_passes(pixels) as u64 * NORMALISATION_BLOCKS;
        let shares = &mut self.shares;
        shares.values.clear();
        shares.values.resize(n, 0.0);
        shares.blocks.clear();
        shares.blocks.resize(blocks as usize * depths, 0.0);
        shares.joined.fill(false);
        let w = self.config.workers as usize;
        let mut incomplete = false;
        // The workers' large steps of their last frame, once per frame,
        // committed only if the call succeeds.
        let track = self.has_bootstrap && self.tracked.begin(self.generation);
        for worker in workers {
            if worker.renderer != self.id {
                return Err(RenderError::Worker);
            }
            let i = worker.index as usize;
            if shares.joined[i] {
                return Err(RenderError::BootstrapIncomplete);
            }
            shares.joined[i] = true;
            if track && let Some(m) = &worker.mlt {
                self.tracked.take(i, worker.generation, m.large_steps());
            }
            let share = worker
                .boot
                .as_ref()
                .filter(|b| b.epoch == Some(epoch) && b.complete);
            let Some(share) = share else {
                incomplete = true;
                continue;
            };
            let start = (i * n.div_ceil(w)).min(n);
            shares.values[start..start + share.values.len()].copy_from_slice(&share.values);
            let at = block_share(i as u64, w as u64, blocks).start as usize * depths;
            shares.blocks[at..at + share.blocks.len()].copy_from_slice(&share.blocks);
        }
        if incomplete || shares.joined.contains(&false) {
            return if carried {
                if track {
                    self.track_b();
                }
                Ok(())
            } else {
                Err(RenderError::BootstrapIncomplete)
            };
        }
        shares.sums.clear();
        shares.sums.resize(depths, 0.0);
        for block in shares.blocks.chunks_exact(depths.max(1)) {
            bootstrap::add_pass(&mut shares.sums, block);
        }
        self.bootstrap.fill(
            &self.boot_settings,
            &self.boot_mlt,
            self.boot_seed,
            &shares.values,
            &shares.sums,
            pixels,
        );
        self.pending = None;
        self.has_bootstrap = true;
        self.joined_view =
            self.boot_one_view
                .then_some((epoch, self.boot_view.0, self.boot_view.1));
        self.push_b(self.bootstrap.b());
        if track {
            self.track_b();
        }
        self.prepared = Some(self.generation);
        Ok(())
    }

    /// Commits the frame of large steps `finish_prepare` took and sets b
    /// to the window's ([`Temporal::large_step_window`]), with the last
    /// joined bootstrap's passes standing in for the frames the window has
    /// not filled yet (`renderer/tracked_b.rs`).
    fn track_b(&mut self) {
        self.tracked.commit(self.generation);
        let pixels = self.pixels();
        let passes = u64::from(self.boot_mlt.normalisation_passes(pixels));
        let samples = if passes > 0 {
            passes * pixels
        } else {
            u64::from(self.boot_mlt.n_bootstrap)
        };
        self.b_used = self.tracked.b(self.bootstrap.depth_b(), samples);
    }

    /// Adds this frame's bootstrap estimate to the b window (restarted when
    /// the camera moved) and sets the b in use to the window's mean.
    fn push_b(&mut self, b: f64) {
        let window = self.config.temporal.b_window.max(1) as usize;
        if self.view_changed || window == 1 {
            self.b_count = 0;
            self.b_next = 0;
        }
        self.b_history[self.b_next] = b;
        self.b_next = (self.b_next + 1) % window;
        self.b_count = (self.b_count + 1).min(window);
        self.b_used = self.b_history[..self.b_count].iter().sum::<f64>() / self.b_count as f64;
    }

    /// Renders `budget` units (see the module docs) into `worker`, after
    /// starting its frame if the camera changed since its last call.
    /// Returns the units rendered: samples up to a pass's end (a pass left
    /// open by [`Renderer::render_while`] is finished first), or whole
    /// rounds · chains (0 when b = 0 leaves no chain to run, or when
    /// `budget` is 0; MLT and CMLT with a block fill then render its
    /// share of the rounds' work, `renderer/fill.rs`).
    pub fn render(
        &self,
        worker: &mut RenderWorker,
        scene: &Scene,
        accel: &dyn DynIntersector,
        budget: u64,
    ) -> Result<u64, RenderError> {
        let mut tracer = self.begin_render(worker, scene, &accel)?;
        let steps = if budget == 0 {
            0
        } else {
            match &worker.mlt {
                Some(m) => {
                    let chains = m.chain_count() as u64;
                    if chains == 0 {
                        0
                    } else {
                        budget.div_ceil(chains)
                    }
                }
                None => budget.div_ceil(self.pixels()),
            }
        };
        let done = self.run_steps(worker, &mut tracer, steps);
        worker.stats.merge(&tracer.stats);
        Ok(done)
    }

    /// The steps worker `index` renders for its share of
    /// [`Budget::PerPixel`]`(per_pixel)` over all workers: passes `index,
    /// index + W, …` below `per_pixel` (PT, BDPT), or
    /// [`mlt::rounds_for`]`(per_pixel, pixels, W, chains)` rounds on every
    /// worker (MLT, CMLT; at least one, none for 0).
    pub fn steps_for(&self, index: u32, per_pixel: u64) -> u64 {
        let w = self.config.workers as u64;
        match self.config.estimator.mlt() {
            Some(_) if per_pixel == 0 => 0,
            Some(m) => mlt::rounds_for(per_pixel, self.pixels(), w, m.n_chains as u64),
            None => per_pixel.saturating_sub(index as u64).div_ceil(w),
        }
    }

    /// Renders `steps` steps into `worker` — passes, the open one first
    /// (PT, BDPT), or whole rounds of every chain (MLT, CMLT) — after
    /// starting its frame if the camera changed since its last call. Returns the units rendered, as
    /// [`Renderer::render`] does; `render_steps(worker, …, n)` then
    /// `render_steps(worker, …, m)` equals `render_steps(worker, …, n + m)`.
    pub fn render_steps(
        &self,
        worker: &mut RenderWorker,
        scene: &Scene,
        accel: &dyn DynIntersector,
        steps: u64,
    ) -> Result<u64, RenderError> {
        let mut tracer = self.begin_render(worker, scene, &accel)?;
        let done = self.run_steps(worker, &mut tracer, steps);
        worker.stats.merge(&tracer.stats);
        Ok(done)
    }

    /// Checks a `render` call and, at a worker's first call of a frame,
    /// clears, keeps or decays its film ([`Accumulation`]; PT, BDPT) or
    /// restarts, re-evaluates or keeps its chains (MLT, CMLT). Returns the
    /// tracer the steps run with.
    fn begin_render<'a, I: Intersector>(
        &self,
        worker: &mut RenderWorker,
        scene: &'a Scene,
        accel: &'a I,
    ) -> Result<Tracer<'a, I>, RenderError> {
        if worker.renderer != self.id {
            return Err(RenderError::Worker);
        }
        if self.prepared != Some(self.generation) || self.scene_revision != Some(scene.revision()) {
            return Err(RenderError::NotPrepared);
        }
        check_path_space(&self.config.estimator, scene)?;
        let c = &self.config;
        let settings = &self.settings;
        let mut tracer = self.tracer(scene, accel);
        if worker.generation != Some(self.generation) {
            // The rays of this worker's set-up since its last frame count
            // towards this one.
            worker.stats = match &mut worker.boot {
                Some(b) => core::mem::take(&mut b.stats),
                None => Stats::default(),
            };
            let seed = self.frame_seed();
            // MLT, CMLT: the block fill carries as the chains' image does;
            // one that holds nothing and is not rendered is left alone.
            if worker.mlt.is_some() && (self.fill_on() || worker.weights.total() > 0.0) {
                self.next_pass_frame(worker);
            }
            if let (Some(m), Some(mlt)) = (&mut worker.mlt, c.estimator.mlt()) {
                // The ended frame's image, at the b it was rendered with,
                // into what the accumulation keeps of earlier frames.
                worker.kept.next_frame(
                    &worker.film,
                    worker.frame_b * self.pixels() as f64,
                    m.stats().records,
                    self.accumulation,
                );
                worker.film.clear();
                let kept =
                    c.temporal.keep_chains && worker.generation.is_some() && m.chain_count() > 0;
                if !kept {
                    m.restart(
                        &mut tracer,
                        settings,
                        mlt,
                        &self.bootstrap,
                        seed,
                        worker.index as u64,
                        c.workers as u64,
                    );
                } else if worker.camera != Some(self.camera)
                    || worker.scene_revision != self.scene_revision
                {
                    m.reevaluate(&mut tracer, settings, &self.bootstrap, seed);
                } else {
                    m.reset_stats();
                }
                // The passes' image of the bootstrap the frame's b comes
                // from joins the frame, weighed by `pass_records`
                // (`mlt/pass_image.rs`), once: without kept chains the
                // frame's own bootstrap's; with them the last joined one's,
                // if it ran entirely under this frame's camera and scene
                // (a bootstrap spread over moving frames images no one
                // view). Its records count once in all the frames' (a
                // still camera's kept frames weigh it as one offline
                // render of the same passes and mutations does); each b
                // refresh adds its own passes the same way.
                if let Some(boot) = &mut worker.boot
                    && let Some(image) = &mut boot.image
                    && boot.complete
                    && !boot.image_added
                    && self.b_used > 0.0
                {
                    if !c.temporal.keep_chains {
                        if boot.epoch == Some(self.epochs) {
                            m.add_pass_image(
                                &mut worker.film,
                                image,
                                boot.pass_samples,
                                mlt.pass_records,
                                self.b_used,
                            );
                            boot.image_added = true;
                        }
                    } else if let Some(epoch) = boot.epoch
                        && self.joined_view == Some((epoch, self.camera, self.scene_revision))
                    {
                        // Into the kept sums, which need no b: the weight
                        // stays exact if b changes within the frame.
                        let records = m.count_pass_records(boot.pass_samples, mlt.pass_records);
                        worker.kept.add_pass_image(
                            image,
                            boot.pass_samples,
                            records,
                            self.pixels(),
                        );
                        boot.image_added = true;
                    }
                }
            } else {
                self.next_pass_frame(worker);
            }
            worker.generation = Some(self.generation);
            worker.camera = Some(self.camera);
            worker.scene_revision = self.scene_revision;
        }
        worker.frame_b = self.b_used;
        Ok(tracer)
    }

    /// Starts a frame of `worker`'s passes (PT, BDPT; MLT and CMLT: the
    /// block fill): its film and sample weights cleared, kept or decayed
    /// ([`Accumulation`]), its last frame's samples kept for the fit.
    fn next_pass_frame(&self, worker: &mut RenderWorker) {
        let film = if worker.mlt.is_some() {
            &mut worker.fill
        } else {
            &mut worker.film
        };
        worker.weights.next_frame(film, self.accumulation);
        worker.last_frame_samples = worker.frame_samples;
        worker.frame_samples = 0;
        if self.accumulation == Accumulation::Reset {
            // A new accumulation: passes are numbered from 0 again.
            // An open pass of the frame's block size goes on from
            // where it stopped (with the streams of pass 0 for its
            // remaining pixels), so that frames ending inside
            // passes cover the image in turn. Another size, or a
            // fitted one (sized for the frame to complete it,
            // each worker starting its W-th of the order, after
            // the frame's guard pass), starts afresh.
            worker.passes = 0;
            if worker.guard || self.pixel_block != PixelBlock::Fixed(worker.block) {
                worker.cursor = 0;
                worker.pass_end = 0;
                worker.guard = false;
            }
            worker.guard_due = self.pixel_block == PixelBlock::Fit && worker.last_frame_samples > 0;
        }
        worker.front = if worker.mlt.is_some() && self.pixel_block == PixelBlock::Fit {
            Front::Due
        } else {
            Front::Done
        };
    }

    /// MLT, CMLT: whether frames render the block fill
    /// (`renderer/fill.rs`): a pixel block other than full resolution and
    /// a fill sample that weighs something (`pass_records` > 0).
    fn fill_on(&self) -> bool {
        self.pixel_block != PixelBlock::Fixed(1)
            && self
                .config
                .estimator
                .mlt()
                .is_some_and(|m| m.pass_records > 0.0)
    }

    /// MLT, CMLT: the fill samples `worker` owes once it has made
    /// `ahead` more mutations (0 with the fill off).
    fn fill_owed(&self, worker: &RenderWorker, ahead: u64) -> u64 {
        match (&worker.mlt, self.config.estimator.mlt()) {
            (Some(m), Some(s)) if self.fill_on() => {
                let coarsest =
                    BlockGrid::new(self.camera.width(), self.camera.height(), MAX_PIXEL_BLOCK);
                let minimum = coarsest
                    .count()
                    .div_ceil(u64::from(self.config.workers))
                    .max(PIECE);
                let owed = fill::owed(
                    m.stats().mutations + ahead,
                    s.pass_records,
                    minimum,
                    worker.frame_samples,
                );
                // The frame's first fitted pass (its guard first) before
                // any further mutation.
                let front = match worker.front {
                    Front::Due => PIECE,
                    Front::Until(end) => end.saturating_sub(worker.frame_samples),
                    Front::Done => 0,
                };
                owed.max(front)
            }
            _ => 0,
        }
    }

    /// MLT, CMLT: ρ′ · P, the records a fill sample's pixel weight counts
    /// for in a pixel (`renderer/fill.rs`): `pass_records` times 1 + s,
    /// times the pixels.
    fn fill_rho_pixels(&self) -> f64 {
        let Some(m) = self.config.estimator.mlt() else {
            return 0.0;
        };
        let s = self.config.estimator.level2().map_or(0, |l2| l2.share());
        f64::from(m.pass_records) * f64::from(1 + s) * self.pixels() as f64
    }

    /// Runs `steps` steps into a worker `begin_render` readied — rounds
    /// (MLT, CMLT), or (PT, BDPT) the samples up to the end of the open
    /// pass, or of the next when none is open; returns the units rendered.
    fn run_steps<I: Intersector>(
        &self,
        worker: &mut RenderWorker,
        tracer: &mut Tracer<'_, I>,
        steps: u64,
    ) -> u64 {
        if let Some(m) = &mut worker.mlt {
            let done = m.run(tracer, &self.settings, &mut worker.film, steps);
            // The block fill's share of the rounds' work, after them
            // (`renderer/fill.rs`; none for no rounds).
            if done > 0 {
                loop {
                    let owed = self.fill_owed(worker, 0);
                    if owed == 0 {
                        break;
                    }
                    self.run_samples(worker, tracer, owed, false);
                }
            }
            return done;
        }
        let mut done = 0;
        for _ in 0..steps {
            done += self.run_samples(worker, tracer, u64::MAX, false);
        }
        done
    }

    /// PT, BDPT: renders the next `count` samples of the worker's passes
    /// (at most to the end of the open pass) — pass `i + W·passes`, from
    /// the cursor on in the pass's order — and returns how many. A pass
    /// begun here takes its block size from [`Renderer::set_pixel_block`]
    /// and visits its pixels (blocks) row-major, or with `strided` in the
    /// order of [`Renderer::stride`], worker `i` of `W` starting at
    /// position `⌊i · n / W⌋` of the n: the workers' partial passes then
    /// cover the image together instead of the same part of it. A reset
    /// frame with the fitted size begins with the worker's share of the
    /// frame's guard pass.
    fn run_samples<I: Intersector>(
        &self,
        worker: &mut RenderWorker,
        tracer: &mut Tracer<'_, I>,
        count: u64,
        strided: bool,
    ) -> u64 {
        let c = &self.config;
        let workers = c.workers as u64;
        if worker.pass_end == 0 {
            self.begin_pass(worker, strided);
        }
        let grid = BlockGrid::new(self.camera.width(), self.camera.height(), worker.block);
        let n = grid.count();
        let order = if worker.strided || worker.guard {
            PassOrder {
                count: n,
                stride: mlt::coprime_stride(n as usize) as u64,
                offset: if worker.guard {
                    0
                } else {
                    worker.index as u64 * n / workers
                },
            }
        } else {
            PassOrder {
                count: n,
                stride: 1,
                offset: 0,
            }
        };
        let end = worker.cursor.saturating_add(count).min(worker.pass_end);
        let (pass, weight) = if worker.guard {
            (pixel_block::GUARD_PASS, pixel_block::GUARD_WEIGHT)
        } else {
            (worker.index as u64 + workers * worker.passes, 1.0)
        };
        let pt = c.estimator.kind() == EstimatorKind::Path;
        let seed = self.frame_seed();
        // MLT and CMLT render their block fill with these passes.
        let film = if worker.mlt.is_some() {
            &mut worker.fill
        } else {
            &mut worker.film
        };
        if worker.block == 1 {
            render_samples(
                tracer,
                &self.settings,
                pt,
                &mut worker.bdpt,
                (seed, pass),
                (worker.cursor..end, order),
                film,
                &mut worker.weights,
            );
        } else {
            pixel_block::render_block_samples(
                tracer,
                &self.settings,
                pt,
                &mut worker.bdpt,
                (seed, pass, weight),
                (worker.cursor..end, order, grid),
                film,
                &mut worker.weights,
            );
        }
        let done = end - worker.cursor;
        worker.cursor = end;
        worker.frame_samples += done;
        if end == worker.pass_end {
            if !worker.guard {
                // The film counts full-resolution passes only: its own
                // `Film::resolve` is the image only of those.
                if worker.block == 1 {
                    film.end_pass();
                }
                worker.passes += 1;
            }
            worker.guard = false;
            worker.cursor = 0;
            worker.pass_end = 0;
        }
        done
    }

    /// Opens `worker`'s next pass: its block size, and where it starts
    /// and ends — the whole pass, or the worker's W-th of a guard pass at
    /// [`pixel_block::GUARD_FACTOR`] times the fitted size, at most
    /// [`pixel_block::MAX_GUARD_BLOCK`] (skipped when that is no coarser).
    fn begin_pass(&self, worker: &mut RenderWorker, strided: bool) {
        let (w, h) = (self.camera.width(), self.camera.height());
        worker.strided = strided;
        worker.block = self.block_for(worker);
        worker.guard = false;
        if core::mem::take(&mut worker.guard_due) {
            let g = (worker.block * pixel_block::GUARD_FACTOR).min(pixel_block::MAX_GUARD_BLOCK);
            let n = BlockGrid::new(w, h, g).count();
            let (i, workers) = (worker.index as u64, self.config.workers as u64);
            let share = (i * n / workers)..((i + 1) * n / workers);
            if g > worker.block && !share.is_empty() {
                worker.block = g;
                worker.guard = true;
                worker.cursor = share.start;
                worker.pass_end = share.end;
                return;
            }
        }
        worker.cursor = 0;
        worker.pass_end = BlockGrid::new(w, h, worker.block).count();
        if worker.front == Front::Due {
            // The whole pass: fitted to this worker's forecast alone.
            worker.front = Front::Until(worker.frame_samples + worker.pass_end);
        }
    }

    /// The block size of the pass `worker` begins (`renderer/pixel_block.rs`):
    /// the fixed one, or the finest whose grid the accumulation can fill —
    /// at most W · (T + margin · r) blocks (W = 1 for a block fill), T the
    /// worker's sample weight now, r what its last frame rendered beyond
    /// this frame's samples so far.
    fn block_for(&self, worker: &RenderWorker) -> u32 {
        match self.pixel_block {
            PixelBlock::Fixed(k) => k,
            PixelBlock::Fit => {
                let left = worker
                    .last_frame_samples
                    .saturating_sub(worker.frame_samples);
                // The workers' passes complement one another only at one
                // block size, which workers fitting their own forecasts
                // need not reach; a block fill, whose few samples make k
                // differ from worker to worker more often, fits each
                // worker's pass to its own forecast (`renderer/fill.rs`).
                let workers = if worker.mlt.is_some() {
                    1.0
                } else {
                    self.config.workers as f64
                };
                let capacity = workers * (worker.weights.total() + FIT_MARGIN * left as f64);
                pixel_block::fit(self.camera.width(), self.camera.height(), capacity)
            }
        }
    }

    /// [`Renderer::render`] in pieces, asking `keep_going(units_so_far)`
    /// before every piece after the first, up to `budget` units: how a
    /// host bounds a frame by its own clock (the core never reads time, so
    /// it stays `no_std`). A piece is [`PIECE`] camera samples (PT, BDPT:
    /// a frame may end inside a pass, whose samples count per pixel, and
    /// the next call goes on from there) or [`PIECE`] level-1 mutations
    /// with their side chains (MLT, CMLT: a frame may end inside a round,
    /// whose chains are then visited in a strided order that keeps the
    /// depths of a partial round in proportion, `WorkerChains::advance`).
    /// A pass begun here visits the pixels in a strided order
    /// ([`Renderer::stride`]) rather than row by row, so that a frame that
    /// ends inside it has samples spread over the whole image, not a band
    /// at the top; whole passes differ from `render`'s only in the order
    /// BDPT's splats are added (rounding). MLT and CMLT with a block
    /// fill ([`Renderer::set_pixel_block`]) render its samples in such
    /// passes too, [`PIECE`] at a time before the mutations they pair
    /// with (`renderer/fill.rs`), and count them as units. The image then
    /// depends on how many pieces the clock allowed. Returns the units
    /// rendered.
    pub fn render_while(
        &self,
        worker: &mut RenderWorker,
        scene: &Scene,
        accel: &dyn DynIntersector,
        budget: u64,
        keep_going: &mut dyn FnMut(u64) -> bool,
    ) -> Result<u64, RenderError> {
        let mut tracer = self.begin_render(worker, scene, &accel)?;
        let mut done = 0;
        while done < budget {
            if done > 0 && !keep_going(done) {
                break;
            }
            // MLT, CMLT: the block fill's share before the mutations it
            // pairs with (`renderer/fill.rs`).
            let owed = self.fill_owed(worker, PIECE);
            let step = match &mut worker.mlt {
                Some(_) if owed > 0 => self.run_samples(worker, &mut tracer, owed.min(PIECE), true),
                Some(m) => m.advance(
                    &mut tracer,
                    &self.settings,
                    &mut worker.film,
                    PIECE as usize,
                    true,
                ),
                None => self.run_samples(worker, &mut tracer, PIECE, true),
            };
            if step == 0 {
                break;
            }
            done += step;
        }
        worker.stats.merge(&tracer.stats);
        Ok(done)
    }

    /// Merges `workers`' films (in the given order) into the image and
    /// hands each pixel to `out(index, colour)`, row-major, row 0 at the
    /// top. Workers that have not rendered since the last camera change
    /// add nothing; before any rendering the image is black.
    pub fn resolve(
        &self,
        workers: &[&RenderWorker],
        mut out: impl FnMut(usize, Rgb),
    ) -> Result<(), RenderError> {
        if workers.iter().any(|w| w.renderer != self.id) {
            return Err(RenderError::Worker);
        }
        let mut totals = Totals::default();
        for w in workers {
            totals.add(self, w);
        }
        let scale = self.scale(&totals);
        for i in 0..self.pixels() as usize {
            let mut sum = Layers::default();
            for w in workers.iter().filter(|w| self.is_current(w)) {
                sum.add(w, i);
            }
            out(i, self.pixel(&sum, &totals, scale));
        }
        Ok(())
    }

    /// Storage for [`Renderer::accumulate`]: the merged image in f64, its
    /// sample and splat layers apart (48 bytes per pixel).
    pub fn accumulator(&self) -> Accumulator {
        Accumulator {
            renderer: self.id,
            sums: alloc::vec![Layers::default(); self.pixels() as usize],
            totals: Totals::default(),
        }
    }

    /// Adds one worker's film and counters into `acc` — the worker-major
    /// form of [`Renderer::resolve`], for hosts that lock one worker at a
    /// time. [`Renderer::finish`] then writes the image. Allocates nothing.
    pub fn accumulate(
        &self,
        acc: &mut Accumulator,
        worker: &RenderWorker,
    ) -> Result<(), RenderError> {
        if worker.renderer != self.id || acc.renderer != self.id {
            return Err(RenderError::Worker);
        }
        if self.is_current(worker) {
            for (i, s) in acc.sums.iter_mut().enumerate() {
                s.add(worker, i);
            }
        }
        acc.totals.add(self, worker);
        Ok(())
    }

    /// Writes the image accumulated in `acc` through `out` (as
    /// [`Renderer::resolve`] does) and empties `acc` for the next frame.
    pub fn finish(
        &self,
        acc: &mut Accumulator,
        mut out: impl FnMut(usize, Rgb),
    ) -> Result<(), RenderError> {
        if acc.renderer != self.id {
            return Err(RenderError::Worker);
        }
        let scale = self.scale(&acc.totals);
        for (i, s) in acc.sums.iter_mut().enumerate() {
            out(i, self.pixel(s, &acc.totals, scale));
            *s = Layers::default();
        }
        acc.totals = Totals::default();
        Ok(())
    }

    /// The counters of `workers` since the last camera change.
    pub fn stats(&self, workers: &[&RenderWorker]) -> RenderStats {
        let mut s = RenderStats::default();
        for w in workers {
            s.merge(&self.worker_stats(w));
        }
        s
    }

    /// One worker's counters since the last camera change (zero for a
    /// worker of another renderer or one that has not rendered since);
    /// `b` is the renderer's.
    pub fn worker_stats(&self, w: &RenderWorker) -> RenderStats {
        let mut s = RenderStats {
            b: if self.config.estimator.is_metropolis() {
                self.b_used
            } else {
                0.0
            },
            ..RenderStats::default()
        };
        if w.renderer == self.id && self.is_current(w) {
            s.tracer = w.stats;
            s.passes = w.passes;
            s.nonfinite = w.film.nonfinite() + w.fill.nonfinite();
            if let Some(m) = &w.mlt {
                s.mlt = *m.stats();
            }
        }
        s
    }

    /// A tracer for one call: the current camera, specialised to the
    /// analysis.
    fn tracer<'a, I: Intersector>(&self, scene: &'a Scene, accel: &'a I) -> Tracer<'a, I> {
        Tracer::new(scene, accel)
            .with_camera(self.camera)
            .with_analysis(self.analysis)
    }

    fn pixels(&self) -> u64 {
        self.camera.pixel_count()
    }

    /// The step of the order in which a full-resolution pass begun by
    /// [`Renderer::render_while`] visits the pixels: worker `i` of `W`'s
    /// k-th sample is in pixel `((k + ⌊i·P/W⌋) mod P) · stride mod P`
    /// (row-major index; a pass at a coarser grid orders its blocks the
    /// same way with their own stride). The stride is the odd number
    /// nearest P·(√5 − 1)/2 that is coprime with P (the order is a
    /// permutation); golden-ratio steps spread any run of the order
    /// evenly over the image (Weyl's sequence), and the workers' runs
    /// start a W-th of the order apart.
    pub fn stride(&self) -> u64 {
        mlt::coprime_stride(self.pixels() as usize) as u64
    }

    /// Whether `w`'s film belongs to the current accumulation.
    fn is_current(&self, w: &RenderWorker) -> bool {
        w.generation == Some(self.generation)
    }

    /// The factor from summed films to radiance of MLT and CMLT: b ·
    /// pixels / records; 0 before anything was rendered (PT and BDPT
    /// normalise per pixel: [`Renderer::pixel`]).
    fn scale(&self, t: &Totals) -> f64 {
        if self.config.estimator.is_metropolis() {
            mlt::image_scale(self.b_used, self.pixels(), t.records)
        } else {
            0.0
        }
    }

    /// One merged pixel's radiance: its sums times the Metropolis `scale`
    /// (mixed with the block fill's by `fill::mix` when there is one),
    /// or (PT, BDPT) its camera samples over its sample weight and its
    /// splats over the whole image's (see `renderer/accumulation.rs`) —
    /// after whole passes both are the pass count and the pixel is (samples
    /// + splats) / passes.
    fn pixel(&self, l: &Layers, t: &Totals, scale: f64) -> Rgb {
        if self.config.estimator.is_metropolis() {
            if t.samples > 0.0 {
                // With the block fill (`renderer/fill.rs`).
                let b_pixels = self.b_used * self.pixels() as f64;
                let s = l.total();
                return scaled(
                    fill::mix(
                        core::array::from_fn(|c| l.kept[c] + s[c] * b_pixels),
                        t.kept_records + t.records as f64,
                        (l.fill_samples, l.fill_splats, l.weight),
                        t.samples,
                        self.fill_rho_pixels(),
                        self.pixels() as f64,
                    ),
                    1.0,
                );
            }
            if !t.kept {
                return scaled(l.total(), scale);
            }
            // The records-weighted mean of the kept frames' images and
            // this frame's (`renderer/accumulation.rs`).
            let b_pixels = self.b_used * self.pixels() as f64;
            let s = l.total();
            let inv = 1.0 / (t.kept_records + t.records as f64);
            return scaled(
                [
                    l.kept[0] + s[0] * b_pixels,
                    l.kept[1] + s[1] * b_pixels,
                    l.kept[2] + s[2] * b_pixels,
                ],
                inv,
            );
        }
        let inv = |w: f64| if w > 0.0 { 1.0 / w } else { 0.0 };
        let splat_weight = t.samples / self.pixels() as f64;
        if l.weight == splat_weight {
            scaled(l.total(), inv(l.weight))
        } else {
            let (a, b) = (inv(l.weight), inv(splat_weight));
            let (s, p) = (l.samples, l.splats);
            scaled(
                [
                    s[0] * a + p[0] * b,
                    s[1] * a + p[1] * b,
                    s[2] * a + p[2] * b,
                ],
                1.0,
            )
        }
    }
}

/// Renders the samples `range` of pass `pass` into `film`, counting them
/// in `weights`, by path tracing (`pt`) or BDPT: the step of PT and BDPT
/// (the Metropolis estimators' normalisation passes are
/// `mlt::bootstrap`'s), at full resolution (coarser passes:
/// `pixel_block::render_block_samples`). Sample k is in pixel
/// `order.at(k)` (row-major for stride 1 and offset 0). Consecutive
/// ranges render exactly what the whole pass renders.
///
/// The random stream of each sample depends only on `(seed, pass, pixel)`,
/// so the same passes give the same samples whichever worker renders them.
#[allow(clippy::too_many_arguments)]
fn render_samples<I: Intersector>(
    tracer: &mut Tracer<'_, I>,
    settings: &Settings,
    pt: bool,
    paths: &mut bdpt::PathStorage,
    (seed, pass): (u64, u64),
    (range, order): (core::ops::Range<u64>, PassOrder),
    film: &mut Film,
    weights: &mut Weights,
) {
    let w = tracer.camera.width() as u64;
    for k in range {
        let i = order.at(k);
        let (x, y) = ((i % w) as u32, (i / w) as u32);
        let mut rng = SampleStream::new(seed, pass, i);
        let raster = Vec2::new(x as f32, y as f32) + rng.next_2d();
        if pt {
            let ray = tracer.camera_ray(raster, rng.next_2d());
            let l = pt::radiance(tracer, settings, ray, &mut rng);
            film.add_sample(x, y, l);
        } else {
            bdpt::sample(tracer, settings, paths, raster, x, y, &mut rng, film);
        }
        weights.add(i as usize);
        tracer.stats.samples += 1;
    }
}

/// The normalisation blocks worker `i` of `w` evaluates out of `blocks`
/// (see [`NORMALISATION_BLOCKS`]): the `i`-th of `w` contiguous runs, of
/// sizes differing by at most one.
fn block_share(i: u64, w: u64, blocks: u64) -> core::ops::Range<u64> {
    let w = w.max(1);
    (i * blocks / w)..((i + 1) * blocks / w)
}

/// Refuses a scene the path-space level 1 of MLT and CMLT does not render
/// right: one with smooth plastic, whose coating is a Dirac lobe beside a
/// smooth one. f(x̄) cannot evaluate a path through that lobe
/// (`mlt::path_space::state`), so the chains never take the coating's
/// reflections and b spreads their energy over the rest: on
/// `tests/scenes/plastics` the smooth plastic's 4×4 block came out 12 %
/// short (14.7 standard errors over 8 seeds) and the rest 1–2 % bright
/// (`docs/accuracy.md`, "The path-space level 1 and CMLT over it").
/// The primary-sample level 1, whose target is BDPT's, renders it.
fn check_path_space(estimator: &Estimator, scene: &Scene) -> Result<(), RenderError> {
    let path_space = estimator
        .mlt()
        .is_some_and(|m| m.level1 != crate::mlt::Level1::PrimarySample);
    if path_space && scene.has_mixed_dirac_lobes() {
        return Err(RenderError::Config(
            "smooth plastic (a Dirac coating over a smooth base) is not rendered by the \
             path-space level 1 (its paths through the coating are missing): use the \
             primary-sample level 1 (--level1 primary)",
        ));
    }
    Ok(())
}

/// Refuses a thin-lens camera when the lens code is not built (a scene's
/// own camera is already checked by `SceneBuilder::build`).
fn check_lens(camera: &Camera) -> Result<(), RenderError> {
    if camera.has_lens() && !Effect::DepthOfField.is_built() {
        return Err(RenderError::EffectNotBuilt(Effect::DepthOfField));
    }
    Ok(())
}

/// The sample weight (PT, BDPT; MLT, CMLT: the block fill's) and
/// Metropolis records of the current accumulation: the current frame's
/// and the kept frames'.
#[derive(Clone, Copy, Debug, Default)]
struct Totals {
    samples: f64,
    records: u64,
    kept_records: f64,
    /// Whether any worker keeps anything ([`Kept::is_empty`]).
    kept: bool,
}

impl Totals {
    fn add(&mut self, r: &Renderer, w: &RenderWorker) {
        if w.renderer == r.id && r.is_current(w) {
            self.samples += w.weights.total();
            self.records += w.mlt.as_ref().map_or(0, |m| m.stats().records);
            self.kept_records += w.kept.records();
            self.kept |= !w.kept.is_empty();
        }
    }
}

fn scaled(total: [f64; 3], scale: f64) -> Rgb {
    Rgb::new(
        (total[0] * scale) as f32,
        (total[1] * scale) as f32,
        (total[2] * scale) as f32,
    )
}

/// One pixel of several films merged: the camera-sample and splat sums
/// added layer by layer and the two only at the end, as merging films and
/// resolving the result does ([`Film::merge`], [`Film::resolve`]), so a
/// host merging films itself gets the same image bit for bit.
#[derive(Clone, Copy, Debug, Default)]
struct Layers {
    samples: [f64; 3],
    splats: [f64; 3],
    /// PT, BDPT: the pixel's sample weight.
    weight: f64,
    /// MLT, CMLT: the kept frames' sums (`accumulation::Kept`).
    kept: [f64; 3],
    /// MLT, CMLT: the block fill's camera-side sums and splats
    /// (`renderer/fill.rs`; its pixel weight is `weight`).
    fill_samples: [f64; 3],
    fill_splats: [f64; 3],
}

impl Layers {
    fn add(&mut self, worker: &RenderWorker, pixel: usize) {
        let (s, p) = worker.film.pixel_parts(pixel);
        for c in 0..3 {
            self.samples[c] += s[c];
            self.splats[c] += p[c];
        }
        // Layers that hold nothing are not read: a resolve is bound by
        // the bytes it reads (MLT at 640 × 360: two films, kept sums and
        // weights per worker).
        if !worker.kept.is_empty() {
            for (sum, k) in self.kept.iter_mut().zip(worker.kept.at(pixel)) {
                *sum += k;
            }
        }
        if worker.weights.total() == 0.0 {
            return;
        }
        self.weight += worker.weights.at(pixel);
        if worker.mlt.is_some() {
            let (s, p) = worker.fill.pixel_parts(pixel);
            for c in 0..3 {
                self.fill_samples[c] += s[c];
                self.fill_splats[c] += p[c];
            }
        }
    }

    fn total(&self) -> [f64; 3] {
        let (s, p) = (self.samples, self.splats);
        [s[0] + p[0], s[1] + p[1], s[2] + p[2]]
    }
}

/// The merged image of a worker-major resolve ([`Renderer::accumulate`]).
pub struct Accumulator {
    renderer: usize,
    sums: Vec<Layers>,
    totals: Totals,
}

impl RenderStats {
    /// Adds another worker's counters (b is kept from either).
    pub fn merge(&mut self, o: &RenderStats) {
        self.tracer.merge(&o.tracer);
        self.mlt.merge(&o.mlt);
        self.passes += o.passes;
        self.nonfinite += o.nonfinite;
        self.b = if o.b != 0.0 { o.b } else { self.b };
    }
}

impl RenderWorker {
    /// Worker `index` of `renderer` (index < `workers`), with all the
    /// storage its renders need.
    pub fn new(renderer: &Renderer, index: u32) -> Result<Self, RenderError> {
        let c = &renderer.config;
        if index >= c.workers {
            return Err(RenderError::Worker);
        }
        let depth = c.max_depth();
        let camera = &renderer.camera;
        let mlt = c.estimator.mlt();
        let level2 = c.estimator.level2();
        Ok(RenderWorker {
            renderer: renderer.id,
            index,
            generation: None,
            camera: None,
            scene_revision: None,
            film: Film::new(camera.width(), camera.height()),
            weights: Weights::new(camera.pixel_count() as usize),
            fill: if mlt.is_some() {
                Film::new(camera.width(), camera.height())
            } else {
                Film::new(0, 0)
            },
            kept: Kept::new(if mlt.is_some() {
                camera.pixel_count() as usize
            } else {
                0
            }),
            frame_b: 0.0,
            cursor: 0,
            pass_end: 0,
            guard: false,
            guard_due: false,
            front: Front::Done,
            strided: false,
            block: 1,
            frame_samples: 0,
            last_frame_samples: 0,
            bdpt: bdpt::PathStorage::with_capacity(depth),
            mlt: mlt.map(|m| WorkerChains::with_capacity(&c.settings, m, level2, camera)),
            boot: mlt.map(|m| {
                // The largest share of a bootstrap: the bootstrap samples of a
                // first frame, and a W-th of the normalisation blocks.
                let w = c.workers as u64;
                let boot_samples = Bootstrap::sample_count(&c.settings, m).div_ceil(w);
                let blocks = (m.normalisation_passes(camera.pixel_count()) as u64
                    * NORMALISATION_BLOCKS)
                    .div_ceil(w)
                    * depth as u64;
                WorkerBootstrap {
                    epoch: None,
                    complete: false,
                    next_sample: 0,
                    block: 0,
                    step: 0,
                    values: Vec::with_capacity(boot_samples as usize),
                    blocks: Vec::with_capacity(blocks as usize),
                    pass_samples: 0,
                    image: (m.pass_records > 0.0 && blocks > 0)
                        .then(|| Film::new(camera.width(), camera.height())),
                    image_added: false,
                    stats: Stats::default(),
                    ws: bdpt::PathStorage::with_capacity(depth),
                    sampler: PrimarySampler::with_capacity(0, m.sigma, m.large_step_prob, depth),
                }
            }),
            passes: 0,
            stats: Stats::default(),
        })
    }

    /// This worker's index.
    pub fn index(&self) -> u32 {
        self.index
    }

    /// This worker's film (unscaled sums; resolve through the renderer).
    pub fn film(&self) -> &Film {
        &self.film
    }

    /// MLT, CMLT: this worker's large steps by path depth in the current
    /// frame (since its chains were started, re-evaluated or last kept
    /// into a new frame), an independent estimate of b by depth that a
    /// host can merge across workers and frames; `None` for PT and BDPT.
    pub fn large_steps(&self) -> Option<&LargeStepTally> {
        self.mlt.as_ref().map(WorkerChains::large_steps)
    }
}

//! The frame loop: a renderer over a committed scene with a fixed
//! resolution and a number of workers (one per host thread or job — the
//! library starts no threads). Per frame: optionally `set_camera`, then
//! the core's one preparation — `prepare_begin`, `prepare_worker` for each
//! worker (concurrently, on the host's threads, if it likes) and
//! `prepare_finish`, or `prepare`, which runs those three on the calling
//! thread — then `render` each worker (concurrently from different threads
//! if the host likes), then `resolve` into the host's buffer. Everything
//! is allocated by `cmlt_renderer_new`; the frame calls allocate nothing.
//! The estimators and budgets are the core's ([`Estimator`]:
//! `CMLT_ESTIMATOR_*` are [`EstimatorKind`]'s discriminants, the flat
//! config's fields the variants' settings;
//! `cmlt_core::renderer::Budget`: `cmlt_renderer_render_per_pixel`, and
//! `cmlt_renderer_render_while` with the host's clock for seconds).

use std::ffi::c_void;
use std::sync::{Arc, RwLock};

use cmlt_core::aov::{self, AovBuffers, AovFormat, AovLayer};
use cmlt_core::film::PixelFormat;
use cmlt_core::integrator::LobeCounts;
use cmlt_core::mlt::{
    Candidates, CmltSettings, Level1, Level2Settings, MltSettings, PathMutations, Splatting,
};
use cmlt_core::renderer::{
    Accumulation, Estimator, EstimatorKind, PixelBlock, RenderError, RenderStats, RenderWorker,
    Renderer, RendererConfig, Temporal,
};

use crate::alloc::{check_oom, measure_allocations, system_can_give, try_reserve};
use crate::error::{Error, Result, cmlt_status, guard, read, write};
use crate::scene::{Accel, Committed, cmlt_camera, cmlt_scene};

/// Path tracing with next-event estimation and MIS (`Estimator::Path`).
pub const CMLT_ESTIMATOR_PT: u32 = 0;
/// Bidirectional path tracing with MIS (`Estimator::Bdpt`).
pub const CMLT_ESTIMATOR_BDPT: u32 = 1;
/// Metropolis light transport: Kelemen mutations over BDPT
/// (`Estimator::Mlt`).
pub const CMLT_ESTIMATOR_MLT: u32 = 2;
/// Coherent MLT: MLT plus lens, caustic and multi-chain perturbations
/// traced as packets (`Estimator::Cmlt`).
pub const CMLT_ESTIMATOR_CMLT: u32 = 3;

// The constants are the core's `EstimatorKind` discriminants (literals
// here so that cbindgen writes them into the header).
const _: () = assert!(
    CMLT_ESTIMATOR_PT == EstimatorKind::Path as u32
        && CMLT_ESTIMATOR_BDPT == EstimatorKind::Bdpt as u32
        && CMLT_ESTIMATOR_MLT == EstimatorKind::Mlt as u32
        && CMLT_ESTIMATOR_CMLT == EstimatorKind::Cmlt as u32
);

/// CMLT: each step records every candidate with its one-proposal
/// acceptance and the current state with the rest (unbiased; the default).
pub const CMLT_SPLATTING_RECYCLED: u32 = 0;
/// CMLT: each step records the chosen candidate with its acceptance a and
/// the current state with 1 − a (unbiased).
pub const CMLT_SPLATTING_EXPECTED_VALUE: u32 = 1;

/// MLT: level 1 in Kelemen et al.'s primary sample space (the default).
pub const CMLT_LEVEL1_PRIMARY_SAMPLE: u32 = 0;
/// MLT and CMLT: level 1 in Veach's path space, with the bidirectional
/// and lens subpath mutations and Veach's perturbations.
pub const CMLT_LEVEL1_PATH_SPACE: u32 = 1;

/// Every frame starts a new accumulation (the default).
pub const CMLT_ACCUMULATION_RESET: u32 = 0;
/// Frames add to the earlier ones (converges while the camera and scene
/// stay; smears when they move).
pub const CMLT_ACCUMULATION_KEEP: u32 = 1;
/// Earlier frames weigh `decay` per frame of age (an exponential moving
/// average).
pub const CMLT_ACCUMULATION_DECAY: u32 = 2;

/// `cmlt_renderer_set_pixel_block`: the block size chosen from the
/// workers' measured samples (dynamic resolution within the frame's time).
pub const CMLT_PIXEL_BLOCK_FIT: u32 = 0;

/// Linear RGB, 3 × `float` per pixel.
pub const CMLT_FORMAT_RGB32F: u32 = 0;
/// sRGB-encoded RGBA, 4 × `uint8_t` per pixel, alpha 255 (each channel
/// clamped to [0, 1], sRGB-encoded and rounded to nearest).
pub const CMLT_FORMAT_RGBA8_SRGB: u32 = 1;
/// Linear RGBA, 4 × `float` per pixel, alpha 1.
pub const CMLT_FORMAT_RGBA32F: u32 = 2;
/// Linear RGBA, 4 × IEEE 754 binary16 (half) per pixel, alpha 1, rounded
/// to nearest even (a GPU's `R16G16B16A16_FLOAT`; values past 65504
/// become +∞).
pub const CMLT_FORMAT_RGBA16F: u32 = 3;

/// What fixes a renderer. Start from `cmlt_renderer_config_default`.
///
/// `estimator` picks the estimator, and with it the fields it reads: every
/// estimator reads the size, `workers`, `max_depth`, `depth_cap`, `seed`,
/// `fixed_sequence` and `all_effects`; MLT and CMLT also the fields marked
/// "MLT" (and `keep_chains`, `b_window`); CMLT alone those marked "CMLT".
/// A field the estimator does not read must keep the value
/// `cmlt_renderer_config_default` gives it (the same for every
/// estimator): otherwise `cmlt_renderer_new` and
/// `cmlt_renderer_memory_requirements` refuse the config with
/// `CMLT_ERROR_INVALID_ARGUMENT` and a message naming the field, so a
/// setting is never silently ignored (before this rule MLT ignored the
/// CMLT fields; `m` never turns MLT into CMLT).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct cmlt_renderer_config {
    /// Image width in pixels (1 ..= 16384).
    pub width: u32,
    /// Image height in pixels (1 ..= 16384).
    pub height: u32,
    /// One of the `CMLT_ESTIMATOR_*` values.
    pub estimator: u32,
    /// Workers (≥ 1): rendered by `cmlt_renderer_render(…, worker, …)`.
    pub workers: u32,
    /// Longest path in segments; 0 = the scene's own depth. A scene built
    /// through this API has none (unbounded, Mitsuba's default), so 0
    /// renders it at `depth_cap` (32 by default) segments; a scene loaded
    /// from a file has its integrator's `max_depth` (capped the same way
    /// when unbounded). Russian roulette starts at 5 segments (a file may
    /// set its own `rr_depth`).
    pub max_depth: u32,
    /// Seed of all random numbers.
    pub seed: u64,
    /// MLT: chains per worker.
    pub chains: u32,
    /// MLT: bootstrap samples per path depth (the chains' starting points).
    pub bootstrap_samples: u32,
    /// MLT: BDPT passes that estimate the normalisation.
    pub normalisation_passes: u32,
    /// MLT: probability of a large step, in [0, 1].
    pub large_step_probability: f32,
    /// MLT: small-step width in primary sample space, in (0, 1].
    pub small_step_sigma: f32,
    /// CMLT: candidates per multiple-try step (1 ..= 64).
    pub k: u32,
    /// CMLT: side-chain steps per level-1 mutation (≥ 1).
    pub m: u32,
    /// CMLT: standard deviation of the lens perturbation in pixels.
    pub lens_sigma: f32,
    /// CMLT: non-zero = stratified candidates, 0 = independent.
    pub stratified: u32,
    /// Frames, MLT/CMLT: non-zero = keep the chains across frames
    /// (re-evaluated after a camera move) instead of restarting them.
    pub keep_chains: u32,
    /// Frames, MLT/CMLT: average the normalisation over this many frames
    /// while the camera stays the same (0 or 1 = off; at most 64).
    pub b_window: u32,
    /// Frames: non-zero = every frame reuses the same random sequences.
    pub fixed_sequence: u32,
    /// Non-zero = simulate every effect, whatever the scene calls for (the
    /// scene analysis off; the CLI's `--all-effects`). 0 by default: only
    /// what the scene needs is simulated.
    pub all_effects: u32,
    /// Longest path in segments when the scene's depth is unbounded and
    /// `max_depth` is 0, for every estimator (1 ..= 1024; 32 by default).
    pub depth_cap: u32,
    /// CMLT: the caustic perturbation's angular σ is `lens_sigma` pixel
    /// angles times this factor (> 0, finite).
    pub caustic_scale: f32,
    /// CMLT: what a multiple-try step records, a `CMLT_SPLATTING_*` value.
    pub splatting: u32,
    /// CMLT: parallel one-proposal side chains per level-1 state, traced
    /// together as packets (1 ..= 64; more than 1 needs k = 1).
    pub lanes: u32,
    /// CMLT: paths of fewer segments get no side chain (their level-1
    /// records carry its share); 0 or 1 = every lens, caustic and
    /// multi-chain path gets one.
    pub side_chain_min_depth: u32,
    /// CMLT: the level-2 share, the weight (in records of one mutation)
    /// each level-1 mutation's side chain adds beyond its own record; 0 =
    /// m. Changes the variance, not the mean.
    pub share: u32,
    /// MLT: least number of normalisation samples (passes × pixels): a
    /// small image gets more than `normalisation_passes` passes (at most
    /// 1024 from this floor), so that the normalisation's error does not
    /// grow as the image shrinks; 0 = exactly `normalisation_passes`. At
    /// most 2²⁴.
    pub normalisation_min_samples: u32,
    /// MLT: least factor on the chains for emitters seen directly (paths
    /// of one segment) against their share of the image's luminance, in
    /// (0, 1]: they get chains for the area that sees an emitter, at least
    /// this share; 1 = chains in proportion to luminance at every depth.
    pub direct_allocation: f32,
    /// MLT: nonzero = record the large steps' proposals also as
    /// independent samples, combined with the chains' records by multiple
    /// importance sampling (Kelemen et al. 2002): same expectation, and
    /// pixels the chains seldom visit get the large steps' samples.
    pub large_step_mis: u32,
    /// MLT: the space level 1 mutates in, a `CMLT_LEVEL1_*` value.
    pub level1: u32,
    /// MLT: the weight of each normalisation-pass sample in the image, in
    /// records (one mutation's worth): the passes' BDPT image is added to
    /// the chains' by these fixed weights; 0 = the passes only estimate
    /// the normalisation. In [0, 1024]; with `keep_chains`, a bootstrap's
    /// passes join only a frame of the camera and scene it ran under.
    pub pass_records: f32,
    /// Frames, MLT/CMLT with `keep_chains`: track the normalisation from
    /// the chains' large steps of this many frames, pooled with the last
    /// bootstrap's passes, across camera moves and mesh updates (0 = off;
    /// at most 64).
    pub large_step_window: u32,
    /// MLT with `CMLT_LEVEL1_PATH_SPACE`: the weights of the bidirectional
    /// mutation, the lens subpath mutation and the lens, caustic and
    /// multi-chain perturbations; at a path each mutation that applies is
    /// chosen in proportion to its weight (0 = off; the bidirectional one's
    /// must be positive, all finite). 1 each by default.
    pub path_mutations: [f32; 5],
    /// MLT with `CMLT_LEVEL1_PATH_SPACE`: the level-1 perturbations'
    /// image-plane σ in pixels (their angular σ is as many pixel angles
    /// times `perturbation_caustic_scale`); > 0, finite.
    pub perturbation_sigma: f32,
    /// MLT with `CMLT_LEVEL1_PATH_SPACE`: the caustic and multi-chain
    /// perturbations' angular σ is `perturbation_sigma` pixel angles times
    /// this factor; > 0, finite (1 by default).
    pub perturbation_caustic_scale: f32,
}

/// Counters of the current accumulation (since the last camera change).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
#[allow(non_camel_case_types)]
pub struct cmlt_stats {
    /// Camera samples (PT, BDPT).
    pub samples: u64,
    /// Level-1 mutations (MLT, CMLT).
    pub mutations: u64,
    /// Fraction of level-1 proposals accepted.
    pub acceptance: f64,
    /// Level-2 lens-perturbation steps and their acceptance.
    pub lens_steps: u64,
    /// Fraction of lens steps accepted.
    pub lens_acceptance: f64,
    /// Level-2 caustic-perturbation steps.
    pub caustic_steps: u64,
    /// Fraction of caustic steps accepted.
    pub caustic_acceptance: f64,
    /// Closest-hit rays.
    pub rays: u64,
    /// Occlusion rays.
    pub shadow_rays: u64,
    /// Packets traced and rays that went in packets.
    pub packets: u64,
    /// Rays traced as packet lanes.
    pub packet_rays: u64,
    /// Non-finite contributions dropped (0 in a correct render).
    pub nonfinite: u64,
    /// Hits from a host intersector rejected as invalid (treated as misses).
    pub rejected_host_hits: u64,
    /// Host shape points (`cmlt_surface_fn` answers) rejected as invalid
    /// or missing (they scatter nothing).
    pub rejected_host_surfaces: u64,
    /// The normalisation b (MLT, CMLT).
    pub b: f64,
    /// The `CMLT_EFFECT_*` bits the scene calls for through this camera.
    pub effects: u32,
    /// BSDF samples per lobe kind, indexed diffuse, glossy, specular
    /// reflection, refraction (the `CMLT_EFFECT_*` values 0–3); the later
    /// lobe kinds are in `bsdf_samples_more`.
    pub bsdf_samples: [u64; 4],
    /// BSDF evaluations (connections) per lobe kind, indexed as
    /// `bsdf_samples`.
    pub bsdf_evals: [u64; 4],
    /// Camera rays that sampled the thin lens (0 for a pinhole).
    pub lens_samples: u64,
    /// BSDF samples of the lobe kinds after the first four (appended to keep
    /// the layout): entry i counts lobe kind 4 + i, that is coating
    /// (plastics, `CMLT_EFFECT_COATING`), rough refraction
    /// (`CMLT_EFFECT_ROUGH_REFRACTION`), principled
    /// (`CMLT_EFFECT_PRINCIPLED`) and rough diffuse
    /// (`CMLT_EFFECT_ROUGH_DIFFUSE`).
    pub bsdf_samples_more: [u64; 4],
    /// BSDF evaluations of the same lobe kinds, indexed as
    /// `bsdf_samples_more`.
    pub bsdf_evals_more: [u64; 4],
    /// Level-2 multi-chain-perturbation steps (paths E S+ D S+ …: a
    /// caustic or a light seen through glass or in a mirror; appended to
    /// keep the layout).
    pub multi_chain_steps: u64,
    /// Fraction of multi-chain steps accepted.
    pub multi_chain_acceptance: f64,
}

/// The first four lobe counts and the rest (the C struct keeps its first
/// four fields and appends the others).
fn split_lobes(c: &LobeCounts) -> ([u64; 4], [u64; 4]) {
    let (mut first, mut more) = ([0; 4], [0; 4]);
    for (i, n) in c.0.iter().enumerate() {
        if i < 4 {
            first[i] = *n;
        } else if let Some(slot) = more.get_mut(i - 4) {
            *slot = *n;
        }
    }
    (first, more)
}

/// A renderer handle (opaque to C).
#[allow(non_camel_case_types)]
pub struct cmlt_renderer {
    scene: Arc<Committed>,
    /// Read-locked by `render` (workers render concurrently) and `resolve`
    /// (host threads resolve rows concurrently), write-locked by
    /// `prepare`, `set_camera`.
    renderer: RwLock<Renderer>,
    /// One lock per worker, write-locked by the thread that renders or
    /// prepares it, read-locked by `resolve` (each resolving thread holds
    /// all of them for its call).
    workers: Box<[RwLock<RenderWorker>]>,
}

/// `*out` = the defaults, with `estimator` set: 1 worker, seed 0, the
/// scene's depth (unbounded capped at 32); MLT with pbrt's step sizes, 256
/// chains, 2000 bootstrap samples, 4 normalisation passes; CMLT with k = 1,
/// m = 1, lens σ = 8 px and side chains only on paths of at least 6
/// segments (the measured defaults of `Level2Settings::default`). Every
/// field but `estimator` has the same default whatever the estimator: the
/// values a field the estimator does not read must keep (see
/// `cmlt_renderer_config`). Width and height are 0: set them.
///
/// # Safety
/// `out` is NULL or valid for writing.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_config_default(
    estimator: u32,
    out: *mut cmlt_renderer_config,
) -> cmlt_status {
    guard("cmlt_renderer_config_default", || {
        // SAFETY: the caller's contract.
        let out = unsafe { write(out, "out") }?;
        EstimatorKind::from_u32(estimator)
            .ok_or_else(|| Error::invalid(format!("unknown estimator {estimator}")))?;
        *out = defaults(estimator);
        Ok(())
    })
}

/// The defaults of every field (`estimator` as given): the core's
/// [`RendererConfig::default`], [`MltSettings::default`] and
/// [`Level2Settings::default`].
fn defaults(estimator: u32) -> cmlt_renderer_config {
    let (c, mlt, l2) = (
        RendererConfig::default(),
        MltSettings::default(),
        Level2Settings::default(),
    );
    cmlt_renderer_config {
        width: 0,
        height: 0,
        estimator,
        workers: c.workers,
        max_depth: 0,
        seed: c.seed,
        chains: mlt.n_chains,
        bootstrap_samples: mlt.n_bootstrap,
        normalisation_passes: mlt.b_passes,
        large_step_probability: mlt.large_step_prob,
        small_step_sigma: mlt.sigma,
        k: l2.k,
        m: l2.m,
        lens_sigma: l2.lens_sigma,
        stratified: (l2.candidates == Candidates::Stratified) as u32,
        keep_chains: c.temporal.keep_chains as u32,
        b_window: c.temporal.b_window,
        fixed_sequence: c.temporal.fixed_sequence as u32,
        all_effects: c.all_effects as u32,
        depth_cap: c.depth_cap,
        caustic_scale: l2.caustic_scale,
        splatting: match l2.splatting {
            Splatting::ExpectedValue => CMLT_SPLATTING_EXPECTED_VALUE,
            _ => CMLT_SPLATTING_RECYCLED,
        },
        lanes: l2.lanes,
        side_chain_min_depth: l2.side_chain_min_depth,
        share: l2.share,
        normalisation_min_samples: mlt.b_min_samples,
        direct_allocation: mlt.direct_allocation,
        large_step_mis: mlt.large_step_mis as u32,
        level1: match mlt.level1 {
            Level1::PathSpace => CMLT_LEVEL1_PATH_SPACE,
            _ => CMLT_LEVEL1_PRIMARY_SAMPLE,
        },
        pass_records: mlt.pass_records,
        large_step_window: c.temporal.large_step_window,
        path_mutations: mlt.path_mutations.weights(),
        perturbation_sigma: mlt.path_mutations.sigma,
        perturbation_caustic_scale: mlt.path_mutations.caustic_scale,
    }
}

/// The first field of `c` that `kind` does not read and that differs from
/// its default (`d`), with the estimators that read it.
fn unread_field(
    c: &cmlt_renderer_config,
    d: &cmlt_renderer_config,
    kind: EstimatorKind,
) -> Option<(&'static str, &'static str)> {
    const MLT: &str = "MLT and CMLT";
    const CMLT: &str = "CMLT";
    // Floats compare by their bits: a NaN given to an estimator that does
    // not read it is refused too.
    let f = |a: f32, b: f32| a.to_bits() == b.to_bits();
    let fields = [
        ("chains", MLT, c.chains == d.chains),
        (
            "bootstrap_samples",
            MLT,
            c.bootstrap_samples == d.bootstrap_samples,
        ),
        (
            "normalisation_passes",
            MLT,
            c.normalisation_passes == d.normalisation_passes,
        ),
        (
            "normalisation_min_samples",
            MLT,
            c.normalisation_min_samples == d.normalisation_min_samples,
        ),
        (
            "large_step_probability",
            MLT,
            f(c.large_step_probability, d.large_step_probability),
        ),
        (
            "small_step_sigma",
            MLT,
            f(c.small_step_sigma, d.small_step_sigma),
        ),
        (
            "direct_allocation",
            MLT,
            f(c.direct_allocation, d.direct_allocation),
        ),
        ("large_step_mis", MLT, c.large_step_mis == d.large_step_mis),
        ("level1", MLT, c.level1 == d.level1),
        ("pass_records", MLT, f(c.pass_records, d.pass_records)),
        (
            "path_mutations",
            MLT,
            (0..5).all(|i| f(c.path_mutations[i], d.path_mutations[i])),
        ),
        (
            "perturbation_sigma",
            MLT,
            f(c.perturbation_sigma, d.perturbation_sigma),
        ),
        (
            "perturbation_caustic_scale",
            MLT,
            f(c.perturbation_caustic_scale, d.perturbation_caustic_scale),
        ),
        ("keep_chains", MLT, c.keep_chains == d.keep_chains),
        ("b_window", MLT, c.b_window == d.b_window),
        (
            "large_step_window",
            MLT,
            c.large_step_window == d.large_step_window,
        ),
        ("k", CMLT, c.k == d.k),
        ("m", CMLT, c.m == d.m),
        ("lens_sigma", CMLT, f(c.lens_sigma, d.lens_sigma)),
        ("stratified", CMLT, c.stratified == d.stratified),
        ("caustic_scale", CMLT, f(c.caustic_scale, d.caustic_scale)),
        ("splatting", CMLT, c.splatting == d.splatting),
        ("lanes", CMLT, c.lanes == d.lanes),
        (
            "side_chain_min_depth",
            CMLT,
            c.side_chain_min_depth == d.side_chain_min_depth,
        ),
        ("share", CMLT, c.share == d.share),
    ];
    let reads = |readers: &str| match kind {
        EstimatorKind::Cmlt => true,
        EstimatorKind::Mlt => readers == MLT,
        EstimatorKind::Path | EstimatorKind::Bdpt => false,
    };
    fields
        .into_iter()
        .find(|&(_, readers, same)| !same && !reads(readers))
        .map(|(name, readers, _)| (name, readers))
}

/// The core configuration of `c` over `scene`, checked: the variant of
/// `c.estimator` with the fields it reads, the others refused unless they
/// keep their defaults (see `cmlt_renderer_config`).
pub(crate) fn core_config(c: &cmlt_renderer_config, scene: &Committed) -> Result<RendererConfig> {
    if c.width == 0 || c.height == 0 || c.width > 1 << 14 || c.height > 1 << 14 {
        return Err(Error::invalid("width and height must be in 1 ..= 16384"));
    }
    let kind = EstimatorKind::from_u32(c.estimator)
        .ok_or_else(|| Error::invalid(format!("unknown estimator {}", c.estimator)))?;
    if let Some((field, readers)) = unread_field(c, &defaults(c.estimator), kind) {
        return Err(Error::invalid(format!(
            "{field} is read by {readers} only, not by {}: leave it at \
             cmlt_renderer_config_default's value",
            kind.name().to_uppercase()
        )));
    }
    if c.max_depth > 1024 {
        return Err(Error::invalid("max_depth must be at most 1024"));
    }
    if c.depth_cap == 0 || c.depth_cap > 1024 {
        return Err(Error::invalid("depth_cap must be in 1 ..= 1024"));
    }
    // The biased eq. 36 splatting has no C constant: only the unbiased two.
    let splatting = match c.splatting {
        CMLT_SPLATTING_RECYCLED => Splatting::Recycled,
        CMLT_SPLATTING_EXPECTED_VALUE => Splatting::ExpectedValue,
        other => return Err(Error::invalid(format!("unknown splatting {other}"))),
    };
    let level1 = match c.level1 {
        CMLT_LEVEL1_PRIMARY_SAMPLE => Level1::PrimarySample,
        CMLT_LEVEL1_PATH_SPACE => Level1::PathSpace,
        other => return Err(Error::invalid(format!("unknown level 1 {other}"))),
    };
    let mut settings = scene.settings;
    if c.max_depth > 0 {
        settings.max_depth = Some(c.max_depth);
    }
    let mlt = MltSettings {
        n_bootstrap: c.bootstrap_samples,
        b_passes: c.normalisation_passes,
        b_min_samples: c.normalisation_min_samples,
        n_chains: c.chains,
        large_step_prob: c.large_step_probability,
        sigma: c.small_step_sigma,
        direct_allocation: c.direct_allocation,
        large_step_mis: c.large_step_mis != 0,
        pass_records: c.pass_records,
        level1,
        path_mutations: PathMutations::new(
            c.path_mutations,
            c.perturbation_sigma,
            c.perturbation_caustic_scale,
        ),
    };
    if kind.is_metropolis() && mlt.n_bootstrap == 0 {
        return Err(Error::invalid(
            "MLT needs at least one bootstrap sample per depth",
        ));
    }
    let estimator = match kind {
        EstimatorKind::Path => Estimator::Path,
        EstimatorKind::Bdpt => Estimator::Bdpt,
        EstimatorKind::Mlt => Estimator::Mlt(mlt),
        EstimatorKind::Cmlt => Estimator::Cmlt(CmltSettings {
            mlt,
            level2: Level2Settings {
                m: c.m,
                k: c.k,
                lens_sigma: c.lens_sigma,
                caustic_scale: c.caustic_scale,
                candidates: if c.stratified != 0 {
                    Candidates::Stratified
                } else {
                    Candidates::Independent
                },
                splatting,
                lanes: c.lanes,
                side_chain_min_depth: c.side_chain_min_depth,
                share: c.share,
            },
        }),
    };
    Ok(RendererConfig {
        estimator,
        settings,
        depth_cap: c.depth_cap,
        seed: c.seed,
        workers: c.workers,
        temporal: Temporal {
            keep_chains: c.keep_chains != 0,
            b_window: c.b_window,
            fixed_sequence: c.fixed_sequence != 0,
            large_step_window: c.large_step_window,
        },
        all_effects: c.all_effects != 0,
    })
}

/// The C error of a core error; literal messages for those a frame can
/// meet (a frame allocates nothing, not even an error message).
fn render_error(e: RenderError) -> Error {
    match e {
        RenderError::Config(_) | RenderError::EffectNotBuilt(_) => Error::invalid(e.to_string()),
        RenderError::TooLarge => Error::out_of_memory(e.to_string()),
        RenderError::Resolution => {
            Error::invalid("the camera's resolution differs from the renderer's")
        }
        RenderError::Worker => Error::invalid("the worker does not belong to this renderer"),
        RenderError::NotPrepared => Error::operation(
            "prepare the renderer (after creating it, changing the camera or updating the \
             scene) before rendering",
        ),
        RenderError::BootstrapIncomplete => Error::operation(
            "every worker must run prepare_worker for this frame before finish_prepare",
        ),
        RenderError::Output(m) => Error::invalid(m),
    }
}

/// Builds the renderer and its workers (everything a frame needs).
///
/// The core sizes its buffers with infallible allocations; so that none of
/// them is ever asked for a block the system cannot give (which would
/// abort: a block the host's hooks refuse is served by the system and the
/// call then fails, `alloc.rs`), the system allocator is first asked,
/// fallibly, for the renderer's upper bound ([`Renderer::memory_bound`])
/// in one block, which is freed at once: a configuration too large for
/// the machine is refused with out-of-memory before anything else is
/// allocated. The probe bypasses the host's hooks, so a host pool the size
/// `cmlt_renderer_memory_requirements` gives is enough.
fn build(
    scene: Arc<Committed>,
    config: &cmlt_renderer_config,
    camera: &cmlt_camera,
) -> Result<cmlt_renderer> {
    let cfg = core_config(config, &scene)?;
    let camera = camera.camera(config.width, config.height)?;
    let bound = Renderer::memory_bound(&cfg, config.width, config.height).map_err(render_error)?;
    system_can_give(usize::try_from(bound).map_err(|_| {
        Error::out_of_memory("out of memory: the renderer's memory overflows the address space")
    })?)?;
    let renderer = Renderer::new(cfg, camera).map_err(render_error)?;
    let mut workers = Vec::new();
    try_reserve(&mut workers, cfg.workers as usize)?;
    for i in 0..cfg.workers {
        workers.push(RwLock::new(
            RenderWorker::new(&renderer, i).map_err(render_error)?,
        ));
    }
    Ok(cmlt_renderer {
        scene,
        renderer: RwLock::new(renderer),
        workers: workers.into_boxed_slice(),
    })
}

/// `*out_bytes` and `*out_alignment` = the memory a renderer of this
/// configuration takes from the allocator (all of it, allocated in
/// `cmlt_renderer_new`; nothing more is allocated while rendering) and the
/// largest alignment it asks for. Measured by building the renderer once
/// and freeing it. Either out pointer may be NULL. A configuration whose
/// upper bound of memory overflows the address space, or which the
/// allocator cannot give in one block, returns `CMLT_ERROR_OUT_OF_MEMORY`
/// before anything is built (as `cmlt_renderer_new` does).
///
/// # Safety
/// `scene` and `config` are NULL or valid; the out pointers are NULL or
/// valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_memory_requirements(
    scene: *const cmlt_scene,
    config: *const cmlt_renderer_config,
    out_bytes: *mut usize,
    out_alignment: *mut usize,
) -> cmlt_status {
    guard("cmlt_renderer_memory_requirements", || {
        // SAFETY: the caller's contract.
        let (scene, config) = unsafe { (read(scene, "scene")?, read(config, "config")?) };
        let committed = scene.committed()?;
        let camera = cmlt_camera {
            position: [0.0; 3],
            target: [0.0, 0.0, 1.0],
            up: [0.0, 1.0, 0.0],
            fov_degrees: 60.0,
            aperture_radius: 0.0,
            focus_distance: 1.0,
        };
        let (built, usage) =
            measure_allocations(|| build(committed, config, &camera).map(Box::new));
        drop(built?);
        check_oom()?;
        // SAFETY: the caller's contract.
        unsafe {
            if let Some(b) = out_bytes.as_mut() {
                *b = usage.peak;
            }
            if let Some(a) = out_alignment.as_mut() {
                *a = usage.max_align;
            }
        }
        Ok(())
    })
}

/// Creates a renderer of the committed `scene` looking through `camera`.
/// Everything its frames need is allocated here. Before that the
/// allocator is asked once, fallibly, for an upper bound of it all in one
/// block (freed at once): `CMLT_ERROR_OUT_OF_MEMORY` when it cannot give
/// it, or when the bound overflows the address space (a huge resolution,
/// worker, chain or bootstrap count).
///
/// # Safety
/// `scene`, `config`, `camera` and `out` are NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_new(
    scene: *const cmlt_scene,
    config: *const cmlt_renderer_config,
    camera: *const cmlt_camera,
    out: *mut *mut cmlt_renderer,
) -> cmlt_status {
    guard("cmlt_renderer_new", || {
        // SAFETY: the caller's contract.
        let (scene, config, camera, out) = unsafe {
            (
                read(scene, "scene")?,
                read(config, "config")?,
                read(camera, "camera")?,
                write(out, "out")?,
            )
        };
        let r = Box::new(build(scene.committed()?, config, camera)?);
        check_oom()?;
        *out = Box::into_raw(r);
        Ok(())
    })
}

/// Releases a renderer (NULL is ignored).
///
/// # Safety
/// `renderer` is NULL or a handle not released before and not in use.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_release(renderer: *mut cmlt_renderer) {
    let _ = guard("cmlt_renderer_release", || {
        if !renderer.is_null() {
            // SAFETY: the caller's contract: it came from Box::into_raw.
            drop(unsafe { Box::from_raw(renderer) });
        }
        Ok(())
    });
}

/// Starts the next frame through `camera` (the same camera again is a new
/// frame too; skip the call to keep accumulating): the accumulation
/// restarts, and what carries over is set by the config's `keep_chains`,
/// `b_window` and `fixed_sequence`. Call `cmlt_renderer_prepare` before
/// rendering again. `CMLT_ERROR_BUSY` while a worker renders.
///
/// # Safety
/// `renderer` and `camera` are NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_set_camera(
    renderer: *mut cmlt_renderer,
    camera: *const cmlt_camera,
) -> cmlt_status {
    guard("cmlt_renderer_set_camera", || {
        // SAFETY: the caller's contract.
        let (r, camera) = unsafe { (read(renderer, "renderer")?, read(camera, "camera")?) };
        let mut inner = r
            .renderer
            .try_write()
            .map_err(|e| Error::lock(e, "workers are rendering"))?;
        let cam = camera.camera(inner.camera().width(), inner.camera().height())?;
        inner.set_camera(cam).map_err(render_error)
    })
}

/// How every estimator carries its accumulation into the frames after
/// this one: `CMLT_ACCUMULATION_RESET` (the default: each frame its own
/// image), `CMLT_ACCUMULATION_KEEP` (frames add up) or
/// `CMLT_ACCUMULATION_DECAY` (earlier frames weigh `decay` per frame of
/// age, 0 < `decay` < 1; ignored by the other modes). May change every
/// frame. PT and BDPT keep their samples; MLT and CMLT their frames'
/// images, each normalised by its own b and weighted by its records (with
/// a still camera, kept frames converge as one long render; with few
/// mutations per frame, decay fills the image). An unknown mode or a
/// decay out of range is `CMLT_ERROR_INVALID_ARGUMENT`; nothing changes
/// then.
/// `CMLT_ERROR_BUSY` while a worker renders.
///
/// # Safety
/// `renderer` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_set_accumulation(
    renderer: *mut cmlt_renderer,
    mode: u32,
    decay: f32,
) -> cmlt_status {
    guard("cmlt_renderer_set_accumulation", || {
        // SAFETY: the caller's contract.
        let r = unsafe { read(renderer, "renderer") }?;
        let mode = match mode {
            CMLT_ACCUMULATION_RESET => Accumulation::Reset,
            CMLT_ACCUMULATION_KEEP => Accumulation::Keep,
            CMLT_ACCUMULATION_DECAY => Accumulation::Decay(decay),
            _ => return Err(Error::invalid("unknown accumulation mode")),
        };
        let mut inner = r
            .renderer
            .try_write()
            .map_err(|e| Error::lock(e, "workers are rendering"))?;
        inner.set_accumulation(mode).map_err(render_error)
    })
}

/// How many pixels each PT or BDPT sample fills, for the passes begun from
/// now on (dynamic resolution): `size` 1 (the default) renders at full
/// resolution; 2 ..= 64 one sample per `size × size` block of pixels,
/// filling the block (P / size² samples a pass; the image box-filtered
/// over the blocks, BDPT's light-tracing splats at full resolution); `CMLT_PIXEL_BLOCK_FIT` (0) the finest block size the
/// workers' measured samples fill, chosen at every pass start, so that a
/// frame within a time budget below one full-resolution pass still shows
/// a full image. May change every frame (a pass open at another size
/// finishes first unless the accumulation is reset). MLT and CMLT at any
/// size but 1 render such BDPT passes beside their chains (the block fill:
/// an eighth of a frame's work, mixed with the chains' splats pixel by
/// pixel at `pass_records` records per sample), so that a frame far below
/// one mutation per pixel still shows a full image; at 1 their chains
/// alone. A size above 64, or a fill for MLT or CMLT with `pass_records`
/// 0 (its samples would weigh nothing), is `CMLT_ERROR_INVALID_ARGUMENT`;
/// nothing changes then. `CMLT_ERROR_BUSY` while a worker renders.
///
/// # Safety
/// `renderer` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_set_pixel_block(
    renderer: *mut cmlt_renderer,
    size: u32,
) -> cmlt_status {
    guard("cmlt_renderer_set_pixel_block", || {
        // SAFETY: the caller's contract.
        let r = unsafe { read(renderer, "renderer") }?;
        let block = match size {
            CMLT_PIXEL_BLOCK_FIT => PixelBlock::Fit,
            k => PixelBlock::Fixed(k),
        };
        let mut inner = r
            .renderer
            .try_write()
            .map_err(|e| Error::lock(e, "workers are rendering"))?;
        inner.set_pixel_block(block).map_err(render_error)
    })
}

/// Runs `f` on worker `worker` with the renderer read-locked and the worker
/// locked: the thread rules of `cmlt_renderer_render` (an index out of
/// range is `INVALID_ARGUMENT`, a renderer being prepared or a worker being
/// rendered is `BUSY`).
fn with_worker(
    r: &cmlt_renderer,
    worker: u32,
    f: impl FnOnce(&Renderer, &mut RenderWorker) -> std::result::Result<u64, RenderError>,
) -> Result<u64> {
    let slot = r
        .workers
        .get(worker as usize)
        .ok_or(Error::invalid("worker ≥ the renderer's number of workers"))?;
    let inner = r
        .renderer
        .try_read()
        .map_err(|e| Error::lock(e, "the renderer is being prepared or moved"))?;
    // Literal messages: this runs inside frames, which allocate nothing.
    let mut w = slot
        .try_write()
        .map_err(|e| Error::lock(e, "the worker is being rendered by another thread"))?;
    crate::error::bug_hook();
    f(&inner, &mut w).map_err(render_error)
}

/// Readies the renderer for this frame's `cmlt_renderer_render` calls on
/// the calling thread: exactly `cmlt_renderer_prepare_begin`, then
/// `cmlt_renderer_prepare_worker` for every worker in turn, then
/// `cmlt_renderer_prepare_finish` (the same image, bit for bit, as those
/// calls spread over the host's threads). After creation, a camera change
/// or a scene update, MLT and CMLT estimate the normalisation here;
/// otherwise it returns at once. `CMLT_ERROR_BUSY` while a worker renders.
///
/// # Safety
/// `renderer` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_prepare(renderer: *mut cmlt_renderer) -> cmlt_status {
    guard("cmlt_renderer_prepare", || {
        // SAFETY: the caller's contract.
        let r = unsafe { read(renderer, "renderer") }?;
        let mut inner = r
            .renderer
            .try_write()
            .map_err(|e| Error::lock(e, "workers are rendering"))?;
        let live = r.scene.live()?;
        if inner.begin_prepare(&live.scene) {
            for slot in r.workers.iter() {
                let mut w = slot
                    .try_write()
                    .map_err(|e| Error::lock(e, "a worker is being prepared or rendered"))?;
                inner
                    .prepare_worker(&mut w, &live.scene, &live.accel)
                    .map_err(render_error)?;
            }
            finish_prepare(r, &mut inner)?;
        }
        Ok(())
    })
}

/// The core's `finish_prepare` over all of `r`'s workers, each locked in
/// turn (no list of guards: a frame allocates nothing); a worker locked by
/// another thread is `CMLT_ERROR_BUSY` and changes nothing.
fn finish_prepare(r: &cmlt_renderer, inner: &mut Renderer) -> Result<()> {
    let mut busy = None;
    let workers = r.workers.iter().map_while(|slot| match slot.try_write() {
        Ok(w) => Some(w),
        Err(e) => {
            busy = Some(Error::lock(e, "a worker is being prepared or rendered"));
            None
        }
    });
    // A worker cut off by a busy lock leaves the bootstrap incomplete:
    // refused by the core, reported as busy.
    let done = inner.finish_prepare(workers);
    match busy {
        Some(e) => Err(e),
        None => done.map_err(render_error),
    }
}

/// The first of the three calls that ready the renderer for the frame
/// (`cmlt_renderer_prepare` runs all three on one thread): starts the
/// frame's preparation and sets
/// `*out_pending` (may be NULL) to 1 when the workers have bootstrap work
/// (MLT, CMLT after creation or a camera change) — then call
/// `cmlt_renderer_prepare_worker` once for every worker (concurrently, from
/// different threads if the host likes) and `cmlt_renderer_prepare_finish`
/// once — or 0 when the renderer is ready (the other two calls then return
/// at once). With `keep_chains`, once a first bootstrap is joined, the
/// renderer is ready at once even when this sets 1: the next bootstrap
/// then runs in the pieces `cmlt_renderer_prepare_worker_while` is given,
/// across frames. The image is bit for bit the same whichever threads run
/// the workers. `CMLT_ERROR_BUSY` while a worker renders.
///
/// # Safety
/// `renderer` is NULL or valid; `out_pending` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_prepare_begin(
    renderer: *mut cmlt_renderer,
    out_pending: *mut u32,
) -> cmlt_status {
    guard("cmlt_renderer_prepare_begin", || {
        // SAFETY: the caller's contract.
        let r = unsafe { read(renderer, "renderer") }?;
        let mut inner = r
            .renderer
            .try_write()
            .map_err(|e| Error::lock(e, "workers are rendering"))?;
        let live = r.scene.live()?;
        let pending = inner.begin_prepare(&live.scene);
        if !out_pending.is_null() {
            // SAFETY: the caller's contract.
            unsafe { *out_pending = pending as u32 };
        }
        Ok(())
    })
}

/// Worker `worker`'s share of the bootstrap begun by
/// `cmlt_renderer_prepare_begin`: its contiguous share of the bootstrap samples
/// and of the normalisation passes' blocks (each pass is cut into 24 blocks
/// of interleaved pixels, so a pass is shared too). Same thread rules as
/// `cmlt_renderer_render` (different workers at the same time from
/// different threads). Returns at once when nothing is pending.
///
/// # Safety
/// `renderer` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_prepare_worker(
    renderer: *mut cmlt_renderer,
    worker: u32,
) -> cmlt_status {
    guard("cmlt_renderer_prepare_worker", || {
        // SAFETY: the caller's contract.
        let r = unsafe { read(renderer, "renderer") }?;
        let c = r.scene.live()?;
        with_worker(r, worker, |inner, w| {
            inner.prepare_worker(w, &c.scene, &c.accel).map(|()| 0)
        })?;
        Ok(())
    })
}

/// `cmlt_renderer_prepare_worker` in pieces of about a millisecond of
/// work (16 bootstrap samples or normalisation-pass pixels), calling
/// `keep_going(user, done)` before every piece after the first and
/// stopping when it returns 0: the set-up bounded by the host's clock.
/// `*out_finished` (may be NULL) is 1 when the worker's share is complete,
/// 0 when the next call must go on (it continues where this one stopped,
/// in a later frame too). The share is the same, bit for bit, however it
/// was cut. Same thread rules as `cmlt_renderer_render`; the callback
/// must not call into cmlt.
///
/// With `keep_chains`, frames after the first bootstrap need none to
/// render: `cmlt_renderer_prepare_begin` then readies the renderer at
/// once (the kept chains go on with the b of earlier frames) while a new
/// bootstrap proceeds in whatever pieces the host's calls allow, spanning
/// frames, and is joined by the `cmlt_renderer_prepare_finish` after it
/// completes.
///
/// # Safety
/// `renderer` is NULL or valid; `keep_going` is callable with `user`;
/// `out_finished` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_prepare_worker_while(
    renderer: *mut cmlt_renderer,
    worker: u32,
    keep_going: cmlt_keep_going_fn,
    user: *mut c_void,
    out_finished: *mut u32,
) -> cmlt_status {
    guard("cmlt_renderer_prepare_worker_while", || {
        // SAFETY: the caller's contract.
        let r = unsafe { read(renderer, "renderer") }?;
        let keep_going = keep_going.ok_or_else(|| Error::null("keep_going"))?;
        // SAFETY: the caller's contract on the callback.
        let ask = |done: u64| unsafe { keep_going(user, done) } != 0;
        let c = r.scene.live()?;
        let finished = with_worker(r, worker, |inner, w| {
            inner
                .prepare_worker_while(w, &c.scene, &c.accel, &mut { ask })
                .map(u64::from)
        })?;
        if !out_finished.is_null() {
            // SAFETY: the caller's contract.
            unsafe { *out_finished = finished as u32 };
        }
        Ok(())
    })
}

/// Joins the workers' shares of the bootstrap (after
/// `cmlt_renderer_prepare_worker` for every worker): the renderer is then
/// ready for `cmlt_renderer_render`. A share missing or incomplete is
/// `CMLT_ERROR_INVALID_OPERATION` (nothing changes; run the missing
/// workers and call again) — unless kept chains go on with an earlier
/// bootstrap (see `cmlt_renderer_prepare_worker_while`): then the
/// incomplete bootstrap stays pending for later frames and the call
/// succeeds. `CMLT_ERROR_BUSY` while a worker renders.
///
/// # Safety
/// `renderer` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_prepare_finish(renderer: *mut cmlt_renderer) -> cmlt_status {
    guard("cmlt_renderer_prepare_finish", || {
        // SAFETY: the caller's contract.
        let r = unsafe { read(renderer, "renderer") }?;
        let mut inner = r
            .renderer
            .try_write()
            .map_err(|e| Error::lock(e, "workers are rendering"))?;
        finish_prepare(r, &mut inner)
    })
}

/// `Budget::PerPixel` in C: renders worker `worker`'s share of `per_pixel` samples (PT, BDPT) or
/// level-1 mutations (MLT, CMLT) per pixel over all workers: passes
/// `worker, worker + W, …` below `per_pixel`, or the same whole rounds on
/// every worker — what the CLI's `--spp` and `--mutations-per-pixel` do.
/// `*out_done` (may be NULL) receives the units rendered. Same thread
/// rules as `cmlt_renderer_render`.
///
/// # Safety
/// `renderer` is NULL or valid; `out_done` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_render_per_pixel(
    renderer: *mut cmlt_renderer,
    worker: u32,
    per_pixel: u64,
    out_done: *mut u64,
) -> cmlt_status {
    guard("cmlt_renderer_render_per_pixel", || {
        // SAFETY: the caller's contract.
        let r = unsafe { read(renderer, "renderer") }?;
        let c = r.scene.live()?;
        let done = with_worker(r, worker, |inner, w| {
            let steps = inner.steps_for(w.index(), per_pixel);
            inner.render_steps(w, &c.scene, &c.accel, steps)
        })?;
        if !out_done.is_null() {
            // SAFETY: the caller's contract.
            unsafe { *out_done = done };
        }
        Ok(())
    })
}

/// Renders `budget` units into worker `worker`: camera samples for PT and
/// BDPT (rounded up to whole passes over the image), level-1 mutations for
/// MLT and CMLT (rounded up to one mutation of every chain of the worker).
/// `*out_done` (may be NULL) receives the units rendered. Different workers
/// may be rendered at the same time from different threads; a worker
/// already being rendered gives `CMLT_ERROR_BUSY`.
///
/// # Safety
/// `renderer` is NULL or valid; `out_done` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_render(
    renderer: *mut cmlt_renderer,
    worker: u32,
    budget: u64,
    out_done: *mut u64,
) -> cmlt_status {
    guard("cmlt_renderer_render", || {
        // SAFETY: the caller's contract.
        let r = unsafe { read(renderer, "renderer") }?;
        let c = r.scene.live()?;
        let done = with_worker(r, worker, |inner, w| {
            inner.render(w, &c.scene, &c.accel, budget)
        })?;
        if !out_done.is_null() {
            // SAFETY: the caller's contract.
            unsafe { *out_done = done };
        }
        Ok(())
    })
}

/// Host clock for `cmlt_renderer_render_while`: return non-zero to let
/// the worker render another step, 0 to stop. `done` is the number of units
/// rendered so far in this call.
#[allow(non_camel_case_types)]
pub type cmlt_keep_going_fn = Option<unsafe extern "C" fn(user: *mut c_void, done: u64) -> u32>;

/// `cmlt_renderer_render` in pieces — 16 camera samples (PT, BDPT: about
/// a millisecond of work; a frame may end inside a pass, the next call
/// goes on from there, and each pixel is normalised by its own sample
/// count) or 16 level-1 mutations with their side chains (MLT, CMLT: a
/// frame may end inside a round, whose chains are then visited in an
/// order that keeps the path depths of the partial round in proportion)
/// — calling
/// `keep_going(user, done)` before every piece after the first and
/// stopping when it returns 0 or `budget` units are done: a frame bounded
/// by the host's own clock (the library never reads time). `*out_done`
/// (may be NULL) receives the units rendered. Same thread rules as
/// `cmlt_renderer_render`; the callback must not call into cmlt.
///
/// # Safety
/// `renderer` is NULL or valid; `keep_going` is callable with `user`;
/// `out_done` is NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_render_while(
    renderer: *mut cmlt_renderer,
    worker: u32,
    budget: u64,
    keep_going: cmlt_keep_going_fn,
    user: *mut c_void,
    out_done: *mut u64,
) -> cmlt_status {
    guard("cmlt_renderer_render_while", || {
        // SAFETY: the caller's contract.
        let r = unsafe { read(renderer, "renderer") }?;
        let keep_going = keep_going.ok_or_else(|| Error::null("keep_going"))?;
        // SAFETY: the caller's contract on the callback.
        let ask = |done: u64| unsafe { keep_going(user, done) } != 0;
        let c = r.scene.live()?;
        let done = with_worker(r, worker, |inner, w| {
            inner.render_while(w, &c.scene, &c.accel, budget, &mut { ask })
        })?;
        if !out_done.is_null() {
            // SAFETY: the caller's contract.
            unsafe { *out_done = done };
        }
        Ok(())
    })
}

/// The core's pixel format of a `CMLT_FORMAT_*` value, or an error for an
/// unknown one.
fn pixel_format(format: u32) -> Result<PixelFormat> {
    match format {
        CMLT_FORMAT_RGB32F => Ok(PixelFormat::Rgb32F),
        CMLT_FORMAT_RGBA8_SRGB => Ok(PixelFormat::Rgba8Srgb),
        CMLT_FORMAT_RGBA32F => Ok(PixelFormat::Rgba32F),
        CMLT_FORMAT_RGBA16F => Ok(PixelFormat::Rgba16F),
        _ => Err(Error::invalid("unknown pixel format")),
    }
}

/// One read-locked worker, its guard held by a frame of [`hold_workers`],
/// linked to the next worker's.
struct Held<'a> {
    worker: &'a RenderWorker,
    next: Option<&'a Held<'a>>,
}

/// The held workers in index order.
#[derive(Clone)]
struct HeldWorkers<'a>(Option<&'a Held<'a>>);

impl<'a> Iterator for HeldWorkers<'a> {
    type Item = &'a RenderWorker;
    fn next(&mut self) -> Option<&'a RenderWorker> {
        let held = self.0?;
        self.0 = held.next;
        Some(held.worker)
    }
}

/// Runs `f` over all of `slots`' workers, each read-locked for the whole
/// call (a worker being rendered or prepared is `CMLT_ERROR_BUSY`). The
/// guards live in the frames of this recursion, one per worker from the
/// last to the first, so the list of them needs no allocation.
fn hold_workers<R>(
    slots: &[RwLock<RenderWorker>],
    next: Option<&Held<'_>>,
    f: impl for<'a> FnOnce(HeldWorkers<'a>) -> R,
) -> Result<R> {
    match slots.split_last() {
        None => Ok(f(HeldWorkers(next))),
        Some((last, rest)) => {
            let guard = last
                .try_read()
                .map_err(|e| Error::lock(e, "a worker is being rendered or prepared"))?;
            let held = Held {
                worker: &guard,
                next,
            };
            hold_workers(rest, Some(&held), f)
        }
    }
}

/// Writes the image of all workers (merged in worker order) into `pixels`:
/// `height` rows of `width` pixels of `format`, row 0 at the top, rows
/// `row_stride` bytes apart (0 = packed), in a buffer of `buffer_size`
/// bytes: `cmlt_renderer_resolve_rows` over every row. `CMLT_ERROR_BUSY`
/// while a worker renders or is prepared.
///
/// # Safety
/// `renderer` is NULL or valid; `pixels` is NULL or valid for writing
/// `buffer_size` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_resolve(
    renderer: *const cmlt_renderer,
    format: u32,
    pixels: *mut u8,
    row_stride: usize,
    buffer_size: usize,
) -> cmlt_status {
    guard("cmlt_renderer_resolve", || {
        // SAFETY: the caller's contract.
        unsafe { resolve_rows(renderer, format, None, pixels, row_stride, buffer_size) }
    })
}

/// Writes rows `[first_row, end_row)` of the image of all workers (merged
/// in worker order) into `pixels` as `format`: row `first_row` at
/// `pixels`, each next row `row_stride` bytes further (0 = packed), in a
/// buffer of `buffer_size` bytes (the last row needs only its own bytes).
/// Each pixel is the one `cmlt_renderer_resolve` writes, so host threads
/// can each resolve a band of rows at the same time and get the same bytes
/// as one call — as long as no worker renders between their calls.
/// Allocates nothing. `CMLT_ERROR_INVALID_ARGUMENT` for rows outside the
/// image, an unknown format, a stride shorter than a row, a buffer too
/// small, or a float or half buffer or stride not aligned to its element
/// size (nothing is written); `CMLT_ERROR_BUSY` while a worker renders or
/// is prepared, or the renderer is being prepared or moved.
///
/// # Safety
/// `renderer` is NULL or valid; `pixels` is NULL or valid for writing
/// `buffer_size` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_resolve_rows(
    renderer: *const cmlt_renderer,
    format: u32,
    first_row: u32,
    end_row: u32,
    pixels: *mut u8,
    row_stride: usize,
    buffer_size: usize,
) -> cmlt_status {
    guard("cmlt_renderer_resolve_rows", || {
        let rows = Some(first_row..end_row);
        // SAFETY: the caller's contract.
        unsafe { resolve_rows(renderer, format, rows, pixels, row_stride, buffer_size) }
    })
}

/// The body of both resolves: `rows` (all of them for `None`) into the
/// host's buffer.
///
/// # Safety
/// As `cmlt_renderer_resolve_rows`.
unsafe fn resolve_rows(
    renderer: *const cmlt_renderer,
    format: u32,
    rows: Option<std::ops::Range<u32>>,
    pixels: *mut u8,
    row_stride: usize,
    buffer_size: usize,
) -> Result<()> {
    // SAFETY: the caller's contract.
    let r = unsafe { read(renderer, "renderer") }?;
    if pixels.is_null() {
        return Err(Error::new(
            cmlt_status::CMLT_ERROR_NULL_POINTER,
            "pixels is NULL",
        ));
    }
    let format = pixel_format(format)?;
    let inner = r
        .renderer
        .try_read()
        .map_err(|e| Error::lock(e, "the renderer is being prepared or its camera changed"))?;
    let rows = rows.unwrap_or(0..inner.camera().height());
    // The core writes bytes, but a C host reads its floats in place: a
    // float or half buffer whose rows are not aligned for its elements is
    // a host bug, refused as before.
    let align = match format {
        PixelFormat::Rgb32F | PixelFormat::Rgba32F => 4,
        PixelFormat::Rgba16F => 2,
        PixelFormat::Rgba8Srgb => 1,
    };
    if !(pixels as usize).is_multiple_of(align) || !row_stride.is_multiple_of(align) {
        return Err(Error::invalid(
            "float pixels need a buffer and row_stride aligned to their element size",
        ));
    }
    // SAFETY: the caller's contract: `pixels` is valid for writing
    // `buffer_size` bytes, and nothing else reads or writes them during
    // the call.
    let out = unsafe { std::slice::from_raw_parts_mut(pixels, buffer_size) };
    hold_workers(&r.workers, None, |workers| {
        inner.resolve_rows(workers, rows, format, out, row_stride)
    })?
    .map_err(render_error)
}

/// Auxiliary outputs as `float`, in the machine's byte order.
pub const CMLT_AOV_F32: u32 = 0;
/// Auxiliary outputs as IEEE 754 binary16 (half), rounded to nearest even.
pub const CMLT_AOV_F16: u32 = 1;

/// One auxiliary output's rows in the host's memory: row `first_row` of
/// the call at `data`, each next row `row_stride` bytes further (0 =
/// packed: width × channels × element size), in `buffer_size` bytes (the
/// last row needs only its own bytes). `data` = NULL: the output is not
/// wanted (and not computed).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct cmlt_aov_layer {
    /// The host's buffer, or NULL for none. Aligned to the element size
    /// (4 bytes for `float`, 2 for half), as is `row_stride`.
    pub data: *mut c_void,
    /// Bytes from one row to the next; 0 = packed.
    pub row_stride: usize,
    /// Bytes of `data`.
    pub buffer_size: usize,
    /// `CMLT_AOV_F32` or `CMLT_AOV_F16`.
    pub format: u32,
}

/// The auxiliary outputs a call writes (see `cmlt_renderer_aov_rows` for
/// what each holds); leave `data` NULL for those not wanted.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct cmlt_aov_buffers {
    /// Albedo: 3 channels, linear RGB in [0, 1].
    pub albedo: cmlt_aov_layer,
    /// Shading normal: 3 channels, world space, unit, facing the camera.
    pub normal: cmlt_aov_layer,
    /// Depth: 1 channel, camera-space z.
    pub depth: cmlt_aov_layer,
    /// Motion vector: 2 channels, pixels, previous minus current.
    pub motion: cmlt_aov_layer,
}

/// Writes rows `[first_row, end_row)` of the auxiliary outputs a denoiser
/// or a temporal upscaler reads into the host's buffers (`out`), from one
/// primary ray per pixel through its centre and the lens centre, traced
/// as packets, through the renderer's current camera:
/// - albedo: the directional reflectance of the surface first hit, towards
///   the camera (textures applied; a mirror its reflectance, clear smooth
///   glass 1), in [0, 1]; 0 where the ray leaves the scene;
/// - normal: that surface's shading normal (normal maps applied), world
///   space, unit, turned towards the camera; 0 on a miss;
/// - depth: camera-space z, (point − camera position) · view direction;
///   +infinity on a miss;
/// - motion: where the point was in the previous frame, in pixels, minus
///   the pixel's centre (x + 0.5, y + 0.5), +x right, +y down: the point
///   carried back by its mesh's motion since `cmlt_scene_begin_frame`
///   (`cmlt_scene_update_mesh`'s previous positions through the hit's
///   barycentric coordinates) and projected through `previous` (the last
///   frame's camera; NULL = the camera did not move); on a miss, the
///   direction's point at infinity; 0 where the previous camera cannot see
///   the point.
///
/// Reads the scene and the camera only: host threads may compute bands of
/// rows at the same time, also while workers render; any split gives the
/// same bytes. Allocates nothing. `CMLT_ERROR_INVALID_ARGUMENT` for rows
/// outside the image, an unknown format, a misaligned or too small layer,
/// or a bad `previous` camera (nothing is written); `CMLT_ERROR_BUSY`
/// while the renderer's camera changes or the scene is updated.
///
/// # Safety
/// `renderer`, `previous` and `out` are NULL or valid; each layer's
/// `data` is NULL or valid for writing its `buffer_size` bytes, and the
/// layers do not overlap.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_aov_rows(
    renderer: *const cmlt_renderer,
    previous: *const cmlt_camera,
    first_row: u32,
    end_row: u32,
    out: *const cmlt_aov_buffers,
) -> cmlt_status {
    guard("cmlt_renderer_aov_rows", || {
        // SAFETY: the caller's contract.
        let (r, out) = unsafe { (read(renderer, "renderer")?, read(out, "out")?) };
        let inner = r
            .renderer
            .try_read()
            .map_err(|e| Error::lock(e, "the renderer is being prepared or its camera changed"))?;
        let camera = *inner.camera();
        drop(inner);
        // SAFETY: the caller's contract.
        let previous = match unsafe { previous.as_ref() } {
            None => camera,
            Some(p) => p.camera(camera.width(), camera.height())?,
        };
        // SAFETY (all four): the caller's contract on each layer.
        let mut buffers = AovBuffers {
            albedo: unsafe { aov_layer(&out.albedo) }?,
            normal: unsafe { aov_layer(&out.normal) }?,
            depth: unsafe { aov_layer(&out.depth) }?,
            motion: unsafe { aov_layer(&out.motion) }?,
        };
        let live = r.scene.live()?;
        aov::render_rows(
            &live.scene,
            &live.accel,
            &camera,
            &previous,
            first_row..end_row,
            &mut buffers,
        )
        .map_err(render_error)
    })
}

/// The core's layer over a host's `cmlt_aov_layer` (`None` for NULL data).
///
/// # Safety
/// `layer.data` is NULL or valid for writing `layer.buffer_size` bytes,
/// which nothing else touches during the call.
unsafe fn aov_layer<'a>(layer: &cmlt_aov_layer) -> Result<Option<AovLayer<'a>>> {
    if layer.data.is_null() {
        return Ok(None);
    }
    let format = match layer.format {
        CMLT_AOV_F32 => AovFormat::F32,
        CMLT_AOV_F16 => AovFormat::F16,
        _ => return Err(Error::invalid("unknown auxiliary output format")),
    };
    let align = format.bytes();
    if !(layer.data as usize).is_multiple_of(align) || !layer.row_stride.is_multiple_of(align) {
        return Err(Error::invalid(
            "an auxiliary output's data and row_stride must be aligned to its element size",
        ));
    }
    // SAFETY: the caller's contract.
    let data =
        unsafe { std::slice::from_raw_parts_mut(layer.data.cast::<u8>(), layer.buffer_size) };
    Ok(Some(AovLayer {
        data,
        row_stride: layer.row_stride,
        format,
    }))
}

/// `*out` = the counters of the current accumulation over all workers.
///
/// # Safety
/// `renderer` and `out` are NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn cmlt_renderer_get_stats(
    renderer: *const cmlt_renderer,
    out: *mut cmlt_stats,
) -> cmlt_status {
    guard("cmlt_renderer_get_stats", || {
        // SAFETY: the caller's contract.
        let (r, out) = unsafe { (read(renderer, "renderer")?, write(out, "out")?) };
        let inner = r
            .renderer
            .try_read()
            .map_err(|e| Error::lock(e, "the renderer is being prepared or moved"))?;
        let mut s = RenderStats::default();
        for slot in r.workers.iter() {
            let w = slot
                .try_read()
                .map_err(|e| Error::lock(e, "a worker is being rendered"))?;
            s.merge(&inner.worker_stats(&w));
        }
        let live = r.scene.live()?;
        let m = &s.mlt;
        *out = cmlt_stats {
            samples: s.tracer.samples,
            mutations: m.mutations,
            acceptance: if m.mutations == 0 {
                0.0
            } else {
                (m.small_accepted + m.large_accepted) as f64 / m.mutations as f64
            },
            lens_steps: m.lens_steps,
            lens_acceptance: m.lens_acceptance(),
            caustic_steps: m.caustic_steps,
            caustic_acceptance: m.caustic_acceptance(),
            rays: s.tracer.rays,
            shadow_rays: s.tracer.shadow_rays,
            packets: s.tracer.packets,
            packet_rays: s.tracer.packet_rays,
            nonfinite: s.nonfinite,
            rejected_host_hits: match &live.accel {
                Accel::Host(h) => h.rejected_hits(),
                _ => 0,
            },
            rejected_host_surfaces: r.scene.rejected_surfaces(),
            b: s.b,
            effects: live.scene.analysis(inner.camera()).effects.0,
            bsdf_samples: split_lobes(&s.tracer.bsdf_samples).0,
            bsdf_evals: split_lobes(&s.tracer.bsdf_evals).0,
            lens_samples: s.tracer.lens_samples,
            bsdf_samples_more: split_lobes(&s.tracer.bsdf_samples).1,
            bsdf_evals_more: split_lobes(&s.tracer.bsdf_evals).1,
            multi_chain_steps: m.multi_chain_steps,
            multi_chain_acceptance: m.multi_chain_acceptance(),
        };
        Ok(())
    })
}

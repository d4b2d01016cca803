//! `cmlt render`'s options, grouped by what they set: the scene, the
//! estimator and its budget, the Metropolis settings (level 1, CMLT's
//! level 2), the output, the frame loop. Each group turns itself into the
//! core's types ([`Estimator`], [`Budget`], [`MltSettings`],
//! [`Level2Settings`], [`RendererConfig`]); the parsers of single values
//! check their ranges, so a bad value is refused with a message before
//! anything is loaded, and so is an option the chosen `--method` does not
//! read ([`check_method_options`]).

use std::path::PathBuf;

use clap::{Args, Command};
use cmlt::integrator::Settings;
use cmlt::mlt::{
    Candidates, CmltSettings, Level1, Level2Settings, MltSettings, PathMutations, Splatting,
};
use cmlt::renderer::{
    Accumulation, Budget, Estimator, EstimatorKind, MAX_PIXEL_BLOCK, PixelBlock, RendererConfig,
    Temporal,
};

/// The longest `--time` budget accepted: a year, so that a deadline
/// always fits the clock (`inf` or 1e30 s used to panic).
pub const MAX_SECONDS: f64 = 365.0 * 24.0 * 3600.0;

/// Most worker threads: far beyond any machine's cores, and each one holds
/// a film of the whole image.
pub const MAX_THREADS: usize = 1024;

/// Most frames one `--frames` render writes.
pub const MAX_FRAMES: usize = 1_000_000;

/// Everything `cmlt render` takes.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// What to render.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Which estimator, for how long, on how many threads.
    #[command(flatten)]
    pub estimator: EstimatorArgs,
    /// MLT and CMLT settings (level 1).
    #[command(flatten)]
    pub mlt: MltArgs,
    /// CMLT's level 2.
    #[command(flatten)]
    pub level2: Level2Args,
    /// Where the image goes.
    #[command(flatten)]
    pub output: OutputArgs,
    /// The frame loop (`--frames`).
    #[command(flatten)]
    pub frames: FrameArgs,
    /// One part of a render split over processes (`--part`, `--state`).
    #[command(flatten)]
    pub part: PartArgs,
}

/// Rendering one part of an image split over processes or machines, to be
/// combined by `cmlt merge`.
#[derive(Args, Debug)]
#[command(next_help_heading = "Parts (distributed rendering)")]
pub struct PartArgs {
    /// Render part I of N (I in 0..N): the same render with its own random
    /// streams (part 0 uses --seed itself), on its own budget; needs
    /// --state.
    #[arg(long, value_parser = parse_part, requires = "state")]
    pub part: Option<(u32, u32)>,
    /// Write the part's mergeable state (film sums, counters, bootstrap
    /// tallies, settings) here for `cmlt merge`; the image is then written
    /// only when -o is given.
    #[arg(long, requires = "part")]
    pub state: Option<PathBuf>,
}

/// The scene and how it is traced.
#[derive(Args, Debug)]
#[command(next_help_heading = "Scene")]
pub struct SceneArgs {
    /// Mitsuba 3 XML scene file, or a built-in name (`cornell-box`).
    pub scene: Option<String>,
    /// Override a scene `<default>` (e.g. `-D resx=64`), like Mitsuba's -D.
    #[arg(short = 'D', value_parser = parse_define)]
    pub define: Vec<(String, String)>,
    /// Ray-tracing backend for every method: our BVH, or Embree
    /// (builds with `--features embree` only).
    #[arg(long, value_enum, default_value = "ours")]
    pub accel: AccelArg,
    /// Simulate every effect (all lobes, lens sampling, caustic
    /// perturbations, full depth) instead of only those the scene
    /// calls for: switches the scene analysis off.
    #[arg(long)]
    pub all_effects: bool,
}

/// `--accel`: which ray-tracing backend renders.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum AccelArg {
    /// Our BVH (8-wide, SIMD kernels; always available).
    Ours,
    /// Embree 3 (only in builds with `--features embree`; an error otherwise).
    Embree,
}

/// The estimator, its budget, threads and seed.
#[derive(Args, Debug)]
#[command(next_help_heading = "Estimator and budget")]
pub struct EstimatorArgs {
    /// Estimator: pt (path tracing with next-event estimation and MIS),
    /// bdpt (bidirectional path tracing with MIS), mlt (primary-sample-space
    /// Metropolis light transport over BDPT: the "MLT and CMLT" options) or
    /// cmlt (coherent MLT: MLT plus lens, caustic and multi-chain
    /// perturbations traced as packets: also the "CMLT" options). An
    /// option the method does not read is an error.
    #[arg(long, default_value = "pt", value_parser = parse_estimator)]
    pub method: EstimatorKind,
    /// Samples per pixel, at least 1 (default: the scene's
    /// `sample_count`).
    #[arg(long, conflicts_with = "time", value_parser = clap::value_parser!(u64).range(1..))]
    pub spp: Option<u64>,
    /// MLT, CMLT: mutations per pixel over all threads, at least 1
    /// (default: --spp, else the scene's `sample_count`).
    #[arg(long, conflicts_with = "time", value_parser = clap::value_parser!(u64).range(1..))]
    pub mutations_per_pixel: Option<u64>,
    /// Render for this many seconds instead of a fixed sample count
    /// (finite, > 0, at most a year).
    #[arg(long, value_parser = parse_seconds)]
    pub time: Option<f64>,
    /// Worker threads, 1..=1024 (default: all cores).
    #[arg(long, value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// Seed of all random streams.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

impl EstimatorArgs {
    /// The budget: `--time`, else `--mutations-per-pixel` (MLT, CMLT) or
    /// `--spp`, else the scene's sample count (16 when it has none).
    pub fn budget(&self, scene_spp: Option<u32>) -> Budget {
        if let Some(t) = self.time {
            return Budget::Seconds(t);
        }
        let n = if self.method.is_metropolis() {
            self.mutations_per_pixel.or(self.spp)
        } else {
            self.spp
        };
        Budget::PerPixel(n.unwrap_or(scene_spp.unwrap_or(16) as u64))
    }

    /// `--threads`, or all cores.
    pub fn threads(&self) -> usize {
        threads_or_all(self.threads)
    }
}

/// Level-1 Metropolis settings (MLT and CMLT).
#[derive(Args, Debug)]
#[command(next_help_heading = "MLT and CMLT")]
pub struct MltArgs {
    /// The space level 1's chains mutate in: primary (Kelemen et al.'s
    /// primary sample space) or path (Veach's path space with the
    /// bidirectional and lens subpath mutations and the lens, caustic and
    /// multi-chain perturbations, CMLT's level 2 over them; every kind of
    /// light, and media; scenes with smooth plastic are refused).
    #[arg(long, default_value = "primary", value_parser = parse_level1)]
    pub level1: Level1,
    /// Markov chains per thread.
    #[arg(long, default_value_t = MltSettings::default().n_chains)]
    pub chains: u32,
    /// Probability of a large step (an independent sample), in [0, 1].
    #[arg(long, default_value_t = MltSettings::default().large_step_prob)]
    pub large_step: f32,
    /// Width of small steps in primary sample space, in (0, 1].
    #[arg(long, default_value_t = MltSettings::default().sigma)]
    pub sigma: f32,
    /// Bootstrap samples per path depth (the chains' starting points).
    #[arg(long, default_value_t = MltSettings::default().n_bootstrap)]
    pub bootstrap: u32,
    /// BDPT passes that estimate the normalisation b (the image's mean
    /// luminance, which scales the whole image); 0 = estimate b from the
    /// bootstrap samples as pbrt does.
    #[arg(long, default_value_t = MltSettings::default().b_passes)]
    pub b_passes: u32,
    /// Least number of normalisation samples (passes × pixels): a small
    /// image gets more passes than --b-passes (at most 1024 from this
    /// floor), so that b's error does not grow as the image shrinks; 0 =
    /// exactly --b-passes; at most 16777216.
    #[arg(long, default_value_t = MltSettings::default().b_min_samples)]
    pub b_min_samples: u32,
    /// Least factor on the chains for emitters seen directly (paths of one
    /// segment) against their share of the image's luminance, in (0, 1]:
    /// they get chains for the area that sees an emitter, at least this
    /// share; 1 = chains in proportion to luminance at every path depth.
    #[arg(long, default_value_t = MltSettings::default().direct_allocation)]
    pub direct_allocation: f32,
    /// Record the large steps' proposals also as independent samples,
    /// combined with the chains' records by multiple importance sampling
    /// (Kelemen et al. 2002): same expectation, and pixels the chains
    /// seldom visit get the large steps' samples.
    #[arg(long, default_value_t = MltSettings::default().large_step_mis, action = clap::ArgAction::Set)]
    pub large_step_mis: bool,
    /// Weight of each normalisation-pass sample in the image, in records
    /// (one mutation's worth): the passes' BDPT image is added to the
    /// chains' by these fixed weights; 0 = the passes only estimate b; in
    /// [0, 1024]. Not used with --keep-chains.
    #[arg(long, default_value_t = MltSettings::default().pass_records)]
    pub pass_records: f32,
    /// With --level1 path: the weights of the bidirectional mutation, the
    /// lens subpath mutation and the lens, caustic and multi-chain
    /// perturbations, five comma-separated numbers; at a path each
    /// mutation that applies is chosen in proportion to its weight (0 =
    /// off; the bidirectional one's must be positive).
    #[arg(long, default_value = "1,1,1,1,1", value_parser = parse_path_weights)]
    pub path_mutations: [f32; 5],
    /// With --level1 path: the perturbations' image-plane σ in pixels
    /// (their angular σ is as many pixel angles times
    /// --perturbation-caustic-scale).
    #[arg(long, default_value_t = PathMutations::default().sigma)]
    pub perturbation_sigma: f32,
    /// With --level1 path: the caustic and multi-chain perturbations'
    /// angular σ as a multiple of --perturbation-sigma pixel angles.
    #[arg(long, default_value_t = PathMutations::default().caustic_scale)]
    pub perturbation_caustic_scale: f32,
}

/// `--path-mutations`: five comma-separated weights.
pub fn parse_path_weights(s: &str) -> Result<[f32; 5], String> {
    let w: Vec<f32> = s
        .split(',')
        .map(|v| {
            v.trim()
                .parse::<f32>()
                .map_err(|_| format!("'{v}' is not a number"))
        })
        .collect::<Result<_, _>>()?;
    w.try_into().map_err(|_| {
        format!("'{s}': five weights (bidirectional, lens subpath, lens, caustic, multi-chain)")
    })
}

impl MltArgs {
    /// The level-1 settings of these options, checked.
    pub fn settings(&self) -> Result<MltSettings, String> {
        if self.bootstrap == 0 {
            return Err("--bootstrap must be at least 1".to_string());
        }
        let mlt = MltSettings {
            level1: self.level1,
            n_bootstrap: self.bootstrap,
            b_passes: self.b_passes,
            b_min_samples: self.b_min_samples,
            n_chains: self.chains,
            large_step_prob: self.large_step,
            sigma: self.sigma,
            direct_allocation: self.direct_allocation,
            large_step_mis: self.large_step_mis,
            pass_records: self.pass_records,
            path_mutations: PathMutations::new(
                self.path_mutations,
                self.perturbation_sigma,
                self.perturbation_caustic_scale,
            ),
        };
        mlt.validate().map_err(|e| {
            format!(
                "{e} (--large-step {}, --sigma {}, --chains {}, --b-min-samples {}, --direct-allocation {}, --pass-records {}, --path-mutations {:?}, --perturbation-sigma {}, --perturbation-caustic-scale {})",
                self.large_step,
                self.sigma,
                self.chains,
                self.b_min_samples,
                self.direct_allocation,
                self.pass_records,
                self.path_mutations,
                self.perturbation_sigma,
                self.perturbation_caustic_scale
            )
        })?;
        Ok(mlt)
    }
}

/// CMLT's level-2 settings (defaults: [`Level2Settings::default`], the
/// measured ones).
#[derive(Args, Debug)]
#[command(next_help_heading = "CMLT")]
pub struct Level2Args {
    /// Candidates per multiple-try step, 1..=64.
    #[arg(long, default_value_t = Level2Settings::default().k)]
    pub k: u32,
    /// Side-chain length (steps per level-1 mutation), at least 1.
    #[arg(long, default_value_t = Level2Settings::default().m)]
    pub m: u32,
    /// Standard deviation of the lens perturbation, in pixels.
    #[arg(long, default_value_t = Level2Settings::default().lens_sigma)]
    pub lens_sigma: f32,
    /// The caustic perturbation's angular width as a multiple of
    /// lens-sigma pixel angles.
    #[arg(long, default_value_t = Level2Settings::default().caustic_scale)]
    pub caustic_scale: f32,
    /// How the k candidates of a step are drawn: independent, or
    /// stratified (a randomly shifted lattice).
    #[arg(long, default_value = "stratified", value_parser = parse_candidates)]
    pub candidates: Candidates,
    /// What a multiple-try step records: recycled (every candidate,
    /// weighted by its one-proposal acceptance over k) or expected (the
    /// selected candidate with a, the current state with 1 − a).
    #[arg(long, default_value = "recycled", value_parser = parse_splatting)]
    pub splatting: Splatting,
    /// Parallel one-proposal side chains per level-1 state, traced
    /// together as packets, 1..=64 (needs --k 1 above 1).
    #[arg(long, default_value_t = Level2Settings::default().lanes)]
    pub lanes: u32,
    /// Paths of fewer segments get no side chain (their level-1 records
    /// carry the side chain's share instead).
    #[arg(long, default_value_t = Level2Settings::default().side_chain_min_depth)]
    pub side_chain_min_depth: u32,
    /// The weight of a level-1 mutation's side chain, in records of one
    /// mutation (0 = --m).
    #[arg(long, default_value_t = Level2Settings::default().share)]
    pub share: u32,
}

impl Level2Args {
    /// The level-2 settings of these options, checked.
    pub fn settings(&self) -> Result<Level2Settings, String> {
        let l2 = Level2Settings {
            m: self.m,
            k: self.k,
            lens_sigma: self.lens_sigma,
            caustic_scale: self.caustic_scale,
            candidates: self.candidates,
            splatting: self.splatting,
            lanes: self.lanes,
            side_chain_min_depth: self.side_chain_min_depth,
            share: self.share,
        };
        l2.validate().map_err(|e| {
            format!(
                "{e} (--m {}, --k {}, --lens-sigma {}, --caustic-scale {}, --lanes {})",
                self.m, self.k, self.lens_sigma, self.caustic_scale, self.lanes
            )
        })?;
        Ok(l2)
    }
}

/// Options outside [`MltArgs`] that only MLT and CMLT read (their ids).
const METROPOLIS_OPTIONS: [&str; 3] = ["mutations_per_pixel", "keep_chains", "b_window"];

/// Refuses an option of `cmlt render` that `method` does not read, given on
/// the command line (`given(id)` says whether the option of clap id `id`
/// was): [`MltArgs`], `--mutations-per-pixel`, `--keep-chains` and
/// `--b-window` are MLT's and CMLT's, [`Level2Args`] CMLT's alone. The
/// message names the option and the method.
pub fn check_method_options(
    method: EstimatorKind,
    given: impl Fn(&str) -> bool,
) -> Result<(), String> {
    let level1 = MltArgs::augment_args(Command::new("level 1"));
    let level2 = Level2Args::augment_args(Command::new("level 2"));
    let render = RenderArgs::augment_args(Command::new("render"));
    let has = |group: &Command, id: &str| group.get_arguments().any(|a| a.get_id() == id);
    for arg in render.get_arguments() {
        let id = arg.get_id().as_str();
        let readers: &[EstimatorKind] = if has(&level2, id) {
            &[EstimatorKind::Cmlt]
        } else if has(&level1, id) || METROPOLIS_OPTIONS.contains(&id) {
            &[EstimatorKind::Mlt, EstimatorKind::Cmlt]
        } else {
            continue;
        };
        if !readers.contains(&method) && given(id) {
            let names: Vec<&str> = readers.iter().map(|k| k.name()).collect();
            return Err(format!(
                "--{} is read by --method {} only, not by --method {}",
                arg.get_long().unwrap_or(id),
                names.join(" and "),
                method.name()
            ));
        }
    }
    Ok(())
}

/// Output files and reporting.
#[derive(Args, Debug)]
#[command(next_help_heading = "Output")]
pub struct OutputArgs {
    /// Output image (.exr linear, or .png sRGB; default cmlt.exr, none with
    /// --state unless given).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Also write an sRGB PNG preview here.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Compare with a reference OpenEXR and print relMSE and means.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// The frame loop.
#[derive(Args, Debug)]
#[command(next_help_heading = "Frames")]
pub struct FrameArgs {
    /// Render this many frames through the core's frame loop (one
    /// worker per thread), written as OUTPUT-0000.exr, … next to the
    /// output; the budget (--spp or --mutations-per-pixel) is per frame.
    #[arg(long, value_parser = parse_frames)]
    pub frames: Option<usize>,
    /// Frames: render only frame K (0-based) of the --frames sequence, as
    /// one part (--part, --state): frames are then rendered, and split, on
    /// any machines. The frame is the one the whole sequence renders when
    /// the frames are independent (no --keep-chains, --b-window or
    /// --accumulation, which carry state from frame to frame and are
    /// refused).
    #[arg(long, requires = "frames", requires = "part")]
    pub frame: Option<usize>,
    /// Frames: orbit the camera about the vertical through the point it
    /// looks at, --orbit-degrees over all frames.
    #[arg(long, requires = "frames")]
    pub orbit: bool,
    /// Frames: total orbit angle in degrees.
    #[arg(long, default_value_t = 30.0, requires = "orbit")]
    pub orbit_degrees: f32,
    /// Frames, MLT and CMLT: keep the chains across frames (re-evaluated
    /// after a camera move) instead of restarting them.
    #[arg(long, requires = "frames")]
    pub keep_chains: bool,
    /// Frames, MLT and CMLT: average b over this many frames while the
    /// camera stays put (0 = each frame its own b; at most 64).
    #[arg(long, default_value_t = 0, requires = "frames")]
    pub b_window: u32,
    /// Frames: reuse the same random sequences in every frame.
    #[arg(long, requires = "frames")]
    pub fixed_sequence: bool,
    /// Frames: what each frame carries of the earlier ones: reset (each
    /// frame its own image), keep (frames add up) or decay:F (earlier
    /// frames weigh F per frame of age, 0 < F < 1). Every method.
    #[arg(long, default_value = "reset", value_parser = parse_accumulation, requires = "frames")]
    pub accumulation: Accumulation,
    /// Frames: dynamic resolution, k (1..=64) or fit. PT and BDPT take
    /// one sample per k × k block of pixels, filling it (fit: k chosen
    /// at every pass from the last frame's samples); MLT and CMLT at any
    /// k but 1 mix such BDPT samples with their chains' splats (the
    /// block fill, an eighth of the work). 1 = full resolution.
    #[arg(long, default_value = "1", value_parser = parse_pixel_block, requires = "frames")]
    pub pixel_block: PixelBlock,
}

impl OutputArgs {
    /// Where the image goes: `-o`, else `cmlt.exr` — or nowhere for a
    /// part (`--state`) without `-o`.
    pub fn image_path(&self, part: bool) -> Option<PathBuf> {
        match (&self.output, part) {
            (Some(p), _) => Some(p.clone()),
            (None, false) => Some(PathBuf::from("cmlt.exr")),
            (None, true) => None,
        }
    }
}

impl FrameArgs {
    /// The frame-to-frame switches.
    pub fn temporal(&self) -> Temporal {
        Temporal {
            keep_chains: self.keep_chains,
            b_window: self.b_window,
            fixed_sequence: self.fixed_sequence,
            ..Temporal::default()
        }
    }
}

impl RenderArgs {
    /// The estimator `--method` names with the settings of its options
    /// (checked; the options it does not read are ignored here and refused
    /// by [`check_method_options`]).
    pub fn estimator(&self) -> Result<Estimator, String> {
        Ok(match self.estimator.method {
            EstimatorKind::Path => Estimator::Path,
            EstimatorKind::Bdpt => Estimator::Bdpt,
            EstimatorKind::Mlt => Estimator::Mlt(self.mlt.settings()?),
            EstimatorKind::Cmlt => Estimator::Cmlt(CmltSettings {
                mlt: self.mlt.settings()?,
                level2: self.level2.settings()?,
            }),
        })
    }

    /// The renderer configuration these options ask for over a scene with
    /// `settings`.
    pub fn config(&self, settings: Settings) -> Result<RendererConfig, String> {
        Ok(RendererConfig {
            estimator: self.estimator()?,
            settings,
            seed: self.estimator.seed,
            workers: self.estimator.threads() as u32,
            temporal: self.frames.temporal(),
            all_effects: self.scene.all_effects,
            ..RendererConfig::default()
        })
    }
}

/// `--method`: `pt`, `bdpt`, `mlt` or `cmlt` ([`EstimatorKind::name`]).
pub fn parse_estimator(s: &str) -> Result<EstimatorKind, String> {
    EstimatorKind::from_name(s)
        .ok_or_else(|| format!("unknown method '{s}' (expected pt, bdpt, mlt or cmlt)"))
}

/// `--candidates`: `independent` or `stratified`.
pub fn parse_candidates(s: &str) -> Result<Candidates, String> {
    match s {
        "independent" => Ok(Candidates::Independent),
        "stratified" => Ok(Candidates::Stratified),
        _ => Err(format!(
            "unknown candidates '{s}' (expected independent or stratified)"
        )),
    }
}

/// `--level1`: `primary` or `path`.
pub fn parse_level1(s: &str) -> Result<Level1, String> {
    match s {
        "primary" => Ok(Level1::PrimarySample),
        "path" => Ok(Level1::PathSpace),
        _ => Err(format!("unknown level 1 '{s}' (expected primary or path)")),
    }
}

/// `--splatting`: `recycled` or `expected`.
pub fn parse_splatting(s: &str) -> Result<Splatting, String> {
    match s {
        "recycled" => Ok(Splatting::Recycled),
        "expected" => Ok(Splatting::ExpectedValue),
        _ => Err(format!(
            "unknown splatting '{s}' (expected recycled or expected)"
        )),
    }
}

/// A time budget in seconds: finite, positive, at most [`MAX_SECONDS`].
pub fn parse_seconds(s: &str) -> Result<f64, String> {
    let t: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if t.is_finite() && t > 0.0 && t <= MAX_SECONDS {
        Ok(t)
    } else {
        Err(format!(
            "the time budget must be finite, > 0 and at most {MAX_SECONDS} s, got {s}"
        ))
    }
}

/// A thread count in 1..=[`MAX_THREADS`].
pub fn parse_threads(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if (1..=MAX_THREADS).contains(&n) => Ok(n),
        _ => Err(format!("threads must be in 1..={MAX_THREADS}, got {s}")),
    }
}

/// `--accumulation`: `reset`, `keep` or `decay:F` with F in (0, 1).
pub fn parse_accumulation(s: &str) -> Result<Accumulation, String> {
    let mode = match s.split_once(':') {
        None if s == "reset" => Accumulation::Reset,
        None if s == "keep" => Accumulation::Keep,
        Some(("decay", f)) => Accumulation::Decay(
            f.parse()
                .map_err(|_| format!("the decay factor '{f}' is not a number"))?,
        ),
        _ => {
            return Err(format!(
                "unknown accumulation '{s}' (expected reset, keep or decay:F)"
            ));
        }
    };
    mode.validate().map_err(|e| format!("{e}, got {s}"))?;
    Ok(mode)
}

/// `--pixel-block`: a block size in 1..=[`MAX_PIXEL_BLOCK`] or `fit`.
pub fn parse_pixel_block(s: &str) -> Result<PixelBlock, String> {
    let block = match s {
        "fit" => PixelBlock::Fit,
        k => PixelBlock::Fixed(k.parse().map_err(|_| {
            format!("the pixel block must be 1..={MAX_PIXEL_BLOCK} or fit, got {s}")
        })?),
    };
    block.validate().map_err(|e| format!("{e}, got {s}"))?;
    Ok(block)
}

/// A frame count in 1..=[`MAX_FRAMES`].
pub fn parse_frames(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if (1..=MAX_FRAMES).contains(&n) => Ok(n),
        _ => Err(format!("frames must be in 1..={MAX_FRAMES}, got {s}")),
    }
}

/// `--part I/N`: 0 ≤ I < N ≤ [`crate::state::MAX_PARTS`].
pub fn parse_part(s: &str) -> Result<(u32, u32), String> {
    let err = || {
        format!(
            "expected I/N with 0 <= I < N <= {}, got '{s}'",
            crate::state::MAX_PARTS
        )
    };
    let (i, n) = s.split_once('/').ok_or_else(err)?;
    let (i, n): (u32, u32) = (
        i.trim().parse().map_err(|_| err())?,
        n.trim().parse().map_err(|_| err())?,
    );
    if i < n && n <= crate::state::MAX_PARTS {
        Ok((i, n))
    } else {
        Err(err())
    }
}

/// `-D NAME=VALUE`.
pub fn parse_define(s: &str) -> Result<(String, String), String> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=VALUE, got '{s}'"))?;
    Ok((k.to_string(), v.to_string()))
}

/// `threads`, or all cores.
pub fn threads_or_all(threads: Option<usize>) -> usize {
    threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    /// `cmlt render`'s options on their own.
    #[derive(Parser)]
    struct Render {
        #[command(flatten)]
        args: RenderArgs,
    }

    /// The check over a parsed command line, as `cmlt render` runs it.
    fn check(line: &[&str]) -> Result<(), String> {
        let m = <Render as clap::CommandFactory>::command()
            .try_get_matches_from(std::iter::once("render").chain(line.iter().copied()))
            .map_err(|e| e.to_string())?;
        let method = *m.get_one::<EstimatorKind>("method").expect("a default");
        check_method_options(method, |id| {
            m.value_source(id) == Some(clap::parser::ValueSource::CommandLine)
        })
    }

    #[test]
    fn each_method_reads_its_own_options_only() {
        for line in [
            &["--method", "pt", "--spp", "4"][..],
            &["--method", "mlt", "--chains", "8", "--sigma", "0.02"],
            &[
                "--method",
                "mlt",
                "--mutations-per-pixel",
                "4",
                "--frames",
                "2",
            ],
            &["--method", "cmlt", "--chains", "8", "--k", "4", "--m", "2"],
            &["--method", "cmlt", "--frames", "2", "--keep-chains"],
            &["--method", "mlt", "--frames", "2", "--accumulation", "keep"],
            &["--method", "mlt", "--chains", "256"],
        ] {
            assert_eq!(check(line), Ok(()), "{line:?}");
        }
        // An option given with its default value is still given.
        let err = check(&["--method", "pt", "--chains", "256"]).unwrap_err();
        assert!(err.contains("--chains is read by"), "{err}");
        let err = check(&["--method", "mlt", "--m", "1"]).unwrap_err();
        assert!(err.contains("--m is read by --method cmlt only"), "{err}");
        let err = check(&["--method", "bdpt", "--b-passes", "4"]).unwrap_err();
        assert!(err.contains("--method mlt and cmlt only"), "{err}");
    }

    #[test]
    fn accumulation_modes_parse_and_bad_factors_are_refused() {
        assert_eq!(parse_accumulation("reset"), Ok(Accumulation::Reset));
        assert_eq!(parse_accumulation("keep"), Ok(Accumulation::Keep));
        assert_eq!(
            parse_accumulation("decay:0.75"),
            Ok(Accumulation::Decay(0.75))
        );
        for bad in ["decay", "decay:1", "decay:0", "decay:x", "keep:0.5", "avg"] {
            assert!(parse_accumulation(bad).is_err(), "{bad}");
        }
        let cli = Render::parse_from(["render", "--frames", "3", "--accumulation", "decay:0.5"]);
        assert_eq!(cli.args.frames.accumulation, Accumulation::Decay(0.5));
        // Only the frame loop carries anything from frame to frame.
        assert!(check(&["--accumulation", "keep"]).is_err());
    }

    #[test]
    fn path_mutation_options_reach_the_settings_and_bad_ones_are_refused() {
        let path = ["render", "--method", "mlt", "--level1", "path"];
        let given = [
            "--path-mutations",
            "1,2,3,4,5",
            "--perturbation-sigma",
            "3",
            "--perturbation-caustic-scale",
            "0.5",
        ];
        let cli = Render::parse_from(path.iter().chain(&given));
        let Ok(Estimator::Mlt(m)) = cli.args.estimator() else {
            panic!("MLT settings expected");
        };
        let want = PathMutations::new([1.0, 2.0, 3.0, 4.0, 5.0], 3.0, 0.5);
        assert_eq!(m.path_mutations, want);
        assert_eq!(want.weights(), [1.0, 2.0, 3.0, 4.0, 5.0]);
        for bad in [
            "--perturbation-caustic-scale=0",
            "--perturbation-caustic-scale=NaN",
            "--perturbation-caustic-scale=inf",
            "--perturbation-sigma=-1",
            "--path-mutations=0,1,1,1,1",
        ] {
            let cli = Render::parse_from(path.iter().chain(&[bad]));
            let err = cli.args.estimator().unwrap_err();
            let option = bad.split('=').next().unwrap();
            assert!(err.contains(option), "{bad}: {err}");
        }
    }

    #[test]
    fn pixel_blocks_parse_and_bad_sizes_are_refused() {
        assert_eq!(parse_pixel_block("fit"), Ok(PixelBlock::Fit));
        assert_eq!(parse_pixel_block("1"), Ok(PixelBlock::Fixed(1)));
        assert_eq!(parse_pixel_block("64"), Ok(PixelBlock::Fixed(64)));
        for bad in ["0", "65", "-1", "x", "Fit", ""] {
            assert!(parse_pixel_block(bad).is_err(), "{bad}");
        }
        let cli = Render::parse_from(["render", "--frames", "3", "--pixel-block", "fit"]);
        assert_eq!(cli.args.frames.pixel_block, PixelBlock::Fit);
        let cli = Render::parse_from(["render", "--frames", "3"]);
        assert_eq!(cli.args.frames.pixel_block, PixelBlock::Fixed(1));
        assert!(check(&["--pixel-block", "4"]).is_err());
    }

    #[test]
    fn methods_map_one_to_one_to_estimators() {
        for kind in EstimatorKind::ALL {
            let cli = Render::parse_from(["render", "--method", kind.name()]);
            let e = cli.args.estimator().unwrap();
            assert_eq!(e, Estimator::default_for(kind), "{kind:?}");
        }
    }
}

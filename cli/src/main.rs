//! `cmlt`: render Mitsuba scenes with the cmlt core.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::{Parser, Subcommand, ValueEnum};
use cmlt::integrator::Method;
use cmlt::mlt::MltSettings;
use cmlt::renderer::{Estimator, RendererConfig, Temporal};
use cmlt::scene::Analysis;
use cmlt_cli::accel::{Accel, AccelKind};
use cmlt_cli::bench::study::load_scene_or_builtin;
use cmlt_cli::frames;
use cmlt_cli::image_io::{self, Image};
use cmlt_cli::metrics;
use cmlt_cli::render::{Budget, MltBudget, render, render_mlt, work_line};
use cmlt_cli::scene::LoadedScene;
use indicatif::{ProgressBar, ProgressStyle};

#[derive(Parser)]
#[command(
    name = "cmlt",
    version,
    about = "Coherent Metropolis Light Transport renderer"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// `cmlt bench rays --clock`.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum ClockArg {
    /// Elapsed real time.
    Wall,
    /// CPU time of the tracing threads.
    Cpu,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum MethodArg {
    /// Path tracing with next-event estimation and MIS.
    Pt,
    /// Bidirectional path tracing with MIS.
    Bdpt,
    /// Metropolis light transport (primary-sample-space MLT over BDPT).
    Mlt,
    /// Coherent MLT: MLT plus multiple-try lens and caustic perturbations
    /// traced as packets (level 2; --k, --m, --lens-sigma).
    Cmlt,
}

/// `--accel`: which ray-tracing backend renders.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum AccelArg {
    /// Our BVH (8-wide, SIMD kernels; always available).
    Ours,
    /// Embree 3 (only in builds with `--features embree`; an error otherwise).
    Embree,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum CandidatesArg {
    /// Independent candidates.
    Independent,
    /// Stratified candidates (a randomly shifted lattice).
    Stratified,
}

/// `--splatting`: what a CMLT multiple-try step records.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum SplattingArg {
    /// Every candidate, weighted by its one-proposal acceptance over k.
    Recycled,
    /// The selected candidate with a, the current state with 1 − a.
    Expected,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (the built-in Cornell box when no file is given).
    Render {
        /// Mitsuba 3 XML scene file, or a built-in name (`cornell-box`).
        scene: Option<String>,
        /// Estimator.
        #[arg(long, value_enum, default_value = "pt")]
        method: MethodArg,
        /// Samples per pixel, at least 1 (default: the scene's
        /// `sample_count`).
        #[arg(long, conflicts_with = "time", value_parser = clap::value_parser!(u64).range(1..))]
        spp: Option<u64>,
        /// MLT: mutations per pixel over all threads, at least 1 (default:
        /// --spp, else the scene's `sample_count`).
        #[arg(long, conflicts_with = "time", value_parser = clap::value_parser!(u64).range(1..))]
        mutations_per_pixel: Option<u64>,
        /// MLT: Markov chains per thread.
        #[arg(long, default_value_t = MltSettings::default().n_chains)]
        chains: u32,
        /// MLT: probability of a large step (an independent sample), in [0, 1].
        #[arg(long, default_value_t = MltSettings::default().large_step_prob)]
        large_step: f32,
        /// MLT: width of small steps in primary sample space, in (0, 1].
        #[arg(long, default_value_t = MltSettings::default().sigma)]
        sigma: f32,
        /// MLT: bootstrap seed samples per path depth (the chains' starting
        /// points).
        #[arg(long, default_value_t = MltSettings::default().n_bootstrap)]
        bootstrap: u32,
        /// MLT: BDPT passes that estimate the normalisation b (the image's
        /// mean luminance, which scales the whole image); 0 = estimate b
        /// from the seed samples as pbrt does.
        #[arg(long, default_value_t = MltSettings::default().b_passes)]
        b_passes: u32,
        /// CMLT: candidates per multiple-try step, 1..=64 (default: the
        /// CMLT default for --method cmlt, 1 for mlt).
        #[arg(long)]
        k: Option<u32>,
        /// CMLT: side-chain length (multiple-try steps per level-1
        /// mutation); 0 = plain MLT (default: the CMLT default for --method
        /// cmlt, 0 for mlt).
        #[arg(long)]
        m: Option<u32>,
        /// CMLT: standard deviation of the lens perturbation, in pixels.
        #[arg(long, default_value_t = MltSettings::cmlt().lens_sigma)]
        lens_sigma: f32,
        /// CMLT: the caustic perturbation's angular width as a multiple of
        /// lens-sigma pixel angles.
        #[arg(long, default_value_t = MltSettings::cmlt().caustic_scale)]
        caustic_scale: f32,
        /// CMLT: how the k candidates of a step are drawn.
        #[arg(long, value_enum, default_value = "stratified")]
        candidates: CandidatesArg,
        /// CMLT: what a multiple-try step records.
        #[arg(long, value_enum, default_value = "recycled")]
        splatting: SplattingArg,
        /// Render for this many seconds instead of a fixed sample count
        /// (finite, > 0, at most a year).
        #[arg(long, value_parser = parse_seconds)]
        time: Option<f64>,
        /// Worker threads, 1..=1024 (default: all cores).
        #[arg(long, value_parser = parse_threads)]
        threads: Option<usize>,
        /// Ray-tracing backend for every method: our BVH, or Embree
        /// (builds with `--features embree` only).
        #[arg(long, value_enum, default_value = "ours")]
        accel: AccelArg,
        /// Seed of all random streams.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Output image (.exr linear, or .png sRGB).
        #[arg(short, long, default_value = "cmlt.exr")]
        output: PathBuf,
        /// Also write an sRGB PNG preview here.
        #[arg(long)]
        png: Option<PathBuf>,
        /// Override a scene `<default>` (e.g. `-D resx=64`), like Mitsuba's -D.
        #[arg(short = 'D', value_parser = parse_define)]
        define: Vec<(String, String)>,
        /// Compare with a reference OpenEXR and print relMSE and means.
        #[arg(long)]
        reference: Option<PathBuf>,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
        /// Render this many frames through the core's frame loop (one
        /// worker per thread), written as OUTPUT-0000.exr, … next to the
        /// output; the budget (--spp or --mutations-per-pixel) is per frame.
        #[arg(long, conflicts_with = "time", value_parser = parse_frames)]
        frames: Option<usize>,
        /// Frames: orbit the camera about the vertical through the point it
        /// looks at, --orbit-degrees over all frames.
        #[arg(long, requires = "frames")]
        orbit: bool,
        /// Frames: total orbit angle in degrees.
        #[arg(long, default_value_t = 30.0, requires = "orbit")]
        orbit_degrees: f32,
        /// Frames, MLT/CMLT: keep the chains across frames (re-evaluated
        /// after a camera move) instead of restarting them.
        #[arg(long, requires = "frames")]
        keep_chains: bool,
        /// Frames, MLT/CMLT: average b over this many frames while the camera
        /// stays put (0 = each frame its own b; at most 64).
        #[arg(long, default_value_t = 0, requires = "frames")]
        b_window: u32,
        /// Frames: reuse the same random sequences in every frame.
        #[arg(long, requires = "frames")]
        fixed_sequence: bool,
        /// Simulate every effect (all lobes, lens sampling, caustic
        /// perturbations, full depth) instead of only those the scene
        /// calls for: switches the scene analysis off.
        #[arg(long)]
        all_effects: bool,
    },
    /// Benchmarks.
    #[command(subcommand)]
    Bench(BenchCommand),
}

/// `cmlt bench …` (implemented in `cmlt_cli::bench`).
#[derive(Subcommand)]
enum BenchCommand {
    /// Ray throughput (Mrays/s) of every traversal kernel, ours and Embree's.
    Rays {
        /// Scenes: shared scene names, XML paths, `mesh` (procedural).
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "cornell-box,veach-mis,veach-bidir,veach-ajar,mesh"
        )]
        scenes: Vec<String>,
        /// Seconds per measurement.
        #[arg(long, default_value_t = 0.1)]
        time: f64,
        /// Thread counts to measure.
        #[arg(long, value_delimiter = ',', default_value = "1,2")]
        threads: Vec<usize>,
        /// Primary rays per scene.
        #[arg(long, default_value_t = 65_536)]
        rays: usize,
        /// Triangles of the procedural mesh (at least).
        #[arg(long, default_value_t = 260_000)]
        mesh_triangles: usize,
        /// Directory of the shared scenes.
        #[arg(long, default_value = "tests/scenes")]
        scenes_dir: PathBuf,
        /// Write one CSV row per measurement here.
        #[arg(long)]
        csv: Option<PathBuf>,
        /// Only these kernels (e.g. `ours-avx512,ours-packet16,embree-16`;
        /// default all).
        #[arg(long, value_delimiter = ',')]
        kernels: Vec<String>,
        /// Only these ray sets (`primary,diffuse,mtm8,mtm16,shadow`;
        /// default all).
        #[arg(long, value_delimiter = ',')]
        sets: Vec<String>,
        /// Time rays by wall clock, or by the tracing threads' CPU time
        /// (steadier on a shared machine; Linux).
        #[arg(long, value_enum, default_value = "wall")]
        clock: ClockArg,
        /// Measure each cell's kernels this many times, taking turns, and
        /// report each kernel's best (steadier ratios on a shared machine).
        #[arg(long, default_value_t = 1)]
        rounds: usize,
    },
    /// Issue 4's throughput targets checked on the CSVs of `bench rays`
    /// runs: each run's table and tallies, then the cells that met each
    /// target in every run.
    RaysSummary {
        /// CSV files written by `bench rays --csv`.
        #[arg(required = true)]
        csv: Vec<PathBuf>,
    },
    /// Flicker of frame-by-frame MLT/CMLT with and without each temporal
    /// switch (static camera), and each orbit frame's mean against a BDPT
    /// reference of its camera (moving camera).
    Flicker {
        /// Mitsuba 3 XML scene file, or a built-in name (default
        /// `cornell-box`).
        scene: Option<String>,
        /// MLT or CMLT.
        #[arg(long, value_enum, default_value = "cmlt")]
        method: MethodArg,
        /// Frames per configuration.
        #[arg(long, default_value_t = 60)]
        frames: usize,
        /// Mutations per pixel per frame (over all workers).
        #[arg(long, default_value_t = 4)]
        mutations_per_pixel: u64,
        /// Workers (one thread each).
        #[arg(long, default_value_t = 2)]
        threads: u32,
        /// The b window of the b-window and all configurations.
        #[arg(long, default_value_t = 16)]
        b_window: u32,
        /// BDPT passes per frame that estimate b (the frame's mean
        /// luminance).
        #[arg(long, default_value_t = MltSettings::default().b_passes)]
        b_passes: u32,
        /// Also measure an orbit (every switch on) against BDPT references.
        #[arg(long)]
        moving: bool,
        /// Orbit: total angle in degrees.
        #[arg(long, default_value_t = 30.0)]
        orbit_degrees: f32,
        /// Orbit: frames (each gets its own reference).
        #[arg(long, default_value_t = 6)]
        orbit_frames: usize,
        /// Orbit: samples per pixel of each BDPT reference.
        #[arg(long, default_value_t = 256)]
        reference_spp: u64,
        /// Seed.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Override a scene `<default>` (e.g. `-D resx=64`).
        #[arg(short = 'D', value_parser = parse_define)]
        define: Vec<(String, String)>,
    },
    /// Samples/s (PT, BDPT) and mutations/s (MLT, CMLT) with the scene
    /// analysis on versus --all-effects, per scene, in one run.
    Effects {
        /// Scenes: shared scene names (under --scenes-dir), XML paths or
        /// built-in names. Defaults: a diffuse-only scene and a pinhole
        /// scene with glossy plates.
        #[arg(long, value_delimiter = ',', default_value = "cornell-box,veach-mis")]
        scenes: Vec<String>,
        /// Methods (pt, bdpt, mlt, cmlt).
        #[arg(long, value_delimiter = ',', default_value = "pt,bdpt,cmlt")]
        methods: Vec<String>,
        /// Seconds per render (MLT: bootstrap included).
        #[arg(long, default_value_t = 2.0)]
        time: f64,
        /// Renders per side (alternating on/off; the best counts).
        #[arg(long, default_value_t = 2)]
        repeats: usize,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Directory of the shared scenes.
        #[arg(long, default_value = "tests/scenes")]
        scenes_dir: PathBuf,
        /// Override a scene `<default>` in every scene (e.g. `-D resx=64`).
        #[arg(short = 'D', value_parser = parse_define)]
        define: Vec<(String, String)>,
    },
    /// Error against a reference versus time: every method at every
    /// budget (CSV and a log–log plot of relMSE vs wall time).
    Convergence {
        /// Mitsuba 3 XML scene file, or a built-in name.
        scene: String,
        /// Reference OpenEXR (full size, or any integer multiple of the
        /// render's size: box-filtered down).
        #[arg(long)]
        reference: PathBuf,
        /// Methods (pt, bdpt, mlt, cmlt; CMLT with its defaults).
        #[arg(long, value_delimiter = ',', default_value = "pt,bdpt,mlt,cmlt")]
        methods: Vec<String>,
        /// Budgets in seconds (or samples per pixel with --samples).
        #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32,64")]
        budgets: Vec<f64>,
        /// Budgets are samples per pixel (PT, BDPT) or mutations per pixel
        /// (MLT, CMLT): deterministic renders, for tests.
        #[arg(long)]
        samples: bool,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Seeds per budget (0..S), for budgets up to --seeds-up-to.
        #[arg(long, default_value_t = 3)]
        seeds: u64,
        /// Larger budgets render one seed only.
        #[arg(long, default_value_t = 4.0)]
        seeds_up_to: f64,
        /// Override a scene `<default>` (e.g. `-D resx=128`).
        #[arg(short = 'D', value_parser = parse_define)]
        define: Vec<(String, String)>,
        /// Write one CSV row per render here (replaced).
        #[arg(long)]
        csv: Option<PathBuf>,
        /// Write the plot to PREFIX.png and PREFIX.svg.
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Plot title (default: the scene's name).
        #[arg(long)]
        title: Option<String>,
    },
    /// CMLT's σ × k × m grid at a fixed time (the seed's §2.5.1): CSV, a
    /// heat map per m, and the best setting.
    Params {
        /// Mitsuba 3 XML scene file, or a built-in name.
        scene: String,
        /// Reference OpenEXR (full size or an integer multiple).
        #[arg(long)]
        reference: PathBuf,
        /// Seconds per render (bootstrap included).
        #[arg(long)]
        time: f64,
        /// Lens-perturbation σ values, pixels.
        #[arg(long, value_delimiter = ',', default_value = "0.5,1,2,4,8,16")]
        lens_sigmas: Vec<f32>,
        /// Candidates per multiple-try step.
        #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16")]
        ks: Vec<u32>,
        /// Side-chain lengths (≥ 1; plain MLT is measured as the baseline).
        #[arg(long, value_delimiter = ',', default_value = "1,4")]
        ms: Vec<u32>,
        /// How the k candidates of a step are drawn.
        #[arg(long, value_enum, default_value = "stratified")]
        candidates: CandidatesArg,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Seeds per cell (0..S).
        #[arg(long, default_value_t = 1)]
        seeds: u64,
        /// Override a scene `<default>` (e.g. `-D resx=128`).
        #[arg(short = 'D', value_parser = parse_define)]
        define: Vec<(String, String)>,
        /// Write one CSV row per render here.
        #[arg(long)]
        csv: Option<PathBuf>,
        /// Write the heat maps to PREFIX.png and PREFIX.svg.
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// Scores an image rendered elsewhere (a peer renderer) against a
    /// reference and appends a `bench convergence` CSV row.
    Score {
        /// The image (OpenEXR).
        image: PathBuf,
        /// Reference OpenEXR (full size or an integer multiple).
        #[arg(long)]
        reference: PathBuf,
        /// Method name for the row (e.g. `mitsuba-path`).
        #[arg(long)]
        method: String,
        /// The time budget, seconds (empty column if not given).
        #[arg(long)]
        budget_s: Option<f64>,
        /// Measured wall-clock seconds of the render.
        #[arg(long)]
        wall_s: f64,
        /// Seed of the render.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Samples per pixel of the render.
        #[arg(long, default_value_t = 0.0)]
        samples: f64,
        /// Mrays/s, if the renderer reports it (0 otherwise).
        #[arg(long, default_value_t = 0.0)]
        mrays_per_s: f64,
        /// The CSV to append to (created with its header if new).
        #[arg(long)]
        csv: PathBuf,
    },
    /// Redraws a `bench convergence` CSV (ours and peers' rows) as a plot
    /// and prints the curves; optionally how long each method takes to
    /// reach the error one method reaches at a given time.
    Plot {
        /// The CSV.
        #[arg(long)]
        csv: PathBuf,
        /// Write the plot to PREFIX.png and PREFIX.svg.
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Plot title.
        #[arg(long, default_value = "relative MSE vs time")]
        title: String,
        /// The reference, to print each method's mean ratio to it.
        #[arg(long)]
        reference: Option<PathBuf>,
        /// Compare every method with this one …
        #[arg(long, requires = "at")]
        versus: Option<String>,
        /// … at this many seconds.
        #[arg(long, requires = "versus")]
        at: Option<f64>,
    },
}

/// The longest `--time` budget accepted: a year, so that a deadline
/// always fits the clock (`inf` or 1e30 s used to panic).
const MAX_SECONDS: f64 = 365.0 * 24.0 * 3600.0;

/// Most worker threads: far beyond any machine's cores, and each one holds
/// a film of the whole image.
const MAX_THREADS: usize = 1024;

/// Most frames one `--frames` render writes.
const MAX_FRAMES: usize = 1_000_000;

/// A time budget in seconds: finite, positive, at most [`MAX_SECONDS`].
fn parse_seconds(s: &str) -> Result<f64, String> {
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
fn parse_threads(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if (1..=MAX_THREADS).contains(&n) => Ok(n),
        _ => Err(format!("threads must be in 1..={MAX_THREADS}, got {s}")),
    }
}

/// A frame count in 1..=[`MAX_FRAMES`].
fn parse_frames(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if (1..=MAX_FRAMES).contains(&n) => Ok(n),
        _ => Err(format!("frames must be in 1..={MAX_FRAMES}, got {s}")),
    }
}

fn parse_define(s: &str) -> Result<(String, String), String> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=VALUE, got '{s}'"))?;
    Ok((k.to_string(), v.to_string()))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Where results go.
struct Output<'a> {
    output: &'a Path,
    png: Option<&'a Path>,
    reference: Option<&'a Path>,
}

/// Writes the image (and PNG preview) and warns about dropped samples.
fn write_outputs(img: &Image, ctx: &Output<'_>, nonfinite: u64) -> Result<(), String> {
    image_io::write_image(ctx.output, img)?;
    if let Some(p) = ctx.png {
        image_io::write_png(p, img)?;
    }
    if nonfinite > 0 {
        eprintln!("warning: {nonfinite} non-finite samples were dropped");
    }
    Ok(())
}

/// Prints relMSE and mean ratios against a reference OpenEXR.
fn compare_reference(img: &Image, r: &Path) -> Result<(), String> {
    let reference = metrics::load_reference(r, img.width, img.height)?;
    let (mean, rm) = (img.mean(), reference.mean());
    println!(
        "vs reference: relMSE {:.6}, RMSE {:.6}; mean ratio ({:.4}, {:.4}, {:.4})",
        metrics::rel_mse(img, &reference),
        metrics::rmse(img, &reference),
        mean.r / rm.r,
        mean.g / rm.g,
        mean.b / rm.b
    );
    Ok(())
}

/// How `run_mlt` renders, besides the scene and the MLT settings.
struct MltRun<'a> {
    analysis: &'a Analysis,
    budget: MltBudget,
    threads: usize,
    seed: u64,
    quiet: bool,
    setup: std::time::Duration,
}

fn run_mlt(
    loaded: &LoadedScene,
    accel: &Accel,
    mlt: &MltSettings,
    run: MltRun<'_>,
    ctx: Output<'_>,
) -> Result<(), String> {
    let MltRun {
        analysis,
        budget,
        threads,
        seed,
        quiet,
        setup,
    } = run;
    let scene = &loaded.scene;
    let (w, h) = (scene.camera.width(), scene.camera.height());
    let pixels = w as u64 * h as u64;
    eprintln!(
        "scene: {} triangles, {} lights, {w}x{h}, max_depth {} (MLT depths 1..={}), {} on {threads} threads ({} BVH), {} chains/thread, large step {}, sigma {}, {} seed samples/depth, {} b passes{} (setup {:.2} s)",
        scene.triangle_count(),
        scene.lights.len(),
        loaded
            .settings
            .max_depth
            .map_or("unbounded".to_string(), |d| d.to_string()),
        cmlt::mlt::path_depth(&loaded.settings, mlt),
        if mlt.m > 0 { "CMLT" } else { "MLT" },
        accel.name(),
        mlt.n_chains,
        mlt.large_step_prob,
        mlt.sigma,
        mlt.n_bootstrap,
        mlt.b_passes,
        if mlt.m > 0 {
            format!(
                ", k {} m {} lens sigma {} px, caustic scale {}, {:?} candidates, {:?} splatting",
                mlt.k, mlt.m, mlt.lens_sigma, mlt.caustic_scale, mlt.candidates, mlt.splatting
            )
        } else {
            String::new()
        },
        setup.as_secs_f64()
    );
    let total = match budget {
        MltBudget::MutationsPerPixel(n) => Some(n.saturating_mul(pixels)),
        MltBudget::Time(_) => None,
    };
    let bar = progress_bar(quiet, total, "{human_pos}/{human_len} mutations");
    let out = render_mlt(
        scene,
        accel,
        &loaded.settings,
        analysis,
        mlt,
        budget,
        threads,
        seed,
        &|n| bar.inc(n),
    )?;
    bar.finish_and_clear();
    let img = Image {
        width: w as usize,
        height: h as usize,
        pixels: out.image(),
    };
    write_outputs(&img, &ctx, out.film.nonfinite())?;
    let mean = img.mean();
    let m = &out.mlt;
    println!(
        "{:.2} mutations/pixel in {:.2} s (bootstrap {:.2} s, b {:.5}): {:.3} M mutations/s, {:.2} Mrays/s; accepted small {:.1}%, large {:.1}%, zero proposals {:.1}%; mean rgb ({:.5}, {:.5}, {:.5}); wrote {}",
        m.mutations as f64 / pixels.max(1) as f64,
        out.wall.as_secs_f64(),
        out.bootstrap_wall.as_secs_f64(),
        out.bootstrap.b(),
        out.mutations_per_sec() * 1e-6,
        out.mrays_per_sec(),
        100.0 * m.small_acceptance(),
        100.0 * m.large_acceptance(),
        100.0 * m.zero_proposals as f64 / m.mutations.max(1) as f64,
        mean.r,
        mean.g,
        mean.b,
        ctx.output.display()
    );
    if mlt.m > 0 {
        println!(
            "level 2: {} lens steps ({:.1}% accepted), {} caustic steps ({:.1}% accepted), {} identity steps; zero candidates {:.1}%; {} packets, {:.2} lanes/packet, {:.1}% of rays in packets",
            m.lens_steps,
            100.0 * m.lens_acceptance(),
            m.caustic_steps,
            100.0 * m.caustic_acceptance(),
            m.identity_steps,
            100.0 * m.l2_zero_fraction(),
            out.stats.packets,
            out.stats.mean_packet_lanes(),
            100.0 * out.stats.packet_rays as f64 / out.stats.total_rays().max(1) as f64
        );
    }
    println!("{}", work_line(&out.stats, Some(m)));
    if let Some(r) = ctx.reference {
        compare_reference(&img, r)?;
    }
    Ok(())
}

/// What `--frames` asked for.
struct FrameSpec {
    frames: usize,
    /// Total orbit in degrees, or a static camera.
    orbit_degrees: Option<f32>,
    /// Samples (PT, BDPT) or mutations (MLT) per pixel per frame, over all
    /// workers.
    per_pixel: u64,
}

/// `cmlt render --frames`: the frame loop, one numbered image per frame.
fn run_frames(
    loaded: &LoadedScene,
    accel: &Accel,
    cfg: RendererConfig,
    spec: &FrameSpec,
    output: &std::path::Path,
    png: Option<&std::path::Path>,
) -> Result<(), String> {
    let scene = &loaded.scene;
    let start = scene.camera;
    let pivot = frames::look_at_point(&start, accel);
    let pixels = start.width() as u64 * start.height() as u64;
    // Each worker renders its share of the frame's budget.
    let budget = (spec.per_pixel * pixels).div_ceil(cfg.workers as u64);
    eprintln!(
        "{} frames, {} per pixel per frame, {} workers, {:?}{}",
        spec.frames,
        spec.per_pixel,
        cfg.workers,
        cfg.temporal,
        spec.orbit_degrees
            .map_or(String::new(), |d| format!(", orbit {d}° about {pivot}"))
    );
    frames::render_frames(
        scene,
        accel,
        cfg,
        spec.frames,
        budget,
        |f| match spec.orbit_degrees {
            Some(d) => frames::orbit_camera(&start, pivot, d, f, spec.frames),
            None => start,
        },
        |f, result| {
            let path = frames::frame_path(output, f);
            let ctx = Output {
                output: &path,
                png: None,
                reference: None,
            };
            write_outputs(&result.image, &ctx, 0)?;
            if let Some(p) = png {
                let p = frames::frame_path(p, f);
                write_outputs(
                    &result.image,
                    &Output {
                        output: &p,
                        png: None,
                        reference: None,
                    },
                    0,
                )?;
            }
            let mean = result.image.mean();
            println!(
                "frame {f}: {:.2} s, b {:.5}, mean rgb ({:.5}, {:.5}, {:.5}); wrote {}",
                result.seconds,
                result.b,
                mean.r,
                mean.g,
                mean.b,
                path.display()
            );
            Ok(())
        },
    )
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Bench(BenchCommand::Flicker {
            scene,
            method,
            frames,
            mutations_per_pixel,
            threads,
            b_window,
            b_passes,
            moving,
            orbit_degrees,
            orbit_frames,
            reference_spp,
            seed,
            define,
        }) => {
            let loaded = load_scene_or_builtin(scene.as_deref().unwrap_or("cornell-box"), &define)?;
            let scene = &loaded.scene;
            let accel = Accel::build(AccelKind::Ours, &scene.triangles().collect::<Vec<_>>())?;
            let mlt = match method {
                MethodArg::Cmlt => MltSettings::cmlt(),
                MethodArg::Mlt => MltSettings::default(),
                _ => return Err("bench flicker measures --method mlt or cmlt".into()),
            };
            let mlt = MltSettings { b_passes, ..mlt };
            let base = RendererConfig {
                estimator: Estimator::Mlt,
                settings: loaded.settings,
                mlt,
                seed,
                workers: threads.max(1),
                temporal: Temporal::default(),
                all_effects: false,
            };
            let pixels = scene.camera.width() as u64 * scene.camera.height() as u64;
            let budget = (mutations_per_pixel * pixels).div_ceil(base.workers as u64);
            println!(
                "static camera: {frames} frames, {mutations_per_pixel} mutations/pixel/frame, {} workers, {:?}",
                base.workers, method
            );
            let mut stdout = std::io::stdout();
            cmlt_cli::bench::flicker::run_static(
                scene,
                &accel,
                base,
                frames,
                budget,
                b_window,
                &mut stdout,
            )?;
            if moving {
                let cfg = RendererConfig {
                    temporal: Temporal {
                        keep_chains: true,
                        b_window,
                        fixed_sequence: true,
                    },
                    ..base
                };
                println!(
                    "moving camera: orbit {orbit_degrees}° in {orbit_frames} frames, every switch on; references: BDPT {reference_spp} spp"
                );
                let d = cmlt_cli::bench::flicker::run_moving(
                    scene,
                    &accel,
                    cfg,
                    orbit_frames,
                    budget,
                    orbit_degrees,
                    reference_spp,
                    &mut stdout,
                )?;
                let worst = d.iter().fold(0.0f64, |a, x| a.max(x.abs()));
                println!("largest |difference|: {:.2}%", 100.0 * worst);
            }
            Ok(())
        }
        Command::Bench(BenchCommand::Effects {
            scenes,
            methods,
            time,
            repeats,
            threads,
            scenes_dir,
            define,
        }) => {
            use cmlt_cli::bench::effects::{BenchMethod, run};
            let methods = methods
                .iter()
                .map(|m| BenchMethod::parse(m))
                .collect::<Result<Vec<_>, _>>()?;
            let mut loaded = Vec::new();
            for name in &scenes {
                let shared = scenes_dir.join(name).join("scene.xml");
                let path = if shared.is_file() {
                    shared.to_string_lossy().into_owned()
                } else {
                    name.clone()
                };
                let l = load_scene_or_builtin(&path, &define)?;
                let tris: Vec<_> = l.scene.triangles().collect();
                let accel = Accel::build(AccelKind::Ours, &tris)?;
                loaded.push((name.clone(), l, accel));
            }
            let threads = threads_or_all(threads);
            println!(
                "effects: {time} s per render, {repeats} per side, {threads} threads; ratio = analysis on / --all-effects"
            );
            run(
                &loaded,
                &methods,
                time,
                repeats,
                threads,
                &mut std::io::stdout(),
            )?;
            Ok(())
        }
        Command::Bench(BenchCommand::Rays {
            scenes,
            time,
            threads,
            rays,
            mesh_triangles,
            scenes_dir,
            csv,
            kernels,
            sets,
            clock,
            rounds,
        }) => {
            let opts = cmlt_cli::bench::rays::Options {
                rounds,
                clock: match clock {
                    ClockArg::Wall => cmlt_cli::bench::rays::Clock::Wall,
                    ClockArg::Cpu => cmlt_cli::bench::rays::Clock::Cpu,
                },
                scenes,
                time,
                threads,
                rays,
                mesh_triangles,
                scenes_dir,
                kernels,
                sets,
            };
            let rows = cmlt_cli::bench::rays::run(&opts, &mut std::io::stdout())?;
            if let Some(path) = csv {
                cmlt_cli::bench::rays::write_csv(&path, &rows)?;
            }
            cmlt_cli::bench::ray_targets::write_summary(&rows, &mut std::io::stdout())
                .map_err(|e| e.to_string())?;
            Ok(())
        }
        Command::Bench(BenchCommand::RaysSummary { csv }) => {
            let runs = csv
                .iter()
                .map(|p| cmlt_cli::bench::ray_targets::read_csv(p))
                .collect::<Result<Vec<_>, _>>()?;
            use std::io::Write as _;
            let mut out = std::io::stdout();
            let io = |e: std::io::Error| e.to_string();
            for (path, rows) in csv.iter().zip(&runs) {
                writeln!(out, "{}:", path.display()).map_err(io)?;
                cmlt_cli::bench::ray_targets::write_summary(rows, &mut out).map_err(io)?;
            }
            if runs.len() > 1 {
                cmlt_cli::bench::ray_targets::write_across(&runs, &mut out).map_err(io)?;
            }
            Ok(())
        }
        Command::Bench(BenchCommand::Convergence {
            scene,
            reference,
            methods,
            budgets,
            samples,
            threads,
            seeds,
            seeds_up_to,
            define,
            csv,
            plot,
            title,
        }) => {
            use cmlt_cli::bench::{convergence, plot as draw};
            let title = title.unwrap_or_else(|| scene_title(&scene));
            let opts = convergence::Options {
                scene,
                reference,
                defines: define,
                methods,
                budgets,
                samples,
                threads: threads_or_all(threads),
                seeds,
                seeds_up_to,
            };
            let rows = convergence::run(&opts, &mut std::io::stdout())?;
            if let Some(path) = &csv {
                convergence::write_csv(path, &rows)?;
            }
            let curves = convergence::curves(&rows);
            let ref_mean = image_io::read_exr(&opts.reference)?.mean();
            let ref_mean = [ref_mean.r as f64, ref_mean.g as f64, ref_mean.b as f64];
            convergence::summarize(&curves, Some(ref_mean), None, &mut std::io::stdout())?;
            if let Some(prefix) = &plot {
                for p in draw::convergence(&curves, &title, prefix)? {
                    println!("wrote {}", p.display());
                }
            }
            Ok(())
        }
        Command::Bench(BenchCommand::Params {
            scene,
            reference,
            time,
            lens_sigmas,
            ks,
            ms,
            candidates,
            threads,
            seeds,
            define,
            csv,
            plot,
        }) => {
            use cmlt_cli::bench::{params, plot as draw};
            let candidates = match candidates {
                CandidatesArg::Independent => cmlt::mlt::Candidates::Independent,
                CandidatesArg::Stratified => cmlt::mlt::Candidates::Stratified,
            };
            let title = format!(
                "{}: CMLT relMSE after {time} s ({candidates:?} candidates)",
                scene_title(&scene)
            );
            let opts = params::Options {
                scene,
                reference,
                defines: define,
                time,
                lens_sigmas,
                ks,
                ms,
                candidates,
                threads: threads_or_all(threads),
                seeds,
            };
            let cells = params::run(&opts, &mut std::io::stdout())?;
            if let Some(path) = &csv {
                params::write_csv(path, &cells, candidates)?;
            }
            if let Some(b) = params::best(&opts, &cells) {
                println!(
                    "best: --lens-sigma {} --k {} --m {} (relMSE {:.5}; plain MLT {:.5}, ratio {:.2})",
                    b.lens_sigma,
                    b.k,
                    b.m,
                    b.rel_mse,
                    b.mlt_rel_mse,
                    b.rel_mse / b.mlt_rel_mse
                );
            }
            if let Some(prefix) = &plot {
                let panels = params::panels(&opts, &cells);
                for p in draw::heat_maps(&panels, &title, "lens σ (pixels)", "k", prefix)? {
                    println!("wrote {}", p.display());
                }
            }
            Ok(())
        }
        Command::Bench(BenchCommand::Score {
            image,
            reference,
            method,
            budget_s,
            wall_s,
            seed,
            samples,
            mrays_per_s,
            csv,
        }) => {
            use cmlt_cli::bench::{convergence, study};
            let img = image_io::read_exr(&image)?;
            let r = metrics::load_reference(&reference, img.width, img.height)?;
            let m = study::score(&img, &r, wall_s, samples, mrays_per_s);
            let rm = r.mean();
            println!(
                "{method}: relMSE {:.5}, mean ratio ({:.4}, {:.4}, {:.4})",
                m.rel_mse,
                m.mean[0] / rm.r as f64,
                m.mean[1] / rm.g as f64,
                m.mean[2] / rm.b as f64
            );
            let row = convergence::Row {
                method,
                budget_s,
                seed,
                m,
            };
            convergence::append_csv(&csv, &row)
        }
        Command::Bench(BenchCommand::Plot {
            csv,
            plot,
            title,
            reference,
            versus,
            at,
        }) => {
            use cmlt_cli::bench::{convergence, plot as draw};
            let rows = convergence::read_csv(&csv)?;
            let curves = convergence::curves(&rows);
            let ref_mean = match reference {
                Some(r) => {
                    let m = image_io::read_exr(&r)?.mean();
                    Some([m.r as f64, m.g as f64, m.b as f64])
                }
                None => None,
            };
            let versus = versus.as_deref().zip(at);
            convergence::summarize(&curves, ref_mean, versus, &mut std::io::stdout())?;
            if let Some(prefix) = &plot {
                for p in draw::convergence(&curves, &title, prefix)? {
                    println!("wrote {}", p.display());
                }
            }
            Ok(())
        }
        Command::Render {
            scene,
            method,
            spp,
            mutations_per_pixel,
            chains,
            large_step,
            sigma,
            bootstrap,
            b_passes,
            k,
            m,
            lens_sigma,
            caustic_scale,
            candidates,
            splatting,
            time,
            threads,
            accel,
            seed,
            output,
            png,
            define,
            reference,
            quiet,
            frames,
            orbit,
            orbit_degrees,
            keep_chains,
            b_window,
            fixed_sequence,
            all_effects,
        } => {
            // Before any work: a render must not end in "cannot write".
            image_io::check_output(&output)?;
            if let Some(p) = &png {
                image_io::check_output(p)?;
                if !image_io::is_png(p) {
                    return Err(format!("{}: --png must end in .png", p.display()));
                }
            }
            let t0 = Instant::now();
            let loaded: LoadedScene =
                load_scene_or_builtin(scene.as_deref().unwrap_or("cornell-box"), &define)?;
            for w in &loaded.warnings {
                eprintln!("warning: {w}");
            }
            let scene = &loaded.scene;
            let tris: Vec<_> = scene.triangles().collect();
            let kind = match accel {
                AccelArg::Ours => AccelKind::Ours,
                AccelArg::Embree => AccelKind::Embree,
            };
            let accel = Accel::build(kind, &tris)?;
            let setup = t0.elapsed();
            let analysis = if all_effects {
                eprintln!("effects: all (--all-effects: scene analysis off)");
                Analysis::all()
            } else {
                let a = scene.analysis(&scene.camera);
                eprintln!("{}", a.report());
                a
            };
            let threads = threads_or_all(threads);
            let is_mlt = matches!(method, MethodArg::Mlt | MethodArg::Cmlt);
            if is_mlt && bootstrap == 0 {
                return Err("--bootstrap must be at least 1".to_string());
            }
            let base = match method {
                MethodArg::Cmlt => MltSettings::cmlt(),
                _ => MltSettings::default(),
            };
            let mlt = MltSettings {
                n_bootstrap: bootstrap,
                b_passes,
                n_chains: chains,
                large_step_prob: large_step,
                sigma,
                k: k.unwrap_or(base.k),
                m: m.unwrap_or(base.m),
                lens_sigma,
                caustic_scale,
                candidates: match candidates {
                    CandidatesArg::Independent => cmlt::mlt::Candidates::Independent,
                    CandidatesArg::Stratified => cmlt::mlt::Candidates::Stratified,
                },
                splatting: match splatting {
                    SplattingArg::Recycled => cmlt::mlt::Splatting::Recycled,
                    SplattingArg::Expected => cmlt::mlt::Splatting::ExpectedValue,
                },
                ..base
            };
            if is_mlt {
                mlt.validate().map_err(|e| {
                    format!(
                        "{e} (--large-step {large_step}, --sigma {sigma}, --chains {chains}, --k {}, --lens-sigma {lens_sigma}, --caustic-scale {caustic_scale})",
                        mlt.k
                    )
                })?;
            }
            if let Some(frames) = frames {
                let estimator = match method {
                    MethodArg::Pt => Estimator::Path,
                    MethodArg::Bdpt => Estimator::Bdpt,
                    MethodArg::Mlt | MethodArg::Cmlt => Estimator::Mlt,
                };
                let per_pixel = if is_mlt {
                    mutations_per_pixel.or(spp)
                } else {
                    spp
                }
                .unwrap_or(loaded.spp.unwrap_or(16) as u64);
                let cfg = RendererConfig {
                    estimator,
                    settings: loaded.settings,
                    mlt: if is_mlt { mlt } else { MltSettings::default() },
                    seed,
                    workers: threads as u32,
                    temporal: Temporal {
                        keep_chains,
                        b_window,
                        fixed_sequence,
                    },
                    all_effects,
                };
                let spec = FrameSpec {
                    frames,
                    orbit_degrees: orbit.then_some(orbit_degrees),
                    per_pixel,
                };
                return run_frames(&loaded, &accel, cfg, &spec, &output, png.as_deref());
            }
            let method = match method {
                MethodArg::Pt => Method::Path,
                MethodArg::Bdpt => Method::Bdpt,
                MethodArg::Mlt | MethodArg::Cmlt => {
                    let budget = match (time, mutations_per_pixel.or(spp)) {
                        (Some(t), _) => MltBudget::Time(t),
                        (None, Some(n)) => MltBudget::MutationsPerPixel(n),
                        (None, None) => {
                            MltBudget::MutationsPerPixel(loaded.spp.unwrap_or(16) as u64)
                        }
                    };
                    let ctx = Output {
                        output: &output,
                        png: png.as_deref(),
                        reference: reference.as_deref(),
                    };
                    let run = MltRun {
                        analysis: &analysis,
                        budget,
                        threads,
                        seed,
                        quiet,
                        setup,
                    };
                    return run_mlt(&loaded, &accel, &mlt, run, ctx);
                }
            };
            let budget = match (spp, time) {
                (_, Some(t)) => Budget::Time(t),
                (Some(n), None) => Budget::Spp(n),
                (None, None) => Budget::Spp(loaded.spp.unwrap_or(16) as u64),
            };
            let (w, h) = (scene.camera.width(), scene.camera.height());
            eprintln!(
                "scene: {} triangles, {} lights, {w}x{h}, max_depth {}, {:?} on {threads} threads ({} BVH, setup {:.2} s)",
                scene.triangle_count(),
                scene.lights.len(),
                loaded
                    .settings
                    .max_depth
                    .map_or("unbounded".to_string(), |d| d.to_string()),
                method,
                accel.name(),
                setup.as_secs_f64()
            );
            let total = match budget {
                Budget::Spp(n) => Some(n),
                Budget::Time(_) => None,
            };
            let bar = progress_bar(quiet, total, "{pos}/{len} spp");
            let out = render(
                scene,
                &accel,
                &loaded.settings,
                &analysis,
                method,
                budget,
                threads,
                seed,
                &|| bar.inc(1),
            )?;
            bar.finish_and_clear();
            let img = Image {
                width: w as usize,
                height: h as usize,
                pixels: out.film.resolve(),
            };
            let ctx = Output {
                output: &output,
                png: png.as_deref(),
                reference: reference.as_deref(),
            };
            write_outputs(&img, &ctx, out.film.nonfinite())?;
            let mean = img.mean();
            println!(
                "{} spp in {:.2} s: {:.3} M samples/s, {:.2} Mrays/s; mean rgb ({:.5}, {:.5}, {:.5}); wrote {}",
                out.film.passes(),
                out.wall.as_secs_f64(),
                out.samples_per_sec() * 1e-6,
                out.mrays_per_sec(),
                mean.r,
                mean.g,
                mean.b,
                output.display()
            );
            println!("{}", work_line(&out.stats, None));
            if let Some(r) = ctx.reference {
                compare_reference(&img, r)?;
            }
            Ok(())
        }
    }
}

/// A progress bar over `total` units (a spinner for time budgets), hidden
/// with `--quiet`; `counter` is the template of the position and length.
fn progress_bar(quiet: bool, total: Option<u64>, counter: &str) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = total.map_or_else(ProgressBar::new_spinner, ProgressBar::new);
    let template = format!("{{spinner}} [{{elapsed_precise}}] {{bar:40}} {counter} ({{per_sec}})");
    bar.set_style(
        ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// `--threads`, or all cores.
fn threads_or_all(threads: Option<usize>) -> usize {
    threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// A plot title from a scene argument: `tests/scenes/veach-ajar/scene.xml`
/// → `veach-ajar`.
fn scene_title(scene: &str) -> String {
    let p = Path::new(scene);
    let name = if p.file_stem().is_some_and(|s| s == "scene") {
        p.parent().and_then(|d| d.file_name())
    } else {
        p.file_stem()
    };
    name.map_or_else(|| scene.to_string(), |n| n.to_string_lossy().into_owned())
}

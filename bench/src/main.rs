//! `cmlt-bench`: the benchmarks of cmlt (ray throughput, convergence
//! against a reference, CMLT's parameter grid, flicker, the effect
//! analysis), implemented in [`cmlt_bench`]. Renders go through the same
//! driver as `cmlt render` ([`cmlt_cli::render`]).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use cmlt::mlt::{Candidates, MltSettings};
use cmlt::renderer::{Estimator, EstimatorKind, RendererConfig, Temporal};
use cmlt_cli::accel::{Accel, AccelKind};
use cmlt_cli::args::{parse_candidates, parse_define, parse_estimator, threads_or_all};
use cmlt_cli::image_io;
use cmlt_cli::load_scene_or_builtin;
use cmlt_cli::metrics;

#[derive(Parser)]
#[command(name = "cmlt-bench", version, about = "Benchmarks of cmlt")]
struct Cli {
    #[command(subcommand)]
    command: BenchCommand,
}

/// `cmlt-bench rays --clock`.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum ClockArg {
    /// Elapsed real time.
    Wall,
    /// CPU time of the tracing threads.
    Cpu,
}

/// `cmlt-bench …` (implemented in `cmlt_bench`).
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
    /// The throughput targets against Embree checked on the CSVs of `bench rays`
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
        #[arg(long, default_value = "cmlt", value_parser = parse_estimator)]
        method: EstimatorKind,
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
        /// luminance): exactly these, without the small-image floor
        /// (`MltSettings::b_min_samples`), so that b's error is K passes'.
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
        /// Methods (pt, bdpt, mlt, cmlt; CMLT with its defaults), or a
        /// Metropolis method with settings changed, e.g.
        /// `cmlt:lanes=4:m=2:share=8:depth=3:k=1:sigma=8`. With two or
        /// more, the first is the base of the printed relMSE ratios.
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
    /// CMLT's σ × k × m grid at a fixed time (Segovia 2007's §2.5.1): CSV, a
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
        #[arg(long, default_value = "stratified", value_parser = parse_candidates)]
        candidates: Candidates,
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
    /// A game engine's frame loop through the C API (the C++17 host
    /// `examples-c/frame_trial.cpp`, built with the examples' Makefile):
    /// moving camera and mesh, two workers, a time budget per frame; p50/p95
    /// frame time, set-up after the first frame, black pixels, flicker and
    /// allocations per frame against a game's frame targets.
    Frames {
        /// Estimators.
        #[arg(long, value_delimiter = ',', default_value = "pt,bdpt,mlt,cmlt")]
        estimators: Vec<String>,
        /// Image sizes, WIDTHxHEIGHT.
        #[arg(long, value_delimiter = ',', default_value = "320x180,640x360")]
        sizes: Vec<String>,
        /// Frame budgets, milliseconds.
        #[arg(long, value_delimiter = ',', default_value = "30,60")]
        budgets: Vec<f64>,
        /// Frames per run.
        #[arg(long, default_value_t = 120)]
        frames: u32,
        /// A host built already (default: `make -C examples-c frame_trial`).
        #[arg(long)]
        host: Option<PathBuf>,
        /// Print every frame's line.
        #[arg(long)]
        verbose: bool,
    },
    /// A still camera's frames kept by the accumulation (each its own b)
    /// against one offline render of the same mutations and of the same
    /// wall time: relMSE against the reference and the ratios, per seed.
    Still {
        /// Mitsuba 3 XML scene file, or a built-in name.
        #[arg(default_value = "tests/scenes/cornell-box/scene.xml")]
        scene: String,
        /// Reference OpenEXR (full size, or any integer multiple of the
        /// render's size: box-filtered down).
        #[arg(long, default_value = "tests/scenes/cornell-box/reference.exr")]
        reference: PathBuf,
        /// Method (its defaults).
        #[arg(long, value_parser = parse_estimator, default_value = "mlt")]
        method: EstimatorKind,
        /// Frames kept.
        #[arg(long, default_value_t = 16)]
        frames: usize,
        /// Mutations (or samples) per pixel per frame.
        #[arg(long, default_value_t = 4)]
        per_frame: u64,
        /// Workers (threads).
        #[arg(long, default_value_t = 2)]
        threads: u32,
        /// MLT/CMLT: keep the chains across the frames too.
        #[arg(long)]
        keep_chains: bool,
        /// Each worker renders a fixed share of every frame (its
        /// `steps_for`, as `cmlt render --frames` does) instead of pieces
        /// until the frame's total is reached: the baseline that waits at
        /// every frame's end.
        #[arg(long)]
        fixed_shares: bool,
        /// Seeds 0..S.
        #[arg(long, default_value_t = 4)]
        seeds: u64,
        /// Override a scene `<default>` (e.g. `-D resx=128`).
        #[arg(short = 'D', value_parser = parse_define)]
        define: Vec<(String, String)>,
    },
    /// Wall time of a first frame's MLT/CMLT bootstrap on the calling
    /// thread (`cmlt_renderer_prepare`) against spread over one thread per
    /// worker (`cmlt_renderer_prepare_begin` / `_worker` / `_finish`), in
    /// turns in one process.
    Prepare {
        /// Mitsuba 3 XML scene file, or a built-in name (default
        /// `cornell-box`).
        scene: Option<String>,
        /// MLT or CMLT.
        #[arg(long, default_value = "cmlt", value_parser = parse_estimator)]
        method: EstimatorKind,
        /// Workers (one thread each when spread).
        #[arg(long, default_value_t = 2)]
        threads: u32,
        /// Turns of each.
        #[arg(long, default_value_t = 9)]
        repeats: usize,
        /// Override a scene `<default>` (e.g. `-D resx=64`).
        #[arg(short = 'D', value_parser = parse_define)]
        define: Vec<(String, String)>,
    },
    /// The per-frame outputs: the resolve in every pixel format (and split
    /// into two bands of rows on two threads) against the resolve the C
    /// API did before, and the auxiliary outputs (albedo, normal, depth,
    /// motion), at each size, in turns.
    Outputs {
        /// Scene (a shared scene name or path; default the built-in Cornell
        /// box).
        #[arg(long)]
        scene: Option<String>,
        /// Image sizes, WIDTHxHEIGHT.
        #[arg(long, value_delimiter = ',', default_value = "320x180,1280x720")]
        sizes: Vec<String>,
        /// Workers whose films are merged.
        #[arg(long, default_value_t = 2)]
        workers: u32,
        /// Turns of every variant.
        #[arg(long, default_value_t = 21)]
        repeats: usize,
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

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        BenchCommand::Flicker {
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
        } => {
            let loaded = load_scene_or_builtin(scene.as_deref().unwrap_or("cornell-box"), &define)?;
            let scene = &loaded.scene;
            let accel = Accel::build(AccelKind::Ours, &scene.triangles().collect::<Vec<_>>())?;
            if !method.is_metropolis() {
                return Err("bench flicker measures --method mlt or cmlt".into());
            }
            let mut estimator = Estimator::default_for(method);
            if let Some(mlt) = estimator.mlt_mut() {
                (mlt.b_passes, mlt.b_min_samples) = (b_passes, 0);
            }
            let base = RendererConfig {
                estimator,
                settings: loaded.settings,
                seed,
                workers: threads.max(1),
                ..RendererConfig::default()
            };
            println!(
                "static camera: {frames} frames, {mutations_per_pixel} mutations/pixel/frame, {} workers, {:?}",
                base.workers, method
            );
            let mut stdout = std::io::stdout();
            cmlt_bench::flicker::run_static(
                scene,
                &accel,
                base,
                frames,
                mutations_per_pixel,
                b_window,
                &mut stdout,
            )?;
            if moving {
                let cfg = RendererConfig {
                    temporal: Temporal {
                        keep_chains: true,
                        b_window,
                        fixed_sequence: true,
                        ..Temporal::default()
                    },
                    ..base
                };
                println!(
                    "moving camera: orbit {orbit_degrees}° in {orbit_frames} frames, every switch on; references: BDPT {reference_spp} spp"
                );
                let d = cmlt_bench::flicker::run_moving(
                    scene,
                    &accel,
                    cfg,
                    orbit_frames,
                    mutations_per_pixel,
                    orbit_degrees,
                    reference_spp,
                    &mut stdout,
                )?;
                let worst = d.iter().fold(0.0f64, |a, x| a.max(x.abs()));
                println!("largest |difference|: {:.2}%", 100.0 * worst);
            }
            Ok(())
        }
        BenchCommand::Frames {
            estimators,
            sizes,
            budgets,
            frames,
            host,
            verbose,
        } => {
            use cmlt_bench::frames;
            let host = match host {
                Some(h) => h,
                None => {
                    frames::build_host(Path::new(env!("CARGO_MANIFEST_DIR")).join("..").as_path())?
                }
            };
            let mut trials = Vec::new();
            for size in &sizes {
                let (w, h) = size
                    .split_once('x')
                    .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
                    .ok_or_else(|| format!("size {size}: expected WIDTHxHEIGHT"))?;
                for &budget in &budgets {
                    for e in &estimators {
                        let t = frames::run(&host, e, (w, h), budget, frames, verbose)?;
                        eprintln!("{e} {size} {budget} ms: p95 {:.1} ms", t.p95_ms);
                        trials.push(t);
                    }
                }
            }
            print!("{}", frames::table(&trials));
            Ok(())
        }
        BenchCommand::Prepare {
            scene,
            method,
            threads,
            repeats,
            define,
        } => {
            use cmlt_bench::prepare::{median, run};
            let loaded = load_scene_or_builtin(scene.as_deref().unwrap_or("cornell-box"), &define)?;
            let scene = &loaded.scene;
            let accel = Accel::build(AccelKind::Ours, &scene.triangles().collect::<Vec<_>>())?;
            let config = RendererConfig {
                settings: loaded.settings,
                workers: threads.max(1),
                ..RendererConfig::for_estimator(method)
            };
            let t = run(scene, &accel, config, repeats.max(1))?;
            let ms = |v: &[f64]| {
                v.iter()
                    .map(|x| format!("{:.1}", 1e3 * x))
                    .collect::<Vec<_>>()
                    .join(" ")
            };
            println!(
                "first-frame bootstrap, {:?}, {} workers, {} turns (b identical in every turn)",
                method,
                config.workers,
                t.serial.len()
            );
            println!(
                "serial ms: {}  (median {:.1})",
                ms(&t.serial),
                1e3 * median(&t.serial)
            );
            println!(
                "spread ms: {}  (median {:.1})",
                ms(&t.spread),
                1e3 * median(&t.spread)
            );
            println!(
                "speed-up (median serial / median spread): {:.2}x",
                t.speedup()
            );
            Ok(())
        }
        BenchCommand::Effects {
            scenes,
            methods,
            time,
            repeats,
            threads,
            scenes_dir,
            define,
        } => {
            use cmlt_bench::effects::run;
            let methods = methods
                .iter()
                .map(|m| parse_estimator(m))
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
        BenchCommand::Rays {
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
        } => {
            let opts = cmlt_bench::rays::Options {
                rounds,
                clock: match clock {
                    ClockArg::Wall => cmlt_bench::rays::Clock::Wall,
                    ClockArg::Cpu => cmlt_bench::rays::Clock::Cpu,
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
            let rows = cmlt_bench::rays::run(&opts, &mut std::io::stdout())?;
            if let Some(path) = csv {
                cmlt_bench::rays::write_csv(&path, &rows)?;
            }
            cmlt_bench::ray_targets::write_summary(&rows, &mut std::io::stdout())
                .map_err(|e| e.to_string())?;
            Ok(())
        }
        BenchCommand::RaysSummary { csv } => {
            let runs = csv
                .iter()
                .map(|p| cmlt_bench::ray_targets::read_csv(p))
                .collect::<Result<Vec<_>, _>>()?;
            use std::io::Write as _;
            let mut out = std::io::stdout();
            let io = |e: std::io::Error| e.to_string();
            for (path, rows) in csv.iter().zip(&runs) {
                writeln!(out, "{}:", path.display()).map_err(io)?;
                cmlt_bench::ray_targets::write_summary(rows, &mut out).map_err(io)?;
            }
            if runs.len() > 1 {
                cmlt_bench::ray_targets::write_across(&runs, &mut out).map_err(io)?;
            }
            Ok(())
        }
        BenchCommand::Convergence {
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
        } => {
            use cmlt_bench::{convergence, plot as draw};
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
            if let Some(base) = opts.methods.first().filter(|_| opts.methods.len() > 1) {
                convergence::ratios(&curves, base, &mut std::io::stdout())?;
            }
            if let Some(prefix) = &plot {
                for p in draw::convergence(&curves, &title, prefix)? {
                    println!("wrote {}", p.display());
                }
            }
            Ok(())
        }
        BenchCommand::Params {
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
        } => {
            use cmlt_bench::{params, plot as draw};
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
        BenchCommand::Score {
            image,
            reference,
            method,
            budget_s,
            wall_s,
            seed,
            samples,
            mrays_per_s,
            csv,
        } => {
            use cmlt_bench::{convergence, study};
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
        BenchCommand::Still {
            scene,
            reference,
            method,
            frames,
            per_frame,
            threads,
            keep_chains,
            fixed_shares,
            seeds,
            define,
        } => {
            use cmlt_bench::still::Shares;
            let shares = if fixed_shares {
                Shares::Fixed
            } else {
                Shares::Shared
            };
            let study = cmlt_bench::study::Study::load(&scene, &define, &reference)?;
            let (w, h) = study.resolution();
            println!(
                "{scene} {w}x{h}, {method:?}, {frames} kept frames of {per_frame}/px, {threads} workers, keep_chains {keep_chains}, {shares:?} shares"
            );
            println!(
                "seed  kept relMSE  kept s   offline same mutations  ratio   offline same time  ratio   same time after set-up  ratio"
            );
            let (mut rm, mut rt, mut ra) = (Vec::new(), Vec::new(), Vec::new());
            let mut breakdowns = Vec::new();
            for seed in 0..seeds.max(1) {
                let s = cmlt_bench::still::run(
                    &study,
                    Estimator::default_for(method),
                    (frames, per_frame),
                    threads.max(1),
                    (keep_chains, shares),
                    seed,
                )?;
                println!(
                    "{seed:>4}  {:>11.5}  {:>6.2}  {:>22.5}  {:>5.2}  {:>17.5}  {:>5.2}  {:>22.5}  {:>5.2}",
                    s.kept,
                    s.kept_s,
                    s.same_mutations,
                    s.ratio_mutations(),
                    s.same_time,
                    s.ratio_time(),
                    s.same_time_after_setup,
                    s.ratio_time_after_setup()
                );
                rm.push(s.ratio_mutations());
                rt.push(s.ratio_time());
                ra.push(s.ratio_time_after_setup());
                breakdowns.push(s.breakdown);
            }
            println!(
                "where the time went (s). kept frames: first set-up, later set-ups, renders (of which idle at \
                 the frames' ends, thread start, waiting to run), resolve, per px; offline same time: set-up, \
                 render, per px; render rate kept/offline; CPU per mutation kept/offline"
            );
            for (seed, b) in breakdowns.iter().enumerate() {
                println!(
                    "{seed:>4}  {:>7.3} {:>7.3} {:>7.3} ({:>6.3} {:>6.4} {:>6.3}) {:>7.4} {:>7.1}   {:>7.3} {:>7.3} {:>7.1}   {:>5.2}  {:>5.2}",
                    b.first_setup_s,
                    b.setup_s,
                    b.render_s,
                    b.join_idle_s,
                    b.start_s,
                    b.run_queue_s,
                    b.resolve_s,
                    b.kept_per_pixel,
                    b.offline_setup_s,
                    b.offline_render_s,
                    b.offline_per_pixel,
                    b.render_rate_ratio(),
                    b.cpu_ratio
                );
            }
            let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
            println!(
                "mean ratio: same mutations {:.2}, same time {:.2}, same time after the set-up {:.2} (target: same time ≤ 1.2)",
                mean(&rm),
                mean(&rt),
                mean(&ra)
            );
            Ok(())
        }
        BenchCommand::Outputs {
            scene,
            sizes,
            workers,
            repeats,
        } => {
            use cmlt_bench::outputs::{print, rendered, run};
            for size in &sizes {
                let (w, h) = size
                    .split_once('x')
                    .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
                    .ok_or_else(|| format!("bad size {size:?} (WIDTHxHEIGHT)"))?;
                let define = [
                    ("resx".to_string(), w.to_string()),
                    ("resy".to_string(), h.to_string()),
                ];
                let loaded =
                    load_scene_or_builtin(scene.as_deref().unwrap_or("cornell-box"), &define)?;
                let scene = &loaded.scene;
                let accel = Accel::build(AccelKind::Ours, &scene.triangles().collect::<Vec<_>>())?;
                let config = RendererConfig {
                    settings: loaded.settings,
                    workers: workers.max(1),
                    ..RendererConfig::for_estimator(EstimatorKind::Bdpt)
                };
                let (r, ws) = rendered(scene, &accel, config, 1)?;
                let rows = run(scene, &accel, &r, &ws, repeats.max(1))?;
                print(
                    &format!(
                        "{w}x{h}, {} workers, {} turns (new resolves identical to the old for rgb32f and rgba8-srgb)",
                        config.workers, repeats
                    ),
                    &rows,
                );
            }
            Ok(())
        }
        BenchCommand::Plot {
            csv,
            plot,
            title,
            reference,
            versus,
            at,
        } => {
            use cmlt_bench::{convergence, plot as draw};
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
    }
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

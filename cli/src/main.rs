//! `cmlt`: render Mitsuba scenes with the cmlt core.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::{Parser, Subcommand, ValueEnum};
use cmlt::accel::bvh::Bvh;
use cmlt::integrator::Method;
use cmlt_cli::image_io::{self, Image};
use cmlt_cli::metrics;
use cmlt_cli::render::{Budget, render};
use cmlt_cli::scene::{LoadedScene, builtin_scene, load_scene};
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

#[derive(Clone, Copy, Debug, ValueEnum)]
enum MethodArg {
    /// Path tracing with next-event estimation and MIS.
    Pt,
    /// Bidirectional path tracing with MIS.
    Bdpt,
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
        /// Samples per pixel (default: the scene's `sample_count`).
        #[arg(long, conflicts_with = "time")]
        spp: Option<u64>,
        /// Render for this many seconds instead of a fixed sample count.
        #[arg(long)]
        time: Option<f64>,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
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
    },
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

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Render {
            scene,
            method,
            spp,
            time,
            threads,
            seed,
            output,
            png,
            define,
            reference,
            quiet,
        } => {
            let t0 = Instant::now();
            let loaded: LoadedScene = match scene.as_deref() {
                None => builtin_scene("cornell-box", &define)
                    .expect("cornell-box is built in")
                    .map_err(|e| e.to_string())?,
                Some(name) => match builtin_scene(name, &define) {
                    Some(r) if !std::path::Path::new(name).exists() => {
                        r.map_err(|e| e.to_string())?
                    }
                    _ => load_scene(std::path::Path::new(name), &define)
                        .map_err(|e| e.to_string())?,
                },
            };
            for w in &loaded.warnings {
                eprintln!("warning: {w}");
            }
            let scene = &loaded.scene;
            let tris: Vec<_> = scene.triangles().collect();
            let bvh = Bvh::build(&tris);
            let setup = t0.elapsed();
            let method = match method {
                MethodArg::Pt => Method::Path,
                MethodArg::Bdpt => Method::Bdpt,
            };
            let budget = match (spp, time) {
                (_, Some(t)) => Budget::Time(t),
                (Some(n), None) => Budget::Spp(n),
                (None, None) => Budget::Spp(loaded.spp.unwrap_or(16) as u64),
            };
            let threads = threads
                .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
            let (w, h) = (scene.camera.width(), scene.camera.height());
            eprintln!(
                "scene: {} triangles, {} lights, {w}x{h}, max_depth {}, {:?} on {threads} threads (setup {:.2} s)",
                scene.triangle_count(),
                scene.lights.len(),
                loaded
                    .settings
                    .max_depth
                    .map_or("unbounded".to_string(), |d| d.to_string()),
                method,
                setup.as_secs_f64()
            );
            let bar = if quiet {
                ProgressBar::hidden()
            } else {
                match budget {
                    Budget::Spp(n) => ProgressBar::new(n),
                    Budget::Time(_) => ProgressBar::new_spinner(),
                }
            };
            bar.set_style(
                ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} spp ({per_sec})",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            let out = render(
                scene,
                &bvh,
                &loaded.settings,
                method,
                budget,
                threads,
                seed,
                &|| bar.inc(1),
            );
            bar.finish_and_clear();
            let img = Image {
                width: w as usize,
                height: h as usize,
                pixels: out.film.resolve(),
            };
            image_io::write_image(&output, &img)?;
            if let Some(p) = &png {
                image_io::write_png(p, &img)?;
            }
            if out.film.nonfinite() > 0 {
                eprintln!(
                    "warning: {} non-finite samples were dropped",
                    out.film.nonfinite()
                );
            }
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
            if let Some(r) = reference {
                let reference = image_io::read_exr(&r)?;
                if (reference.width, reference.height) != (img.width, img.height) {
                    return Err(format!(
                        "reference {} is {}x{}, image is {}x{}",
                        r.display(),
                        reference.width,
                        reference.height,
                        img.width,
                        img.height
                    ));
                }
                let rm = reference.mean();
                println!(
                    "vs reference: relMSE {:.6}, RMSE {:.6}; mean ratio ({:.4}, {:.4}, {:.4})",
                    metrics::rel_mse(&img, &reference),
                    metrics::rmse(&img, &reference),
                    mean.r / rm.r,
                    mean.g / rm.g,
                    mean.b / rm.b
                );
            }
            Ok(())
        }
    }
}

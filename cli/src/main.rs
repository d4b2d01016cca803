//! `cmlt`: render Mitsuba scenes with the cmlt core. The options are in
//! [`cmlt_cli::args`], the files and lines written in
//! [`cmlt_cli::output`], the threads in [`cmlt_cli::render`] and
//! [`cmlt_cli::frames`]; this file loads the scene and picks the driver.
//! Benchmarks are a separate binary, `cmlt-bench` (crate `bench/`).

use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};
use cmlt::renderer::{Budget, RendererConfig};
use cmlt_cli::accel::{Accel, AccelKind};
use cmlt_cli::args::{AccelArg, RenderArgs};
use cmlt_cli::mitsuba::LoadedScene;
use cmlt_cli::render::render;
use cmlt_cli::{frames, load_scene_or_builtin, output};

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

#[derive(Subcommand)]
enum Command {
    /// Render a scene (the built-in Cornell box when no file is given).
    Render(Box<RenderArgs>),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => run_render(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `cmlt render`: checks the outputs, loads the scene, builds the
/// intersector, then renders one image or `--frames` frames.
fn run_render(args: &RenderArgs) -> Result<(), String> {
    output::check(&args.output)?;
    let t0 = Instant::now();
    let loaded = load_scene_or_builtin(
        args.scene.scene.as_deref().unwrap_or("cornell-box"),
        &args.scene.define,
    )?;
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    let scene = &loaded.scene;
    let tris: Vec<_> = scene.triangles().collect();
    let kind = match args.scene.accel {
        AccelArg::Ours => AccelKind::Ours,
        AccelArg::Embree => AccelKind::Embree,
    };
    let accel = Accel::build(kind, &tris)?;
    let setup = t0.elapsed();
    if args.scene.all_effects {
        eprintln!("effects: all (--all-effects: scene analysis off)");
    } else {
        eprintln!("{}", scene.analysis(&scene.camera).report());
    }
    let config = args.config(loaded.settings)?;
    let budget = args.estimator.budget(loaded.spp);
    match args.frames.frames {
        Some(n) => run_frames(args, &loaded, &accel, config, n, budget),
        None => run_single(args, &loaded, &accel, config, budget, setup),
    }
}

/// One image, its summary, and the comparison with `--reference`.
fn run_single(
    args: &RenderArgs,
    loaded: &LoadedScene,
    accel: &Accel,
    config: RendererConfig,
    budget: Budget,
    setup: Duration,
) -> Result<(), String> {
    let scene = &loaded.scene;
    let (w, h) = (scene.camera.width(), scene.camera.height());
    let pixels = w as u64 * h as u64;
    let depth = loaded
        .settings
        .max_depth
        .map_or("unbounded".to_string(), |d| d.to_string());
    let threads = config.workers;
    let metropolis = config.estimator.is_metropolis();
    let mlt = &config.mlt;
    if metropolis {
        eprintln!(
            "scene: {} triangles, {} lights, {w}x{h}, max_depth {depth} (MLT depths 1..={}), {} on {threads} threads ({} BVH), {} chains/thread, large step {}, sigma {}, {} bootstrap samples/depth, {} b passes{} (setup {:.2} s)",
            scene.triangle_count(),
            scene.lights.len(),
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
    } else {
        eprintln!(
            "scene: {} triangles, {} lights, {w}x{h}, max_depth {depth}, {:?} on {threads} threads ({} BVH, setup {:.2} s)",
            scene.triangle_count(),
            scene.lights.len(),
            config.estimator,
            accel.name(),
            setup.as_secs_f64()
        );
    }
    let o = &args.output;
    let bar = match (metropolis, budget) {
        (true, Budget::PerPixel(n)) => output::progress_bar(
            o.quiet,
            Some(n.saturating_mul(pixels)),
            "{human_pos}/{human_len} mutations",
        ),
        (true, Budget::Seconds(_)) => {
            output::progress_bar(o.quiet, None, "{human_pos}/{human_len} mutations")
        }
        (false, Budget::PerPixel(n)) => output::progress_bar(o.quiet, Some(n), "{pos}/{len} spp"),
        (false, Budget::Seconds(_)) => output::progress_bar(o.quiet, None, "{pos}/{len} spp"),
    };
    let out = render(scene, accel, config, budget, &|n| bar.inc(n))?;
    bar.finish_and_clear();
    output::write(&out.image, &o.output, o.png.as_deref(), out.stats.nonfinite)?;
    if metropolis {
        output::print_metropolis(&out, &o.output, mlt.m > 0);
    } else {
        output::print_passes(&out, &o.output);
    }
    if let Some(r) = &o.reference {
        output::compare_reference(&out.image, r)?;
    }
    Ok(())
}

/// `--frames`: the frame loop, one numbered image per frame.
fn run_frames(
    args: &RenderArgs,
    loaded: &LoadedScene,
    accel: &Accel,
    config: RendererConfig,
    count: usize,
    budget: Budget,
) -> Result<(), String> {
    let Budget::PerPixel(per_pixel) = budget else {
        return Err("--frames needs a per-pixel budget, not --time".to_string());
    };
    let start = loaded.scene.camera;
    let pivot = frames::look_at_point(&start, accel);
    let orbit = args.frames.orbit.then_some(args.frames.orbit_degrees);
    eprintln!(
        "{count} frames, {per_pixel} per pixel per frame, {} workers, {:?}{}",
        config.workers,
        config.temporal,
        orbit.map_or(String::new(), |d| format!(", orbit {d}° about {pivot}"))
    );
    let o = &args.output;
    frames::render_frames(
        &loaded.scene,
        accel,
        config,
        count,
        per_pixel,
        |f| match orbit {
            Some(d) => frames::orbit_camera(&start, pivot, d, f, count),
            None => start,
        },
        |f, result| {
            let path = frames::frame_path(&o.output, f);
            output::write(&result.image, &path, None, 0)?;
            if let Some(p) = &o.png {
                output::write(&result.image, &frames::frame_path(p, f), None, 0)?;
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

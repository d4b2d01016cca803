//! `cmlt`: render Mitsuba scenes with the cmlt core. The options are in
//! [`cmlt_cli::args`], the files and lines written in
//! [`cmlt_cli::output`], the threads in [`cmlt_cli::render`] and
//! [`cmlt_cli::frames`]; this file loads the scene and picks the driver.
//! Benchmarks are a separate binary, `cmlt-bench` (crate `bench/`).

use std::process::ExitCode;
use std::time::{Duration, Instant};

use std::path::PathBuf;

use clap::parser::ValueSource;
use clap::{Args, CommandFactory, FromArgMatches, Parser, Subcommand};
use cmlt::renderer::{Accumulation, Budget, PixelBlock, RendererConfig};
use cmlt::scene::Camera;
use cmlt_cli::accel::{Accel, AccelKind};
use cmlt_cli::args::{AccelArg, RenderArgs, check_method_options};
use cmlt_cli::mitsuba::LoadedScene;
use cmlt_cli::render::{render, render_frame_with_sums};
use cmlt_cli::state::{self, PartState};
use cmlt_cli::{frames, image_io, load_scene_or_builtin, output};

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
    /// Merge the states of parts rendered with `render --part I/N --state`
    /// into one image.
    Merge(MergeArgs),
}

/// `cmlt merge`'s options.
#[derive(Args, Debug)]
struct MergeArgs {
    /// The part states (`render --part I/N --state FILE`), any order.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// Output image (.exr linear, or .png sRGB).
    #[arg(short, long)]
    output: PathBuf,
    /// Also write an sRGB PNG preview here.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Compare with a reference OpenEXR and print relMSE and means.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Refuse to merge unless every index 0..N is present.
    #[arg(long)]
    complete: bool,
}

fn main() -> ExitCode {
    let matches = Cli::command().get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    let result = match cli.command {
        Command::Render(args) => {
            // Which options the command line gave (not their defaults):
            // those the method does not read are refused before anything
            // is loaded.
            let given = matches.subcommand_matches("render").map_or(Ok(()), |m| {
                check_method_options(args.estimator.method, |id| {
                    m.value_source(id) == Some(ValueSource::CommandLine)
                })
            });
            given.and_then(|()| run_render(&args))
        }
        Command::Merge(args) => run_merge(&args),
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
    let part = args.part.part.is_some();
    output::check(&args.output, part)?;
    if let Some(s) = &args.part.state {
        image_io::check_writable(s)?;
    }
    let t0 = Instant::now();
    let scene_name = args.scene.scene.as_deref().unwrap_or("cornell-box");
    let loaded = load_scene_or_builtin(scene_name, &args.scene.define)?;
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
    let mut config = args.config(loaded.settings)?;
    let budget = args.estimator.budget(loaded.spp);
    if let Some((i, n)) = args.part.part {
        config.seed = state::part_seed(args.estimator.seed, i);
        eprintln!(
            "part {i} of {n}: seed {} (base seed {})",
            config.seed, args.estimator.seed
        );
    }
    let fr = &args.frames;
    match (fr.frames, fr.frame) {
        (Some(n), Some(k)) => {
            if k >= n {
                return Err(format!("--frame {k} is beyond the {n} frames (0..{n})"));
            }
            if fr.keep_chains || fr.b_window > 1 || fr.accumulation != Accumulation::Reset {
                return Err(
                    "--frame renders one frame on its own: --keep-chains, --b-window and --accumulation carry state from frame to frame".to_string(),
                );
            }
            if fr.pixel_block != PixelBlock::Fixed(1) {
                return Err("--frame renders one frame on its own, at full resolution: --pixel-block is for the frame loop".to_string());
            }
            let start = loaded.scene.camera;
            let camera = if fr.orbit {
                let pivot = frames::look_at_point(&start, &accel);
                frames::orbit_camera(&start, pivot, fr.orbit_degrees, k, n)
            } else {
                start
            };
            let frame = Some((camera, k as u64));
            run_single(args, &loaded, &accel, config, budget, setup, frame)
        }
        (Some(_), None) if part => {
            Err("--part with --frames renders one frame: give --frame K".to_string())
        }
        (Some(n), None) => run_frames(args, &loaded, &accel, config, n, budget),
        (None, _) => run_single(args, &loaded, &accel, config, budget, setup, None),
    }
}

/// One image, its summary, and the comparison with `--reference`;
/// `frame`: frame K of a sequence, through its camera.
fn run_single(
    args: &RenderArgs,
    loaded: &LoadedScene,
    accel: &Accel,
    config: RendererConfig,
    budget: Budget,
    setup: Duration,
    frame: Option<(Camera, u64)>,
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
    let level2 = config.estimator.level2();
    if let Some(mlt) = config.estimator.mlt() {
        eprintln!(
            "scene: {} triangles, {} lights, {w}x{h}, max_depth {depth} (MLT depths 1..={}), {} on {threads} threads ({} BVH), {} chains/thread, large step {}, sigma {}, {} bootstrap samples/depth, {} b passes{} (setup {:.2} s)",
            scene.triangle_count(),
            scene.lights.len(),
            config.max_depth(),
            config.estimator.kind().name().to_uppercase(),
            accel.name(),
            mlt.n_chains,
            mlt.large_step_prob,
            mlt.sigma,
            mlt.n_bootstrap,
            mlt.normalisation_passes(u64::from(w) * u64::from(h)),
            level2.map_or(String::new(), |l2| format!(
                ", k {} m {} lens sigma {} px, caustic scale {}, {:?} candidates, {:?} splatting",
                l2.k, l2.m, l2.lens_sigma, l2.caustic_scale, l2.candidates, l2.splatting
            )),
            setup.as_secs_f64()
        );
    } else {
        eprintln!(
            "scene: {} triangles, {} lights, {w}x{h}, max_depth {depth}, {:?} on {threads} threads ({} BVH, setup {:.2} s)",
            scene.triangle_count(),
            scene.lights.len(),
            config.estimator.kind(),
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
    let (out, sums) = if args.part.part.is_some() {
        let (out, sums) =
            render_frame_with_sums(scene, accel, config, budget, &|n| bar.inc(n), frame)?;
        (out, Some(sums))
    } else {
        (render(scene, accel, config, budget, &|n| bar.inc(n))?, None)
    };
    bar.finish_and_clear();
    let image = o.image_path(sums.is_some());
    if let Some(p) = &image {
        output::write(&out.image, p, o.png.as_deref(), out.stats.nonfinite)?;
    } else if let Some(p) = &o.png {
        output::write(&out.image, p, None, out.stats.nonfinite)?;
    }
    let shown = image
        .clone()
        .or_else(|| args.part.state.clone())
        .unwrap_or_default();
    if metropolis {
        output::print_metropolis(&out, &shown, level2.is_some());
    } else {
        output::print_passes(&out, &shown);
    }
    if let (Some(sums), Some(path), Some((part, parts))) = (sums, &args.part.state, args.part.part)
    {
        let s = state::from_render(
            &out,
            sums,
            &config,
            state::Identity {
                part,
                parts,
                frame: frame.map_or(0, |(_, k)| k),
                seed: args.estimator.seed,
                scene_hash: state::scene_hash(
                    args.scene.scene.as_deref().unwrap_or("cornell-box"),
                    &args.scene.define,
                    scene.triangles(),
                ),
            },
        );
        let bytes = s.to_bytes();
        image_io::write_atomically(path, &bytes)?;
        println!(
            "part {part} of {parts}: wrote {} ({} bytes)",
            path.display(),
            bytes.len()
        );
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
        "{count} frames, {per_pixel} per pixel per frame, {} workers, {:?}, {:?}{}",
        config.workers,
        config.temporal,
        args.frames.accumulation,
        orbit.map_or(String::new(), |d| format!(", orbit {d}° about {pivot}"))
    );
    let o = &args.output;
    frames::render_frames(
        &loaded.scene,
        accel,
        config,
        count,
        per_pixel,
        args.frames.accumulation,
        args.frames.pixel_block,
        |f| match orbit {
            Some(d) => frames::orbit_camera(&start, pivot, d, f, count),
            None => start,
        },
        |f, result| {
            let path = frames::frame_path(&o.image_path(false).unwrap_or_default(), f);
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

/// `cmlt merge`: reads and checks every part, merges them, writes the
/// image. Nothing is written when a part is unreadable or does not belong.
fn run_merge(args: &MergeArgs) -> Result<(), String> {
    image_io::check_output(&args.output)?;
    if let Some(p) = &args.png {
        image_io::check_output(p)?;
        if !image_io::is_png(p) {
            return Err(format!("{}: --png must end in .png", p.display()));
        }
    }
    let t0 = Instant::now();
    let merged = state::merge_files(&args.parts)?;
    let first = PartState::read_header(&args.parts[0])?;
    let n = first.parts;
    if !merged.missing.is_empty() {
        let list: Vec<String> = merged.missing.iter().map(|i| i.to_string()).collect();
        let notice = format!(
            "{} of {n} parts given; missing: {} (the image is the estimate of the parts present, at their budget)",
            args.parts.len(),
            list.join(", ")
        );
        if args.complete {
            return Err(format!("--complete: {notice}"));
        }
        eprintln!("notice: {notice}");
    }
    let seconds = t0.elapsed();
    output::write(
        &merged.image,
        &args.output,
        args.png.as_deref(),
        merged.nonfinite,
    )?;
    let mean = merged.image.mean();
    let metropolis = first.estimator().is_some_and(|e| e.is_metropolis());
    let pixels = (merged.image.width * merged.image.height).max(1) as f64;
    println!(
        "merged {} of {n} parts ({}): {:.2} {} per pixel{}; read and merged in {:.3} s; mean rgb ({:.5}, {:.5}, {:.5}); wrote {}",
        args.parts.len(),
        first.estimator,
        merged.units as f64 / if metropolis { pixels } else { 1.0 },
        if metropolis { "mutations" } else { "samples" },
        if metropolis {
            format!(", pooled b {:.5}", merged.b)
        } else {
            String::new()
        },
        seconds.as_secs_f64(),
        mean.r,
        mean.g,
        mean.b,
        args.output.display()
    );
    if let Some(r) = &args.reference {
        output::compare_reference(&merged.image, r)?;
    }
    Ok(())
}

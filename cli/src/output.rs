//! What `cmlt render` writes and prints: the image files, the summary
//! lines of a render, the comparison with a reference, the progress bar.

use std::path::Path;

use indicatif::{ProgressBar, ProgressStyle};

use crate::args::OutputArgs;
use crate::image_io::{self, Image};
use crate::metrics;
use crate::render::{RenderOutput, work_line};

/// Refuses, before any work, outputs that could not be written (a render
/// must not end in "cannot write") and a `--png` that is not a PNG.
pub fn check(args: &OutputArgs, part: bool) -> Result<(), String> {
    if let Some(p) = args.image_path(part) {
        image_io::check_output(&p)?;
    }
    if let Some(p) = &args.png {
        image_io::check_output(p)?;
        if !image_io::is_png(p) {
            return Err(format!("{}: --png must end in .png", p.display()));
        }
    }
    Ok(())
}

/// Writes `img` to `output` (and the PNG preview to `png`) and warns about
/// dropped samples.
pub fn write(img: &Image, output: &Path, png: Option<&Path>, nonfinite: u64) -> Result<(), String> {
    image_io::write_image(output, img)?;
    if let Some(p) = png {
        image_io::write_png(p, img)?;
    }
    if nonfinite > 0 {
        eprintln!("warning: {nonfinite} non-finite samples were dropped");
    }
    Ok(())
}

/// Prints relMSE and mean ratios against a reference OpenEXR.
pub fn compare_reference(img: &Image, r: &Path) -> Result<(), String> {
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

/// Prints the summary of a PT or BDPT render.
pub fn print_passes(out: &RenderOutput, output: &Path) {
    let mean = out.image.mean();
    println!(
        "{} spp in {:.2} s: {:.3} M samples/s, {:.2} Mrays/s; mean rgb ({:.5}, {:.5}, {:.5}); wrote {}",
        out.stats.passes,
        out.wall.as_secs_f64(),
        out.samples_per_sec() * 1e-6,
        out.mrays_per_sec(),
        mean.r,
        mean.g,
        mean.b,
        output.display()
    );
    println!("{}", work_line(out.tracer(), None));
}

/// Prints the summary of an MLT or CMLT render (`level2`: the side chains'
/// line too).
pub fn print_metropolis(out: &RenderOutput, output: &Path, level2: bool) {
    let mean = out.image.mean();
    let m = out.mlt();
    let t = out.tracer();
    println!(
        "{:.2} mutations/pixel in {:.2} s (bootstrap {:.2} s, b {:.5}): {:.3} M mutations/s, {:.2} Mrays/s; accepted small {:.1}%, large {:.1}%, zero proposals {:.1}%; mean rgb ({:.5}, {:.5}, {:.5}); wrote {}",
        out.per_pixel(),
        out.wall.as_secs_f64(),
        out.bootstrap_wall.as_secs_f64(),
        out.stats.b,
        out.mutations_per_sec() * 1e-6,
        out.mrays_per_sec(),
        100.0 * m.small_acceptance(),
        100.0 * m.large_acceptance(),
        100.0 * m.zero_proposals as f64 / m.mutations.max(1) as f64,
        mean.r,
        mean.g,
        mean.b,
        output.display()
    );
    if m.technique_proposed > 0 {
        println!(
            "technique changes: {:.2}% of small steps proposed another strategy (s, t), {:.1}% of those accepted",
            100.0 * m.technique_fraction(),
            100.0 * m.technique_acceptance(),
        );
    }
    if m.bidirectional_proposed + m.lens_subpath_proposed > 0 {
        println!(
            "path space: {} bidirectional mutations ({:.1}% accepted), {} lens subpath mutations ({:.1}% accepted); {:.1}% made no path",
            m.bidirectional_proposed,
            100.0 * m.bidirectional_acceptance(),
            m.lens_subpath_proposed,
            100.0 * m.lens_subpath_acceptance(),
            100.0 * m.zero_fraction()
        );
        let a = m.perturbation_acceptance();
        println!(
            "path space: {} lens perturbations ({:.1}% accepted), {} caustic perturbations ({:.1}% accepted), {} multi-chain perturbations ({:.1}% accepted)",
            m.perturbations_proposed[0],
            100.0 * a[0],
            m.perturbations_proposed[1],
            100.0 * a[1],
            m.perturbations_proposed[2],
            100.0 * a[2]
        );
    }
    if let Some(ls) = out.large_step_b().filter(|ls| ls.count > 0) {
        println!(
            "b: passes {:.5}, large steps {:.5} ± {:.5} ({} large steps), pooled by sample counts {:.5}",
            out.stats.b, ls.b, ls.error, ls.count, ls.pooled
        );
    }
    if level2 {
        println!(
            "level 2: {} lens steps ({:.1}% accepted), {} caustic steps ({:.1}% accepted), {} multi-chain steps ({:.1}% accepted), {} identity steps; zero candidates {:.1}%; {} packets, {:.2} lanes/packet, {:.1}% of rays in packets",
            m.lens_steps,
            100.0 * m.lens_acceptance(),
            m.caustic_steps,
            100.0 * m.caustic_acceptance(),
            m.multi_chain_steps,
            100.0 * m.multi_chain_acceptance(),
            m.identity_steps,
            100.0 * m.l2_zero_fraction(),
            t.packets,
            t.mean_packet_lanes(),
            100.0 * t.packet_rays as f64 / t.total_rays().max(1) as f64
        );
    }
    println!("{}", work_line(t, Some(m)));
}

/// A progress bar over `total` units (a spinner for time budgets), hidden
/// with `--quiet`; `counter` is the template of the position and length.
pub fn progress_bar(quiet: bool, total: Option<u64>, counter: &str) -> ProgressBar {
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

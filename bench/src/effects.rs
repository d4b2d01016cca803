//! `cmlt-bench effects`: what simulating only the effects a scene calls for
//! (the scene analysis) buys, against `--all-effects`, in one run.
//!
//! For each scene and method, renders of a fixed wall time alternate
//! between analysis on and off, `repeats` times each (alternating keeps
//! both sides under the same machine load); each side's figure is its best
//! run: samples/s for PT and BDPT, mutations/s for MLT and CMLT. The ratio
//! on / off above 1 is the speed-up. The image means of both sides are
//! printed too: they must agree within noise.

use std::io::Write;

use cmlt::math::Rgb;
use cmlt::renderer::{EstimatorKind, RendererConfig};
use cmlt::scene::Scene;
use cmlt_cli::accel::Accel;

use cmlt_cli::mitsuba::LoadedScene;
use cmlt_cli::render::{Budget, render};

/// What the throughput of `method` counts.
fn unit(method: EstimatorKind) -> &'static str {
    if method.is_metropolis() {
        "mutations/s"
    } else {
        "samples/s"
    }
}

/// One scene and method: throughput and image mean with the analysis on
/// and off.
#[derive(Clone, Debug)]
pub struct Row {
    /// Scene name.
    pub scene: String,
    /// The method.
    pub method: EstimatorKind,
    /// Best throughput with the analysis on.
    pub on: f64,
    /// Best throughput with every effect on (`--all-effects`).
    pub off: f64,
    /// Image mean of the last run with the analysis on.
    pub mean_on: Rgb,
    /// Image mean of the last run with every effect on.
    pub mean_off: Rgb,
}

impl Row {
    /// Speed-up of the analysis: on / off.
    pub fn ratio(&self) -> f64 {
        self.on / self.off.max(1e-300)
    }
}

/// One timed render, the scene analysis on or off (`all_effects`):
/// (throughput, image mean).
fn measure(
    loaded: &LoadedScene,
    accel: &Accel,
    all_effects: bool,
    method: EstimatorKind,
    seconds: f64,
    threads: usize,
) -> Result<(f64, Rgb), String> {
    let config = RendererConfig {
        settings: loaded.settings,
        workers: threads as u32,
        all_effects,
        ..RendererConfig::for_estimator(method)
    };
    let out = render(
        &loaded.scene,
        accel,
        config,
        Budget::Seconds(seconds),
        &|_| {},
    )?;
    let throughput = if method.is_metropolis() {
        out.mutations_per_sec()
    } else {
        out.samples_per_sec()
    };
    Ok((throughput, out.image.mean()))
}

/// Measures every scene × method (see the module docs), printing a line
/// per row to `out` as it goes.
#[allow(clippy::too_many_arguments)]
pub fn run(
    scenes: &[(String, LoadedScene, Accel)],
    methods: &[EstimatorKind],
    seconds: f64,
    repeats: usize,
    threads: usize,
    out: &mut impl Write,
) -> Result<Vec<Row>, String> {
    let io = |e: std::io::Error| e.to_string();
    let mut rows = Vec::new();
    for (name, loaded, accel) in scenes {
        let scene: &Scene = &loaded.scene;
        let analysis = scene.analysis(&scene.camera);
        writeln!(out, "{name}: {}", analysis.report()).map_err(io)?;
        for &method in methods {
            let mut row = Row {
                scene: name.clone(),
                method,
                on: 0.0,
                off: 0.0,
                mean_on: Rgb::ZERO,
                mean_off: Rgb::ZERO,
            };
            for _ in 0..repeats.max(1) {
                let (t, m) = measure(loaded, accel, false, method, seconds, threads)?;
                row.on = row.on.max(t);
                row.mean_on = m;
                let (t, m) = measure(loaded, accel, true, method, seconds, threads)?;
                row.off = row.off.max(t);
                row.mean_off = m;
            }
            writeln!(
                out,
                "  {:<5} analysis on {:>12.0} {unit}, --all-effects {:>12.0} {unit}: ratio {:.3}; mean luminance {:.5} vs {:.5}",
                method.name(),
                row.on,
                row.off,
                row.ratio(),
                row.mean_on.luminance(),
                row.mean_off.luminance(),
                unit = unit(method),
            )
            .map_err(io)?;
            rows.push(row);
        }
    }
    Ok(rows)
}

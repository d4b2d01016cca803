//! `cmlt bench effects`: what simulating only the effects a scene calls for
//! (the scene analysis, issue 8) buys, against `--all-effects`, in one run.
//!
//! For each scene and method, renders of a fixed wall time alternate
//! between analysis on and off, `repeats` times each (alternating keeps
//! both sides under the same machine load); each side's figure is its best
//! run: samples/s for PT and BDPT, mutations/s for MLT and CMLT. The ratio
//! on / off above 1 is the speed-up. The image means of both sides are
//! printed too: they must agree within noise.

use std::io::Write;

use cmlt::accel::Intersector;
use cmlt::integrator::Method;
use cmlt::math::Rgb;
use cmlt::mlt::MltSettings;
use cmlt::scene::{Analysis, Scene};

use crate::render::{Budget, MltBudget, render, render_mlt};
use crate::scene::LoadedScene;

/// An estimator as the benchmark names it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BenchMethod {
    /// Path tracing (samples/s).
    Pt,
    /// Bidirectional path tracing (samples/s).
    Bdpt,
    /// Level-1 MLT (mutations/s).
    Mlt,
    /// CMLT with its defaults (mutations/s).
    Cmlt,
}

impl BenchMethod {
    /// Parses `pt`, `bdpt`, `mlt` or `cmlt`.
    pub fn parse(s: &str) -> Result<Self, String> {
        Ok(match s {
            "pt" => BenchMethod::Pt,
            "bdpt" => BenchMethod::Bdpt,
            "mlt" => BenchMethod::Mlt,
            "cmlt" => BenchMethod::Cmlt,
            _ => return Err(format!("unknown method `{s}` (pt, bdpt, mlt, cmlt)")),
        })
    }

    fn name(self) -> &'static str {
        match self {
            BenchMethod::Pt => "pt",
            BenchMethod::Bdpt => "bdpt",
            BenchMethod::Mlt => "mlt",
            BenchMethod::Cmlt => "cmlt",
        }
    }

    /// What the throughput counts.
    fn unit(self) -> &'static str {
        match self {
            BenchMethod::Pt | BenchMethod::Bdpt => "samples/s",
            BenchMethod::Mlt | BenchMethod::Cmlt => "mutations/s",
        }
    }
}

/// One scene and method: throughput and image mean with the analysis on
/// and off.
#[derive(Clone, Debug)]
pub struct Row {
    /// Scene name.
    pub scene: String,
    /// The method.
    pub method: BenchMethod,
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

/// One timed render: (throughput, image mean).
fn measure<I: Intersector + Sync>(
    loaded: &LoadedScene,
    accel: &I,
    analysis: &Analysis,
    method: BenchMethod,
    seconds: f64,
    threads: usize,
) -> Result<(f64, Rgb), String> {
    let scene = &loaded.scene;
    let (pixels, throughput) = match method {
        BenchMethod::Pt | BenchMethod::Bdpt => {
            let m = if method == BenchMethod::Pt {
                Method::Path
            } else {
                Method::Bdpt
            };
            let out = render(
                scene,
                accel,
                &loaded.settings,
                analysis,
                m,
                Budget::Time(seconds),
                threads,
                0,
                &|| {},
            )?;
            (out.film.resolve(), out.samples_per_sec())
        }
        BenchMethod::Mlt | BenchMethod::Cmlt => {
            let mlt = if method == BenchMethod::Cmlt {
                MltSettings::cmlt()
            } else {
                MltSettings::default()
            };
            let out = render_mlt(
                scene,
                accel,
                &loaded.settings,
                analysis,
                &mlt,
                MltBudget::Time(seconds),
                threads,
                0,
                &|_| {},
            )?;
            (out.image(), out.mutations_per_sec())
        }
    };
    let n = pixels.len().max(1) as f32;
    let sum = pixels.iter().fold(Rgb::ZERO, |a, &p| a + p);
    Ok((throughput, sum / n))
}

/// Measures every scene × method (see the module docs), printing a line
/// per row to `out` as it goes.
#[allow(clippy::too_many_arguments)]
pub fn run<I: Intersector + Sync>(
    scenes: &[(String, LoadedScene, I)],
    methods: &[BenchMethod],
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
                let (t, m) = measure(loaded, accel, &analysis, method, seconds, threads)?;
                row.on = row.on.max(t);
                row.mean_on = m;
                let (t, m) = measure(loaded, accel, &Analysis::all(), method, seconds, threads)?;
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
                unit = method.unit(),
            )
            .map_err(io)?;
            rows.push(row);
        }
    }
    Ok(rows)
}

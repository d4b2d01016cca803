//! `cmlt-bench params`: the parameter study of Segovia 2007's §2.5.1 — CMLT's
//! lens-perturbation width σ (pixels) × candidates per step k × side-chain
//! length m, every cell rendered for the same wall-clock time and scored
//! against the reference.
//!
//! Small σ with many candidates is where stratified candidates should help
//! most (Segovia 2007's fig. 14: a lattice of k candidates covers a small
//! perturbation disc evenly), so the grid spans both. Plain MLT (m = 0) is
//! measured alongside as the baseline level 2 has to beat.

use std::io::Write;
use std::path::{Path, PathBuf};

use cmlt::mlt::{Candidates, CmltSettings, Level2Settings, MltSettings};
use cmlt::renderer::Estimator;

use super::plot::HeatPanel;
use super::study::{Measurement, Study};
use cmlt_cli::render::Budget;

/// The CSV header of [`write_csv`]; `method` is `cmlt` or `mlt` (the
/// baseline, whose σ, k and m columns are empty).
pub const CSV_HEADER: &str =
    "method,lens_sigma,k,m,candidates,seed,wall_s,mutations_per_pixel,rel_mse,rmse,mrays_per_s";

/// Settings of one parameter study.
#[derive(Clone, Debug)]
pub struct Options {
    /// Scene file (Mitsuba 3 XML) or built-in name.
    pub scene: String,
    /// Reference OpenEXR (full size or an integer multiple of the render).
    pub reference: PathBuf,
    /// `-D` overrides of the scene's defaults.
    pub defines: Vec<(String, String)>,
    /// Seconds per render (bootstrap included).
    pub time: f64,
    /// Lens-perturbation σ values, pixels.
    pub lens_sigmas: Vec<f32>,
    /// Candidates per multiple-try step.
    pub ks: Vec<u32>,
    /// Side-chain lengths (each ≥ 1).
    pub ms: Vec<u32>,
    /// How the k candidates are drawn.
    pub candidates: Candidates,
    /// Worker threads.
    pub threads: usize,
    /// Seeds 0..seeds per cell (the cell's value is their mean).
    pub seeds: u64,
}

/// One render of the grid (or of the MLT baseline when `m == 0`).
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    /// Lens σ in pixels (unused when `m == 0`).
    pub lens_sigma: f32,
    /// Candidates per step.
    pub k: u32,
    /// Side-chain length; 0 = the plain-MLT baseline.
    pub m: u32,
    /// Seed.
    pub seed: u64,
    /// What the render measured (`samples` = mutations per pixel).
    pub result: Measurement,
}

/// Runs the baseline and the grid, printing one line per render; returns
/// the cells in order (baseline first, then m, k, σ).
pub fn run(opts: &Options, out: &mut dyn Write) -> Result<Vec<Cell>, String> {
    if opts.ms.contains(&0) {
        return Err("--ms: m = 0 is plain MLT, measured anyway as the baseline".to_string());
    }
    if !(opts.time.is_finite() && opts.time > 0.0) {
        return Err("--time must be a positive number of seconds".to_string());
    }
    let study = Study::load(&opts.scene, &opts.defines, &opts.reference)?;
    let (w, h) = study.resolution();
    let io = |e: std::io::Error| e.to_string();
    writeln!(
        out,
        "{} at {w}x{h}, {} s per render on {} threads, {:?} candidates",
        opts.scene, opts.time, opts.threads, opts.candidates
    )
    .map_err(io)?;
    let mut grid = vec![(0.0f32, 1u32, 0u32)];
    for &m in &opts.ms {
        for &k in &opts.ks {
            for &s in &opts.lens_sigmas {
                grid.push((s, k, m));
            }
        }
    }
    let mut cells = Vec::new();
    for (lens_sigma, k, m) in grid {
        // m = 0: the MLT baseline; otherwise CMLT with the cell's level 2.
        let estimator = if m == 0 {
            Estimator::Mlt(MltSettings::default())
        } else {
            Estimator::Cmlt(CmltSettings {
                level2: Level2Settings {
                    lens_sigma,
                    k,
                    m,
                    candidates: opts.candidates,
                    ..Level2Settings::default()
                },
                ..CmltSettings::default()
            })
        };
        estimator
            .validate()
            .map_err(|e| format!("{e} (σ {lens_sigma}, k {k}, m {m})"))?;
        for seed in 0..opts.seeds.max(1) {
            let result =
                study.measure(estimator, Budget::Seconds(opts.time), opts.threads, seed)?;
            let what = if m == 0 {
                "mlt (baseline)".to_string()
            } else {
                format!("σ {lens_sigma:>4} k {k:>2} m {m:>2}")
            };
            writeln!(
                out,
                "{what:<20} seed {seed}: relMSE {:.5}, {:.1} mutations/px, {:.2} Mrays/s",
                result.rel_mse, result.samples, result.mrays_per_s
            )
            .map_err(io)?;
            cells.push(Cell {
                lens_sigma,
                k,
                m,
                seed,
                result,
            });
        }
    }
    Ok(cells)
}

/// Writes `cells` with [`CSV_HEADER`].
pub fn write_csv(path: &Path, cells: &[Cell], candidates: Candidates) -> Result<(), String> {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for c in cells {
        let r = &c.result;
        let (method, params) = if c.m == 0 {
            ("mlt", ",,,".to_string())
        } else {
            (
                "cmlt",
                format!(
                    "{},{},{},{}",
                    c.lens_sigma,
                    c.k,
                    c.m,
                    format!("{candidates:?}").to_lowercase()
                ),
            )
        };
        s.push_str(&format!(
            "{method},{params},{},{:.4},{:.3},{:.6e},{:.6e},{:.3}\n",
            c.seed, r.wall_s, r.samples, r.rel_mse, r.rmse, r.mrays_per_s
        ));
    }
    std::fs::write(path, s).map_err(|e| format!("{}: {e}", path.display()))
}

/// Mean relMSE over the seeds of the cell (σ, k, m), NaN if not measured.
fn mean_rel_mse(cells: &[Cell], lens_sigma: f32, k: u32, m: u32) -> f64 {
    let v: Vec<f64> = cells
        .iter()
        .filter(|c| c.m == m && (m == 0 || (c.k == k && c.lens_sigma == lens_sigma)))
        .map(|c| c.result.rel_mse)
        .collect();
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// The study's verdict: the best cell and the baseline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Best {
    /// σ of the best cell.
    pub lens_sigma: f32,
    /// k of the best cell.
    pub k: u32,
    /// m of the best cell.
    pub m: u32,
    /// Its mean relMSE.
    pub rel_mse: f64,
    /// Plain MLT's mean relMSE.
    pub mlt_rel_mse: f64,
}

/// The grid cell with the lowest mean relMSE.
pub fn best(opts: &Options, cells: &[Cell]) -> Option<Best> {
    let mut best: Option<Best> = None;
    for &m in &opts.ms {
        for &k in &opts.ks {
            for &s in &opts.lens_sigmas {
                let e = mean_rel_mse(cells, s, k, m);
                if e.is_finite() && best.is_none_or(|b| e < b.rel_mse) {
                    best = Some(Best {
                        lens_sigma: s,
                        k,
                        m,
                        rel_mse: e,
                        mlt_rel_mse: mean_rel_mse(cells, 0.0, 1, 0),
                    });
                }
            }
        }
    }
    best
}

/// One heat map per m: σ across, k up, mean relMSE per cell, the best
/// cell outlined.
pub fn panels(opts: &Options, cells: &[Cell]) -> Vec<HeatPanel> {
    let b = best(opts, cells);
    opts.ms
        .iter()
        .map(|&m| HeatPanel {
            title: format!("m = {m}"),
            x_labels: opts.lens_sigmas.iter().map(|s| s.to_string()).collect(),
            y_labels: opts.ks.iter().map(|k| k.to_string()).collect(),
            values: opts
                .ks
                .iter()
                .map(|&k| {
                    opts.lens_sigmas
                        .iter()
                        .map(|&s| mean_rel_mse(cells, s, k, m))
                        .collect()
                })
                .collect(),
            mark: b.filter(|b| b.m == m).map(|b| {
                (
                    opts.lens_sigmas
                        .iter()
                        .position(|&s| s == b.lens_sigma)
                        .unwrap_or(0),
                    opts.ks.iter().position(|&k| k == b.k).unwrap_or(0),
                )
            }),
        })
        .collect()
}

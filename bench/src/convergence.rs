//! `cmlt-bench convergence`: error against a reference versus time, per
//! method — what accuracy costs.
//!
//! Every method renders the scene at every budget (seconds of wall-clock
//! time, or samples per pixel for deterministic runs) from several seeds;
//! each render is one CSV row ([`CSV_HEADER`]). Curves average the seeds
//! of each (method, budget): mean wall time against mean relMSE. Peer
//! renderers (`bench/peers/`) append rows of the same shape with
//! `cmlt-bench score`, and `cmlt-bench plot` redraws the curves from the
//! CSV.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::study::{Measurement, Study};
use cmlt::mlt::Level1;
use cmlt::renderer::{Estimator, EstimatorKind};
use cmlt_cli::render::Budget;

/// The CSV header of [`write_csv`]. `budget_s` is empty for sample-count
/// budgets; `samples` is samples per pixel (PT, BDPT, peers) or mutations
/// per pixel (MLT, CMLT).
/// `rel_mse_4` and `rel_mse_16` are the relMSE of 4 × 4 and 16 × 16-pixel
/// block averages ([`super::study::block_rel_mse`]), `cpu_s` the render's
/// CPU seconds; files written before they existed (11 columns) still read,
/// with NaN there.
pub const CSV_HEADER: &str = "method,budget_s,wall_s,seed,samples,rel_mse,rmse,mean_r,mean_g,mean_b,mrays_per_s,rel_mse_4,rel_mse_16,cpu_s";

/// The header of files written before the block-averaged columns.
const CSV_HEADER_11: &str =
    "method,budget_s,wall_s,seed,samples,rel_mse,rmse,mean_r,mean_g,mean_b,mrays_per_s";

/// Settings of one convergence study.
#[derive(Clone, Debug)]
pub struct Options {
    /// Scene file (Mitsuba 3 XML) or built-in name.
    pub scene: String,
    /// Reference OpenEXR (full size or an integer multiple of the render).
    pub reference: PathBuf,
    /// `-D` overrides of the scene's defaults (e.g. `resx`, `resy`).
    pub defines: Vec<(String, String)>,
    /// Method names (`pt`, `bdpt`, `mlt`, `cmlt`).
    pub methods: Vec<String>,
    /// Budgets, ascending: seconds, or samples per pixel with `samples`.
    pub budgets: Vec<f64>,
    /// Budgets are samples (PT, BDPT) or mutations (MLT, CMLT) per pixel
    /// rather than seconds.
    pub samples: bool,
    /// Worker threads.
    pub threads: usize,
    /// Seeds 0..seeds for budgets up to `seeds_up_to`.
    pub seeds: u64,
    /// Larger budgets render seed 0 only (a long render's own error is
    /// already an average over many samples; extra seeds would cost the
    /// most where they help the least).
    pub seeds_up_to: f64,
}

/// One render: a CSV row.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Method name (`pt`, …, or a peer's, e.g. `mitsuba-path`).
    pub method: String,
    /// The time budget in seconds; `None` for a sample-count budget.
    pub budget_s: Option<f64>,
    /// Seed of the render.
    pub seed: u64,
    /// What the render measured.
    pub m: Measurement,
}

impl Row {
    /// The budget the row belongs to: seconds, or else samples per pixel.
    pub fn budget(&self) -> f64 {
        self.budget_s.unwrap_or(self.m.samples)
    }

    fn to_csv(&self) -> String {
        let m = &self.m;
        format!(
            "{},{},{:.4},{},{},{:.6e},{:.6e},{:.6},{:.6},{:.6},{:.3},{:.6e},{:.6e},{:.3}",
            self.method,
            self.budget_s.map_or(String::new(), |b| b.to_string()),
            m.wall_s,
            self.seed,
            // Mutations per pixel are fractional; three decimals suffice.
            (m.samples * 1e3).round() / 1e3,
            m.rel_mse,
            m.rmse,
            m.mean[0],
            m.mean[1],
            m.mean[2],
            m.mrays_per_s,
            m.rel_mse_4,
            m.rel_mse_16,
            m.cpu_s
        )
    }

    fn from_csv(line: &str) -> Result<Row, String> {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let full = f.len() == 14;
        if f.len() != 11 && !full {
            return Err(format!(
                "expected 11 or 14 fields, got {}: '{line}'",
                f.len()
            ));
        }
        let num = |i: usize| -> Result<f64, String> {
            f[i].parse::<f64>()
                .map_err(|e| format!("field {} '{}': {e}", i + 1, f[i]))
        };
        Ok(Row {
            method: f[0].to_string(),
            budget_s: if f[1].is_empty() { None } else { Some(num(1)?) },
            seed: f[3].parse().map_err(|e| format!("seed '{}': {e}", f[3]))?,
            m: Measurement {
                wall_s: num(2)?,
                samples: num(4)?,
                rel_mse: num(5)?,
                rmse: num(6)?,
                mean: [num(7)?, num(8)?, num(9)?],
                mrays_per_s: num(10)?,
                rel_mse_4: if full { num(11)? } else { f64::NAN },
                rel_mse_16: if full { num(12)? } else { f64::NAN },
                cpu_s: if full { num(13)? } else { f64::NAN },
            },
        })
    }
}

/// Writes `rows` with [`CSV_HEADER`], replacing `path`.
pub fn write_csv(path: &Path, rows: &[Row]) -> Result<(), String> {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for r in rows {
        s.push_str(&r.to_csv());
        s.push('\n');
    }
    std::fs::write(path, s).map_err(|e| format!("{}: {e}", path.display()))
}

/// Appends `row` to `path`, writing the header first if the file is new.
pub fn append_csv(path: &Path, row: &Row) -> Result<(), String> {
    let fresh = !path.exists();
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let mut s = String::new();
    if fresh {
        s.push_str(CSV_HEADER);
        s.push('\n');
    }
    s.push_str(&row.to_csv());
    s.push('\n');
    f.write_all(s.as_bytes())
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// Reads a CSV written by [`write_csv`] / [`append_csv`].
pub fn read_csv(path: &Path) -> Result<Vec<Row>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut lines = text.lines();
    let header = lines.next().map(str::trim);
    if header != Some(CSV_HEADER) && header != Some(CSV_HEADER_11) {
        return Err(format!(
            "{}: the first line is not '{CSV_HEADER}'",
            path.display()
        ));
    }
    lines
        .filter(|l| !l.trim().is_empty())
        .enumerate()
        .map(|(i, l)| Row::from_csv(l).map_err(|e| format!("{}:{}: {e}", path.display(), i + 2)))
        .collect()
}

/// One point of a curve: the mean over the seeds of one (method, budget).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// The budget (seconds, or samples per pixel).
    pub budget: f64,
    /// Mean wall-clock seconds.
    pub wall_s: f64,
    /// Mean relative MSE.
    pub rel_mse: f64,
    /// Mean relative MSE of 4 × 4-pixel block averages.
    pub rel_mse_4: f64,
    /// Mean relative MSE of 16 × 16-pixel block averages.
    pub rel_mse_16: f64,
    /// Mean CPU seconds.
    pub cpu_s: f64,
    /// Mean of the image's channel means (bias shows here).
    pub mean: [f64; 3],
    /// Seeds averaged.
    pub seeds: usize,
}

/// A method's error-versus-time curve, points in ascending budget.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    /// Method name.
    pub method: String,
    /// Points by ascending budget.
    pub points: Vec<Point>,
}

impl Curve {
    /// The wall time at which the curve reaches `rel_mse`, interpolated
    /// linearly in log time and log error between the two points that
    /// bracket it (the curves are close to straight lines in log–log);
    /// `None` if the curve never gets that low. The first point that is
    /// already below counts as reached at its own time.
    pub fn time_to_reach(&self, rel_mse: f64) -> Option<f64> {
        let mut prev: Option<&Point> = None;
        for p in &self.points {
            if p.rel_mse <= rel_mse {
                return Some(match prev {
                    None => p.wall_s,
                    Some(q) => {
                        let t = (rel_mse.ln() - q.rel_mse.ln()) / (p.rel_mse.ln() - q.rel_mse.ln());
                        (q.wall_s.ln() + t * (p.wall_s.ln() - q.wall_s.ln())).exp()
                    }
                });
            }
            prev = Some(p);
        }
        None
    }

    /// The curve's relMSE at wall time `t`, interpolated in log–log
    /// between the bracketing points (`None` outside the measured range).
    pub fn rel_mse_at(&self, t: f64) -> Option<f64> {
        self.points.windows(2).find_map(|w| {
            let (q, p) = (&w[0], &w[1]);
            (q.wall_s <= t && t <= p.wall_s).then(|| {
                let s = (t.ln() - q.wall_s.ln()) / (p.wall_s.ln() - q.wall_s.ln()).max(1e-12);
                (q.rel_mse.ln() + s * (p.rel_mse.ln() - q.rel_mse.ln())).exp()
            })
        })
    }
}

/// Groups rows into one curve per method (in first-appearance order),
/// averaging the seeds of each budget.
pub fn curves(rows: &[Row]) -> Vec<Curve> {
    let mut out: Vec<Curve> = Vec::new();
    for r in rows {
        let i = match out.iter().position(|c| c.method == r.method) {
            Some(i) => i,
            None => {
                out.push(Curve {
                    method: r.method.clone(),
                    points: Vec::new(),
                });
                out.len() - 1
            }
        };
        let budget = r.budget();
        let points = &mut out[i].points;
        // Running sums first; divided by the seed count below.
        match points.iter_mut().find(|p| p.budget == budget) {
            Some(p) => {
                p.wall_s += r.m.wall_s;
                p.rel_mse += r.m.rel_mse;
                p.rel_mse_4 += r.m.rel_mse_4;
                p.rel_mse_16 += r.m.rel_mse_16;
                p.cpu_s += r.m.cpu_s;
                for c in 0..3 {
                    p.mean[c] += r.m.mean[c];
                }
                p.seeds += 1;
            }
            None => points.push(Point {
                budget,
                wall_s: r.m.wall_s,
                rel_mse: r.m.rel_mse,
                rel_mse_4: r.m.rel_mse_4,
                rel_mse_16: r.m.rel_mse_16,
                cpu_s: r.m.cpu_s,
                mean: r.m.mean,
                seeds: 1,
            }),
        }
    }
    for c in &mut out {
        for p in &mut c.points {
            let n = p.seeds as f64;
            p.wall_s /= n;
            p.rel_mse /= n;
            p.rel_mse_4 /= n;
            p.rel_mse_16 /= n;
            p.cpu_s /= n;
            for m in &mut p.mean {
                *m /= n;
            }
        }
        c.points.sort_by(|a, b| a.budget.total_cmp(&b.budget));
    }
    out
}

/// A method of the study: an estimator's name with its defaults (`pt`,
/// `bdpt`, `mlt`, `cmlt`), or a Metropolis method with settings changed,
/// `cmlt:lanes=4:m=2:share=8:depth=3:k=1:passes=32:sigma=8` (any subset,
/// in any order; for mlt and cmlt `passes` the normalisation passes,
/// `level1` `primary` or `path`, `pass_records` the weight of the
/// passes' image, `perturb` the path-space level 1's weight of each
/// perturbation (0: off), `psigma` their σ in pixels and `pcaustic` the
/// caustic perturbation's angle scale (the CLI's
/// `--perturbation-caustic-scale`); the rest CMLT's level 2: `depth` the
/// side-chain minimum depth, `sigma` the lens σ in pixels) — how the
/// parameter study compares settings in one run. A setting the method
/// does not read is an error.
pub fn method_settings(spec: &str) -> Result<Estimator, String> {
    let mut parts = spec.split(':');
    let name = parts.next().unwrap_or_default();
    let kind = EstimatorKind::from_name(name)
        .ok_or_else(|| format!("unknown method '{name}' (expected pt, bdpt, mlt or cmlt)"))?;
    let mut estimator = Estimator::default_for(kind);
    for kv in parts {
        let (k, v) = kv
            .split_once('=')
            .ok_or_else(|| format!("'{spec}': '{kv}' is not key=value"))?;
        let int = || {
            v.parse::<u32>()
                .map_err(|e| format!("'{spec}': {k} '{v}': {e}"))
        };
        if let Some(mlt) = estimator.mlt_mut()
            && matches!(
                k,
                "passes" | "level1" | "pass_records" | "perturb" | "psigma" | "pcaustic"
            )
        {
            let float = || {
                v.parse::<f32>()
                    .map_err(|e| format!("'{spec}': {k} '{v}': {e}"))
            };
            match k {
                "passes" => mlt.b_passes = int()?,
                "perturb" => {
                    let w = float()?;
                    let pm = &mut mlt.path_mutations;
                    (pm.lens, pm.caustic, pm.multi_chain) = (w, w, w);
                }
                "psigma" => mlt.path_mutations.sigma = float()?,
                "pcaustic" => mlt.path_mutations.caustic_scale = float()?,
                "level1" => {
                    mlt.level1 = match v {
                        "primary" => Level1::PrimarySample,
                        "path" => Level1::PathSpace,
                        _ => return Err(format!("'{spec}': level1 is primary or path, not '{v}'")),
                    }
                }
                _ => {
                    mlt.pass_records = v
                        .parse::<f32>()
                        .map_err(|e| format!("'{spec}': pass_records '{v}': {e}"))?
                }
            }
            continue;
        }
        let Estimator::Cmlt(c) = &mut estimator else {
            return Err(format!("'{spec}': {k} is a cmlt setting"));
        };
        let l2 = &mut c.level2;
        match k {
            "lanes" => l2.lanes = int()?,
            "m" => l2.m = int()?,
            "share" => l2.share = int()?,
            "depth" => l2.side_chain_min_depth = int()?,
            "k" => l2.k = int()?,
            "sigma" => {
                l2.lens_sigma = v
                    .parse::<f32>()
                    .map_err(|e| format!("'{spec}': sigma '{v}': {e}"))?
            }
            _ => {
                return Err(format!(
                    "'{spec}': unknown setting '{k}' (lanes, m, share, depth, k, passes, sigma, level1, pass_records, perturb, psigma, pcaustic)"
                ));
            }
        }
    }
    estimator.validate().map_err(|e| format!("'{spec}': {e}"))?;
    Ok(estimator)
}

/// Runs the study, printing one line per render to `out`; returns the rows
/// in order (budget, seed, method). The methods take turns at each budget
/// and seed, so that a change in the machine's load during the run falls
/// on all of them alike (equal-time comparisons on a shared machine).
pub fn run(opts: &Options, out: &mut dyn Write) -> Result<Vec<Row>, String> {
    let estimators = opts
        .methods
        .iter()
        .map(|m| method_settings(m).map(|e| (m.clone(), e)))
        .collect::<Result<Vec<_>, _>>()?;
    if opts.budgets.iter().any(|b| !(b.is_finite() && *b > 0.0)) {
        return Err("budgets must be positive numbers".to_string());
    }
    let study = Study::load(&opts.scene, &opts.defines, &opts.reference)?;
    let (w, h) = study.resolution();
    let io = |e: std::io::Error| e.to_string();
    writeln!(
        out,
        "{} at {w}x{h} on {} threads; budgets {:?} {}",
        opts.scene,
        opts.threads,
        opts.budgets,
        if opts.samples { "samples/pixel" } else { "s" }
    )
    .map_err(io)?;
    let mut rows = Vec::new();
    for &b in &opts.budgets {
        let (budget, budget_s) = if opts.samples {
            (Budget::PerPixel(b.round().max(1.0) as u64), None)
        } else {
            (Budget::Seconds(b), Some(b))
        };
        let seeds = if b <= opts.seeds_up_to {
            opts.seeds.max(1)
        } else {
            1
        };
        for seed in 0..seeds {
            for (name, estimator) in &estimators {
                let m = study.measure(*estimator, budget, opts.threads, seed)?;
                writeln!(
                    out,
                    "{name:>5} budget {b:>6} seed {seed}: {:>8.2} s, {:>10.2} samples/px, relMSE {:.5} (4x4 {:.5}, 16x16 {:.5}), mean rgb ({:.4}, {:.4}, {:.4}), {:.2} Mrays/s, {:.2} CPU s",
                    m.wall_s, m.samples, m.rel_mse, m.rel_mse_4, m.rel_mse_16, m.mean[0], m.mean[1], m.mean[2], m.mrays_per_s, m.cpu_s
                )
                .map_err(io)?;
                rows.push(Row {
                    method: name.clone(),
                    budget_s,
                    seed,
                    m,
                });
            }
        }
    }
    Ok(rows)
}

/// Prints the curves as a table (mean relMSE and wall time per budget,
/// and each method's mean ratio to the reference's mean), and, with
/// `versus = Some((method, t))`, how long every other method takes to reach
/// the relMSE `method` reaches at `t` seconds, and that time's ratio to `t`.
pub fn summarize(
    curves: &[Curve],
    reference_mean: Option<[f64; 3]>,
    versus: Option<(&str, f64)>,
    out: &mut dyn Write,
) -> Result<(), String> {
    let io = |e: std::io::Error| e.to_string();
    for c in curves {
        write!(out, "{:<26}", c.method).map_err(io)?;
        for p in &c.points {
            write!(out, " {:>7.2}s:{:.5}", p.wall_s, p.rel_mse).map_err(io)?;
        }
        if let (Some(r), Some(last)) = (reference_mean, c.points.last()) {
            write!(
                out,
                "  (mean/ref {:.3} {:.3} {:.3} at the largest budget)",
                last.mean[0] / r[0],
                last.mean[1] / r[1],
                last.mean[2] / r[2]
            )
            .map_err(io)?;
        }
        writeln!(out).map_err(io)?;
    }
    if let Some((base, t)) = versus {
        let Some(b) = curves.iter().find(|c| c.method == base) else {
            return Err(format!("--versus: no method '{base}' in the data"));
        };
        let Some(target) = b.rel_mse_at(t) else {
            return Err(format!(
                "--versus: {base}'s curve does not span {t} s (wall times {:?})",
                b.points.iter().map(|p| p.wall_s).collect::<Vec<_>>()
            ));
        };
        writeln!(out, "relMSE of {base} at {t} s: {target:.5}").map_err(io)?;
        for c in curves.iter().filter(|c| c.method != base) {
            match c.time_to_reach(target) {
                Some(s) => writeln!(
                    out,
                    "  {:<26} reaches it in {s:>7.2} s = {:.2} × {t} s",
                    c.method,
                    s / t
                ),
                None => writeln!(
                    out,
                    "  {:<26} does not reach it within its largest budget",
                    c.method
                ),
            }
            .map_err(io)?;
        }
    }
    Ok(())
}

/// Prints, for every method other than `base`, the equal-budget ratio of
/// `base`'s mean relMSE to its own (above 1: lower error than `base` in
/// the same time, the speed-up when error ∝ 1/time), per budget, per pixel
/// and at 4 × 4 and 16 × 16-pixel blocks; then the same per-pixel ratio
/// per CPU second, (relMSE·CPU s of `base`) / (relMSE·CPU s), the speed-up
/// at equal work, which other jobs on the machine disturb much less than
/// the wall time (relMSE ∝ 1/work, as for any unbiased Monte Carlo
/// average past its start-up).
pub fn ratios(curves: &[Curve], base: &str, out: &mut dyn Write) -> Result<(), String> {
    let io = |e: std::io::Error| e.to_string();
    let Some(b) = curves.iter().find(|c| c.method == base) else {
        return Err(format!("no method '{base}' in the data"));
    };
    writeln!(
        out,
        "relMSE ratio {base} / method at equal budget (pixels, 4x4 blocks, 16x16 blocks; per CPU s; seeds):"
    )
    .map_err(io)?;
    for c in curves.iter().filter(|c| c.method != base) {
        for p in &c.points {
            let Some(q) = b.points.iter().find(|q| q.budget == p.budget) else {
                continue;
            };
            writeln!(
                out,
                "  {:<40} budget {:>6}: {:.3}  {:.3}  {:.3}  {:.3}  ({} seeds)",
                c.method,
                p.budget,
                q.rel_mse / p.rel_mse,
                q.rel_mse_4 / p.rel_mse_4,
                q.rel_mse_16 / p.rel_mse_16,
                (q.rel_mse * q.cpu_s) / (p.rel_mse * p.cpu_s),
                p.seeds.min(q.seeds)
            )
            .map_err(io)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(method: &str, budget: f64, seed: u64, wall_s: f64, rel_mse: f64) -> Row {
        Row {
            method: method.to_string(),
            budget_s: Some(budget),
            seed,
            m: Measurement {
                wall_s,
                samples: 1.0,
                rel_mse,
                rel_mse_4: rel_mse / 4.0,
                rel_mse_16: rel_mse / 16.0,
                cpu_s: wall_s * 2.0,
                rmse: 0.1,
                mean: [0.5; 3],
                mrays_per_s: 1.0,
            },
        }
    }

    #[test]
    fn method_settings_change_only_what_they_name() {
        use cmlt::mlt::{CmltSettings, Level2Settings, MltSettings};
        for kind in EstimatorKind::ALL {
            assert_eq!(
                method_settings(kind.name()).unwrap(),
                Estimator::default_for(kind)
            );
        }
        let s = method_settings("cmlt:lanes=4:share=8:depth=3:sigma=2.5:passes=7").unwrap();
        let d = CmltSettings::default();
        assert_eq!(
            s,
            Estimator::Cmlt(CmltSettings {
                mlt: MltSettings {
                    b_passes: 7,
                    ..d.mlt
                },
                level2: Level2Settings {
                    lanes: 4,
                    share: 8,
                    side_chain_min_depth: 3,
                    lens_sigma: 2.5,
                    ..d.level2
                },
            })
        );
        assert_eq!(
            method_settings("mlt:passes=2")
                .unwrap()
                .mlt()
                .unwrap()
                .b_passes,
            2
        );
        for bad in [
            "cmlt:lanes",
            "cmlt:x=1",
            "bdpt:m=1",
            "pt:passes=2",
            "mlt:m=1",
            "cmlt:k=0",
            "cmlt:m=0",
            "foo",
        ] {
            assert!(method_settings(bad).is_err(), "{bad} was accepted");
        }
    }

    /// The path-space level 1's keys set the fields they name and no
    /// other (the defaults' values differ from the ones set here, so a key
    /// that set nothing or the wrong field would fail), and out-of-range
    /// values are refused by the settings' own validation.
    #[test]
    fn path_space_keys_set_their_fields() {
        use cmlt::mlt::{Level1, MltSettings, PathMutations};
        let e = method_settings("mlt:level1=path:perturb=0.5:psigma=3:pcaustic=2.5").unwrap();
        let d = MltSettings::default();
        assert_eq!(
            e,
            Estimator::Mlt(MltSettings {
                level1: Level1::PathSpace,
                path_mutations: PathMutations {
                    lens: 0.5,
                    caustic: 0.5,
                    multi_chain: 0.5,
                    sigma: 3.0,
                    caustic_scale: 2.5,
                    ..d.path_mutations
                },
                ..d
            })
        );
        let c = method_settings("cmlt:level1=path:pcaustic=4").unwrap();
        assert_eq!(c.mlt().unwrap().path_mutations.caustic_scale, 4.0);
        assert_eq!(
            method_settings("mlt:level1=primary").unwrap(),
            Estimator::Mlt(d)
        );
        for bad in [
            "mlt:level1=veach",
            "mlt:pcaustic=0",
            "mlt:pcaustic=-1",
            "mlt:pcaustic=inf",
            "mlt:pcaustic=x",
            "bdpt:pcaustic=2",
            "mlt:psigma=0",
        ] {
            assert!(method_settings(bad).is_err(), "{bad} was accepted");
        }
    }

    #[test]
    fn ratios_divide_the_base_by_each_method() {
        let rows = [
            row("base", 1.0, 0, 1.0, 0.4),
            row("base", 1.0, 1, 1.0, 0.2),
            row("x", 1.0, 0, 1.0, 0.1),
            row("x", 1.0, 1, 1.0, 0.1),
        ];
        let mut out = Vec::new();
        ratios(&curves(&rows), "base", &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        // Means 0.3 and 0.1: a ratio of 3 at every scale.
        assert!(
            text.contains("3.000  3.000  3.000  3.000  (2 seeds)"),
            "{text}"
        );
        assert!(ratios(&curves(&rows), "nobody", &mut Vec::new()).is_err());
    }

    #[test]
    fn curves_average_seeds_and_sort_budgets() {
        let rows = [
            row("a", 2.0, 0, 2.0, 0.5),
            row("a", 1.0, 0, 1.0, 1.0),
            row("a", 1.0, 1, 3.0, 3.0),
            row("b", 1.0, 0, 1.0, 0.1),
        ];
        let c = curves(&rows);
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].method, "a");
        assert_eq!(c[0].points.len(), 2);
        let p = c[0].points[0];
        assert_eq!((p.budget, p.wall_s, p.rel_mse, p.seeds), (1.0, 2.0, 2.0, 2));
        assert_eq!(c[0].points[1].budget, 2.0);
    }

    #[test]
    fn time_to_reach_interpolates_in_log_log() {
        // relMSE = 1/t: a straight line of slope −1 in log–log.
        let rows: Vec<Row> = [1.0, 4.0, 16.0]
            .iter()
            .map(|&t| row("pt", t, 0, t, 1.0 / t))
            .collect();
        let c = &curves(&rows)[0];
        let t = c.time_to_reach(0.125).unwrap();
        assert!((t - 8.0).abs() < 1e-9, "{t}");
        assert_eq!(c.time_to_reach(2.0), Some(1.0));
        assert_eq!(c.time_to_reach(0.01), None);
        let e = c.rel_mse_at(2.0).unwrap();
        assert!((e - 0.5).abs() < 1e-9, "{e}");
        assert_eq!(c.rel_mse_at(32.0), None);
    }

    #[test]
    fn csv_rows_round_trip() {
        let mut r = row("luxcore-metropolis-path", 8.0, 3, 8.25, 0.0123);
        r.m.samples = 123.5;
        let back = Row::from_csv(&r.to_csv()).unwrap();
        assert_eq!(back.method, r.method);
        assert_eq!(back.budget_s, Some(8.0));
        assert_eq!(back.seed, 3);
        assert_eq!(back.m.samples, 123.5);
        assert!((back.m.rel_mse - 0.0123).abs() < 1e-9);
        assert!((back.m.rel_mse_16 - 0.0123 / 16.0).abs() < 1e-9);
        assert_eq!(back.m.cpu_s, 16.5);
        r.budget_s = None;
        assert_eq!(Row::from_csv(&r.to_csv()).unwrap().budget_s, None);
        // A row of the 11 columns before the block errors still reads.
        let old = "mlt,8,8.1,0,12.5,1.0e-2,1.0e-1,0.5,0.5,0.5,2.0";
        let back = Row::from_csv(old).unwrap();
        assert_eq!(back.m.rel_mse, 1.0e-2);
        assert!(back.m.rel_mse_4.is_nan() && back.m.cpu_s.is_nan());
    }
}

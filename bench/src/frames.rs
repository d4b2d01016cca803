//! `cmlt-bench frames`: a game engine's frame loop as a benchmark. The host
//! is `examples-c/frame_trial.cpp` (C++17 over `include/cmlt.hpp`, the C
//! API): a ~5k-triangle room from its own arrays, a dolly camera, one mesh
//! moved by `cmlt_scene_update_mesh` every frame, two workers on its own
//! threads, each frame bounded by `cmlt_renderer_render_while` and the
//! host's clock. This module builds it (`make -C examples-c frame_trial`,
//! the release staticlib), runs it once per estimator × size × budget and
//! prints its figures against the targets a game's frame loop needs:
//!
//! - p95 frame time ≤ budget + 10 %;
//! - set-up after the first frame ≤ 10 % of the budget;
//! - black-pixel fraction of MLT/CMLT ≤ BDPT's at the same size, budget
//!   and accumulation (`+keep`, `+decay` suffixes);
//! - mean-luminance flicker (rms of the relative frame-to-frame change of
//!   the mean) ≤ 2 %, with the moving camera;
//! - allocations per frame: 0.
//!
//! Beside the frame times it prints each frame's work as thread CPU time
//! (the busier worker's, plus the resolve's), and for the frames over
//! budget + 10 % their mean time off the CPU: on a loaded machine a late
//! frame whose CPU time is on budget was held back by the scheduler, one
//! whose CPU time is late did too much work.

use std::path::{Path, PathBuf};
use std::process::Command;

/// One run of the host.
#[derive(Clone, Debug, PartialEq)]
pub struct Trial {
    /// `pt`, `bdpt`, `mlt` or `cmlt`, with `+keep` or `+decay` for the
    /// accumulation (reset without).
    pub estimator: String,
    /// Image size.
    pub width: u32,
    /// Image size.
    pub height: u32,
    /// The frame budget, milliseconds.
    pub budget_ms: f64,
    /// Frames rendered.
    pub frames: u32,
    /// Median frame time, milliseconds.
    pub p50_ms: f64,
    /// 95th percentile of the frame time, milliseconds.
    pub p95_ms: f64,
    /// Mean set-up time of the frames after the first, milliseconds.
    pub setup_ms: f64,
    /// Median set-up time of the frames after the first, milliseconds
    /// (the mean is the target's; a frame whose thread the scheduler held
    /// back weighs on it).
    pub setup_p50_ms: f64,
    /// Mean fraction of exactly black pixels.
    pub black: f64,
    /// Rms relative frame-to-frame change of the mean luminance.
    pub flicker: f64,
    /// cmlt's allocations per frame.
    pub allocs_per_frame: f64,
    /// Median of a frame's work in thread CPU time, milliseconds (the
    /// busier worker's set-up and render, plus the resolve).
    pub cpu_p50_ms: f64,
    /// 95th percentile of a frame's work in thread CPU time,
    /// milliseconds.
    pub cpu_p95_ms: f64,
    /// Frames after the first longer than the budget + 10 %.
    pub over: u32,
    /// Their mean wall time not spent on the CPU (frame time minus its
    /// work), milliseconds.
    pub over_lost_ms: f64,
    /// Mean thread CPU time of the set-up after the first frame (the
    /// busier worker's slice and the join), milliseconds: the set-up's
    /// work, against `setup_ms`, its wall time.
    pub setup_cpu_ms: f64,
}

impl Trial {
    /// Parses the host's `trial …` line (see `frame_trial.cpp`).
    pub fn parse(line: &str) -> Option<Trial> {
        let w: Vec<&str> = line.split_whitespace().collect();
        if w.first() != Some(&"trial") {
            return None;
        }
        let (width, height) = w.get(2)?.split_once('x')?;
        let value = |key: &str| -> Option<f64> {
            let i = w.iter().position(|&x| x == key)?;
            w.get(i + 1)?.parse().ok()
        };
        Some(Trial {
            estimator: w.get(1)?.to_string(),
            width: width.parse().ok()?,
            height: height.parse().ok()?,
            budget_ms: value("budget_ms")?,
            frames: value("frames")? as u32,
            p50_ms: value("p50_ms")?,
            p95_ms: value("p95_ms")?,
            setup_ms: value("setup_ms")?,
            setup_p50_ms: value("setup_p50_ms")?,
            black: value("black")?,
            flicker: value("flicker")?,
            allocs_per_frame: value("allocs_per_frame")?,
            cpu_p50_ms: value("cpu_p50_ms")?,
            cpu_p95_ms: value("cpu_p95_ms")?,
            over: value("over")? as u32,
            over_lost_ms: value("over_lost_ms")?,
            setup_cpu_ms: value("setup_cpu_ms")?,
        })
    }

    /// Whether the p95 frame time is within the budget + 10 %.
    pub fn budget_held(&self) -> bool {
        self.p95_ms <= 1.1 * self.budget_ms
    }

    /// Whether the set-up after the first frame is within 10 % of the
    /// budget.
    pub fn setup_held(&self) -> bool {
        self.setup_ms <= 0.1 * self.budget_ms
    }
}

/// Builds the host with the examples' Makefile (the release staticlib
/// first); returns its path.
pub fn build_host(workspace: &Path) -> Result<PathBuf, String> {
    let dir = workspace.join("examples-c");
    let status = Command::new("make")
        .arg("-C")
        .arg(&dir)
        .arg("frame_trial")
        .status()
        .map_err(|e| format!("make: {e}"))?;
    if !status.success() {
        return Err(format!("make -C {} frame_trial failed", dir.display()));
    }
    Ok(dir.join("frame_trial"))
}

/// Runs the host once; its per-frame lines go to stderr when `verbose`.
pub fn run(
    host: &Path,
    estimator: &str,
    (width, height): (u32, u32),
    budget_ms: f64,
    frames: u32,
    verbose: bool,
) -> Result<Trial, String> {
    let o = Command::new(host)
        .args([
            estimator,
            &width.to_string(),
            &height.to_string(),
            &budget_ms.to_string(),
            &frames.to_string(),
        ])
        .output()
        .map_err(|e| format!("{}: {e}", host.display()))?;
    let out = String::from_utf8_lossy(&o.stdout);
    if !o.status.success() {
        return Err(format!(
            "{} {estimator} failed: {}{}",
            host.display(),
            out,
            String::from_utf8_lossy(&o.stderr)
        ));
    }
    if verbose {
        eprint!("{out}");
    }
    out.lines()
        .find_map(Trial::parse)
        .ok_or_else(|| format!("no trial line in:\n{out}"))
}

/// `estimator`'s method and accumulation suffix: `mlt+decay` → (`mlt`,
/// `+decay`).
fn split_accumulation(estimator: &str) -> (&str, &str) {
    estimator.split_at(estimator.find('+').unwrap_or(estimator.len()))
}

/// The table of `trials`, each row against the targets ("ok"/"MISS"); the
/// black fraction of MLT/CMLT is compared with BDPT's of the same size,
/// budget and accumulation when there is one.
pub fn table(trials: &[Trial]) -> String {
    let mut s = String::from(
        "estimator    size     budget  p50 ms  p95 ms  p95/budget  cpu p50  cpu p95  over  lost ms  setup ms  setup/budget  setup p50  setup cpu  black    black/bdpt  flicker  allocs/frame\n",
    );
    let mark = |ok: bool| if ok { "ok " } else { "MISS" };
    for t in trials {
        let (method, accumulation) = split_accumulation(&t.estimator);
        let bdpt = trials.iter().find(|b| {
            split_accumulation(&b.estimator) == ("bdpt", accumulation)
                && (b.width, b.height) == (t.width, t.height)
                && b.budget_ms == t.budget_ms
        });
        let vs_bdpt = match bdpt {
            Some(b) if method == "mlt" || method == "cmlt" => format!(
                "{:>6.2} {}",
                t.black / b.black.max(1e-6),
                mark(t.black <= b.black)
            ),
            _ => format!("{:>11}", "-"),
        };
        s += &format!(
            "{:<12} {:>4}x{:<4} {:>5.0}  {:>6.1}  {:>6.1}  {:>6.2} {}  {:>7.1}  {:>7.1}  {:>4}  {:>7.1}  {:>8.2}  {:>8.3} {}  {:>9.2}  {:>9.2}  {:>7.4}  {}  {:>6.4} {}  {:>6.2} {}\n",
            t.estimator,
            t.width,
            t.height,
            t.budget_ms,
            t.p50_ms,
            t.p95_ms,
            t.p95_ms / t.budget_ms,
            mark(t.budget_held()),
            t.cpu_p50_ms,
            t.cpu_p95_ms,
            t.over,
            t.over_lost_ms,
            t.setup_ms,
            t.setup_ms / t.budget_ms,
            mark(t.setup_held()),
            t.setup_p50_ms,
            t.setup_cpu_ms,
            t.black,
            vs_bdpt,
            t.flicker,
            mark(t.flicker <= 0.02),
            t.allocs_per_frame,
            mark(t.allocs_per_frame == 0.0),
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_trial_line_parses() {
        let t = Trial::parse(
            "trial bdpt 320x180 triangles 5250 budget_ms 30.0 frames 8 p50_ms 31.5 p95_ms 32.0 \
             setup_ms 0.10 setup_p50_ms 0.08 black 0.0001 flicker 0.0075 allocs_per_frame 0.00 \
             cpu_p50_ms 29.0 cpu_p95_ms 29.5 over 1 over_lost_ms 4.50 setup_cpu_ms 0.05",
        )
        .unwrap();
        assert_eq!((t.width, t.height, t.frames), (320, 180, 8));
        assert_eq!(t.estimator, "bdpt");
        assert!(t.budget_held() && t.setup_held());
        assert_eq!(t.p95_ms, 32.0);
        assert_eq!((t.cpu_p95_ms, t.over, t.over_lost_ms), (29.5, 1, 4.5));
        assert!(Trial::parse("frame 0 ms 3").is_none());
        let late = Trial { p95_ms: 33.1, ..t };
        assert!(!late.budget_held());
    }

    #[test]
    fn metropolis_black_pixels_are_compared_with_bdpt_of_the_same_accumulation() {
        let t = |estimator: &str, black: f64| Trial {
            estimator: estimator.into(),
            width: 8,
            height: 8,
            budget_ms: 30.0,
            frames: 2,
            p50_ms: 30.0,
            p95_ms: 30.0,
            setup_ms: 0.0,
            setup_p50_ms: 0.0,
            black,
            flicker: 0.0,
            allocs_per_frame: 0.0,
            cpu_p50_ms: 30.0,
            cpu_p95_ms: 30.0,
            over: 0,
            over_lost_ms: 0.0,
            setup_cpu_ms: 0.0,
        };
        let s = table(&[t("bdpt", 0.9), t("bdpt+decay", 0.1), t("mlt+decay", 0.2)]);
        let row = s.lines().find(|l| l.starts_with("mlt+decay")).unwrap();
        assert!(row.contains("  2.00 MISS"), "{row}");
    }
}

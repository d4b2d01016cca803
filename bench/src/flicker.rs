//! `cmlt-bench flicker`: what the frame-to-frame switches
//! ([`cmlt::renderer::Temporal`]) do to flicker, at equal per-frame budget.
//!
//! Static camera: F frames of the same view, each a fresh accumulation of
//! the same budget. Two figures per configuration:
//! - **mean flicker**: the standard deviation of the frames' mean
//!   luminance over frames, relative to its average — the global
//!   brightening and darkening that a noisy normalisation b causes;
//! - **pixel noise**: the temporal standard deviation of each pixel's
//!   luminance over frames, averaged over pixels, relative to the image's
//!   mean luminance — the per-pixel shimmer.
//!
//! Each configuration is run in the same process; ratios are against the
//! configuration with every switch off.
//!
//! Moving camera: frames of an orbit with every switch on, each frame's
//! mean luminance against a BDPT render of that camera with many samples
//! (the reference).

use std::io::Write;

use cmlt::renderer::{Accumulation, Estimator, PixelBlock, RendererConfig, Temporal};
use cmlt::scene::{Camera, Scene};
use cmlt_cli::accel::Accel;

use cmlt_cli::frames::{self, FrameResult};

/// One configuration's figures.
#[derive(Clone, Debug)]
pub struct Flicker {
    /// Name of the switch set.
    pub name: &'static str,
    /// The switches.
    pub temporal: Temporal,
    /// Relative standard deviation of the frame means.
    pub mean_flicker: f64,
    /// Mean temporal standard deviation per pixel, relative to the mean.
    pub pixel_noise: f64,
    /// Seconds per frame.
    pub seconds_per_frame: f64,
}

/// The switch sets measured: none, each alone, all.
pub fn configurations(b_window: u32) -> Vec<(&'static str, Temporal)> {
    let none = Temporal::default();
    vec![
        ("none", none),
        (
            "keep-chains",
            Temporal {
                keep_chains: true,
                ..none
            },
        ),
        ("b-window", Temporal { b_window, ..none }),
        (
            "fixed-sequence",
            Temporal {
                fixed_sequence: true,
                ..none
            },
        ),
        (
            "all",
            Temporal {
                keep_chains: true,
                b_window,
                fixed_sequence: true,
                ..none
            },
        ),
    ]
}

/// Luminance of each pixel of a frame.
fn luminance(f: &FrameResult) -> Vec<f64> {
    f.image
        .pixels
        .iter()
        .map(|c| c.luminance() as f64)
        .collect()
}

/// Runs `frames` static frames of `cfg` and measures its flicker.
pub fn measure(
    scene: &Scene,
    accel: &Accel,
    cfg: RendererConfig,
    frames: usize,
    per_pixel: u64,
    name: &'static str,
) -> Result<Flicker, String> {
    let mut lum: Vec<Vec<f64>> = Vec::with_capacity(frames);
    let mut seconds = 0.0;
    let camera = scene.camera;
    frames::render_frames(
        scene,
        accel,
        cfg,
        frames,
        per_pixel,
        Accumulation::Reset,
        PixelBlock::Fixed(1),
        |_| camera,
        |_, r| {
            seconds += r.seconds;
            lum.push(luminance(&r));
            Ok(())
        },
    )?;
    let means: Vec<f64> = lum
        .iter()
        .map(|l| l.iter().sum::<f64>() / l.len() as f64)
        .collect();
    let avg = means.iter().sum::<f64>() / means.len() as f64;
    let n = frames as f64;
    let mean_sd = (means.iter().map(|m| (m - avg).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let pixels = lum[0].len();
    let mut pixel_sd = 0.0;
    for p in 0..pixels {
        let mu = lum.iter().map(|l| l[p]).sum::<f64>() / n;
        pixel_sd += (lum.iter().map(|l| (l[p] - mu).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    }
    Ok(Flicker {
        name,
        temporal: cfg.temporal,
        mean_flicker: if avg > 0.0 { mean_sd / avg } else { 0.0 },
        pixel_noise: if avg > 0.0 {
            pixel_sd / pixels as f64 / avg
        } else {
            0.0
        },
        seconds_per_frame: seconds / n,
    })
}

/// Runs every configuration and prints the table with ratios to "none".
pub fn run_static(
    scene: &Scene,
    accel: &Accel,
    base: RendererConfig,
    frames: usize,
    per_pixel: u64,
    b_window: u32,
    out: &mut impl Write,
) -> Result<Vec<Flicker>, String> {
    if frames < 2 {
        return Err("flicker needs at least 2 frames".into());
    }
    let mut rows = Vec::new();
    for (name, temporal) in configurations(b_window) {
        let cfg = RendererConfig { temporal, ..base };
        let row = measure(scene, accel, cfg, frames, per_pixel, name)?;
        rows.push(row);
    }
    let base_row = rows[0].clone();
    // "identical" when a configuration's frames do not vary at all.
    let ratio = |a: f64, b: f64| {
        if b > 0.0 {
            format!("{:.2}", a / b)
        } else {
            "identical".to_string()
        }
    };
    writeln!(
        out,
        "{:<16} {:>12} {:>10} {:>12} {:>10} {:>9}",
        "switches", "mean flicker", "vs none", "pixel noise", "vs none", "s/frame"
    )
    .map_err(|e| e.to_string())?;
    for r in &rows {
        writeln!(
            out,
            "{:<16} {:>12.5} {:>10} {:>12.5} {:>10} {:>9.3}",
            r.name,
            r.mean_flicker,
            ratio(base_row.mean_flicker, r.mean_flicker),
            r.pixel_noise,
            ratio(base_row.pixel_noise, r.pixel_noise),
            r.seconds_per_frame
        )
        .map_err(|e| e.to_string())?;
    }
    writeln!(
        out,
        "(\"vs none\": how many times lower than with every switch off)"
    )
    .map_err(|e| e.to_string())?;
    Ok(rows)
}

/// Moving camera: `frames` orbit frames of `cfg`; for each, the relative
/// difference of its mean luminance from a BDPT render of that camera with
/// `reference_spp` samples per pixel. Prints one line per frame; returns
/// the differences.
#[allow(clippy::too_many_arguments)]
pub fn run_moving(
    scene: &Scene,
    accel: &Accel,
    cfg: RendererConfig,
    frames: usize,
    per_pixel: u64,
    orbit_degrees: f32,
    reference_spp: u64,
    out: &mut impl Write,
) -> Result<Vec<f64>, String> {
    let start = scene.camera;
    let pivot = frames::look_at_point(&start, accel);
    let camera_at = |f: usize| frames::orbit_camera(&start, pivot, orbit_degrees, f, frames);
    let mut means = Vec::new();
    frames::render_frames(
        scene,
        accel,
        cfg,
        frames,
        per_pixel,
        Accumulation::Reset,
        PixelBlock::Fixed(1),
        camera_at,
        |_, r| {
            means.push(r.image.mean().luminance() as f64);
            Ok(())
        },
    )?;
    let mut diffs = Vec::new();
    for (f, m) in means.iter().enumerate() {
        let reference = reference_mean(scene, accel, &cfg, camera_at(f), reference_spp)?;
        let d = m / reference - 1.0;
        writeln!(
            out,
            "frame {f:>3}: mean {m:.5}, reference {reference:.5}, difference {:+.2}%",
            100.0 * d
        )
        .map_err(|e| e.to_string())?;
        diffs.push(d);
    }
    Ok(diffs)
}

/// Mean luminance of a BDPT render of `camera` with `per_pixel` samples
/// per pixel.
fn reference_mean(
    scene: &Scene,
    accel: &Accel,
    cfg: &RendererConfig,
    camera: Camera,
    per_pixel: u64,
) -> Result<f64, String> {
    let cfg = RendererConfig {
        estimator: Estimator::Bdpt,
        temporal: Temporal::default(),
        ..*cfg
    };
    let mut mean = 0.0;
    frames::render_frames(
        scene,
        accel,
        cfg,
        1,
        per_pixel,
        Accumulation::Reset,
        PixelBlock::Fixed(1),
        |_| camera,
        |_, r| {
            mean = r.image.mean().luminance() as f64;
            Ok(())
        },
    )?;
    Ok(mean)
}

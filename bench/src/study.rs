//! What the accuracy benchmarks share: a scene loaded once with its
//! reference, and one measured render of it (error against the reference,
//! and what the render cost).
//!
//! Renders go through the CLI's driver ([`cmlt_cli::render::render`], over the
//! core's renderer) and are scored with [`cmlt_cli::metrics`], exactly as
//! `cmlt render --reference` does.

use std::path::Path;
use std::time::Instant;

use cmlt::renderer::{Estimator, RendererConfig};

use cmlt_cli::accel::{Accel, AccelKind};
use cmlt_cli::image_io::Image;
use cmlt_cli::load_scene_or_builtin;
use cmlt_cli::metrics;
use cmlt_cli::mitsuba::LoadedScene;
use cmlt_cli::render::{Budget, render};

/// One measured render.
#[derive(Clone, Debug, PartialEq)]
pub struct Measurement {
    /// Wall-clock seconds of the render (bootstrap included, scene loading
    /// and BVH build excluded).
    pub wall_s: f64,
    /// CPU seconds the process spent during the render, all threads
    /// ([`process_cpu_s`]; NaN where it cannot be read): the work done,
    /// which other jobs on a shared machine change much less than the
    /// wall time.
    pub cpu_s: f64,
    /// Samples per pixel (PT, BDPT) or mutations per pixel (MLT, CMLT),
    /// over all threads.
    pub samples: f64,
    /// Relative MSE against the reference ([`metrics::rel_mse`]).
    pub rel_mse: f64,
    /// Relative MSE of the 4 × 4-pixel block averages ([`block_rel_mse`]):
    /// the error at the scale of a few pixels, where level 2's side chains
    /// act.
    pub rel_mse_4: f64,
    /// Relative MSE of the 16 × 16-pixel block averages.
    pub rel_mse_16: f64,
    /// RMSE against the reference.
    pub rmse: f64,
    /// Mean of each channel of the image.
    pub mean: [f64; 3],
    /// Millions of rays per second over the whole render.
    pub mrays_per_s: f64,
}

/// A scene, its intersector and its reference, loaded once for many renders.
pub struct Study {
    /// The scene as loaded (with the `-D` overrides).
    pub loaded: LoadedScene,
    accel: Accel,
    /// The reference at the scene's resolution (box-filtered down).
    pub reference: Image,
}

impl Study {
    /// Loads `scene` (see [`load_scene_or_builtin`]) with `defines`, builds
    /// our BVH over it and reads `reference`, downsampled to the scene's
    /// resolution when that divides the reference's.
    pub fn load(
        scene: &str,
        defines: &[(String, String)],
        reference: &Path,
    ) -> Result<Study, String> {
        let loaded = load_scene_or_builtin(scene, defines)?;
        let tris: Vec<_> = loaded.scene.triangles().collect();
        let accel = Accel::build(AccelKind::Ours, &tris)?;
        let cam = &loaded.scene.camera;
        let reference =
            metrics::load_reference(reference, cam.width() as usize, cam.height() as usize)?;
        Ok(Study {
            loaded,
            accel,
            reference,
        })
    }

    /// The intersector over the scene (our BVH).
    pub fn accel(&self) -> &Accel {
        &self.accel
    }

    /// Width × height of the renders.
    pub fn resolution(&self) -> (usize, usize) {
        let cam = &self.loaded.scene.camera;
        (cam.width() as usize, cam.height() as usize)
    }

    /// Renders with `estimator` (and its settings) under `budget` on
    /// `threads` threads from `seed`, and scores the image against the
    /// reference.
    pub fn measure(
        &self,
        estimator: Estimator,
        budget: Budget,
        threads: usize,
        seed: u64,
    ) -> Result<Measurement, String> {
        let config = RendererConfig {
            estimator,
            settings: self.loaded.settings,
            seed,
            workers: threads as u32,
            ..RendererConfig::default()
        };
        let cpu0 = process_cpu_s();
        let start = Instant::now();
        let out = render(&self.loaded.scene, &self.accel, config, budget, &|_| {})?;
        let wall_s = start.elapsed().as_secs_f64();
        let mut m = score(
            &out.image,
            &self.reference,
            wall_s,
            out.per_pixel(),
            out.mrays_per_sec(),
        );
        m.cpu_s = process_cpu_s() - cpu0;
        Ok(m)
    }
}

/// CPU seconds (user and system) this process has used, its finished
/// threads included: fields 14 and 15 of `/proc/self/stat`, in clock ticks
/// of 1/100 s (Linux's USER_HZ). NaN where that file is missing.
pub fn process_cpu_s() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    // The command name (field 2) may hold spaces; the fields after its
    // closing parenthesis start at field 3.
    let Some((_, rest)) = stat.rsplit_once(')') else {
        return f64::NAN;
    };
    let f: Vec<&str> = rest.split_whitespace().collect();
    match (
        f.get(11).map(|v| v.parse::<f64>()),
        f.get(12).map(|v| v.parse::<f64>()),
    ) {
        (Some(Ok(u)), Some(Ok(s))) => (u + s) / 100.0,
        _ => f64::NAN,
    }
}

/// Relative MSE ([`metrics::rel_mse`]) between the `n × n`-pixel block
/// averages of `img` and `reference` (the box-filtered images at 1/n the
/// resolution; a partial block at the right or bottom edge is left out).
/// NaN when the image is smaller than one block.
pub fn block_rel_mse(img: &Image, reference: &Image, n: usize) -> f64 {
    if img.width < n || img.height < n {
        return f64::NAN;
    }
    metrics::rel_mse(&img.downsample(n), &reference.downsample(n))
}

/// Scores `img` against `reference` (same size) into a [`Measurement`] with
/// the given cost figures.
pub fn score(
    img: &Image,
    reference: &Image,
    wall_s: f64,
    samples: f64,
    mrays_per_s: f64,
) -> Measurement {
    let mean = img.mean();
    Measurement {
        wall_s,
        cpu_s: f64::NAN,
        samples,
        rel_mse: metrics::rel_mse(img, reference),
        rel_mse_4: block_rel_mse(img, reference, 4),
        rel_mse_16: block_rel_mse(img, reference, 16),
        rmse: metrics::rmse(img, reference),
        mean: [mean.r as f64, mean.g as f64, mean.b as f64],
        mrays_per_s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cmlt::math::Rgb;

    fn image(w: usize, h: usize, f: impl Fn(usize, usize) -> f32) -> Image {
        Image {
            width: w,
            height: h,
            pixels: (0..w * h).map(|i| Rgb::splat(f(i % w, i / w))).collect(),
        }
    }

    #[test]
    fn block_error_sees_low_frequencies_only() {
        let reference = image(32, 20, |_, _| 1.0);
        // A checkerboard of ±0.5: large per-pixel error that cancels in
        // every even block.
        let checker = image(32, 20, |x, y| if (x + y) % 2 == 0 { 1.5 } else { 0.5 });
        assert!(metrics::rel_mse(&checker, &reference) > 0.2);
        assert!(block_rel_mse(&checker, &reference, 4) < 1e-12);
        // A uniform offset of 0.5 is the same error at every scale; the
        // partial bottom row of 16-blocks (20 = 16 + 4) is left out.
        let offset = image(32, 20, |_, _| 1.5);
        let e = metrics::rel_mse(&offset, &reference);
        for n in [4, 16] {
            assert!((block_rel_mse(&offset, &reference, n) - e).abs() < 1e-9);
        }
        assert!(block_rel_mse(&offset, &reference, 64).is_nan());
    }

    #[test]
    fn process_cpu_time_counts_work() {
        let t0 = process_cpu_s();
        let start = Instant::now();
        let mut x = 0u64;
        while start.elapsed().as_secs_f64() < 0.3 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
        let dt = process_cpu_s() - t0;
        // Busy for 0.3 s of wall time: some CPU time (10 ms ticks) must
        // show, however loaded the machine.
        assert!(dt > 0.0 && dt.is_finite(), "{dt}");
    }
}

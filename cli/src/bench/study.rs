//! What the accuracy benchmarks share: a scene loaded once with its
//! reference, and one measured render of it (error against the reference,
//! and what the render cost).
//!
//! Renders go through the CLI's drivers ([`crate::render::render`],
//! [`crate::render::render_mlt`]) and are scored with [`crate::metrics`],
//! exactly as `cmlt render --reference` does.

use std::path::Path;
use std::time::Instant;

use cmlt::integrator::Method;
use cmlt::mlt::MltSettings;

use crate::accel::{Accel, AccelKind};
use crate::image_io::Image;
use crate::metrics;
use crate::render::{Budget, MltBudget, render, render_mlt};
use crate::scene::{LoadedScene, builtin_scene, load_scene};

/// Loads `name`: a built-in scene name (`cornell-box`) unless a file of
/// that name exists, else a Mitsuba 3 XML file; `defines` override the
/// scene's `<default>`s (`-D resx=64`).
pub fn load_scene_or_builtin(
    name: &str,
    defines: &[(String, String)],
) -> Result<LoadedScene, String> {
    match builtin_scene(name, defines) {
        Some(r) if !Path::new(name).exists() => r.map_err(|e| e.to_string()),
        _ => load_scene(Path::new(name), defines).map_err(|e| e.to_string()),
    }
}

/// An estimator with its settings, as the benchmarks name it.
#[derive(Clone, Debug, PartialEq)]
pub enum Estimator {
    /// Path tracing or BDPT: one sample per pixel per pass.
    Passes(Method),
    /// MLT (m = 0) or CMLT (m > 0).
    Metropolis(MltSettings),
}

impl Estimator {
    /// The estimator of a method name: `pt`, `bdpt`, `mlt`
    /// ([`MltSettings::default`]) or `cmlt` ([`MltSettings::cmlt`]).
    pub fn from_name(name: &str) -> Result<Estimator, String> {
        match name {
            "pt" => Ok(Estimator::Passes(Method::Path)),
            "bdpt" => Ok(Estimator::Passes(Method::Bdpt)),
            "mlt" => Ok(Estimator::Metropolis(MltSettings::default())),
            "cmlt" => Ok(Estimator::Metropolis(MltSettings::cmlt())),
            _ => Err(format!(
                "unknown method '{name}' (expected pt, bdpt, mlt or cmlt)"
            )),
        }
    }
}

/// How much work one render may do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StudyBudget {
    /// Wall-clock seconds (the drivers' time budgets; MLT's includes the
    /// bootstrap).
    Seconds(f64),
    /// Samples per pixel (PT, BDPT) or mutations per pixel (MLT, CMLT):
    /// deterministic for a fixed seed and thread count.
    Samples(u64),
}

/// One measured render.
#[derive(Clone, Debug, PartialEq)]
pub struct Measurement {
    /// Wall-clock seconds of the render (bootstrap included, scene loading
    /// and BVH build excluded).
    pub wall_s: f64,
    /// Samples per pixel (PT, BDPT) or mutations per pixel (MLT, CMLT),
    /// over all threads.
    pub samples: f64,
    /// Relative MSE against the reference ([`metrics::rel_mse`]).
    pub rel_mse: f64,
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

    /// Width × height of the renders.
    pub fn resolution(&self) -> (usize, usize) {
        let cam = &self.loaded.scene.camera;
        (cam.width() as usize, cam.height() as usize)
    }

    /// Renders with `estimator` under `budget` on `threads` threads from
    /// `seed`, and scores the image against the reference.
    pub fn measure(
        &self,
        estimator: &Estimator,
        budget: StudyBudget,
        threads: usize,
        seed: u64,
    ) -> Result<Measurement, String> {
        let (w, h) = self.resolution();
        let (scene, settings) = (&self.loaded.scene, &self.loaded.settings);
        let start = Instant::now();
        let (pixels, samples, mrays) = match estimator {
            Estimator::Passes(method) => {
                let budget = match budget {
                    StudyBudget::Seconds(s) => Budget::Time(s),
                    StudyBudget::Samples(n) => Budget::Spp(n),
                };
                let out = render(
                    scene,
                    &self.accel,
                    settings,
                    &scene.analysis(&scene.camera),
                    *method,
                    budget,
                    threads,
                    seed,
                    &|| {},
                )?;
                let spp = out.film.passes() as f64;
                (out.film.resolve(), spp, out.mrays_per_sec())
            }
            Estimator::Metropolis(mlt) => {
                let budget = match budget {
                    StudyBudget::Seconds(s) => MltBudget::Time(s),
                    StudyBudget::Samples(n) => MltBudget::MutationsPerPixel(n),
                };
                let out = render_mlt(
                    scene,
                    &self.accel,
                    settings,
                    &scene.analysis(&scene.camera),
                    mlt,
                    budget,
                    threads,
                    seed,
                    &|_| {},
                )?;
                let mpp = out.mlt.mutations as f64 / (w * h).max(1) as f64;
                (out.image(), mpp, out.mrays_per_sec())
            }
        };
        let wall_s = start.elapsed().as_secs_f64();
        let img = Image {
            width: w,
            height: h,
            pixels,
        };
        Ok(score(&img, &self.reference, wall_s, samples, mrays))
    }
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
        samples,
        rel_mse: metrics::rel_mse(img, reference),
        rmse: metrics::rmse(img, reference),
        mean: [mean.r as f64, mean.g as f64, mean.b as f64],
        mrays_per_s,
    }
}

//! `cmlt-bench still`: a still camera's frames kept by the accumulation
//! ([`Accumulation::Keep`], every frame normalised by its own b) against
//! one offline render — of the same total mutations (the kept frames'
//! estimate is unbiased, so only the frames' restarts and set-ups may
//! cost error) and of the same total wall time (their set-up per frame
//! included). A game wants the kept frames within 1.2× the offline
//! render's relMSE at the same time. Without kept chains every frame runs
//! its whole set-up (its own bootstrap and b), as `cmlt render --frames`
//! does; with them the frames after the first give their set-up no time
//! (the chains go on with the first frame's b), as a game's host that
//! slices its set-up (`cmlt-bench frames`) mostly does.

use std::time::Instant;

use cmlt::math::Rgb;
use cmlt::renderer::{
    Accumulation, Budget, Estimator, RenderWorker, Renderer, RendererConfig, Temporal,
};
use cmlt_cli::image_io::Image;
use cmlt_cli::metrics::rel_mse;
use cmlt_cli::render::{prepare, render_workers};

use crate::study::Study;

/// One seed's figures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Still {
    /// relMSE of the last kept frame.
    pub kept: f64,
    /// Wall seconds of all the kept frames (set-up, render, resolve).
    pub kept_s: f64,
    /// relMSE of one render of the frames' total mutations per pixel.
    pub same_mutations: f64,
    /// relMSE of one render of the frames' total wall time.
    pub same_time: f64,
}

impl Still {
    /// The kept frames' relMSE over the offline render's of the same
    /// mutations.
    pub fn ratio_mutations(&self) -> f64 {
        self.kept / self.same_mutations
    }

    /// The kept frames' relMSE over the offline render's of the same time.
    pub fn ratio_time(&self) -> f64 {
        self.kept / self.same_time
    }
}

/// Renders `frames` frames of `study`'s camera with `estimator`, `mpp`
/// mutations (or samples) per pixel each, kept by the accumulation
/// (`keep_chains`: the chains too), on `threads` workers from `seed`, and
/// the two offline renders.
pub fn run(
    study: &Study,
    estimator: Estimator,
    (frames, mpp): (usize, u64),
    threads: u32,
    keep_chains: bool,
    seed: u64,
) -> Result<Still, String> {
    let scene = &study.loaded.scene;
    let cfg = RendererConfig {
        estimator,
        settings: study.loaded.settings,
        seed,
        workers: threads,
        temporal: Temporal {
            keep_chains: keep_chains && estimator.is_metropolis(),
            ..Temporal::default()
        },
        ..RendererConfig::default()
    };
    let accel = study.accel();
    let t0 = Instant::now();
    let err = |e: cmlt::renderer::RenderError| e.to_string();
    let mut r = Renderer::new(cfg, scene.camera).map_err(err)?;
    r.set_accumulation(Accumulation::Keep).map_err(err)?;
    let mut workers = (0..threads)
        .map(|i| RenderWorker::new(&r, i))
        .collect::<Result<Vec<_>, _>>()
        .map_err(err)?;
    for f in 0..frames {
        if f > 0 {
            r.set_camera(scene.camera).map_err(err)?;
        }
        if f == 0 || !cfg.temporal.keep_chains {
            prepare(&mut r, &mut workers, scene, accel)?;
        } else if r.begin_prepare(scene) {
            // No set-up time: the kept chains go on with the b carried.
            for w in workers.iter_mut() {
                cmlt_cli::render::prepare_worker_while(&r, w, scene, accel, &mut |_| false)
                    .map_err(err)?;
            }
            r.finish_prepare(workers.iter()).map_err(err)?;
        }
        render_workers(
            &r,
            &mut workers,
            scene,
            accel,
            Budget::PerPixel(mpp),
            None,
            &|_| {},
        )?;
    }
    let (w, h) = study.resolution();
    let mut pixels = vec![Rgb::ZERO; w * h];
    let refs: Vec<&RenderWorker> = workers.iter().collect();
    r.resolve(&refs, |i, c| pixels[i] = c).map_err(err)?;
    let last = Image {
        width: w,
        height: h,
        pixels,
    };
    let kept_s = t0.elapsed().as_secs_f64();
    let kept = rel_mse(&last, &study.reference);
    let total = Budget::PerPixel(frames as u64 * mpp);
    let same_mutations = study.measure(estimator, total, threads as usize, seed)?;
    let same_time = study.measure(estimator, Budget::Seconds(kept_s), threads as usize, seed)?;
    Ok(Still {
        kept,
        kept_s,
        same_mutations: same_mutations.rel_mse,
        same_time: same_time.rel_mse,
    })
}

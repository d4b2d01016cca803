//! `cmlt-bench prepare`: what spreading the first frame's preparation (the
//! MLT bootstrap) over the host's threads saves.
//!
//! Preparing is [`Renderer::begin_prepare`], one
//! [`Renderer::prepare_worker`] per worker and [`Renderer::finish_prepare`]
//! (C: `cmlt_renderer_prepare_begin` / `_worker` / `_finish`). A host runs
//! the workers' calls one after the other on its own thread (C:
//! `cmlt_renderer_prepare`), or each on its worker's thread (what
//! `examples-c/frame_loop.c` and `cmlt render` do). Both give the same
//! bootstrap bit for bit; this measures the wall time of each on fresh
//! renderers (a first frame), in turns (serial, spread, serial, …) in one
//! process so that a change in the machine's load hits both alike, and
//! checks that the normalisation b agrees exactly.

use std::time::Instant;

use cmlt::renderer::{RenderWorker, Renderer, RendererConfig};
use cmlt::scene::Scene;
use cmlt_cli::accel::Accel;

/// The measured times, in seconds, one entry per turn.
#[derive(Clone, Debug, Default)]
pub struct PrepareTimes {
    /// Every worker's share on the calling thread, one after the other.
    pub serial: Vec<f64>,
    /// The bootstrap spread over one thread per worker.
    pub spread: Vec<f64>,
}

impl PrepareTimes {
    /// Median serial time over median spread time: the speed-up.
    pub fn speedup(&self) -> f64 {
        median(&self.serial) / median(&self.spread)
    }
}

/// The median of `v` (0 for none).
pub fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// A fresh renderer of `config` with its workers (the state of a host's
/// first frame).
fn fresh(config: RendererConfig, scene: &Scene) -> Result<(Renderer, Vec<RenderWorker>), String> {
    let renderer = Renderer::new(config, scene.camera).map_err(|e| e.to_string())?;
    let workers = (0..config.workers)
        .map(|i| RenderWorker::new(&renderer, i))
        .collect::<Result<_, _>>()
        .map_err(|e| e.to_string())?;
    Ok((renderer, workers))
}

/// `repeats` turns of both ways of preparing a first frame of `config`
/// (an MLT or CMLT configuration with `config.workers` workers). Refuses a
/// turn whose two bootstraps disagree on b.
pub fn run(
    scene: &Scene,
    accel: &Accel,
    config: RendererConfig,
    repeats: usize,
) -> Result<PrepareTimes, String> {
    if !config.estimator.is_metropolis() {
        return Err("only MLT and CMLT have a bootstrap to prepare".into());
    }
    let mut times = PrepareTimes::default();
    for _ in 0..repeats {
        let (mut serial, mut workers) = fresh(config, scene)?;
        let t = Instant::now();
        if serial.begin_prepare(scene) {
            for w in &mut workers {
                serial
                    .prepare_worker_while(w, scene, accel, &mut |_| true)
                    .map_err(|e| e.to_string())?;
            }
            serial
                .finish_prepare(workers.iter())
                .map_err(|e| e.to_string())?;
        }
        times.serial.push(t.elapsed().as_secs_f64());

        let (mut spread, mut workers) = fresh(config, scene)?;
        let t = Instant::now();
        cmlt_cli::render::prepare(&mut spread, &mut workers, scene, accel)?;
        times.spread.push(t.elapsed().as_secs_f64());

        if serial.b().to_bits() != spread.b().to_bits() {
            return Err(format!(
                "the two bootstraps differ: b = {} (serial) and {} (spread)",
                serial.b(),
                spread.b()
            ));
        }
    }
    Ok(times)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[]), 0.0);
    }

    /// Both ways of preparing a small Cornell box's first frame run and
    /// agree on b (`run` refuses a turn where they do not).
    #[test]
    fn both_ways_prepare_the_same_bootstrap() {
        let loaded = cmlt_cli::load_scene_or_builtin(
            "cornell-box",
            &[("resx".into(), "16".into()), ("resy".into(), "16".into())],
        )
        .unwrap();
        let scene = &loaded.scene;
        let accel = cmlt_cli::accel::Accel::build(
            cmlt_cli::accel::AccelKind::Ours,
            &scene.triangles().collect::<Vec<_>>(),
        )
        .unwrap();
        let mut config = RendererConfig::for_estimator(cmlt::renderer::EstimatorKind::Mlt);
        config.settings = loaded.settings;
        config.workers = 2;
        config.estimator.mlt_mut().unwrap().n_bootstrap = 64;
        let t = run(scene, &accel, config, 2).unwrap();
        assert_eq!((t.serial.len(), t.spread.len()), (2, 2));
        assert!(t.speedup().is_finite() && t.speedup() > 0.0);
    }
}

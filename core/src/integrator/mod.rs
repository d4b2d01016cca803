//! Estimators of the measurement equation: path tracing and bidirectional
//! path tracing, both with multiple importance sampling.

/// Integrator settings with Mitsuba's meanings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Settings {
    /// Longest path in segments (Mitsuba `max_depth`): 1 = emitters seen
    /// directly, 2 = direct lighting, … `None` = unbounded (Mitsuba's −1).
    pub max_depth: Option<u32>,
    /// Path length from which Russian roulette may stop a path (Mitsuba
    /// `rr_depth`, default 5).
    pub rr_depth: u32,
    /// Do not show emitters seen directly by the camera (Mitsuba
    /// `hide_emitters`).
    pub hide_emitters: bool,
}

impl Default for Settings {
    /// Mitsuba's defaults: unbounded depth, roulette from depth 5, emitters
    /// visible.
    fn default() -> Self {
        Settings {
            max_depth: None,
            rr_depth: 5,
            hide_emitters: false,
        }
    }
}

impl Settings {
    /// These settings specialised to what a scene calls for: a scene whose
    /// surfaces do not scatter ([`Analysis::emitters_only`]) needs paths of
    /// one segment (emitters seen directly) and no deeper, which also
    /// shrinks MLT's bootstrap and chains to that one depth.
    pub fn specialised(&self, analysis: &Analysis) -> Settings {
        let mut s = *self;
        if analysis.emitters_only {
            s.max_depth = Some(s.max_depth.map_or(1, |d| d.min(1)));
        }
        s
    }
}

pub mod bdpt;
pub mod context;
pub mod path;

pub use context::{LobeCounts, Stats, Tracer};

use glam::Vec2;

use crate::accel::Intersector;
use crate::film::Film;
use crate::sampler::SampleStream;
use crate::scene::Analysis;

/// Which estimator renders a pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Path tracing with next-event estimation and MIS.
    Path,
    /// Bidirectional path tracing with MIS over all strategies.
    Bdpt,
}

/// Per-worker state that lives across passes (subpath storage).
#[derive(Default)]
pub struct Worker {
    bdpt: bdpt::Workspace,
}

impl Worker {
    /// Fresh worker state.
    pub fn new() -> Self {
        Self::default()
    }

    /// Worker state around caller-sized BDPT storage (see
    /// [`bdpt::Workspace::with_capacity`]).
    pub fn with_workspace(bdpt: bdpt::Workspace) -> Self {
        Worker { bdpt }
    }

    /// See [`bdpt::Workspace::set_strategy_filter`]: BDPT evaluates only
    /// the strategies `(s, t)` the filter accepts, without MIS.
    pub fn set_bdpt_strategy_filter(&mut self, only: Option<fn(usize, usize) -> bool>) {
        self.bdpt.set_strategy_filter(only);
    }
}

/// Renders pass `pass` — one sample in every pixel — into `film`.
///
/// The random stream of each sample depends only on `(seed, pass, pixel)`,
/// so the same passes give the same samples whichever worker renders them;
/// the host decides which worker renders which passes and merges the films
/// in a fixed order.
pub fn render_pass<I: Intersector>(
    tracer: &mut Tracer<'_, I>,
    settings: &Settings,
    method: Method,
    worker: &mut Worker,
    seed: u64,
    pass: u64,
    film: &mut Film,
) {
    let camera = tracer.camera;
    let (w, h) = (camera.width(), camera.height());
    for y in 0..h {
        for x in 0..w {
            let mut rng = SampleStream::new(seed, pass, y as u64 * w as u64 + x as u64);
            let raster = Vec2::new(x as f32, y as f32) + rng.next_2d();
            match method {
                Method::Path => {
                    let ray = tracer.camera_ray(raster, rng.next_2d());
                    let l = path::radiance(tracer, settings, ray, &mut rng);
                    film.add_sample(x, y, l);
                }
                Method::Bdpt => bdpt::sample(
                    tracer,
                    settings,
                    &mut worker.bdpt,
                    raster,
                    x,
                    y,
                    &mut rng,
                    film,
                ),
            }
            tracer.stats.samples += 1;
        }
    }
    film.end_pass();
}

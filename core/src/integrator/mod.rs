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
pub mod pt;
pub mod tracer;

pub use tracer::{LobeCounts, Stats, Tracer};

use glam::Vec2;

use crate::accel::Intersector;
use crate::film::Film;
use crate::sampler::SampleStream;
use crate::scene::Analysis;

/// Which estimator renders: the one name of the choice everywhere (the
/// renderer's configuration, the CLI's `--method`, the C API's
/// `CMLT_ESTIMATOR_*` constants, whose values are the discriminants).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Estimator {
    /// Path tracing with next-event estimation and MIS.
    Path = 0,
    /// Bidirectional path tracing with MIS over all strategies.
    Bdpt = 1,
    /// Metropolis light transport: Kelemen mutations in primary sample
    /// space over BDPT's strategies (level 1 only: `MltSettings::m` = 0).
    Mlt = 2,
    /// Coherent MLT (Segovia 2007): MLT plus lens, caustic and multi-chain
    /// perturbations traced as packets (level 2: `MltSettings::m` ≥ 1).
    Cmlt = 3,
}

impl Estimator {
    /// Every estimator, in discriminant order.
    pub const ALL: [Estimator; 4] = [
        Estimator::Path,
        Estimator::Bdpt,
        Estimator::Mlt,
        Estimator::Cmlt,
    ];

    /// The short name the CLI and the benchmarks use: `pt`, `bdpt`, `mlt`,
    /// `cmlt`.
    pub fn name(self) -> &'static str {
        match self {
            Estimator::Path => "pt",
            Estimator::Bdpt => "bdpt",
            Estimator::Mlt => "mlt",
            Estimator::Cmlt => "cmlt",
        }
    }

    /// The estimator of a short name ([`Estimator::name`]).
    pub fn from_name(name: &str) -> Option<Estimator> {
        Estimator::ALL.into_iter().find(|e| e.name() == name)
    }

    /// The estimator of a C API constant (its discriminant).
    pub fn from_u32(value: u32) -> Option<Estimator> {
        Estimator::ALL.get(value as usize).copied()
    }

    /// Whether it runs Markov chains (MLT, CMLT) rather than passes of
    /// independent samples (PT, BDPT): budgets count mutations, not
    /// samples, and the image is normalised by the bootstrap's b.
    pub fn is_metropolis(self) -> bool {
        matches!(self, Estimator::Mlt | Estimator::Cmlt)
    }
}

/// Renders pass `pass` — one sample in every pixel — into `film`, by path
/// tracing for [`Estimator::Path`] and BDPT otherwise (the Metropolis
/// estimators have no passes of their own; their normalisation passes are
/// BDPT's).
///
/// The random stream of each sample depends only on `(seed, pass, pixel)`,
/// so the same passes give the same samples whichever worker renders them;
/// the host decides which worker renders which passes and merges the films
/// in a fixed order.
pub fn render_pass<I: Intersector>(
    tracer: &mut Tracer<'_, I>,
    settings: &Settings,
    method: Estimator,
    paths: &mut bdpt::PathStorage,
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
                Estimator::Path => {
                    let ray = tracer.camera_ray(raster, rng.next_2d());
                    let l = pt::radiance(tracer, settings, ray, &mut rng);
                    film.add_sample(x, y, l);
                }
                _ => bdpt::sample(tracer, settings, paths, raster, x, y, &mut rng, film),
            }
            tracer.stats.samples += 1;
        }
    }
    film.end_pass();
}

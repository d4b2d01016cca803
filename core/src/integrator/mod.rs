//! Estimators of the measurement equation: path tracing and bidirectional
//! path tracing, both with multiple importance sampling.

/// Integrator settings with Mitsuba's meanings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Settings {
    /// Longest path in segments (Mitsuba `max_depth`): 1 = emitters seen
    /// directly, 2 = direct lighting, … `None` = unbounded (Mitsuba's −1),
    /// which a renderer renders at its
    /// [`crate::renderer::RendererConfig::depth_cap`].
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

use crate::scene::Analysis;

//! Level 1's Metropolis target: the contribution f_d(u) of one BDPT
//! strategy of path depth d at a primary-sample point u, whose luminance
//! Y(f_d(u)) a chain of depth d samples in proportion to (the parent
//! module's "Units and invariants"). The bootstrap, the chains and the
//! tests all evaluate it here, so they agree on one target.

use super::chain::PathSample;
use super::primary::PrimarySampler;
use crate::accel::Intersector;
use crate::integrator::{Settings, Tracer, bdpt};

/// Evaluates the target of depth `depth` at the current point of `sampler`:
/// [`bdpt::sample_strategy`]'s contribution (one strategy, times the
/// strategy count) and where on the image it lands.
#[inline]
pub(crate) fn evaluate<I: Intersector>(
    tracer: &mut Tracer<'_, I>,
    settings: &Settings,
    ws: &mut bdpt::PathStorage,
    depth: u32,
    sampler: &mut PrimarySampler,
) -> PathSample {
    let r = bdpt::sample_strategy(tracer, settings, ws, depth as usize, sampler);
    PathSample {
        l: r.l,
        raster: r.raster,
        strategy: r.s,
    }
}

//! A worker's path-space chains ([`crate::mlt::Level1::PathSpace`]), driven
//! by `WorkerChains` as it drives the primary-sample ones.
//!
//! A path-space chain moves between depths (the bidirectional mutation
//! changes the path's length), so its stationary distribution is Y(f(x̄))
//! over all depths 1 … D together, normalised by b = Σ_d b_d: every chain
//! weighs the same, and a record of unit luminance scales by b·P/N like
//! the primary-sample ones ([`crate::mlt::image_scale`]). The chains'
//! starting depths are a systematic sample of the depths by b_d / b (not
//! the primary-sample chains' allocation, which gives emitters seen
//! directly fewer chains and weighs them back: a path-space chain leaves
//! its depth, so only a start ∝ Y(f) over all depths is stationary), each
//! start a bootstrap sample of its depth picked ∝ Y (`state.rs`: Veach's
//! start-up).
//!
//! CMLT over it: level 2 runs from each chain's state exactly as from a
//! primary-sample one ([`Level2`], one implementation for both). Its proof
//! (`mlt/level2.rs`) needs only that level 1's stationary distribution
//! over paths is Y(f(x̄)) in the path measure, which both level 1s have
//! (the primary-sample one after summing over the strategies, whose MIS
//! weights sum to 1): every state keeps its class (perturbation, side-chain
//! length), a classless state's records carry the share s, and each
//! mutation counts 1 + s records.

use alloc::vec::Vec;

use rand_pcg::Pcg32;

use super::super::chain::PathSample;
use super::super::level2::Level2;
use super::super::perturbation::Applicable;
use super::super::{
    Bootstrap, LEVEL2_STREAM, MltSettings, MltStats, PrimarySampler, chain_seed, depths, mix64,
    start_sample, target, uniform_f64,
};
use super::chain::{Mutations, PathChain, PathStep};
use super::selection::Mutation;
use crate::accel::Intersector;
use crate::film::Film;
use crate::integrator::{Settings, Tracer, bdpt};
use crate::sampler::SampleStream;
use crate::scene::Camera;

/// The depth at position `u` ∈ [0, 1) of the split of b into the b_d
/// (`None` when b = 0).
fn depth_at(bootstrap: &Bootstrap, u: f64) -> Option<u32> {
    let b = bootstrap.b();
    if !(b > 0.0) {
        return None;
    }
    let mut acc = 0.0;
    let depth_b = bootstrap.depth_b();
    for (i, &b_d) in depth_b.iter().enumerate() {
        acc += b_d / b;
        if u < acc && b_d > 0.0 {
            return Some(i as u32 + 1);
        }
    }
    depth_b
        .iter()
        .rposition(|&b_d| b_d > 0.0)
        .map(|i| i as u32 + 1)
}

/// A worker's path-space chains and the storage they mutate with.
pub(crate) struct PathChains {
    /// Room for `n_chains` chains; the first `live` run.
    chains: Vec<PathChain>,
    live: usize,
    mutations: Mutations,
    /// Replays bootstrap samples for the starts.
    sampler: PrimarySampler,
    /// CMLT: the class of each live chain's current path and its
    /// side-chain length ([`Level2::classify`]); empty for MLT.
    classes: Vec<(Applicable, u32)>,
    /// Test only: classless states' records do not carry the level-2
    /// share (a negative control).
    #[cfg(test)]
    pub broken_carry: bool,
}

impl PathChains {
    /// Storage for `mlt.n_chains` chains at `settings`' depths on
    /// `camera`'s image, with their classes when `level2` (CMLT): after
    /// this nothing is allocated.
    pub fn with_capacity(
        settings: &Settings,
        mlt: &MltSettings,
        level2: bool,
        camera: &Camera,
    ) -> Self {
        let depth = depths(settings);
        PathChains {
            classes: Vec::with_capacity(if level2 { mlt.n_chains as usize } else { 0 }),
            #[cfg(test)]
            broken_carry: false,
            chains: (0..mlt.n_chains)
                .map(|_| PathChain::with_capacity(depth))
                .collect(),
            live: 0,
            mutations: Mutations::new(
                &mlt.path_mutations,
                depth,
                camera.width(),
                camera.height(),
                camera.pixel_angle(),
            ),
            sampler: PrimarySampler::with_capacity(0, mlt.sigma, mlt.large_step_prob, depth),
        }
    }

    /// Chains running.
    pub fn len(&self) -> usize {
        self.live
    }

    /// Starts the chains of worker `worker` of `workers` afresh (the same
    /// depths and bootstrap picks as the primary-sample chains of the same
    /// seed would get), counting them in `stats`; with `level2` (CMLT),
    /// classifies each start.
    #[allow(clippy::too_many_arguments)]
    pub fn restart<I: Intersector>(
        &mut self,
        tracer: &mut Tracer<'_, I>,
        settings: &Settings,
        ws: &mut bdpt::PathStorage,
        bootstrap: &Bootstrap,
        start_tries: u64,
        seed: u64,
        worker: u64,
        workers: u64,
        stats: &mut MltStats,
        level2: Option<&Level2>,
    ) {
        self.live = 0;
        self.classes.clear();
        let workers = workers.max(1);
        let n = self.chains.len() as u64;
        let total = n * workers;
        let offset = uniform_f64(&mut Pcg32::new(mix64(seed ^ 0x0FF5_E700), 7));
        for c in 0..n {
            let global = worker + workers * c;
            let Some(depth) = depth_at(bootstrap, (global as f64 + offset) / total as f64) else {
                break;
            };
            let cs = chain_seed(seed, worker, c);
            let mut rng = Pcg32::new(cs, mix64(cs ^ 1));
            let sampler = &mut self.sampler;
            let u = uniform_f64(&mut rng);
            let start = start_sample(bootstrap, depth, u, start_tries, &mut rng, |i| {
                sampler.restart(bootstrap.seed_of(i));
                target::evaluate(tracer, settings, ws, depth, sampler).target() > 0.0
            });
            let Some(index) = start else {
                continue;
            };
            let chain = &mut self.chains[self.live];
            let started = chain.current_mut().start(
                tracer,
                settings,
                ws,
                &mut self.sampler,
                bootstrap,
                depth,
                index,
            );
            if started {
                chain.start(cs);
                self.live += 1;
                stats.chains += 1;
                if let Some(l2) = level2 {
                    self.classes
                        .push(l2.classify(tracer, &chain.current().path));
                }
            }
        }
    }

    /// One mutation of chain `ci`, counted in `stats`.
    pub fn step<I: Intersector>(
        &mut self,
        ci: usize,
        tracer: &mut Tracer<'_, I>,
        stats: &mut MltStats,
    ) -> PathStep {
        let st = self.chains[ci].step(tracer, &mut self.mutations);
        stats.mutations += 1;
        stats.records += 1;
        let accepted = st.accepted as u64;
        let (proposed, taken) = match st.mutation {
            Mutation::Bidirectional => (
                &mut stats.bidirectional_proposed,
                &mut stats.bidirectional_accepted,
            ),
            Mutation::LensSubpath => (
                &mut stats.lens_subpath_proposed,
                &mut stats.lens_subpath_accepted,
            ),
            Mutation::Lens => (
                &mut stats.perturbations_proposed[0],
                &mut stats.perturbations_accepted[0],
            ),
            Mutation::Caustic => (
                &mut stats.perturbations_proposed[1],
                &mut stats.perturbations_accepted[1],
            ),
            Mutation::MultiChain => (
                &mut stats.perturbations_proposed[2],
                &mut stats.perturbations_accepted[2],
            ),
        };
        *proposed += 1;
        *taken += accepted;
        stats.zero_proposals += (st.proposal_depth == 0) as u64;
        st
    }

    /// Records mutation `st` of chain `ci` into `film`. MLT (`level2`
    /// `None`): its records as they are. CMLT: as the primary-sample
    /// chains' (`WorkerChains::advance`, proof in `mlt/level2.rs`) — a
    /// record of a state whose class has no side chain carries the share
    /// (weight 1 + s), the proposal's class is found whenever it is
    /// recorded and kept when it is accepted, and the chain's state then
    /// runs its class's side chain, whose records weigh s in all; the
    /// mutation counts s more records.
    pub fn record<I: Intersector>(
        &mut self,
        ci: usize,
        st: &PathStep,
        tracer: &mut Tracer<'_, I>,
        level2: Option<&mut Level2>,
        stats: &mut MltStats,
        film: &mut Film,
    ) {
        let Some(l2) = level2 else {
            for sp in st.proposal.into_iter().chain(st.current) {
                film.add_splat(sp.raster, sp.value);
            }
            return;
        };
        let share = l2.share() as f32;
        #[cfg(test)]
        let carried = if self.broken_carry { 0.0 } else { share };
        #[cfg(not(test))]
        let carried = share;
        let carry = |length: u32| if length == 0 { 1.0 + carried } else { 1.0 };
        let chain = &self.chains[ci];
        let mut y_class = (Applicable::Neither, 0);
        if let Some(sp) = st.proposal {
            // Accepted: the proposal is the chain's current path now.
            let y = if st.accepted {
                chain.current()
            } else {
                chain.other()
            };
            y_class = l2.classify(tracer, &y.path);
            film.add_splat(sp.raster, sp.value * carry(y_class.1));
        }
        if let Some(sp) = st.current {
            film.add_splat(sp.raster, sp.value * carry(self.classes[ci].1));
        }
        if st.accepted {
            self.classes[ci] = y_class;
        }
        let (class, length) = &self.classes[ci];
        if *length > 0 {
            let x = chain.current();
            let current = PathSample {
                l: x.f,
                raster: x.raster,
                strategy: 0,
            };
            let (seed, iteration) = chain.stream_key();
            let mut rng = SampleStream::new(seed, iteration, LEVEL2_STREAM);
            l2.side_chain(
                tracer,
                &x.path,
                class,
                *length,
                &current,
                &mut rng,
                stats,
                &mut |r, v| film.add_splat(r, v),
            );
        } else {
            stats.identity_steps += l2.share() as u64;
        }
        stats.records += l2.share() as u64;
    }
}

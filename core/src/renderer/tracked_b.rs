//! b tracked over a moving camera's frames from the chains' large steps
//! ([`super::Temporal::large_step_window`]).
//!
//! With kept chains a frame after a camera move or a scene update goes on
//! with the b of the last joined bootstrap, and the next bootstrap is
//! evaluated in the frames' set-up slices: at a game's budget one
//! normalisation pass takes tens of frames, so b is stale in between and
//! jumps when the next one is joined (the frame trial's dolly: the mean
//! luminance stayed at the first view's for 80 frames, then rose by 25–31 %
//! in one frame). The chains' large steps are independent samples of the
//! target at every frame (`mlt/large_steps.rs`: their mean Y per depth
//! estimates b_d), tens of thousands per frame, so b is taken from the
//! large steps of the last N frames ([`LargeStepTally::pooled_b`]): b
//! follows the view with a lag of about N / 2 frames, and changes a
//! little at every frame instead of much at a join. A frame's large
//! steps are heavy-tailed (in the frame trial one frame's estimate varies
//! by about 17 %, so a window of 8 frames moved the mean by 2–3 % a
//! frame): the window wants tens of frames. Until it has filled, the
//! first bootstrap's passes stand in for its empty frames; after, the
//! last joined bootstrap's b_d count as one sample, for a depth without
//! large steps — pooled by their sample counts, passes evaluated over the
//! tens of frames before the join would hold b at an old view (the
//! trial's dolly lagged 12–25 % below BDPT's mean that way).
//!
//! Each frame's tally is the workers' large steps of that frame, taken at
//! the next frame's `finish_prepare` (before the workers clear them at
//! their first `render`) and added in worker index order, so b is the
//! same whichever order the host hands the workers in.

use alloc::vec::Vec;

use crate::mlt::LargeStepTally;

/// The last frames' large-step tallies, one per frame in a ring, sized
/// when the renderer is made (empty when tracking is off).
pub(crate) struct TrackedB {
    /// One tally per frame of the window, the newest at `next − 1`.
    frames: Vec<LargeStepTally>,
    next: usize,
    /// The frame being taken: one tally per worker, merged in index
    /// order by [`TrackedB::commit`].
    workers: Vec<LargeStepTally>,
    taken: Vec<bool>,
    /// The window's frames merged.
    merged: LargeStepTally,
    /// The renderer generation of the last commit.
    committed: Option<u64>,
    /// Frames committed, up to the window's length.
    filled: usize,
}

impl TrackedB {
    /// A window of `frames` frames (0: tracking off) for `workers`
    /// workers' tallies of `depths` depths.
    pub(crate) fn new(frames: u32, workers: u32, depths: u32) -> Self {
        let tally = || LargeStepTally::with_depths(depths);
        let w = if frames > 0 { workers as usize } else { 0 };
        TrackedB {
            frames: (0..frames).map(|_| tally()).collect(),
            next: 0,
            workers: (0..w).map(|_| tally()).collect(),
            taken: alloc::vec![false; w],
            merged: tally(),
            committed: None,
            filled: 0,
        }
    }

    /// Whether a frame is to be taken at renderer generation
    /// `generation`: tracking is on and nothing was committed at this
    /// generation yet. Clears the workers' slots for it.
    pub(crate) fn begin(&mut self, generation: u64) -> bool {
        if self.frames.is_empty() || self.committed == Some(generation) {
            return false;
        }
        self.taken.fill(false);
        true
    }

    /// Takes worker `index`'s tally, if the worker rendered since the last
    /// commit (its `generation`, that of its last frame, is not older):
    /// a tally already taken is not counted again.
    pub(crate) fn take(&mut self, index: usize, generation: Option<u64>, tally: &LargeStepTally) {
        let fresh = match (generation, self.committed) {
            (Some(g), Some(c)) => g >= c,
            (Some(_), None) => true,
            (None, _) => false,
        };
        if fresh && let Some(slot) = self.workers.get_mut(index) {
            slot.clear();
            slot.merge(tally);
            self.taken[index] = true;
        }
    }

    /// Ends the frame begun by [`TrackedB::begin`] at `generation`: the
    /// workers' tallies, added in index order, replace the window's
    /// oldest frame. Allocates nothing.
    pub(crate) fn commit(&mut self, generation: u64) {
        let n = self.frames.len();
        let slot = &mut self.frames[self.next];
        slot.clear();
        for (t, &taken) in self.workers.iter().zip(&self.taken) {
            if taken {
                slot.merge(t);
            }
        }
        self.next = (self.next + 1) % n;
        self.merged.clear();
        for f in &self.frames {
            self.merged.merge(f);
        }
        self.committed = Some(generation);
        self.filled = (self.filled + 1).min(n);
    }

    /// b from the window's large steps pooled with a bootstrap's
    /// `pass_depth_b` of `pass_samples` samples, which stand in for the
    /// frames of the window not yet filled (each frame a share of them)
    /// and, once it is full, count as one sample: they keep only a depth
    /// without large steps.
    pub(crate) fn b(&self, pass_depth_b: &[f64], pass_samples: u64) -> f64 {
        let n = self.frames.len() as u64;
        let empty = n - self.filled as u64;
        let weight = (pass_samples * empty / n.max(1)).max(1);
        self.merged.pooled_b(pass_depth_b, weight)
    }
}

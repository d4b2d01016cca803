//! b by depth from the large steps a render makes anyway (Tungsten's
//! `LargeStepTracker` in its multiplexed MLT; Kelemen et al. 2002, §4).
//!
//! A large step of a depth-d chain evaluates the target Y(f_d(u)) at an
//! independent uniform primary point u, whatever the chain's state, so the
//! mean of the proposals' Y over a depth's large steps is an unbiased
//! estimate of b_d = E_u[Y(f_d(u))] (accepted or not: the acceptance
//! decides what is recorded in the image, not what was drawn). Small
//! steps are not: their proposals follow the chain, distributed ∝ Y, and
//! their mean tends to E_Y[Y] = ∫Y² / ∫Y instead.
//!
//! The tally is per worker, cleared when its chains restart and at every
//! frame ([`crate::renderer::RenderWorker::large_steps`]); a host merges
//! the workers' tallies of a frame (or of several frames through the same
//! camera) in any order and reads b_d with [`LargeStepTally::depth_b`] and
//! its standard error with [`LargeStepTally::depth_b_error`], e.g. to pool
//! it with the bootstrap's estimate by inverse variance. It changes no
//! image by itself.

use alloc::vec::Vec;

/// Per path depth: the number of large steps, and the sum and sum of
/// squares of their proposals' target values Y.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LargeStepTally {
    /// `counts[d − 1]`: large steps of depth d.
    counts: Vec<u64>,
    /// Σ Y over them.
    sums: Vec<f64>,
    /// Σ Y² over them (for the standard error).
    squares: Vec<f64>,
}

impl LargeStepTally {
    /// An empty tally with room for depths 1 ..= `depths` (recording
    /// then allocates nothing).
    pub fn with_depths(depths: u32) -> Self {
        let n = depths as usize;
        LargeStepTally {
            counts: alloc::vec![0; n],
            sums: alloc::vec![0.0; n],
            squares: alloc::vec![0.0; n],
        }
    }

    /// Forgets every large step, keeping the depths.
    pub fn clear(&mut self) {
        self.counts.fill(0);
        self.sums.fill(0.0);
        self.squares.fill(0.0);
    }

    /// Records a large step of `depth` whose proposal's target was `y`
    /// (non-finite or negative values count as 0, as the chain treats
    /// them). Depths outside the tally are ignored.
    pub(crate) fn add(&mut self, depth: u32, y: f32) {
        let Some(i) = (depth as usize).checked_sub(1) else {
            return;
        };
        if i >= self.counts.len() {
            return;
        }
        let y = if y.is_finite() && y > 0.0 {
            y as f64
        } else {
            0.0
        };
        self.counts[i] += 1;
        self.sums[i] += y;
        self.squares[i] += y * y;
    }

    /// Adds another tally (another worker's, or another frame's through
    /// the same camera). Depths beyond this tally's are dropped.
    pub fn merge(&mut self, other: &LargeStepTally) {
        for (i, &c) in other.counts.iter().enumerate().take(self.counts.len()) {
            self.counts[i] += c;
            self.sums[i] += other.sums[i];
            self.squares[i] += other.squares[i];
        }
    }

    /// The largest depth the tally holds.
    pub fn depths(&self) -> u32 {
        self.counts.len() as u32
    }

    /// Large steps recorded at `depth` (0 outside the tally).
    pub fn count(&self, depth: u32) -> u64 {
        self.index(depth).map_or(0, |i| self.counts[i])
    }

    /// b_d estimated from the large steps of `depth`: the mean of their
    /// proposals' Y (`None` without any).
    pub fn depth_b(&self, depth: u32) -> Option<f64> {
        let i = self.index(depth)?;
        let n = self.counts[i];
        (n > 0).then(|| self.sums[i] / n as f64)
    }

    /// The standard error of [`LargeStepTally::depth_b`]: the sample
    /// standard deviation of Y over √n (`None` with fewer than two large
    /// steps).
    pub fn depth_b_error(&self, depth: u32) -> Option<f64> {
        let i = self.index(depth)?;
        let n = self.counts[i];
        if n < 2 {
            return None;
        }
        let nf = n as f64;
        let mean = self.sums[i] / nf;
        let var = ((self.squares[i] - nf * mean * mean) / (nf - 1.0)).max(0.0);
        Some(libm::sqrt(var / nf))
    }

    /// b pooled from the normalisation passes and these large steps: per
    /// depth, the mean of both estimates weighted by their sample counts
    /// (`pass_depth_b[d − 1]` from `pass_samples` BDPT samples, the
    /// passes' b_d; the large steps' count from this tally), summed over
    /// the depths. A depth without large steps keeps the passes' b_d, and
    /// `pass_samples` = 0 gives the large steps' b alone.
    pub fn pooled_b(&self, pass_depth_b: &[f64], pass_samples: u64) -> f64 {
        let depths = self.counts.len().max(pass_depth_b.len());
        (0..depths)
            .map(|i| {
                let (n_p, b_p) = match pass_depth_b.get(i) {
                    Some(&b) => (pass_samples as f64, b),
                    None => (0.0, 0.0),
                };
                let n_l = self.counts.get(i).map_or(0.0, |&c| c as f64);
                let sum_l = self.sums.get(i).copied().unwrap_or(0.0);
                if n_p + n_l > 0.0 {
                    (n_p * b_p + sum_l) / (n_p + n_l)
                } else {
                    0.0
                }
            })
            .sum()
    }

    fn index(&self, depth: u32) -> Option<usize> {
        let i = (depth as usize).checked_sub(1)?;
        (i < self.counts.len()).then_some(i)
    }
}

#[cfg(test)]
mod tests {
    use super::super::chain::Chain;
    use super::super::primary::PrimarySampler;
    use super::*;

    // The chain tests' toy target: Y(u) = 1 + 3x + 8·[y > ¾] on the unit
    // square, ∫Y = 4.5, and a chain's states, distributed ∝ Y, have mean
    // ∫Y²/∫Y = 33/4.5 ≈ 7.3.
    use super::super::chain::tests::toy;

    /// Runs 16 chains of 20 000 mutations on the toy, tallying at depth
    /// 1 the large steps' proposals and, at depth 2, every proposal.
    fn run() -> LargeStepTally {
        let mut tally = LargeStepTally::with_depths(2);
        for c in 0..16 {
            let mut s = PrimarySampler::new(c, 0.05, 0.3);
            let init = toy(&mut s);
            let mut chain = Chain::new(s, init, 500 + c);
            for _ in 0..20_000 {
                let st = chain.step(toy, None);
                if st.large {
                    tally.add(1, st.proposal_target);
                }
                tally.add(2, st.proposal_target);
            }
        }
        tally
    }

    #[test]
    fn large_steps_estimate_the_integral_and_small_steps_do_not() {
        let t = run();
        let (b, err) = (t.depth_b(1).unwrap(), t.depth_b_error(1).unwrap());
        assert!(
            t.count(1) > 80_000 && t.count(1) < 112_000,
            "{}",
            t.count(1)
        );
        assert!((b - 4.5).abs() < 4.0 * err && err < 0.02, "b {b} ± {err}");
        // Negative control: all proposals, small steps included, follow
        // the chain (∝ Y) and overestimate: about 0.3·4.5 + 0.7·7.3 ≈ 6.5
        // (a little less: small steps from the bright strip fall off it).
        let all = t.depth_b(2).unwrap();
        assert!(all > 5.5, "every proposal's mean {all} looked unbiased");
    }

    #[test]
    fn merge_adds_and_out_of_range_depths_are_ignored() {
        let mut a = LargeStepTally::with_depths(3);
        a.add(1, 2.0);
        a.add(1, 4.0);
        a.add(0, 9.0);
        a.add(4, 9.0);
        a.add(3, f32::NAN);
        let mut b = LargeStepTally::with_depths(3);
        b.add(1, 6.0);
        b.merge(&a);
        assert_eq!((b.count(1), b.depth_b(1)), (3, Some(4.0)));
        assert_eq!((b.count(3), b.depth_b(3)), (1, Some(0.0)));
        assert_eq!((b.count(2), b.depth_b(2)), (0, None));
        // Sample standard deviation 2 over √3.
        assert!((b.depth_b_error(1).unwrap() - 2.0 / 3f64.sqrt()).abs() < 1e-12);
        // Pooled with 3 pass samples per depth of b_d = (1, 2, 5): depth 1
        // (3·1 + 12)/6, depth 2 the passes' alone, depth 3 (3·5 + 0)/4.
        let pooled = b.pooled_b(&[1.0, 2.0, 5.0], 3);
        assert!((pooled - (2.5 + 2.0 + 3.75)).abs() < 1e-12, "{pooled}");
        assert!((b.pooled_b(&[], 0) - 4.0).abs() < 1e-12);
        b.clear();
        assert_eq!((b.count(1), b.depths()), (0, 3));
    }
}

//! Piecewise-constant discrete distributions in one and two dimensions
//! (pbrt-v4 §A.4's `PiecewiseConstant1D`/`2D`, discrete part): cells are
//! chosen in proportion to non-negative weights by inverting a cumulative
//! table, and the leftover of the random number places the sample inside
//! its cell. Built once; sampling allocates nothing.

use alloc::vec::Vec;

use glam::Vec2;

/// Chooses among `n` cells in proportion to their weights.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution1D {
    /// Cumulative probabilities, ending at exactly 1.
    cdf: Vec<f32>,
    /// Sum of the weights (f64: a large image sums millions of texels).
    total: f64,
}

impl Distribution1D {
    /// The distribution of `weights`; `None` when one is negative or not
    /// finite, or when they sum to zero (nothing could be chosen).
    pub fn new(weights: &[f32]) -> Option<Self> {
        if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return None;
        }
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let mut acc = 0.0f64;
        let mut cdf: Vec<f32> = weights
            .iter()
            .map(|&w| {
                acc += w as f64;
                (acc / total) as f32
            })
            .collect();
        *cdf.last_mut()? = 1.0;
        Some(Distribution1D { cdf, total })
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.cdf.len()
    }

    /// Never true: a distribution has at least one cell of positive weight.
    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    /// Sum of the weights.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Probability of cell `i`, as [`Distribution1D::sample`] chooses it.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        self.cdf[i] - lo
    }

    /// The cell that `u` ∈ [0, 1) falls in (never one of zero weight) and
    /// the leftover of `u`, rescaled to [0, 1), to place a point inside it.
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32) {
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.cdf.len() - 1);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let p = self.cdf[i] - lo;
        let rest = if p > 0.0 { (u - lo) / p } else { 0.0 };
        (i, rest.clamp(0.0, 1.0 - f32::EPSILON / 2.0))
    }
}

/// Chooses among the cells of a `width × height` grid in proportion to
/// their weights: a row by the rows' sums (the marginal), then a cell in
/// it (the conditional).
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution2D {
    width: usize,
    marginal: Distribution1D,
    /// One conditional per row; `None` for rows of zero weight, which the
    /// marginal never chooses.
    rows: Vec<Option<Distribution1D>>,
}

impl Distribution2D {
    /// The distribution of the row-major `weights` of a `width`-wide grid;
    /// `None` when the size does not match, a weight is negative or not
    /// finite, or all are zero.
    pub fn new(width: usize, weights: &[f32]) -> Option<Self> {
        if width == 0 || weights.is_empty() || !weights.len().is_multiple_of(width) {
            return None;
        }
        let rows: Vec<Option<Distribution1D>> =
            weights.chunks(width).map(Distribution1D::new).collect();
        if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return None;
        }
        let sums: Vec<f32> = rows
            .iter()
            .map(|r| r.as_ref().map_or(0.0, |r| r.total() as f32))
            .collect();
        let marginal = Distribution1D::new(&sums)?;
        Some(Distribution2D {
            width,
            marginal,
            rows,
        })
    }

    /// Grid width.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Grid height.
    pub fn height(&self) -> usize {
        self.rows.len()
    }

    /// Probability of cell (`x`, `y`), as [`Distribution2D::sample`]
    /// chooses it.
    #[inline]
    pub fn pmf(&self, x: usize, y: usize) -> f32 {
        match &self.rows[y] {
            Some(r) => self.marginal.pmf(y) * r.pmf(x),
            None => 0.0,
        }
    }

    /// The cell (`x`, `y`) that `u` chooses and the leftovers in [0, 1)²
    /// that place a point inside it.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (usize, usize, Vec2) {
        let (y, ry) = self.marginal.sample(u.y);
        // The marginal never chooses a row of zero weight.
        let (x, rx) = self.rows[y].as_ref().map_or((0, u.x), |r| r.sample(u.x));
        (x, y, Vec2::new(rx, ry))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sampling frequencies match `pmf`, zero cells are never chosen and
    /// the leftovers are uniform within the cell (mean ½).
    #[test]
    fn frequencies_match_pmf() {
        let weights = [0.0, 1.0, 3.0, 0.0, 0.0, 0.0, 2.0, 0.5, 4.0];
        let d = Distribution2D::new(3, &weights).unwrap();
        let total: f32 = weights.iter().sum();
        let n = 300;
        let mut count = [0u32; 9];
        let mut rest = Vec2::ZERO;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let (x, y, r) = d.sample(u);
                count[y * 3 + x] += 1;
                rest += r;
            }
        }
        for (c, w) in count.iter().zip(weights) {
            let f = *c as f32 / (n * n) as f32;
            assert!((f - w / total).abs() < 2e-3, "{f} vs {}", w / total);
            if w == 0.0 {
                assert_eq!(*c, 0);
            }
        }
        for y in 0..3 {
            for x in 0..3 {
                assert!((d.pmf(x, y) - weights[y * 3 + x] / total).abs() < 1e-6);
            }
        }
        let mean = rest / (n * n) as f32;
        assert!(
            (mean - Vec2::splat(0.5)).abs().max_element() < 1e-2,
            "{mean}"
        );
        assert!(Distribution2D::new(2, &[0.0; 4]).is_none());
        assert!(Distribution2D::new(2, &[1.0, f32::NAN]).is_none());
        assert!(Distribution2D::new(2, &[1.0, -1.0]).is_none());
        assert!(Distribution2D::new(2, &[1.0; 3]).is_none());
    }
}

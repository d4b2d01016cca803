//! Dynamic resolution for PT and BDPT ([`PixelBlock`]): a pass at block
//! size k draws one sample per k × k block of pixels, at a point uniform
//! over the block, and fills the whole block with its camera-side value.
//! Such a pass costs P / k² samples and is an unbiased estimate of the
//! image box-filtered over the blocks, B_k I(i) = (1 / m) Σ_{j ∈ block(i)}
//! I(j) (m the block's pixels inside the image), whose mean over the image
//! is I's — except BDPT's light-tracing (t = 1) splats, which stay at full
//! resolution (P / k² light subpaths a pass, normalised as ever by the
//! samples over the pixels): BDPT estimates B_k I_c + I_t1, its camera-side
//! strategies block-filtered and light tracing not, with the same mean.
//! Spreading each splat over its block too would make every BDPT sample
//! cost (1 + splats) · k² pixel writes instead of k²: the camera-side
//! fill alone is one write per pixel per pass, whatever k, and even that
//! is a large share of a frame at 640 × 360 (`bench/README.md`, frames).
//!
//! Every sample carries a weight of 1 spread over its block (1 / m per
//! pixel, `accumulation::Weights`), so a pixel's value is the
//! weight-averaged mean of the samples that cover it: a frame at one k
//! shows B_k I, and a pixel that also holds finer samples leans towards
//! them by their larger share of weight (a sample at k = 1 weighs k²
//! times one at k in its pixel). Frames that mix block sizes (a refining
//! first frame, decayed or kept frames, [`PixelBlock::Fit`]) show a
//! per-pixel mixture of block-filtered images; with a still camera and
//! [`super::Accumulation::Keep`] the fit reaches k = 1, after which the
//! coarse samples' share of every pixel's weight falls as 1 / samples.
//!
//! [`PixelBlock::Fit`] chooses k at every pass start, without reading
//! time, from the worker's samples: the finest k whose grid has at most
//! `W · (T + margin · r)` blocks, with T the sample weight the worker's
//! accumulation holds now (0 at a reset frame's start, decayed or kept
//! otherwise), r the samples its last frame rendered minus those of this
//! frame so far (the forecast of what is left of the frame), W the
//! workers (each worker's passes start a W-th of the order apart, so
//! their passes complement one another when their sizes agree; 1 for
//! MLT's and CMLT's block fill, `fill.rs`) and the margin [`FIT_MARGIN`]
//! for frames slower than the last. A reset frame then holds at least
//! one sample per block unless it renders less than the margin of its
//! last frame; the first frame, with nothing measured, starts at
//! [`MAX_PIXEL_BLOCK`] and refines pass by pass.
//!
//! A frame slower than that (a hitch, the scheduler) would leave blocks
//! black, so a reset frame with the fitted size begins with a *guard
//! pass*: one pass at [`GUARD_FACTOR`] times the fitted size (at most
//! [`MAX_GUARD_BLOCK`]), shared by
//! the workers (worker i renders the i-th W-th of its order, so together
//! they cover the image at about 1/16 of the forecast's samples), whose
//! samples weigh [`GUARD_WEIGHT`]: a pixel the frame's passes reach is
//! theirs (the guard's share of its weight below 10⁻³), one they do not
//! reach shows the guard's coarser block. Either way the frame is a
//! mixture of block-filtered images of its own camera, whose mean is the
//! image's.
//!
//! A block's sample lands at a point of a pass-wide lattice ([`Lattice`])
//! rather than independently: block b's position in its block is
//! `frac(Δ + b · α)`, α the generators of the two-dimensional R-sequence
//! and Δ a uniform shift drawn per worker, pass and frame. Each sample's
//! position stays uniform over its block and independent of the rest of
//! its stream, so every pixel's estimate is as unbiased as before; what
//! changes is that neighbouring blocks' samples are spread over their
//! blocks evenly instead of independently, so that along an edge of the
//! image inside the blocks (the ceiling light's, a wall's) the share of
//! samples on either side follows the share of the area. That share's
//! noise is much of a frame's mean's (its flicker): the trial's BDPT
//! reset frames at a fixed 3 000 samples a worker flicker 0.0157 and
//! 0.0156 at 320 × 180 and 640 × 360 against 0.0193 and 0.0180 with
//! independent positions (`bench/README.md`, frames). Only block passes
//! (k > 1: the frame hosts' dynamic resolution) do this; full-resolution
//! passes, and so every offline render, keep their streams bit for bit.

use core::ops::Range;

use glam::Vec2;

use crate::accel::Intersector;
use crate::film::Film;
use crate::integrator::{Settings, Tracer, bdpt, pt};
use crate::math::Rgb;
use crate::sampler::SampleStream;

use super::accumulation::Weights;

/// The coarsest block size, in pixels per side: the fit's range reaches
/// BDPT at 640 × 360 within 30 ms on a loaded machine (a few hundred
/// samples a worker), and its guard pass beyond.
pub const MAX_PIXEL_BLOCK: u32 = 64;

/// The share of its last frame's samples [`PixelBlock::Fit`] plans a frame
/// for: a frame up to 30 % slower than the last still completes its pass.
pub const FIT_MARGIN: f64 = 0.7;

/// A reset frame's guard pass is at this many times the fitted block size
/// (at most [`MAX_GUARD_BLOCK`]).
pub const GUARD_FACTOR: u32 = 4;

/// The coarsest guard pass, in pixels per side: coarser than
/// [`MAX_PIXEL_BLOCK`], so that a frame fitted at the coarsest size (MLT's
/// block fill at 640 × 360 under load) still has a guard (6 blocks at
/// 640 × 360).
pub const MAX_GUARD_BLOCK: u32 = GUARD_FACTOR * MAX_PIXEL_BLOCK;

/// The weight of a guard pass's sample against a pass's (1): small enough
/// that a pixel the frame's passes reach is theirs (to 10⁻³), and the
/// whole weight of a pixel they do not.
pub const GUARD_WEIGHT: f32 = 1e-3;

/// The pass number of the guard passes' random streams, which no
/// worker's passes reach.
pub(crate) const GUARD_PASS: u64 = u64::MAX;

/// The stream index of a pass's [`Lattice`] shift: no block's
/// (`b | k << 48`, k ≤ [`MAX_GUARD_BLOCK`]) nor pixel's.
const LATTICE_INDEX: u64 = u64::MAX;

/// The lattice's generators α in 32-bit fixed point: the
/// two-dimensional R-sequence's (Roberts: 1 / φ₂ and 1 / φ₂², φ₂ the
/// real root of x³ = x + 1), whose runs of points, unlike the golden
/// ratio's, spread evenly over the square in both coordinates at once.
const GENERATORS: [u32; 2] = [3_242_174_889, 2_447_445_413];

/// A pass's rank-1 lattice of positions in the blocks: block b's is
/// `frac(Δ + b · α)` (see the module docs), in 32-bit fixed point, so
/// exact and the same on every target.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Lattice {
    shift: [u32; 2],
}

impl Lattice {
    /// The lattice of pass `pass` of frame seed `seed`: its shift Δ drawn
    /// from a stream no sample uses.
    pub(crate) fn new(seed: u64, pass: u64) -> Self {
        let mut rng = SampleStream::new(seed, pass, LATTICE_INDEX);
        // A stream's 24 bits, high: `point` keeps the high 24 bits of
        // Δ + b α, uniform over their 2²⁴ values since Δ's are.
        Lattice {
            shift: core::array::from_fn(|_| ((rng.next_f32() * 16_777_216.0) as u32) << 8),
        }
    }

    /// Block `b`'s position in its block, each coordinate in [0, 1)
    /// with the streams' 24 bits.
    pub(crate) fn point(&self, b: u64) -> Vec2 {
        // b mod 2³² is exact: (Δ + b α) mod 1 in fixed point.
        let b = b as u32;
        let [x, y] = core::array::from_fn(|i| {
            let x = self.shift[i].wrapping_add(b.wrapping_mul(GENERATORS[i]));
            (x >> 8) as f32 * (1.0 / 16_777_216.0)
        });
        Vec2::new(x, y)
    }
}

/// How many pixels one PT or BDPT sample fills
/// ([`super::Renderer::set_pixel_block`]; see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelBlock {
    /// Every pass at block size k (1 ..= [`MAX_PIXEL_BLOCK`]): 1 is the
    /// full resolution (the default: an offline render's image); k > 1
    /// estimates the image box-filtered over k × k blocks, P / k² samples a
    /// pass — dynamic resolution chosen by the host.
    Fixed(u32),
    /// The block size chosen at every pass start from the worker's
    /// measured samples (module docs): the finest grid the accumulation
    /// can fill, so that a frame below one full-resolution pass still
    /// shows a full image.
    Fit,
}

impl Default for PixelBlock {
    fn default() -> Self {
        PixelBlock::Fixed(1)
    }
}

impl PixelBlock {
    /// Checks a fixed size: 1 ..= [`MAX_PIXEL_BLOCK`].
    pub fn validate(&self) -> Result<(), &'static str> {
        match *self {
            PixelBlock::Fixed(k) if !(1..=MAX_PIXEL_BLOCK).contains(&k) => {
                Err("the pixel block must be 1 ..= 64 pixels")
            }
            _ => Ok(()),
        }
    }
}

/// The k × k blocks over a `width × height` image, row-major; the last
/// column and row are cut by the image's edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct BlockGrid {
    width: u32,
    height: u32,
    k: u32,
    columns: u32,
}

impl BlockGrid {
    pub(crate) fn new(width: u32, height: u32, k: u32) -> Self {
        BlockGrid {
            width,
            height,
            k,
            columns: width.div_ceil(k),
        }
    }

    /// The number of blocks: the samples of one pass.
    pub(crate) fn count(&self) -> u64 {
        self.columns as u64 * self.height.div_ceil(self.k) as u64
    }

    /// The pixels of block `b` (row-major index), cut by the image.
    pub(crate) fn pixels(&self, b: u64) -> (Range<u32>, Range<u32>) {
        let (bx, by) = (
            (b % self.columns as u64) as u32,
            (b / self.columns as u64) as u32,
        );
        self.span(bx * self.k, by * self.k)
    }

    fn span(&self, x0: u32, y0: u32) -> (Range<u32>, Range<u32>) {
        (
            x0..(x0 + self.k).min(self.width),
            y0..(y0 + self.k).min(self.height),
        )
    }
}

/// The finest block size (1 ..= [`MAX_PIXEL_BLOCK`]) whose grid over a
/// `width × height` image has at most `capacity` blocks;
/// [`MAX_PIXEL_BLOCK`] when none has.
pub(crate) fn fit(width: u32, height: u32, capacity: f64) -> u32 {
    (1..MAX_PIXEL_BLOCK)
        .find(|&k| BlockGrid::new(width, height, k).count() as f64 <= capacity)
        .unwrap_or(MAX_PIXEL_BLOCK)
}

/// The order in which a pass visits its `count` pixels or blocks: its j-th
/// sample is at `((j + offset) mod count) · stride mod count` (stride
/// coprime with count: a permutation; see `Renderer::stride`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PassOrder {
    pub(crate) count: u64,
    pub(crate) stride: u64,
    pub(crate) offset: u64,
}

impl PassOrder {
    /// The pixel or block of the pass's `j`-th sample.
    #[inline]
    pub(crate) fn at(&self, j: u64) -> u64 {
        if self.stride == 1 && self.offset == 0 {
            j
        } else {
            (j + self.offset) % self.count * self.stride % self.count
        }
    }
}

/// Renders the samples `range` of pass `pass` at block size `grid` (k > 1)
/// into `film`, each of weight `weight` (1, or a guard pass's) spread
/// over its block in `weights` and in the film, by path tracing (`pt`) or
/// BDPT, BDPT's splats at their own pixels times the same weight. The random stream of a sample depends only on `(seed, pass, k,
/// block)`, apart from the full-resolution passes' streams, and its
/// position in the block is the pass's [`Lattice`] point of the block.
#[allow(clippy::too_many_arguments)]
pub(crate) fn render_block_samples<I: Intersector>(
    tracer: &mut Tracer<'_, I>,
    settings: &Settings,
    pt: bool,
    paths: &mut bdpt::PathStorage,
    (seed, pass, weight): (u64, u64, f32),
    (range, order, grid): (Range<u64>, PassOrder, BlockGrid),
    film: &mut Film,
    weights: &mut Weights,
) {
    let lattice = Lattice::new(seed, pass);
    for j in range {
        let b = order.at(j);
        let (xs, ys) = grid.pixels(b);
        // The block size in the stream's index: blocks never share a
        // stream with the pixels of a full-resolution pass.
        let mut rng = SampleStream::new(seed, pass, b | (grid.k as u64) << 48);
        let u = lattice.point(b);
        let raster = Vec2::new(
            xs.start as f32 + u.x * xs.len() as f32,
            ys.start as f32 + u.y * ys.len() as f32,
        );
        let l = if pt {
            let ray = tracer.camera_ray(raster, rng.next_2d());
            pt::radiance(tracer, settings, ray, &mut rng)
        } else {
            let mut l_pixel = Rgb::ZERO;
            bdpt::sample_each(
                tracer,
                settings,
                paths,
                raster,
                &mut rng,
                |_, _, l, splat| match splat {
                    Some(r) => film.add_splat(r, l * weight),
                    None => l_pixel += l,
                },
            );
            l_pixel
        };
        // One weight for the film and the weights, so that a pixel is the
        // weighted mean of its samples (its own f32 rounding in both).
        let w = weight / (xs.len() * ys.len()) as f32;
        film.add_sample_area(xs.clone(), ys.clone(), l, w as f64);
        weights.add_area(xs, ys, grid.width, w, weight);
        tracer.stats.samples += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_tile_the_image_once() {
        for (w, h, k) in [
            (7, 5, 1),
            (7, 5, 2),
            (7, 5, 3),
            (320, 180, 16),
            (5, 3, 8),
            (640, 360, 64),
        ] {
            let g = BlockGrid::new(w, h, k);
            let mut hits = alloc::vec![0u32; (w * h) as usize];
            for b in 0..g.count() {
                let (xs, ys) = g.pixels(b);
                assert!(!xs.is_empty() && !ys.is_empty());
                for y in ys {
                    for x in xs.clone() {
                        hits[(y * w + x) as usize] += 1;
                    }
                }
            }
            assert!(hits.iter().all(|&n| n == 1), "{w}x{h} at {k}");
        }
    }

    #[test]
    fn fit_is_the_finest_grid_within_the_capacity() {
        // 320 × 180: 57 600 pixels; k = 3: 107 × 60 = 6 420 blocks.
        assert_eq!(fit(320, 180, 57_600.0), 1);
        assert_eq!(fit(320, 180, 57_599.0), 2);
        assert_eq!(fit(320, 180, 6_420.0), 3);
        assert_eq!(fit(320, 180, 6_419.0), 4);
        assert_eq!(fit(320, 180, 0.0), MAX_PIXEL_BLOCK);
    }

    #[test]
    fn a_pass_order_is_a_permutation() {
        let order = PassOrder {
            count: 391,
            stride: 241,
            offset: 195,
        };
        let mut seen = alloc::vec![false; 391];
        for j in 0..391 {
            let i = order.at(j) as usize;
            assert!(!seen[i]);
            seen[i] = true;
        }
    }

    /// The counts of `points` in the cells of a 4 × 4 grid over the unit
    /// square.
    fn cells(points: impl Iterator<Item = Vec2>) -> [u32; 16] {
        let mut cells = [0u32; 16];
        for p in points {
            assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
            cells[(p.y * 4.0) as usize * 4 + (p.x * 4.0) as usize] += 1;
        }
        cells
    }

    #[test]
    fn a_pass_lattice_spreads_runs_of_blocks_evenly_and_each_block_uniformly() {
        // Any run of 1 024 blocks of a pass (a partial pass's blocks are
        // such runs' positions) puts 64 positions in each cell, to within
        // the lattice's discrepancy (at most ±6 over 2 000 random shifts
        // and runs); independent positions (the sample streams' before)
        // vary by about ±8 (binomial), and here by more than the bound in
        // some cell: the negative control.
        let lattice = Lattice::new(7, 3);
        for start in [0u64, 1_000, 123_456] {
            let c = cells((start..start + 1_024).map(|b| lattice.point(b)));
            assert!(c.iter().all(|&n| n.abs_diff(64) <= 7), "{c:?}");
            let c = cells((start..start + 1_024).map(|b| SampleStream::new(7, 3, b).next_2d()));
            assert!(c.iter().any(|&n| n.abs_diff(64) > 7), "{c:?}");
        }
        // One block's position over the passes (and frames) is uniform:
        // the shift is drawn afresh for each, so each pixel's estimate is
        // unbiased. 4 096 passes: 256 a cell, ±16 (binomial); a shift
        // that did not depend on the pass would put all in one cell.
        for b in [0u64, 77, 1 << 20] {
            let c = cells((0..4_096).map(|pass| Lattice::new(7, pass).point(b)));
            assert!(c.iter().all(|&n| n.abs_diff(256) <= 64), "{c:?}");
            let c = cells((0..4_096).map(|seed| Lattice::new(seed, 3).point(b)));
            assert!(c.iter().all(|&n| n.abs_diff(256) <= 64), "{c:?}");
        }
    }

    #[test]
    fn a_fixed_block_is_checked() {
        assert!(PixelBlock::Fixed(0).validate().is_err());
        assert!(PixelBlock::Fixed(MAX_PIXEL_BLOCK + 1).validate().is_err());
        assert!(PixelBlock::Fixed(MAX_PIXEL_BLOCK).validate().is_ok());
        assert!(PixelBlock::Fit.validate().is_ok());
    }
}

//! The film: per-pixel sums of camera-path samples plus a splat layer for
//! contributions that land anywhere (light tracing, BDPT t = 1, Metropolis).
//!
//! Films are mergeable: workers render into their own film and the host sums
//! them ([`Film::merge`]) in a fixed order, which keeps the result
//! independent of scheduling. Sums are kept in f64 so that long renders do
//! not lose the last digits of noise to f32 rounding.
//!
//! Pixel filter: box (one sample belongs to the pixel it falls in), which is
//! what the references use.
//!
//! What a resolve writes: [`PixelFormat`] (`format.rs`), with the 8-bit
//! sRGB encoding by table (`srgb.rs`) and the binary16 encoding
//! (`half.rs`).

mod format;
pub mod half;
pub mod srgb;

pub use format::PixelFormat;

use alloc::vec;
use alloc::vec::Vec;
use core::ops::Range;

use glam::Vec2;

use crate::math::Rgb;

/// Accumulated radiance estimates of one image.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    width: u32,
    height: u32,
    /// Sum of camera-path samples per pixel (RGB).
    sum: Vec<[f64; 3]>,
    /// Sum of splatted contributions per pixel (RGB).
    splat: Vec<[f64; 3]>,
    /// Number of passes (one sample per pixel each) accumulated.
    passes: u64,
    /// Samples rejected because they were NaN or infinite.
    nonfinite: u64,
}

/// A film's storage could not be allocated (`width × height` pixels of
/// [`Film::BYTES_PER_PIXEL`] bytes each, which the heap refused or which
/// overflows the address space).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FilmAllocError {
    /// Bytes the film needed (saturated at `u64::MAX`).
    pub bytes: u64,
}

impl core::fmt::Display for FilmAllocError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "out of memory: a film needs {} bytes", self.bytes)
    }
}

impl Film {
    /// Bytes of storage per pixel: the sum and the splat layer, three f64
    /// each.
    pub const BYTES_PER_PIXEL: u64 = 2 * 3 * 8;

    /// A black film of `width × height` pixels, or an error when the heap
    /// cannot hold it: the fallible form of [`Film::new`] for sizes that
    /// come from input (a 65536² film needs 206 GB).
    pub fn try_new(width: u32, height: u32) -> Result<Self, FilmAllocError> {
        let n = width as u64 * height as u64;
        let err = FilmAllocError {
            bytes: n.saturating_mul(Self::BYTES_PER_PIXEL),
        };
        let n = usize::try_from(n).map_err(|_| err)?;
        let zeroed = |n: usize| -> Result<Vec<[f64; 3]>, FilmAllocError> {
            let mut v = Vec::new();
            v.try_reserve_exact(n).map_err(|_| err)?;
            v.resize(n, [0.0; 3]);
            Ok(v)
        };
        Ok(Film {
            width,
            height,
            sum: zeroed(n)?,
            splat: zeroed(n)?,
            passes: 0,
            nonfinite: 0,
        })
    }

    /// A black film of `width × height` pixels. Aborts when the heap cannot
    /// hold it; sizes from input go through [`Film::try_new`].
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            sum: vec![[0.0; 3]; n],
            splat: vec![[0.0; 3]; n],
            passes: 0,
            nonfinite: 0,
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Number of completed passes.
    pub fn passes(&self) -> u64 {
        self.passes
    }

    /// Samples dropped as non-finite (a correct renderer keeps this at 0;
    /// the stability tests assert it).
    pub fn nonfinite(&self) -> u64 {
        self.nonfinite
    }

    /// Back to black (no passes, nothing splatted), keeping the storage.
    pub fn clear(&mut self) {
        self.sum.fill([0.0; 3]);
        self.splat.fill([0.0; 3]);
        self.passes = 0;
        self.nonfinite = 0;
    }

    /// Multiplies every sum (samples and splats) by `factor`, keeping the
    /// pass count: the decay of an exponentially weighted accumulation
    /// (`renderer::Accumulation::Decay`).
    pub fn scale(&mut self, factor: f64) {
        for p in self.sum.iter_mut().chain(self.splat.iter_mut()) {
            for c in p {
                *c *= factor;
            }
        }
    }

    /// Pixel `index`'s camera-sample sum and splat sum, apart: a merge of
    /// several films that adds each layer on its own and the two at the
    /// end (as [`Film::merge`] then [`Film::resolve`] do) rounds the same.
    pub fn pixel_parts(&self, index: usize) -> ([f64; 3], [f64; 3]) {
        (self.sum[index], self.splat[index])
    }

    /// The camera-sample sums and the splat sums of every pixel, row-major:
    /// what a resolve merges, a run of pixels at a time.
    pub fn layers(&self) -> (&[[f64; 3]], &[[f64; 3]]) {
        (&self.sum, &self.splat)
    }

    /// The unscaled total (samples + splats) of pixel `index` (row-major),
    /// in f64: what a host merging several films without a copy sums.
    ///
    /// # Panics
    /// When `index` ≥ width · height.
    #[inline]
    pub fn pixel_total(&self, index: usize) -> [f64; 3] {
        let (s, p) = (self.sum[index], self.splat[index]);
        [s[0] + p[0], s[1] + p[1], s[2] + p[2]]
    }

    /// Records that one more pass (one sample in every pixel) is complete.
    pub fn end_pass(&mut self) {
        self.passes += 1;
    }

    /// Adds a camera-path sample to pixel `(x, y)`.
    #[inline]
    pub fn add_sample(&mut self, x: u32, y: u32, l: Rgb) {
        if !l.is_finite() {
            self.nonfinite += 1;
            return;
        }
        let s = &mut self.sum[y as usize * self.width as usize + x as usize];
        s[0] += l.r as f64;
        s[1] += l.g as f64;
        s[2] += l.b as f64;
    }

    /// Asks the cache for the splat pixel of `raster` ahead of an
    /// [`Film::add_splat`] there (a hint: no effect on any value; nothing
    /// outside the image, nothing on targets without a prefetch). A large
    /// step lands on a random pixel of a film larger than the L2 cache, so
    /// its splat otherwise waits for memory.
    #[inline]
    pub fn prefetch_splat(&self, raster: Vec2) {
        #[cfg(target_arch = "x86_64")]
        {
            use core::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            if !(raster.x >= 0.0 && raster.y >= 0.0) {
                return;
            }
            let (x, y) = (raster.x as u32, raster.y as u32);
            if x >= self.width || y >= self.height {
                return;
            }
            let p = self.splat[y as usize * self.width as usize + x as usize]
                .as_ptr()
                .cast::<i8>();
            // SAFETY: SSE is part of the x86_64 baseline; a prefetch reads
            // nothing the program can observe and never faults. The pixel's
            // 24 bytes may straddle two cache lines: ask for both ends.
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(p);
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(23));
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = raster;
    }

    /// Splats a contribution at continuous raster position `raster`; points
    /// outside the image are ignored.
    #[inline]
    pub fn add_splat(&mut self, raster: Vec2, l: Rgb) {
        if !l.is_finite() {
            self.nonfinite += 1;
            return;
        }
        if !(raster.x >= 0.0 && raster.y >= 0.0) {
            return;
        }
        let (x, y) = (raster.x as u32, raster.y as u32);
        if x >= self.width || y >= self.height {
            return;
        }
        let s = &mut self.splat[y as usize * self.width as usize + x as usize];
        s[0] += l.r as f64;
        s[1] += l.g as f64;
        s[2] += l.b as f64;
    }

    /// Adds a camera-path sample times `weight` to each of the pixels `xs
    /// × ys`: a sample of a pass at a coarser pixel grid, which fills its
    /// block of m pixels with weight 1 / m each (`renderer::PixelBlock`).
    /// A non-finite `l` is counted and dropped.
    pub fn add_sample_area(&mut self, xs: Range<u32>, ys: Range<u32>, l: Rgb, weight: f64) {
        if !l.is_finite() {
            self.nonfinite += 1;
            return;
        }
        let v = [
            l.r as f64 * weight,
            l.g as f64 * weight,
            l.b as f64 * weight,
        ];
        add_area(&mut self.sum, self.width, xs, ys, v);
    }

    /// Adds another film of the same size into this one.
    ///
    /// # Panics
    /// When the sizes differ (a programming error of the host).
    pub fn merge(&mut self, other: &Film) {
        assert!(
            self.width == other.width && self.height == other.height,
            "merging films of different sizes"
        );
        for (a, b) in self.sum.iter_mut().zip(&other.sum) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
        for (a, b) in self.splat.iter_mut().zip(&other.splat) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
        self.passes += other.passes;
        self.nonfinite += other.nonfinite;
    }

    /// The image estimate: (samples + splats) / passes per pixel, row-major,
    /// row 0 at the top. Black before the first pass.
    pub fn resolve(&self) -> Vec<Rgb> {
        let inv = if self.passes == 0 {
            0.0
        } else {
            1.0 / self.passes as f64
        };
        self.resolve_scaled(inv)
    }

    /// (samples + splats) · `scale` per pixel, row-major, row 0 at the top,
    /// ignoring the pass count: for estimators whose normalisation is not
    /// "per pass". Metropolis light transport records unit-luminance splats
    /// and resolves with b · pixels / mutations
    /// ([`crate::mlt::image_scale`]).
    pub fn resolve_scaled(&self, scale: f64) -> Vec<Rgb> {
        self.sum
            .iter()
            .zip(&self.splat)
            .map(|(s, p)| {
                Rgb::new(
                    ((s[0] + p[0]) * scale) as f32,
                    ((s[1] + p[1]) * scale) as f32,
                    ((s[2] + p[2]) * scale) as f32,
                )
            })
            .collect()
    }
}

/// Adds `v` to the pixels `xs × ys` of a row-major layer `width` wide.
fn add_area(layer: &mut [[f64; 3]], width: u32, xs: Range<u32>, ys: Range<u32>, v: [f64; 3]) {
    for y in ys {
        let row = y as usize * width as usize;
        for p in &mut layer[row + xs.start as usize..row + xs.end as usize] {
            for c in 0..3 {
                p[c] += v[c];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn try_new_refuses_what_the_heap_cannot_hold() {
        // (2^32 − 1)² pixels overflow any address space: an error, not an
        // abort, and it says how much was asked for.
        let e = Film::try_new(u32::MAX, u32::MAX).unwrap_err();
        assert_eq!(
            e.bytes,
            (u32::MAX as u64 * u32::MAX as u64).saturating_mul(Film::BYTES_PER_PIXEL)
        );
        let f = Film::try_new(3, 2).unwrap();
        assert_eq!(f, Film::new(3, 2));
    }

    #[test]
    fn resolve_divides_by_passes_and_merges() {
        let mut a = Film::new(2, 1);
        a.add_sample(0, 0, Rgb::splat(1.0));
        a.add_splat(Vec2::new(1.5, 0.5), Rgb::splat(4.0));
        a.add_splat(Vec2::new(2.5, 0.5), Rgb::splat(100.0));
        a.add_sample(1, 0, Rgb::splat(f32::NAN));
        a.end_pass();
        let mut b = Film::new(2, 1);
        b.add_sample(0, 0, Rgb::splat(3.0));
        b.end_pass();
        a.merge(&b);
        let img = a.resolve();
        assert_eq!(img[0], Rgb::splat(2.0));
        assert_eq!(img[1], Rgb::splat(2.0));
        assert_eq!(a.nonfinite(), 1);
    }

    #[test]
    fn an_area_sample_spreads_its_value_over_its_pixels_and_nothing_else() {
        let mut f = Film::new(4, 3);
        f.add_sample_area(1..3, 1..3, Rgb::splat(8.0), 0.25);
        f.add_sample_area(0..1, 0..1, Rgb::splat(f32::INFINITY), 1.0);
        for y in 0..3 {
            for x in 0..4 {
                let (s, p) = f.pixel_parts(y * 4 + x);
                let inside = (1..3).contains(&x) && (1..3).contains(&y);
                assert_eq!(s[0], if inside { 2.0 } else { 0.0 }, "sample at ({x}, {y})");
                assert_eq!(p, [0.0; 3]);
            }
        }
        assert_eq!(f.nonfinite(), 1);
    }
}

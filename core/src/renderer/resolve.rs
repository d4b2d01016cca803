//! The resolve a host splits by rows: [`Renderer::resolve_rows`] writes
//! rows `[y0, y1)` of the merged image straight into the host's buffer in a
//! [`PixelFormat`], so host threads can each resolve a band of rows at the
//! same time (the workers are only read).

use core::ops::Range;

use super::{Layers, RenderError, RenderWorker, Renderer, Totals};
use crate::film::PixelFormat;

/// Pixels merged at a time: their sums sit on the stack (64 · 80 bytes)
/// while each worker's film adds its run of them, so every film is read in
/// runs of 3 KB, and nothing is allocated.
const RUN: usize = 64;

impl Renderer {
    /// Writes rows `rows` of the image — `workers`' films merged in the
    /// given order and scaled as [`Renderer::resolve`] scales them — into
    /// `out` as `format`: row `rows.start` at `out[0..]`, each next row
    /// `row_stride` bytes further (0 = packed: width · `format.bytes()`).
    /// Every pixel is the value `resolve` hands out, bit for bit, written as
    /// [`PixelFormat::write`] writes it, so any split of the rows gives the
    /// same bytes as one call over the whole image. Allocates nothing.
    ///
    /// `workers` is iterated once to count the accumulation and then once
    /// per run of pixels (a cloned iterator), so the host holds every
    /// worker for the whole call; rows resolved by different calls agree
    /// only if no worker renders in between.
    ///
    /// [`RenderError::Output`] when `rows` leaves the image, the stride is
    /// shorter than a row, or `out` is shorter than the rows need;
    /// [`RenderError::Worker`] for a worker of another renderer. Nothing is
    /// written then.
    pub fn resolve_rows<'w, W>(
        &self,
        workers: W,
        rows: Range<u32>,
        format: PixelFormat,
        out: &mut [u8],
        row_stride: usize,
    ) -> Result<(), RenderError>
    where
        W: IntoIterator<Item = &'w RenderWorker>,
        W::IntoIter: Clone,
    {
        let workers = workers.into_iter();
        let mut totals = Totals::default();
        for w in workers.clone() {
            if w.renderer != self.id {
                return Err(RenderError::Worker);
            }
            totals.add(self, w);
        }
        let (width, height) = (self.camera.width() as usize, self.camera.height());
        if rows.start > rows.end || rows.end > height {
            return Err(RenderError::Output("the rows leave the image"));
        }
        let row = width * format.bytes();
        let stride = check_buffer(rows.len(), row, row_stride, out.len())?;
        let scale = self.scale(&totals);
        let current = workers.filter(|w| self.is_current(w));
        let px = format.bytes();
        for (y, line) in rows.zip(out.chunks_mut(stride)) {
            let first = y as usize * width;
            for x0 in (0..width).step_by(RUN) {
                let n = RUN.min(width - x0);
                let mut sums = [Layers::default(); RUN];
                for w in current.clone() {
                    for (k, s) in sums[..n].iter_mut().enumerate() {
                        s.add(w, first + x0 + k);
                    }
                }
                let pixels = line[x0 * px..(x0 + n) * px].chunks_exact_mut(px);
                // The pixel `resolve` hands out: its own sample weight for
                // PT and BDPT (a frame may end inside a pass).
                for (s, p) in sums.iter().zip(pixels) {
                    format.write(self.pixel(s, &totals, scale), p);
                }
            }
        }
        Ok(())
    }
}

/// The stride of `rows` rows of `row` bytes at `row_stride` (0 = packed)
/// in a buffer of `len` bytes, or why they do not fit. The last row needs
/// only its own bytes, not a whole stride.
pub(crate) fn check_buffer(
    rows: usize,
    row: usize,
    row_stride: usize,
    len: usize,
) -> Result<usize, RenderError> {
    let stride = if row_stride == 0 { row } else { row_stride };
    if stride < row {
        return Err(RenderError::Output("the row stride is shorter than a row"));
    }
    let needed = match rows {
        0 => 0,
        n => (n - 1)
            .checked_mul(stride)
            .and_then(|b| b.checked_add(row))
            .ok_or(RenderError::Output(
                "the rows at this stride overflow the address space",
            ))?,
    };
    if len < needed {
        return Err(RenderError::Output(
            "the buffer is shorter than the rows need",
        ));
    }
    Ok(stride.max(1))
}

//! The host's buffers for the auxiliary outputs: one [`AovLayer`] per
//! output, each rows of pixels of a few [`AovFormat`] channels.

use crate::film::half::f16_bits;
use crate::renderer::RenderError;

/// The element type of an auxiliary output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AovFormat {
    /// `f32`, in the machine's byte order.
    F32,
    /// IEEE binary16 (half), rounded to nearest even
    /// ([`crate::film::half::f16_bits`]), in the machine's byte order.
    F16,
}

impl AovFormat {
    /// Bytes of one channel.
    pub const fn bytes(self) -> usize {
        match self {
            AovFormat::F32 => 4,
            AovFormat::F16 => 2,
        }
    }
}

/// One output's rows in the host's buffer: the first row of the call at
/// `data[0..]`, each next one `row_stride` bytes further (0 = packed:
/// width · channels · `format.bytes()`). No alignment is asked of `data`.
#[derive(Debug)]
pub struct AovLayer<'a> {
    /// The bytes.
    pub data: &'a mut [u8],
    /// Bytes from one row to the next; 0 = packed.
    pub row_stride: usize,
    /// The element type.
    pub format: AovFormat,
}

impl<'a> AovLayer<'a> {
    /// Packed rows of `format` in `data`.
    pub fn packed(data: &'a mut [u8], format: AovFormat) -> Self {
        AovLayer {
            data,
            row_stride: 0,
            format,
        }
    }

    /// Checks that `rows` rows of `width` pixels of `channels` fit, and
    /// settles the stride.
    pub(super) fn check(
        &mut self,
        rows: usize,
        width: usize,
        channels: usize,
    ) -> Result<(), RenderError> {
        let row = width * channels * self.format.bytes();
        self.row_stride =
            crate::renderer::check_buffer(rows, row, self.row_stride, self.data.len())?;
        Ok(())
    }

    /// Writes a run of pixels from pixel `x0` of the call's row `row` on:
    /// `values` holds their `channels` channels, pixel after pixel.
    #[inline(always)]
    pub(super) fn put_run(&mut self, row: usize, x0: usize, channels: usize, values: &[f32]) {
        let bytes = self.format.bytes();
        let at = row * self.row_stride + x0 * channels * bytes;
        let run = &mut self.data[at..at + values.len() * bytes];
        match self.format {
            AovFormat::F32 => {
                for (v, p) in values.iter().zip(run.chunks_exact_mut(4)) {
                    p.copy_from_slice(&v.to_ne_bytes());
                }
            }
            AovFormat::F16 => {
                for (v, p) in values.iter().zip(run.chunks_exact_mut(2)) {
                    p.copy_from_slice(&f16_bits(*v).to_ne_bytes());
                }
            }
        }
    }
}

/// The outputs one call writes; `None` = not wanted (not computed either:
/// the albedo's BSDF samples are skipped without it).
#[derive(Debug, Default)]
pub struct AovBuffers<'a> {
    /// Albedo, 3 channels (linear RGB in [0, 1]).
    pub albedo: Option<AovLayer<'a>>,
    /// Shading normal, 3 channels (world space, unit, facing the camera).
    pub normal: Option<AovLayer<'a>>,
    /// Depth, 1 channel (camera-space z).
    pub depth: Option<AovLayer<'a>>,
    /// Motion vector, 2 channels (pixels, to the previous frame).
    pub motion: Option<AovLayer<'a>>,
}

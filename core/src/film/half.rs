//! IEEE 754 binary16 ("half") encoding of `f32`, rounded to nearest with
//! ties to even — what a GPU's `f32 → f16` conversion (F16C's
//! `vcvtps2ph` with rounding mode 0) gives: the element type of the
//! RGBA16F resolve and of half-float auxiliary outputs. Overflow gives
//! ±∞, NaN stays a (quiet) NaN, tiny values become subnormals or ±0.

/// Bits of 65520, the midpoint between the largest half (65504) and 2¹⁶:
/// from here on (ties to even: 65504's mantissa is odd) a value rounds to
/// ∞.
const OVERFLOW: u32 = 0x477f_f000;
/// Bits of 2⁻¹⁴, the smallest normal half.
const MIN_NORMAL: u32 = 0x3880_0000;

/// The binary16 bits of `v`, rounded to nearest, ties to even.
#[inline(always)]
pub fn f16_bits(v: f32) -> u16 {
    let x = v.to_bits();
    let sign = ((x >> 16) & 0x8000) as u16;
    let a = x & 0x7fff_ffff;
    let magnitude = if a >= 0x7f80_0000 {
        // ∞ stays ∞; a NaN keeps its top payload bits and is made quiet.
        if a > 0x7f80_0000 {
            0x7e00 | ((a >> 13) & 0x3ff) as u16
        } else {
            0x7c00
        }
    } else if a >= OVERFLOW {
        0x7c00
    } else if a < MIN_NORMAL {
        // A subnormal half counts units of 2⁻²⁴, which is the ulp of f32
        // in [0.5, 1): adding 0.5 makes the f32 addition round to that
        // unit (to nearest, ties to even), and the mantissa bits of the
        // sum above 0.5 are the count (2¹⁰ = the smallest normal half).
        ((f32::from_bits(a) + 0.5).to_bits() - 0x3f00_0000) as u16
    } else {
        // Normal: rebias the exponent from 127 to 15 (subtract 112 << 23)
        // and round the 13 dropped mantissa bits to nearest, ties to even
        // (add 0xfff, plus one when the kept mantissa is odd); a carry out
        // of the mantissa bumps the exponent, which is the right rounding
        // at a binade's end.
        let odd = (a >> 13) & 1;
        ((a - (112 << 23) + 0xfff + odd) >> 13) as u16
    };
    sign | magnitude
}

#[cfg(test)]
mod tests {
    use super::*;
    use ::half::f16;

    /// Every half value's neighbourhood: the value itself, the midpoints to
    /// its neighbours and one f32 ulp either side of those — every rounding
    /// boundary of the encoding.
    #[test]
    fn every_rounding_boundary_matches_the_half_crate() {
        let check = |v: f32| {
            let want = f16::from_f32(v);
            let got = f16_bits(v);
            if want.is_nan() {
                assert!(f16::from_bits(got).is_nan(), "{v:e}");
            } else {
                assert_eq!(got, want.to_bits(), "{v:e} ({:#x})", v.to_bits());
            }
        };
        for h in 0..=u16::MAX {
            let v = f16::from_bits(h).to_f32();
            if v.is_nan() {
                check(v);
                continue;
            }
            check(v);
            let next = f16::from_bits(h.wrapping_add(1)).to_f32();
            if next.is_finite() && v.is_finite() && next.signum() == v.signum() {
                let mid = (f64::from(v) + f64::from(next)) / 2.0;
                let mid = mid as f32; // exact: one bit more than a half
                for m in [
                    mid,
                    f32::from_bits(mid.to_bits() - 1),
                    f32::from_bits(mid.to_bits() + 1),
                ] {
                    check(m);
                }
            }
        }
        // Past the largest half (and its negative), and a stride over all
        // floats.
        for v in [65504.0f32, 65519.996, 65520.0, 65536.0, 1e10, f32::MAX] {
            check(v);
            check(-v);
        }
        for bits in (0..=u32::MAX).step_by(4099) {
            check(f32::from_bits(bits));
        }
    }
}

//! Portable Float Map images, read as Mitsuba 3 reads them
//! (`Bitmap::read_pfm`): `PF` (RGB) or `Pf` (grey), width, height and a
//! scale as whitespace-separated ASCII tokens, one whitespace byte, then
//! 32-bit floats row by row from the bottom of the image up. A negative or
//! zero scale means little-endian floats, a positive one big-endian; every
//! value is multiplied by |scale| (Mitsuba does the same when it is not 1).
//! The image crate has no PFM decoder.

use cmlt::math::Rgb;

use crate::input::MAX_IMAGE_SIDE;

/// Whether `bytes` start like a PFM file (Mitsuba sniffs the same three
/// bytes).
pub(crate) fn is_pfm(bytes: &[u8]) -> bool {
    bytes.len() >= 3
        && bytes[0] == b'P'
        && (bytes[1] == b'F' || bytes[1] == b'f')
        && bytes[2].is_ascii_whitespace()
}

/// Decodes a PFM file's bytes into its width, height and linear texels
/// (row 0 at the top; grey replicated into RGB). The error says what is
/// wrong, without the file name.
pub(crate) fn decode_pfm(bytes: &[u8]) -> Result<(u32, u32, Vec<Rgb>), String> {
    if !is_pfm(bytes) {
        return Err("not a PFM file (it must start with 'PF' or 'Pf')".into());
    }
    let channels = if bytes[1] == b'F' { 3 } else { 1 };
    let mut at = 2;
    let mut token = |what: &str| -> Result<&str, String> {
        while at < bytes.len() && bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        let start = at;
        while at < bytes.len() && !bytes[at].is_ascii_whitespace() && at - start < 64 {
            at += 1;
        }
        if start == at || at >= bytes.len() {
            return Err(format!("invalid PFM header: no {what}"));
        }
        std::str::from_utf8(&bytes[start..at])
            .map_err(|_| format!("invalid PFM header: the {what} is not text"))
    };
    let side = |t: &str, what: &str| -> Result<u32, String> {
        match t.parse::<u32>() {
            Ok(v) if (1..=MAX_IMAGE_SIDE).contains(&v) => Ok(v),
            Ok(v) => Err(format!(
                "the PFM {what} is {v}, outside 1..={MAX_IMAGE_SIDE} texels"
            )),
            Err(_) => Err(format!("invalid PFM header: bad {what} '{t}'")),
        }
    };
    let w = side(token("width")?, "width")?;
    let h = side(token("height")?, "height")?;
    let t = token("scale")?;
    let scale: f32 = t
        .parse()
        .ok()
        .filter(|s: &f32| s.is_finite() && *s != 0.0)
        .ok_or_else(|| {
            format!("invalid PFM header: bad scale '{t}' (a finite, non-zero number)")
        })?;
    // One whitespace byte ends the header.
    let data = &bytes[at + 1..];
    // At most 2^15 · 2^15 · 3 floats: 12 GiB, more than a 32-bit usize.
    let count = (w as usize)
        .checked_mul(h as usize)
        .and_then(|p| p.checked_mul(channels))
        .filter(|c| c.checked_mul(4).is_some())
        .ok_or_else(|| format!("a {w}×{h} PFM image does not fit this machine's memory"))?;
    if data.len() < 4 * count {
        return Err(format!(
            "the PFM data is cut short: {} bytes for {w}×{h}×{channels} floats",
            data.len()
        ));
    }
    let little = scale < 0.0;
    let factor = scale.abs();
    let value = |i: usize| {
        let b: [u8; 4] = data[4 * i..4 * i + 4].try_into().unwrap();
        let v = if little {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        };
        if factor == 1.0 { v } else { v * factor }
    };
    let (w, h) = (w as usize, h as usize);
    let mut texels = Vec::with_capacity(w * h);
    for y in 0..h {
        // File rows go from the bottom up.
        let row = (h - 1 - y) * w;
        texels.extend((0..w).map(|x| {
            let i = (row + x) * channels;
            if channels == 3 {
                Rgb::new(value(i), value(i + 1), value(i + 2))
            } else {
                Rgb::splat(value(i))
            }
        }));
    }
    Ok((w as u32, h as u32, texels))
}

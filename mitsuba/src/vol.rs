//! Mitsuba's binary voxel grid files (`.vol`, read by `gridvolume`):
//! the bytes `VOL`, version 3, then little-endian int32 encoding (1 =
//! float32, the only one Mitsuba 3 reads), the resolution x, y, z and the
//! channel count, six floats of bounding box (min, max), then the voxels,
//! channels fastest, then x, y, z.

use cmlt::math::Rgb;

/// The header's size in bytes.
const HEADER: usize = 48;

/// A decoded grid: resolution, voxels (x fastest; one channel replicated
/// into grey) and the file's bounding box (min, max).
#[derive(Debug)]
pub(crate) struct VolFile {
    pub res: [u32; 3],
    pub voxels: Vec<Rgb>,
    pub bbox: ([f32; 3], [f32; 3]),
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}

fn f32_at(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}

/// Decodes a `.vol` file's bytes. The error says what is wrong, without
/// the file name. Sizes are checked against the bytes before any voxel
/// memory is taken, so the allocation is bounded by the file's size.
pub(crate) fn decode_vol(b: &[u8]) -> Result<VolFile, String> {
    if b.len() < HEADER || &b[..3] != b"VOL" {
        return Err(
            "not a Mitsuba volume file (it must start with 'VOL' and a 48-byte header)".into(),
        );
    }
    if b[3] != 3 {
        return Err(format!(
            "volume file version {} (only version 3 is read)",
            b[3]
        ));
    }
    let encoding = u32_at(b, 4);
    if encoding != 1 {
        return Err(format!(
            "volume file encoding {encoding} (only 1, float32, is read, as in Mitsuba 3)"
        ));
    }
    let res = [u32_at(b, 8), u32_at(b, 12), u32_at(b, 16)];
    let channels = u32_at(b, 20);
    if channels != 1 && channels != 3 {
        return Err(format!(
            "a volume texture's grid has {channels} channels (1 or 3 can be read)"
        ));
    }
    let count = res
        .iter()
        .try_fold(1u64, |n, &r| n.checked_mul(u64::from(r)))
        .filter(|&n| n > 0);
    let values = count.and_then(|n| n.checked_mul(u64::from(channels)));
    let want = values
        .and_then(|v| v.checked_mul(4))
        .and_then(|v| v.checked_add(HEADER as u64));
    if want != Some(b.len() as u64) {
        return Err(format!(
            "the grid's resolution {}×{}×{} with {channels} channels does not match the file's {} bytes",
            res[0],
            res[1],
            res[2],
            b.len()
        ));
    }
    let bbox = (
        [f32_at(b, 24), f32_at(b, 28), f32_at(b, 32)],
        [f32_at(b, 36), f32_at(b, 40), f32_at(b, 44)],
    );
    let data = &b[HEADER..];
    let voxels: Vec<Rgb> = if channels == 1 {
        data.chunks_exact(4)
            .map(|c| Rgb::splat(f32_at(c, 0)))
            .collect()
    } else {
        data.chunks_exact(12)
            .map(|c| Rgb::new(f32_at(c, 0), f32_at(c, 4), f32_at(c, 8)))
            .collect()
    };
    if let Some(i) = voxels.iter().position(|v| !v.is_finite()) {
        return Err(format!("voxel {i} is not finite"));
    }
    Ok(VolFile { res, voxels, bbox })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(res: [u32; 3], channels: u32, values: &[f32]) -> Vec<u8> {
        let mut b = b"VOL\x03".to_vec();
        for v in [1, res[0], res[1], res[2], channels] {
            b.extend(u32::to_le_bytes(v));
        }
        for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0].iter().chain(values) {
            b.extend(v.to_le_bytes());
        }
        b
    }

    #[test]
    fn reads_one_and_three_channels() {
        let g = decode_vol(&file([2, 1, 1], 1, &[0.25, 0.5])).unwrap();
        assert_eq!(g.res, [2, 1, 1]);
        assert_eq!(g.voxels, vec![Rgb::splat(0.25), Rgb::splat(0.5)]);
        let g = decode_vol(&file([1, 1, 1], 3, &[0.1, 0.2, 0.3])).unwrap();
        assert_eq!(g.voxels, vec![Rgb::new(0.1, 0.2, 0.3)]);
    }

    #[test]
    fn refuses_what_it_cannot_read() {
        let ok = file([2, 1, 1], 1, &[0.25, 0.5]);
        assert!(decode_vol(&ok).is_ok());
        // Cut short, one byte too many, zero or overflowing resolutions.
        assert!(decode_vol(&ok[..ok.len() - 1]).is_err());
        let mut long = ok.clone();
        long.push(0);
        assert!(decode_vol(&long).is_err());
        assert!(decode_vol(&file([0, 1, 1], 1, &[])).is_err());
        let huge = file([u32::MAX, u32::MAX, u32::MAX], 3, &[]);
        assert!(decode_vol(&huge).unwrap_err().contains("does not match"));
        // Wrong magic, version, encoding, channels; a NaN voxel.
        let mut bad = ok.clone();
        bad[0] = b'X';
        assert!(decode_vol(&bad).is_err());
        let mut bad = ok.clone();
        bad[3] = 2;
        assert!(decode_vol(&bad).unwrap_err().contains("version"));
        let mut bad = ok.clone();
        bad[4] = 2;
        assert!(decode_vol(&bad).unwrap_err().contains("encoding"));
        assert!(
            decode_vol(&file([1, 1, 1], 2, &[0.0, 0.0]))
                .unwrap_err()
                .contains("channels")
        );
        assert!(
            decode_vol(&file([1, 1, 1], 1, &[f32::NAN]))
                .unwrap_err()
                .contains("finite")
        );
        assert!(decode_vol(&[]).is_err());
    }
}

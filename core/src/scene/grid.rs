//! Voxel grids a surface reads at its position: Mitsuba's `volume`
//! texture over a `gridvolume` (a `constvolume` is a constant texture and
//! never gets here).
//!
//! A grid spans the unit cube [0, 1]³ of its local frame; `to_local` maps
//! a world point there (Mitsuba's `to_world` inverted, and with
//! `use_grid_bbox` the file's bounding box normalised to the unit cube).
//! Lookups follow Mitsuba 3's `gridvolume` (checked against it here and by
//! `cli/tests/suite/grid_textures.rs`): trilinear filtering at cell
//! centres (a voxel's value sits at (i + ½)/res) or the nearest voxel,
//! with the wrap mode applied to voxel indices.

#[cfg(feature = "alloc")]
use glam::{Affine3A, Vec3};

#[cfg(feature = "alloc")]
use crate::math::Rgb;

/// Index of a [`Grid`] in [`crate::scene::Scene::grids`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridId(pub u32);

/// How a grid interpolates between voxels (Mitsuba's `filter_type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum GridFilter {
    /// Trilinear interpolation between the eight nearest voxel centres.
    #[default]
    Trilinear,
    /// The voxel the point lies in.
    Nearest,
}

/// What a lookup outside [0, 1]³ reads (Mitsuba's `wrap_mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum GridWrap {
    /// The nearest voxel on the grid's boundary.
    #[default]
    Clamp,
    /// The grid tiled.
    Repeat,
    /// The grid tiled with every other copy mirrored.
    Mirror,
}

#[cfg(feature = "alloc")]
impl GridWrap {
    /// Voxel index `i` of an axis of `n` voxels, wrapped into 0..n.
    #[inline]
    fn index(self, i: i64, n: i64) -> usize {
        let i = match self {
            GridWrap::Clamp => i.clamp(0, n - 1),
            GridWrap::Repeat => i.rem_euclid(n),
            // Period 2n: the second half counts down again.
            GridWrap::Mirror => {
                let j = i.rem_euclid(2 * n);
                if j >= n { 2 * n - 1 - j } else { j }
            }
        };
        i as usize
    }
}

/// A grid of linear-RGB voxels (a one-channel file is stored grey) with
/// the transform, filter and wrap mode of the `gridvolume` that holds it.
///
/// Invariants (checked by [`Grid::new`]): every axis has at least one
/// voxel, the voxel count matches, every voxel is finite and
/// non-negative, and `to_local` is finite.
#[cfg(feature = "alloc")]
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    res: [u32; 3],
    voxels: alloc::vec::Vec<Rgb>,
    to_local: Affine3A,
    filter: GridFilter,
    wrap: GridWrap,
}

#[cfg(feature = "alloc")]
impl Grid {
    /// A grid of `res = [x, y, z]` voxels stored x fastest, then y, then z
    /// (the layout of Mitsuba's `.vol` files). Returns `None` when the
    /// sizes disagree or are zero, a voxel is negative or not finite, or
    /// `to_local` is not finite.
    pub fn new(
        res: [u32; 3],
        voxels: alloc::vec::Vec<Rgb>,
        to_local: Affine3A,
        filter: GridFilter,
        wrap: GridWrap,
    ) -> Option<Self> {
        let count = res
            .iter()
            .try_fold(1usize, |n, &r| n.checked_mul(r as usize));
        let ok = res.iter().all(|&r| r > 0)
            && count == Some(voxels.len())
            && voxels
                .iter()
                .all(|v| v.is_finite() && v.r >= 0.0 && v.g >= 0.0 && v.b >= 0.0)
            && to_local.is_finite();
        ok.then_some(Grid {
            res,
            voxels,
            to_local,
            filter,
            wrap,
        })
    }

    /// Voxels along x, y and z.
    pub fn resolution(&self) -> [u32; 3] {
        self.res
    }

    /// The voxels, x fastest, then y, then z.
    pub fn voxels(&self) -> &[Rgb] {
        &self.voxels
    }

    /// The map from world space to the grid's unit cube.
    pub fn to_local(&self) -> Affine3A {
        self.to_local
    }

    #[inline]
    fn voxel(&self, i: [i64; 3]) -> Rgb {
        let [nx, ny, nz] = self.res.map(i64::from);
        let x = self.wrap.index(i[0], nx);
        let y = self.wrap.index(i[1], ny);
        let z = self.wrap.index(i[2], nz);
        self.voxels[(z * ny as usize + y) * nx as usize + x]
    }

    /// The grid's value at world point `p`.
    pub fn eval(&self, p: Vec3) -> Rgb {
        let local = self.to_local.transform_point3(p);
        let res = Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32);
        let q = local * res;
        if !q.is_finite() {
            return Rgb::ZERO;
        }
        match self.filter {
            GridFilter::Nearest => self.voxel([q.x, q.y, q.z].map(|c| libm::floorf(c) as i64)),
            GridFilter::Trilinear => {
                // Voxel centres sit at (i + ½)/res.
                let c = q - Vec3::splat(0.5);
                let lo = Vec3::new(libm::floorf(c.x), libm::floorf(c.y), libm::floorf(c.z));
                let f = c - lo;
                let [x0, y0, z0] = [lo.x as i64, lo.y as i64, lo.z as i64];
                let mut sum = Rgb::ZERO;
                for dz in 0..2 {
                    let wz = if dz == 0 { 1.0 - f.z } else { f.z };
                    for dy in 0..2 {
                        let wy = if dy == 0 { 1.0 - f.y } else { f.y };
                        for dx in 0..2 {
                            let wx = if dx == 0 { 1.0 - f.x } else { f.x };
                            sum += self.voxel([x0 + dx, y0 + dy, z0 + dz]) * (wx * wy * wz);
                        }
                    }
                }
                sum
            }
        }
    }

    /// The largest voxel value per channel: what a reflectance read from
    /// the grid can reach (trilinear weights are convex).
    pub fn max(&self) -> Rgb {
        self.voxels.iter().fold(Rgb::ZERO, |m, v| {
            Rgb::new(m.r.max(v.r), m.g.max(v.g), m.b.max(v.b))
        })
    }
}

#[cfg(all(test, feature = "alloc"))]
mod tests {
    use super::*;
    use alloc::vec::Vec;

    /// A 4×1×1 ramp 0, 1, 2, 3 over the unit cube.
    fn ramp(filter: GridFilter, wrap: GridWrap) -> Grid {
        let v: Vec<Rgb> = (0..4).map(|i| Rgb::splat(i as f32)).collect();
        Grid::new([4, 1, 1], v, Affine3A::IDENTITY, filter, wrap).unwrap()
    }

    fn at(g: &Grid, xs: &[f32]) -> Vec<f32> {
        xs.iter()
            .map(|&x| (g.eval(Vec3::new(x, 0.5, 0.5)).r * 1000.0).round() / 1000.0)
            .collect()
    }

    /// Values Mitsuba 3.9.1's `gridvolume` gives for the same ramp (the
    /// pip package, `eval_1` at these x), for each filter and wrap mode.
    #[test]
    fn lookups_match_mitsubas_gridvolume() {
        use GridFilter::*;
        use GridWrap::*;
        let xs = [-0.6, -0.3, -0.1, 0.05, 0.95, 1.1, 1.3, 1.6, 2.2];
        let cases: [(GridFilter, GridWrap, [f32; 9]); 6] = [
            (
                Nearest,
                Mirror,
                [2.0, 1.0, 0.0, 0.0, 3.0, 3.0, 2.0, 1.0, 0.0],
            ),
            (
                Nearest,
                Repeat,
                [1.0, 2.0, 3.0, 0.0, 3.0, 0.0, 1.0, 2.0, 0.0],
            ),
            (
                Nearest,
                Clamp,
                [0.0, 0.0, 0.0, 0.0, 3.0, 3.0, 3.0, 3.0, 3.0],
            ),
            (
                Trilinear,
                Mirror,
                [1.9, 0.7, 0.0, 0.0, 3.0, 3.0, 2.3, 1.1, 0.3],
            ),
            (
                Trilinear,
                Repeat,
                [1.1, 2.3, 2.7, 0.9, 2.1, 0.3, 0.7, 1.9, 0.3],
            ),
            (
                Trilinear,
                Clamp,
                [0.0, 0.0, 0.0, 0.0, 3.0, 3.0, 3.0, 3.0, 3.0],
            ),
        ];
        for (filter, wrap, want) in cases {
            assert_eq!(at(&ramp(filter, wrap), &xs), want, "{filter:?} {wrap:?}");
        }
    }

    /// Trilinear lookups weigh all three axes: the x-fastest layout and
    /// the cell-centre offset on y and z (Mitsuba: (0.3, 0.7, 0.9) on a
    /// 4×3×2 grid of (x/3, y/2, z) gives (0.2333, 0.8, 1)).
    #[test]
    fn trilinear_reads_every_axis_in_file_order() {
        let mut v = Vec::new();
        for z in 0..2 {
            for y in 0..3 {
                for x in 0..4 {
                    v.push(Rgb::new(x as f32 / 3.0, y as f32 / 2.0, z as f32));
                }
            }
        }
        let g = Grid::new(
            [4, 3, 2],
            v,
            Affine3A::IDENTITY,
            GridFilter::Trilinear,
            GridWrap::Clamp,
        )
        .unwrap();
        let c = g.eval(Vec3::new(0.3, 0.7, 0.9));
        assert!(
            (c.r - 0.23333).abs() < 1e-4 && (c.g - 0.8).abs() < 1e-5 && (c.b - 1.0).abs() < 1e-6,
            "{c:?}"
        );
        // The transform places the cube: scaled by 2 and moved by +2 on x.
        let to_world = Affine3A::from_scale(Vec3::splat(2.0))
            * Affine3A::from_translation(Vec3::new(1.0, 0.0, 0.0));
        let g2 = Grid::new(
            g.res,
            g.voxels.clone(),
            to_world.inverse(),
            GridFilter::Trilinear,
            GridWrap::Clamp,
        )
        .unwrap();
        let c2 = g2.eval(Vec3::new(2.6, 1.4, 1.8));
        assert!(
            (c2.r - c.r).abs() < 1e-4 && (c2.g - c.g).abs() < 1e-4,
            "{c2:?}"
        );
    }

    #[test]
    fn bad_grids_are_refused() {
        let id = Affine3A::IDENTITY;
        let (f, w) = (GridFilter::Trilinear, GridWrap::Clamp);
        assert!(Grid::new([2, 1, 1], vec![Rgb::ONE], id, f, w).is_none());
        assert!(Grid::new([0, 1, 1], vec![], id, f, w).is_none());
        assert!(Grid::new([1, 1, 1], vec![Rgb::splat(f32::NAN)], id, f, w).is_none());
        assert!(Grid::new([1, 1, 1], vec![Rgb::splat(-1.0)], id, f, w).is_none());
        let nan = Affine3A::from_scale(Vec3::splat(f32::NAN));
        assert!(Grid::new([1, 1, 1], vec![Rgb::ONE], nan, f, w).is_none());
        assert!(Grid::new([u32::MAX, u32::MAX, u32::MAX], vec![], id, f, w).is_none());
        assert!(Grid::new([1, 1, 1], vec![Rgb::ONE], id, f, w).is_some());
    }
}

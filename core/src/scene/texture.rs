//! Reflectance textures: constant, bitmap and checkerboard (Mitsuba semantics).

use glam::Affine2;
#[cfg(feature = "alloc")]
use glam::Vec2;

use crate::math::Rgb;

/// Index of a [`Bitmap`] in [`crate::scene::Scene::bitmaps`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BitmapId(pub u32);

/// A linear-RGB image, row 0 at the top, sampled with bilinear filtering and
/// repeat wrapping (Mitsuba's `bitmap` with `filter_type=bilinear`,
/// `wrap_mode=repeat`). 8-bit sRGB sources are decoded to linear by the
/// loader before they get here.
#[cfg(feature = "alloc")]
#[derive(Clone, Debug, PartialEq)]
pub struct Bitmap {
    width: u32,
    height: u32,
    texels: alloc::vec::Vec<Rgb>,
}

#[cfg(feature = "alloc")]
impl Bitmap {
    /// A bitmap from `width × height` row-major linear texels (row 0 = top).
    /// Returns `None` when the size does not match, is zero, or a texel is
    /// not finite.
    pub fn new(width: u32, height: u32, texels: alloc::vec::Vec<Rgb>) -> Option<Self> {
        let ok = width > 0
            && height > 0
            && texels.len() == width as usize * height as usize
            && texels.iter().all(|t| t.is_finite());
        ok.then_some(Bitmap {
            width,
            height,
            texels,
        })
    }

    /// Width in texels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels.
    pub fn height(&self) -> u32 {
        self.height
    }

    #[inline]
    fn texel(&self, x: i64, y: i64) -> Rgb {
        let x = x.rem_euclid(self.width as i64) as usize;
        let y = y.rem_euclid(self.height as i64) as usize;
        self.texels[y * self.width as usize + x]
    }

    /// Bilinear lookup at `uv`. Mitsuba maps `uv` to texel space as
    /// `(u·w − ½, v·h − ½)`, with row 0 at v = 0; the OBJ loader has already
    /// flipped v (`flip_tex_coords`), so v = 0 is the image's top row.
    pub fn eval(&self, uv: Vec2) -> Rgb {
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return Rgb::ZERO;
        }
        let x0 = libm::floorf(x);
        let y0 = libm::floorf(y);
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let t00 = self.texel(x0, y0);
        let t10 = self.texel(x0 + 1, y0);
        let t01 = self.texel(x0, y0 + 1);
        let t11 = self.texel(x0 + 1, y0 + 1);
        (t00 * (1.0 - fx) + t10 * fx) * (1.0 - fy) + (t01 * (1.0 - fx) + t11 * fx) * fy
    }

    /// Mean texel value, used to estimate a texture's albedo.
    pub fn mean(&self) -> Rgb {
        let mut s = Rgb::ZERO;
        for t in &self.texels {
            s += *t;
        }
        s / self.texels.len() as f32
    }
}

/// A spatially varying RGB parameter of a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Texture {
    /// The same value everywhere.
    Constant(Rgb),
    /// A bitmap looked up at `to_uv · uv`.
    Bitmap {
        /// Which bitmap.
        id: BitmapId,
        /// Transform applied to the surface uv before lookup.
        to_uv: Affine2,
    },
    /// Mitsuba's `checkerboard`: with `(u', v') = to_uv · uv`, `color0` where
    /// `(frac(u') > ½) == (frac(v') > ½)`, else `color1`.
    Checkerboard {
        /// Colour of the cells where both fractions agree.
        color0: Rgb,
        /// Colour of the other cells.
        color1: Rgb,
        /// Transform applied to the surface uv.
        to_uv: Affine2,
    },
}

impl Texture {
    /// The texture's value at surface coordinates `uv`. Without the
    /// `textures` feature only constants are built and every other
    /// texture is black (scenes using one are rejected at build).
    #[cfg(feature = "alloc")]
    #[inline]
    #[cfg_attr(not(feature = "textures"), allow(unused_variables))]
    pub fn eval(&self, uv: Vec2, bitmaps: &[Bitmap]) -> Rgb {
        match *self {
            Texture::Constant(c) => c,
            #[cfg(not(feature = "textures"))]
            _ => Rgb::ZERO,
            #[cfg(feature = "textures")]
            Texture::Bitmap { id, to_uv } => {
                bitmaps[id.0 as usize].eval(to_uv.transform_point2(uv))
            }
            #[cfg(feature = "textures")]
            Texture::Checkerboard {
                color0,
                color1,
                to_uv,
            } => {
                let p = to_uv.transform_point2(uv);
                let fu = p.x - libm::floorf(p.x);
                let fv = p.y - libm::floorf(p.y);
                if (fu > 0.5) == (fv > 0.5) {
                    color0
                } else {
                    color1
                }
            }
        }
    }

    /// True when the texture never varies over the surface.
    pub fn is_constant(&self) -> bool {
        matches!(self, Texture::Constant(_))
    }
}

#[cfg(all(test, feature = "alloc"))]
mod tests {
    use super::*;
    use alloc::vec;

    #[test]
    fn checkerboard_matches_mitsuba_rule() {
        let t = Texture::Checkerboard {
            color0: Rgb::ONE,
            color1: Rgb::ZERO,
            to_uv: Affine2::from_scale(Vec2::new(2.0, 2.0)),
        };
        assert_eq!(t.eval(Vec2::new(0.1, 0.1), &[]), Rgb::ONE);
        assert_eq!(t.eval(Vec2::new(0.3, 0.1), &[]), Rgb::ZERO);
        assert_eq!(t.eval(Vec2::new(0.3, 0.3), &[]), Rgb::ONE);
    }

    #[test]
    fn bilinear_interpolates_between_texel_centres() {
        let b = Bitmap::new(2, 1, vec![Rgb::ZERO, Rgb::ONE]).unwrap();
        // Texel centres are at u = 0.25 and 0.75.
        assert!((b.eval(Vec2::new(0.25, 0.5)).r - 0.0).abs() < 1e-6);
        assert!((b.eval(Vec2::new(0.5, 0.5)).r - 0.5).abs() < 1e-6);
        assert!((b.eval(Vec2::new(0.75, 0.5)).r - 1.0).abs() < 1e-6);
        assert!(Bitmap::new(2, 2, vec![Rgb::ZERO]).is_none());
    }
}

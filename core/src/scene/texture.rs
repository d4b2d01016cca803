//! Reflectance textures: constant, bitmap, checkerboard and voxel grid
//! (Mitsuba semantics).

use glam::Affine2;
#[cfg(feature = "alloc")]
use glam::{Vec2, Vec3};

#[cfg(feature = "alloc")]
use super::grid::Grid;
use super::grid::GridId;
use crate::math::Rgb;

/// Where a texture is looked up: the surface coordinates image textures
/// read and the world position grid textures read.
#[cfg(feature = "alloc")]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexCoords {
    /// Surface (uv) coordinates.
    pub uv: Vec2,
    /// World-space position of the surface point.
    pub p: Vec3,
}

/// The images a scene's textures index: [`Texture::Bitmap`] into
/// `bitmaps`, [`Texture::Grid`] into `grids`.
#[cfg(feature = "alloc")]
#[derive(Clone, Copy, Debug, Default)]
pub struct TextureImages<'a> {
    /// The scene's bitmaps.
    pub bitmaps: &'a [Bitmap],
    /// The scene's voxel grids.
    pub grids: &'a [Grid],
}

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

    /// The texels, row-major, row 0 at the top.
    pub fn texels(&self) -> &[Rgb] {
        &self.texels
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

    /// The uv gradient of the bilinear interpolant of the texels'
    /// luminance at `uv` (Mitsuba's `bitmap::eval_1_grad`): the partials
    /// in texel units, times the resolution.
    pub fn luminance_grad(&self, uv: Vec2) -> Vec2 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return Vec2::ZERO;
        }
        let x0 = libm::floorf(x);
        let y0 = libm::floorf(y);
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let f00 = self.texel(x0, y0).luminance();
        let f10 = self.texel(x0 + 1, y0).luminance();
        let f01 = self.texel(x0, y0 + 1).luminance();
        let f11 = self.texel(x0 + 1, y0 + 1).luminance();
        let dx = (1.0 - fy) * (f10 - f00) + fy * (f11 - f01);
        let dy = (1.0 - fx) * (f01 - f00) + fx * (f11 - f10);
        Vec2::new(dx * self.width as f32, dy * self.height as f32)
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
    /// Mitsuba's `volume` texture over a `gridvolume`: the grid read at the
    /// surface point's world position (its transform, filter and wrap
    /// mode live in the [`Grid`]). Grids have no uv
    /// gradient, so they are never bump or normal maps.
    Grid(GridId),
}

impl Texture {
    /// The texture's value at `at`. Without the `textures` feature only
    /// constants are built and every other texture is black (scenes using
    /// one are rejected at build).
    #[cfg(feature = "alloc")]
    #[inline]
    #[cfg_attr(not(feature = "textures"), allow(unused_variables))]
    pub fn eval(&self, at: TexCoords, images: TextureImages<'_>) -> Rgb {
        let uv = at.uv;
        match *self {
            Texture::Constant(c) => c,
            #[cfg(not(feature = "textures"))]
            _ => Rgb::ZERO,
            #[cfg(feature = "textures")]
            Texture::Bitmap { id, to_uv } => {
                images.bitmaps[id.0 as usize].eval(to_uv.transform_point2(uv))
            }
            #[cfg(feature = "textures")]
            Texture::Grid(id) => images.grids[id.0 as usize].eval(at.p),
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

    /// The texture as a scalar (Mitsuba's `eval_1`): the luminance of its
    /// RGB value, which is the value itself for a grey texture.
    #[cfg(feature = "alloc")]
    #[inline]
    pub fn eval_1(&self, at: TexCoords, images: TextureImages<'_>) -> f32 {
        Texture::scalar(self.eval(at, images))
    }

    /// The scalar an RGB texture value stands for where a material takes a
    /// float (Mitsuba's `eval_1`): its luminance. The one place that rule
    /// is written ([`Texture::eval_1`] and the BSDFs' scalar parameters).
    #[inline]
    pub fn scalar(value: Rgb) -> f32 {
        value.luminance()
    }

    /// The uv gradient of [`Texture::eval_1`] (Mitsuba's `eval_1_grad`):
    /// zero for constants and for the piecewise-constant checkerboard
    /// (and for grids, which materials refuse as bump maps),
    /// through the transform's transpose for a bitmap (as Mitsuba, the
    /// texel-space partials are scaled by the resolution after the
    /// transpose).
    #[cfg(feature = "alloc")]
    #[cfg_attr(not(feature = "textures"), allow(unused_variables))]
    pub fn eval_1_grad(&self, uv: Vec2, bitmaps: &[Bitmap]) -> Vec2 {
        match *self {
            #[cfg(feature = "textures")]
            Texture::Bitmap { id, to_uv } => {
                let b = &bitmaps[id.0 as usize];
                let g = b.luminance_grad(to_uv.transform_point2(uv));
                // Undo the resolution scale, apply the transpose, redo it
                // (Mitsuba: resolution · Mᵀ · ∂f/∂(x, y)).
                let res = Vec2::new(b.width as f32, b.height as f32);
                let gxy = g / res;
                let m = to_uv.matrix2;
                Vec2::new(m.x_axis.dot(gxy), m.y_axis.dot(gxy)) * res
            }
            _ => Vec2::ZERO,
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
        let at = |u, v| TexCoords {
            uv: Vec2::new(u, v),
            p: Vec3::ZERO,
        };
        let none = TextureImages::default();
        assert_eq!(t.eval(at(0.1, 0.1), none), Rgb::ONE);
        assert_eq!(t.eval(at(0.3, 0.1), none), Rgb::ZERO);
        assert_eq!(t.eval(at(0.3, 0.3), none), Rgb::ONE);
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

    #[test]
    fn luminance_gradient_of_a_ramp() {
        // Texels 0, 1, 2, 3 along u (width 4): the interpolant rises by one
        // per texel, i.e. by 4 per unit u, and is flat along v.
        let b = Bitmap::new(4, 1, (0..4).map(|i| Rgb::splat(i as f32)).collect()).unwrap();
        let g = b.luminance_grad(Vec2::new(0.45, 0.5));
        assert!((g.x - 4.0).abs() < 1e-4 && g.y.abs() < 1e-6, "{g}");
        let t = Texture::Bitmap {
            id: BitmapId(0),
            to_uv: Affine2::from_scale(Vec2::new(0.5, 1.0)),
        };
        // u' = u/2: half the slope per unit u.
        let g = t.eval_1_grad(Vec2::new(0.9, 0.5), &[b]);
        assert!((g.x - 2.0).abs() < 1e-4, "{g}");
    }
}

//! Mitsuba 3's `envmap`: radiance from a latitude-longitude image at
//! infinity, with importance sampling of its directions.
//!
//! Parameterisation (Mitsuba's `direction_to_uv`): a direction `d` towards
//! the environment is taken to the emitter's frame, `v = to_world⁻¹ d`,
//! then `u = atan2(v.x, −v.z) / 2π` (wrapped to [0, 1)) and
//! `v = acos(v.y) / π`, so the image's top row looks along +y, its left
//! edge along −z, its centre column along +z and u = ¼ along +x. The lookup is Mitsuba's bilinear one: texel-centred and
//! periodic in φ (`x = u·W − ½`), corner-aligned and clamped in θ
//! (`y = v·(H − 1)`: row 0 is the pole θ = 0, row H − 1 the pole θ = π).
//! Images smaller than 2 × 3 are padded by repeating their last column
//! and row, as Mitsuba's `pad_to` does.
//!
//! Sampling: the cells of that bilinear lattice — between texel columns
//! i, i + 1 (periodic) and rows j, j + 1 — are chosen by a
//! [`Distribution2D`] in proportion to the integral of the luminance over
//! their solid angle, approximated by the mean of the four corner texels
//! times the cell's solid angle Ω_ij = (2π/W)(cos θ_j − cos θ_{j+1}) (the
//! sin θ Jacobian of the lat-long map, integrated exactly over the row).
//! A point in the cell is uniform in solid angle (φ uniform, cos θ
//! uniform), so the density is constant per cell: p(ω) = P(cell) / Ω_ij.
//! A cell has positive probability whenever a corner texel is non-black,
//! which covers every direction of non-zero radiance.

use alloc::vec::Vec;

use glam::{Mat3, Vec2, Vec3};

use super::texture::Bitmap;
use crate::math::distribution::Distribution2D;
use crate::math::{PI, Rgb};

/// An environment map ready to evaluate and sample.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    width: usize,
    height: usize,
    /// Linear RGB texels times `scale`, row-major, row 0 at θ = 0.
    texels: Vec<Rgb>,
    /// Emitter to world (orthonormal) and its inverse (the transpose).
    to_world: Mat3,
    to_local: Mat3,
    /// Over the `width × (height − 1)` lattice cells.
    dist: Distribution2D,
    /// cos θ_j of the texel rows (f64: near the poles the rows' cosines
    /// differ by less than f32 resolves).
    cos_row: Vec<f64>,
    /// Solid angle of a cell of each row, Ω_j = (2π/W)(cos θ_j − cos θ_{j+1}).
    cell_solid_angle: Vec<f32>,
    /// ∫ Y(L) dω over the sphere, by the cells' mean luminance.
    luminance_integral: f64,
}

impl EnvMap {
    /// Builds the map of `bitmap` (texels finite and non-negative, checked
    /// by the scene builder) times `scale`, oriented by the orthonormal
    /// `to_world`. `None` when the map is black (it emits nothing).
    pub fn new(bitmap: &Bitmap, scale: f32, to_world: Mat3) -> Option<Self> {
        let (w0, h0) = (bitmap.width() as usize, bitmap.height() as usize);
        let (width, height) = (w0.max(2), h0.max(3));
        let src = bitmap.texels();
        let mut texels = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                texels.push(src[y.min(h0 - 1) * w0 + x.min(w0 - 1)] * scale);
            }
        }
        let rows = height - 1;
        let cos_row: Vec<f64> = (0..height)
            .map(|j| libm::cos(j as f64 * core::f64::consts::PI / rows as f64))
            .collect();
        let dphi = 2.0 * core::f64::consts::PI / width as f64;
        let cell_solid_angle: Vec<f64> = (0..rows)
            .map(|j| {
                // cos a − cos b = 2 sin((a + b)/2) sin((b − a)/2): exact
                // near the poles where the cosines agree to f64's precision.
                let step = core::f64::consts::PI / rows as f64;
                let mid = (j as f64 + 0.5) * step;
                dphi * 2.0 * libm::sin(mid) * libm::sin(step * 0.5)
            })
            .collect();
        let lum = |x: usize, y: usize| texels[y * width + x % width].luminance();
        let mut weights = Vec::with_capacity(width * rows);
        let mut integral = 0.0f64;
        for (j, &omega) in cell_solid_angle.iter().enumerate() {
            for i in 0..width {
                let mean = 0.25 * (lum(i, j) + lum(i + 1, j) + lum(i, j + 1) + lum(i + 1, j + 1));
                let wgt = mean as f64 * omega;
                integral += wgt;
                weights.push(wgt as f32);
            }
        }
        let dist = Distribution2D::new(width, &weights)?;
        Some(EnvMap {
            width,
            height,
            texels,
            to_world,
            to_local: to_world.transpose(),
            dist,
            cos_row,
            cell_solid_angle: cell_solid_angle.iter().map(|&o| o as f32).collect(),
            luminance_integral: integral,
        })
    }

    /// ∫ Y(L(ω)) dω over the sphere (with the cells' mean luminance): the
    /// light's power through a unit disk.
    pub fn luminance_integral(&self) -> f64 {
        self.luminance_integral
    }

    /// Texel-lattice coordinates (x periodic in [0, W), y in [0, H − 1])
    /// of the unit world direction `d` (Mitsuba's `direction_to_uv`).
    #[inline]
    fn lattice(&self, d: Vec3) -> Vec2 {
        let v = self.to_local * d;
        let mut u = libm::atan2f(v.x, -v.z) * (0.5 / PI);
        u -= libm::floorf(u);
        let theta = libm::acosf(v.y.clamp(-1.0, 1.0));
        let w = self.width as f32;
        // u ∈ [0, 1), so x ∈ [−½, w − ½): wrap the left half texel (a
        // tiny negative plus w may round to w itself).
        let mut x = u * w - 0.5;
        if x < 0.0 {
            x += w;
        }
        if x >= w {
            x = 0.0;
        }
        let y = (theta / PI).clamp(0.0, 1.0) * (self.height - 1) as f32;
        Vec2::new(x, y)
    }

    /// Radiance arriving from the unit world direction `d` (towards the
    /// environment): the bilinear lookup.
    #[inline]
    pub fn eval(&self, d: Vec3) -> Rgb {
        let p = self.lattice(d);
        if !(p.x.is_finite() && p.y.is_finite()) {
            return Rgb::ZERO;
        }
        let (x0, y0) = (libm::floorf(p.x), libm::floorf(p.y));
        let (fx, fy) = (p.x - x0, p.y - y0);
        let x0 = (x0 as usize).min(self.width - 1);
        let x1 = (x0 + 1) % self.width;
        let y0 = (y0 as usize).min(self.height - 1);
        let y1 = (y0 + 1).min(self.height - 1);
        let t = |x: usize, y: usize| self.texels[y * self.width + x];
        (t(x0, y0) * (1.0 - fx) + t(x1, y0) * fx) * (1.0 - fy)
            + (t(x0, y1) * (1.0 - fx) + t(x1, y1) * fx) * fy
    }

    /// Solid-angle density with which [`EnvMap::sample`] picks the unit
    /// world direction `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        let p = self.lattice(d);
        if !(p.x.is_finite() && p.y.is_finite()) {
            return 0.0;
        }
        let i = (p.x as usize).min(self.width - 1);
        let j = (p.y as usize).min(self.height - 2);
        self.dist.pmf(i, j) / self.cell_solid_angle[j]
    }

    /// Samples a unit world direction towards the environment from `u`;
    /// returns it with its solid-angle density.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (i, j, r) = self.dist.sample(u);
        let phi = 2.0 * PI * ((i as f32 + r.x + 0.5) / self.width as f32);
        // cos θ uniform in the row: 1 − cos θ and 1 + cos θ in f64 keep
        // sin θ accurate near the poles.
        let (c0, c1) = (self.cos_row[j], self.cos_row[j + 1]);
        let cos = c0 + (c1 - c0) * r.y as f64;
        let sin = libm::sqrt(((1.0 - cos) * (1.0 + cos)).max(0.0)) as f32;
        let local = Vec3::new(libm::sinf(phi) * sin, cos as f32, -libm::cosf(phi) * sin);
        let d = (self.to_world * local).normalize();
        // The density of the cell the direction is looked up in: on a cell
        // boundary rounding may place it in the neighbour, and the
        // estimators must see the density `pdf` reports for it (MIS).
        (d, self.pdf(d))
    }
}

/// True when `m` is orthonormal (a rotation, possibly with a reflection)
/// to within rounding of an XML matrix: only then does it map directions
/// to directions without changing solid angles, as Mitsuba's lookup
/// assumes.
pub fn is_orthonormal(m: Mat3) -> bool {
    m.is_finite() && (m.transpose() * m).abs_diff_eq(Mat3::IDENTITY, 1e-3)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bitmap(w: u32, h: u32, f: impl Fn(u32, u32) -> Rgb) -> Bitmap {
        let mut t = Vec::new();
        for y in 0..h {
            for x in 0..w {
                t.push(f(x, y));
            }
        }
        Bitmap::new(w, h, t).unwrap()
    }

    /// The orientation is Mitsuba's: row 0 is +y, texel column x is at
    /// u = (x + ½)/W with φ = 2πu from −z towards +x, and `to_world`
    /// rotates the whole map.
    #[test]
    fn orientation_matches_mitsuba() {
        let b = bitmap(4, 3, |x, y| Rgb::new(x as f32, y as f32, 1.0));
        let e = EnvMap::new(&b, 2.0, Mat3::IDENTITY).unwrap();
        // u = (x + ½)/W at x = 1 is 3/8: φ = 3π/4, d = (sin φ, 0, −cos φ).
        let phi = 2.0 * PI * 3.0 / 8.0;
        let d = Vec3::new(libm::sinf(phi), 0.0, -libm::cosf(phi));
        let l = e.eval(d);
        assert!(
            (l.r - 2.0).abs() < 1e-5 && (l.g - 2.0).abs() < 1e-5,
            "{l:?}"
        );
        // +y is row 0, −y row H − 1.
        assert!((e.eval(Vec3::Y).g).abs() < 1e-6);
        assert!((e.eval(-Vec3::Y).g - 4.0).abs() < 1e-5);
        // A rotation by 90° about y moves what was seen along −z to +x.
        let rot = Mat3::from_rotation_y(core::f32::consts::FRAC_PI_2);
        let er = EnvMap::new(&b, 2.0, rot).unwrap();
        let d = Vec3::new(0.3, 0.4, -0.6).normalize();
        let a = e.eval(d);
        let c = er.eval(rot * d);
        assert!(
            (a.r - c.r).abs() < 1e-4 && (a.g - c.g).abs() < 1e-4,
            "{a:?} {c:?}"
        );
    }

    /// The density integrates to 1 over the sphere (midpoint rule in
    /// (φ, cos θ)), sampled directions report `pdf`'s density, and a
    /// constant map is sampled uniformly (1/4π).
    #[test]
    fn pdf_is_normalised_and_consistent() {
        let b = bitmap(16, 8, |x, y| {
            Rgb::new(
                0.1 + (x * y) as f32,
                0.5,
                if (x, y) == (3, 2) { 50.0 } else { 0.2 },
            )
        });
        let rot = Mat3::from_rotation_x(0.4) * Mat3::from_rotation_y(1.1);
        let e = EnvMap::new(&b, 1.0, rot).unwrap();
        let (nphi, nz) = (600, 600);
        let mut s = 0.0f64;
        for a in 0..nphi {
            for c in 0..nz {
                let phi = (a as f32 + 0.5) / nphi as f32 * 2.0 * PI;
                let z = 1.0 - 2.0 * (c as f32 + 0.5) / nz as f32;
                let r = libm::sqrtf(1.0 - z * z);
                let d = Vec3::new(r * libm::cosf(phi), r * libm::sinf(phi), z);
                s += e.pdf(d) as f64;
            }
        }
        s *= 4.0 * core::f64::consts::PI / (nphi * nz) as f64;
        assert!((s - 1.0).abs() < 3e-3, "{s}");
        for k in 0..200 {
            let u = Vec2::new((k as f32 * 0.618_034).fract(), (k as f32 + 0.5) / 200.0);
            let (d, pdf) = e.sample(u);
            assert!((d.length() - 1.0).abs() < 1e-5);
            // The cell the sample was drawn from.
            let (i, j, _) = e.dist.sample(u);
            let cell = e.dist.pmf(i, j) / e.cell_solid_angle[j];
            assert!((cell - pdf).abs() <= 1e-3 * pdf, "{cell} vs {pdf}");
        }
        let c = EnvMap::new(&bitmap(8, 5, |_, _| Rgb::splat(3.0)), 1.0, Mat3::IDENTITY).unwrap();
        for d in [
            Vec3::X,
            Vec3::Y,
            -Vec3::Z,
            Vec3::new(1.0, 2.0, 3.0).normalize(),
        ] {
            assert!((c.pdf(d) * 4.0 * PI - 1.0).abs() < 1e-4);
            assert_eq!(c.eval(d), Rgb::splat(3.0));
        }
        assert!((c.luminance_integral() - 12.0 * core::f64::consts::PI).abs() < 1e-4);
        assert!(EnvMap::new(&bitmap(4, 4, |_, _| Rgb::ZERO), 1.0, Mat3::IDENTITY).is_none());
    }

    /// A sun-and-sky map: a gradient sky, a bright 2×1-texel sun and a
    /// black ground band.
    fn sky(w: u32, h: u32) -> Bitmap {
        bitmap(w, h, |x, y| {
            if (x == w / 3 || x == w / 3 + 1) && y == h / 4 {
                Rgb::new(400.0, 300.0, 200.0)
            } else if y > h * 3 / 4 {
                Rgb::ZERO
            } else {
                Rgb::new(0.2, 0.3, 0.5 + y as f32 / h as f32)
            }
        })
    }

    /// χ² of the sampled directions against `pdf` (the BSDF tests' sphere
    /// binning, with cubature of the density), for maps of a few sizes and
    /// orientations, including one padded from 1×1.
    #[cfg(all(feature = "std", feature = "effects"))]
    #[test]
    fn sampling_matches_pdf_chi2() {
        use crate::bsdf::chi2;
        let cases = [
            (
                sky(13, 7),
                Mat3::from_rotation_z(0.7) * Mat3::from_rotation_x(-1.2),
            ),
            (
                bitmap(1, 1, |_, _| Rgb::new(1.0, 2.0, 3.0)),
                Mat3::from_rotation_y(2.0),
            ),
        ];
        let alpha = chi2::sidak(1e-3, cases.len());
        for (b, rot) in &cases {
            let e = EnvMap::new(b, 1.5, *rot).unwrap();
            let out = chi2::run(
                200_000,
                7,
                |rng| {
                    let u = Vec2::new(chi2::uniform(rng), chi2::uniform(rng));
                    let (d, pdf) = e.sample(u);
                    (pdf > 0.0).then_some(d)
                },
                |d| e.pdf(d) as f64,
            );
            assert!(out.passes(alpha), "{}x{}: {out}", b.width(), b.height());
            assert!((out.integral - 1.0).abs() < 1e-3, "{out}");
        }
    }
}

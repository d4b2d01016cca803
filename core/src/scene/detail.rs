//! Surface detail: normal maps, bump maps and alpha masks (Mitsuba 3's
//! `normalmap`, `bumpmap` and `mask` BSDF wrappers).
//!
//! Normal and bump maps replace the shading frame at a hit point; the
//! nested BSDF is then evaluated in the perturbed frame, as Mitsuba does.
//! An alpha mask makes a surface stochastically transparent: a ray passes
//! straight through with probability 1 − opacity (Mitsuba's `mask` samples
//! its null lobe with that probability), which the tracer decides per hit
//! ([`mask_passes`]) for closest-hit and occlusion rays alike.

use glam::{Vec2, Vec3};

use super::texture::Texture;
use crate::math::Frame;

/// The surface-detail wrappers of a material: none by default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Detail {
    /// Tangent-space normal map (RGB in [0, 1] → n = 2c − 1, read linear),
    /// relative to the frame whose first tangent is ∂p/∂u.
    pub normal_map: Option<Texture>,
    /// Height texture whose uv gradient (of its luminance, Mitsuba's
    /// `eval_1_grad`) times [`Detail::bump_scale`] displaces the surface.
    pub bump_map: Option<Texture>,
    /// Scale of the bump map's height.
    pub bump_scale: f32,
    /// Opacity in [0, 1] (its luminance for an RGB texture, Mitsuba's
    /// `eval_1`): the probability that a ray stops at the surface.
    pub opacity: Option<Texture>,
}

impl Default for Detail {
    fn default() -> Self {
        Detail::NONE
    }
}

impl Detail {
    /// No detail: the surface is shaded with its own normal and is opaque.
    pub const NONE: Detail = Detail {
        normal_map: None,
        bump_map: None,
        bump_scale: 1.0,
        opacity: None,
    };

    /// Whether the shading frame is perturbed (normal or bump map).
    #[inline]
    pub fn perturbs_frame(&self) -> bool {
        self.normal_map.is_some() || self.bump_map.is_some()
    }

    /// The textures the detail uses, for validation and effect analysis.
    pub fn textures(&self) -> impl Iterator<Item = &Texture> {
        [&self.normal_map, &self.bump_map, &self.opacity]
            .into_iter()
            .flatten()
    }

    /// Checks the parameters; returns what is wrong.
    pub fn validate(&self) -> Result<(), &'static str> {
        if self.normal_map.is_some() && self.bump_map.is_some() {
            return Err("a material takes a normal map or a bump map, not both");
        }
        if !self.bump_scale.is_finite() {
            return Err("bump map scale must be finite");
        }
        let finite_uv = |t: &Texture| match t {
            Texture::Constant(c) => c.is_finite(),
            Texture::Bitmap { to_uv, .. } | Texture::Checkerboard { to_uv, .. } => {
                to_uv.is_finite()
            }
            Texture::Grid(_) => true,
        };
        // A normal or bump map perturbs the frame along the surface's uv
        // tangents; a grid read at the world position has no uv gradient.
        let grid = |t: &Option<Texture>| matches!(t, Some(Texture::Grid(_)));
        if grid(&self.normal_map) || grid(&self.bump_map) {
            return Err("a volume (grid) texture cannot be a normal or bump map");
        }
        if !self.textures().all(finite_uv) {
            return Err("surface-detail textures must be finite");
        }
        // Opacity outside [0, 1] is no probability: refuse it rather than
        // clamp it into a different image (Mitsuba clips silently).
        let in_unit = |c: &crate::math::Rgb| {
            let v = c.luminance();
            (0.0..=1.0).contains(&v) && c.r >= 0.0 && c.g >= 0.0 && c.b >= 0.0
        };
        match &self.opacity {
            Some(Texture::Constant(c)) if !in_unit(c) => Err("opacity must lie in [0, 1]"),
            Some(Texture::Checkerboard { color0, color1, .. })
                if !(in_unit(color0) && in_unit(color1)) =>
            {
                Err("opacity must lie in [0, 1]")
            }
            _ => Ok(()),
        }
    }
}

/// The tangent-space shading frame Mitsuba builds for a normal map: normal
/// `ns`, first tangent ∂p/∂u projected onto the tangent plane (Gram–Schmidt),
/// or the normal's own basis when ∂p/∂u is zero or parallel to it.
#[inline]
pub fn tangent_frame(ns: Vec3, dp_du: Vec3) -> Frame {
    let s = dp_du - ns * ns.dot(dp_du);
    let len = s.length();
    if !(len > 1e-20 && len.is_finite()) {
        return Frame::from_normal(ns);
    }
    let s = s / len;
    Frame {
        s,
        t: ns.cross(s),
        n: ns,
    }
}

/// The shading frame perturbed by a normal map texel `c` (RGB in [0, 1]):
/// n = normalize(2c − 1) in `frame`'s coordinates, first tangent the
/// projection of `frame.s` (Mitsuba 3 `normalmap::frame`, without its
/// direction-dependent `flip_invalid_normals`). `None` when the texel
/// encodes no direction.
#[inline]
pub fn normal_mapped(frame: &Frame, c: Vec3) -> Option<Frame> {
    let n = c * 2.0 - Vec3::ONE;
    let len = n.length();
    if !(len > 1e-6 && len.is_finite()) {
        return None;
    }
    let n = n / len;
    // s = normalize(x − n·n.x): the local x axis made orthogonal to n.
    let s = (Vec3::X - n * n.x).normalize_or_zero();
    if s == Vec3::ZERO {
        return None;
    }
    let t = n.cross(s);
    Some(Frame {
        s: frame.to_world(s),
        t: frame.to_world(t),
        n: frame.to_world(n),
    })
}

/// The shading frame of a bump map (Mitsuba 3 `bumpmap::frame`): the surface
/// displaced along `ns` by the height h(u, v), whose gradient is `grad`
/// (already times the scale), has tangents ∂p/∂u + (∂h/∂u − ns·∂p/∂u)·ns
/// and likewise for v; the new normal is their cross product, turned to
/// the side of the geometric normal `ng`, the first tangent ∂p/∂u
/// projected onto the new tangent plane. `None` when degenerate.
#[inline]
pub fn bump_mapped(ns: Vec3, ng: Vec3, dp_du: Vec3, dp_dv: Vec3, grad: Vec2) -> Option<Frame> {
    let du = dp_du + ns * (grad.x - ns.dot(dp_du));
    let dv = dp_dv + ns * (grad.y - ns.dot(dp_dv));
    let mut n = du.cross(dv).normalize_or_zero();
    if n == Vec3::ZERO || !n.is_finite() {
        return None;
    }
    if n.dot(ng) < 0.0 {
        n = -n;
    }
    Some(tangent_frame(n, dp_du))
}

/// Whether a ray passes through a masked surface of opacity `opacity` at
/// its hit on primitive `prim`: true with probability 1 − opacity.
///
/// The uniform number is a hash of the ray (origin and direction bits) and
/// the primitive, so that a path stays a deterministic function of its
/// random numbers (MLT's primary-sample space and bit-identical replay rely
/// on that) while, over the continuous distribution of rays, the decision
/// is an independent Bernoulli trial: unbiased for fractional opacity and
/// exact for opacity 0 or 1 (always passes / never passes).
#[inline]
pub fn mask_passes(opacity: f32, o: Vec3, d: Vec3, prim: u32) -> bool {
    if opacity >= 1.0 {
        return false;
    }
    if opacity <= 0.0 {
        return true;
    }
    let mut h = 0x9e37_79b9_7f4a_7c15u64 ^ prim as u64;
    for v in [o.x, o.y, o.z, d.x, d.y, d.z] {
        h = mix(h ^ v.to_bits() as u64);
    }
    // 24 random bits → [0, 1).
    let u = (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32);
    u >= opacity
}

/// SplitMix64's finaliser: a bijective avalanche mix of 64 bits.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_normal_map_keeps_the_frame() {
        let f = tangent_frame(Vec3::Z, Vec3::new(2.0, 0.0, 0.3));
        assert!((f.s - Vec3::X).length() < 1e-6);
        let p = normal_mapped(&f, Vec3::new(0.5, 0.5, 1.0)).unwrap();
        assert!((p.n - f.n).length() < 1e-6);
        assert!((p.s - f.s).length() < 1e-6);
        assert!((p.t - f.t).length() < 1e-6);
        // A texel of (0.5, 0.5, 0.5) encodes no direction.
        assert!(normal_mapped(&f, Vec3::splat(0.5)).is_none());
    }

    #[test]
    fn tilted_normal_map_tilts_towards_the_u_tangent() {
        // Tangent-space n = (sin θ, 0, cos θ), θ = 30°, with ∂p/∂u along +y.
        let th = 30f32.to_radians();
        let f = tangent_frame(Vec3::Z, Vec3::Y);
        let c = (Vec3::new(th.sin(), 0.0, th.cos()) + Vec3::ONE) * 0.5;
        let p = normal_mapped(&f, c).unwrap();
        let want = Vec3::new(0.0, th.sin(), th.cos());
        assert!((p.n - want).length() < 1e-5, "{:?}", p.n);
        assert!(p.s.dot(p.n).abs() < 1e-5 && (p.t.length() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn linear_height_ramp_tilts_the_bump_normal() {
        // Height h = k·u on the plane z = 0 with p = (u, v, 0): the surface
        // (u, v, k·u) has normal (−k, 0, 1)/√(1 + k²), a tilt of atan k.
        let k = 0.7f32;
        let f = bump_mapped(Vec3::Z, Vec3::Z, Vec3::X, Vec3::Y, Vec2::new(k, 0.0)).unwrap();
        let want = Vec3::new(-k, 0.0, 1.0).normalize();
        assert!((f.n - want).length() < 1e-6, "{:?}", f.n);
        assert!((f.n.z.acos() - k.atan()).abs() < 1e-5);
        let flat = bump_mapped(Vec3::Z, Vec3::Z, Vec3::X, Vec3::Y, Vec2::ZERO).unwrap();
        assert!((flat.n - Vec3::Z).length() < 1e-7);
        // Stays on the geometric normal's side for a mirrored parameterisation.
        let g = bump_mapped(Vec3::Z, Vec3::Z, Vec3::Y, Vec3::X, Vec2::new(0.0, k)).unwrap();
        assert!(g.n.z > 0.0);
    }

    #[test]
    fn mask_decisions_follow_the_opacity() {
        assert!(mask_passes(0.0, Vec3::ZERO, Vec3::Z, 3));
        assert!(!mask_passes(1.0, Vec3::ZERO, Vec3::Z, 3));
        // Deterministic for one ray, and a pass rate of 1 − opacity over
        // many rays.
        let o = Vec3::new(0.1, 0.2, 0.3);
        let d = Vec3::new(0.3, -0.1, 0.9);
        assert_eq!(mask_passes(0.4, o, d, 7), mask_passes(0.4, o, d, 7));
        let n = 200_000;
        let mut passes = 0;
        for i in 0..n {
            let a = i as f32 * 0.618_034;
            let d = Vec3::new(a.sin(), a.cos(), 0.5 + (i % 97) as f32 * 1e-3);
            passes += mask_passes(0.3, o, d, i % 5) as u32;
        }
        let rate = passes as f64 / n as f64;
        // Binomial σ ≈ 0.001; 5σ.
        assert!((rate - 0.7).abs() < 0.005, "pass rate {rate}");
    }

    #[test]
    fn bad_detail_is_refused() {
        use crate::math::Rgb;
        let mut d = Detail::NONE;
        assert!(d.validate().is_ok());
        d.opacity = Some(Texture::Constant(Rgb::splat(1.5)));
        assert!(d.validate().is_err());
        d.opacity = Some(Texture::Constant(Rgb::splat(f32::NAN)));
        assert!(d.validate().is_err());
        d.opacity = Some(Texture::Constant(Rgb::splat(0.25)));
        assert!(d.validate().is_ok());
        d.bump_scale = f32::INFINITY;
        assert!(d.validate().is_err());
    }
}

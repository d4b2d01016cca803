//! Perspective camera, pinhole or thin lens, with Mitsuba's conventions.
//!
//! Camera space looks down +z with +y up and +x to the *left* of the image
//! (Mitsuba's `perspective` sensor). Raster coordinates run from (0, 0) at
//! the top-left corner to (width, height).
//!
//! Besides generating rays, the camera is an importance emitter for light
//! tracing and BDPT's t = 1 strategies: [`Camera::connect`] samples a point
//! on the lens towards a scene point and returns the importance We, the
//! raster position and the densities (Veach 1997, §10.2; pbrt-v4 §5.2.5 for
//! the same construction).

use core::fmt;

use glam::{Mat3, Mat4, Vec2, Vec3};

use crate::geometry::Ray;
use crate::math::{PI, warp};

/// Which image axis Mitsuba's `fov` refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    /// Horizontal (Mitsuba's default).
    X,
    /// Vertical.
    Y,
    /// Image diagonal.
    Diagonal,
    /// The smaller of the two axes.
    Smaller,
    /// The larger of the two axes.
    Larger,
}

/// Why a camera description was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraError {
    /// The transform has non-finite entries or a degenerate rotation.
    BadTransform,
    /// The field of view is not in (0°, 180°).
    BadFov,
    /// Width or height is zero.
    BadResolution,
    /// Aperture radius negative/non-finite, or focus distance not positive.
    BadLens,
}

impl fmt::Display for CameraError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CameraError::BadTransform => "camera transform must be finite and invertible",
            CameraError::BadFov => "camera field of view must be in (0, 180) degrees",
            CameraError::BadResolution => "image width and height must be at least 1",
            CameraError::BadLens => {
                "aperture radius must be >= 0 and focus distance > 0, both finite"
            }
        })
    }
}

#[cfg(feature = "std")]
impl std::error::Error for CameraError {}

/// A perspective camera with an optional thin lens.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Orthonormal camera-to-world rotation (columns: x, y, z axes).
    rot: Mat3,
    /// Camera position (centre of the lens).
    pos: Vec3,
    /// tan of half the horizontal / vertical field of view.
    tan_half: Vec2,
    width: u32,
    height: u32,
    lens_radius: f32,
    focus_distance: f32,
}

/// A lens sample connected to a scene point: what light tracing splats.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraConnection {
    /// Point on the lens (the ray's camera end).
    pub p_lens: Vec3,
    /// Continuous raster position the connection lands on.
    pub raster: Vec2,
    /// Importance We(p_lens → scene point).
    pub we: f32,
    /// Density of `p_lens` per unit area of the lens (1 for a pinhole,
    /// whose lens is a point: the delta cancels against We).
    pub pdf_lens_area: f32,
    /// Cosine between the camera axis and the connection direction.
    pub cos_theta: f32,
}

impl Camera {
    /// A camera from Mitsuba's `to_world` matrix (scale is removed; the
    /// camera looks down local +z), a field of view in degrees along
    /// `fov_axis`, the image size, and a thin lens (`aperture_radius = 0`
    /// for a pinhole; `focus_distance` along the optical axis).
    pub fn perspective(
        to_world: Mat4,
        fov_degrees: f32,
        fov_axis: FovAxis,
        width: u32,
        height: u32,
        aperture_radius: f32,
        focus_distance: f32,
    ) -> Result<Camera, CameraError> {
        if width == 0 || height == 0 {
            return Err(CameraError::BadResolution);
        }
        if !(fov_degrees.is_finite() && fov_degrees > 0.0 && fov_degrees < 180.0) {
            return Err(CameraError::BadFov);
        }
        if !(aperture_radius.is_finite()
            && aperture_radius >= 0.0
            && focus_distance.is_finite()
            && focus_distance > 0.0)
        {
            return Err(CameraError::BadLens);
        }
        if !to_world.is_finite() {
            return Err(CameraError::BadTransform);
        }
        let x = to_world.x_axis.truncate();
        let y = to_world.y_axis.truncate();
        let z = to_world.z_axis.truncate();
        // Orthonormalise around the viewing direction, keeping Mitsuba's
        // handedness (x = y × z for a rigid right-handed frame).
        let zn = z.normalize_or_zero();
        let xn = y.cross(zn).normalize_or_zero();
        if zn == Vec3::ZERO || xn == Vec3::ZERO {
            return Err(CameraError::BadTransform);
        }
        let mut xn = xn;
        if xn.dot(x) < 0.0 {
            // A mirrored frame (x = −(y × z)) is kept mirrored.
            xn = -xn;
        }
        let yn = zn.cross(xn)
            * if xn.dot(y.cross(zn)) >= 0.0 {
                1.0
            } else {
                -1.0
            };
        let aspect = width as f32 / height as f32;
        let t = libm::tanf(fov_degrees.to_radians() * 0.5);
        let tan_half = match fov_axis {
            FovAxis::X => Vec2::new(t, t / aspect),
            FovAxis::Y => Vec2::new(t * aspect, t),
            FovAxis::Diagonal => {
                let d = libm::sqrtf(aspect * aspect + 1.0);
                Vec2::new(t * aspect / d, t / d)
            }
            FovAxis::Smaller => {
                if aspect >= 1.0 {
                    Vec2::new(t * aspect, t)
                } else {
                    Vec2::new(t, t / aspect)
                }
            }
            FovAxis::Larger => {
                if aspect >= 1.0 {
                    Vec2::new(t, t / aspect)
                } else {
                    Vec2::new(t * aspect, t)
                }
            }
        };
        Ok(Camera {
            rot: Mat3::from_cols(xn, yn, zn),
            pos: to_world.w_axis.truncate(),
            tan_half,
            width,
            height,
            lens_radius: aperture_radius,
            focus_distance,
        })
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Pixels of the image, width · height.
    pub fn pixel_count(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }

    /// Camera position (lens centre).
    pub fn position(&self) -> Vec3 {
        self.pos
    }

    /// Unit viewing direction.
    pub fn forward(&self) -> Vec3 {
        self.rot.z_axis
    }

    /// The angle one pixel subtends at the image centre (radians, along x).
    pub fn pixel_angle(&self) -> f32 {
        2.0 * libm::atanf(self.tan_half.x / self.width as f32)
    }

    /// The camera frame's y axis (unit): "up" in the image.
    pub fn up(&self) -> Vec3 {
        self.rot.y_axis
    }

    /// The full horizontal field of view in degrees.
    pub fn fov_x_degrees(&self) -> f32 {
        2.0 * libm::atanf(self.tan_half.x).to_degrees()
    }

    /// Radius of the thin lens (0 for a pinhole).
    pub fn aperture_radius(&self) -> f32 {
        self.lens_radius
    }

    /// Distance of the plane in focus along the optical axis.
    pub fn focus_distance(&self) -> f32 {
        self.focus_distance
    }

    /// This camera carried around the axis through `pivot` along `axis`
    /// (unit length) by `angle` radians: position and orientation turn
    /// together, so a camera looking at `pivot` keeps looking at it (a
    /// turntable orbit). Field of view, lens and resolution are kept.
    pub fn orbited(&self, pivot: Vec3, axis: Vec3, angle: f32) -> Camera {
        let turn = Mat3::from_axis_angle(axis, angle);
        Camera {
            rot: turn * self.rot,
            pos: pivot + turn * (self.pos - pivot),
            ..*self
        }
    }

    /// True for a thin lens with non-zero aperture.
    pub fn has_lens(&self) -> bool {
        self.lens_radius > 0.0
    }

    /// Area of the image rectangle on the plane at unit distance.
    #[inline]
    fn image_plane_area(&self) -> f32 {
        4.0 * self.tan_half.x * self.tan_half.y
    }

    /// Camera-space direction through continuous raster position `raster`.
    #[inline]
    fn local_dir(&self, raster: Vec2) -> Vec3 {
        let sx = raster.x / self.width as f32;
        let sy = raster.y / self.height as f32;
        Vec3::new(
            (1.0 - 2.0 * sx) * self.tan_half.x,
            (1.0 - 2.0 * sy) * self.tan_half.y,
            1.0,
        )
    }

    /// Raster position of a camera-space direction, if it is in the image.
    #[inline]
    fn raster_of_local(&self, d: Vec3) -> Option<Vec2> {
        let r = self.raster_unbounded(d)?;
        (r.x >= 0.0 && r.y >= 0.0 && r.x < self.width as f32 && r.y < self.height as f32)
            .then_some(r)
    }

    /// Raster position of a camera-space direction on the image plane,
    /// inside the image or not; `None` for a direction not in front of
    /// the camera.
    #[inline]
    fn raster_unbounded(&self, d: Vec3) -> Option<Vec2> {
        if d.z <= 0.0 {
            return None;
        }
        let sx = 0.5 * (1.0 - d.x / (d.z * self.tan_half.x));
        let sy = 0.5 * (1.0 - d.y / (d.z * self.tan_half.y));
        Some(Vec2::new(sx * self.width as f32, sy * self.height as f32))
    }

    /// The continuous raster position world point `p` projects to through
    /// the lens centre (the pinhole projection; pixel (x, y) spans
    /// [x, x + 1) × [y, y + 1)), inside the image or not: what a motion
    /// vector measures. `None` when `p` is not in front of the camera.
    #[inline]
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        self.raster_unbounded(self.rot.transpose() * (p - self.pos))
    }

    /// The raster position of the point at infinity in world direction
    /// `d` (where the environment seen along `d` projects), inside the
    /// image or not; `None` when `d` does not point in front of the
    /// camera.
    #[inline]
    pub fn project_direction(&self, d: Vec3) -> Option<Vec2> {
        self.raster_unbounded(self.rot.transpose() * d)
    }

    /// A primary ray through `raster` (continuous pixel coordinates), using
    /// `u_lens` for the lens position. The direction is unit length.
    /// Without the `depth-of-field` feature the lens is not built and every
    /// camera is a pinhole (a scene with a lens is rejected at build).
    #[cfg_attr(not(feature = "depth-of-field"), allow(unused_variables))]
    pub fn generate_ray(&self, raster: Vec2, u_lens: Vec2) -> Ray {
        #[cfg(feature = "depth-of-field")]
        if self.lens_radius > 0.0 {
            let d = self.local_dir(raster);
            let lens = warp::square_to_uniform_disk_concentric(u_lens) * self.lens_radius;
            let focus = d * self.focus_distance;
            let o = Vec3::new(lens.x, lens.y, 0.0);
            let dir = (focus - o).normalize();
            return Ray::new(self.pos + self.rot * o, self.rot * dir);
        }
        self.pinhole_ray(raster)
    }

    /// The ray of a pinhole through `raster`: [`Camera::generate_ray`]
    /// without the lens (what a thin lens's centre sees). The direction is
    /// unit length.
    #[inline]
    pub fn pinhole_ray(&self, raster: Vec2) -> Ray {
        Ray::new(self.pos, (self.rot * self.local_dir(raster)).normalize())
    }

    /// Importance We of a ray leaving the lens in world direction `w` (unit),
    /// with the raster position it belongs to. Zero outside the image.
    ///
    /// We = 1 / (A · cos⁴θ · A_lens), with A the image-plane area at unit
    /// distance, so that ∫ We cosθ dω dA_lens = 1 over each ray's pixel
    /// footprint scaled to the whole image (pbrt-v4, eq. 5.7). For a pinhole
    /// A_lens is taken as 1 (the position is a delta).
    pub fn importance(&self, p_lens: Vec3, w: Vec3) -> Option<(f32, Vec2)> {
        let local = self.rot.transpose() * w;
        let cos_theta = local.z;
        if cos_theta <= 0.0 {
            return None;
        }
        // A lens ray's raster position is where it crosses the focal plane,
        // seen from the lens centre.
        let raster = if self.lens_radius > 0.0 {
            let o = self.rot.transpose() * (p_lens - self.pos);
            let t = (self.focus_distance - o.z) / cos_theta;
            let focus = o + local * t;
            self.raster_of_local(focus)?
        } else {
            self.raster_of_local(local)?
        };
        let lens_area = if self.lens_radius > 0.0 {
            PI * self.lens_radius * self.lens_radius
        } else {
            1.0
        };
        let c2 = cos_theta * cos_theta;
        Some((
            1.0 / (self.image_plane_area() * lens_area * c2 * c2),
            raster,
        ))
    }

    /// Densities of the ray leaving the lens at `p_lens` in direction `w`:
    /// (per unit lens area, per unit solid angle). Both are zero when `w`
    /// leaves the image.
    pub fn pdf_ray(&self, p_lens: Vec3, w: Vec3) -> (f32, f32) {
        match self.importance(p_lens, w) {
            None => (0.0, 0.0),
            Some(_) => {
                let cos_theta = (self.rot.transpose() * w).z;
                let lens_area = if self.lens_radius > 0.0 {
                    PI * self.lens_radius * self.lens_radius
                } else {
                    1.0
                };
                // Uniform raster sampling maps to 1/(A cos³θ) per solid angle.
                (
                    1.0 / lens_area,
                    1.0 / (self.image_plane_area() * cos_theta * cos_theta * cos_theta),
                )
            }
        }
    }

    /// Samples a lens point to connect with scene point `p` (light tracing,
    /// BDPT t = 1). Returns `None` when `p` projects outside the image or
    /// lies behind the camera.
    pub fn connect(&self, p: Vec3, u_lens: Vec2) -> Option<CameraConnection> {
        self.connect_at(p, self.lens_point(u_lens))
    }

    /// The world-space lens point for `u_lens` (the camera position for a
    /// pinhole).
    #[inline]
    pub fn lens_point(&self, u_lens: Vec2) -> Vec3 {
        if self.lens_radius > 0.0 {
            let l = warp::square_to_uniform_disk_concentric(u_lens) * self.lens_radius;
            self.pos + self.rot * Vec3::new(l.x, l.y, 0.0)
        } else {
            self.pos
        }
    }

    /// Connects scene point `p` with the given lens point `p_lens` (the
    /// caustic perturbation keeps the lens point of the path it perturbs).
    pub fn connect_at(&self, p: Vec3, p_lens: Vec3) -> Option<CameraConnection> {
        let to = p - p_lens;
        let dist = to.length();
        if !(dist > 0.0) {
            return None;
        }
        let w = to / dist;
        let (we, raster) = self.importance(p_lens, w)?;
        let lens_area = if self.lens_radius > 0.0 {
            PI * self.lens_radius * self.lens_radius
        } else {
            1.0
        };
        let cos_theta = (self.rot.transpose() * w).z;
        Some(CameraConnection {
            p_lens,
            raster,
            we,
            pdf_lens_area: 1.0 / lens_area,
            cos_theta,
        })
    }

    /// The ray from lens point `p_lens` through raster position `raster`:
    /// towards the point of the focal plane that `raster` images (for a
    /// pinhole, the ray of [`Camera::generate_ray`]). The lens
    /// perturbation moves the raster position and keeps the lens point.
    pub fn ray_from_lens(&self, raster: Vec2, p_lens: Vec3) -> Ray {
        let d = self.local_dir(raster);
        if self.lens_radius > 0.0 {
            let focus = self.pos + self.rot * (d * self.focus_distance);
            Ray::new(p_lens, (focus - p_lens).normalize())
        } else {
            Ray::new(self.pos, (self.rot * d).normalize())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(w: u32, h: u32, lens: f32) -> Camera {
        // Mitsuba's cornell-box sensor: at (0,1,6.8) looking down −z.
        let m = Mat4::from_cols_array(&[
            -1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 6.8, 1.0,
        ]);
        Camera::perspective(m, 19.5, FovAxis::X, w, h, lens, 6.8).unwrap()
    }

    #[test]
    fn image_left_is_world_minus_x_for_cornell_sensor() {
        let c = cam(256, 256, 0.0);
        let left = c.generate_ray(Vec2::new(0.0, 128.0), Vec2::ZERO);
        let right = c.generate_ray(Vec2::new(256.0, 128.0), Vec2::ZERO);
        assert!(left.d.x < 0.0 && right.d.x > 0.0);
        let top = c.generate_ray(Vec2::new(128.0, 0.0), Vec2::ZERO);
        assert!(top.d.y > 0.0);
        let half = libm::atanf(left.d.x.abs() / left.d.z.abs()).to_degrees();
        assert!((half - 9.75).abs() < 1e-3);
    }

    #[test]
    fn raster_round_trips_through_importance() {
        for lens in [0.0, 0.2] {
            let c = cam(64, 48, lens);
            for &(x, y) in &[(3.5f32, 7.25f32), (60.0, 40.0), (32.0, 24.0)] {
                let r = c.generate_ray(Vec2::new(x, y), Vec2::new(0.3, 0.8));
                let (_, raster) = c.importance(r.o, r.d).unwrap();
                assert!(
                    (raster - Vec2::new(x, y)).length() < 1e-2,
                    "{raster} vs {x},{y}"
                );
                // The same ray from its lens point and raster position.
                let p_lens = c.lens_point(Vec2::new(0.3, 0.8));
                let q = c.ray_from_lens(Vec2::new(x, y), p_lens);
                assert!((q.o - r.o).length() < 1e-5 && (q.d - r.d).length() < 1e-4);
            }
        }
    }

    #[test]
    fn importance_integrates_to_one_over_directions() {
        // ∫ We cosθ dω over the image = 1 for a pinhole: Monte Carlo with the
        // camera's own direction density.
        let c = cam(40, 30, 0.0);
        let mut sum = 0.0f64;
        let n = 200;
        for i in 0..n {
            for j in 0..n {
                let raster = Vec2::new(
                    (i as f32 + 0.5) / n as f32 * 40.0,
                    (j as f32 + 0.5) / n as f32 * 30.0,
                );
                let r = c.generate_ray(raster, Vec2::ZERO);
                let (we, _) = c.importance(r.o, r.d).unwrap();
                let (_, pdf) = c.pdf_ray(r.o, r.d);
                let cos = r.d.dot(c.forward());
                sum += (we * cos / pdf) as f64;
            }
        }
        assert!((sum / (n * n) as f64 - 1.0).abs() < 1e-3);
    }
}

//! Auxiliary outputs (AOVs) for a denoiser and a temporal upscaler:
//! albedo, shading normal, depth and screen-space motion vectors, from one
//! primary ray per pixel through its centre, traced as packets.
//!
//! [`render_rows`] writes rows `[y0, y1)` of the outputs a host asks for
//! ([`AovBuffers`]) into its buffers, as `f32` or half floats
//! ([`AovFormat`]); it reads the scene and allocates nothing, so host
//! threads can each compute a band of rows at the same time. Every pixel
//! depends only on its own ray, so any split of the rows gives the same
//! bytes.
//!
//! What each output holds, at the first surface the pixel's centre ray
//! hits (the pinhole ray through the lens centre: the outputs are sharp
//! whatever the aperture). The first hit, not the first non-specular one:
//! one deterministic ray gives outputs without noise and keeps depth,
//! normal and motion of the same point, which is what a temporal upscaler
//! reprojects. Index-matched (null) boundaries are invisible in the image
//! and so in the outputs too: the ray passes them to the first other
//! surface; participating media leave the outputs unchanged. OIDN reads a normal in world or view space with 0 where
//! nothing is hit, and an albedo in [0, 1], for which its documentation
//! allows a mirror's or glass's own reflectance (or 1) instead of the
//! surface seen through them.
//! - **albedo**: the BSDF's directional-hemispherical reflectance
//!   towards the camera, textures and normal maps applied (`albedo.rs`
//!   says how it is estimated; a flat Lambertian triangle of constant
//!   reflectance gives that reflectance, once per run of pixels on it);
//!   0 where the ray leaves the scene.
//! - **normal**: the shading normal (normal or bump map applied) in world
//!   space, unit length, turned to face the camera; 0 on a miss.
//! - **depth**: camera-space z, the distance from the camera's position
//!   along its viewing direction ((p − position) · forward, not the
//!   distance along the ray); +∞ on a miss.
//! - **motion**: where the visible point was in the previous frame, in
//!   pixels, minus the pixel's centre (x + ½, y + ½): +x to the right, +y
//!   down, as raster coordinates (DLSS and FSR read "previous minus
//!   current"; scale it by −1 or to UV units as the upscaler asks). The
//!   point is projected through `previous` (the previous frame's camera);
//!   on a mesh moved since [`Scene::begin_frame`] it is first carried back
//!   by its triangle's vertex displacements through the hit's barycentric
//!   coordinates ([`Scene::previous_point`]). Where the ray leaves the
//!   scene, the point at infinity in its direction (the environment
//!   moves only with the camera's rotation). 0 where the previous camera
//!   cannot see the point (behind it).

mod albedo;
mod layer;

use core::ops::Range;

use glam::{Vec2, Vec3};

pub use layer::{AovBuffers, AovFormat, AovLayer};

use crate::accel::{DynIntersector, Intersector};
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::{Hit, HitPacket, LaneMask, Ray, RayPacket};
use crate::integrator::Tracer;
use crate::integrator::tracer::{MAX_NULL_CROSSINGS, Shading};
use crate::math::Rgb;
use crate::renderer::RenderError;
use crate::scene::material::MaterialKind;
use crate::scene::texture::Texture;
use crate::scene::{Camera, SHAPE_PRIM_BIT, Scene, SurfacePoint};

/// Pixels of a row traced as one packet.
const LANES: usize = 8;

/// Writes rows `rows` of the outputs `out` asks for, seen through
/// `camera`, with motion vectors to where each point was through
/// `previous` (the last frame's camera; `camera` itself for none): row
/// `rows.start` is each layer's first row. [`RenderError::Resolution`]
/// when the two cameras' resolutions differ, [`RenderError::Output`] when
/// the rows leave the image or a layer is too small for them (nothing is
/// written then). Allocates nothing.
pub fn render_rows(
    scene: &Scene,
    accel: &dyn DynIntersector,
    camera: &Camera,
    previous: &Camera,
    rows: Range<u32>,
    out: &mut AovBuffers<'_>,
) -> Result<(), RenderError> {
    if (previous.width(), previous.height()) != (camera.width(), camera.height()) {
        return Err(RenderError::Resolution);
    }
    if rows.start > rows.end || rows.end > camera.height() {
        return Err(RenderError::Output("the rows leave the image"));
    }
    let (width, n) = (camera.width() as usize, rows.len());
    for (layer, channels) in [
        (&mut out.albedo, 3),
        (&mut out.normal, 3),
        (&mut out.depth, 1),
        (&mut out.motion, 2),
    ] {
        if let Some(l) = layer {
            l.check(n, width, channels)?;
        }
    }
    let mut tracer = Tracer::new(scene, &accel).with_camera(*camera);
    let want = Wanted {
        albedo: out.albedo.is_some(),
        normal: out.normal.is_some(),
        depth: out.depth.is_some(),
        motion: out.motion.is_some(),
    };
    let shade = want.albedo || want.normal;
    // With alpha masks the tracer walks through masked surfaces ray by ray
    // (and hands back shaded points); otherwise one packet per LANES
    // pixels, and the BSDF and shading frame are resolved only for albedo
    // and normal: depth and motion read the hit's distance and
    // barycentric coordinates (hit points and shading were most of the
    // cost of depth and motion). A triangle whose albedo and normal are
    // the same all over ([`Uniform`]) is shaded once per run of pixels
    // that see it; others at each pixel's own point (`shading_point`: no
    // ray leaves it, so it needs neither a margin off the edges nor an
    // error bound, which were most of the cost of albedo and normal).
    // Each lane's outputs are computed into `px` as plain floats and
    // written a packet's run of pixels at a time: per-lane arrays of
    // `Option<Uniform>` and `Option<Shading>` between two loops cost a
    // store-forwarding stall per pixel (their copies at odd offsets were
    // the hottest instruction of depth and motion).
    // Null boundaries (media scenes) are walked through ray by ray too.
    let walks = tracer.has_alpha_masks() || scene.has_media();
    let mut rays = [None; LANES];
    let mut shaded: [Option<Shading>; LANES] = [None; LANES];
    let mut run = Run::default();
    let mut last: Option<(u32, Option<Uniform>)> = None;
    for (row, y) in rows.enumerate() {
        for x0 in (0..width).step_by(LANES) {
            let lanes = LANES.min(width - x0);
            for (i, r) in rays[..lanes].iter_mut().enumerate() {
                *r = Some(camera.pinhole_ray(centre(x0 + i, y)));
            }
            if walks {
                for (r, o) in rays[..lanes].iter().zip(&mut shaded[..lanes]) {
                    *o = r
                        .as_ref()
                        .and_then(|r| first_visible(scene, &mut tracer, r));
                }
                for i in 0..lanes {
                    let ray = rays[i].expect("set above");
                    let c = centre(x0 + i, y);
                    let Some(sh) = &shaded[i] else {
                        run.miss(i, previous, &ray, c, want);
                        continue;
                    };
                    let point = PixelPoint::of_surface(scene, &sh.sp);
                    run.hit(i, scene, camera, previous, point, c, want);
                    run.shaded(i, &mut tracer, sh, ray.d, want);
                }
            } else {
                let hits = intersect(&accel, &rays[..lanes]);
                for (i, ray) in rays[..lanes].iter().enumerate() {
                    let ray = ray.expect("set above");
                    let c = centre(x0 + i, y);
                    let Some(h) = hits.get(i) else {
                        run.miss(i, previous, &ray, c, want);
                        continue;
                    };
                    run.hit(
                        i,
                        scene,
                        camera,
                        previous,
                        PixelPoint::of_hit(&ray, &h),
                        c,
                        want,
                    );
                    if !shade {
                        continue;
                    }
                    if h.prim & SHAPE_PRIM_BIT != 0 {
                        if let Some(sp) = scene.hit_point(&h) {
                            let sh = tracer.shade(sp);
                            run.shaded(i, &mut tracer, &sh, ray.d, want);
                        }
                        continue;
                    }
                    if !matches!(last, Some((prim, _)) if prim == h.prim) {
                        last = Some((h.prim, Uniform::of(scene, h.prim)));
                    }
                    // Read in place: a copy of the cached `Uniform` per
                    // pixel stalled on its own stores.
                    match last.as_ref().and_then(|(_, u)| u.as_ref()) {
                        Some(u) => {
                            let (a, n) = u.look(ray.d);
                            run.albedo[3 * i..3 * i + 3].copy_from_slice(&a);
                            run.normal[3 * i..3 * i + 3].copy_from_slice(&n);
                        }
                        None => {
                            if let Some(sp) = scene.shading_point(h.prim, h.b1, h.b2) {
                                let sh = tracer.shade(sp);
                                run.shaded(i, &mut tracer, &sh, ray.d, want);
                            }
                        }
                    }
                }
            }
            run.write(out, row, x0, lanes);
        }
    }
    Ok(())
}

/// The first surface `ray` meets that is not a null boundary (alpha-masked
/// surfaces whose test passes are walked through by [`Tracer::trace`]):
/// the surface a denoiser should see, as the index-matched boundaries of
/// media are invisible in the image. Media themselves are not seen by the
/// outputs (their scattering is noise a denoiser's albedo does not carry).
/// `None` on a miss, or after [`MAX_NULL_CROSSINGS`] boundaries in a row.
fn first_visible<I: Intersector>(
    scene: &Scene,
    tracer: &mut Tracer<'_, I>,
    ray: &Ray,
) -> Option<Shading> {
    let mut ray = *ray;
    for _ in 0..MAX_NULL_CROSSINGS {
        let sh = tracer.trace(&ray)?;
        if !matches!(scene.material(&sh.sp).kind, MaterialKind::Null) {
            return Some(sh);
        }
        let sp = &sh.sp;
        ray = Ray::new(offset_ray_origin(sp.p, sp.p_error, sp.ng, ray.d), ray.d);
    }
    None
}

/// Which outputs a call writes (the others are not computed).
#[derive(Clone, Copy)]
struct Wanted {
    albedo: bool,
    normal: bool,
    depth: bool,
    motion: bool,
}

/// The outputs of a packet's run of pixels, channel after channel and
/// pixel after pixel as the layers hold them, written into the layers
/// together ([`Run::write`]). Each value is stored once, where its layer
/// reads it (a per-pixel struct copied into place stalled on its own
/// stores).
struct Run {
    albedo: [f32; 3 * LANES],
    normal: [f32; 3 * LANES],
    depth: [f32; LANES],
    motion: [f32; 2 * LANES],
}

impl Default for Run {
    fn default() -> Self {
        Run {
            albedo: [0.0; 3 * LANES],
            normal: [0.0; 3 * LANES],
            depth: [0.0; LANES],
            motion: [0.0; 2 * LANES],
        }
    }
}

impl Run {
    /// Pixel `i`'s ray (through raster `centre`) leaves the scene: no
    /// surface, infinite depth, and the motion of the point at infinity
    /// in its direction.
    fn miss(&mut self, i: usize, previous: &Camera, ray: &Ray, centre: Vec2, want: Wanted) {
        self.albedo[3 * i..3 * i + 3].fill(0.0);
        self.normal[3 * i..3 * i + 3].fill(0.0);
        self.depth[i] = f32::INFINITY;
        if want.motion {
            let m = previous
                .project_direction(ray.d)
                .map_or(Vec2::ZERO, |q| q - centre);
            self.motion[2 * i..2 * i + 2].copy_from_slice(&[m.x, m.y]);
        }
    }

    /// Pixel `i`'s ray stopped at `point`: its depth and motion, albedo
    /// and normal zero until a surface point sets them
    /// ([`Run::shaded`], a [`Uniform`]).
    #[allow(clippy::too_many_arguments)]
    fn hit(
        &mut self,
        i: usize,
        scene: &Scene,
        camera: &Camera,
        previous: &Camera,
        point: PixelPoint,
        centre: Vec2,
        want: Wanted,
    ) {
        self.albedo[3 * i..3 * i + 3].fill(0.0);
        self.normal[3 * i..3 * i + 3].fill(0.0);
        if want.depth {
            self.depth[i] = (point.p - camera.position()).dot(camera.forward());
        }
        if want.motion {
            let before = scene.previous_point(point.prim, point.b1, point.b2, point.p);
            let m = previous.project(before).map_or(Vec2::ZERO, |q| q - centre);
            self.motion[2 * i..2 * i + 2].copy_from_slice(&[m.x, m.y]);
        }
    }

    /// Pixel `i`'s albedo and normal: the surface `sh` seen along `d`.
    fn shaded<I: Intersector>(
        &mut self,
        i: usize,
        tracer: &mut Tracer<'_, I>,
        sh: &Shading,
        d: Vec3,
        want: Wanted,
    ) {
        if want.albedo {
            let a = albedo::albedo(tracer, sh, -d);
            self.albedo[3 * i..3 * i + 3].copy_from_slice(&[a.r, a.g, a.b]);
        }
        if want.normal {
            self.normal[3 * i..3 * i + 3].copy_from_slice(&facing(sh.sp.ns, d).to_array());
        }
    }

    /// Writes the first `lanes` pixels into every wanted layer, from
    /// pixel `x0` of the call's row `row` on.
    fn write(&self, out: &mut AovBuffers<'_>, row: usize, x0: usize, lanes: usize) {
        if let Some(l) = &mut out.albedo {
            l.put_run(row, x0, 3, &self.albedo[..3 * lanes]);
        }
        if let Some(l) = &mut out.normal {
            l.put_run(row, x0, 3, &self.normal[..3 * lanes]);
        }
        if let Some(l) = &mut out.depth {
            l.put_run(row, x0, 1, &self.depth[..lanes]);
        }
        if let Some(l) = &mut out.motion {
            l.put_run(row, x0, 2, &self.motion[..2 * lanes]);
        }
    }
}

/// Where a pixel's ray stopped: the point, its primitive and its
/// barycentric coordinates (b1, b2) there (what motion carries back).
#[derive(Clone, Copy)]
struct PixelPoint {
    p: Vec3,
    prim: u32,
    b1: f32,
    b2: f32,
}

impl PixelPoint {
    /// The point of an intersector's hit: o + t·d, with the hit's own
    /// barycentric coordinates.
    fn of_hit(ray: &Ray, h: &Hit) -> Self {
        PixelPoint {
            p: ray.o + ray.d * h.t,
            prim: h.prim,
            b1: h.b1,
            b2: h.b2,
        }
    }

    /// The point of a shaded surface point (alpha-masked scenes), its
    /// barycentric coordinates those of its projection onto the
    /// triangle's plane (Cramer's rule on the edges' Gram matrix; 0 for
    /// host shapes and degenerate triangles, which do not move).
    fn of_surface(scene: &Scene, sp: &SurfacePoint) -> Self {
        let (mut b1, mut b2) = (0.0, 0.0);
        if sp.prim & SHAPE_PRIM_BIT == 0 {
            let [p0, p1, p2] = scene.triangle(sp.prim);
            let (e1, e2, d) = (p1 - p0, p2 - p0, sp.p - p0);
            let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
            let (dp1, dp2) = (d.dot(e1), d.dot(e2));
            let det = d11 * d22 - d12 * d12;
            if det > 0.0 && det.is_finite() {
                b1 = (d22 * dp1 - d12 * dp2) / det;
                b2 = (d11 * dp2 - d12 * dp1) / det;
            }
        }
        PixelPoint {
            p: sp.p,
            prim: sp.prim,
            b1,
            b2,
        }
    }
}

/// A triangle's albedo and shading normal when they are the same at
/// every point of it, found once for a run of pixels on it (see
/// [`Uniform::of`]).
#[derive(Clone, Copy)]
enum Uniform {
    /// A degenerate triangle: no BSDF, no normal (0 in both outputs, as
    /// for a surface point that cannot be computed).
    Degenerate,
    /// A flat-shaded triangle (`Scene::flat_shaded`: its shading normal
    /// `n` at every point) under a Lambertian material of constant
    /// reflectance: the albedo is that reflectance
    /// whatever the direction (ρ = R exactly, which the cosine-weighted
    /// sample of `albedo.rs` gives up to rounding), on the front side or
    /// on both.
    Lambertian {
        reflectance: Rgb,
        two_sided: bool,
        n: Vec3,
    },
}

impl Uniform {
    /// The uniform outputs of mesh triangle `prim`, or `None` when they
    /// vary over it (unequal vertex normals, a normal or bump map, a
    /// texture, a model whose albedo depends on the direction).
    fn of(scene: &Scene, prim: u32) -> Option<Uniform> {
        if !scene.flat_shaded(prim) {
            return None;
        }
        // Any point of the triangle: its normal and material are those of
        // every other point.
        let Some(sp) = scene.shading_point(prim, 1.0 / 3.0, 1.0 / 3.0) else {
            return Some(Uniform::Degenerate);
        };
        let m = scene.material(&sp);
        if m.detail.perturbs_frame() {
            return None;
        }
        match m.kind {
            MaterialKind::Diffuse {
                reflectance: Texture::Constant(reflectance),
            } => Some(Uniform::Lambertian {
                reflectance,
                two_sided: m.two_sided,
                n: sp.ns,
            }),
            _ => None,
        }
    }

    /// (albedo, normal facing the camera) seen along direction `d`: a
    /// one-sided Lambertian seen from behind reflects nothing.
    fn look(&self, d: Vec3) -> ([f32; 3], [f32; 3]) {
        match *self {
            Uniform::Degenerate => ([0.0; 3], [0.0; 3]),
            Uniform::Lambertian {
                reflectance,
                two_sided,
                n,
            } => {
                let albedo = if two_sided || n.dot(d) < 0.0 {
                    albedo::clamped(reflectance)
                } else {
                    Rgb::ZERO
                };
                ([albedo.r, albedo.g, albedo.b], facing(n, d).to_array())
            }
        }
    }
}

/// Closest hits of `rays` (up to [`LANES`]) as one packet.
fn intersect<I: Intersector>(accel: &I, rays: &[Option<Ray>]) -> HitPacket<LANES> {
    let mut packet = RayPacket::<LANES>::default();
    let mut active = LaneMask::NONE;
    for (i, r) in rays.iter().enumerate() {
        if let Some(r) = r {
            packet.set(i, r);
            active.set(i);
        }
    }
    let mut hits = HitPacket::<LANES>::default();
    accel.intersect_packet(&packet, active, &mut hits);
    hits
}

/// The centre of pixel (x, y) in raster coordinates.
fn centre(x: usize, y: u32) -> Vec2 {
    Vec2::new(x as f32 + 0.5, y as f32 + 0.5)
}

/// `n` turned to the side the ray (direction `d`) came from.
fn facing(n: Vec3, d: Vec3) -> Vec3 {
    if n.dot(d) > 0.0 { -n } else { n }
}

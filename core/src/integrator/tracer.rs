//! What every estimator needs per sample: the scene, the intersector and
//! counters.

use glam::{Vec2, Vec3};

use crate::accel::Intersector;
use crate::bsdf::{Bsdf, BsdfSample, Lobe, TransportMode};
use crate::geometry::{HitPacket, LaneMask, Ray, RayPacket, offset};
use crate::math::{Frame, Rgb};
#[cfg(any(
    feature = "normal-mapping",
    feature = "alpha-masks",
    feature = "principled"
))]
use crate::scene::detail;
#[cfg(feature = "normal-mapping")]
use crate::scene::detail::Detail;
use crate::scene::{Analysis, Camera, Effect, Scene, SurfacePoint};
#[cfg(feature = "media")]
use crate::scene::{MaterialKind, MediumId};

/// One counter per [`Lobe`] kind (index `lobe as usize`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LobeCounts(pub [u64; Lobe::ALL.len()]);

impl LobeCounts {
    /// The count of `lobe`.
    pub fn get(&self, lobe: Lobe) -> u64 {
        self.0[lobe as usize]
    }

    /// Counts one more of `lobe`.
    #[inline]
    pub fn add(&mut self, lobe: Lobe) {
        self.0[lobe as usize] += 1;
    }

    /// All lobes together.
    pub fn total(&self) -> u64 {
        self.0.iter().sum()
    }

    fn merge(&mut self, o: &LobeCounts) {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a += b;
        }
    }
}

/// Work counters of one worker; summed across workers by the host.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Closest-hit rays traced.
    pub rays: u64,
    /// Occlusion (shadow/connection) rays traced.
    pub shadow_rays: u64,
    /// Camera samples (one per pixel per pass).
    pub samples: u64,
    /// Packets traced (closest-hit and occlusion), each of 4, 8 or 16
    /// lanes; their rays are also counted in `rays` / `shadow_rays`.
    pub packets: u64,
    /// Active lanes over all packets: rays that went as packets.
    pub packet_rays: u64,
    /// BSDF samples by lobe kind: every continuation of a path (PT, BDPT
    /// subpaths, MLT's BDPT) and every specular lobe a level-2 retrace
    /// follows.
    pub bsdf_samples: LobeCounts,
    /// BSDF evaluations by lobe kind: every connection through a surface
    /// vertex (PT's light samples, BDPT's edges, light-tracing and
    /// light-sample strategies, the perturbations' reconnections).
    pub bsdf_evals: LobeCounts,
    /// Camera rays that sampled a point on a thin lens (zero for a
    /// pinhole camera).
    pub lens_samples: u64,
}

impl Stats {
    /// Adds another worker's counters.
    pub fn merge(&mut self, o: &Stats) {
        self.rays += o.rays;
        self.shadow_rays += o.shadow_rays;
        self.samples += o.samples;
        self.packets += o.packets;
        self.packet_rays += o.packet_rays;
        self.bsdf_samples.merge(&o.bsdf_samples);
        self.bsdf_evals.merge(&o.bsdf_evals);
        self.lens_samples += o.lens_samples;
    }

    /// Mean active lanes per packet (0 when none was traced).
    pub fn mean_packet_lanes(&self) -> f64 {
        if self.packets == 0 {
            0.0
        } else {
            self.packet_rays as f64 / self.packets as f64
        }
    }

    /// All rays of both kinds.
    pub fn total_rays(&self) -> u64 {
        self.rays + self.shadow_rays
    }
}

/// Scene, intersector and counters for one worker.
pub struct Tracer<'a, I: Intersector> {
    /// The scene.
    pub scene: &'a Scene,
    /// The intersector over the scene's triangles.
    pub accel: &'a I,
    /// The camera rendered through: the scene's own unless replaced with
    /// [`Tracer::with_camera`] (a renderer's per-frame camera; the scene
    /// is shared and never mutated).
    pub camera: Camera,
    /// This worker's counters.
    pub stats: Stats,
    /// What the scene calls for: the estimators skip what it leaves out
    /// (lens sampling without depth of field, the caustic perturbation
    /// without specular chains). [`Analysis::all`] unless set with
    /// [`Tracer::with_analysis`]; it must describe `scene` seen through
    /// `camera` (or be a superset), or images come out wrong.
    pub analysis: Analysis,
    /// The analysis has alpha masks and a material of the scene has an
    /// opacity: only then do ray queries walk (an [`Analysis::all`] of a
    /// scene without masks keeps the plain queries and packets).
    masks: bool,
    /// The scene has media or null boundaries ([`Scene::has_media`]),
    /// found once: only then do path tracing and BDPT run their media
    /// code.
    #[cfg(feature = "media")]
    media: bool,
}

/// A surface point with its resolved BSDF and shading frame.
#[derive(Clone, Copy, Debug)]
pub struct Shading {
    /// The point.
    pub sp: SurfacePoint,
    /// BSDF with textures evaluated at the point.
    pub bsdf: Bsdf,
    /// Frame around the shading normal.
    pub frame: Frame,
}

impl<'a, I: Intersector> Tracer<'a, I> {
    /// A tracer with zeroed counters.
    pub fn new(scene: &'a Scene, accel: &'a I) -> Self {
        Tracer {
            scene,
            accel,
            camera: scene.camera,
            stats: Stats::default(),
            analysis: Analysis::all(),
            masks: Self::scene_has_masks(scene),
            #[cfg(feature = "media")]
            media: scene.has_media(),
        }
    }

    /// Whether the scene has media or null boundaries (always false
    /// without the `media` feature, which refuses such scenes).
    #[inline]
    pub fn has_media(&self) -> bool {
        #[cfg(feature = "media")]
        return self.media;
        #[cfg(not(feature = "media"))]
        false
    }

    fn scene_has_masks(scene: &Scene) -> bool {
        scene.materials.iter().any(|m| m.detail.opacity.is_some())
    }

    /// The same tracer specialised to `analysis` (see [`Tracer::analysis`]).
    pub fn with_analysis(mut self, analysis: Analysis) -> Self {
        self.analysis = analysis;
        self.masks =
            analysis.effects.contains(Effect::AlphaMasks) && Self::scene_has_masks(self.scene);
        self
    }

    /// Whether ray queries walk through alpha masks (see
    /// [`Tracer::analysis`]): the scene has masks and the analysis them.
    #[inline]
    pub fn has_alpha_masks(&self) -> bool {
        self.masks
    }

    /// The primary ray through `raster` (lens point from `u_lens`): without
    /// depth of field in the analysis, the pinhole ray with no lens code
    /// run. Callers draw `u_lens` either way, so the random streams (and
    /// images) do not depend on the analysis.
    #[inline]
    pub fn camera_ray(&mut self, raster: Vec2, u_lens: Vec2) -> Ray {
        if self.analysis.effects.contains(Effect::DepthOfField) && self.camera.has_lens() {
            self.stats.lens_samples += 1;
            self.camera.generate_ray(raster, u_lens)
        } else {
            self.camera.pinhole_ray(raster)
        }
    }

    /// [`Bsdf::sample`], counted in [`Stats::bsdf_samples`].
    #[inline]
    pub fn sample_bsdf(
        &mut self,
        bsdf: &Bsdf,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        self.stats.bsdf_samples.add(bsdf.lobe());
        bsdf.sample(wo, u_lobe, u, mode)
    }

    /// [`Bsdf::eval`], counted in [`Stats::bsdf_evals`].
    #[inline]
    pub fn eval_bsdf(&mut self, bsdf: &Bsdf, wo: Vec3, wi: Vec3, mode: TransportMode) -> Rgb {
        self.stats.bsdf_evals.add(bsdf.lobe());
        bsdf.eval(wo, wi, mode)
    }

    /// The same tracer looking through `camera` instead of the scene's.
    pub fn with_camera(mut self, camera: Camera) -> Self {
        self.camera = camera;
        self
    }

    /// Closest surface along `ray`, resolved for shading. Degenerate
    /// triangles are treated as misses.
    // Forced, as `shade`: out of line, every hit's `Shading` was built on
    // the stack and copied to the caller.
    #[inline(always)]
    pub fn trace(&mut self, ray: &Ray) -> Option<Shading> {
        self.stats.rays += 1;
        #[cfg(feature = "alpha-masks")]
        if self.has_masks() {
            let sp = self.closest_opaque(ray)?;
            return Some(self.shade(sp));
        }
        let hit = self.accel.intersect(ray)?;
        let sp = self.scene.hit_point(&hit)?;
        Some(self.shade(sp))
    }

    /// Resolves the BSDF and frame at a surface point. A normal or bump
    /// map (when the analysis has them) replaces the shading frame, and
    /// `sp.ns` with its normal, so that every estimator's cosines and
    /// BSDF queries use the perturbed frame, as Mitsuba's wrappers
    /// evaluate the nested BSDF in it.
    #[inline(always)]
    pub fn shade(&self, sp: SurfacePoint) -> Shading {
        let scene = self.scene;
        let material = scene.material(&sp);
        // One `Shading` built at one exit, so that it is written in place
        // (early returns of whole `Shading`s made every call copy one).
        #[allow(unused_mut)]
        let mut sh = Shading {
            sp,
            bsdf: material.bsdf(|t| t.eval(sp.tex_coords(), scene.texture_images())),
            frame: Frame::from_normal(sp.ns),
        };
        #[cfg(feature = "normal-mapping")]
        if self.analysis.effects.contains(Effect::NormalMapping)
            && material.detail.perturbs_frame()
            && let Some(frame) = self.detail_frame(&sp, &material.detail)
        {
            sh.bsdf = sh.bsdf.with_unperturbed_normal(frame.to_local(sp.ns));
            sh.sp.ns = frame.n;
            sh.frame = frame;
            return sh;
        }
        // An anisotropic principled lobe is oriented by the first tangent,
        // which Mitsuba takes along ∂p/∂u (its `initialize_sh_frame`).
        #[cfg(feature = "principled")]
        if self.analysis.effects.contains(Effect::Principled) && material.is_anisotropic() {
            let (dp_du, _) = scene.uv_tangents(&sp);
            sh.frame = detail::tangent_frame(sp.ns, dp_du);
        }
        sh
    }

    /// The shading frame a normal or bump map gives at `sp` (`None` when
    /// the map encodes no direction there: the surface keeps its own).
    #[cfg(feature = "normal-mapping")]
    fn detail_frame(&self, sp: &SurfacePoint, detail: &Detail) -> Option<Frame> {
        let scene = self.scene;
        let (dp_du, dp_dv) = scene.uv_tangents(sp);
        if let Some(nm) = &detail.normal_map {
            let c = nm.eval(sp.tex_coords(), scene.texture_images());
            let base = detail::tangent_frame(sp.ns, dp_du);
            return detail::normal_mapped(&base, Vec3::new(c.r, c.g, c.b));
        }
        let bump = detail.bump_map.as_ref()?;
        let grad = bump.eval_1_grad(sp.uv, &scene.bitmaps) * detail.bump_scale;
        detail::bump_mapped(sp.ns, sp.ng, dp_du, dp_dv, grad)
    }

    /// Whether the analysis has alpha masks: only then do ray queries walk
    /// through masked surfaces.
    #[cfg(feature = "alpha-masks")]
    #[inline]
    fn has_masks(&self) -> bool {
        self.masks
    }

    /// Whether `ray`, having hit `sp`, passes through it: a masked surface
    /// lets it through with probability 1 − opacity ([`detail::mask_passes`]).
    #[cfg(feature = "alpha-masks")]
    #[inline]
    fn passes_mask(&self, ray: &Ray, sp: &SurfacePoint) -> bool {
        let scene = self.scene;
        match &scene.material(sp).detail.opacity {
            None => false,
            Some(o) => detail::mask_passes(
                o.eval_1(sp.tex_coords(), scene.texture_images()),
                ray.o,
                ray.d,
                sp.prim,
            ),
        }
    }

    /// `ray` continued past its hit at `sp` (parameter `t`): the same
    /// direction from the point offset to the far side of the surface,
    /// over what is left of its extent.
    #[cfg(feature = "alpha-masks")]
    #[inline]
    fn continued(ray: &Ray, t: f32, sp: &SurfacePoint) -> Ray {
        Ray {
            o: offset::offset_ray_origin(sp.p, sp.p_error, sp.ng, ray.d),
            d: ray.d,
            t_max: ray.t_max - t,
        }
    }

    /// The closest surface along `ray` that stops it: masked surfaces
    /// whose test passes are walked through (each step one more ray in
    /// [`Stats::rays`]); after [`MAX_MASK_CROSSINGS`] the next surface
    /// stops the ray whatever its opacity.
    #[cfg(feature = "alpha-masks")]
    fn closest_opaque(&mut self, ray: &Ray) -> Option<SurfacePoint> {
        let mut r = *ray;
        for crossing in 0..=MAX_MASK_CROSSINGS {
            let hit = self.accel.intersect(&r)?;
            let sp = self.scene.hit_point(&hit)?;
            if crossing == MAX_MASK_CROSSINGS || !self.passes_mask(&r, &sp) {
                return Some(sp);
            }
            r = Self::continued(&r, hit.t, &sp);
            self.stats.rays += 1;
        }
        None
    }

    /// Occlusion of one ray (counted by the caller): an any-hit query, and
    /// with masks in the scene, when that finds something, a walk that
    /// decides each masked surface on the way (the plain query's "free"
    /// stays free: masks only ever let more through).
    #[inline]
    fn occluded_ray(&mut self, ray: &Ray) -> bool {
        if !self.accel.occluded(ray) {
            return false;
        }
        #[cfg(feature = "alpha-masks")]
        if self.has_masks() {
            return self.occluded_walk(ray);
        }
        true
    }

    /// Whether something opaque lies along `ray`, walking through masked
    /// surfaces whose test passes.
    #[cfg(feature = "alpha-masks")]
    fn occluded_walk(&mut self, ray: &Ray) -> bool {
        let mut r = *ray;
        for _ in 0..MAX_MASK_CROSSINGS {
            let Some(hit) = self.accel.intersect(&r) else {
                return false;
            };
            // A degenerate triangle the any-hit query counted still blocks.
            let Some(sp) = self.scene.hit_point(&hit) else {
                return true;
            };
            if !self.passes_mask(&r, &sp) {
                return true;
            }
            r = Self::continued(&r, hit.t, &sp);
            self.stats.shadow_rays += 1;
        }
        true
    }

    /// Whether the segment between two surface points is blocked.
    #[inline]
    pub fn occluded_between(&mut self, a: &SurfacePoint, b: &SurfacePoint) -> bool {
        self.occluded_segment(offset::spawn_rays_between(
            a.p, a.p_error, a.ng, b.p, b.p_error, b.ng,
        ))
    }

    /// Whether the segment from a surface point to a free point (a camera
    /// lens) is blocked.
    #[inline]
    pub fn occluded_to_point(&mut self, a: &SurfacePoint, p: Vec3) -> bool {
        self.occluded_segment(offset::spawn_rays_between(
            a.p,
            a.p_error,
            a.ng,
            p,
            Vec3::ZERO,
            Vec3::ZERO,
        ))
    }

    /// Whether anything lies along unit direction `d` from a surface point
    /// (the shadow ray towards a light at infinity).
    #[inline]
    pub fn occluded_towards(&mut self, a: &SurfacePoint, d: Vec3) -> bool {
        self.stats.shadow_rays += 1;
        // Through `occluded_ray`, so alpha masks let light at infinity
        // through as they do any other shadow ray.
        self.occluded_ray(&offset::spawn_ray(a.p, a.p_error, a.ng, d))
    }

    /// Whether a segment spawned by [`offset::spawn_rays_between`] is
    /// blocked (a segment it refused is: it is tangent to a surface).
    // Forced: out of line, each shadow ray paid a call for a few
    // instructions of glue around the any-hit query.
    #[inline(always)]
    pub fn occluded_segment(&mut self, seg: Option<offset::SegmentRays>) -> bool {
        let Some(seg) = seg else { return true };
        self.stats.shadow_rays += 1;
        if self.occluded_ray(&seg.main) {
            return true;
        }
        seg.tail.is_some_and(|tail| {
            self.stats.shadow_rays += 1;
            self.occluded_ray(&tail)
        })
    }

    /// Closest surfaces along a bundle of rays, traced as packets of 4, 8
    /// or 16 lanes (the narrowest that holds the bundle; longer bundles in
    /// chunks of 16), or ray by ray when fewer than [`MIN_PACKET_LANES`]
    /// are live. `None` rays are inactive lanes; `out[i]` receives the
    /// shaded hit of `rays[i]` (`None` for a miss or an inactive lane).
    pub fn trace_bundle(&mut self, rays: &[Option<Ray>], out: &mut [Option<Shading>]) {
        debug_assert_eq!(rays.len(), out.len());
        // With masks, rays walk through masked surfaces one by one.
        if live_lanes(rays) < MIN_PACKET_LANES || self.walks_masks() {
            for (r, o) in rays.iter().zip(out.iter_mut()) {
                *o = r.as_ref().and_then(|r| self.trace(r));
            }
            return;
        }
        for (rays, out) in rays.chunks(16).zip(out.chunks_mut(16)) {
            match rays.len() {
                0..=4 => self.trace_chunk::<4>(rays, out),
                5..=8 => self.trace_chunk::<8>(rays, out),
                _ => self.trace_chunk::<16>(rays, out),
            }
        }
    }

    fn trace_chunk<const N: usize>(&mut self, rays: &[Option<Ray>], out: &mut [Option<Shading>]) {
        let (packet, active) = pack::<N>(rays);
        out.fill(None);
        if active.is_empty() {
            return;
        }
        self.count_packet(active, false);
        let mut hits = HitPacket::<N>::default();
        self.accel.intersect_packet(&packet, active, &mut hits);
        for i in active.iter() {
            out[i] = hits
                .get(i)
                .and_then(|h| self.scene.hit_point(&h))
                .map(|sp| self.shade(sp));
        }
    }

    /// Occlusion of a bundle of rays as packets (see
    /// [`Tracer::trace_bundle`]); `out[i]` is true when `rays[i]` is
    /// blocked, false for inactive lanes.
    pub fn occluded_bundle(&mut self, rays: &[Option<Ray>], out: &mut [bool]) {
        debug_assert_eq!(rays.len(), out.len());
        if live_lanes(rays) < MIN_PACKET_LANES || self.walks_masks() {
            for (r, o) in rays.iter().zip(out.iter_mut()) {
                *o = r.as_ref().is_some_and(|r| {
                    self.stats.shadow_rays += 1;
                    self.occluded_ray(r)
                });
            }
            return;
        }
        for (rays, out) in rays.chunks(16).zip(out.chunks_mut(16)) {
            let blocked = match rays.len() {
                0..=4 => self.occluded_chunk::<4>(rays),
                5..=8 => self.occluded_chunk::<8>(rays),
                _ => self.occluded_chunk::<16>(rays),
            };
            for (i, o) in out.iter_mut().enumerate() {
                *o = blocked.get(i);
            }
        }
    }

    fn occluded_chunk<const N: usize>(&mut self, rays: &[Option<Ray>]) -> LaneMask {
        let (packet, active) = pack::<N>(rays);
        if active.is_empty() {
            return LaneMask::NONE;
        }
        self.count_packet(active, true);
        self.accel.occluded_packet(&packet, active)
    }

    /// Whether ray queries walk through alpha masks (then bundles are
    /// traced ray by ray).
    #[inline]
    fn walks_masks(&self) -> bool {
        #[cfg(feature = "alpha-masks")]
        return self.has_masks();
        #[cfg(not(feature = "alpha-masks"))]
        false
    }

    /// Counts one packet with `active` lanes of closest-hit or occlusion
    /// (`shadow`) rays.
    #[inline]
    fn count_packet(&mut self, active: LaneMask, shadow: bool) {
        let n = active.count() as u64;
        if shadow {
            self.stats.shadow_rays += n;
        } else {
            self.stats.rays += n;
        }
        self.stats.packets += 1;
        self.stats.packet_rays += n;
    }
}

/// The far end of a transmittance query ([`Tracer::transmittance`]).
#[cfg(feature = "media")]
#[derive(Clone, Copy, Debug)]
pub enum Endpoint {
    /// A point on a surface (offset off it towards the query's start).
    Surface(SurfacePoint),
    /// A point on no surface (a point light).
    Point(Vec3),
    /// Infinitely far along a unit direction (a light at infinity).
    Direction(Vec3),
}

/// Most null boundaries one transmittance query crosses before it counts
/// as blocked (a bound on the work of a ray through a stack of them).
pub const MAX_NULL_CROSSINGS: usize = 64;

#[cfg(feature = "media")]
impl<I: Intersector> Tracer<'_, I> {
    /// Transmittance from a point (`p` with error bound `p_error` on a
    /// surface with geometric normal `ng`, or `ng` zero for a point in a
    /// medium) to `to`, starting in `medium`: zero when a surface other
    /// than a null boundary is in the way; otherwise the product of each
    /// medium's exp(−σ_t ℓ) over the lengths ℓ the segment runs in it,
    /// the medium tracked across null boundaries as a path crosses them.
    /// Every ray it traces counts in [`Stats::shadow_rays`].
    #[inline]
    pub fn transmittance(
        &mut self,
        p: Vec3,
        p_error: Vec3,
        ng: Vec3,
        to: Endpoint,
        medium: Option<MediumId>,
    ) -> Rgb {
        self.transmittance_pieces(p, p_error, ng, to, medium, |_, _| {})
    }

    /// [`Tracer::transmittance`], also handing each stretch of the segment
    /// between null boundaries to `piece(medium, length)`, in order from
    /// the start (the stretches a free-flight sampler draws one distance
    /// each for: BDPT's densities of a connection). Masked surfaces the
    /// segment passes do not split a stretch, as a traced ray walks them
    /// within one query. When the result is zero the pieces may be
    /// incomplete.
    pub fn transmittance_pieces(
        &mut self,
        p: Vec3,
        p_error: Vec3,
        ng: Vec3,
        to: Endpoint,
        medium: Option<MediumId>,
        mut piece: impl FnMut(Option<MediumId>, f32),
    ) -> Rgb {
        let scene = self.scene;
        // The direction to the far end, that end (offset off its surface
        // towards the start; none at infinity) and the rays' extent.
        let (towards, end, t_max) = match to {
            Endpoint::Surface(sp) => (
                sp.p - p,
                Some(offset::offset_ray_origin(sp.p, sp.p_error, sp.ng, p - sp.p)),
                1.0 - offset::SHADOW_EPSILON,
            ),
            Endpoint::Point(q) => (q - p, Some(q), 1.0),
            Endpoint::Direction(d) => (d, None, 1.0),
        };
        // A segment tangent to the start's surface carries nothing (as
        // `offset::spawn_rays_between` refuses it).
        if offset::side_of(ng, towards).is_none() {
            return Rgb::ZERO;
        }
        let mut o = offset::offset_ray_origin(p, p_error, ng, towards);
        let mut medium = medium;
        let mut tr = Rgb::ONE;
        // Length of the current stretch before `o` (masked surfaces
        // passed).
        let mut run = 0.0f32;
        for _ in 0..MAX_NULL_CROSSINGS {
            let ray = match end {
                Some(e) => Ray { o, d: e - o, t_max },
                None => Ray::new(o, towards),
            };
            self.stats.shadow_rays += 1;
            let Some(hit) = self.accel.intersect(&ray) else {
                let left = match end {
                    Some(e) => (e - o).length(),
                    None => f32::INFINITY,
                };
                if let Some(m) = medium {
                    tr *= scene.medium(m).transmittance(left);
                }
                piece(medium, run + left);
                return tr;
            };
            // A degenerate triangle the query reported still blocks.
            let Some(sp) = scene.hit_point(&hit) else {
                return Rgb::ZERO;
            };
            // A masked surface whose test passes is walked through as the
            // plain shadow rays walk it (it changes no medium).
            #[cfg(feature = "alpha-masks")]
            let passes = self.has_masks() && self.passes_mask(&ray, &sp);
            #[cfg(not(feature = "alpha-masks"))]
            let passes = false;
            if !passes && !matches!(scene.material(&sp).kind, MaterialKind::Null) {
                return Rgb::ZERO;
            }
            let len = (sp.p - o).length();
            if let Some(m) = medium {
                tr *= scene.medium(m).transmittance(len);
                if tr.is_black() {
                    return tr;
                }
            }
            if passes {
                run += len;
            } else {
                piece(medium, run + len);
                run = 0.0;
            }
            let iface = scene.surface_media(sp.surface);
            if !passes && iface.is_transition() {
                medium = iface.target(sp.ng, ray.d);
            }
            o = offset::offset_ray_origin(sp.p, sp.p_error, sp.ng, ray.d);
        }
        Rgb::ZERO
    }

    /// The medium a point lies in that no surface's media name (a point
    /// on an emitter whose mesh names none, a point or spot light): the
    /// one on the near side of the first surface naming media that a ray
    /// from it along `d` meets (surfaces naming none passed, as they change
    /// no medium); `None` when the ray meets none (leaves the scene, or
    /// passes [`MAX_NULL_CROSSINGS`] surfaces). `p` has error bound
    /// `p_error` on a surface of geometric normal `ng` (zero off
    /// surfaces). In a scene whose media are consistent — every ray
    /// between two points crosses the same boundaries — any direction
    /// gives the same answer. Every ray it traces counts in
    /// [`Stats::shadow_rays`].
    pub fn enclosing_medium(
        &mut self,
        p: Vec3,
        p_error: Vec3,
        ng: Vec3,
        d: Vec3,
    ) -> Option<Option<MediumId>> {
        let scene = self.scene;
        let mut o = offset::offset_ray_origin(p, p_error, ng, d);
        for _ in 0..MAX_NULL_CROSSINGS {
            self.stats.shadow_rays += 1;
            let hit = self.accel.intersect(&Ray::new(o, d))?;
            let sp = scene.hit_point(&hit)?;
            let iface = scene.surface_media(sp.surface);
            if iface.is_transition() {
                // The side the ray arrives from.
                return Some(iface.target(sp.ng, -d));
            }
            o = offset::offset_ray_origin(sp.p, sp.p_error, sp.ng, d);
        }
        None
    }
}

/// Most masked surfaces one ray walks through before the next surface
/// stops it whatever its opacity (a bound on the work of a ray through a
/// dense stack of cut-outs, e.g. foliage).
pub const MAX_MASK_CROSSINGS: usize = 64;

/// Bundles with fewer live rays than this are traced ray by ray: a packet
/// of 2–4 live lanes is slower than its rays one by one. Measured on
/// veach-bidir, CMLT k = 4 (bundles of 4 candidates and 3 reference
/// points), 1 thread: 0.052 M level-1 mutations/s with packets from 2
/// lanes, 0.064 with this threshold; k = 16 unchanged.
pub const MIN_PACKET_LANES: usize = 5;

/// How many rays of a bundle are live.
#[inline]
fn live_lanes(rays: &[Option<Ray>]) -> usize {
    rays.iter().filter(|r| r.is_some()).count()
}

/// Rays `rays` (at most N) in SoA layout with the mask of present ones.
#[inline]
fn pack<const N: usize>(rays: &[Option<Ray>]) -> (RayPacket<N>, LaneMask) {
    let mut packet = RayPacket::<N>::default();
    let mut active = LaneMask::NONE;
    for (i, r) in rays.iter().enumerate().take(N) {
        if let Some(r) = r {
            packet.set(i, r);
            active.set(i);
        }
    }
    (packet, active)
}

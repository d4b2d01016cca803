//! The Embree 3 backend (feature `embree`): the system's `libembree3`
//! behind the [`Intersector`] seam.
//!
//! [`EmbreeScene::new`] takes the same scene-global triangle list as
//! [`crate::accel::bvh::Bvh::build`] and reports the same numbering:
//! degenerate triangles ([`is_degenerate`]) are left out, as by our BVH and
//! the brute-force reference, and Embree's `primID` is mapped back through a
//! table. Embree's `(u, v)` are the weights of vertices 1 and 2, i.e. our
//! `(b1, b2)`.
//!
//! Facts of the system library this relies on (Debian's 3.13 build):
//! - `rtcInitIntersectContext` is an inline header function, re-implemented
//!   in `sys::RTCIntersectContext::new` (private);
//! - ray masks are compiled in, so every ray carries mask `0xFFFF_FFFF`
//!   (mask 0 would hit nothing);
//! - packets want 16/32/64-byte alignment for 4/8/16 lanes and a `valid`
//!   word of -1 (active) or 0 per lane; `sys::RTCRayHitN` is 64-byte
//!   aligned.
//!
//! Embree accepts hits with `t` in `[tnear, tfar]`; our contract is the open
//! interval `(0, t_max)`, so `tnear = 0` and `tfar` is the float below
//! `t_max`. Distances differ from our watertight test by rounding only.
//! Single rays use incoherent traversal, packets (bundles) coherent.

mod sys;

use alloc::vec::Vec;
use core::ffi::c_void;
use core::ptr;

use glam::Vec3;

use super::Intersector;
use crate::geometry::triangle::is_degenerate;
use crate::geometry::{Hit, HitPacket, LaneMask, Ray, RayPacket};

/// Why an [`EmbreeScene`] could not be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmbreeError {
    /// `rtcNewDevice` failed; the `RTCError` code (e.g. 5 = unsupported CPU).
    Device(u32),
    /// Creating or committing the scene failed; the `RTCError` code.
    Scene(u32),
    /// The library was built with back-face culling, which would break the
    /// "both faces are hit" contract.
    BackfaceCulling,
    /// More triangles than `u32` primitive ids can number.
    TooManyTriangles,
}

impl core::fmt::Display for EmbreeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            EmbreeError::Device(e) => write!(f, "Embree: device creation failed (RTCError {e})"),
            EmbreeError::Scene(e) => write!(f, "Embree: scene build failed (RTCError {e})"),
            EmbreeError::BackfaceCulling => {
                write!(f, "Embree: library built with back-face culling")
            }
            EmbreeError::TooManyTriangles => write!(f, "Embree: too many triangles"),
        }
    }
}

impl std::error::Error for EmbreeError {}

/// An Embree device and a committed triangle scene; implements
/// [`Intersector`]. Released on drop.
///
/// Queries are thread-safe (Embree allows concurrent `rtcIntersect*` /
/// `rtcOccluded*` on a committed scene), so the type is `Send + Sync`.
#[derive(Debug)]
pub struct EmbreeScene {
    device: sys::RTCDevice,
    scene: sys::RTCScene,
    /// Embree `primID` → scene-global triangle index.
    prim_ids: Vec<u32>,
}

// SAFETY: the device and scene handles are only used for queries after
// `rtcCommitScene`, which Embree documents as safe from any number of
// threads, and for release in `Drop` (exclusive access).
unsafe impl Send for EmbreeScene {}
// SAFETY: see `Send`: `&EmbreeScene` only allows concurrent queries.
unsafe impl Sync for EmbreeScene {}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        // SAFETY: the handles were returned by Embree (or are null, which is
        // skipped) and are released exactly once, here.
        unsafe {
            if !self.scene.is_null() {
                sys::rtcReleaseScene(self.scene);
            }
            if !self.device.is_null() {
                sys::rtcReleaseDevice(self.device);
            }
        }
    }
}

/// A ray our backends could hit anything with; others miss (Embree is not
/// asked about them, so non-finite input never reaches it).
#[inline]
fn usable(r: &Ray) -> bool {
    r.o.is_finite() && r.d.is_finite() && r.d != Vec3::ZERO && r.t_max > 0.0
}

/// Embree's inclusive `tnear` for our exclusive lower bound 0: Embree
/// accepts `t == tnear`, and with `tnear = 0` reports `t = ±0` for rays that
/// start on a surface.
const TNEAR: f32 = f32::MIN_POSITIVE;

/// Embree's inclusive `tfar` for our exclusive `t_max > 0`: the next float
/// down (infinity stays).
#[inline]
fn tfar(t_max: f32) -> f32 {
    if t_max.is_finite() {
        f32::from_bits(t_max.to_bits() - 1)
    } else {
        t_max
    }
}

impl EmbreeScene {
    /// Builds an Embree scene (robust mode, high build quality) over `tris`
    /// in scene-global order; `tris[i]` is reported as `prim == i`.
    pub fn new(tris: &[[Vec3; 3]]) -> Result<Self, EmbreeError> {
        if tris.len() >= u32::MAX as usize {
            return Err(EmbreeError::TooManyTriangles);
        }
        let prim_ids: Vec<u32> = (0..tris.len() as u32)
            .filter(|&i| {
                let [a, b, c] = tris[i as usize];
                !is_degenerate(a, b, c)
            })
            .collect();
        // SAFETY: a null config string is allowed (defaults).
        let device = unsafe { sys::rtcNewDevice(ptr::null()) };
        if device.is_null() {
            // SAFETY: a null device queries the thread-local creation error.
            return Err(EmbreeError::Device(unsafe {
                sys::rtcGetDeviceError(ptr::null_mut())
            }));
        }
        // From here on, `Drop` releases whatever was created.
        let mut me = EmbreeScene {
            device,
            scene: ptr::null_mut(),
            prim_ids,
        };
        // SAFETY: `device` is a live device handle.
        let culling = unsafe {
            sys::rtcGetDeviceProperty(device, sys::RTC_DEVICE_PROPERTY_BACKFACE_CULLING_ENABLED)
        };
        if culling != 0 {
            return Err(EmbreeError::BackfaceCulling);
        }
        // SAFETY: `device` is live; the returned handle is checked for null.
        me.scene = unsafe { sys::rtcNewScene(device) };
        if me.scene.is_null() {
            return Err(me.error(EmbreeError::Scene));
        }
        // SAFETY: live scene handle; valid flag and quality values.
        unsafe {
            sys::rtcSetSceneFlags(me.scene, sys::RTC_SCENE_FLAG_ROBUST);
            sys::rtcSetSceneBuildQuality(me.scene, sys::RTC_BUILD_QUALITY_HIGH);
        }
        if !me.prim_ids.is_empty() {
            me.attach_triangles(tris)?;
        }
        // SAFETY: live scene handle; no query runs before this returns.
        unsafe { sys::rtcCommitScene(me.scene) };
        match me.error(EmbreeError::Scene) {
            EmbreeError::Scene(sys::RTC_ERROR_NONE) => Ok(me),
            e => Err(e),
        }
    }

    /// The device's pending error code wrapped by `kind`.
    fn error(&self, kind: fn(u32) -> EmbreeError) -> EmbreeError {
        // SAFETY: `self.device` is a live device handle.
        kind(unsafe { sys::rtcGetDeviceError(self.device) })
    }

    /// One triangle geometry holding the non-degenerate triangles in
    /// `prim_ids` order, each with its own three vertices.
    fn attach_triangles(&mut self, tris: &[[Vec3; 3]]) -> Result<(), EmbreeError> {
        let n = self.prim_ids.len();
        // SAFETY: live device; the handle is checked for null.
        let geom = unsafe { sys::rtcNewGeometry(self.device, sys::RTC_GEOMETRY_TYPE_TRIANGLE) };
        if geom.is_null() {
            return Err(self.error(EmbreeError::Scene));
        }
        // SAFETY: live geometry; Embree allocates (with its own padding) a
        // buffer of `3n` float3 vertices and `n` uint3 triangles, returned
        // as writable pointers of that many 12-byte items, 4-byte aligned.
        let (verts, index) = unsafe {
            let v = sys::rtcSetNewGeometryBuffer(
                geom,
                sys::RTC_BUFFER_TYPE_VERTEX,
                0,
                sys::RTC_FORMAT_FLOAT3,
                12,
                3 * n,
            ) as *mut f32;
            let i = sys::rtcSetNewGeometryBuffer(
                geom,
                sys::RTC_BUFFER_TYPE_INDEX,
                0,
                sys::RTC_FORMAT_UINT3,
                12,
                n,
            ) as *mut u32;
            (v, i)
        };
        if verts.is_null() || index.is_null() {
            // SAFETY: the geometry is ours and not attached.
            unsafe { sys::rtcReleaseGeometry(geom) };
            return Err(self.error(EmbreeError::Scene));
        }
        // SAFETY: both buffers hold 9n elements (checked non-null above) and
        // nothing else aliases them until the geometry is committed.
        let (verts, index) = unsafe {
            (
                core::slice::from_raw_parts_mut(verts, 9 * n),
                core::slice::from_raw_parts_mut(index, 3 * n),
            )
        };
        for (k, &id) in self.prim_ids.iter().enumerate() {
            for (j, p) in tris[id as usize].iter().enumerate() {
                verts[9 * k + 3 * j..9 * k + 3 * j + 3].copy_from_slice(&p.to_array());
                index[3 * k + j] = (3 * k + j) as u32;
            }
        }
        // SAFETY: live geometry and scene; attaching takes a reference, so
        // releasing ours afterwards leaves the scene the owner.
        unsafe {
            sys::rtcCommitGeometry(geom);
            sys::rtcAttachGeometry(self.scene, geom);
            sys::rtcReleaseGeometry(geom);
        }
        Ok(())
    }

    /// Our hit from Embree's `(tfar, primID, u, v)`.
    #[inline]
    fn hit(&self, geom: u32, prim: u32, t: f32, u: f32, v: f32) -> Option<Hit> {
        if geom == sys::RTC_INVALID_GEOMETRY_ID {
            return None;
        }
        let prim = *self.prim_ids.get(prim as usize)?;
        Some(Hit {
            t,
            prim,
            b1: u,
            b2: v,
        })
    }

    /// Copies the usable active lanes into an Embree packet; returns it with
    /// its `valid` words and the mask of those lanes.
    #[inline]
    fn packet<const N: usize>(
        rays: &RayPacket<N>,
        active: LaneMask,
    ) -> (sys::RTCRayHitN<N>, sys::ValidN<N>, u32) {
        let mut rh = sys::RTCRayHitN::<N> {
            ray: sys::RTCRayN {
                org_x: [0.0; N],
                org_y: [0.0; N],
                org_z: [0.0; N],
                tnear: [TNEAR; N],
                dir_x: [0.0; N],
                dir_y: [0.0; N],
                dir_z: [1.0; N],
                time: [0.0; N],
                tfar: [-1.0; N],
                mask: [u32::MAX; N],
                id: [0; N],
                flags: [0; N],
            },
            hit: sys::RTCHitN {
                Ng_x: [0.0; N],
                Ng_y: [0.0; N],
                Ng_z: [0.0; N],
                u: [0.0; N],
                v: [0.0; N],
                primID: [sys::RTC_INVALID_GEOMETRY_ID; N],
                geomID: [sys::RTC_INVALID_GEOMETRY_ID; N],
                instID: [[sys::RTC_INVALID_GEOMETRY_ID; N]],
            },
        };
        let mut valid = sys::ValidN([0i32; N]);
        let mut live = 0u32;
        for i in active.iter().filter(|&i| i < N) {
            let r = rays.get(i);
            if !usable(&r) {
                continue;
            }
            rh.ray.org_x[i] = r.o.x;
            rh.ray.org_y[i] = r.o.y;
            rh.ray.org_z[i] = r.o.z;
            rh.ray.dir_x[i] = r.d.x;
            rh.ray.dir_y[i] = r.d.y;
            rh.ray.dir_z[i] = r.d.z;
            rh.ray.tfar[i] = tfar(r.t_max);
            rh.ray.id[i] = i as u32;
            valid.0[i] = -1;
            live |= 1 << i;
        }
        (rh, valid, live)
    }

    /// Runs `rtcIntersect{N}` (`OCCLUDED = false`) or `rtcOccluded{N}` on a
    /// packet for N = 4, 8, 16; false for other widths (nothing ran).
    #[inline]
    fn trace_packet<const N: usize, const OCCLUDED: bool>(
        &self,
        rh: &mut sys::RTCRayHitN<N>,
        valid: &sys::ValidN<N>,
    ) -> bool {
        let mut ctx = sys::RTCIntersectContext::new(sys::RTC_INTERSECT_CONTEXT_FLAG_COHERENT);
        let v = valid.0.as_ptr();
        let p = (rh as *mut sys::RTCRayHitN<N>).cast::<c_void>();
        // SAFETY: `self.scene` is committed; `RTCRayHitN<N>` has the layout
        // of `RTCRayHit{N}` (whose `ray` member is the `RTCRay{N}` the
        // occlusion calls take) at 64-byte alignment, and `valid` holds N
        // words of -1/0 at 64-byte alignment; the call matches N.
        unsafe {
            match (N, OCCLUDED) {
                (4, false) => sys::rtcIntersect4(v, self.scene, &mut ctx, p),
                (8, false) => sys::rtcIntersect8(v, self.scene, &mut ctx, p),
                (16, false) => sys::rtcIntersect16(v, self.scene, &mut ctx, p),
                (4, true) => sys::rtcOccluded4(v, self.scene, &mut ctx, p),
                (8, true) => sys::rtcOccluded8(v, self.scene, &mut ctx, p),
                (16, true) => sys::rtcOccluded16(v, self.scene, &mut ctx, p),
                _ => return false,
            }
        }
        true
    }

    /// An Embree ray-hit record for a usable `ray`, hit fields empty.
    #[inline]
    fn ray_hit1(ray: &Ray) -> sys::RTCRayHit {
        sys::RTCRayHit {
            ray: Self::ray1(ray),
            hit: sys::RTCHit {
                primID: sys::RTC_INVALID_GEOMETRY_ID,
                geomID: sys::RTC_INVALID_GEOMETRY_ID,
                instID: [sys::RTC_INVALID_GEOMETRY_ID],
                ..Default::default()
            },
        }
    }

    /// The usable rays of `rays` (at most [`STREAM_CHUNK`]) as Embree
    /// records made by `record`, in `out`; returns how many, with their
    /// indices in `index`.
    #[inline]
    fn stream_chunk<T>(
        rays: &[Ray],
        record: impl Fn(&Ray) -> T,
        out: &mut [T; STREAM_CHUNK],
        index: &mut [usize; STREAM_CHUNK],
    ) -> usize {
        let mut m = 0;
        for (i, r) in rays.iter().enumerate().filter(|(_, r)| usable(r)) {
            out[m] = record(r);
            index[m] = i;
            m += 1;
        }
        m
    }

    /// An Embree single ray for a usable `ray`.
    #[inline]
    fn ray1(ray: &Ray) -> sys::RTCRay {
        sys::RTCRay {
            org_x: ray.o.x,
            org_y: ray.o.y,
            org_z: ray.o.z,
            tnear: TNEAR,
            dir_x: ray.d.x,
            dir_y: ray.d.y,
            dir_z: ray.d.z,
            time: 0.0,
            tfar: tfar(ray.t_max),
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }
}

impl Intersector for EmbreeScene {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !usable(ray) {
            return None;
        }
        let mut rh = Self::ray_hit1(ray);
        let mut ctx = sys::RTCIntersectContext::new(sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
        // SAFETY: committed scene; `rh` is a 16-byte aligned RTCRayHit with
        // a finite ray and mask ~0.
        unsafe { sys::rtcIntersect1(self.scene, &mut ctx, &mut rh) };
        self.hit(
            rh.hit.geomID,
            rh.hit.primID,
            rh.ray.tfar,
            rh.hit.u,
            rh.hit.v,
        )
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if !usable(ray) {
            return false;
        }
        let mut r = Self::ray1(ray);
        let mut ctx = sys::RTCIntersectContext::new(sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
        // SAFETY: committed scene; `r` is a 16-byte aligned RTCRay.
        unsafe { sys::rtcOccluded1(self.scene, &mut ctx, &mut r) };
        // Embree marks an occluded ray by setting tfar to -inf.
        r.tfar < 0.0
    }

    fn intersect_packet<const N: usize>(
        &self,
        rays: &RayPacket<N>,
        active: LaneMask,
        hits: &mut HitPacket<N>,
    ) {
        let (mut rh, valid, live) = Self::packet(rays, active);
        if live == 0 || !self.trace_packet::<N, false>(&mut rh, &valid) {
            for i in active.iter().filter(|&i| i < N) {
                hits.set(i, self.intersect(&rays.get(i)));
            }
            return;
        }
        for i in active.iter().filter(|&i| i < N) {
            let h = if live >> i & 1 != 0 {
                let (ray, hit) = (&rh.ray, &rh.hit);
                self.hit(
                    hit.geomID[i],
                    hit.primID[i],
                    ray.tfar[i],
                    hit.u[i],
                    hit.v[i],
                )
            } else {
                None
            };
            hits.set(i, h);
        }
    }

    fn occluded_packet<const N: usize>(&self, rays: &RayPacket<N>, active: LaneMask) -> LaneMask {
        let (mut rh, valid, live) = Self::packet(rays, active);
        if live == 0 {
            return LaneMask::NONE;
        }
        if !self.trace_packet::<N, true>(&mut rh, &valid) {
            let mut out = LaneMask::NONE;
            for i in LaneMask(live).iter() {
                if self.occluded(&rays.get(i)) {
                    out.set(i);
                }
            }
            return out;
        }
        let mut out = LaneMask::NONE;
        for i in LaneMask(live).iter() {
            if rh.ray.tfar[i] < 0.0 {
                out.set(i);
            }
        }
        out
    }

    /// `rtcIntersect1M` in incoherent mode, `STREAM_CHUNK` (64) rays per call
    /// (Embree 3.13 traces such a stream as packets of its SIMD width).
    fn intersect_stream(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.stream(
            rays,
            hits,
            None,
            Self::ray_hit1,
            |ctx, records, m| {
                // SAFETY: committed scene; `records[..m]` are 16-byte
                // aligned RTCRayHit records of finite rays with mask ~0
                // (`stream`), and the stride is the record's size.
                unsafe {
                    sys::rtcIntersect1M(
                        self.scene,
                        ctx,
                        records.as_mut_ptr(),
                        m,
                        size_of::<sys::RTCRayHit>(),
                    )
                }
            },
            |r| self.hit(r.hit.geomID, r.hit.primID, r.ray.tfar, r.hit.u, r.hit.v),
        );
    }

    /// `rtcOccluded1M` in incoherent mode, `STREAM_CHUNK` (64) rays per call
    /// (Embree 3.13 sorts such a stream by direction octant and traces it
    /// as packets).
    fn occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.stream(
            rays,
            occluded,
            false,
            Self::ray1,
            |ctx, records, m| {
                // SAFETY: committed scene; `records[..m]` are 16-byte
                // aligned RTCRay records of finite rays (`stream`), stride
                // = the record's size.
                unsafe {
                    sys::rtcOccluded1M(
                        self.scene,
                        ctx,
                        records.as_mut_ptr(),
                        m,
                        size_of::<sys::RTCRay>(),
                    )
                }
            },
            // Embree marks an occluded ray by setting tfar to -inf.
            |r| r.tfar < 0.0,
        );
    }
}

impl EmbreeScene {
    /// A stream through one of Embree's `*1M` calls: per chunk of
    /// `STREAM_CHUNK` rays, the usable ones become `record`s and go to
    /// `call(context, records, count)`, and each answer is read back with
    /// `answer`; unusable rays (and chunks with none usable) get `miss`.
    /// Outputs past the shorter of `rays` and `out` are left alone.
    fn stream<T: Copy + Default, O: Copy>(
        &self,
        rays: &[Ray],
        out: &mut [O],
        miss: O,
        record: impl Fn(&Ray) -> T,
        call: impl Fn(&mut sys::RTCIntersectContext, &mut [T; STREAM_CHUNK], u32),
        answer: impl Fn(&T) -> O,
    ) {
        let n = rays.len().min(out.len());
        let mut records = [T::default(); STREAM_CHUNK];
        let mut index = [0usize; STREAM_CHUNK];
        for (rays, out) in rays[..n]
            .chunks(STREAM_CHUNK)
            .zip(out[..n].chunks_mut(STREAM_CHUNK))
        {
            out.fill(miss);
            let m = Self::stream_chunk(rays, &record, &mut records, &mut index);
            if m == 0 {
                continue;
            }
            let mut ctx = sys::RTCIntersectContext::new(sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
            // `m` ≤ 64 fits Embree's `unsigned int`.
            call(&mut ctx, &mut records, m as u32);
            for (r, &i) in records[..m].iter().zip(&index[..m]) {
                out[i] = answer(r);
            }
        }
    }
}

/// Rays per `rtcIntersect1M`/`rtcOccluded1M` call: the records live in a
/// 5 KB array on the stack (no allocation per call), and Embree cuts a
/// stream into batches of its own anyway (`RayStreamFilter::filterAOS`).
const STREAM_CHUNK: usize = 64;

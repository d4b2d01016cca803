//! The host's own ray tracer behind the core's intersector seam: C
//! callbacks for single rays and SoA packets of 4, 8 or 16 lanes.
//!
//! The host may also own analytic shapes ([`cmlt_shapes`]): its
//! intersector reports them with [`CMLT_SHAPE_BIT`] set in `prim_id` and
//! its own surface parameters in `u`, `v`, which the core hands back to
//! the shapes' `surface` callback for the point to shade.
//!
//! Hits the host reports are checked before the core sees them — a
//! primitive index past the scene's triangles or shapes, a non-finite or
//! out-of-interval distance or barycentric, is counted
//! (`HostIntersector::rejected_hits`) and treated as a miss; an invalid
//! surface point is counted (`HostShapes`) and scatters nothing. A buggy
//! callback can cost image quality but never memory safety or a panic.

use std::ffi::c_void;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use cmlt_core::accel::Intersector;
use cmlt_core::geometry::{Hit, HitPacket, LaneMask, Ray, RayPacket};
use cmlt_core::math::{Vec2, Vec3};
use cmlt_core::scene::{SHAPE_PRIM_BIT, ShapePoint, ShapeSurface};

/// How far a host's barycentric weight may leave [0, 1] and still count
/// as a hit on the triangle: host tracers round (Embree reports weights of
/// about −10⁻⁷ on an edge); a weight off by more is a wrong answer.
const BARYCENTRIC_SLACK: f32 = 1e-4;

/// `prim_id` of a miss.
pub const CMLT_INVALID_ID: u32 = u32::MAX;

/// `prim_id = CMLT_SHAPE_BIT | shape` names host shape `shape` (numbered
/// from 0 across all `cmlt_scene_add_shapes` calls, in order).
pub const CMLT_SHAPE_BIT: u32 = 0x8000_0000;

// cbindgen writes the literal above into cmlt.h; it must be the core's bit.
const _: () = assert!(CMLT_SHAPE_BIT == SHAPE_PRIM_BIT);

/// A point on a host shape, as its `surface` callback describes it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
#[allow(non_camel_case_types)]
pub struct cmlt_surface {
    /// Position.
    pub p: [f32; 3],
    /// Absolute error bound of `p` per axis (≥ 0): ray origins leaving the
    /// point are pushed past it. For a point computed on an analytic
    /// surface, `5 · FLT_EPSILON · |p|` per axis is a safe choice.
    pub p_error: [f32; 3],
    /// Geometric normal (any non-zero length; normalised by the library).
    pub ng: [f32; 3],
    /// Shading normal (any non-zero length); equal to `ng` if unsure.
    pub ns: [f32; 3],
    /// Texture coordinates.
    pub uv: [f32; 2],
}

/// The point of shape `shape` (an index within its group, `0..count`) at
/// the surface parameters `u`, `v` the host's intersector reported: fill
/// `out` and return 1, or return 0 when there is none. Called from every
/// rendering thread; must not call back into cmlt.
#[allow(non_camel_case_types)]
pub type cmlt_surface_fn = Option<
    unsafe extern "C" fn(
        user: *mut c_void,
        shape: u32,
        u: f32,
        v: f32,
        out: *mut cmlt_surface,
    ) -> u32,
>;

/// A group of analytic shapes the host intersects itself (spheres,
/// patches, …), all of one material. Shapes scatter but never emit.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct cmlt_shapes {
    /// Number of shapes (≥ 1).
    pub count: u32,
    /// Material id from `cmlt_scene_add_material`.
    pub material: u32,
    /// Passed to `surface`.
    pub user: *mut c_void,
    /// Surface reconstruction (required).
    pub surface: cmlt_surface_fn,
}

/// [`cmlt_shapes`] as the core's [`ShapeSurface`], counting invalid
/// answers in a counter shared by the scene's groups.
pub(crate) struct HostShapes {
    callbacks: cmlt_shapes,
    rejected: Arc<AtomicU64>,
}

// SAFETY: as for HostIntersector: the API contract makes `surface`
// callable from any rendering thread, concurrently.
unsafe impl Send for HostShapes {}
// SAFETY: as for Send; the only shared state is an atomic counter.
unsafe impl Sync for HostShapes {}

impl HostShapes {
    /// Wraps `callbacks` (`surface` checked non-null by the caller).
    pub fn new(callbacks: cmlt_shapes, rejected: Arc<AtomicU64>) -> Self {
        HostShapes {
            callbacks,
            rejected,
        }
    }
}

impl ShapeSurface for HostShapes {
    fn surface(&self, shape: u32, u: f32, v: f32) -> Option<ShapePoint> {
        let f = self.callbacks.surface?;
        let mut out = cmlt_surface::default();
        // SAFETY: the host's callback contract; `out` is valid for the call.
        let found = unsafe { f(self.callbacks.user, shape, u, v, &mut out) } != 0;
        if !found {
            self.rejected.fetch_add(1, Ordering::Relaxed);
            return None;
        }
        let point = ShapePoint {
            p: Vec3::from_array(out.p),
            p_error: Vec3::from_array(out.p_error),
            ng: Vec3::from_array(out.ng),
            ns: Vec3::from_array(out.ns),
            uv: Vec2::from_array(out.uv),
        };
        if point.unit_normals().is_none() {
            self.rejected.fetch_add(1, Ordering::Relaxed);
            return None;
        }
        Some(point)
    }
}

/// One ray: points `org + t·dir` for `t` in the open interval (0, `tfar`).
/// `dir` is not necessarily unit length; `t` is in units of `|dir|`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
#[allow(non_camel_case_types)]
pub struct cmlt_ray {
    /// Origin.
    pub org: [f32; 3],
    /// Direction.
    pub dir: [f32; 3],
    /// Exclusive upper bound of `t`.
    pub tfar: f32,
}

/// The closest hit of a ray: `prim_id` is the scene-global triangle index
/// (meshes numbered in the order they were added, triangles consecutively
/// within a mesh; `cmlt_scene_add_mesh` returns a mesh's first index), `u`
/// and `v` the barycentric weights of the triangle's second and third
/// vertex. A hit on a host shape has `prim_id = CMLT_SHAPE_BIT | shape` and
/// the host's surface parameters (any finite values) in `u`, `v`. A miss
/// has `prim_id` = `CMLT_INVALID_ID`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct cmlt_hit {
    /// Ray parameter of the hit, in (0, tfar).
    pub t: f32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
    /// Scene-global triangle index, or `CMLT_INVALID_ID`.
    pub prim_id: u32,
}

/// A packet of up to 16 rays in SoA layout (Embree's `RTCRay16` order:
/// origins, directions, `tfar`); lane `i` of a packet of `width` lanes is
/// element `i` of every array, lanes ≥ `width` are unused. The library
/// keeps it 64-byte aligned.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct cmlt_ray_packet {
    /// Origin x per lane.
    pub org_x: [f32; 16],
    /// Origin y per lane.
    pub org_y: [f32; 16],
    /// Origin z per lane.
    pub org_z: [f32; 16],
    /// Direction x per lane.
    pub dir_x: [f32; 16],
    /// Direction y per lane.
    pub dir_y: [f32; 16],
    /// Direction z per lane.
    pub dir_z: [f32; 16],
    /// Upper bound of `t` per lane.
    pub tfar: [f32; 16],
}

/// The hits of a packet, SoA, one lane per ray; lanes outside the active
/// mask must be left untouched.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
#[allow(non_camel_case_types)]
pub struct cmlt_hit_packet {
    /// Hit distance per lane.
    pub t: [f32; 16],
    /// Barycentric u per lane.
    pub u: [f32; 16],
    /// Barycentric v per lane.
    pub v: [f32; 16],
    /// Triangle index per lane, `CMLT_INVALID_ID` for a miss.
    pub prim_id: [u32; 16],
}

/// Closest hit of one ray: fill `hit` (set `prim_id` = `CMLT_INVALID_ID`
/// for a miss).
#[allow(non_camel_case_types)]
pub type cmlt_intersect_fn =
    Option<unsafe extern "C" fn(user: *mut c_void, ray: *const cmlt_ray, hit: *mut cmlt_hit)>;

/// Any hit in (0, tfar): return 1 when occluded, 0 when not.
#[allow(non_camel_case_types)]
pub type cmlt_occluded_fn =
    Option<unsafe extern "C" fn(user: *mut c_void, ray: *const cmlt_ray) -> u32>;

/// Closest hits of the lanes `i < width` whose bit `i` of `active` is set
/// (`width` is 4, 8 or 16); other lanes of `hits` must stay untouched.
#[allow(non_camel_case_types)]
pub type cmlt_intersect_packet_fn = Option<
    unsafe extern "C" fn(
        user: *mut c_void,
        width: u32,
        active: u32,
        rays: *const cmlt_ray_packet,
        hits: *mut cmlt_hit_packet,
    ),
>;

/// Occlusion of the active lanes: return the mask of occluded lanes (bits
/// outside `active` are ignored).
#[allow(non_camel_case_types)]
pub type cmlt_occluded_packet_fn = Option<
    unsafe extern "C" fn(
        user: *mut c_void,
        width: u32,
        active: u32,
        rays: *const cmlt_ray_packet,
    ) -> u32,
>;

/// A host ray tracer. `intersect` and `occluded` are required; without the
/// packet callbacks, packets are traced lane by lane through the single-ray
/// ones. Callbacks may be called from every thread that renders a worker
/// at the same time, so they must be thread-safe then; they must not call
/// back into cmlt.
#[repr(C)]
#[derive(Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct cmlt_intersector {
    /// Passed to every callback.
    pub user: *mut c_void,
    /// Single-ray closest hit (required).
    pub intersect: cmlt_intersect_fn,
    /// Single-ray occlusion (required).
    pub occluded: cmlt_occluded_fn,
    /// Packet closest hit (optional).
    pub intersect_packet: cmlt_intersect_packet_fn,
    /// Packet occlusion (optional).
    pub occluded_packet: cmlt_occluded_packet_fn,
}

/// [`cmlt_intersector`] as an [`Intersector`] over a scene of `triangles`
/// triangles and `shapes` host shapes.
pub(crate) struct HostIntersector {
    callbacks: cmlt_intersector,
    triangles: u32,
    shapes: u32,
    rejected: AtomicU64,
}

// SAFETY: the callbacks and their user pointer are the host's; the API
// contract (see `cmlt_intersector`) makes them callable from any rendering
// thread, concurrently when the host renders workers concurrently.
unsafe impl Send for HostIntersector {}
// SAFETY: as for Send; the only interior state is an atomic counter.
unsafe impl Sync for HostIntersector {}

impl HostIntersector {
    /// Wraps `callbacks` (their required entries checked by the caller).
    pub fn new(callbacks: cmlt_intersector, triangles: u32, shapes: u32) -> Self {
        HostIntersector {
            callbacks,
            triangles,
            shapes,
            rejected: AtomicU64::new(0),
        }
    }

    /// Hits reported by the host that were invalid and treated as misses.
    pub fn rejected_hits(&self) -> u64 {
        self.rejected.load(Ordering::Relaxed)
    }

    /// The host's answer as a core hit, if it is a valid one for `t_max`.
    fn check(&self, t: f32, u: f32, v: f32, prim: u32, t_max: f32) -> Option<Hit> {
        if prim == CMLT_INVALID_ID {
            return None;
        }
        let surface_ok = if prim & CMLT_SHAPE_BIT != 0 {
            prim & !CMLT_SHAPE_BIT < self.shapes && u.is_finite() && v.is_finite()
        } else {
            // Each of the three barycentric weights (u, v, 1 − u − v)
            // may miss [0, 1] by a rounding: Embree reports u = −9·10⁻⁸
            // on a triangle's edge, as it reports u + v just above 1.
            prim < self.triangles
                && u >= -BARYCENTRIC_SLACK
                && v >= -BARYCENTRIC_SLACK
                && u + v <= 1.0 + BARYCENTRIC_SLACK
        };
        let valid = surface_ok && t > 0.0 && t < t_max;
        if !valid {
            self.rejected.fetch_add(1, Ordering::Relaxed);
            return None;
        }
        Some(Hit {
            t,
            prim,
            b1: u,
            b2: v,
        })
    }
}

fn to_c(ray: &Ray) -> cmlt_ray {
    cmlt_ray {
        org: ray.o.to_array(),
        dir: ray.d.to_array(),
        tfar: ray.t_max,
    }
}

fn packet_to_c<const N: usize>(rays: &RayPacket<N>) -> cmlt_ray_packet {
    let mut p = cmlt_ray_packet {
        org_x: [0.0; 16],
        org_y: [0.0; 16],
        org_z: [0.0; 16],
        dir_x: [0.0; 16],
        dir_y: [0.0; 16],
        dir_z: [1.0; 16],
        tfar: [0.0; 16],
    };
    p.org_x[..N].copy_from_slice(&rays.ox);
    p.org_y[..N].copy_from_slice(&rays.oy);
    p.org_z[..N].copy_from_slice(&rays.oz);
    p.dir_x[..N].copy_from_slice(&rays.dx);
    p.dir_y[..N].copy_from_slice(&rays.dy);
    p.dir_z[..N].copy_from_slice(&rays.dz);
    p.tfar[..N].copy_from_slice(&rays.t_max);
    p
}

impl Intersector for HostIntersector {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let f = self.callbacks.intersect?;
        let r = to_c(ray);
        let mut h = cmlt_hit {
            t: f32::INFINITY,
            u: 0.0,
            v: 0.0,
            prim_id: CMLT_INVALID_ID,
        };
        // SAFETY: the host's callback contract; both pointers are valid for
        // the call.
        unsafe { f(self.callbacks.user, &r, &mut h) };
        self.check(h.t, h.u, h.v, h.prim_id, ray.t_max)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        let Some(f) = self.callbacks.occluded else {
            return false;
        };
        let r = to_c(ray);
        // SAFETY: as in `intersect`.
        unsafe { f(self.callbacks.user, &r) != 0 }
    }

    fn intersect_packet<const N: usize>(
        &self,
        rays: &RayPacket<N>,
        active: LaneMask,
        hits: &mut HitPacket<N>,
    ) {
        let Some(f) = self.callbacks.intersect_packet.filter(|_| N <= 16) else {
            for i in active.iter() {
                hits.set(i, self.intersect(&rays.get(i)));
            }
            return;
        };
        let p = packet_to_c(rays);
        let mut h = cmlt_hit_packet {
            t: [f32::INFINITY; 16],
            u: [0.0; 16],
            v: [0.0; 16],
            prim_id: [CMLT_INVALID_ID; 16],
        };
        let mask = active.0 & ((1u64 << N) - 1) as u32;
        // SAFETY: as in `intersect`; `N` is 4, 8 or 16 (the trait's packet
        // widths) and the structs hold 16 lanes.
        unsafe { f(self.callbacks.user, N as u32, mask, &p, &mut h) };
        for i in active.iter().filter(|&i| i < N) {
            hits.set(
                i,
                self.check(h.t[i], h.u[i], h.v[i], h.prim_id[i], rays.t_max[i]),
            );
        }
    }

    fn occluded_packet<const N: usize>(&self, rays: &RayPacket<N>, active: LaneMask) -> LaneMask {
        let Some(f) = self.callbacks.occluded_packet.filter(|_| N <= 16) else {
            let mut out = LaneMask::NONE;
            for i in active.iter() {
                if self.occluded(&rays.get(i)) {
                    out.set(i);
                }
            }
            return out;
        };
        let p = packet_to_c(rays);
        let mask = active.0 & ((1u64 << N) - 1) as u32;
        // SAFETY: as in `intersect_packet`.
        let hit = unsafe { f(self.callbacks.user, N as u32, mask, &p) };
        LaneMask(hit & mask)
    }
}

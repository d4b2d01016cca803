//! Hand-written bindings for the part of Embree 3's C API (`embree3/rtcore*.h`,
//! checked against 3.13) that [`super::EmbreeScene`] uses.
//!
//! Layouts follow the headers of Debian's build: `RTC_MAX_INSTANCE_LEVEL_COUNT
//! == 1` and `RTC_MIN_WIDTH == 0`, so `RTCIntersectContext` has no
//! `instStackSize` or `minWidthDistanceFactor` field and every hit carries a
//! single `instID`. Linking (`-lembree3`) is done by `core/build.rs` when the
//! `embree` feature is on.

#![allow(non_camel_case_types, non_snake_case, missing_docs)]

use core::ffi::{c_char, c_uint, c_void};

/// Opaque `RTCDeviceTy*`.
pub type RTCDevice = *mut c_void;
/// Opaque `RTCSceneTy*`.
pub type RTCScene = *mut c_void;
/// Opaque `RTCGeometryTy*`.
pub type RTCGeometry = *mut c_void;

/// `RTCError`: `RTC_ERROR_NONE`.
pub const RTC_ERROR_NONE: u32 = 0;
/// `RTCGeometryType`: `RTC_GEOMETRY_TYPE_TRIANGLE`.
pub const RTC_GEOMETRY_TYPE_TRIANGLE: u32 = 0;
/// `RTCBufferType`: `RTC_BUFFER_TYPE_INDEX`.
pub const RTC_BUFFER_TYPE_INDEX: u32 = 0;
/// `RTCBufferType`: `RTC_BUFFER_TYPE_VERTEX`.
pub const RTC_BUFFER_TYPE_VERTEX: u32 = 1;
/// `RTCFormat`: `RTC_FORMAT_UINT3` (`RTC_FORMAT_UINT = 0x5001`, then 2, 3).
pub const RTC_FORMAT_UINT3: u32 = 0x5003;
/// `RTCFormat`: `RTC_FORMAT_FLOAT3` (`RTC_FORMAT_FLOAT = 0x9001`, then 2, 3).
pub const RTC_FORMAT_FLOAT3: u32 = 0x9003;
/// `RTCSceneFlags`: `RTC_SCENE_FLAG_ROBUST` (no leaks through edges).
pub const RTC_SCENE_FLAG_ROBUST: u32 = 1 << 2;
/// `RTCBuildQuality`: `RTC_BUILD_QUALITY_HIGH`.
pub const RTC_BUILD_QUALITY_HIGH: u32 = 2;
/// `RTCIntersectContextFlags`: `RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT`.
pub const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: u32 = 0;
/// `RTCIntersectContextFlags`: `RTC_INTERSECT_CONTEXT_FLAG_COHERENT`.
pub const RTC_INTERSECT_CONTEXT_FLAG_COHERENT: u32 = 1;
/// `RTCDeviceProperty`: `RTC_DEVICE_PROPERTY_BACKFACE_CULLING_ENABLED`.
pub const RTC_DEVICE_PROPERTY_BACKFACE_CULLING_ENABLED: u32 = 65;
/// `RTC_INVALID_GEOMETRY_ID`.
pub const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;

/// `struct RTCIntersectContext` (instance level count 1, no min width).
#[repr(C)]
pub struct RTCIntersectContext {
    pub flags: u32,
    pub filter: Option<unsafe extern "C" fn(*const c_void)>,
    pub instID: [c_uint; 1],
}

impl RTCIntersectContext {
    /// `rtcInitIntersectContext`, an inline function of `rtcore_common.h`
    /// (not a library symbol), re-implemented; `flags` picks coherent or
    /// incoherent traversal.
    pub fn new(flags: u32) -> Self {
        RTCIntersectContext {
            flags,
            filter: None,
            instID: [RTC_INVALID_GEOMETRY_ID],
        }
    }
}

/// `struct RTCRay` (16-byte aligned).
#[repr(C, align(16))]
#[derive(Clone, Copy, Default)]
pub struct RTCRay {
    pub org_x: f32,
    pub org_y: f32,
    pub org_z: f32,
    pub tnear: f32,
    pub dir_x: f32,
    pub dir_y: f32,
    pub dir_z: f32,
    pub time: f32,
    pub tfar: f32,
    pub mask: u32,
    pub id: u32,
    pub flags: u32,
}

/// `struct RTCHit` (16-byte aligned).
#[repr(C, align(16))]
#[derive(Clone, Copy, Default)]
pub struct RTCHit {
    pub Ng_x: f32,
    pub Ng_y: f32,
    pub Ng_z: f32,
    pub u: f32,
    pub v: f32,
    pub primID: u32,
    pub geomID: u32,
    pub instID: [u32; 1],
}

/// `struct RTCRayHit`.
#[repr(C)]
#[derive(Clone, Copy, Default)]
pub struct RTCRayHit {
    pub ray: RTCRay,
    pub hit: RTCHit,
}

/// `struct RTCRayN` for N = 4, 8, 16 (`RTCRay4/8/16`): one array per field.
///
/// Aligned to 64 bytes, which covers the 16/32/64 bytes Embree asks for.
/// The headers' `RTCRayHitN` is a `RTCRayN` directly followed by a
/// `RTCHitN`; both are multiples of their alignment, so [`RTCRayHitN`]
/// below has no padding between them either.
#[repr(C, align(64))]
#[derive(Clone, Copy)]
pub struct RTCRayN<const N: usize> {
    pub org_x: [f32; N],
    pub org_y: [f32; N],
    pub org_z: [f32; N],
    pub tnear: [f32; N],
    pub dir_x: [f32; N],
    pub dir_y: [f32; N],
    pub dir_z: [f32; N],
    pub time: [f32; N],
    pub tfar: [f32; N],
    pub mask: [u32; N],
    pub id: [u32; N],
    pub flags: [u32; N],
}

/// `struct RTCHitN` for N = 4, 8, 16.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct RTCHitN<const N: usize> {
    pub Ng_x: [f32; N],
    pub Ng_y: [f32; N],
    pub Ng_z: [f32; N],
    pub u: [f32; N],
    pub v: [f32; N],
    pub primID: [u32; N],
    pub geomID: [u32; N],
    pub instID: [[u32; N]; 1],
}

/// `struct RTCRayHit4/8/16`.
#[repr(C, align(64))]
#[derive(Clone, Copy)]
pub struct RTCRayHitN<const N: usize> {
    pub ray: RTCRayN<N>,
    pub hit: RTCHitN<N>,
}

/// The `valid` argument of the packet calls: -1 = active lane, 0 = inactive,
/// aligned like the packet.
#[repr(C, align(64))]
#[derive(Clone, Copy)]
pub struct ValidN<const N: usize>(pub [i32; N]);

// RTCRayHit4 is 192 + 128 bytes, RTCRayHit16 is 768 + 512 bytes.
const _: () = assert!(core::mem::size_of::<RTCRayHit>() == 80);
const _: () = assert!(core::mem::size_of::<RTCIntersectContext>() == 24);
const _: () = assert!(core::mem::offset_of!(RTCRayHitN<4>, hit) == 192);
const _: () = assert!(core::mem::offset_of!(RTCRayHitN<8>, hit) == 384);
const _: () = assert!(core::mem::offset_of!(RTCRayHitN<16>, hit) == 768);

unsafe extern "C" {
    pub fn rtcNewDevice(config: *const c_char) -> RTCDevice;
    pub fn rtcReleaseDevice(device: RTCDevice);
    pub fn rtcGetDeviceError(device: RTCDevice) -> u32;
    pub fn rtcGetDeviceProperty(device: RTCDevice, prop: u32) -> isize;

    pub fn rtcNewScene(device: RTCDevice) -> RTCScene;
    pub fn rtcReleaseScene(scene: RTCScene);
    pub fn rtcSetSceneFlags(scene: RTCScene, flags: u32);
    pub fn rtcSetSceneBuildQuality(scene: RTCScene, quality: u32);
    pub fn rtcAttachGeometry(scene: RTCScene, geometry: RTCGeometry) -> c_uint;
    pub fn rtcCommitScene(scene: RTCScene);

    pub fn rtcNewGeometry(device: RTCDevice, kind: u32) -> RTCGeometry;
    pub fn rtcSetNewGeometryBuffer(
        geometry: RTCGeometry,
        kind: u32,
        slot: c_uint,
        format: u32,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    pub fn rtcCommitGeometry(geometry: RTCGeometry);
    pub fn rtcReleaseGeometry(geometry: RTCGeometry);

    pub fn rtcIntersect1(scene: RTCScene, ctx: *mut RTCIntersectContext, rayhit: *mut RTCRayHit);
    pub fn rtcOccluded1(scene: RTCScene, ctx: *mut RTCIntersectContext, ray: *mut RTCRay);
    pub fn rtcIntersect1M(
        scene: RTCScene,
        ctx: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit,
        m: c_uint,
        byte_stride: usize,
    );
    pub fn rtcOccluded1M(
        scene: RTCScene,
        ctx: *mut RTCIntersectContext,
        ray: *mut RTCRay,
        m: c_uint,
        byte_stride: usize,
    );
    pub fn rtcIntersect4(
        valid: *const i32,
        scene: RTCScene,
        ctx: *mut RTCIntersectContext,
        rayhit: *mut c_void,
    );
    pub fn rtcIntersect8(
        valid: *const i32,
        scene: RTCScene,
        ctx: *mut RTCIntersectContext,
        rayhit: *mut c_void,
    );
    pub fn rtcIntersect16(
        valid: *const i32,
        scene: RTCScene,
        ctx: *mut RTCIntersectContext,
        rayhit: *mut c_void,
    );
    pub fn rtcOccluded4(
        valid: *const i32,
        scene: RTCScene,
        ctx: *mut RTCIntersectContext,
        ray: *mut c_void,
    );
    pub fn rtcOccluded8(
        valid: *const i32,
        scene: RTCScene,
        ctx: *mut RTCIntersectContext,
        ray: *mut c_void,
    );
    pub fn rtcOccluded16(
        valid: *const i32,
        scene: RTCScene,
        ctx: *mut RTCIntersectContext,
        ray: *mut c_void,
    );
}

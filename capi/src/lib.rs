//! # The C API of cmlt
//!
//! A C or C++ renderer links the staticlib (`libcmlt_capi.a` in the build
//! tree, installed as `libcmlt.a`) or the shared library and
//! includes `include/cmlt.h`, generated from this crate by cbindgen. The
//! surface, in the order a host uses it:
//!
//! - [`alloc`]: optional allocator callbacks (`cmlt_set_allocator`) through
//!   which every allocation of the library goes;
//! - [`error`]: `cmlt_status` results, `cmlt_last_error`, an error
//!   callback; no panic ever crosses the boundary;
//! - [`scene`]: materials and meshes by pointer, or a scene file / built-in
//!   scene (with the `loader` feature), optionally the host's own
//!   intersector ([`host`]), then commit;
//! - [`renderer`]: a renderer per view with one worker per host thread;
//!   per frame set the camera, prepare, render each worker under a budget,
//!   resolve into the host's pixel buffer; statistics.
//!
//! Handles are opaque pointers created by `*_new` and freed by
//! `*_release`. Every function checks its pointers, sizes, strides, enums
//! and numbers and rejects bad input with a status and a message, leaving
//! the object unchanged.

pub mod alloc;
mod call;
pub mod error;
pub mod host;
mod loader;
pub mod renderer;
pub mod scene;

#[cfg(feature = "test-hooks")]
#[doc(hidden)]
pub mod test_hooks;

/// Major version of the C API.
pub const CMLT_VERSION_MAJOR: u32 = 0;
/// Minor version of the C API.
pub const CMLT_VERSION_MINOR: u32 = 1;
/// Patch version of the C API.
pub const CMLT_VERSION_PATCH: u32 = 0;

/// The library's version as `major · 10000 + minor · 100 + patch`, to
/// compare with the header's `CMLT_VERSION_*` macros.
#[unsafe(no_mangle)]
pub extern "C" fn cmlt_version() -> u32 {
    CMLT_VERSION_MAJOR * 10_000 + CMLT_VERSION_MINOR * 100 + CMLT_VERSION_PATCH
}

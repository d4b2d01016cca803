//! The C API called from Rust as a C host would: every function rejects
//! NULL pointers, bad sizes, strides, enums, non-finite numbers and calls
//! in the wrong order with the documented status and a message, and leaves
//! the object usable; the allocator hooks see every allocation, none of
//! them inside a frame; the memory query matches what creation allocates.

#[path = "../common/mod.rs"]
mod common;

mod alloc;
mod errors;
mod host;
mod lights;
mod materials;
mod media;
mod memory;
mod outputs;
mod renderer;
mod scene;
mod textures;

use std::cell::Cell;
use std::ffi::{CStr, c_void};
use std::ptr::{null, null_mut};

use cmlt_capi::alloc::{cmlt_allocator, cmlt_set_allocator};
use cmlt_capi::error::{cmlt_set_error_callback, cmlt_status, cmlt_status_name};
use cmlt_capi::host::{cmlt_hit, cmlt_intersector, cmlt_ray};
use cmlt_capi::renderer::*;
use cmlt_capi::scene::*;

use cmlt_status::*;
use common::*;

/// A new, uncommitted scene holding the floor and the light (material 0,
/// white).
fn floor_and_light() -> *mut cmlt_scene {
    let mut s = null_mut();
    let mut id = 0;
    // SAFETY: valid pointers throughout.
    unsafe {
        expect(cmlt_scene_new(&mut s), CMLT_OK, "cmlt_scene_new");
        expect(
            cmlt_scene_add_material(s, &WHITE, &mut id),
            CMLT_OK,
            "add_material",
        );
        expect(
            cmlt_scene_add_mesh(s, &mesh(&FLOOR, id, 0.0), null_mut()),
            CMLT_OK,
            "add_mesh",
        );
        expect(
            cmlt_scene_add_mesh(s, &mesh(&LIGHT, id, 5.0), null_mut()),
            CMLT_OK,
            "add_mesh",
        );
    }
    s
}

/// A committed floor-and-light scene (our BVH unless `host` is given).
fn scene(host: Option<&cmlt_intersector>) -> *mut cmlt_scene {
    let s = floor_and_light();
    // SAFETY: `s` is a valid, uncommitted scene.
    unsafe {
        if let Some(h) = host {
            expect(cmlt_scene_set_intersector(s, h), CMLT_OK, "set_intersector");
        }
        expect(cmlt_scene_commit(s), CMLT_OK, "commit");
    }
    s
}

fn config(estimator: u32, workers: u32) -> cmlt_renderer_config {
    let mut c = std::mem::MaybeUninit::uninit();
    // SAFETY: valid out pointer.
    unsafe {
        expect(
            cmlt_renderer_config_default(estimator, c.as_mut_ptr()),
            CMLT_OK,
            "config_default",
        );
        let mut c = c.assume_init();
        c.width = 16;
        c.height = 12;
        c.workers = workers;
        // Only the fields the estimator reads may leave their defaults.
        if estimator == CMLT_ESTIMATOR_MLT || estimator == CMLT_ESTIMATOR_CMLT {
            c.chains = 16;
            c.bootstrap_samples = 100;
            c.normalisation_passes = 1;
            c.normalisation_min_samples = 0;
        }
        if estimator == CMLT_ESTIMATOR_CMLT {
            c.k = 4;
            c.m = 2;
        }
        c
    }
}

fn renderer(s: *const cmlt_scene, c: &cmlt_renderer_config) -> *mut cmlt_renderer {
    let mut r = null_mut();
    // SAFETY: valid pointers.
    unsafe {
        expect(
            cmlt_renderer_new(s, c, &CAMERA, &mut r),
            CMLT_OK,
            "renderer_new",
        )
    };
    r
}

/// Prepares `r`, renders `budget` units into worker 0 and returns the
/// statistics.
fn prepare_render_stats(r: *mut cmlt_renderer, budget: u64) -> cmlt_stats {
    let mut stats = cmlt_stats::default();
    // SAFETY: a valid renderer; valid out pointers.
    unsafe {
        expect(cmlt_renderer_prepare(r), CMLT_OK, "prepare");
        expect(
            cmlt_renderer_render(r, 0, budget, null_mut()),
            CMLT_OK,
            "render",
        );
        expect(cmlt_renderer_get_stats(r, &mut stats), CMLT_OK, "stats");
    }
    stats
}

fn image(r: *const cmlt_renderer) -> Vec<f32> {
    let mut px = vec![0.0f32; 16 * 12 * 3];
    // SAFETY: the buffer holds what we say.
    unsafe {
        expect(
            cmlt_renderer_resolve(
                r,
                CMLT_FORMAT_RGB32F,
                px.as_mut_ptr().cast(),
                0,
                px.len() * 4,
            ),
            CMLT_OK,
            "resolve",
        )
    };
    px
}

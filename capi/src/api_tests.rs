//! The C API called from Rust as a C host would: every function rejects
//! NULL pointers, bad sizes, strides, enums, non-finite numbers and calls
//! in the wrong order with the documented status and a message, and leaves
//! the object usable; the allocator hooks see every allocation, none of
//! them inside a frame; the memory query matches what creation allocates.

use std::cell::Cell;
use std::ffi::{CStr, c_void};
use std::ptr::{null, null_mut};

use crate::alloc::{cmlt_allocator, cmlt_set_allocator};
use crate::error::{cmlt_last_error, cmlt_set_error_callback, cmlt_status, cmlt_status_name};
use crate::host::{cmlt_hit, cmlt_intersector, cmlt_ray};
use crate::renderer::*;
use crate::scene::*;

use cmlt_status::*;

fn last_error() -> String {
    // SAFETY: never NULL, NUL-terminated.
    unsafe { CStr::from_ptr(cmlt_last_error()) }
        .to_string_lossy()
        .into_owned()
}

/// Asserts `status` is `want` and that a message naming `function` was set.
fn expect(status: cmlt_status, want: cmlt_status, function: &str) {
    assert_eq!(status, want, "{function}: {}", last_error());
    if want != CMLT_OK {
        let msg = last_error();
        assert!(
            msg.starts_with(function),
            "message {msg:?} does not name {function}"
        );
    }
}

const WHITE: cmlt_material = cmlt_material {
    type_: CMLT_MATERIAL_DIFFUSE,
    color: [0.7, 0.7, 0.7],
    ior: 1.0,
    roughness: 0.0,
    two_sided: 0,
    color_texture: CMLT_NO_TEXTURE,
    normal_map: CMLT_NO_TEXTURE,
    bump_map: CMLT_NO_TEXTURE,
    bump_scale: 1.0,
    opacity_texture: CMLT_NO_TEXTURE,
    specular_color: [1.0; 3],
    transmission_color: [1.0; 3],
    distribution: CMLT_DISTRIBUTION_GGX,
    nonlinear: 0,
    metallic: 0.0,
    anisotropic: 0.0,
    specular: 0.5,
    spec_tint: 0.0,
    spec_trans: 0.0,
    sheen: 0.0,
    sheen_tint: 0.0,
    clearcoat: 0.0,
    clearcoat_gloss: 0.0,
    flatness: 0.0,
    principled_textures: [CMLT_NO_TEXTURE; 10],
};

/// A floor quad and a light quad facing it.
const POSITIONS: [f32; 24] = [
    -1.0, 0.0, -1.0, -1.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0, -1.0, // floor, facing +y
    -0.3, 1.0, -0.3, 0.3, 1.0, -0.3, 0.3, 1.0, 0.3, -0.3, 1.0, 0.3, // light, facing −y
];
const FLOOR: [u32; 6] = [0, 1, 2, 0, 2, 3];
const LIGHT: [u32; 6] = [4, 5, 6, 4, 6, 7];

fn mesh(indices: &[u32], material: u32, emission: f32) -> cmlt_mesh {
    cmlt_mesh {
        positions: POSITIONS.as_ptr(),
        vertex_count: 8,
        position_stride: 0,
        normals: null(),
        normal_stride: 0,
        uvs: null(),
        uv_stride: 0,
        indices: indices.as_ptr(),
        triangle_count: indices.len() / 3,
        index_stride: 0,
        material,
        emission: [emission; 3],
    }
}

const CAMERA: cmlt_camera = cmlt_camera {
    position: [0.0, 0.5, -2.0],
    target: [0.0, 0.3, 0.0],
    up: [0.0, 1.0, 0.0],
    fov_degrees: 60.0,
    aperture_radius: 0.0,
    focus_distance: 1.0,
};

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
        c.chains = 16;
        c.bootstrap_samples = 100;
        c.normalisation_passes = 1;
        c.normalisation_min_samples = 0;
        c.k = 4;
        c.m = 2;
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

#[test]
fn scene_inputs_are_checked_and_leave_the_scene_usable() {
    let mut s = null_mut();
    let mut id = 0;
    // SAFETY: every pointer is valid or deliberately NULL.
    unsafe {
        expect(
            cmlt_scene_new(null_mut()),
            CMLT_ERROR_NULL_POINTER,
            "cmlt_scene_new",
        );
        expect(cmlt_scene_new(&mut s), CMLT_OK, "cmlt_scene_new");
        let f = "cmlt_scene_add_material";
        expect(
            cmlt_scene_add_material(null_mut(), &WHITE, &mut id),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(
            cmlt_scene_add_material(s, null(), &mut id),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(
            cmlt_scene_add_material(s, &WHITE, null_mut()),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        for bad in [
            cmlt_material { type_: 99, ..WHITE },
            cmlt_material {
                color: [f32::NAN, 0.5, 0.5],
                ..WHITE
            },
            cmlt_material {
                color: [1.5, 0.5, 0.5],
                ..WHITE
            },
            cmlt_material {
                color: [-0.1, 0.5, 0.5],
                ..WHITE
            },
            cmlt_material {
                type_: CMLT_MATERIAL_GLASS,
                ior: 0.0,
                ..WHITE
            },
            cmlt_material {
                type_: CMLT_MATERIAL_GLASS,
                ior: f32::INFINITY,
                ..WHITE
            },
            cmlt_material {
                type_: CMLT_MATERIAL_ROUGH_METAL,
                roughness: 0.0,
                ..WHITE
            },
            cmlt_material {
                type_: CMLT_MATERIAL_ROUGH_METAL,
                roughness: f32::NAN,
                ..WHITE
            },
            // Rough glass: α > 0, η > 0 and ≠ 1, transmittance in [0, 1].
            cmlt_material {
                type_: CMLT_MATERIAL_ROUGH_GLASS,
                ior: 1.5,
                roughness: 0.0,
                ..WHITE
            },
            cmlt_material {
                type_: CMLT_MATERIAL_ROUGH_GLASS,
                ior: 1.0,
                roughness: 0.2,
                ..WHITE
            },
            cmlt_material {
                type_: CMLT_MATERIAL_ROUGH_GLASS,
                ior: f32::NAN,
                roughness: 0.2,
                ..WHITE
            },
            cmlt_material {
                type_: CMLT_MATERIAL_ROUGH_GLASS,
                ior: 1.5,
                roughness: 0.2,
                color: [1.0, 1.2, 1.0],
                ..WHITE
            },
        ] {
            expect(
                cmlt_scene_add_material(s, &bad, &mut id),
                CMLT_ERROR_INVALID_ARGUMENT,
                f,
            );
        }
        expect(cmlt_scene_add_material(s, &WHITE, &mut id), CMLT_OK, f);
        assert_eq!(id, 0, "rejected materials took ids");

        let f = "cmlt_scene_add_mesh";
        let good = mesh(&FLOOR, id, 0.0);
        let nan = [f32::NAN; 24];
        let out_of_range = [0u32, 1, 8];
        let normals = [0.0f32; 24];
        let misaligned = POSITIONS
            .as_ptr()
            .cast::<u8>()
            .wrapping_add(1)
            .cast::<f32>();
        expect(
            cmlt_scene_add_mesh(s, null(), null_mut()),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(
            cmlt_scene_add_mesh(
                s,
                &cmlt_mesh {
                    positions: null(),
                    ..good
                },
                null_mut(),
            ),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(
            cmlt_scene_add_mesh(
                s,
                &cmlt_mesh {
                    indices: null(),
                    ..good
                },
                null_mut(),
            ),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        for (what, bad) in [
            (
                "NaN vertex",
                cmlt_mesh {
                    positions: nan.as_ptr(),
                    ..good
                },
            ),
            (
                "index out of range",
                cmlt_mesh {
                    indices: out_of_range.as_ptr(),
                    triangle_count: 1,
                    ..good
                },
            ),
            (
                "stride too small",
                cmlt_mesh {
                    position_stride: 8,
                    ..good
                },
            ),
            (
                "stride not a multiple of 4",
                cmlt_mesh {
                    position_stride: 13,
                    ..good
                },
            ),
            (
                "index stride too small",
                cmlt_mesh {
                    index_stride: 4,
                    ..good
                },
            ),
            (
                "misaligned positions",
                cmlt_mesh {
                    positions: misaligned,
                    ..good
                },
            ),
            (
                "unknown material",
                cmlt_mesh {
                    material: 7,
                    ..good
                },
            ),
            (
                "negative emission",
                cmlt_mesh {
                    emission: [-1.0, 0.0, 0.0],
                    ..good
                },
            ),
            (
                "NaN emission",
                cmlt_mesh {
                    emission: [f32::NAN, 0.0, 0.0],
                    ..good
                },
            ),
            (
                "zero-length normals",
                cmlt_mesh {
                    normals: normals.as_ptr(),
                    ..good
                },
            ),
            (
                "huge count",
                cmlt_mesh {
                    vertex_count: usize::MAX / 2,
                    ..good
                },
            ),
        ] {
            let st = cmlt_scene_add_mesh(s, &bad, null_mut());
            assert_eq!(st, CMLT_ERROR_INVALID_ARGUMENT, "{what}: {}", last_error());
        }
        let mut first = 99;
        expect(cmlt_scene_add_mesh(s, &good, &mut first), CMLT_OK, f);
        assert_eq!(first, 0, "rejected meshes took triangle numbers");
        expect(
            cmlt_scene_add_mesh(s, &mesh(&LIGHT, id, 4.0), &mut first),
            CMLT_OK,
            f,
        );
        assert_eq!(first, 2);

        let no_callbacks = cmlt_intersector {
            user: null_mut(),
            intersect: None,
            occluded: None,
            intersect_packet: None,
            occluded_packet: None,
        };
        expect(
            cmlt_scene_set_intersector(s, &no_callbacks),
            CMLT_ERROR_NULL_POINTER,
            "cmlt_scene_set_intersector",
        );
        expect(
            cmlt_scene_set_accel(s, 9),
            CMLT_ERROR_INVALID_ARGUMENT,
            "cmlt_scene_set_accel",
        );
        if !cfg!(feature = "embree") {
            expect(
                cmlt_scene_set_accel(s, CMLT_ACCEL_EMBREE),
                CMLT_ERROR_UNSUPPORTED,
                "cmlt_scene_set_accel",
            );
        }
        // Renderers need a committed scene.
        let mut r = null_mut();
        let c = config(CMLT_ESTIMATOR_BDPT, 1);
        expect(
            cmlt_renderer_new(s, &c, &CAMERA, &mut r),
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_renderer_new",
        );
        let mut n = 0;
        expect(
            cmlt_scene_triangle_count(s, &mut n),
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_scene_triangle_count",
        );
        expect(cmlt_scene_commit(s), CMLT_OK, "cmlt_scene_commit");
        expect(cmlt_scene_triangle_count(s, &mut n), CMLT_OK, "count");
        assert_eq!(n, 4);
        // A committed scene is frozen.
        expect(
            cmlt_scene_commit(s),
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_scene_commit",
        );
        expect(
            cmlt_scene_add_material(s, &WHITE, &mut id),
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_scene_add_material",
        );
        expect(
            cmlt_scene_add_mesh(s, &good, null_mut()),
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_scene_add_mesh",
        );
        cmlt_scene_release(s);
        cmlt_scene_release(null_mut());

        // Files and built-ins.
        let mut l = null_mut();
        expect(
            cmlt_scene_load_file(
                c"/no/such/scene.xml".as_ptr(),
                &mut l,
                null_mut(),
                null_mut(),
                null_mut(),
            ),
            CMLT_ERROR_IO,
            "cmlt_scene_load_file",
        );
        expect(
            cmlt_scene_load_file(null(), &mut l, null_mut(), null_mut(), null_mut()),
            CMLT_ERROR_NULL_POINTER,
            "cmlt_scene_load_file",
        );
        expect(
            cmlt_scene_new_builtin(c"no-such-scene".as_ptr(), 8, 8, &mut l, null_mut()),
            CMLT_ERROR_INVALID_ARGUMENT,
            "cmlt_scene_new_builtin",
        );
        expect(
            cmlt_scene_new_builtin(c"cornell-box".as_ptr(), 0, 8, &mut l, null_mut()),
            CMLT_ERROR_INVALID_ARGUMENT,
            "cmlt_scene_new_builtin",
        );
        assert!(l.is_null(), "a failed call wrote its out pointer");
    }
}

#[test]
fn renderer_inputs_and_call_order_are_checked() {
    let s = scene(None);
    // SAFETY: every pointer is valid or deliberately NULL.
    unsafe {
        let f = "cmlt_renderer_new";
        let mut r = null_mut();
        let good = config(CMLT_ESTIMATOR_CMLT, 2);
        expect(
            cmlt_renderer_new(null(), &good, &CAMERA, &mut r),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(
            cmlt_renderer_new(s, null(), &CAMERA, &mut r),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(
            cmlt_renderer_new(s, &good, null(), &mut r),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(
            cmlt_renderer_new(s, &good, &CAMERA, null_mut()),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        for (what, bad) in [
            ("zero width", cmlt_renderer_config { width: 0, ..good }),
            (
                "huge height",
                cmlt_renderer_config {
                    height: 1 << 20,
                    ..good
                },
            ),
            (
                "estimator",
                cmlt_renderer_config {
                    estimator: 17,
                    ..good
                },
            ),
            ("no workers", cmlt_renderer_config { workers: 0, ..good }),
            ("k = 0", cmlt_renderer_config { k: 0, ..good }),
            ("k = 65", cmlt_renderer_config { k: 65, ..good }),
            ("m = 0", cmlt_renderer_config { m: 0, ..good }),
            (
                "NaN lens σ",
                cmlt_renderer_config {
                    lens_sigma: f32::NAN,
                    ..good
                },
            ),
            (
                "σ > 1",
                cmlt_renderer_config {
                    small_step_sigma: 2.0,
                    ..good
                },
            ),
            (
                "large step p",
                cmlt_renderer_config {
                    large_step_probability: -0.5,
                    ..good
                },
            ),
            ("no chains", cmlt_renderer_config { chains: 0, ..good }),
            (
                "no bootstrap",
                cmlt_renderer_config {
                    bootstrap_samples: 0,
                    ..good
                },
            ),
            (
                "depth",
                cmlt_renderer_config {
                    max_depth: 100_000,
                    ..good
                },
            ),
            (
                "depth cap 0",
                cmlt_renderer_config {
                    depth_cap: 0,
                    ..good
                },
            ),
            (
                "depth cap 2000",
                cmlt_renderer_config {
                    depth_cap: 2000,
                    ..good
                },
            ),
            (
                "NaN caustic scale",
                cmlt_renderer_config {
                    caustic_scale: f32::NAN,
                    ..good
                },
            ),
            (
                "zero caustic scale",
                cmlt_renderer_config {
                    caustic_scale: 0.0,
                    ..good
                },
            ),
            (
                "splatting 2 (the biased eq. 36 has no constant)",
                cmlt_renderer_config {
                    splatting: 2,
                    ..good
                },
            ),
            ("no lanes", cmlt_renderer_config { lanes: 0, ..good }),
            ("65 lanes", cmlt_renderer_config { lanes: 65, ..good }),
            (
                "2 lanes with k = 4",
                cmlt_renderer_config { lanes: 2, ..good },
            ),
        ] {
            let st = cmlt_renderer_new(s, &bad, &CAMERA, &mut r);
            assert_eq!(st, CMLT_ERROR_INVALID_ARGUMENT, "{what}: {}", last_error());
        }
        for (what, cam) in [
            (
                "NaN position",
                cmlt_camera {
                    position: [f32::NAN, 0.0, 0.0],
                    ..CAMERA
                },
            ),
            (
                "target = position",
                cmlt_camera {
                    target: CAMERA.position,
                    ..CAMERA
                },
            ),
            (
                "up parallel",
                cmlt_camera {
                    target: [0.0, 0.25, 0.0],
                    up: [0.0, -0.25, 2.0],
                    ..CAMERA
                },
            ),
            (
                "fov 180",
                cmlt_camera {
                    fov_degrees: 180.0,
                    ..CAMERA
                },
            ),
            (
                "fov NaN",
                cmlt_camera {
                    fov_degrees: f32::NAN,
                    ..CAMERA
                },
            ),
            (
                "negative aperture",
                cmlt_camera {
                    aperture_radius: -1.0,
                    ..CAMERA
                },
            ),
        ] {
            let st = cmlt_renderer_new(s, &good, &cam, &mut r);
            assert_eq!(st, CMLT_ERROR_INVALID_ARGUMENT, "{what}: {}", last_error());
        }
        assert!(r.is_null());
        let r = renderer(s, &good);

        // Wrong order: render before prepare.
        let f = "cmlt_renderer_render";
        expect(
            cmlt_renderer_render(r, 0, 100, null_mut()),
            CMLT_ERROR_INVALID_OPERATION,
            f,
        );
        expect(cmlt_renderer_prepare(r), CMLT_OK, "prepare");
        expect(
            cmlt_renderer_render(r, 2, 100, null_mut()),
            CMLT_ERROR_INVALID_ARGUMENT,
            f,
        );
        expect(
            cmlt_renderer_render(null(), 0, 100, null_mut()),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        let mut done = 0;
        expect(
            cmlt_renderer_render(r, 0, 16 * 12 * 4, &mut done),
            CMLT_OK,
            f,
        );
        assert!(done >= 16 * 12 * 4);
        let before = image(r);
        assert!(before.iter().any(|&v| v > 0.0));

        // Bad camera moves change nothing.
        let f = "cmlt_renderer_set_camera";
        expect(
            cmlt_renderer_set_camera(
                r,
                &cmlt_camera {
                    fov_degrees: -3.0,
                    ..CAMERA
                },
            ),
            CMLT_ERROR_INVALID_ARGUMENT,
            f,
        );
        expect(
            cmlt_renderer_set_camera(r, null()),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        assert_eq!(image(r), before, "a rejected camera changed the image");

        // Resolve: sizes, strides, formats, alignment.
        let f = "cmlt_renderer_resolve";
        let mut buf = vec![0u8; 16 * 12 * 12 + 64];
        let row = 16 * 12;
        expect(
            cmlt_renderer_resolve(r, CMLT_FORMAT_RGB32F, null_mut(), 0, buf.len()),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(
            cmlt_renderer_resolve(r, 7, buf.as_mut_ptr(), 0, buf.len()),
            CMLT_ERROR_INVALID_ARGUMENT,
            f,
        );
        expect(
            cmlt_renderer_resolve(r, CMLT_FORMAT_RGB32F, buf.as_mut_ptr(), 0, 12 * row - 1),
            CMLT_ERROR_INVALID_ARGUMENT,
            f,
        );
        expect(
            cmlt_renderer_resolve(r, CMLT_FORMAT_RGB32F, buf.as_mut_ptr(), row - 4, buf.len()),
            CMLT_ERROR_INVALID_ARGUMENT,
            f,
        );
        let aligned = buf.as_mut_ptr().align_offset(4);
        expect(
            cmlt_renderer_resolve(
                r,
                CMLT_FORMAT_RGB32F,
                buf.as_mut_ptr().add(aligned + 1),
                0,
                12 * row,
            ),
            CMLT_ERROR_INVALID_ARGUMENT,
            f,
        );
        // Regression: a row stride whose (rows − 1) multiple wraps
        // around must be refused, not write out of bounds.
        for stride in [usize::MAX / 2 + 1, usize::MAX / 11 * 2, usize::MAX] {
            expect(
                cmlt_renderer_resolve(
                    r,
                    CMLT_FORMAT_RGBA8_SRGB,
                    buf.as_mut_ptr(),
                    stride,
                    buf.len(),
                ),
                CMLT_ERROR_INVALID_ARGUMENT,
                f,
            );
        }
        // A padded stride writes the same pixels.
        let mut rgba = vec![0u8; 13 * 16 * 4 * 2];
        expect(
            cmlt_renderer_resolve(
                r,
                CMLT_FORMAT_RGBA8_SRGB,
                rgba.as_mut_ptr(),
                16 * 4 * 2,
                rgba.len(),
            ),
            CMLT_OK,
            f,
        );
        assert!(rgba.chunks(4).step_by(1).take(16).all(|p| p[3] == 255));
        assert!(
            rgba[16 * 4..16 * 8].iter().all(|&b| b == 0),
            "padding written"
        );

        let mut stats = cmlt_stats::default();
        expect(
            cmlt_renderer_get_stats(r, null_mut()),
            CMLT_ERROR_NULL_POINTER,
            "cmlt_renderer_get_stats",
        );
        expect(cmlt_renderer_get_stats(r, &mut stats), CMLT_OK, "stats");
        assert!(stats.mutations >= 16 * 12 * 4 && stats.rays > 0 && stats.b > 0.0);
        assert_eq!(stats.nonfinite, 0);
        assert!(
            stats.lens_steps + stats.caustic_steps + stats.multi_chain_steps > 0
                || stats.mutations > 0
        );

        // A host clock that allows two steps of one round each.
        unsafe extern "C" fn two_steps(user: *mut c_void, _done: u64) -> u32 {
            // SAFETY: `user` is the counter below.
            let n = unsafe { &mut *user.cast::<u32>() };
            *n += 1;
            (*n < 2) as u32
        }
        let mut asked = 0u32;
        let mut done = 0u64;
        expect(
            cmlt_renderer_render_while(
                r,
                1,
                u64::MAX,
                Some(two_steps),
                (&mut asked as *mut u32).cast(),
                &mut done,
            ),
            CMLT_OK,
            "render_while",
        );
        assert_eq!(
            (asked, done),
            (2, 2 * 16),
            "two rounds of the worker's 16 chains"
        );
        expect(
            cmlt_renderer_render_while(r, 1, 10, None, null_mut(), null_mut()),
            CMLT_ERROR_NULL_POINTER,
            "cmlt_renderer_render_while",
        );

        // Effects: a diffuse floor under an area light, through a pinhole.
        let (mut fx, mut chains) = (0u32, 9u32);
        expect(
            cmlt_scene_get_effects(s, &mut fx, &mut chains),
            CMLT_OK,
            "get_effects",
        );
        assert_eq!(fx, CMLT_EFFECT_DIFFUSE | CMLT_EFFECT_AREA_LIGHTS);
        assert_eq!(chains, 0);
        assert_eq!(stats.effects, fx);
        // Work per lobe kind: diffuse only; no lens sampled.
        assert!(stats.bsdf_samples[0] > 0 && stats.bsdf_evals[0] > 0);
        assert_eq!(stats.bsdf_samples[1..], [0; 3]);
        assert_eq!(stats.bsdf_evals[1..], [0; 3]);
        assert_eq!(
            (stats.bsdf_samples_more, stats.bsdf_evals_more),
            ([0; 4], [0; 4])
        );
        assert_eq!(stats.lens_samples, 0);
        expect(
            cmlt_scene_get_effects(s, null_mut(), null_mut()),
            CMLT_ERROR_NULL_POINTER,
            "cmlt_scene_get_effects",
        );

        // The renderer outlives the scene handle.
        cmlt_scene_release(s);
        expect(
            cmlt_renderer_render(r, 1, 100, null_mut()),
            CMLT_OK,
            "render after scene release",
        );
        cmlt_renderer_release(r);
    }
}

#[test]
fn status_names_and_error_callback() {
    thread_local! {
        static SEEN: Cell<u32> = const { Cell::new(u32::MAX) };
    }
    unsafe extern "C" fn on_error(
        _user: *mut c_void,
        status: cmlt_status,
        message: *const std::ffi::c_char,
    ) {
        // SAFETY: the library passes a NUL-terminated message.
        assert!(!unsafe { CStr::from_ptr(message) }.to_bytes().is_empty());
        SEEN.with(|s| s.set(status as u32));
    }
    // SAFETY: valid pointers.
    unsafe {
        // SAFETY: NUL-terminated static strings.
        assert_eq!(
            CStr::from_ptr(cmlt_status_name(2)).to_str().unwrap(),
            "CMLT_ERROR_INVALID_ARGUMENT"
        );
        assert_eq!(
            CStr::from_ptr(cmlt_status_name(12345)).to_str().unwrap(),
            "unknown status"
        );
        expect(
            cmlt_set_error_callback(Some(on_error), null_mut()),
            CMLT_OK,
            "set_error_callback",
        );
        let _ = cmlt_scene_new(null_mut());
        assert_eq!(SEEN.with(Cell::get), CMLT_ERROR_NULL_POINTER as u32);
        expect(
            cmlt_set_error_callback(None, null_mut()),
            CMLT_OK,
            "set_error_callback",
        );
    }
}

/// A host intersector returning garbage: out-of-range primitives and NaN
/// distances are rejected and counted, never crash, and the image stays
/// finite.
#[test]
fn bad_host_hits_are_rejected() {
    unsafe extern "C" fn garbage(_: *mut c_void, ray: *const cmlt_ray, hit: *mut cmlt_hit) {
        // SAFETY: valid for the call.
        let (ray, hit) = unsafe { (&*ray, &mut *hit) };
        let odd = ray.dir[0] > 0.0;
        *hit = cmlt_hit {
            t: if odd { f32::NAN } else { 0.5 },
            u: 0.2,
            v: 0.2,
            prim_id: if odd { 3 } else { 1_000_000 },
        };
    }
    unsafe extern "C" fn never(_: *mut c_void, _: *const cmlt_ray) -> u32 {
        0
    }
    let host = cmlt_intersector {
        user: null_mut(),
        intersect: Some(garbage),
        occluded: Some(never),
        intersect_packet: None,
        occluded_packet: None,
    };
    let s = scene(Some(&host));
    let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 1));
    let stats = prepare_render_stats(r, 16 * 12 * 2);
    assert!(stats.rejected_host_hits > 0);
    assert!(image(r).iter().all(|v| v.is_finite()));
    // SAFETY: handles from this test.
    unsafe {
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
}

thread_local! {
    /// Allocations made through the hooks by this thread while counting.
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
    static BYTES: Cell<usize> = const { Cell::new(0) };
}

unsafe extern "C" fn counting_alloc(_: *mut c_void, size: usize, align: usize) -> *mut c_void {
    if COUNTING.with(Cell::get) {
        ALLOCS.with(|a| a.set(a.get() + 1));
        BYTES.with(|b| b.set(b.get() + size));
    }
    // SAFETY: valid layout (the library passes a power-of-two alignment).
    unsafe { std::alloc::System.alloc(std::alloc::Layout::from_size_align_unchecked(size, align)) }
        .cast()
}

unsafe extern "C" fn counting_free(_: *mut c_void, ptr: *mut c_void, size: usize, align: usize) {
    if COUNTING.with(Cell::get) {
        BYTES.with(|b| b.set(b.get().wrapping_sub(size)));
    }
    // SAFETY: `ptr` came from `counting_alloc` with this layout.
    unsafe {
        std::alloc::System.dealloc(
            ptr.cast(),
            std::alloc::Layout::from_size_align_unchecked(size, align),
        )
    }
}

use std::alloc::GlobalAlloc;

/// Allocations (count, net bytes) `f` makes on this thread through the
/// hooks.
fn counted<R>(f: impl FnOnce() -> R) -> (R, u64, usize) {
    ALLOCS.with(|a| a.set(0));
    BYTES.with(|b| b.set(0));
    COUNTING.with(|c| c.set(true));
    let r = f();
    COUNTING.with(|c| c.set(false));
    (r, ALLOCS.with(Cell::get), BYTES.with(Cell::get))
}

#[test]
fn frames_allocate_nothing_through_the_hooks_and_the_query_is_exact() {
    let hooks = cmlt_allocator {
        user: null_mut(),
        alloc: Some(counting_alloc),
        free: Some(counting_free),
    };
    // SAFETY: valid allocator with process-lifetime callbacks.
    unsafe {
        expect(
            cmlt_set_allocator(&cmlt_allocator {
                alloc: None,
                ..hooks
            }),
            CMLT_ERROR_NULL_POINTER,
            "cmlt_set_allocator",
        );
        expect(cmlt_set_allocator(&hooks), CMLT_OK, "set_allocator");
    }
    let s = scene(None);
    for estimator in [
        CMLT_ESTIMATOR_PT,
        CMLT_ESTIMATOR_BDPT,
        CMLT_ESTIMATOR_MLT,
        CMLT_ESTIMATOR_CMLT,
    ] {
        let c = config(estimator, 2);
        let (mut bytes, mut align) = (0usize, 0usize);
        // SAFETY: valid pointers.
        unsafe {
            expect(
                cmlt_renderer_memory_requirements(s, &c, &mut bytes, &mut align),
                CMLT_OK,
                "memory_requirements",
            )
        };
        let (r, n, created) = counted(|| renderer(s, &c));
        assert!(n > 0, "creation went around the hooks");
        // The query builds the same handle (renderer, workers, accumulator)
        // and measures it: byte for byte what creation takes.
        assert_eq!(
            created, bytes,
            "estimator {estimator}: query {bytes} B, creation {created} B"
        );
        assert!(align >= 8 && align.is_power_of_two());
        let mut px = vec![0.0f32; 16 * 12 * 3];
        let mut moved = CAMERA;
        let ((), n, _) = counted(|| {
            for frame in 0..3 {
                moved.position[0] = 0.1 * frame as f32;
                // SAFETY: valid pointers.
                unsafe {
                    expect(cmlt_renderer_set_camera(r, &moved), CMLT_OK, "set_camera");
                    expect(cmlt_renderer_prepare(r), CMLT_OK, "prepare");
                    for w in 0..2 {
                        expect(
                            cmlt_renderer_render(r, w, 16 * 12 * 2, null_mut()),
                            CMLT_OK,
                            "render",
                        );
                    }
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
                    );
                    let mut st = cmlt_stats::default();
                    expect(cmlt_renderer_get_stats(r, &mut st), CMLT_OK, "stats");
                }
            }
        });
        assert_eq!(n, 0, "estimator {estimator}: {n} allocations during frames");
        assert!(px.iter().any(|&v| v > 0.0));
        // Mesh updates are part of the frame loop, and so are refused
        // calls: their messages are literals (`expect`, which copies the
        // message, runs after counting).
        let raised: Vec<f32> = POSITIONS
            .iter()
            .enumerate()
            .map(|(i, &v)| if i % 3 == 1 { v + 0.05 } else { v })
            .collect();
        let strided: Vec<f32> = raised
            .chunks(3)
            .flat_map(|p| [p[0], p[1], p[2], -7.0])
            .collect();
        let mut nan = raised.clone();
        nan[4] = f32::NAN;
        let mut statuses = [CMLT_OK; 7];
        let ((), n, _) = counted(|| {
            // SAFETY: valid pointers; arrays of 8 vertices at their strides.
            unsafe {
                statuses = [
                    cmlt_scene_update_mesh(s, 1, raised.as_ptr(), 8, 0, null(), 0),
                    cmlt_scene_update_mesh(s, 1, strided.as_ptr(), 8, 16, null(), 0),
                    cmlt_scene_update_mesh(s, 1, nan.as_ptr(), 8, 0, null(), 0),
                    cmlt_scene_update_mesh(s, 1, raised.as_ptr(), 7, 0, null(), 0),
                    cmlt_scene_update_mesh(s, 1, raised.as_ptr(), 8, 13, null(), 0),
                    cmlt_scene_update_mesh(s, 9, raised.as_ptr(), 8, 0, null(), 0),
                    cmlt_renderer_render(r, 0, 16, null_mut()),
                ];
            }
        });
        assert_eq!(
            n, 0,
            "estimator {estimator}: {n} allocations in mesh updates"
        );
        assert_eq!(&statuses[..2], &[CMLT_OK; 2]);
        assert_eq!(&statuses[2..6], &[CMLT_ERROR_INVALID_ARGUMENT; 4]);
        // A refused update leaves the scene as it was: the last good one
        // (the strided copy) still stands, and it started a new frame.
        expect(
            statuses[6],
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_renderer_render",
        );
        // SAFETY: valid pointers.
        unsafe {
            expect(
                cmlt_scene_update_mesh(s, 1, POSITIONS.as_ptr(), 8, 0, null(), 0),
                CMLT_OK,
                "update_mesh",
            );
        }
        // SAFETY: handle from this test.
        unsafe { cmlt_renderer_release(r) };
    }
    // SAFETY: handle from this test; NULL restores the system allocator.
    unsafe {
        cmlt_scene_release(s);
        expect(cmlt_set_allocator(null()), CMLT_OK, "set_allocator");
    }
}

/// The host's world for the shape tests: the floor and light of [`scene`]
/// as triangles, and one analytic sphere of radius 0.25 at (0, 0.25, 0)
/// resting on the floor, reported as host shape 0.
struct ShapeHost {
    /// Non-zero: the surface callback answers with a NaN normal.
    broken: bool,
    surface_calls: std::sync::atomic::AtomicU64,
}

const SPHERE_C: [f32; 3] = [0.0, 0.25, 0.0];
const SPHERE_R: f32 = 0.25;

/// Möller–Trumbore on triangle `tri` of the shared vertex array.
fn hit_triangle(tri: [u32; 3], o: [f32; 3], d: [f32; 3]) -> Option<(f32, f32, f32)> {
    use cmlt_core::math::Vec3;
    let p = |i: u32| Vec3::from_slice(&POSITIONS[3 * i as usize..]);
    let (a, b, c) = (p(tri[0]), p(tri[1]), p(tri[2]));
    let (o, d) = (Vec3::from_array(o), Vec3::from_array(d));
    let (e1, e2) = (b - a, c - a);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1e-12 {
        return None;
    }
    let tv = o - a;
    let u = tv.dot(pv) / det;
    let qv = tv.cross(e1);
    let v = d.dot(qv) / det;
    let t = e2.dot(qv) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 1e-5).then_some((t, u, v))
}

/// The nearest sphere crossing in (0, tfar), in f64 (rays leave its
/// surface offset by the point's error bound only).
fn hit_sphere(o: [f32; 3], d: [f32; 3], tfar: f32) -> Option<(f32, f32, f32)> {
    let oc: Vec<f64> = (0..3).map(|i| (o[i] - SPHERE_C[i]) as f64).collect();
    let dd: Vec<f64> = d.iter().map(|&x| x as f64).collect();
    let a: f64 = dd.iter().map(|x| x * x).sum();
    let hb: f64 = (0..3).map(|i| oc[i] * dd[i]).sum();
    let c: f64 = oc.iter().map(|x| x * x).sum::<f64>() - (SPHERE_R as f64).powi(2);
    let disc = hb * hb - a * c;
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let t = [(-hb - disc.sqrt()) / a, (-hb + disc.sqrt()) / a]
        .into_iter()
        .map(|t| t as f32)
        .find(|&t| t > 0.0 && t < tfar)?;
    let n: Vec<f32> = (0..3)
        .map(|i| (o[i] + t * d[i] - SPHERE_C[i]) / SPHERE_R)
        .collect();
    Some((t, n[1].clamp(-1.0, 1.0).acos(), n[2].atan2(n[0])))
}

unsafe extern "C" fn shape_host_intersect(
    _: *mut c_void,
    ray: *const cmlt_ray,
    hit: *mut cmlt_hit,
) {
    // SAFETY: valid for the call.
    let (ray, hit) = unsafe { (&*ray, &mut *hit) };
    hit.prim_id = crate::host::CMLT_INVALID_ID;
    hit.t = ray.tfar;
    for (k, tri) in [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]]
        .into_iter()
        .enumerate()
    {
        if let Some((t, u, v)) = hit_triangle(tri, ray.org, ray.dir).filter(|h| h.0 < hit.t) {
            *hit = cmlt_hit {
                t,
                u,
                v,
                prim_id: k as u32,
            };
        }
    }
    if let Some((t, u, v)) = hit_sphere(ray.org, ray.dir, hit.t) {
        *hit = cmlt_hit {
            t,
            u,
            v,
            prim_id: crate::host::CMLT_SHAPE_BIT,
        };
    }
}

unsafe extern "C" fn shape_host_occluded(user: *mut c_void, ray: *const cmlt_ray) -> u32 {
    let mut hit = cmlt_hit {
        t: 0.0,
        u: 0.0,
        v: 0.0,
        prim_id: 0,
    };
    // SAFETY: forwarded from our caller.
    unsafe { shape_host_intersect(user, ray, &mut hit) };
    (hit.prim_id != crate::host::CMLT_INVALID_ID) as u32
}

unsafe extern "C" fn shape_host_surface(
    user: *mut c_void,
    shape: u32,
    theta: f32,
    phi: f32,
    out: *mut crate::host::cmlt_surface,
) -> u32 {
    // SAFETY: `user` is the test's ShapeHost; `out` is valid for the call.
    let (host, out) = unsafe { (&*(user as *const ShapeHost), &mut *out) };
    host.surface_calls
        .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    assert_eq!(shape, 0);
    let n = [
        theta.sin() * phi.cos(),
        theta.cos(),
        theta.sin() * phi.sin(),
    ];
    out.p = [0, 1, 2].map(|i| SPHERE_C[i] + SPHERE_R * n[i]);
    out.p_error = out.p.map(|x| x.abs() * 5.0 * f32::EPSILON);
    out.ng = if host.broken { [f32::NAN; 3] } else { n };
    out.ns = n;
    out.uv = [0.0, 0.0];
    1
}

/// Host shapes: argument checks of `cmlt_scene_add_shapes`, commit refused
/// without a host intersector (the scene stays editable), an analytic
/// sphere rendered through the callbacks (it changes the picture, and no
/// answer is rejected), and broken surface answers counted, never drawn.
#[test]
fn host_shapes_are_checked_and_rendered() {
    use crate::host::cmlt_shapes;
    let make = |host: &ShapeHost, with_sphere: bool| -> *mut cmlt_scene {
        let s = floor_and_light();
        let shapes = cmlt_shapes {
            count: 1,
            material: 0,
            user: host as *const ShapeHost as *mut c_void,
            surface: Some(shape_host_surface),
        };
        let isect = cmlt_intersector {
            user: null_mut(),
            intersect: Some(shape_host_intersect),
            occluded: Some(shape_host_occluded),
            intersect_packet: None,
            occluded_packet: None,
        };
        // SAFETY: valid or deliberately invalid pointers.
        unsafe {
            if with_sphere {
                let f = "cmlt_scene_add_shapes";
                let mut first = 99;
                expect(
                    cmlt_scene_add_shapes(s, null(), &mut first),
                    CMLT_ERROR_NULL_POINTER,
                    f,
                );
                let bad = [
                    cmlt_shapes {
                        surface: None,
                        ..shapes
                    },
                    cmlt_shapes { count: 0, ..shapes },
                    cmlt_shapes {
                        material: 9,
                        ..shapes
                    },
                ];
                let want = [
                    CMLT_ERROR_NULL_POINTER,
                    CMLT_ERROR_INVALID_ARGUMENT,
                    CMLT_ERROR_INVALID_ARGUMENT,
                ];
                for (b, w) in bad.iter().zip(want) {
                    expect(cmlt_scene_add_shapes(s, b, &mut first), w, f);
                }
                assert_eq!(first, 99, "rejected shapes wrote an index");
                expect(cmlt_scene_add_shapes(s, &shapes, &mut first), CMLT_OK, f);
                assert_eq!(first, 0, "rejected groups took shape numbers");
                expect(
                    cmlt_scene_commit(s),
                    CMLT_ERROR_INVALID_OPERATION,
                    "cmlt_scene_commit",
                );
            }
            expect(
                cmlt_scene_set_intersector(s, &isect),
                CMLT_OK,
                "set_intersector",
            );
            expect(cmlt_scene_commit(s), CMLT_OK, "commit");
        }
        s
    };
    let render = |s: *mut cmlt_scene| {
        let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 1));
        let stats = prepare_render_stats(r, 16 * 12 * 8);
        let img = image(r);
        // SAFETY: handles from this test.
        unsafe {
            cmlt_renderer_release(r);
            cmlt_scene_release(s);
        }
        (img, stats)
    };
    let host = ShapeHost {
        broken: false,
        surface_calls: Default::default(),
    };
    let (without, _) = render(make(&host, false));
    let (with, stats) = render(make(&host, true));
    assert!(
        host.surface_calls
            .load(std::sync::atomic::Ordering::Relaxed)
            > 0
    );
    assert_eq!(
        (stats.rejected_host_hits, stats.rejected_host_surfaces),
        (0, 0)
    );
    assert_eq!(stats.nonfinite, 0);
    let changed = with.iter().zip(&without).filter(|(a, b)| a != b).count();
    assert!(changed > 16, "the sphere changed {changed} pixel values");

    let broken = ShapeHost {
        broken: true,
        surface_calls: Default::default(),
    };
    let (img, stats) = render(make(&broken, true));
    assert!(stats.rejected_host_surfaces > 0);
    assert_eq!(stats.nonfinite, 0);
    assert!(img.iter().all(|v| v.is_finite()));
}

/// `cmlt_scene_update_mesh`: bad updates are refused and change nothing
/// (renderers keep rendering their frame); a good one (the light rises)
/// refits the BVH, makes `render` ask for `prepare`, and the next frame
/// shows the dimmer floor.
#[test]
fn mesh_updates_between_frames() {
    let s = scene(None);
    let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 1));
    let mean = |img: &[f32]| img.iter().sum::<f32>() / img.len() as f32;
    let mut raised = POSITIONS;
    for v in 4..8 {
        raised[3 * v + 1] = 1.8;
    }
    // SAFETY: valid or deliberately invalid pointers and sizes.
    unsafe {
        expect(cmlt_renderer_prepare(r), CMLT_OK, "prepare");
        expect(
            cmlt_renderer_render(r, 0, 16 * 12 * 16, null_mut()),
            CMLT_OK,
            "render",
        );
        let before = mean(&image(r));

        let f = "cmlt_scene_update_mesh";
        let mut nan = raised;
        nan[13] = f32::NAN;
        let zero = [0.0f32; 24];
        // (mesh, positions, count, stride, normals, expected status)
        let bad = [
            (1, null(), 8, 0, null(), CMLT_ERROR_NULL_POINTER),
            (
                1,
                raised.as_ptr(),
                7,
                0,
                null(),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                1,
                raised.as_ptr(),
                8,
                8,
                null(),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (1, nan.as_ptr(), 8, 0, null(), CMLT_ERROR_INVALID_ARGUMENT),
            (
                2,
                raised.as_ptr(),
                8,
                0,
                null(),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                1,
                raised.as_ptr(),
                8,
                0,
                zero.as_ptr(),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
        ];
        for (mesh, p, n, stride, normals, want) in bad {
            expect(
                cmlt_scene_update_mesh(s, mesh, p, n, stride, normals, 0),
                want,
                f,
            );
        }
        let mut building = null_mut();
        expect(cmlt_scene_new(&mut building), CMLT_OK, "new");
        expect(
            cmlt_scene_update_mesh(building, 0, raised.as_ptr(), 8, 0, null(), 0),
            CMLT_ERROR_INVALID_OPERATION,
            f,
        );
        cmlt_scene_release(building);
        // Nothing changed: the frame goes on without a new prepare.
        expect(
            cmlt_renderer_render(r, 0, 16 * 12, null_mut()),
            CMLT_OK,
            "render",
        );

        expect(
            cmlt_scene_update_mesh(s, 1, raised.as_ptr(), 8, 0, null(), 0),
            CMLT_OK,
            f,
        );
        expect(
            cmlt_renderer_render(r, 0, 16 * 12, null_mut()),
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_renderer_render",
        );
        expect(cmlt_renderer_prepare(r), CMLT_OK, "prepare");
        expect(
            cmlt_renderer_render(r, 0, 16 * 12 * 16, null_mut()),
            CMLT_OK,
            "render",
        );
        let after = mean(&image(r));
        assert!(after < 0.9 * before, "raised light: {after} vs {before}");
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
}

#[test]
fn textures_from_host_memory_feed_colour_normal_bump_and_opacity() {
    let f = "cmlt_scene_add_texture";
    // 2×2 RGB with a row stride of 8 bytes (2 bytes of padding).
    let rgb: [u8; 16] = [
        255, 0, 0, 0, 255, 0, 9, 9, //
        0, 0, 255, 255, 255, 255, 9, 9,
    ];
    let grey: [u8; 4] = [0, 255, 128, 255];
    let flat_normal: [u8; 3] = [128, 128, 255];
    let mut s = null_mut();
    let (mut colour, mut alpha, mut normal, mut id) = (0u32, 0u32, 0u32, 0u32);
    // SAFETY: valid pointers throughout; the arrays hold what the sizes say.
    unsafe {
        expect(cmlt_scene_new(&mut s), CMLT_OK, "cmlt_scene_new");
        expect(
            cmlt_scene_add_texture(s, 2, 2, 3, rgb.as_ptr(), 8, 1, &mut colour),
            CMLT_OK,
            f,
        );
        assert_eq!(colour, 1, "texture ids start at 1");
        expect(
            cmlt_scene_add_texture(s, 2, 2, 1, grey.as_ptr(), 0, 0, &mut alpha),
            CMLT_OK,
            f,
        );
        expect(
            cmlt_scene_add_texture(s, 1, 1, 3, flat_normal.as_ptr(), 0, 0, &mut normal),
            CMLT_OK,
            f,
        );
        assert_eq!((alpha, normal), (2, 3));
        for (w, h, c, p, stride) in [
            (2, 2, 2, rgb.as_ptr(), 0), // 2 channels
            (0, 2, 3, rgb.as_ptr(), 0), // empty
            (2, 2, 3, rgb.as_ptr(), 5), // stride below a row
            (2, 2, 3, null::<u8>(), 0), // no texels
        ] {
            let want = if p.is_null() {
                CMLT_ERROR_NULL_POINTER
            } else {
                CMLT_ERROR_INVALID_ARGUMENT
            };
            expect(
                cmlt_scene_add_texture(s, w, h, c, p, stride, 0, &mut id),
                want,
                f,
            );
        }
        let f = "cmlt_scene_add_material";
        for bad in [
            cmlt_material {
                color_texture: 4,
                ..WHITE
            },
            cmlt_material {
                normal_map: normal,
                bump_map: alpha,
                ..WHITE
            },
            cmlt_material {
                bump_map: alpha,
                bump_scale: f32::NAN,
                ..WHITE
            },
            cmlt_material {
                type_: CMLT_MATERIAL_GLASS,
                ior: 1.5,
                color_texture: colour,
                ..WHITE
            },
        ] {
            expect(
                cmlt_scene_add_material(s, &bad, &mut id),
                CMLT_ERROR_INVALID_ARGUMENT,
                f,
            );
        }
        let textured = cmlt_material {
            color_texture: colour,
            normal_map: normal,
            opacity_texture: alpha,
            ..WHITE
        };
        expect(cmlt_scene_add_material(s, &textured, &mut id), CMLT_OK, f);
        assert_eq!(id, 0, "rejected materials took no ids");
        let mut uv_floor = mesh(&FLOOR, id, 0.0);
        const UVS: [f32; 16] = [0.0; 16];
        uv_floor.uvs = UVS.as_ptr();
        expect(
            cmlt_scene_add_mesh(s, &uv_floor, null_mut()),
            CMLT_OK,
            "add_mesh",
        );
        expect(
            cmlt_scene_add_mesh(s, &mesh(&LIGHT, id, 5.0), null_mut()),
            CMLT_OK,
            "add_mesh",
        );
        expect(cmlt_scene_commit(s), CMLT_OK, "commit");
        let mut fx = 0u32;
        expect(
            cmlt_scene_get_effects(s, &mut fx, null_mut()),
            CMLT_OK,
            "get_effects",
        );
        for e in [
            CMLT_EFFECT_TEXTURES,
            CMLT_EFFECT_NORMAL_MAPPING,
            CMLT_EFFECT_ALPHA_MASKS,
        ] {
            assert_ne!(fx & e, 0, "effects {fx:#x} lack {e:#x}");
        }
        // A committed scene takes no more textures.
        expect(
            cmlt_scene_add_texture(s, 1, 1, 3, flat_normal.as_ptr(), 0, 0, &mut id),
            CMLT_ERROR_INVALID_OPERATION,
            f.replace("material", "texture").as_str(),
        );
        cmlt_scene_release(s);
    }
}

/// A committed scene: a floor of material `m` under the white light.
fn floor_of(m: &cmlt_material) -> Result<*mut cmlt_scene, cmlt_status> {
    let mut s = null_mut();
    let (mut white, mut id) = (0, 0);
    // SAFETY: valid pointers throughout.
    unsafe {
        expect(cmlt_scene_new(&mut s), CMLT_OK, "cmlt_scene_new");
        expect(
            cmlt_scene_add_material(s, &WHITE, &mut white),
            CMLT_OK,
            "white",
        );
        let status = cmlt_scene_add_material(s, m, &mut id);
        if status != CMLT_OK {
            cmlt_scene_release(s);
            return Err(status);
        }
        expect(
            cmlt_scene_add_mesh(s, &mesh(&FLOOR, id, 0.0), null_mut()),
            CMLT_OK,
            "floor",
        );
        expect(
            cmlt_scene_add_mesh(s, &mesh(&LIGHT, white, 5.0), null_mut()),
            CMLT_OK,
            "light",
        );
        expect(cmlt_scene_commit(s), CMLT_OK, "commit");
    }
    Ok(s)
}

#[test]
fn coating_and_thin_glass_materials_are_checked_and_rendered() {
    let plastic = cmlt_material {
        type_: CMLT_MATERIAL_PLASTIC,
        color: [0.6, 0.2, 0.1],
        ior: 1.5,
        two_sided: 1,
        ..WHITE
    };
    let rough = cmlt_material {
        type_: CMLT_MATERIAL_ROUGH_PLASTIC,
        roughness: 0.2,
        distribution: CMLT_DISTRIBUTION_BECKMANN,
        nonlinear: 1,
        ..plastic
    };
    let thin = cmlt_material {
        type_: CMLT_MATERIAL_THIN_GLASS,
        ior: 1.5,
        transmission_color: [0.9, 0.5, 0.2],
        ..WHITE
    };
    let tinted = cmlt_material {
        type_: CMLT_MATERIAL_TINTED_GLASS,
        specular_color: [0.8, 0.8, 0.8],
        ..thin
    };
    for (name, m, effect) in [
        ("plastic", plastic, CMLT_EFFECT_COATING),
        ("rough plastic", rough, CMLT_EFFECT_COATING),
        ("thin glass", thin, CMLT_EFFECT_REFRACTION),
        ("tinted glass", tinted, CMLT_EFFECT_REFRACTION),
    ] {
        let s = floor_of(&m).unwrap_or_else(|e| panic!("{name}: status {e:?}"));
        let mut fx = 0u32;
        // SAFETY: valid pointers.
        unsafe {
            expect(
                cmlt_scene_get_effects(s, &mut fx, null_mut()),
                CMLT_OK,
                name,
            )
        };
        assert_eq!(
            fx & (CMLT_EFFECT_COATING | CMLT_EFFECT_REFRACTION),
            effect,
            "{name}"
        );
        let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 1));
        let stats = prepare_render_stats(r, 4);
        assert_eq!(stats.nonfinite, 0, "{name}");
        let px = image(r);
        assert!(px.iter().all(|v| v.is_finite() && *v >= 0.0), "{name}");
        if effect == CMLT_EFFECT_COATING {
            // The floor is seen and lit: coloured like its base (red > blue)
            // and its lobes counted as coating work.
            let (red, blue): (f32, f32) = (
                px.chunks(3).map(|p| p[0]).sum(),
                px.chunks(3).map(|p| p[2]).sum(),
            );
            assert!(red > 1.1 * blue && blue > 0.0, "{name}: {red} {blue}");
            assert!(
                stats.bsdf_samples_more[0] > 0 && stats.bsdf_evals_more[0] > 0,
                "{name}"
            );
        } else {
            assert_eq!(stats.bsdf_samples_more[0], 0, "{name}");
        }
        // SAFETY: handles from above.
        unsafe {
            cmlt_renderer_release(r);
            cmlt_scene_release(s);
        }
    }

    for (name, bad) in [
        (
            "plastic ior NaN",
            cmlt_material {
                ior: f32::NAN,
                ..plastic
            },
        ),
        (
            "plastic albedo > 1",
            cmlt_material {
                color: [1.2, 0.2, 0.1],
                ..plastic
            },
        ),
        (
            "plastic specular < 0",
            cmlt_material {
                specular_color: [-1.0, 1.0, 1.0],
                ..plastic
            },
        ),
        (
            "rough plastic α = 0",
            cmlt_material {
                roughness: 0.0,
                ..rough
            },
        ),
        (
            "rough plastic α NaN",
            cmlt_material {
                roughness: f32::NAN,
                ..rough
            },
        ),
        ("rough plastic ior 1", cmlt_material { ior: 1.0, ..rough }),
        (
            "rough plastic distribution",
            cmlt_material {
                distribution: 7,
                ..rough
            },
        ),
        ("thin glass ior 0", cmlt_material { ior: 0.0, ..thin }),
        (
            "thin glass tint < 0",
            cmlt_material {
                transmission_color: [0.5, -0.1, 0.5],
                ..thin
            },
        ),
        (
            "tinted glass tint NaN",
            cmlt_material {
                specular_color: [f32::NAN, 1.0, 1.0],
                ..tinted
            },
        ),
    ] {
        assert_eq!(
            floor_of(&bad).err(),
            Some(CMLT_ERROR_INVALID_ARGUMENT),
            "{name}"
        );
        assert!(
            last_error().starts_with("cmlt_scene_add_material"),
            "{name}"
        );
    }
}

/// Rough glass through the C API: the effect is reported, PT and BDPT
/// sample and connect through its lobe (counted after the first four lobe
/// kinds), and every estimator's image is finite and lit.
#[test]
fn rough_glass_renders_through_every_estimator() {
    let glass = cmlt_material {
        type_: CMLT_MATERIAL_ROUGH_GLASS,
        color: [0.9, 0.8, 0.7],
        ior: 1.5,
        roughness: 0.3,
        two_sided: 0,
        ..WHITE
    };
    let mut s = null_mut();
    let (mut gid, mut wid) = (0, 0);
    // SAFETY: valid pointers throughout.
    unsafe {
        expect(cmlt_scene_new(&mut s), CMLT_OK, "cmlt_scene_new");
        expect(
            cmlt_scene_add_material(s, &glass, &mut gid),
            CMLT_OK,
            "add_material",
        );
        expect(
            cmlt_scene_add_material(s, &WHITE, &mut wid),
            CMLT_OK,
            "add_material",
        );
        expect(
            cmlt_scene_add_mesh(s, &mesh(&FLOOR, gid, 0.0), null_mut()),
            CMLT_OK,
            "add_mesh",
        );
        expect(
            cmlt_scene_add_mesh(s, &mesh(&LIGHT, wid, 5.0), null_mut()),
            CMLT_OK,
            "add_mesh",
        );
        expect(cmlt_scene_commit(s), CMLT_OK, "commit");
        let mut fx = 0u32;
        expect(
            cmlt_scene_get_effects(s, &mut fx, null_mut()),
            CMLT_OK,
            "get_effects",
        );
        assert_eq!(
            fx,
            CMLT_EFFECT_DIFFUSE | CMLT_EFFECT_ROUGH_REFRACTION | CMLT_EFFECT_AREA_LIGHTS
        );
        for est in [
            CMLT_ESTIMATOR_PT,
            CMLT_ESTIMATOR_BDPT,
            CMLT_ESTIMATOR_MLT,
            CMLT_ESTIMATOR_CMLT,
        ] {
            let r = renderer(s, &config(est, 1));
            let stats = prepare_render_stats(r, 16 * 12 * 2);
            // MLT's chains here sit on the light seen directly (most of
            // the image's luminance); its paths through the glass are
            // checked by the rough-glass scene's convergence tests.
            assert!(
                est >= CMLT_ESTIMATOR_MLT
                    || stats.bsdf_samples_more[1] > 0 && stats.bsdf_evals_more[1] > 0,
                "estimator {est}: {:?} {:?}",
                stats.bsdf_samples_more,
                stats.bsdf_evals_more
            );
            let px = image(r);
            assert!(px.iter().all(|v| v.is_finite()), "estimator {est}");
            assert!(px.iter().any(|v| *v > 0.0), "estimator {est}: black");
            cmlt_renderer_release(r);
        }
        cmlt_scene_release(s);
    }
}

/// A principled floor through the C API: every parameter is passed on
/// (the scene's material equals the core's), η comes from `ior` or from
/// `specular`, a scalar takes a texture, the effect and its lobe counter
/// (the third of the later lobe kinds) are reported, and bad values are
/// refused with a status.
#[test]
fn principled_materials_are_checked_and_rendered() {
    use cmlt_core::math::Rgb;
    use cmlt_core::scene::{MaterialKind, PrincipledParams, Texture};
    let p = cmlt_material {
        type_: CMLT_MATERIAL_PRINCIPLED,
        color: [0.8, 0.3, 0.2],
        ior: 0.0,
        roughness: 0.4,
        metallic: 0.3,
        anisotropic: 0.5,
        specular: 0.6,
        spec_tint: 0.2,
        sheen: 0.5,
        sheen_tint: 0.4,
        clearcoat: 0.7,
        clearcoat_gloss: 0.9,
        flatness: 0.1,
        two_sided: 1,
        ..WHITE
    };
    let m = material_from_c(&p, &[]).expect("valid principled");
    let c = |v: f32| Texture::Constant(Rgb::splat(v));
    assert_eq!(
        m.kind,
        MaterialKind::Principled(PrincipledParams {
            base_color: Texture::Constant(Rgb::new(0.8, 0.3, 0.2)),
            roughness: c(0.4),
            anisotropic: c(0.5),
            metallic: c(0.3),
            spec_trans: c(0.0),
            spec_tint: c(0.2),
            sheen: c(0.5),
            sheen_tint: c(0.4),
            clearcoat: c(0.7),
            clearcoat_gloss: c(0.9),
            flatness: c(0.1),
            eta: PrincipledParams::eta_from_specular(0.6),
        })
    );
    assert!(m.two_sided);
    let glass = cmlt_material {
        ior: 1.45,
        spec_trans: 1.0,
        ..p
    };
    let MaterialKind::Principled(g) = material_from_c(&glass, &[]).unwrap().kind else {
        panic!("not principled");
    };
    assert_eq!((g.eta, g.spec_trans), (1.45, c(1.0)));
    let mut textured = p;
    textured.principled_textures[CMLT_PRINCIPLED_METALLIC as usize] = 1;
    let MaterialKind::Principled(t) = material_from_c(&textured, &[cmlt_core::scene::BitmapId(0)])
        .unwrap()
        .kind
    else {
        panic!("not principled");
    };
    assert!(matches!(t.metallic, Texture::Bitmap { id, .. } if id.0 == 0));
    for (name, m) in [("opaque", p), ("glass", glass)] {
        let s = floor_of(&m).unwrap_or_else(|e| panic!("{name}: status {e:?}"));
        let mut fx = 0u32;
        // SAFETY: valid pointers and handles.
        unsafe {
            expect(
                cmlt_scene_get_effects(s, &mut fx, null_mut()),
                CMLT_OK,
                name,
            );
        }
        assert_ne!(fx & CMLT_EFFECT_PRINCIPLED, 0, "{name}");
        for est in [
            CMLT_ESTIMATOR_PT,
            CMLT_ESTIMATOR_BDPT,
            CMLT_ESTIMATOR_MLT,
            CMLT_ESTIMATOR_CMLT,
        ] {
            let r = renderer(s, &config(est, 1));
            let stats = prepare_render_stats(r, 16 * 12 * 2);
            assert_eq!(stats.nonfinite, 0, "{name} {est}");
            assert!(
                est >= CMLT_ESTIMATOR_MLT
                    || stats.bsdf_samples_more[2] > 0 && stats.bsdf_evals_more[2] > 0,
                "{name} estimator {est}: {:?}",
                stats.bsdf_samples_more
            );
            let px = image(r);
            assert!(
                px.iter().all(|v| v.is_finite() && *v >= 0.0),
                "{name} {est}"
            );
            assert!(px.iter().any(|v| *v > 0.0), "{name} {est}: black");
            // SAFETY: a handle from above.
            unsafe { cmlt_renderer_release(r) };
        }
        // SAFETY: a handle from above.
        unsafe { cmlt_scene_release(s) };
    }
    let mut bad_texture = p;
    bad_texture.principled_textures[CMLT_PRINCIPLED_SHEEN as usize] = 3;
    for (name, bad) in [
        (
            "roughness NaN",
            cmlt_material {
                roughness: f32::NAN,
                ..p
            },
        ),
        (
            "metallic < 0",
            cmlt_material {
                metallic: -0.1,
                ..p
            },
        ),
        ("sheen > 1", cmlt_material { sheen: 1.5, ..p }),
        (
            "clearcoat_gloss NaN",
            cmlt_material {
                clearcoat_gloss: f32::NAN,
                ..p
            },
        ),
        (
            "base colour > 1",
            cmlt_material {
                color: [0.5, 1.5, 0.5],
                ..p
            },
        ),
        ("specular > 1", cmlt_material { specular: 2.0, ..p }),
        (
            "specular NaN",
            cmlt_material {
                specular: f32::NAN,
                ..p
            },
        ),
        ("ior < 0", cmlt_material { ior: -1.5, ..p }),
        ("ior 1 with spec_trans", cmlt_material { ior: 1.0, ..glass }),
        ("unknown texture", bad_texture),
    ] {
        assert_eq!(
            floor_of(&bad).err(),
            Some(CMLT_ERROR_INVALID_ARGUMENT),
            "{name}"
        );
        assert!(
            last_error().starts_with("cmlt_scene_add_material"),
            "{name}: {}",
            last_error()
        );
    }
}

#[test]
fn lights_are_checked_added_and_rendered() {
    let point = cmlt_light {
        type_: CMLT_LIGHT_POINT,
        color: [2.0, 2.0, 2.0],
        position: [0.0, 1.0, 0.0],
        direction: [0.0, 0.0, 0.0],
        cutoff_angle: 0.0,
        beam_width: 0.0,
        texels: null(),
        width: 0,
        height: 0,
        stride: 0,
        to_world: [0.0; 9],
    };
    let f = "cmlt_scene_add_light";
    let s = floor_and_light();
    // SAFETY: valid pointers, or deliberately NULL / bad values.
    unsafe {
        expect(
            cmlt_scene_add_light(s, null(), null_mut()),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(
            cmlt_scene_add_light(null_mut(), &point, null_mut()),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        let bad = [
            cmlt_light {
                color: [-1.0, 0.0, 0.0],
                ..point
            },
            cmlt_light {
                position: [f32::NAN, 0.0, 0.0],
                ..point
            },
            cmlt_light { type_: 9, ..point },
            cmlt_light {
                type_: CMLT_LIGHT_DIRECTIONAL,
                ..point
            },
            cmlt_light {
                type_: CMLT_LIGHT_SPOT,
                direction: [0.0, -1.0, 0.0],
                cutoff_angle: 10.0,
                beam_width: 20.0,
                ..point
            },
        ];
        for l in bad {
            expect(
                cmlt_scene_add_light(s, &l, null_mut()),
                CMLT_ERROR_INVALID_ARGUMENT,
                f,
            );
        }
        let mut index = 7;
        expect(cmlt_scene_add_light(s, &point, &mut index), CMLT_OK, f);
        assert_eq!(index, 0);
        let sun = cmlt_light {
            type_: CMLT_LIGHT_DIRECTIONAL,
            direction: [0.2, -1.0, 0.1],
            ..point
        };
        expect(cmlt_scene_add_light(s, &sun, &mut index), CMLT_OK, f);
        assert_eq!(index, 1);
        expect(cmlt_scene_commit(s), CMLT_OK, "commit");
        let mut effects = 0;
        expect(
            cmlt_scene_get_effects(s, &mut effects, null_mut()),
            CMLT_OK,
            "effects",
        );
        assert_ne!(effects & CMLT_EFFECT_POINT_LIGHTS, 0);
        assert_eq!(effects & CMLT_EFFECT_ENVIRONMENT, 0);
        // A committed scene takes no more lights.
        expect(
            cmlt_scene_add_light(s, &point, null_mut()),
            CMLT_ERROR_INVALID_OPERATION,
            f,
        );
    }
    // The lights add to the area light's image.
    let with = {
        let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 1));
        prepare_render_stats(r, 8);
        let px = image(r);
        unsafe { cmlt_renderer_release(r) };
        px
    };
    let plain = scene(None);
    let without = {
        let r = renderer(plain, &config(CMLT_ESTIMATOR_PT, 1));
        prepare_render_stats(r, 8);
        let px = image(r);
        unsafe { cmlt_renderer_release(r) };
        px
    };
    let sum = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>();
    assert!(with.iter().all(|v| v.is_finite()));
    assert!(
        sum(&with) > 1.2 * sum(&without),
        "{} vs {}",
        sum(&with),
        sum(&without)
    );
    unsafe {
        cmlt_scene_release(s);
        cmlt_scene_release(plain);
    }
}

/// The bootstrap spread over the host's threads (`prepare_begin`, one
/// `prepare_worker` per worker, `prepare_finish`) gives `prepare`'s image
/// bit for bit; a missing share is refused and leaves the renderer
/// unprepared; `render_per_pixel` renders each worker's share of a
/// per-pixel budget.
#[test]
fn bootstrap_on_the_hosts_threads_equals_prepare() {
    let s = scene(None);
    for estimator in [CMLT_ESTIMATOR_PT, CMLT_ESTIMATOR_MLT, CMLT_ESTIMATOR_CMLT] {
        let mut c = config(estimator, 3);
        // 4 passes asked for, 20 from the small-image floor: split 7/7/6
        // over the three workers.
        c.normalisation_passes = 4;
        c.normalisation_min_samples = 20 * 16 * 12;
        let (one, split) = (renderer(s, &c), renderer(s, &c));
        // SAFETY: valid renderers and out pointers; workers in range.
        unsafe {
            expect(cmlt_renderer_prepare(one), CMLT_OK, "cmlt_renderer_prepare");
            let mut pending = 7u32;
            expect(
                cmlt_renderer_prepare_begin(split, &mut pending),
                CMLT_OK,
                "cmlt_renderer_prepare_begin",
            );
            assert_eq!(pending, (estimator != CMLT_ESTIMATOR_PT) as u32);
            if pending == 1 {
                // Two of three shares: refused, and rendering is refused.
                for w in 0..2 {
                    expect(
                        cmlt_renderer_prepare_worker(split, w),
                        CMLT_OK,
                        "cmlt_renderer_prepare_worker",
                    );
                }
                expect(
                    cmlt_renderer_prepare_finish(split),
                    CMLT_ERROR_INVALID_OPERATION,
                    "cmlt_renderer_prepare_finish",
                );
                expect(
                    cmlt_renderer_render(split, 0, 1, null_mut()),
                    CMLT_ERROR_INVALID_OPERATION,
                    "cmlt_renderer_render",
                );
            }
            // Each worker's share on its own thread.
            let addr = split as usize;
            std::thread::scope(|sc| {
                for w in 0..3 {
                    sc.spawn(move || {
                        let r = addr as *const cmlt_renderer;
                        expect(
                            cmlt_renderer_prepare_worker(r, w),
                            CMLT_OK,
                            "cmlt_renderer_prepare_worker",
                        );
                    });
                }
            });
            expect(
                cmlt_renderer_prepare_finish(split),
                CMLT_OK,
                "cmlt_renderer_prepare_finish",
            );
            expect(
                cmlt_renderer_prepare_worker(split, 3),
                CMLT_ERROR_INVALID_ARGUMENT,
                "cmlt_renderer_prepare_worker",
            );
            let mut total = [0u64; 2];
            for w in 0..3 {
                let mut done = 0;
                expect(
                    cmlt_renderer_render_per_pixel(one, w, 5, &mut done),
                    CMLT_OK,
                    "cmlt_renderer_render_per_pixel",
                );
                total[0] += done;
                expect(
                    cmlt_renderer_render_per_pixel(split, w, 5, &mut done),
                    CMLT_OK,
                    "cmlt_renderer_render_per_pixel",
                );
                total[1] += done;
            }
            assert_eq!(total[0], total[1]);
            // At least 5 per pixel over the workers.
            assert!(total[0] >= 5 * 16 * 12, "{total:?}");
            if estimator == CMLT_ESTIMATOR_PT {
                assert_eq!(total[0], 5 * 16 * 12, "passes 0..5 over 3 workers");
            }
            let (a, b) = (image(one), image(split));
            assert!(a.iter().any(|&v| v > 0.0));
            assert_eq!(a, b, "estimator {estimator}");
            cmlt_renderer_release(one);
            cmlt_renderer_release(split);
        }
    }
    // SAFETY: a valid scene.
    unsafe { cmlt_scene_release(s) };
}

/// Mean of a PT image of committed scene `s` at `budget` samples per pixel.
fn pt_mean(s: *const cmlt_scene, budget: u64) -> f64 {
    let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 1));
    prepare_render_stats(r, budget);
    let px = image(r);
    // SAFETY: a renderer we created.
    unsafe { cmlt_renderer_release(r) };
    assert!(px.iter().all(|v| v.is_finite()));
    px.iter().map(|&v| v as f64).sum::<f64>() / px.len() as f64
}

#[test]
fn envmaps_are_checked_copied_and_rendered() {
    // A 4 × 3 map of 0.25 in rows padded to 64 bytes, times color 2: the
    // constant environment of radiance 0.5.
    let (w, h, stride) = (4u32, 3u32, 64usize);
    let mut rows = vec![0.0f32; stride / 4 * h as usize];
    for y in 0..h as usize {
        for v in &mut rows[y * 16..y * 16 + 12] {
            *v = 0.25;
        }
        // The padding is not read: poison it.
        rows[y * 16 + 12] = f32::NAN;
    }
    let env = cmlt_light {
        type_: CMLT_LIGHT_ENVMAP,
        color: [2.0, 2.0, 2.0],
        position: [0.0; 3],
        direction: [0.0; 3],
        cutoff_angle: 0.0,
        beam_width: 0.0,
        texels: rows.as_ptr(),
        width: w,
        height: h,
        stride,
        to_world: [0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0],
    };
    let f = "cmlt_scene_add_light";
    let s = floor_and_light();
    let mut nan = rows.clone();
    nan[17] = f32::NAN;
    let mut negative = rows.clone();
    negative[40] = -1.0;
    // SAFETY: valid pointers, or deliberately NULL / bad values; every
    // texel pointer covers the rows it claims.
    unsafe {
        // A texture before the map keeps id 1 (bitmaps and texture ids
        // differ once a map is added).
        let mut tex = 0;
        let grey = [128u8; 12];
        expect(
            cmlt_scene_add_texture(s, 2, 2, 3, grey.as_ptr(), 0, 1, &mut tex),
            CMLT_OK,
            "add_texture",
        );
        assert_eq!(tex, 1);
        expect(
            cmlt_scene_add_light(
                s,
                &cmlt_light {
                    texels: null(),
                    ..env
                },
                null_mut(),
            ),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        let bad = [
            cmlt_light { width: 0, ..env },
            cmlt_light { height: 0, ..env },
            cmlt_light { stride: 40, ..env },
            cmlt_light { stride: 50, ..env },
            cmlt_light {
                texels: nan.as_ptr(),
                ..env
            },
            cmlt_light {
                texels: negative.as_ptr(),
                ..env
            },
            cmlt_light {
                color: [1.0, -1.0, 1.0],
                ..env
            },
            cmlt_light {
                to_world: [2.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                ..env
            },
            cmlt_light {
                to_world: [f32::NAN, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                ..env
            },
            cmlt_light {
                texels: rows.as_ptr().cast::<u8>().add(2).cast(),
                ..env
            },
        ];
        for l in bad {
            expect(
                cmlt_scene_add_light(s, &l, null_mut()),
                CMLT_ERROR_INVALID_ARGUMENT,
                f,
            );
        }
        let mut index = 7;
        expect(cmlt_scene_add_light(s, &env, &mut index), CMLT_OK, f);
        assert_eq!(index, 0);
        // Copied in: changing the host's texels afterwards changes nothing.
        rows.iter_mut().for_each(|v| *v = 100.0);
        // A texture after the map gets the next id, usable by materials.
        expect(
            cmlt_scene_add_texture(s, 2, 2, 3, grey.as_ptr(), 0, 1, &mut tex),
            CMLT_OK,
            "add_texture",
        );
        assert_eq!(tex, 2);
        let mut m = WHITE;
        m.color_texture = 2;
        let mut id = 0;
        expect(cmlt_scene_add_material(s, &m, &mut id), CMLT_OK, "material");
        expect(cmlt_scene_commit(s), CMLT_OK, "commit");
        let mut effects = 0;
        expect(
            cmlt_scene_get_effects(s, &mut effects, null_mut()),
            CMLT_OK,
            "effects",
        );
        assert_ne!(effects & CMLT_EFFECT_ENVIRONMENT, 0);
    }
    // The same scene under the constant environment of radiance 0.5: the
    // images agree (a flat map is that environment).
    let c = floor_and_light();
    // SAFETY: valid pointers.
    unsafe {
        let constant = cmlt_light {
            type_: CMLT_LIGHT_CONSTANT,
            color: [0.5; 3],
            texels: null(),
            ..env
        };
        expect(cmlt_scene_add_light(c, &constant, null_mut()), CMLT_OK, f);
        expect(cmlt_scene_commit(c), CMLT_OK, "commit");
    }
    let (a, b) = (pt_mean(s, 64), pt_mean(c, 64));
    assert!((a - b).abs() < 0.02 * b, "envmap {a} vs constant {b}");
    let plain = scene(None);
    assert!(a > pt_mean(plain, 64) * 1.05, "the map adds light");
    // SAFETY: scenes we created.
    unsafe {
        cmlt_scene_release(s);
        cmlt_scene_release(c);
        cmlt_scene_release(plain);
    }
}

/// Rough diffuse through the C API: `roughness` is Mitsuba's α; the
/// effect and the lobe counters (fourth of `bsdf_*_more`) report it, α = 0
/// renders Lambert's image exactly, α = 1 another one, and bad α or
/// albedo are refused.
#[test]
fn rough_diffuse_is_checked_counted_and_rendered() {
    let lambert = cmlt_material {
        color: [0.6, 0.5, 0.4],
        two_sided: 1,
        ..WHITE
    };
    let rough = |alpha: f32| cmlt_material {
        type_: CMLT_MATERIAL_ROUGH_DIFFUSE,
        roughness: alpha,
        ..lambert
    };
    let render = |m: &cmlt_material| {
        let s = floor_of(m).unwrap_or_else(|e| panic!("status {e:?}"));
        let mut fx = 0u32;
        // SAFETY: valid pointers.
        unsafe {
            expect(
                cmlt_scene_get_effects(s, &mut fx, null_mut()),
                CMLT_OK,
                "effects",
            )
        };
        let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 1));
        let stats = prepare_render_stats(r, 16 * 12 * 4);
        let px = image(r);
        // SAFETY: handles from above.
        unsafe {
            cmlt_renderer_release(r);
            cmlt_scene_release(s);
        }
        (fx, stats, px)
    };
    let (fx_l, stats_l, px_l) = render(&lambert);
    let (fx_0, stats_0, px_0) = render(&rough(0.0));
    let (fx_1, stats_1, px_1) = render(&rough(1.0));
    assert_eq!(fx_l & CMLT_EFFECT_ROUGH_DIFFUSE, 0);
    assert_ne!(fx_0 & CMLT_EFFECT_ROUGH_DIFFUSE, 0);
    assert_ne!(fx_1 & CMLT_EFFECT_ROUGH_DIFFUSE, 0);
    assert_eq!(stats_l.bsdf_samples_more[3], 0);
    for st in [&stats_0, &stats_1] {
        assert!(
            st.bsdf_samples_more[3] > 0 && st.bsdf_evals_more[3] > 0,
            "{st:?}"
        );
    }
    assert!(px_1.iter().all(|v| v.is_finite() && *v >= 0.0));
    assert_eq!(px_0, px_l, "α = 0 is Lambert");
    assert_ne!(px_1, px_l, "α = 1 is not");
    for (name, bad) in [
        ("NaN α", rough(f32::NAN)),
        ("negative α", rough(-0.5)),
        ("huge α", rough(1e5)),
        (
            "albedo > 1",
            cmlt_material {
                color: [1.2, 0.5, 0.5],
                ..rough(0.5)
            },
        ),
    ] {
        assert_eq!(
            floor_of(&bad).err(),
            Some(CMLT_ERROR_INVALID_ARGUMENT),
            "{name}"
        );
        assert!(
            last_error().contains("material"),
            "{name}: {}",
            last_error()
        );
    }
}

/// One rule per parameter, the core's (`Material::validate`), as the
/// loader applies it: every colour of a material in [0, 1], the
/// microfacet α of rough metal, plastic and glass in (0, 1e4].
#[test]
fn colours_and_roughness_follow_one_rule() {
    let metal = |alpha: f32| cmlt_material {
        type_: CMLT_MATERIAL_ROUGH_METAL,
        roughness: alpha,
        ..WHITE
    };
    let plastic = |alpha: f32| cmlt_material {
        type_: CMLT_MATERIAL_ROUGH_PLASTIC,
        roughness: alpha,
        ior: 1.5,
        ..WHITE
    };
    let glass = |alpha: f32| cmlt_material {
        type_: CMLT_MATERIAL_ROUGH_GLASS,
        roughness: alpha,
        ior: 1.5,
        ..WHITE
    };
    for m in [metal(2.0), plastic(2.0), glass(2.0), metal(1e4)] {
        let s = floor_of(&m).unwrap_or_else(|e| panic!("α {}: {e:?}", m.roughness));
        // SAFETY: a handle from floor_of.
        unsafe { cmlt_scene_release(s) };
    }
    for (name, bad) in [
        ("metal α 0", metal(0.0)),
        ("metal α 2e4", metal(2e4)),
        ("plastic α 2e4", plastic(2e4)),
        ("glass α NaN", glass(f32::NAN)),
        (
            "plastic specular 1.5",
            cmlt_material {
                specular_color: [1.0, 1.5, 1.0],
                ..plastic(0.2)
            },
        ),
        (
            "thin glass transmission 1.2",
            cmlt_material {
                type_: CMLT_MATERIAL_THIN_GLASS,
                ior: 1.5,
                transmission_color: [1.2, 1.0, 1.0],
                ..WHITE
            },
        ),
        (
            "metal colour 1.01",
            cmlt_material {
                color: [1.01, 0.5, 0.5],
                ..metal(0.3)
            },
        ),
    ] {
        assert_eq!(
            floor_of(&bad).err(),
            Some(CMLT_ERROR_INVALID_ARGUMENT),
            "{name}"
        );
        let e = last_error();
        assert!(
            e.contains("[0, 1]") || e.contains("(0, 1e4]"),
            "{name}: {e}"
        );
    }
}

/// Meshes too far from the origin for their size are refused at commit
/// (`SceneError::TooFarFromOrigin`), with the bound in the message, and
/// the scene stays editable.
#[test]
fn a_scene_far_from_the_origin_is_refused_at_commit_and_update() {
    // Both quads moved 10⁷ along x (their extent is about 3).
    let mut far = POSITIONS;
    for p in far.chunks_mut(3) {
        p[0] += 1e7;
    }
    let mut s = null_mut();
    let mut id = 0;
    // SAFETY: valid pointers throughout.
    unsafe {
        expect(cmlt_scene_new(&mut s), CMLT_OK, "new");
        expect(
            cmlt_scene_add_material(s, &WHITE, &mut id),
            CMLT_OK,
            "material",
        );
        for (indices, emission) in [(&FLOOR, 0.0), (&LIGHT, 5.0)] {
            let m = cmlt_mesh {
                positions: far.as_ptr(),
                ..mesh(indices, id, emission)
            };
            expect(cmlt_scene_add_mesh(s, &m, null_mut()), CMLT_OK, "mesh");
        }
        expect(
            cmlt_scene_commit(s),
            CMLT_ERROR_INVALID_ARGUMENT,
            "cmlt_scene_commit",
        );
        let e = last_error();
        assert!(e.contains("65536") && e.contains("origin"), "{e}");
        cmlt_scene_release(s);
    }
    // Moving meshes there later is refused the same way: one mesh far away
    // only widens the scene, the second leaves it unresolvable.
    let s = scene(None);
    // SAFETY: valid pointers throughout.
    unsafe {
        expect(
            cmlt_scene_update_mesh(s, 0, far.as_ptr(), 8, 0, null(), 0),
            CMLT_OK,
            "update_mesh",
        );
        expect(
            cmlt_scene_update_mesh(s, 1, far.as_ptr(), 8, 0, null(), 0),
            CMLT_ERROR_INVALID_ARGUMENT,
            "cmlt_scene_update_mesh",
        );
        let e = last_error();
        assert!(e.contains("65536") && e.contains("origin"), "{e}");
        expect(
            cmlt_scene_update_mesh(s, 0, POSITIONS.as_ptr(), 8, 0, null(), 0),
            CMLT_OK,
            "update_mesh",
        );
        cmlt_scene_release(s);
    }
}

/// A panic inside a call that holds an object's lock (the test hook
/// stands in for a bug) poisons that lock: the call reports
/// `CMLT_ERROR_INTERNAL`, and so does every later call that needs the
/// object — it is dead, never `CMLT_ERROR_BUSY` forever — while other
/// objects and the renderer's other workers go on, and release works.
#[test]
fn a_panic_under_a_lock_leaves_the_object_dead_not_busy() {
    let dead = |status: cmlt_status, function: &str| {
        expect(status, CMLT_ERROR_INTERNAL, function);
        assert!(last_error().contains("unusable"), "{}", last_error());
    };
    let s = floor_and_light();
    let other = floor_and_light();
    let mut id = 0;
    // SAFETY: valid pointers; handles from this test.
    unsafe {
        crate::error::PANIC_ONCE.set(true);
        expect(
            cmlt_scene_add_material(s, &WHITE, &mut id),
            CMLT_ERROR_INTERNAL,
            "cmlt_scene_add_material",
        );
        assert!(last_error().contains("test hook"), "{}", last_error());
        for _ in 0..2 {
            dead(
                cmlt_scene_add_material(s, &WHITE, &mut id),
                "cmlt_scene_add_material",
            );
            dead(cmlt_scene_commit(s), "cmlt_scene_commit");
        }
        expect(
            cmlt_scene_add_material(other, &WHITE, &mut id),
            CMLT_OK,
            "add_material",
        );
        cmlt_scene_release(s);
        cmlt_scene_release(other);
    }
    let s = scene(None);
    let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 2));
    let mut px = vec![0.0f32; 16 * 12 * 3];
    let mut stats = cmlt_stats::default();
    // SAFETY: valid pointers; handles from this test.
    unsafe {
        expect(cmlt_renderer_prepare(r), CMLT_OK, "prepare");
        crate::error::PANIC_ONCE.set(true);
        expect(
            cmlt_renderer_render(r, 0, 16 * 12, null_mut()),
            CMLT_ERROR_INTERNAL,
            "cmlt_renderer_render",
        );
        for _ in 0..2 {
            dead(
                cmlt_renderer_render(r, 0, 16 * 12, null_mut()),
                "cmlt_renderer_render",
            );
            dead(
                cmlt_renderer_resolve(
                    r,
                    CMLT_FORMAT_RGB32F,
                    px.as_mut_ptr().cast(),
                    0,
                    px.len() * 4,
                ),
                "cmlt_renderer_resolve",
            );
            dead(
                cmlt_renderer_get_stats(r, &mut stats),
                "cmlt_renderer_get_stats",
            );
        }
        // The other worker was not touched by the bug.
        expect(
            cmlt_renderer_render(r, 1, 16 * 12, null_mut()),
            CMLT_OK,
            "render",
        );
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
}

/// Huge worker, chain, bootstrap or pass counts and resolutions are
/// refused by the memory query and by creation with a status and a
/// message — out of memory, before anything is built — instead of
/// aborting the process; `*out` stays NULL. A configuration whose bound
/// overflows even 64 bits says so.
#[test]
fn huge_renderer_configurations_are_refused_not_aborted() {
    let s = scene(None);
    type Tweak = fn(&mut cmlt_renderer_config);
    let cases: [(&str, Tweak); 6] = [
        ("workers", |c| c.workers = u32::MAX),
        ("chains", |c| c.chains = u32::MAX),
        ("bootstrap", |c| c.bootstrap_samples = u32::MAX),
        ("passes", |c| c.normalisation_passes = u32::MAX),
        ("resolution × workers", |c| {
            (c.width, c.height, c.workers) = (16384, 16384, 4096)
        }),
        ("chains × workers", |c| {
            (c.chains, c.workers, c.max_depth) = (u32::MAX, u32::MAX, 1024)
        }),
    ];
    for (what, tweak) in cases {
        let mut c = config(CMLT_ESTIMATOR_CMLT, 2);
        tweak(&mut c);
        let (mut bytes, mut r) = (7usize, null_mut());
        // SAFETY: valid pointers.
        unsafe {
            expect(
                cmlt_renderer_memory_requirements(s, &c, &mut bytes, null_mut()),
                CMLT_ERROR_OUT_OF_MEMORY,
                "cmlt_renderer_memory_requirements",
            );
            assert_eq!(bytes, 7, "{what}: the query wrote its output");
            expect(
                cmlt_renderer_new(s, &c, &CAMERA, &mut r),
                CMLT_ERROR_OUT_OF_MEMORY,
                "cmlt_renderer_new",
            );
            assert!(r.is_null(), "{what}");
        }
        if what == "chains × workers" {
            assert!(last_error().contains("address space"), "{}", last_error());
        }
    }
    // SAFETY: handle from this test.
    unsafe { cmlt_scene_release(s) };
}

/// A configuration refused by creation is refused by the memory query too,
/// before any bound is computed from it: an out-of-range k once made both
/// compute a bound of terabytes, which creation then asked the allocator
/// for (an AddressSanitizer abort under the fuzzer).
#[test]
fn invalid_configurations_get_no_memory_bound() {
    let s = scene(None);
    for (what, tweak) in [
        (
            "k",
            (|c| c.k = 0x6868_6868) as fn(&mut cmlt_renderer_config),
        ),
        ("lanes", |c| c.lanes = u32::MAX),
        ("normalisation floor", |c| {
            c.normalisation_min_samples = u32::MAX
        }),
        ("no workers", |c| c.workers = 0),
        ("m = 0", |c| c.m = 0),
    ] {
        let mut c = config(CMLT_ESTIMATOR_CMLT, 2);
        tweak(&mut c);
        let (mut bytes, mut r) = (7usize, null_mut());
        // SAFETY: valid pointers.
        unsafe {
            expect(
                cmlt_renderer_memory_requirements(s, &c, &mut bytes, null_mut()),
                CMLT_ERROR_INVALID_ARGUMENT,
                "cmlt_renderer_memory_requirements",
            );
            assert_eq!(bytes, 7, "{what}: the query wrote its output");
            expect(
                cmlt_renderer_new(s, &c, &CAMERA, &mut r),
                CMLT_ERROR_INVALID_ARGUMENT,
                "cmlt_renderer_new",
            );
            assert!(r.is_null(), "{what}");
        }
    }
    // SAFETY: handle from this test.
    unsafe { cmlt_scene_release(s) };
}

/// The bound creation reserves first is an upper bound of what the
/// renderer really takes (the memory query's measurement), and within 8×
/// of it, across estimators, depths, chain, bootstrap and pass counts, k,
/// worker counts and resolutions.
#[test]
fn the_memory_bound_covers_what_creation_allocates() {
    let s = scene(None);
    // SAFETY: a committed scene.
    let committed = unsafe { &*s }.committed().unwrap();
    for estimator in [
        CMLT_ESTIMATOR_PT,
        CMLT_ESTIMATOR_BDPT,
        CMLT_ESTIMATOR_MLT,
        CMLT_ESTIMATOR_CMLT,
    ] {
        for (workers, chains, depth, k, (w, h)) in [
            (1, 16, 0, 4, (16, 12)),
            (3, 256, 5, 64, (64, 48)),
            (2, 1000, 64, 8, (7, 300)),
            (4, 4, 1024, 1, (1, 1)),
        ] {
            let mut c = config(estimator, workers);
            (c.chains, c.max_depth, c.k, c.width, c.height) = (chains, depth, k, w, h);
            (c.bootstrap_samples, c.normalisation_passes) = (10 * chains, chains / 4 + 1);
            let mut bytes = 0;
            // SAFETY: valid pointers.
            unsafe {
                expect(
                    cmlt_renderer_memory_requirements(s, &c, &mut bytes, null_mut()),
                    CMLT_OK,
                    "memory_requirements",
                )
            };
            let cfg = crate::renderer::core_config(&c, &committed).unwrap();
            let bound = cmlt_core::renderer::Renderer::memory_bound(&cfg, w, h).unwrap();
            let case = format!(
                "estimator {estimator}, {workers} workers, {chains} chains, depth {depth}, k {k}, {w}×{h}"
            );
            assert!(bound >= bytes as u64, "{case}: bound {bound} < {bytes} B");
            assert!(
                bound <= 8 * bytes as u64,
                "{case}: bound {bound} ≫ {bytes} B"
            );
        }
    }
    // SAFETY: handle from this test.
    unsafe { cmlt_scene_release(s) };
}

/// `cmlt_renderer_config_default` mirrors every MLT setting of the core's
/// defaults for the estimator (CMLT's measured defaults included), so a C
/// host that starts from it renders what `cmlt render --method …` does.
#[test]
fn config_default_is_the_cores_default() {
    let s = scene(None);
    // SAFETY: a committed scene.
    let committed = unsafe { &*s }.committed().unwrap();
    for estimator in [
        CMLT_ESTIMATOR_PT,
        CMLT_ESTIMATOR_BDPT,
        CMLT_ESTIMATOR_MLT,
        CMLT_ESTIMATOR_CMLT,
    ] {
        let mut c = std::mem::MaybeUninit::uninit();
        // SAFETY: valid out pointer.
        let mut c = unsafe {
            expect(
                cmlt_renderer_config_default(estimator, c.as_mut_ptr()),
                CMLT_OK,
                "config_default",
            );
            c.assume_init()
        };
        (c.width, c.height) = (16, 12);
        let e = cmlt_core::renderer::Estimator::from_u32(estimator).unwrap();
        let cfg = crate::renderer::core_config(&c, &committed).unwrap();
        let mut expected = cmlt_core::renderer::RendererConfig::for_estimator(e).mlt;
        if estimator != CMLT_ESTIMATOR_CMLT {
            // The C config's m is CMLT's alone (1 by default, unused).
            expected.m = 0;
        }
        assert_eq!(cfg.mlt, expected, "estimator {estimator}");
    }
    // SAFETY: handle from this test.
    unsafe { cmlt_scene_release(s) };
}

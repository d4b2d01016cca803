//! A small subset for Miri (`cargo +nightly miri test -p cmlt-capi --test
//! miri`): the unsafe code a host's input goes through — the allocator's
//! block headers (host hooks installed), `gather` of strided, interleaved
//! host arrays in `cmlt_scene_add_mesh`, the host-intersector callbacks
//! and the pixel writes of `cmlt_renderer_resolve` at a padded row stride.
//! No BVH is built (Miri runs no SIMD): the scene traces through a host
//! intersector whose rays all miss, and the camera sees the emitter only
//! through `resolve`'s arithmetic — enough to walk every pointer.

use std::alloc::{GlobalAlloc, Layout, System};
use std::ffi::c_void;
use std::ptr::{null, null_mut};

use cmlt_capi::alloc::{cmlt_allocator, cmlt_set_allocator};
use cmlt_capi::error::cmlt_status::*;
use cmlt_capi::host::{CMLT_INVALID_ID, cmlt_hit, cmlt_intersector, cmlt_ray};
use cmlt_capi::renderer::*;
use cmlt_capi::scene::*;

unsafe extern "C" fn host_alloc(_: *mut c_void, size: usize, align: usize) -> *mut c_void {
    // SAFETY: size > 0 (the library never asks for 0), align a power of two.
    unsafe {
        System
            .alloc(Layout::from_size_align(size, align).unwrap())
            .cast()
    }
}

unsafe extern "C" fn host_free(_: *mut c_void, ptr: *mut c_void, size: usize, align: usize) {
    // SAFETY: `ptr` came from `host_alloc` with this size and alignment.
    unsafe { System.dealloc(ptr.cast(), Layout::from_size_align(size, align).unwrap()) }
}

unsafe extern "C" fn miss(_: *mut c_void, _: *const cmlt_ray, hit: *mut cmlt_hit) {
    // SAFETY: the library passes a valid hit to fill.
    unsafe { (*hit).prim_id = CMLT_INVALID_ID };
}

unsafe extern "C" fn never(_: *mut c_void, _: *const cmlt_ray) -> u32 {
    0
}

#[test]
fn host_input_paths_under_miri() {
    // Interleaved vertices: position, normal, uv, 2 floats of padding.
    #[rustfmt::skip]
    let verts: [f32; 40] = [
        -1.0, 0.0, -1.0,  0.0, 1.0, 0.0,  0.0, 0.0,  9.0, 9.0,
         1.0, 0.0, -1.0,  0.0, 1.0, 0.0,  1.0, 0.0,  9.0, 9.0,
         1.0, 0.0,  1.0,  0.0, 1.0, 0.0,  1.0, 1.0,  9.0, 9.0,
        -1.0, 0.0,  1.0,  0.0, 1.0, 0.0,  0.0, 1.0,  9.0, 9.0,
    ];
    // Triangles padded to 4 indices.
    let indices: [u32; 8] = [0, 2, 1, 77, 0, 3, 2, 77];
    let base = verts.as_ptr();
    let hooks = cmlt_allocator {
        user: null_mut(),
        alloc: Some(host_alloc),
        free: Some(host_free),
    };
    // SAFETY: valid pointers; the strided arrays lie inside `verts` and
    // `indices`.
    unsafe {
        assert_eq!(cmlt_set_allocator(&hooks), CMLT_OK);
        let mut s = null_mut();
        assert_eq!(cmlt_scene_new(&mut s), CMLT_OK);
        let mut id = 0;
        // A 2×1×1 grey grid read by the material: its voxels are read
        // through the raw pointer during the call and copied.
        let voxels = [0.25f32, 0.75];
        let grid = cmlt_grid {
            resolution: [2, 1, 1],
            channels: 1,
            voxels: voxels.as_ptr(),
            to_world: [0.0; 12],
            filter: CMLT_GRID_TRILINEAR,
            wrap: CMLT_GRID_REPEAT,
        };
        let mut grid_id = 0;
        assert_eq!(cmlt_scene_add_grid_texture(s, &grid, &mut grid_id), CMLT_OK);
        let white = cmlt_material {
            type_: CMLT_MATERIAL_DIFFUSE,
            color: [0.5; 3],
            ior: 1.0,
            roughness: 0.0,
            two_sided: 1,
            color_texture: grid_id,
            normal_map: CMLT_NO_TEXTURE,
            bump_map: CMLT_NO_TEXTURE,
            bump_scale: 1.0,
            opacity_texture: CMLT_NO_TEXTURE,
            specular_color: [1.0; 3],
            transmission_color: [1.0; 3],
            distribution: 0,
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
        assert_eq!(cmlt_scene_add_material(s, &white, &mut id), CMLT_OK);
        let mesh = cmlt_mesh {
            positions: base,
            vertex_count: 4,
            position_stride: 40,
            normals: base.add(3),
            normal_stride: 40,
            uvs: base.add(6),
            uv_stride: 40,
            indices: indices.as_ptr(),
            triangle_count: 2,
            index_stride: 16,
            material: id,
            emission: [2.0; 3],
        };
        let mut first = 99;
        assert_eq!(cmlt_scene_add_mesh(s, &mesh, &mut first), CMLT_OK);
        assert_eq!(first, 0);
        // Rejected: the padding as a fourth vertex index is out of range.
        let bad = cmlt_mesh {
            index_stride: 12,
            triangle_count: 2,
            ..mesh
        };
        assert_eq!(
            cmlt_scene_add_mesh(s, &bad, null_mut()),
            CMLT_ERROR_INVALID_ARGUMENT
        );
        let isect = cmlt_intersector {
            user: null_mut(),
            intersect: Some(miss),
            occluded: Some(never),
            intersect_packet: None,
            occluded_packet: None,
        };
        assert_eq!(cmlt_scene_set_intersector(s, &isect), CMLT_OK);
        assert_eq!(cmlt_scene_commit(s), CMLT_OK);

        let mut c = std::mem::MaybeUninit::uninit();
        assert_eq!(
            cmlt_renderer_config_default(CMLT_ESTIMATOR_PT, c.as_mut_ptr()),
            CMLT_OK
        );
        let mut c = c.assume_init();
        c.width = 3;
        c.height = 2;
        c.max_depth = 2;
        let camera = cmlt_camera {
            position: [0.0, 1.0, -2.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_degrees: 60.0,
            aperture_radius: 0.0,
            focus_distance: 1.0,
        };
        let mut r = null_mut();
        assert_eq!(cmlt_renderer_new(s, &c, &camera, &mut r), CMLT_OK);
        assert_eq!(cmlt_renderer_prepare(r), CMLT_OK);
        let mut done = 0;
        assert_eq!(cmlt_renderer_render(r, 0, 6, &mut done), CMLT_OK);
        assert_eq!(done, 6);
        // Rows of 3 RGB floats padded to 48 bytes, and RGBA8 at 16.
        let mut f = vec![7.0f32; 12 * 2];
        assert_eq!(
            cmlt_renderer_resolve(r, CMLT_FORMAT_RGB32F, f.as_mut_ptr().cast(), 48, 48 + 36),
            CMLT_OK
        );
        assert!(f[9..12].iter().all(|&v| v == 7.0), "padding written");
        let mut px = vec![0u8; 16 + 12];
        assert_eq!(
            cmlt_renderer_resolve(r, CMLT_FORMAT_RGBA8_SRGB, px.as_mut_ptr(), 16, px.len()),
            CMLT_OK
        );
        assert_eq!(px[3], 255);
        let mut stats = cmlt_stats::default();
        assert_eq!(cmlt_renderer_get_stats(r, &mut stats), CMLT_OK);
        assert_eq!(stats.nonfinite, 0);
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
        assert_eq!(cmlt_set_allocator(null()), CMLT_OK);
    }
}

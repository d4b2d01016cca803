//! What the C API's integration tests share: the last error and the
//! status check, the white material, the floor-and-light quads with their
//! mesh descriptor, and the camera looking at them.
#![allow(dead_code)]

use std::ffi::CStr;
use std::ptr::null;

use cmlt_capi::error::cmlt_last_error;
use cmlt_capi::error::cmlt_status::{self, *};
use cmlt_capi::scene::*;

/// The calling thread's last error message.
pub fn last_error() -> String {
    // SAFETY: never NULL, NUL-terminated.
    unsafe { CStr::from_ptr(cmlt_last_error()) }
        .to_string_lossy()
        .into_owned()
}

/// Asserts `status` is `want` and that a message naming `function` was set.
pub fn expect(status: cmlt_status, want: cmlt_status, function: &str) {
    assert_eq!(status, want, "{function}: {}", last_error());
    if want != CMLT_OK {
        let msg = last_error();
        assert!(
            msg.starts_with(function),
            "message {msg:?} does not name {function}"
        );
    }
}

/// A white-ish diffuse material, every other field at its default.
pub const WHITE: cmlt_material = cmlt_material {
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
pub const POSITIONS: [f32; 24] = [
    -1.0, 0.0, -1.0, -1.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0, -1.0, // floor, facing +y
    -0.3, 1.0, -0.3, 0.3, 1.0, -0.3, 0.3, 1.0, 0.3, -0.3, 1.0, 0.3, // light, facing −y
];
/// The floor's and the light's triangles in [`POSITIONS`].
pub const FLOOR: [u32; 6] = [0, 1, 2, 0, 2, 3];
pub const LIGHT: [u32; 6] = [4, 5, 6, 4, 6, 7];

/// The quads of [`POSITIONS`] named by `indices`, of `material`,
/// emitting `emission` (0: none).
pub fn mesh(indices: &[u32], material: u32, emission: f32) -> cmlt_mesh {
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

/// A camera looking at the floor and the light.
pub const CAMERA: cmlt_camera = cmlt_camera {
    position: [0.0, 0.5, -2.0],
    target: [0.0, 0.3, 0.0],
    up: [0.0, 1.0, 0.0],
    fov_degrees: 60.0,
    aperture_radius: 0.0,
    focus_distance: 1.0,
};

//! Textures from host memory: colour, normal, bump and opacity.

use super::*;

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

/// A 2×1×1 grid, red then green, spread by `to_world` over the cube
/// [−1, 1]³ (mirrored in x with `mirror`), read at the nearest voxel.
fn red_green_grid(voxels: &[f32; 6], mirror: bool) -> cmlt_grid {
    let sx = if mirror { -2.0 } else { 2.0 };
    cmlt_grid {
        resolution: [2, 1, 1],
        channels: 3,
        voxels: voxels.as_ptr(),
        to_world: [
            sx,
            0.0,
            0.0,
            -sx / 2.0,
            0.0,
            2.0,
            0.0,
            -1.0,
            0.0,
            0.0,
            2.0,
            -1.0,
        ],
        filter: CMLT_GRID_NEAREST,
        wrap: CMLT_GRID_CLAMP,
    }
}

/// The floor coloured by `grid` under the light, rendered by PT: per image
/// column of the floor's lower rows, +1 where red dominates, −1 where
/// green does, 0 where neither (the columns off the floor).
fn floor_colour_columns(grid: &cmlt_grid) -> Vec<i32> {
    let mut s = null_mut();
    let (mut tex, mut mat) = (0u32, 0u32);
    // SAFETY: valid pointers throughout; the grid's voxels are alive.
    let px = unsafe {
        expect(cmlt_scene_new(&mut s), CMLT_OK, "cmlt_scene_new");
        expect(
            cmlt_scene_add_grid_texture(s, grid, &mut tex),
            CMLT_OK,
            "cmlt_scene_add_grid_texture",
        );
        let m = cmlt_material {
            color_texture: tex,
            ..WHITE
        };
        expect(
            cmlt_scene_add_material(s, &m, &mut mat),
            CMLT_OK,
            "material",
        );
        expect(
            cmlt_scene_add_mesh(s, &mesh(&FLOOR, mat, 0.0), null_mut()),
            CMLT_OK,
            "add_mesh",
        );
        expect(
            cmlt_scene_add_mesh(s, &mesh(&LIGHT, mat, 5.0), null_mut()),
            CMLT_OK,
            "add_mesh",
        );
        expect(cmlt_scene_commit(s), CMLT_OK, "commit");
        let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 1));
        prepare_render_stats(r, 16 * 12 * 64);
        let px = image(r);
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
        px
    };
    // The bottom three rows see the floor only.
    (0..16)
        .map(|x| {
            let (mut r, mut g) = (0.0, 0.0);
            for y in 9..12 {
                r += px[(y * 16 + x) * 3];
                g += px[(y * 16 + x) * 3 + 1];
            }
            if r > 4.0 * g {
                1
            } else if g > 4.0 * r {
                -1
            } else {
                0
            }
        })
        .collect()
}

/// A grid texture colours a surface by its world position through
/// `to_world`: red on one side of x = 0, green on the other, and the sides
/// swap when `to_world` mirrors x. An ignored `to_world` (the grid over
/// the unit cube) would put the boundary at x = ½, off the image's centre,
/// and mirroring would not swap the sides.
#[test]
fn grid_textures_colour_surfaces_by_world_position() {
    let voxels = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let plain = floor_colour_columns(&red_green_grid(&voxels, false));
    let mirrored = floor_colour_columns(&red_green_grid(&voxels, true));
    // Each half of the image is one colour, the halves differ, and the
    // mirror swaps them.
    let (left, right) = (plain[..8].to_vec(), plain[8..].to_vec());
    assert!(
        left.iter().all(|&c| c == left[0]) && right.iter().all(|&c| c == -left[0]) && left[0] != 0,
        "{plain:?}"
    );
    let swapped: Vec<i32> = plain.iter().map(|c| -c).collect();
    assert_eq!(mirrored, swapped, "plain {plain:?}");
}

/// Bad grids are refused at the call with the scene unchanged (no id
/// taken), and a grid cannot be a normal or bump map.
#[test]
fn bad_grid_textures_are_refused() {
    let f = "cmlt_scene_add_grid_texture";
    let voxels = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let over = [1.0, 0.0, 0.0, 0.0, 1.5, 0.0];
    let nan = [1.0, 0.0, f32::NAN, 0.0, 1.0, 0.0];
    let good = red_green_grid(&voxels, false);
    let mut s = null_mut();
    let mut id = 0u32;
    // SAFETY: valid pointers throughout; the voxel arrays hold 6 floats.
    unsafe {
        expect(cmlt_scene_new(&mut s), CMLT_OK, "cmlt_scene_new");
        let singular = {
            let mut g = good;
            g.to_world[0] = 0.0;
            g
        };
        for (bad, want) in [
            (red_green_grid(&over, false), CMLT_ERROR_INVALID_ARGUMENT),
            (red_green_grid(&nan, false), CMLT_ERROR_INVALID_ARGUMENT),
            (
                cmlt_grid {
                    channels: 2,
                    ..good
                },
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_grid {
                    resolution: [2, 0, 1],
                    ..good
                },
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (cmlt_grid { filter: 7, ..good }, CMLT_ERROR_INVALID_ARGUMENT),
            (cmlt_grid { wrap: 7, ..good }, CMLT_ERROR_INVALID_ARGUMENT),
            (singular, CMLT_ERROR_INVALID_ARGUMENT),
            (
                cmlt_grid {
                    voxels: null(),
                    ..good
                },
                CMLT_ERROR_NULL_POINTER,
            ),
        ] {
            expect(cmlt_scene_add_grid_texture(s, &bad, &mut id), want, f);
        }
        expect(
            cmlt_scene_add_grid_texture(s, null(), &mut id),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(cmlt_scene_add_grid_texture(s, &good, &mut id), CMLT_OK, f);
        assert_eq!(id, 1, "refused grids took no ids");
        let identity = cmlt_grid {
            to_world: [0.0; 12],
            ..good
        };
        expect(
            cmlt_scene_add_grid_texture(s, &identity, &mut id),
            CMLT_OK,
            f,
        );
        assert_eq!(id, 2);
        let f = "cmlt_scene_add_material";
        for bad in [
            cmlt_material {
                normal_map: 1,
                ..WHITE
            },
            cmlt_material {
                bump_map: 1,
                ..WHITE
            },
        ] {
            expect(
                cmlt_scene_add_material(s, &bad, &mut id),
                CMLT_ERROR_INVALID_ARGUMENT,
                f,
            );
            assert!(last_error().contains("grid"), "{}", last_error());
        }
        let opacity = cmlt_material {
            opacity_texture: 2,
            ..WHITE
        };
        expect(cmlt_scene_add_material(s, &opacity, &mut id), CMLT_OK, f);
        expect(cmlt_scene_commit(s), CMLT_OK, "commit");
        expect(
            cmlt_scene_add_grid_texture(s, &good, &mut id),
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_scene_add_grid_texture",
        );
        cmlt_scene_release(s);
    }
}

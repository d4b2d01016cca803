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

//! Scenes: argument checks of building and committing, mesh updates
//! between frames, and meshes too far from the origin.

use super::*;

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
    }
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

//! Lights besides emitting meshes: point, spot, directional and constant
//! lights checked, added and rendered; environment maps checked, copied
//! and rendered.

use super::*;

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

/// `cmlt_scene_light_count` says when nothing emits: the floor and light
/// has one light, the light squashed to zero area by `update_mesh` none
/// (its frames are black, and OK) and again one when it is restored; a
/// scene of the floor alone none (the query needs a committed scene).
#[test]
fn the_light_count_tells_a_scene_that_cannot_be_lit() {
    let count = |s: *const cmlt_scene| {
        let mut n = 99;
        // SAFETY: valid pointers.
        unsafe { expect(cmlt_scene_light_count(s, &mut n), CMLT_OK, "light_count") };
        n
    };
    let s = scene(None);
    assert_eq!(count(s), 1);
    // The light quad's four corners moved onto one point: no area.
    let mut squashed = POSITIONS;
    for v in squashed[12..].chunks_mut(3) {
        v.copy_from_slice(&[0.0, 1.0, 0.0]);
    }
    // SAFETY: valid pointers; 8 packed positions.
    unsafe {
        expect(
            cmlt_scene_update_mesh(s, 1, squashed.as_ptr(), 8, 0, null(), 0),
            CMLT_OK,
            "update_mesh",
        );
    }
    assert_eq!(count(s), 0);
    // SAFETY: as above.
    unsafe {
        expect(
            cmlt_scene_update_mesh(s, 1, POSITIONS.as_ptr(), 8, 0, null(), 0),
            CMLT_OK,
            "update_mesh",
        );
    }
    assert_eq!(count(s), 1);
    let mut dark = null_mut();
    let mut id = 0;
    // SAFETY: valid pointers; the second scene is uncommitted at first.
    unsafe {
        expect(cmlt_scene_new(&mut dark), CMLT_OK, "scene_new");
        expect(
            cmlt_scene_add_material(dark, &WHITE, &mut id),
            CMLT_OK,
            "add_material",
        );
        expect(
            cmlt_scene_add_mesh(dark, &mesh(&FLOOR, id, 0.0), null_mut()),
            CMLT_OK,
            "add_mesh",
        );
        let mut n = 0;
        expect(
            cmlt_scene_light_count(dark, &mut n),
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_scene_light_count",
        );
        expect(
            cmlt_scene_light_count(dark, null_mut()),
            CMLT_ERROR_NULL_POINTER,
            "cmlt_scene_light_count",
        );
        expect(cmlt_scene_commit(dark), CMLT_OK, "commit");
    }
    assert_eq!(count(dark), 0);
    // SAFETY: handles from this test.
    unsafe {
        cmlt_scene_release(s);
        cmlt_scene_release(dark);
    }
}

/// A sun disc (`CMLT_LIGHT_SUN`): checked (radius outside (0, 90)
/// degrees, a zero direction, negative radiance), seen as an environment,
/// and lighting the floor as a directional light of the disc's irradiance
/// L · Ω does (at 0.27° the cosine varies over the disc by 1e-5, so the
/// two images have the same mean); a disc of the wrong solid angle (the
/// radiance meant for a disc twice as wide) is off by 4×, far outside the
/// 3 % tolerance.
#[test]
fn sun_discs_are_checked_and_light_like_their_irradiance() {
    let alpha = 0.2679f32;
    let omega = 2.0 * std::f64::consts::PI * (1.0 - (alpha as f64).to_radians().cos());
    let e = 0.8f64;
    let sun = cmlt_light {
        type_: CMLT_LIGHT_SUN,
        color: [(e / omega) as f32; 3],
        position: [0.0; 3],
        direction: [0.3, -1.0, 0.2],
        cutoff_angle: alpha,
        beam_width: 0.0,
        texels: null(),
        width: 0,
        height: 0,
        stride: 0,
        to_world: [0.0; 9],
    };
    let directional = cmlt_light {
        type_: CMLT_LIGHT_DIRECTIONAL,
        color: [e as f32; 3],
        cutoff_angle: 0.0,
        ..sun
    };
    let f = "cmlt_scene_add_light";
    let with = |l: &cmlt_light| {
        let s = floor_and_light();
        // SAFETY: valid pointers.
        unsafe {
            expect(cmlt_scene_add_light(s, l, null_mut()), CMLT_OK, f);
            expect(cmlt_scene_commit(s), CMLT_OK, "commit");
        }
        s
    };
    let s = floor_and_light();
    // SAFETY: valid pointers and deliberately bad values.
    unsafe {
        for bad in [
            cmlt_light {
                cutoff_angle: 0.0,
                ..sun
            },
            cmlt_light {
                cutoff_angle: 90.0,
                ..sun
            },
            cmlt_light {
                direction: [0.0; 3],
                ..sun
            },
            cmlt_light {
                color: [1.0, -1.0, 1.0],
                ..sun
            },
        ] {
            expect(
                cmlt_scene_add_light(s, &bad, null_mut()),
                CMLT_ERROR_INVALID_ARGUMENT,
                f,
            );
        }
        cmlt_scene_release(s);
    }
    let (s_sun, s_dir, s_none) = (with(&sun), with(&directional), scene(None));
    let mut effects = 0;
    // SAFETY: a committed scene and a valid out pointer.
    unsafe {
        expect(
            cmlt_scene_get_effects(s_sun, &mut effects, null_mut()),
            CMLT_OK,
            "effects",
        );
    }
    assert_ne!(effects & CMLT_EFFECT_ENVIRONMENT, 0);
    let (m_sun, m_dir, m_none) = (pt_mean(s_sun, 64), pt_mean(s_dir, 64), pt_mean(s_none, 64));
    let ratio = (m_sun - m_none) / (m_dir - m_none);
    eprintln!("sun {m_sun} directional {m_dir} neither {m_none}: ratio {ratio}");
    assert!(m_dir > 1.2 * m_none, "{m_dir} vs {m_none}");
    assert!((ratio - 1.0).abs() < 0.03, "{ratio}");
    let wide = with(&cmlt_light {
        color: [(e / (4.0 * omega)) as f32; 3],
        ..sun
    });
    let ratio_wide = (pt_mean(wide, 64) - m_none) / (m_dir - m_none);
    assert!((ratio_wide - 0.25).abs() < 0.03, "{ratio_wide}");
    // SAFETY: scenes we created.
    unsafe {
        for s in [s_sun, s_dir, s_none, wide] {
            cmlt_scene_release(s);
        }
    }
}

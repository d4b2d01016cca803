//! Materials: each kind's parameters checked, passed on and rendered;
//! colours and roughness under the core's one validation rule.

use super::*;

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
    let m = cmlt_capi::test_hooks::material_from_c(&p, &[]).expect("valid principled");
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
    let MaterialKind::Principled(g) = cmlt_capi::test_hooks::material_from_c(&glass, &[])
        .unwrap()
        .kind
    else {
        panic!("not principled");
    };
    assert_eq!((g.eta, g.spec_trans), (1.45, c(1.0)));
    let mut textured = p;
    textured.principled_textures[CMLT_PRINCIPLED_METALLIC as usize] = 1;
    let MaterialKind::Principled(t) = cmlt_capi::test_hooks::material_from_c(
        &textured,
        &[Texture::Bitmap {
            id: cmlt_core::scene::BitmapId(0),
            to_uv: cmlt_core::math::Affine2::IDENTITY,
        }],
    )
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

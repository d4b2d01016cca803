//! Participating media through the C API: media checked and added, ids
//! checked where they are passed, a null boundary and the camera's medium
//! attached, and the transmittance of an absorbing slab rendered as
//! Beer–Lambert says (with the sides swapped and without the medium as the
//! controls).

use super::*;

/// Absorbs only, σ_t = (0, 1.5, 3) per unit length: red passes unchanged,
/// so the red channel is the slab's own control.
const ABSORBER: cmlt_medium = cmlt_medium {
    sigma_t: [0.0, 1.5, 3.0],
    albedo: [0.0, 0.0, 0.0],
    phase: CMLT_PHASE_ISOTROPIC,
    g: 0.0,
};

#[test]
fn media_are_checked_added_and_attached() {
    let s = floor_and_light();
    let f = "cmlt_scene_add_medium";
    // SAFETY: valid pointers, or deliberately NULL / bad values.
    unsafe {
        expect(
            cmlt_scene_add_medium(s, null(), null_mut()),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(
            cmlt_scene_add_medium(null_mut(), &ABSORBER, null_mut()),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        let bad = [
            cmlt_medium {
                sigma_t: [-1.0, 0.0, 0.0],
                ..ABSORBER
            },
            cmlt_medium {
                sigma_t: [f32::NAN, 0.0, 0.0],
                ..ABSORBER
            },
            cmlt_medium {
                sigma_t: [f32::INFINITY, 0.0, 0.0],
                ..ABSORBER
            },
            cmlt_medium {
                albedo: [0.5, 1.5, 0.5],
                ..ABSORBER
            },
            cmlt_medium {
                phase: CMLT_PHASE_HG,
                g: 1.0,
                ..ABSORBER
            },
            cmlt_medium {
                phase: CMLT_PHASE_HG,
                g: f32::NAN,
                ..ABSORBER
            },
            cmlt_medium {
                g: f32::NAN,
                ..ABSORBER
            },
            cmlt_medium {
                phase: 7,
                ..ABSORBER
            },
        ];
        for m in bad {
            expect(
                cmlt_scene_add_medium(s, &m, null_mut()),
                CMLT_ERROR_INVALID_ARGUMENT,
                f,
            );
        }
        // The refusals left the scene as it was: the first medium is 0.
        let mut id = 9;
        expect(cmlt_scene_add_medium(s, &ABSORBER, &mut id), CMLT_OK, f);
        assert_eq!(id, 0);
        let fog = cmlt_medium {
            albedo: [0.9; 3],
            phase: CMLT_PHASE_HG,
            g: 0.6,
            ..ABSORBER
        };
        expect(cmlt_scene_add_medium(s, &fog, &mut id), CMLT_OK, f);
        assert_eq!(id, 1);

        let f = "cmlt_scene_set_mesh_media";
        // The floor and the light are meshes 0 and 1; media 0 and 1 exist.
        for (mesh, interior, exterior) in [(2, 0, 0), (0, 2, CMLT_MEDIUM_NONE), (1, 0, 7)] {
            expect(
                cmlt_scene_set_mesh_media(s, mesh, interior, exterior),
                CMLT_ERROR_INVALID_ARGUMENT,
                f,
            );
        }
        expect(
            cmlt_scene_set_mesh_media(null_mut(), 0, 0, 0),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(
            cmlt_scene_set_mesh_media(s, 0, 1, CMLT_MEDIUM_NONE),
            CMLT_OK,
            f,
        );
        let f = "cmlt_scene_set_camera_medium";
        expect(
            cmlt_scene_set_camera_medium(s, 2),
            CMLT_ERROR_INVALID_ARGUMENT,
            f,
        );
        expect(cmlt_scene_set_camera_medium(s, 0), CMLT_OK, f);
        expect(
            cmlt_scene_set_camera_medium(s, CMLT_MEDIUM_NONE),
            CMLT_OK,
            f,
        );

        expect(cmlt_scene_commit(s), CMLT_OK, "commit");
        let mut effects = 0;
        expect(
            cmlt_scene_get_effects(s, &mut effects, null_mut()),
            CMLT_OK,
            "effects",
        );
        assert_ne!(effects & CMLT_EFFECT_MEDIA, 0);
        // A committed scene takes no more media or attachments.
        expect(
            cmlt_scene_add_medium(s, &ABSORBER, null_mut()),
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_scene_add_medium",
        );
        expect(
            cmlt_scene_set_mesh_media(s, 0, 0, 0),
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_scene_set_mesh_media",
        );
        expect(
            cmlt_scene_set_camera_medium(s, 0),
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_scene_set_camera_medium",
        );
        cmlt_scene_release(s);
    }
    // Media added but attached nowhere call for nothing: the scene has no
    // media effect (its rays never enter one).
    let plain = floor_and_light();
    // SAFETY: a valid, uncommitted scene.
    unsafe {
        expect(
            cmlt_scene_add_medium(plain, &ABSORBER, null_mut()),
            CMLT_OK,
            "add_medium",
        );
        expect(cmlt_scene_commit(plain), CMLT_OK, "commit");
        let mut effects = 0;
        expect(
            cmlt_scene_get_effects(plain, &mut effects, null_mut()),
            CMLT_OK,
            "effects",
        );
        assert_eq!(effects & CMLT_EFFECT_MEDIA, 0);
        cmlt_scene_release(plain);
    }
}

/// A closed box from `lo` to `hi` wound counter-clockwise seen from
/// outside (outward geometric normals: its inside is the interior side).
fn box_mesh(lo: [f32; 3], hi: [f32; 3]) -> (Vec<f32>, Vec<u32>) {
    let corner = |i: u32| {
        [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ]
    };
    let positions: Vec<f32> = (0..8).flat_map(corner).collect();
    let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let quads = [
        [0, 1, 3, 2],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 3, 7, 5],
    ];
    let mut indices = Vec::new();
    for q in quads {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            let [a, b, c] = t.map(corner);
            let e1 = [0, 1, 2].map(|k| b[k] - a[k]);
            let e2 = [0, 1, 2].map(|k| c[k] - a[k]);
            let n = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            let out: f32 = (0..3).map(|k| n[k] * (a[k] - centre[k])).sum();
            indices.extend(if out > 0.0 { t } else { [t[0], t[2], t[1]] });
        }
    }
    (positions, indices)
}

/// Which side of the slab's null box the absorber is on.
#[derive(Clone, Copy)]
enum Slab {
    Inside,
    Outside,
    Absent,
}

/// The mean RGB of a 16 × 12 PT image looking straight up, from (0, 0.1, 0)
/// through a null box filling 0.3 < y < 0.7, at the light quad (black,
/// emitting 5) at y = 1 that fills the view: every pixel is the light's
/// radiance times the transmittance along its ray.
fn slab_mean(slab: Slab) -> [f64; 3] {
    // 256 camera samples per pixel.
    slab_mean_with(slab, &config(CMLT_ESTIMATOR_PT, 1), 16 * 12 * 256)
}

/// [`slab_mean`] rendered with renderer configuration `c` and `budget`
/// work units.
fn slab_mean_with(slab: Slab, c: &cmlt_renderer_config, budget: u64) -> [f64; 3] {
    let black = cmlt_material {
        color: [0.0; 3],
        ..WHITE
    };
    let null_material = cmlt_material {
        type_: CMLT_MATERIAL_NULL,
        ..WHITE
    };
    let (box_positions, box_indices) = box_mesh([-2.0, 0.3, -2.0], [2.0, 0.7, 2.0]);
    let mut s = null_mut();
    let (mut black_id, mut null_id, mut medium) = (0, 0, 0);
    // SAFETY: valid pointers; the arrays outlive the calls that copy them.
    unsafe {
        expect(cmlt_scene_new(&mut s), CMLT_OK, "scene_new");
        expect(
            cmlt_scene_add_material(s, &black, &mut black_id),
            CMLT_OK,
            "add_material",
        );
        expect(
            cmlt_scene_add_material(s, &null_material, &mut null_id),
            CMLT_OK,
            "add_material (null)",
        );
        expect(
            cmlt_scene_add_mesh(s, &mesh(&LIGHT, black_id, 5.0), null_mut()),
            CMLT_OK,
            "add_mesh (light)",
        );
        let slab_box = cmlt_mesh {
            positions: box_positions.as_ptr(),
            vertex_count: 8,
            indices: box_indices.as_ptr(),
            triangle_count: 12,
            ..mesh(&[], null_id, 0.0)
        };
        expect(
            cmlt_scene_add_mesh(s, &slab_box, null_mut()),
            CMLT_OK,
            "add_mesh (box)",
        );
        expect(
            cmlt_scene_add_medium(s, &ABSORBER, &mut medium),
            CMLT_OK,
            "add_medium",
        );
        let (interior, exterior) = match slab {
            Slab::Inside => (medium, CMLT_MEDIUM_NONE),
            Slab::Outside => (CMLT_MEDIUM_NONE, medium),
            Slab::Absent => (CMLT_MEDIUM_NONE, CMLT_MEDIUM_NONE),
        };
        expect(
            cmlt_scene_set_mesh_media(s, 1, interior, exterior),
            CMLT_OK,
            "set_mesh_media",
        );
        expect(cmlt_scene_commit(s), CMLT_OK, "commit");
    }
    let up = cmlt_camera {
        position: [0.0, 0.1, 0.0],
        target: [0.0, 1.0, 0.0],
        up: [0.0, 0.0, 1.0],
        // Rays within 6.3° of the axis: 1/cos θ ≤ 1.006.
        fov_degrees: 10.0,
        aperture_radius: 0.0,
        focus_distance: 1.0,
    };
    let mut r = null_mut();
    // SAFETY: valid pointers.
    unsafe {
        expect(
            cmlt_renderer_new(s, c, &up, &mut r),
            CMLT_OK,
            "renderer_new",
        );
    }
    prepare_render_stats(r, budget);
    let px = image(r);
    // SAFETY: handles we created.
    unsafe {
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
    assert!(px.iter().all(|v| v.is_finite()));
    let n = (px.len() / 3) as f64;
    [0, 1, 2].map(|c| px.iter().skip(c).step_by(3).map(|&v| v as f64).sum::<f64>() / n)
}

#[test]
fn an_absorbing_slab_transmits_as_beer_lambert_says() {
    // Along the axis a ray crosses 0.4 of the slab inside the box and 0.3
    // between the box and the light: e^{−σ_t d} per channel. A PT sample
    // is 5 · e^{−σ_t,c d} / p̄ when its free-flight draws pass the slab (p̄
    // their probability averaged over the channels, the spectral MIS) and
    // 0 when one stops in it (albedo 0), so with 192 × 256 samples the
    // means are within about 0.5 % (one standard error) of 5 · e^{−σ_t d};
    // the rays' tilt adds at most 0.6 % to d.
    let expect_mean = |d: f64| ABSORBER.sigma_t.map(|s| 5.0 * (-(s as f64) * d).exp());
    for (slab, d) in [
        (Slab::Inside, 0.4),
        (Slab::Outside, 0.3),
        (Slab::Absent, 0.0),
    ] {
        let got = slab_mean(slab);
        let want = expect_mean(d);
        for c in 0..3 {
            assert!(
                (got[c] / want[c] - 1.0).abs() < 0.025,
                "slab {d}: channel {c} mean {} against e^(-σ_t d) · 5 = {}",
                got[c],
                want[c]
            );
        }
    }
}

/// MLT over the path-space level 1 renders media through the C API: the
/// absorbing slab at Beer–Lambert's value (its image's mean is the
/// bootstrap's b, whose paths cross the null box and the absorber), as PT
/// does; it refused such a scene when it prepared before its mutations
/// knew media. Negative control: without the absorber the same mean is
/// the light's 5, far from e^{−σ_t d} · 5 in the absorbed channels.
#[test]
fn path_space_mlt_renders_media() {
    let mut c = config(CMLT_ESTIMATOR_MLT, 1);
    c.level1 = CMLT_LEVEL1_PATH_SPACE;
    // As `an_absorbing_slab_transmits_as_beer_lambert_says` has it.
    let want = ABSORBER.sigma_t.map(|s| 5.0 * (-(s as f64) * 0.4).exp());
    let got = slab_mean_with(Slab::Inside, &c, 16 * 12 * 64);
    let vacuum = slab_mean_with(Slab::Absent, &c, 16 * 12 * 16);
    for ch in 0..3 {
        assert!(
            (got[ch] / want[ch] - 1.0).abs() < 0.03,
            "channel {ch}: mean {} against e^(-σ_t d) · 5 = {}",
            got[ch],
            want[ch]
        );
    }
    // Red has no absorption (σ_t = 0): green and blue tell.
    assert!((1..3).all(|ch| (vacuum[ch] / want[ch] - 1.0).abs() > 0.1));
}

//! Renderers: argument and call-order checks, fields an estimator does
//! not read, the bootstrap on the host's threads, and the default
//! configuration.

use super::*;

use cmlt_core::renderer::{EstimatorKind, RendererConfig};

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
            (
                "direct allocation 0",
                cmlt_renderer_config {
                    direct_allocation: 0.0,
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
                "path space, bidirectional weight 0",
                cmlt_renderer_config {
                    path_mutations: [0.0, 1.0, 1.0, 1.0, 1.0],
                    ..good
                },
            ),
            (
                "path space, perturbation σ -1",
                cmlt_renderer_config {
                    perturbation_sigma: -1.0,
                    ..good
                },
            ),
            (
                "path space, NaN perturbation caustic scale",
                cmlt_renderer_config {
                    perturbation_caustic_scale: f32::NAN,
                    ..good
                },
            ),
            (
                "path space, zero perturbation caustic scale",
                cmlt_renderer_config {
                    perturbation_caustic_scale: 0.0,
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
            (
                "unknown level 1",
                cmlt_renderer_config { level1: 7, ..good },
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
            cmlt_renderer_render(null_mut(), 0, 100, null_mut()),
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

/// A field the estimator does not read is refused unless it keeps
/// `cmlt_renderer_config_default`'s value, by creation and by the memory
/// query, with a message naming the field; `m` no longer turns MLT into
/// CMLT. Every field but `estimator` has one default for all estimators.
#[test]
fn fields_the_estimator_does_not_read_are_refused() {
    let s = scene(None);
    type Tweak = fn(&mut cmlt_renderer_config);
    let cases: [(u32, &str, Tweak); 11] = [
        (CMLT_ESTIMATOR_MLT, "m", |c| c.m = 4),
        (CMLT_ESTIMATOR_MLT, "k", |c| c.k = 2),
        (CMLT_ESTIMATOR_MLT, "lens_sigma", |c| {
            c.lens_sigma = f32::NAN
        }),
        (CMLT_ESTIMATOR_MLT, "splatting", |c| {
            c.splatting = CMLT_SPLATTING_EXPECTED_VALUE
        }),
        (CMLT_ESTIMATOR_PT, "chains", |c| c.chains = 8),
        (CMLT_ESTIMATOR_BDPT, "normalisation_passes", |c| {
            c.normalisation_passes = 3
        }),
        (CMLT_ESTIMATOR_PT, "keep_chains", |c| c.keep_chains = 1),
        (CMLT_ESTIMATOR_BDPT, "b_window", |c| c.b_window = 2),
        (CMLT_ESTIMATOR_BDPT, "large_step_window", |c| {
            c.large_step_window = 8
        }),
        (CMLT_ESTIMATOR_PT, "path_mutations", |c| {
            c.path_mutations[2] = 0.0
        }),
        (CMLT_ESTIMATOR_BDPT, "perturbation_caustic_scale", |c| {
            c.perturbation_caustic_scale = 2.0
        }),
    ];
    for (estimator, field, tweak) in cases {
        let mut c = config(estimator, 1);
        tweak(&mut c);
        let (mut bytes, mut r) = (7usize, null_mut());
        // SAFETY: valid pointers.
        unsafe {
            expect(
                cmlt_renderer_memory_requirements(s, &c, &mut bytes, null_mut()),
                CMLT_ERROR_INVALID_ARGUMENT,
                "cmlt_renderer_memory_requirements",
            );
            expect(
                cmlt_renderer_new(s, &c, &CAMERA, &mut r),
                CMLT_ERROR_INVALID_ARGUMENT,
                "cmlt_renderer_new",
            );
        }
        let e = last_error();
        assert!(e.contains(&format!("{field} is read by")), "{e}");
        assert!(bytes == 7 && r.is_null(), "{field}");
    }
    // The fields every estimator reads may change for any of them.
    for estimator in [CMLT_ESTIMATOR_PT, CMLT_ESTIMATOR_MLT] {
        let mut c = config(estimator, 1);
        (c.seed, c.max_depth, c.depth_cap, c.fixed_sequence) = (9, 3, 7, 1);
        let r = renderer(s, &c);
        // SAFETY: a renderer from this test.
        unsafe { cmlt_renderer_release(r) };
    }
    // SAFETY: handle from this test.
    unsafe { cmlt_scene_release(s) };
}

/// The bootstrap spread over the host's threads (`prepare_begin`, one
/// `prepare_worker` per worker, `prepare_finish`) gives `prepare`'s image
/// (the same three steps on one thread) bit for bit; a missing share is
/// refused and leaves the renderer unprepared; `render_per_pixel` renders
/// each worker's share of a per-pixel budget.
#[test]
fn bootstrap_on_the_hosts_threads_equals_prepare() {
    let s = scene(None);
    for estimator in [CMLT_ESTIMATOR_PT, CMLT_ESTIMATOR_MLT, CMLT_ESTIMATOR_CMLT] {
        let mut c = config(estimator, 3);
        if estimator != CMLT_ESTIMATOR_PT {
            // 4 passes asked for, 20 from the small-image floor: split
            // 7/7/6 over the three workers.
            c.normalisation_passes = 4;
            c.normalisation_min_samples = 20 * 16 * 12;
        }
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
                        let r = addr as *mut cmlt_renderer;
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

/// `cmlt_renderer_config_default` is the core's default configuration of
/// each estimator (CMLT's measured defaults included), so a C host that
/// starts from it renders what `cmlt render --method …` does; every field
/// but `estimator` is the same for all estimators.
#[test]
fn config_default_is_the_cores_default() {
    let s = scene(None);
    // SAFETY: a committed scene from this test.
    let settings = unsafe { cmlt_capi::test_hooks::scene_settings(s) }.unwrap();
    let mut first = None;
    for kind in EstimatorKind::ALL {
        let estimator = kind as u32;
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
        assert_eq!(c.estimator, estimator);
        (c.width, c.height) = (16, 12);
        // SAFETY: as above.
        let cfg = unsafe { cmlt_capi::test_hooks::core_config(&c, s) }.unwrap();
        let expected = RendererConfig {
            settings,
            ..RendererConfig::for_estimator(kind)
        };
        assert_eq!(cfg, expected, "{kind:?}");
        c.estimator = 0;
        let text = format!("{c:?}");
        assert_eq!(first.get_or_insert_with(|| text.clone()), &text, "{kind:?}");
    }
    // SAFETY: handle from this test.
    unsafe { cmlt_scene_release(s) };
}

/// The frame loop's pieces through C: `cmlt_renderer_prepare_worker_while`
/// stops when the host's clock says so and a first frame is not ready until
/// every share is complete; with `keep_chains` a later frame renders at
/// once while its bootstrap waits. `cmlt_renderer_set_accumulation` takes
/// every mode for PT and MLT and refuses an unknown mode and a decay out
/// of (0, 1).
#[test]
fn set_up_in_pieces_and_accumulation_modes() {
    unsafe extern "C" fn never(_user: *mut c_void, _done: u64) -> u32 {
        0
    }
    let s = scene(None);
    let mut c = config(CMLT_ESTIMATOR_MLT, 2);
    c.keep_chains = 1;
    let r = renderer(s, &c);
    // SAFETY: valid handles and out pointers; workers in range.
    unsafe {
        let mut pending = 0;
        expect(
            cmlt_renderer_prepare_begin(r, &mut pending),
            CMLT_OK,
            "begin",
        );
        assert_eq!(pending, 1);
        expect(
            cmlt_renderer_prepare_worker_while(r, 0, None, null_mut(), null_mut()),
            CMLT_ERROR_NULL_POINTER,
            "cmlt_renderer_prepare_worker_while",
        );
        let mut calls = 0;
        loop {
            calls += 1;
            let mut finished = [7u32; 2];
            for (w, f) in finished.iter_mut().enumerate() {
                expect(
                    cmlt_renderer_prepare_worker_while(r, w as u32, Some(never), null_mut(), f),
                    CMLT_OK,
                    "prepare_worker_while",
                );
            }
            assert!(finished.iter().all(|&f| f <= 1));
            let status = cmlt_renderer_prepare_finish(r);
            if status == CMLT_OK {
                assert_eq!(finished, [1, 1]);
                break;
            }
            expect(
                status,
                CMLT_ERROR_INVALID_OPERATION,
                "cmlt_renderer_prepare_finish",
            );
            expect(
                cmlt_renderer_render(r, 0, 1, null_mut()),
                CMLT_ERROR_INVALID_OPERATION,
                "cmlt_renderer_render",
            );
        }
        assert!(calls > 2, "{calls} calls");
        let mut cam = cmlt_camera {
            position: [0.0, 1.0, -3.0],
            target: [0.0, 0.5, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_degrees: 50.0,
            aperture_radius: 0.0,
            focus_distance: 1.0,
        };
        for frame in 1..4 {
            cam.position[0] = 0.05 * frame as f32;
            expect(cmlt_renderer_set_camera(r, &cam), CMLT_OK, "set_camera");
            expect(
                cmlt_renderer_prepare_begin(r, &mut pending),
                CMLT_OK,
                "begin",
            );
            assert_eq!(pending, 1);
            // No set-up time at all: the kept chains render anyway.
            for w in 0..2 {
                let mut f = 7;
                expect(
                    cmlt_renderer_prepare_worker_while(r, w, Some(never), null_mut(), &mut f),
                    CMLT_OK,
                    "prepare_worker_while",
                );
                assert_eq!(f, 0);
            }
            expect(cmlt_renderer_prepare_finish(r), CMLT_OK, "prepare_finish");
            for w in 0..2 {
                expect(
                    cmlt_renderer_render(r, w, 64, null_mut()),
                    CMLT_OK,
                    "render",
                );
            }
            assert!(image(r).iter().any(|&v| v > 0.0));
        }
        // MLT keeps and decays its frames' images as PT does.
        expect(
            cmlt_renderer_set_accumulation(r, CMLT_ACCUMULATION_DECAY, 1.5),
            CMLT_ERROR_INVALID_ARGUMENT,
            "cmlt_renderer_set_accumulation",
        );
        for (mode, decay) in [
            (CMLT_ACCUMULATION_KEEP, 0.0),
            (CMLT_ACCUMULATION_DECAY, 0.5),
        ] {
            expect(
                cmlt_renderer_set_accumulation(r, mode, decay),
                CMLT_OK,
                "set_accumulation",
            );
            expect(cmlt_renderer_set_camera(r, &cam), CMLT_OK, "set_camera");
            expect(cmlt_renderer_prepare(r), CMLT_OK, "prepare");
            // Before this frame renders, its workers hold only the kept
            // frames; once it has, the image is theirs and its own.
            for w in 0..2 {
                expect(
                    cmlt_renderer_render(r, w, 64, null_mut()),
                    CMLT_OK,
                    "render",
                );
            }
            assert!(image(r).iter().all(|&v| v.is_finite()));
            assert!(image(r).iter().any(|&v| v > 0.0));
        }
        cmlt_renderer_release(r);

        let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 1));
        for (mode, decay, want) in [
            (CMLT_ACCUMULATION_DECAY, 0.5, CMLT_OK),
            (CMLT_ACCUMULATION_KEEP, f32::NAN, CMLT_OK),
            (CMLT_ACCUMULATION_DECAY, 1.5, CMLT_ERROR_INVALID_ARGUMENT),
            (
                CMLT_ACCUMULATION_DECAY,
                f32::NAN,
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (7, 0.5, CMLT_ERROR_INVALID_ARGUMENT),
        ] {
            expect(
                cmlt_renderer_set_accumulation(r, mode, decay),
                want,
                "cmlt_renderer_set_accumulation",
            );
        }
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
}

/// `cmlt_renderer_set_pixel_block` through C: a size above 64 and a NULL
/// renderer are refused and change nothing; at size 4 one pass fills
/// every 4 × 4 block of the 16 × 12 image with one value; the fitted size
/// is taken.
#[test]
fn pixel_block_sizes_through_c() {
    let s = scene(None);
    let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 1));
    // SAFETY: valid handles, or NULL on purpose.
    unsafe {
        let f = "cmlt_renderer_set_pixel_block";
        expect(
            cmlt_renderer_set_pixel_block(null_mut(), 4),
            CMLT_ERROR_NULL_POINTER,
            f,
        );
        expect(
            cmlt_renderer_set_pixel_block(r, 65),
            CMLT_ERROR_INVALID_ARGUMENT,
            f,
        );
        expect(cmlt_renderer_set_pixel_block(r, 4), CMLT_OK, f);
        expect(cmlt_renderer_prepare(r), CMLT_OK, "prepare");
        expect(cmlt_renderer_render(r, 0, 1, null_mut()), CMLT_OK, "render");
        let img = image(r);
        for by in 0..3 {
            for bx in 0..4 {
                let corner = &img[(by * 4 * 16 + bx * 4) * 3..][..3];
                for y in by * 4..by * 4 + 4 {
                    for x in bx * 4..bx * 4 + 4 {
                        assert_eq!(&img[(y * 16 + x) * 3..][..3], corner, "({x}, {y})");
                    }
                }
            }
        }
        assert!(img.iter().any(|&v| v > 0.0));
        expect(
            cmlt_renderer_set_pixel_block(r, CMLT_PIXEL_BLOCK_FIT),
            CMLT_OK,
            f,
        );
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
}

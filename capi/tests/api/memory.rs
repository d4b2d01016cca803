//! The renderer's memory bound: huge or invalid configurations refused
//! before anything is built, and the bound covers what creation takes.

use super::*;

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
            (c.max_depth, c.width, c.height) = (depth, w, h);
            // Only the fields the estimator reads.
            if estimator == CMLT_ESTIMATOR_MLT || estimator == CMLT_ESTIMATOR_CMLT {
                c.chains = chains;
                (c.bootstrap_samples, c.normalisation_passes) = (10 * chains, chains / 4 + 1);
            }
            if estimator == CMLT_ESTIMATOR_CMLT {
                c.k = k;
            }
            let mut bytes = 0;
            // SAFETY: valid pointers.
            unsafe {
                expect(
                    cmlt_renderer_memory_requirements(s, &c, &mut bytes, null_mut()),
                    CMLT_OK,
                    "memory_requirements",
                )
            };
            // SAFETY: a committed scene from this test.
            let cfg = unsafe { cmlt_capi::test_hooks::core_config(&c, s) }.unwrap();
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

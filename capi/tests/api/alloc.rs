//! The allocator hooks: they see every allocation, none inside a frame,
//! and the memory query is exact.

use std::alloc::GlobalAlloc;

use super::*;

thread_local! {
    /// Allocations made through the hooks by this thread while counting.
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
    static BYTES: Cell<usize> = const { Cell::new(0) };
}

unsafe extern "C" fn counting_alloc(_: *mut c_void, size: usize, align: usize) -> *mut c_void {
    if COUNTING.with(Cell::get) {
        ALLOCS.with(|a| a.set(a.get() + 1));
        BYTES.with(|b| b.set(b.get() + size));
    }
    // SAFETY: valid layout (the library passes a power-of-two alignment).
    unsafe { std::alloc::System.alloc(std::alloc::Layout::from_size_align_unchecked(size, align)) }
        .cast()
}

unsafe extern "C" fn counting_free(_: *mut c_void, ptr: *mut c_void, size: usize, align: usize) {
    if COUNTING.with(Cell::get) {
        BYTES.with(|b| b.set(b.get().wrapping_sub(size)));
    }
    // SAFETY: `ptr` came from `counting_alloc` with this layout.
    unsafe {
        std::alloc::System.dealloc(
            ptr.cast(),
            std::alloc::Layout::from_size_align_unchecked(size, align),
        )
    }
}

/// Allocations (count, net bytes) `f` makes on this thread through the
/// hooks.
fn counted<R>(f: impl FnOnce() -> R) -> (R, u64, usize) {
    ALLOCS.with(|a| a.set(0));
    BYTES.with(|b| b.set(0));
    COUNTING.with(|c| c.set(true));
    let r = f();
    COUNTING.with(|c| c.set(false));
    (r, ALLOCS.with(Cell::get), BYTES.with(Cell::get))
}

/// Held by each test that installs hooks: the hooks are the process's, and
/// the tests of this binary run in parallel.
static HOOKS: std::sync::Mutex<()> = std::sync::Mutex::new(());

#[test]
fn frames_allocate_nothing_through_the_hooks_and_the_query_is_exact() {
    let _hooks = HOOKS.lock().unwrap_or_else(|e| e.into_inner());
    let hooks = cmlt_allocator {
        user: null_mut(),
        alloc: Some(counting_alloc),
        free: Some(counting_free),
    };
    // SAFETY: valid allocator with process-lifetime callbacks.
    unsafe {
        expect(
            cmlt_set_allocator(&cmlt_allocator {
                alloc: None,
                ..hooks
            }),
            CMLT_ERROR_NULL_POINTER,
            "cmlt_set_allocator",
        );
        expect(cmlt_set_allocator(&hooks), CMLT_OK, "set_allocator");
    }
    let s = scene(None);
    // Every estimator, and MLT and CMLT over the path-space level 1 too
    // (its mutations, perturbations included, keep their scratch).
    for (estimator, level1) in [
        (CMLT_ESTIMATOR_PT, CMLT_LEVEL1_PRIMARY_SAMPLE),
        (CMLT_ESTIMATOR_BDPT, CMLT_LEVEL1_PRIMARY_SAMPLE),
        (CMLT_ESTIMATOR_MLT, CMLT_LEVEL1_PRIMARY_SAMPLE),
        (CMLT_ESTIMATOR_CMLT, CMLT_LEVEL1_PRIMARY_SAMPLE),
        (CMLT_ESTIMATOR_MLT, CMLT_LEVEL1_PATH_SPACE),
        (CMLT_ESTIMATOR_CMLT, CMLT_LEVEL1_PATH_SPACE),
    ] {
        let mut c = config(estimator, 2);
        c.level1 = level1;
        let (mut bytes, mut align) = (0usize, 0usize);
        // SAFETY: valid pointers.
        unsafe {
            expect(
                cmlt_renderer_memory_requirements(s, &c, &mut bytes, &mut align),
                CMLT_OK,
                "memory_requirements",
            )
        };
        let (r, n, created) = counted(|| renderer(s, &c));
        assert!(n > 0, "creation went around the hooks");
        // The query builds the same handle (renderer, workers, accumulator)
        // and measures it: byte for byte what creation takes.
        assert_eq!(
            created, bytes,
            "estimator {estimator}: query {bytes} B, creation {created} B"
        );
        assert!(align >= 8 && align.is_power_of_two());
        let mut px = vec![0.0f32; 16 * 12 * 3];
        let mut half = vec![0u16; 16 * 12 * 4];
        let (mut depth, mut normal) = (vec![0.0f32; 16 * 12], vec![0u16; 16 * 12 * 3]);
        let layer = |data: *mut c_void, buffer_size, format| cmlt_aov_layer {
            data,
            row_stride: 0,
            buffer_size,
            format,
        };
        let aov = cmlt_aov_buffers {
            albedo: layer(null_mut(), 0, CMLT_AOV_F32),
            normal: layer(normal.as_mut_ptr().cast(), normal.len() * 2, CMLT_AOV_F16),
            depth: layer(depth.as_mut_ptr().cast(), depth.len() * 4, CMLT_AOV_F32),
            motion: layer(null_mut(), 0, CMLT_AOV_F32),
        };
        let mut moved = CAMERA;
        let ((), n, _) = counted(|| {
            for frame in 0..3 {
                let previous = moved;
                moved.position[0] = 0.1 * frame as f32;
                // SAFETY: valid pointers.
                unsafe {
                    expect(cmlt_scene_begin_frame(s), CMLT_OK, "begin_frame");
                    expect(cmlt_renderer_set_camera(r, &moved), CMLT_OK, "set_camera");
                    expect(cmlt_renderer_prepare(r), CMLT_OK, "prepare");
                    for w in 0..2 {
                        expect(
                            cmlt_renderer_render(r, w, 16 * 12 * 2, null_mut()),
                            CMLT_OK,
                            "render",
                        );
                    }
                    expect(
                        cmlt_renderer_resolve(
                            r,
                            CMLT_FORMAT_RGB32F,
                            px.as_mut_ptr().cast(),
                            0,
                            px.len() * 4,
                        ),
                        CMLT_OK,
                        "resolve",
                    );
                    for (y0, y1) in [(0, 5), (5, 12)] {
                        let at = y0 as usize * 16 * 4;
                        expect(
                            cmlt_renderer_resolve_rows(
                                r,
                                CMLT_FORMAT_RGBA16F,
                                y0,
                                y1,
                                half[at..].as_mut_ptr().cast(),
                                0,
                                (half.len() - at) * 2,
                            ),
                            CMLT_OK,
                            "resolve_rows",
                        );
                    }
                    expect(
                        cmlt_renderer_aov_rows(r, &previous, 0, 12, &aov),
                        CMLT_OK,
                        "aov_rows",
                    );
                    let mut st = cmlt_stats::default();
                    expect(cmlt_renderer_get_stats(r, &mut st), CMLT_OK, "stats");
                }
            }
        });
        assert!(depth.iter().any(|d| d.is_finite() && *d > 0.0));
        assert_eq!(
            n, 0,
            "estimator {estimator}, level 1 {level1}: {n} allocations during frames"
        );
        assert!(px.iter().any(|&v| v > 0.0));
        // Mesh updates are part of the frame loop, and so are refused
        // calls: their messages are literals (`expect`, which copies the
        // message, runs after counting).
        let raised: Vec<f32> = POSITIONS
            .iter()
            .enumerate()
            .map(|(i, &v)| if i % 3 == 1 { v + 0.05 } else { v })
            .collect();
        let strided: Vec<f32> = raised
            .chunks(3)
            .flat_map(|p| [p[0], p[1], p[2], -7.0])
            .collect();
        let mut nan = raised.clone();
        nan[4] = f32::NAN;
        let mut statuses = [CMLT_OK; 7];
        let ((), n, _) = counted(|| {
            // SAFETY: valid pointers; arrays of 8 vertices at their strides.
            unsafe {
                statuses = [
                    cmlt_scene_update_mesh(s, 1, raised.as_ptr(), 8, 0, null(), 0),
                    cmlt_scene_update_mesh(s, 1, strided.as_ptr(), 8, 16, null(), 0),
                    cmlt_scene_update_mesh(s, 1, nan.as_ptr(), 8, 0, null(), 0),
                    cmlt_scene_update_mesh(s, 1, raised.as_ptr(), 7, 0, null(), 0),
                    cmlt_scene_update_mesh(s, 1, raised.as_ptr(), 8, 13, null(), 0),
                    cmlt_scene_update_mesh(s, 9, raised.as_ptr(), 8, 0, null(), 0),
                    cmlt_renderer_render(r, 0, 16, null_mut()),
                ];
            }
        });
        assert_eq!(
            n, 0,
            "estimator {estimator}: {n} allocations in mesh updates"
        );
        assert_eq!(&statuses[..2], &[CMLT_OK; 2]);
        assert_eq!(&statuses[2..6], &[CMLT_ERROR_INVALID_ARGUMENT; 4]);
        // A refused update leaves the scene as it was: the last good one
        // (the strided copy) still stands, and it started a new frame.
        expect(
            statuses[6],
            CMLT_ERROR_INVALID_OPERATION,
            "cmlt_renderer_render",
        );
        // SAFETY: valid pointers.
        unsafe {
            expect(
                cmlt_scene_update_mesh(s, 1, POSITIONS.as_ptr(), 8, 0, null(), 0),
                CMLT_OK,
                "update_mesh",
            );
        }
        // SAFETY: handle from this test.
        unsafe { cmlt_renderer_release(r) };
    }
    // SAFETY: handle from this test; NULL restores the system allocator.
    unsafe {
        cmlt_scene_release(s);
        expect(cmlt_set_allocator(null()), CMLT_OK, "set_allocator");
    }
}

thread_local! {
    /// The capacity of this thread's pool (`None`: not limited) and the
    /// bytes it has handed out.
    static CAPACITY: Cell<Option<usize>> = const { Cell::new(None) };
    static LIVE: Cell<usize> = const { Cell::new(0) };
}

/// A host pool of fixed capacity: refuses a block that would take more
/// than `CAPACITY` bytes out of it at once (no fragmentation).
unsafe extern "C" fn pool_alloc(_: *mut c_void, size: usize, align: usize) -> *mut c_void {
    if let Some(cap) = CAPACITY.with(Cell::get) {
        let live = LIVE.with(Cell::get);
        if live + size > cap {
            return null_mut();
        }
        LIVE.with(|l| l.set(live + size));
    }
    // SAFETY: valid layout (the library passes a power-of-two alignment).
    unsafe { std::alloc::System.alloc(std::alloc::Layout::from_size_align_unchecked(size, align)) }
        .cast()
}

unsafe extern "C" fn pool_free(_: *mut c_void, ptr: *mut c_void, size: usize, align: usize) {
    if CAPACITY.with(Cell::get).is_some() {
        LIVE.with(|l| l.set(l.get().saturating_sub(size)));
    }
    // SAFETY: `ptr` came from `pool_alloc` with this layout.
    unsafe {
        std::alloc::System.dealloc(
            ptr.cast(),
            std::alloc::Layout::from_size_align_unchecked(size, align),
        )
    }
}

/// A host pool of exactly the size `cmlt_renderer_memory_requirements`
/// gives is enough for `cmlt_renderer_new` (nothing asks the host for more
/// at once, not even the check of the renderer's upper bound), and one 10 %
/// smaller is refused cleanly with out-of-memory.
#[test]
fn a_pool_of_the_queried_size_is_enough_to_create_a_renderer() {
    let _hooks = HOOKS.lock().unwrap_or_else(|e| e.into_inner());
    let hooks = cmlt_allocator {
        user: null_mut(),
        alloc: Some(pool_alloc),
        free: Some(pool_free),
    };
    // SAFETY: valid allocator with process-lifetime callbacks.
    unsafe { expect(cmlt_set_allocator(&hooks), CMLT_OK, "set_allocator") };
    let s = scene(None);
    for estimator in [
        CMLT_ESTIMATOR_PT,
        CMLT_ESTIMATOR_BDPT,
        CMLT_ESTIMATOR_MLT,
        CMLT_ESTIMATOR_CMLT,
    ] {
        let c = config(estimator, 2);
        let mut bytes = 0usize;
        // SAFETY: valid pointers.
        unsafe {
            expect(
                cmlt_renderer_memory_requirements(s, &c, &mut bytes, null_mut()),
                CMLT_OK,
                "memory_requirements",
            )
        };
        for (capacity, want) in [(bytes, CMLT_OK), (bytes / 10 * 9, CMLT_ERROR_OUT_OF_MEMORY)] {
            CAPACITY.with(|cap| cap.set(Some(capacity)));
            LIVE.with(|l| l.set(0));
            let mut r = null_mut();
            // SAFETY: valid pointers.
            let status = unsafe { cmlt_renderer_new(s, &c, &CAMERA, &mut r) };
            CAPACITY.with(|cap| cap.set(None));
            assert_eq!(
                status,
                want,
                "estimator {estimator}: a pool of {capacity} B (query {bytes} B): {}",
                last_error()
            );
            assert_eq!(r.is_null(), want != CMLT_OK);
            // SAFETY: NULL or a renderer from this test.
            unsafe { cmlt_renderer_release(r) };
        }
    }
    // SAFETY: handle from this test; NULL restores the system allocator.
    unsafe {
        cmlt_scene_release(s);
        expect(cmlt_set_allocator(null()), CMLT_OK, "set_allocator");
    }
}

//! Errors: status names, the error callback, and an object left dead
//! (not busy) by a panic under its lock.

use super::*;

#[test]
fn status_names_and_error_callback() {
    thread_local! {
        static SEEN: Cell<u32> = const { Cell::new(u32::MAX) };
    }
    unsafe extern "C" fn on_error(
        _user: *mut c_void,
        status: cmlt_status,
        message: *const std::ffi::c_char,
    ) {
        // SAFETY: the library passes a NUL-terminated message.
        assert!(!unsafe { CStr::from_ptr(message) }.to_bytes().is_empty());
        SEEN.with(|s| s.set(status as u32));
    }
    // SAFETY: valid pointers.
    unsafe {
        // SAFETY: NUL-terminated static strings.
        assert_eq!(
            CStr::from_ptr(cmlt_status_name(2)).to_str().unwrap(),
            "CMLT_ERROR_INVALID_ARGUMENT"
        );
        assert_eq!(
            CStr::from_ptr(cmlt_status_name(12345)).to_str().unwrap(),
            "unknown status"
        );
        expect(
            cmlt_set_error_callback(Some(on_error), null_mut()),
            CMLT_OK,
            "set_error_callback",
        );
        let _ = cmlt_scene_new(null_mut());
        assert_eq!(SEEN.with(Cell::get), CMLT_ERROR_NULL_POINTER as u32);
        expect(
            cmlt_set_error_callback(None, null_mut()),
            CMLT_OK,
            "set_error_callback",
        );
    }
}

/// A panic inside a call that holds an object's lock (the test hook
/// stands in for a bug) poisons that lock: the call reports
/// `CMLT_ERROR_INTERNAL`, and so does every later call that needs the
/// object — it is dead, never `CMLT_ERROR_BUSY` forever — while other
/// objects and the renderer's other workers go on, and release works.
#[test]
fn a_panic_under_a_lock_leaves_the_object_dead_not_busy() {
    let dead = |status: cmlt_status, function: &str| {
        expect(status, CMLT_ERROR_INTERNAL, function);
        assert!(last_error().contains("unusable"), "{}", last_error());
    };
    let s = floor_and_light();
    let other = floor_and_light();
    let mut id = 0;
    // SAFETY: valid pointers; handles from this test.
    unsafe {
        cmlt_capi::test_hooks::panic_once();
        expect(
            cmlt_scene_add_material(s, &WHITE, &mut id),
            CMLT_ERROR_INTERNAL,
            "cmlt_scene_add_material",
        );
        assert!(last_error().contains("test hook"), "{}", last_error());
        for _ in 0..2 {
            dead(
                cmlt_scene_add_material(s, &WHITE, &mut id),
                "cmlt_scene_add_material",
            );
            dead(cmlt_scene_commit(s), "cmlt_scene_commit");
        }
        expect(
            cmlt_scene_add_material(other, &WHITE, &mut id),
            CMLT_OK,
            "add_material",
        );
        cmlt_scene_release(s);
        cmlt_scene_release(other);
    }
    let s = scene(None);
    let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 2));
    let mut px = vec![0.0f32; 16 * 12 * 3];
    let mut stats = cmlt_stats::default();
    // SAFETY: valid pointers; handles from this test.
    unsafe {
        expect(cmlt_renderer_prepare(r), CMLT_OK, "prepare");
        cmlt_capi::test_hooks::panic_once();
        expect(
            cmlt_renderer_render(r, 0, 16 * 12, null_mut()),
            CMLT_ERROR_INTERNAL,
            "cmlt_renderer_render",
        );
        for _ in 0..2 {
            dead(
                cmlt_renderer_render(r, 0, 16 * 12, null_mut()),
                "cmlt_renderer_render",
            );
            dead(
                cmlt_renderer_resolve(
                    r,
                    CMLT_FORMAT_RGB32F,
                    px.as_mut_ptr().cast(),
                    0,
                    px.len() * 4,
                ),
                "cmlt_renderer_resolve",
            );
            dead(
                cmlt_renderer_get_stats(r, &mut stats),
                "cmlt_renderer_get_stats",
            );
        }
        // The other worker was not touched by the bug.
        expect(
            cmlt_renderer_render(r, 1, 16 * 12, null_mut()),
            CMLT_OK,
            "render",
        );
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
}

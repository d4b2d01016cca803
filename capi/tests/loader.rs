//! Scene files and built-in scenes (`cmlt_scene_load_file`,
//! `cmlt_scene_new_builtin`). With the `loader` feature they load, and
//! refuse bad input with the documented status; without it they refuse a
//! good call as unsupported, naming the feature, and write nothing. An
//! integration test, so that CI runs the loader's side alone (`--test
//! loader`) next to the other packages' builds (see `.ci/run`).

use std::ptr::null_mut;

use cmlt_capi::error::cmlt_status::*;
use cmlt_capi::scene::*;

mod common;
use common::*;

/// The camera the out pointers start with: a refused call leaves it.
const UNTOUCHED: cmlt_camera = cmlt_camera {
    position: [1.0, 2.0, 3.0],
    target: [0.0; 3],
    up: [0.0, 1.0, 0.0],
    fov_degrees: 33.0,
    aperture_radius: 0.0,
    focus_distance: 1.0,
};

/// The Cornell box file the built-in scene is made from.
#[cfg(feature = "loader")]
fn cornell_box_file() -> std::ffi::CString {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../mitsuba/scenes/cornell-box.xml"
    );
    std::ffi::CString::new(path).unwrap()
}

/// A scene file and the built-in scene load, committed, with their
/// sensor; a missing file is an I/O error, a NULL path a NULL pointer, an
/// unknown name or a zero size an invalid argument, and no failed call
/// writes its out pointers.
#[cfg(feature = "loader")]
#[test]
fn files_and_builtins_load_and_bad_input_is_refused() {
    let path = cornell_box_file();
    let mut camera = UNTOUCHED;
    let (mut width, mut height) = (0, 0);
    // SAFETY: every pointer is valid or deliberately NULL; handles from
    // this test.
    unsafe {
        let (mut file, mut builtin) = (null_mut(), null_mut());
        expect(
            cmlt_scene_load_file(
                path.as_ptr(),
                &mut file,
                &mut camera,
                &mut width,
                &mut height,
            ),
            CMLT_OK,
            "cmlt_scene_load_file",
        );
        // The file's `<default>` resolution, and its sensor's field of view.
        assert_eq!((width, height), (256, 256));
        assert!(camera.fov_degrees != UNTOUCHED.fov_degrees);
        let mut camera = UNTOUCHED;
        expect(
            cmlt_scene_new_builtin(c"cornell-box".as_ptr(), 8, 6, &mut builtin, &mut camera),
            CMLT_OK,
            "cmlt_scene_new_builtin",
        );
        assert!(camera.fov_degrees != UNTOUCHED.fov_degrees);
        let (mut a, mut b) = (0, 0);
        expect(cmlt_scene_triangle_count(file, &mut a), CMLT_OK, "count");
        expect(cmlt_scene_triangle_count(builtin, &mut b), CMLT_OK, "count");
        assert!(a > 0 && a == b, "{a} and {b} triangles");
        cmlt_scene_release(file);
        cmlt_scene_release(builtin);

        let mut l = null_mut();
        let mut camera = UNTOUCHED;
        expect(
            cmlt_scene_load_file(
                c"/no/such/scene.xml".as_ptr(),
                &mut l,
                &mut camera,
                &mut width,
                &mut height,
            ),
            CMLT_ERROR_IO,
            "cmlt_scene_load_file",
        );
        expect(
            cmlt_scene_load_file(std::ptr::null(), &mut l, null_mut(), null_mut(), null_mut()),
            CMLT_ERROR_NULL_POINTER,
            "cmlt_scene_load_file",
        );
        expect(
            cmlt_scene_new_builtin(c"no-such-scene".as_ptr(), 8, 8, &mut l, &mut camera),
            CMLT_ERROR_INVALID_ARGUMENT,
            "cmlt_scene_new_builtin",
        );
        expect(
            cmlt_scene_new_builtin(c"cornell-box".as_ptr(), 0, 8, &mut l, &mut camera),
            CMLT_ERROR_INVALID_ARGUMENT,
            "cmlt_scene_new_builtin",
        );
        assert!(l.is_null(), "a failed call wrote its out pointer");
        assert_eq!(camera.fov_degrees, UNTOUCHED.fov_degrees);
    }
}

/// Without the `loader` feature both functions exist and refuse a good
/// call as unsupported, naming the feature, and write nothing.
#[cfg(not(feature = "loader"))]
#[test]
fn without_the_loader_files_and_builtins_are_unsupported() {
    let mut l = null_mut();
    let mut camera = UNTOUCHED;
    let (mut width, mut height) = (7, 9);
    // SAFETY: valid pointers.
    unsafe {
        expect(
            cmlt_scene_load_file(
                c"scene.xml".as_ptr(),
                &mut l,
                &mut camera,
                &mut width,
                &mut height,
            ),
            CMLT_ERROR_UNSUPPORTED,
            "cmlt_scene_load_file",
        );
        assert!(last_error().contains("`loader`"), "{}", last_error());
        expect(
            cmlt_scene_new_builtin(c"cornell-box".as_ptr(), 8, 8, &mut l, &mut camera),
            CMLT_ERROR_UNSUPPORTED,
            "cmlt_scene_new_builtin",
        );
        assert!(last_error().contains("`loader`"), "{}", last_error());
    }
    assert!(l.is_null(), "a refused call wrote its out pointer");
    assert_eq!((width, height), (7, 9));
    assert_eq!(
        (camera.position, camera.fov_degrees),
        (UNTOUCHED.position, UNTOUCHED.fov_degrees)
    );
}

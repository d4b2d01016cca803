//! `cmlt_renderer_resolve_rows` and `cmlt_renderer_aov_rows`: bands of
//! rows (also from two threads at once) give the bytes of one call, every
//! misuse is refused with its status and writes nothing, and
//! `cmlt_scene_begin_frame` frames the motion of a moved mesh.

use super::*;

const PIXELS: usize = 16 * 12;

/// A floor-and-light renderer (BDPT, two workers) with both workers
/// rendered.
fn rendered(s: *const cmlt_scene) -> *mut cmlt_renderer {
    let r = renderer(s, &config(CMLT_ESTIMATOR_BDPT, 2));
    // SAFETY: a valid renderer.
    unsafe {
        expect(cmlt_renderer_prepare(r), CMLT_OK, "prepare");
        for w in 0..2 {
            expect(
                cmlt_renderer_render(r, w, PIXELS as u64 * 2, null_mut()),
                CMLT_OK,
                "render",
            );
        }
    }
    r
}

/// Rows `y0..y1` of `format` (`px` bytes a pixel), packed.
fn rows(r: *const cmlt_renderer, format: u32, px: usize, y0: u32, y1: u32) -> Vec<u8> {
    // u32 storage: aligned for every format.
    let n = (y1 - y0) as usize * 16 * px;
    let mut buf = vec![0u32; n.div_ceil(4)];
    // SAFETY: the buffer holds `n` bytes.
    unsafe {
        expect(
            cmlt_renderer_resolve_rows(r, format, y0, y1, buf.as_mut_ptr().cast(), 0, n),
            CMLT_OK,
            "resolve_rows",
        );
    }
    buf.iter().flat_map(|v| v.to_ne_bytes()).take(n).collect()
}

#[test]
fn resolve_rows_in_bands_and_threads_gives_one_calls_bytes() {
    let s = scene(None);
    let r = rendered(s);
    for (format, px) in [
        (CMLT_FORMAT_RGB32F, 12),
        (CMLT_FORMAT_RGBA8_SRGB, 4),
        (CMLT_FORMAT_RGBA32F, 16),
        (CMLT_FORMAT_RGBA16F, 8),
    ] {
        let whole = rows(r, format, px, 0, 12);
        assert!(whole.iter().any(|&b| b != 0));
        let mut bands = Vec::new();
        for (y0, y1) in [(0, 1), (1, 7), (7, 7), (7, 12)] {
            bands.extend(rows(r, format, px, y0, y1));
        }
        assert_eq!(bands, whole, "format {format}");
        // `cmlt_renderer_resolve` is the same call over every row.
        let mut all = vec![0u32; PIXELS * px / 4];
        // SAFETY: the buffer holds what we say.
        unsafe {
            expect(
                cmlt_renderer_resolve(r, format, all.as_mut_ptr().cast(), 0, PIXELS * px),
                CMLT_OK,
                "resolve",
            );
        }
        let all: Vec<u8> = all.iter().flat_map(|v| v.to_ne_bytes()).collect();
        assert_eq!(all, whole);
        // Two host threads, one band each, at the same time (a resolving
        // thread holds every worker for reading only).
        let handle = r as usize;
        let (top, bottom) = std::thread::scope(|sc| {
            let a = sc.spawn(move || rows(handle as *const _, format, px, 0, 6));
            let b = sc.spawn(move || rows(handle as *const _, format, px, 6, 12));
            (a.join().unwrap(), b.join().unwrap())
        });
        assert_eq!([top, bottom].concat(), whole);
    }
    // SAFETY: handles from this test.
    unsafe {
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
}

#[test]
fn bad_resolve_rows_calls_are_refused_and_write_nothing() {
    let s = scene(None);
    let r = rendered(s);
    let f = "cmlt_renderer_resolve_rows";
    let mut buf = vec![7u32; PIXELS * 4];
    let p = buf.as_mut_ptr().cast::<u8>();
    let n = buf.len() * 4;
    // SAFETY: `p` holds `n` bytes; every call below says at most that.
    unsafe {
        let cases = [
            (
                cmlt_renderer_resolve_rows(null(), CMLT_FORMAT_RGB32F, 0, 12, p, 0, n),
                CMLT_ERROR_NULL_POINTER,
            ),
            (
                cmlt_renderer_resolve_rows(r, CMLT_FORMAT_RGB32F, 0, 12, null_mut(), 0, n),
                CMLT_ERROR_NULL_POINTER,
            ),
            (
                cmlt_renderer_resolve_rows(r, 9, 0, 12, p, 0, n),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_renderer_resolve_rows(r, CMLT_FORMAT_RGB32F, 0, 13, p, 0, n),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_renderer_resolve_rows(r, CMLT_FORMAT_RGB32F, 6, 5, p, 0, n),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_renderer_resolve_rows(r, CMLT_FORMAT_RGBA32F, 0, 12, p, 0, PIXELS * 16 - 1),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_renderer_resolve_rows(r, CMLT_FORMAT_RGBA16F, 0, 2, p.add(1), 0, n - 1),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_renderer_resolve_rows(r, CMLT_FORMAT_RGBA16F, 0, 2, p, 129, n),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_renderer_resolve_rows(r, CMLT_FORMAT_RGBA8_SRGB, 0, 2, p, 63, n),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_renderer_resolve_rows(r, CMLT_FORMAT_RGBA8_SRGB, 0, 12, p, usize::MAX, n),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
        ];
        for (i, (status, want)) in cases.into_iter().enumerate() {
            assert_eq!(status, want, "case {i}");
        }
        // The last one's message names the function.
        expect(
            cmlt_renderer_resolve_rows(r, CMLT_FORMAT_RGBA8_SRGB, 0, 12, p, 63, n),
            CMLT_ERROR_INVALID_ARGUMENT,
            f,
        );
    }
    assert!(buf.iter().all(|&v| v == 7), "a refused call wrote");
    // SAFETY: handles from this test.
    unsafe {
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
}

/// Depth (f32) and motion (f32) of rows `y0..y1` through `previous`.
fn depth_motion(
    r: *const cmlt_renderer,
    previous: Option<&cmlt_camera>,
    y0: u32,
    y1: u32,
) -> (Vec<f32>, Vec<f32>) {
    let n = (y1 - y0) as usize * 16;
    let (mut depth, mut motion) = (vec![0.0f32; n], vec![0.0f32; 2 * n]);
    let none = cmlt_aov_layer {
        data: null_mut(),
        row_stride: 0,
        buffer_size: 0,
        format: CMLT_AOV_F32,
    };
    let out = cmlt_aov_buffers {
        albedo: none,
        normal: none,
        depth: cmlt_aov_layer {
            data: depth.as_mut_ptr().cast(),
            buffer_size: n * 4,
            ..none
        },
        motion: cmlt_aov_layer {
            data: motion.as_mut_ptr().cast(),
            buffer_size: n * 8,
            ..none
        },
    };
    let previous = previous.map_or(null(), |p| p as *const _);
    // SAFETY: the layers hold what they say.
    unsafe {
        expect(
            cmlt_renderer_aov_rows(r, previous, y0, y1, &out),
            CMLT_OK,
            "aov_rows",
        )
    };
    (depth, motion)
}

#[test]
fn aov_rows_split_and_frame_a_moved_mesh() {
    let s = scene(None);
    let r = rendered(s);
    let (depth, motion) = depth_motion(r, None, 0, 12);
    // Pixel (8, 8) sees the floor (16° below the axis, 1.8 away); the
    // top corner sees nothing.
    let floor = 8 * 16 + 8;
    assert!(depth[floor].is_finite() && depth[floor] > 1.0);
    assert_eq!(depth[0], f32::INFINITY);
    assert!(motion.iter().all(|m| m.abs() < 1e-3), "a still camera");
    let (d0, m0) = depth_motion(r, None, 0, 5);
    let (d1, m1) = depth_motion(r, None, 5, 12);
    assert_eq!([d0, d1].concat(), depth);
    assert_eq!([m0, m1].concat(), motion);
    // The floor (mesh 0) slides along +x after a new frame: floor pixels
    // move, sky pixels do not, and the next frame without an update has
    // no motion.
    let slid: Vec<f32> = POSITIONS
        .iter()
        .enumerate()
        .map(|(i, &v)| if i % 3 == 0 && i < 12 { v + 0.25 } else { v })
        .collect();
    // SAFETY: a valid scene; 8 packed vertices.
    unsafe {
        expect(cmlt_scene_begin_frame(s), CMLT_OK, "begin_frame");
        expect(
            cmlt_scene_update_mesh(s, 0, slid.as_ptr(), 8, 0, null(), 0),
            CMLT_OK,
            "update_mesh",
        );
    }
    let (_, moved) = depth_motion(r, None, 0, 12);
    // 0.25 along +x (image-left) at 1.8: it was about 2 pixels right.
    assert!(
        moved[2 * floor] > 1.0,
        "the floor moved: {}",
        moved[2 * floor]
    );
    assert!(moved[..2].iter().all(|m| m.abs() < 1e-3), "the sky did not");
    // SAFETY: a valid scene.
    unsafe { expect(cmlt_scene_begin_frame(s), CMLT_OK, "begin_frame") };
    let (_, still) = depth_motion(r, None, 0, 12);
    assert!(still.iter().all(|m| m.abs() < 1e-3));
    // A camera that moved gives motion everywhere it sees the floor.
    let before = cmlt_camera {
        position: [0.3, 0.5, -2.0],
        ..CAMERA
    };
    let (_, panned) = depth_motion(r, Some(&before), 0, 12);
    assert!(panned[2 * floor].abs() > 0.1);
    // SAFETY: handles from this test.
    unsafe {
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
}

#[test]
fn bad_aov_calls_are_refused_and_write_nothing() {
    let s = scene(None);
    let r = rendered(s);
    let f = "cmlt_renderer_aov_rows";
    let mut depth = vec![7.0f32; PIXELS + 1];
    let good = cmlt_aov_layer {
        data: depth.as_mut_ptr().cast(),
        row_stride: 0,
        buffer_size: PIXELS * 4,
        format: CMLT_AOV_F32,
    };
    let none = cmlt_aov_layer {
        data: null_mut(),
        ..good
    };
    let with_depth = |depth| cmlt_aov_buffers {
        albedo: none,
        normal: none,
        depth,
        motion: none,
    };
    let bad_camera = cmlt_camera {
        fov_degrees: 0.0,
        ..CAMERA
    };
    // SAFETY: every layer holds what it says.
    unsafe {
        let misaligned = cmlt_aov_layer {
            data: depth.as_mut_ptr().cast::<u8>().add(1).cast(),
            ..good
        };
        let cases = [
            (
                cmlt_renderer_aov_rows(null(), null(), 0, 12, &with_depth(good)),
                CMLT_ERROR_NULL_POINTER,
            ),
            (
                cmlt_renderer_aov_rows(r, null(), 0, 12, null()),
                CMLT_ERROR_NULL_POINTER,
            ),
            (
                cmlt_renderer_aov_rows(r, null(), 0, 13, &with_depth(good)),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_renderer_aov_rows(
                    r,
                    null(),
                    0,
                    12,
                    &with_depth(cmlt_aov_layer {
                        buffer_size: PIXELS * 4 - 1,
                        ..good
                    }),
                ),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_renderer_aov_rows(
                    r,
                    null(),
                    0,
                    12,
                    &with_depth(cmlt_aov_layer { format: 2, ..good }),
                ),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_renderer_aov_rows(r, null(), 0, 1, &with_depth(misaligned)),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_renderer_aov_rows(
                    r,
                    null(),
                    0,
                    1,
                    &with_depth(cmlt_aov_layer {
                        row_stride: 66,
                        ..good
                    }),
                ),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
            (
                cmlt_renderer_aov_rows(r, &bad_camera, 0, 12, &with_depth(good)),
                CMLT_ERROR_INVALID_ARGUMENT,
            ),
        ];
        for (i, (status, want)) in cases.into_iter().enumerate() {
            assert_eq!(status, want, "case {i}");
        }
        expect(
            cmlt_renderer_aov_rows(r, null(), 3, 2, &with_depth(good)),
            CMLT_ERROR_INVALID_ARGUMENT,
            f,
        );
        expect(
            cmlt_scene_begin_frame(null_mut()),
            CMLT_ERROR_NULL_POINTER,
            "cmlt_scene_begin_frame",
        );
    }
    assert!(depth.iter().all(|&v| v == 7.0), "a refused call wrote");
    // An uncommitted scene has no frames.
    let u = floor_and_light();
    // SAFETY: handles from this test.
    unsafe {
        assert_ne!(cmlt_scene_begin_frame(u), CMLT_OK);
        cmlt_scene_release(u);
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
}

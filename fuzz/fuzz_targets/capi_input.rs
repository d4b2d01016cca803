//! The C API's input validation on arbitrary bytes: a material, a mesh
//! (vertex, normal, uv and index arrays with arbitrary strides inside one
//! buffer), a camera and a renderer configuration, all made of fuzz bytes,
//! then commit, create, prepare, render one pass and resolve with an
//! arbitrary row stride. Every call must return a status; a caught panic
//! (`CMLT_ERROR_INTERNAL`) is a bug. Sizes that would only make the run
//! slow (image size, chains, bootstrap samples, m) are reduced modulo a small
//! bound; everything else — NaN, Inf, strides, indices, k, depth — is raw.
#![no_main]

use std::ptr::{null, null_mut};

use cmlt_capi::error::cmlt_status;
use cmlt_capi::renderer::*;
use cmlt_capi::scene::*;
use libfuzzer_sys::arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;

fn ok(st: cmlt_status) -> bool {
    assert_ne!(
        st,
        cmlt_status::CMLT_ERROR_INTERNAL,
        "a panic crossed into a status: {:?}",
        unsafe { std::ffi::CStr::from_ptr(cmlt_capi::error::cmlt_last_error()) }
    );
    st == cmlt_status::CMLT_OK
}

fn f3(u: &mut Unstructured) -> Result<[f32; 3]> {
    Ok([u.arbitrary()?, u.arbitrary()?, u.arbitrary()?])
}

fn run(u: &mut Unstructured) -> Result<()> {
    // One 4-byte aligned buffer holds every array; the mesh reads stay
    // inside it (counts and strides are chosen to fit, then checked by
    // the library as a host's would be).
    let words: Vec<u32> = (0..u.int_in_range(0..=256)?)
        .map(|_| u.arbitrary())
        .collect::<Result<_>>()?;
    let material = cmlt_material {
        type_: u.int_in_range(0..=9)?,
        color: f3(u)?,
        ior: u.arbitrary()?,
        roughness: u.arbitrary()?,
        two_sided: u.arbitrary()?,
        color_texture: CMLT_NO_TEXTURE,
        normal_map: CMLT_NO_TEXTURE,
        bump_map: CMLT_NO_TEXTURE,
        bump_scale: 1.0,
        opacity_texture: CMLT_NO_TEXTURE,
        specular_color: f3(u)?,
        transmission_color: f3(u)?,
        distribution: u.int_in_range(0..=2)?,
        nonlinear: u.arbitrary()?,
        metallic: u.arbitrary()?,
        anisotropic: u.arbitrary()?,
        specular: u.arbitrary()?,
        spec_tint: u.arbitrary()?,
        spec_trans: u.arbitrary()?,
        sheen: u.arbitrary()?,
        sheen_tint: u.arbitrary()?,
        clearcoat: u.arbitrary()?,
        clearcoat_gloss: u.arbitrary()?,
        flatness: u.arbitrary()?,
        principled_textures: [CMLT_NO_TEXTURE; 10],
    };
    // An array of `count` elements of `size` words at `stride` bytes from
    // word `at`, or NULL / empty.
    let mut array = |size: usize| -> Result<(*const u32, usize, usize)> {
        let stride_words = u.int_in_range(0..=6)?;
        let stride = 4 * stride_words + if u.ratio(1, 16)? { 1 } else { 0 };
        let at = u.int_in_range(0..=words.len())?;
        let room = words.len() - at;
        let per = stride_words.max(size).max(1);
        let count = if room < size { 0 } else { 1 + (room - size) / per };
        let count = u.int_in_range(0..=count)?;
        let ptr = if u.ratio(1, 32)? {
            null()
        } else {
            words[at..].as_ptr()
        };
        Ok((ptr, count, stride))
    };
    let (positions, vertex_count, position_stride) = array(3)?;
    let (normals, n_count, normal_stride) = array(3)?;
    let (uvs, uv_count, uv_stride) = array(2)?;
    let (indices, triangle_count, index_stride) = array(3)?;
    let vertex_count = vertex_count.min(n_count.max(if u.arbitrary()? { 0 } else { vertex_count }));
    let mesh = cmlt_mesh {
        positions: positions.cast(),
        vertex_count,
        position_stride,
        normals: if n_count >= vertex_count { normals.cast() } else { null() },
        normal_stride,
        uvs: if uv_count >= vertex_count { uvs.cast() } else { null() },
        uv_stride,
        indices,
        triangle_count,
        index_stride,
        material: u.int_in_range(0..=1)?,
        emission: f3(u)?,
    };
    let camera = cmlt_camera {
        position: f3(u)?,
        target: f3(u)?,
        up: f3(u)?,
        fov_degrees: u.arbitrary()?,
        aperture_radius: u.arbitrary()?,
        focus_distance: u.arbitrary()?,
    };
    let mut config = std::mem::MaybeUninit::uninit();
    let estimator = u.int_in_range(0..=4)?;
    // SAFETY: valid pointers throughout; the mesh arrays lie in `words`.
    unsafe {
        if !ok(cmlt_renderer_config_default(estimator, config.as_mut_ptr())) {
            return Ok(());
        }
        let mut c = config.assume_init();
        c.width = u.int_in_range(0..=24)?;
        c.height = u.int_in_range(0..=24)?;
        c.workers = u.int_in_range(0..=2)?;
        c.max_depth = u.int_in_range(0..=1100)?;
        c.seed = u.arbitrary()?;
        let mut d = c;
        d.chains = u.int_in_range(0..=16)?;
        d.bootstrap_samples = u.int_in_range(0..=64)?;
        d.normalisation_passes = u.int_in_range(0..=2)?;
        d.large_step_probability = u.arbitrary()?;
        d.small_step_sigma = u.arbitrary()?;
        d.k = u.arbitrary()?;
        d.m = u.int_in_range(0..=4)?;
        d.lens_sigma = u.arbitrary()?;
        d.stratified = u.arbitrary()?;
        // A field the estimator does not read must keep its default (or
        // the config is refused): set those it reads, and the others only
        // when the input says so (the refusal).
        let misuse: bool = u.arbitrary().unwrap_or(false);
        if misuse || estimator >= CMLT_ESTIMATOR_MLT {
            (c.chains, c.bootstrap_samples, c.normalisation_passes) =
                (d.chains, d.bootstrap_samples, d.normalisation_passes);
            (c.large_step_probability, c.small_step_sigma) =
                (d.large_step_probability, d.small_step_sigma);
        }
        if misuse || estimator == CMLT_ESTIMATOR_CMLT {
            (c.k, c.m, c.lens_sigma, c.stratified) = (d.k, d.m, d.lens_sigma, d.stratified);
        }

        let mut s = null_mut();
        assert!(ok(cmlt_scene_new(&mut s)));
        let mut id = 0;
        ok(cmlt_scene_add_material(s, &material, &mut id));
        let mut first = 0;
        ok(cmlt_scene_add_mesh(s, &mesh, &mut first));
        if ok(cmlt_scene_commit(s)) {
            let mut r = null_mut();
            if ok(cmlt_renderer_new(s, &c, &camera, &mut r)) {
                ok(cmlt_renderer_prepare(r));
                for w in 0..c.workers + 1 {
                    ok(cmlt_renderer_render(r, w, 1, null_mut()));
                }
                let mut pixels = vec![0u32; 24 * 24 * 3 * 2];
                let row_stride: usize = u.arbitrary()?;
                let size: usize = u.int_in_range(0..=pixels.len() * 4)?;
                ok(cmlt_renderer_resolve(
                    r,
                    u.int_in_range(0..=2)?,
                    pixels.as_mut_ptr().cast(),
                    row_stride,
                    size,
                ));
                let mut stats = cmlt_stats::default();
                ok(cmlt_renderer_get_stats(r, &mut stats));
                assert_eq!(stats.nonfinite, 0, "non-finite samples: {stats:?}");
                ok(cmlt_renderer_set_camera(r, &camera));
                cmlt_renderer_release(r);
            }
        }
        cmlt_scene_release(s);
    }
    Ok(())
}

fuzz_target!(|data: &[u8]| {
    let _ = run(&mut Unstructured::new(data));
});

//! Helpers shared by the front end's integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

use cmlt::accel::bvh::Bvh;
use cmlt::mlt::MltSettings;
use cmlt::renderer::{Estimator, RendererConfig};
use cmlt_cli::accel::Accel;
use cmlt_cli::image_io::{Image, read_exr};
use cmlt_cli::mitsuba::{LoadedScene, load_scene};
use cmlt_cli::render::{Budget, RenderOutput, render};

/// The test scenes: `$CMLT_SCENES_DIR` if set, else the copies of the
/// shared scenes committed under `tests/scenes` (CC0, with their Mitsuba 3
/// references), so a fresh clone needs nothing else.
pub fn scenes_dir() -> PathBuf {
    let dir = std::env::var_os("CMLT_SCENES_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/scenes")));
    assert!(
        dir.is_dir(),
        "shared scenes not found at {} (set CMLT_SCENES_DIR)",
        dir.display()
    );
    dir
}

/// Loads shared scene `name` at 1/`factor` of its reference resolution.
pub fn load_reduced(name: &str, factor: u32) -> (LoadedScene, Image) {
    let dir = scenes_dir().join(name);
    let reference = read_exr(&dir.join("reference.exr")).expect("reference readable");
    let defines = vec![
        (
            "resx".to_string(),
            (reference.width as u32 / factor).to_string(),
        ),
        (
            "resy".to_string(),
            (reference.height as u32 / factor).to_string(),
        ),
    ];
    let loaded = load_scene(&dir.join("scene.xml"), &defines).expect("scene loads");
    (loaded, reference.downsample(factor as usize))
}

/// Renders `loaded` over our BVH with `config` (the scene's settings
/// replace the config's) at `per_pixel` samples or mutations per pixel.
pub fn render_loaded(loaded: &LoadedScene, config: RendererConfig, per_pixel: u64) -> RenderOutput {
    let tris: Vec<_> = loaded.scene.triangles().collect();
    let accel = Accel::Ours(Bvh::build(&tris));
    let config = RendererConfig {
        settings: loaded.settings,
        ..config
    };
    render(
        &loaded.scene,
        &accel,
        config,
        Budget::PerPixel(per_pixel),
        &|_| {},
    )
    .expect("render")
}

/// The pixel-wise average of equally sized renders. For independent
/// renders of an unbiased estimator it is a render with their samples
/// pooled: four at N samples per pixel stand for one at 4N.
pub fn average(renders: &[Image]) -> Image {
    let first = &renders[0];
    let mut pixels = vec![cmlt::math::Rgb::ZERO; first.pixels.len()];
    for img in renders {
        assert_eq!((img.width, img.height), (first.width, first.height));
        for (sum, p) in pixels.iter_mut().zip(&img.pixels) {
            *sum += *p;
        }
    }
    let n = renders.len() as f32;
    for p in &mut pixels {
        *p /= n;
    }
    Image {
        width: first.width,
        height: first.height,
        pixels,
    }
}

/// Renders a loaded scene with the default BVH on two threads.
pub fn render_scene(
    loaded: &LoadedScene,
    method: Estimator,
    spp: u64,
    seed: u64,
) -> (Image, RenderOutput) {
    let config = RendererConfig {
        estimator: method,
        seed,
        workers: 2,
        ..RendererConfig::default()
    };
    let out = render_loaded(loaded, config, spp);
    let img = out.image.clone();
    (img, out)
}

/// Level 1 as the MLT, CMLT, parts and frames tests run it: 1 000
/// bootstrap samples per depth, 8 normalisation passes and `chains`
/// chains per thread; the passes only estimate b (no pass image). The
/// passes are most of a test render's time (at 1/4 of the Cornell box's
/// resolution, 16 passes took 0.77 s of CPU against 0.19 s for 32
/// mutations per pixel). With 8 every MLT/CMLT check still passes with
/// its margin (the mean checks also widen to 3 standard errors of the
/// renders' spread, b's noise included); veach-mis, whose b is
/// heavy-tailed, asks for 16.
pub fn level1(chains: u32) -> MltSettings {
    MltSettings {
        n_bootstrap: 1_000,
        b_passes: 8,
        b_min_samples: 0,
        n_chains: chains,
        // The chains alone: the tests' relMSE-per-mutation rates measure
        // them (the passes' image has its own test).
        pass_records: 0.0,
        ..MltSettings::default()
    }
}
